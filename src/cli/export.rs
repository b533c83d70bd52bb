//! `fslcal export`: a unit file back into the FishSense lab's formats, `.pkg` archives or
//! its API's JSON bodies, in the frame the lab's tools work in.

use super::inspect;
use super::lab_files::{self, LAB_FRAME};
use super::outputs::{self, Input, Output};
use crate::atomic_file::write_atomically;
use crate::photo::frame::Frame;
use crate::units::lab_api::{CameraIntrinsics, LaserExtrinsics};
use crate::units::lab_pkg::{LaserPkg, LensPkg};
use crate::units::signed_file::{self, UnitFileError};
use crate::utc_time;
use anyhow::Context;
use fslcal_core::unit_file::UnitFile;
use fslcal_core::CameraModel;
use serde_json::json;
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
enum ExportFormat {
    /// The lab's lens and laser `.pkg` archives (gzip tar of metadata.json and .npy arrays).
    FishsensePkg,
    /// The lab's API bodies: `CameraIntrinsics` and `LaserExtrinsics` JSON.
    FishsenseApi,
}

/// Write a unit file's calibration in another tool's format.
///
/// `fishsense-pkg` writes UNIT-lens.pkg and UNIT-laser.pkg into --out, which NumPy reads with
/// the same numbers. `fishsense-api` writes UNIT-camera-intrinsics.json and
/// UNIT-laser-extrinsics.json, the bodies the lab's API takes (`PUT
/// /api/v1/cameras/{camera_id}/intrinsics/`, `PUT /api/v1/dives/{dive_id}/laser-extrinsics/`).
/// The lens is written in --lab-frame (the lab's tools work in the TG-6's whole 4040x3016
/// readout), the laser in metres. A tampered file is refused.
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

    /// The frame the lab's tools take lenses in, pixels; the unit file's camera is moved
    /// into it by the sensor's crop (the principal point only).
    #[arg(long, value_name = "WxH", default_value = LAB_FRAME, value_parser = lab_files::parse_frame)]
    lab_frame: Frame,

    /// `camera_id` of the lab's database for both bodies (fishsense-api); null when not
    /// given (the API's PUT takes it from its path).
    #[arg(long, value_name = "ID")]
    camera_id: Option<i64>,

    /// `dive_id` for the LaserExtrinsics body (fishsense-api); null when not given.
    #[arg(long, value_name = "ID")]
    dive_id: Option<i64>,

    /// Print one JSON object instead of the summary.
    #[arg(long)]
    json: bool,
}

/// The unit file's camera in the lab's frame.
fn lab_camera(args: &ExportArgs, camera: &CameraModel) -> anyhow::Result<CameraModel> {
    let map = Frame::of_camera(camera).map_to(&args.lab_frame).with_context(|| {
        format!(
            "{}: the calibration's camera (give its own size as --lab-frame to write it unmoved)",
            args.file.display()
        )
    })?;
    Ok(map.camera(camera))
}

/// The two files' names and contents.
fn files(args: &ExportArgs, unit: &str, c: &UnitFile<'_>) -> anyhow::Result<Vec<(String, Vec<u8>)>> {
    let cam = lab_camera(args, &c.camera)?;
    let k = [cam.fx_px, 0.0, cam.cx_px, 0.0, cam.fy_px, cam.cy_px, 0.0, 0.0, 1.0];
    let (origin, axis) = (c.laser.origin_m, c.laser.direction);
    Ok(match args.format {
        ExportFormat::FishsensePkg => {
            let lens = LensPkg {
                camera_matrix: k,
                distortion: cam.distortion.to_opencv().to_vec(),
                calibrated_utc_s: c.made_utc_s,
            };
            let laser = LaserPkg { position_m: origin, axis, calibrated_utc_s: c.made_utc_s };
            let build = |r: std::io::Result<Vec<u8>>| r.context("cannot build the archive");
            vec![
                (format!("{unit}-lens.pkg"), build(lens.write())?),
                (format!("{unit}-laser.pkg"), build(laser.write())?),
            ]
        }
        ExportFormat::FishsenseApi => {
            let intrinsics = CameraIntrinsics {
                id: None,
                camera_matrix: [[k[0], k[1], k[2]], [k[3], k[4], k[5]], [k[6], k[7], k[8]]],
                distortion_coefficients: cam.distortion.to_opencv().to_vec(),
                camera_id: args.camera_id,
            };
            let extrinsics = LaserExtrinsics {
                id: None,
                laser_position: origin,
                laser_axis: axis,
                created_at: Some(utc_time::format_iso_offset(c.made_utc_s)),
                dive_id: args.dive_id,
                camera_id: args.camera_id,
            };
            let text = |v: serde_json::Result<String>| v.map(|t| (t + "\n").into_bytes());
            vec![
                (format!("{unit}-camera-intrinsics.json"), text(serde_json::to_string_pretty(&intrinsics))?),
                (format!("{unit}-laser-extrinsics.json"), text(serde_json::to_string_pretty(&extrinsics))?),
            ]
        }
    })
}

pub fn run(args: ExportArgs) -> anyhow::Result<ExitCode> {
    let bytes = signed_file::read_bytes(&args.file)?;
    let file = inspect::decode(&args.file, &bytes)?;
    file.check_signature().map_err(UnitFileError::at(&args.file))?;
    let c = &file.contents;
    // The unit names the output files: a crafted `../` must not write elsewhere.
    let unit = signed_file::unit_id(c.unit)?;
    let named = files(&args, &unit, c)?;
    let paths: Vec<PathBuf> = named.iter().map(|(name, _)| args.out.join(name)).collect();
    let outs: Vec<Output> = paths.iter().map(|p| Output::file("--out", p)).collect();
    outputs::check(&[Input::new("FILE", &args.file)], &outs, false)?;
    std::fs::create_dir_all(&args.out).with_context(|| format!("{}: cannot create the folder", args.out.display()))?;
    let mut written = Vec::new();
    for (path, (_, contents)) in paths.iter().zip(named) {
        outputs::say_if_replacing(path);
        write_atomically(path, &contents).with_context(|| format!("{}: cannot write", path.display()))?;
        written.push(path.display().to_string());
    }
    let frame = Frame::of_camera(&c.camera).map_to(&args.lab_frame)?;
    if args.json {
        let (lens, laser) = match args.format {
            ExportFormat::FishsensePkg => ("lens", "laser"),
            ExportFormat::FishsenseApi => ("camera_intrinsics", "laser_extrinsics"),
        };
        let v = json!({ "unit": unit, lens: written[0], laser: written[1], "lab_frame": args.lab_frame.to_string(), "principal_point_shift_px": [frame.shift_px.x, frame.shift_px.y] });
        println!("{v}");
    } else {
        println!("{unit}: wrote {} and {}", written[0], written[1]);
        println!("  lens in {}: principal point {}", args.lab_frame.describe(), frame.describe());
    }
    Ok(ExitCode::SUCCESS)
}
