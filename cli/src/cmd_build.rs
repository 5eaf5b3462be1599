//! `pomc build`: a layered POMC from a plain RGB-D panorama.

use std::path::PathBuf;

use pomc::jobs;
use pomc_flags::{BuildArgs, DepthArgs, LayeringArgs};

use crate::output::Output;
use crate::Failure;

/// The colour and depth inputs and how the depth is read and prepared (`build` and `prepare`).
#[derive(clap::Args, Debug)]
pub struct InputArgs {
    /// Colour panorama (PNG, JPEG, EXR, HDR), equirect 2:1 or 3×2 cube map.
    #[arg(long)]
    pub colour: PathBuf,
    /// Depth panorama: float EXR (channel Z, or any single channel), 16-bit PNG, or with a relative
    /// --depth-kind an 8/16-bit PNG or JPEG; any resolution (upsampled onto the colour's grid).
    #[arg(long)]
    pub depth: PathBuf,
    #[command(flatten)]
    pub options: DepthArgs,
}

#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    input: InputArgs,
    /// Output panorama directory.
    #[arg(short, long)]
    output: PathBuf,
    #[command(flatten)]
    layering: LayeringArgs,
    /// Also write the JSON report to this file.
    #[arg(long)]
    report: Option<PathBuf>,
}

/// Whether `--report FILE` can be written: not a directory, its directory creatable and writable.
fn check_report_path(p: &std::path::Path) -> Result<(), Failure> {
    let bad = |why: String| Failure::usage(format!("{}: cannot write the report there ({why})", p.display()));
    if p.is_dir() {
        return Err(bad("it is a directory".into()));
    }
    let dir = p.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(std::path::Path::new("."));
    std::fs::create_dir_all(dir).map_err(|e| bad(e.to_string()))?;
    let probe = dir.join(format!(".pomc-tmp-report-{}", std::process::id()));
    std::fs::OpenOptions::new().write(true).create_new(true).open(&probe).map_err(|e| bad(e.to_string()))?;
    let _ = std::fs::remove_file(&probe);
    Ok(())
}

pub fn run(args: Args, out: Output) -> Result<u8, Failure> {
    // The report is checked before any work: failing on it after the panorama is written would
    // report an error for a run that did its job.
    if let Some(p) = &args.report {
        check_report_path(p)?;
    }
    let settings =
        BuildArgs { depth: args.input.options.clone(), layering: args.layering.clone() }.settings();
    // Reading, then every stage the job names: a bar with an ETA.
    let bar = out.progress(jobs::build_stages(&settings).len() as u64, "reading");
    let progress = |stage: &str| {
        bar.set_message(stage.to_string());
        bar.inc(1);
    };
    let built = jobs::build_panorama_with_progress(
        &args.input.colour,
        &args.input.depth,
        &args.output,
        &settings,
        &progress,
    )?;
    bar.finish_and_clear();
    for w in &built.prepare.warnings {
        out.warn(w.code, &w.message);
    }

    let report = serde_json::to_value(&built).expect("report serialises");
    if let Some(p) = &args.report {
        pomc::jobs::write_report(p, &report)?;
    }
    out.json(&report);
    for l in &built.report.layers {
        let depth = match l.depth_range {
            Some((lo, hi)) => format!("depth {lo:.3}–{hi:.3} m"),
            None => "no finite depth".to_string(),
        };
        out.say(format!(
            "{:>14} {:>10} order {}: {} px seen, {} px filled, {depth}",
            l.name, l.role, l.order, l.own_pixels, l.filled_pixels
        ));
    }
    out.say(format!(
        "built {} layer(s) in {:.2} s (fill band up to {:.2}°, d_dirmin {:.0} m) -> {}",
        built.manifest.layers.len(),
        built.total_s,
        built.report.max_band_deg,
        built.report.d_dirmin,
        args.output.display()
    ));
    Ok(0)
}
