//! `pomc view PANO [--port N] [--open] | --export DIR`: the browser viewer, served on localhost or
//! written as a static site.

use std::path::PathBuf;

use pomc::viewer::SiteSettings;

use crate::args::Range;
use crate::output::Output;
use crate::Failure;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Panorama directory or panorama.xml.
    pano: PathBuf,
    /// Write the viewer as a static site into DIR (HTML, JavaScript, the scene, textures) instead of
    /// serving it; any static file server can serve DIR.
    #[arg(long, value_name = "DIR")]
    export: Option<PathBuf>,
    /// Port to serve on, on 127.0.0.1 (0 picks a free one).
    #[arg(long, default_value_t = 8080, conflicts_with = "export")]
    port: u16,
    /// Open the page in the default browser.
    #[arg(long, conflicts_with = "export")]
    open: bool,
    /// Radius of the sky dome (drawn as infinitely far whatever its radius).
    #[arg(long, value_name = "R", value_parser = Range::POSITIVE.parser())]
    sky_radius: Option<f64>,
}

pub fn run(a: Args, out: Output) -> Result<u8, Failure> {
    let pano = pomc::panorama::Panorama::open(&a.pano)?;
    // Listen before the meshing, so that a busy port is reported at once.
    let server = match a.export {
        Some(_) => None,
        None => Some(tiny_http::Server::http(("127.0.0.1", a.port)).map_err(|e| Failure {
            code: pomc::codes::VIEW_SERVE_FAILED,
            message: format!(
                "cannot listen on 127.0.0.1:{}: {e} (pick another --port, or 0 for any free one)",
                a.port
            ),
            exit: 2,
        })?),
    };
    let spinner = out.spinner("meshing the layers");
    let settings = SiteSettings { sky_radius: a.sky_radius, ..SiteSettings::default() };
    let (site, report) = pomc::jobs::view_site(&pano, &settings)?;
    spinner.finish_and_clear();
    let (report, server) = match (&a.export, server) {
        (Some(dir), _) => (report.exported(&site, dir)?, None),
        (None, server) => {
            let server = server.expect("bound above when there is no --export");
            let port = server.server_addr().to_ip().map(|a| a.port()).unwrap_or(a.port);
            (report.served(&format!("http://127.0.0.1:{port}/")), Some(server))
        }
    };
    out.json(&serde_json::to_value(&report).expect("report serialises"));
    out.say(report.summary());
    let (Some(server), Some(url)) = (server, report.url) else { return Ok(0) };
    if a.open {
        if let Err(e) = open::that_detached(&url) {
            eprintln!("note: could not open a browser ({e}); open {url} yourself");
        }
    }
    for request in server.incoming_requests() {
        let path = request.url().split(['?', '#']).next().unwrap_or("").trim_start_matches('/');
        let response = match (request.method(), site.get(path)) {
            (tiny_http::Method::Get | tiny_http::Method::Head, Some((bytes, mime))) => {
                let mime = tiny_http::Header::from_bytes("Content-Type", mime).expect("static header");
                tiny_http::Response::from_data(bytes.to_vec()).with_header(mime)
            }
            (_, Some(_)) => tiny_http::Response::from_string("method not allowed").with_status_code(405),
            (_, None) => tiny_http::Response::from_string("not found").with_status_code(404),
        };
        // A client that went away is its own business; keep serving the others.
        let _ = request.respond(response);
    }
    Ok(0)
}
