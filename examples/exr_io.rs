//! Times `pomc::layer_io` reading and writing EXR files (for `tools/bench/exr_vs_openexr.py`).
//!
//! ```text
//! cargo run --release --example exr_io -- read|write FILE...
//! ```
//! `read` decodes every file once; `write` decodes them, then times writing them again (ZIP, as
//! `pomc` writes layers) into a temporary directory. Prints the seconds taken on stdout.

use std::path::PathBuf;
use std::time::Instant;

use pomc::layer_io::{read_exr, write_exr, ReadLimits, WriteOptions};
use rayon::prelude::*;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (mode, files) = args.split_first().ok_or("usage: exr_io read|write FILE...")?;
    let files: Vec<PathBuf> = files.iter().map(PathBuf::from).collect();
    let limits = ReadLimits::default();
    // Files in parallel, as a panorama's layers are read and written.
    let read = || files.par_iter().map(|f| read_exr(f, &limits)).collect::<Result<Vec<_>, _>>();
    match mode.as_str() {
        "read" => {
            let t = Instant::now();
            read()?;
            println!("{}", t.elapsed().as_secs_f64());
        }
        "write" => {
            let images = read()?;
            let dir = std::env::temp_dir().join(format!("pomc-exr-io-{}", std::process::id()));
            std::fs::create_dir_all(&dir)?;
            let t = Instant::now();
            let written = images.par_iter().zip(&files).try_for_each(|(img, f)| {
                write_exr(&dir.join(f.file_name().unwrap_or_default()), img, &WriteOptions::default())
            });
            let secs = t.elapsed().as_secs_f64();
            std::fs::remove_dir_all(&dir)?;
            written?;
            println!("{secs}");
        }
        other => return Err(format!("unknown mode `{other}`: read or write").into()),
    }
    Ok(())
}
