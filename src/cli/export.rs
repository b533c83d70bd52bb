//! `fslcal export`: a unit file back into the FishSense lab's `.pkg` archives.

use super::inspect;
use super::outputs::{self, Input, Output};
use crate::atomic_file::write_atomically;
use crate::units::lab_pkg::{LaserPkg, LensPkg};
use crate::units::signed_file::{self, UnitFileError};
use anyhow::Context;
use serde_json::json;
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(clap::ValueEnum, Clone, Copy, Debug)]
enum ExportFormat {
    /// The lab's lens and laser `.pkg` archives (gzip tar of metadata.json and .npy arrays).
    FishsensePkg,
}

/// Write a unit file's calibration in another tool's format.
///
/// `fishsense-pkg` writes UNIT-lens.pkg and UNIT-laser.pkg into --out, which NumPy reads with
/// the same numbers. A tampered file is refused.
#[derive(clap::Args, Debug)]
pub struct ExportArgs {
    /// The unit file (.fslcal).
    #[arg(value_name = "FILE")]
    file: PathBuf,

    #[arg(long, value_enum)]
    format: ExportFormat,

    /// Folder to write into (created if missing).
    #[arg(long, value_name = "DIR")]
    out: PathBuf,

    /// Print one JSON object instead of the summary.
    #[arg(long)]
    json: bool,
}

pub fn run(args: ExportArgs) -> anyhow::Result<ExitCode> {
    let ExportFormat::FishsensePkg = args.format;
    let bytes = signed_file::read_bytes(&args.file)?;
    let file = inspect::decode(&args.file, &bytes)?;
    file.check_signature().map_err(UnitFileError::at(&args.file))?;
    let c = &file.contents;
    // The unit names the output files: a crafted `../` must not write elsewhere.
    let unit = signed_file::unit_id(c.unit)?;
    let cam = &c.camera;
    let lens = LensPkg {
        camera_matrix: [cam.fx_px, 0.0, cam.cx_px, 0.0, cam.fy_px, cam.cy_px, 0.0, 0.0, 1.0],
        distortion: cam.distortion.to_opencv().to_vec(),
        calibrated_utc_s: c.made_utc_s,
    };
    let laser = LaserPkg { position_m: c.laser.origin_m, axis: c.laser.direction, calibrated_utc_s: c.made_utc_s };
    let paths = ["lens", "laser"].map(|kind| args.out.join(format!("{unit}-{kind}.pkg")));
    let outs = [Output::file("--out", &paths[0]), Output::file("--out", &paths[1])];
    outputs::check(&[Input::new("FILE", &args.file)], &outs, false)?;
    std::fs::create_dir_all(&args.out).with_context(|| format!("{}: cannot create the folder", args.out.display()))?;
    let mut written = Vec::new();
    for (path, archive) in paths.iter().zip([lens.write(), laser.write()]) {
        let archive = archive.context("cannot build the archive")?;
        outputs::say_if_replacing(path);
        write_atomically(path, &archive).with_context(|| format!("{}: cannot write", path.display()))?;
        written.push(path.display().to_string());
    }
    if args.json {
        println!("{}", json!({ "unit": unit, "lens": written[0], "laser": written[1] }));
    } else {
        println!("{unit}: wrote {} and {}", written[0], written[1]);
    }
    Ok(ExitCode::SUCCESS)
}
