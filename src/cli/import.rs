//! `fslcal import`: a signed unit file from the FishSense lab's lens and laser calibrations,
//! as `.pkg` archives or as the bodies of its API (`CameraIntrinsics`, `LaserExtrinsics`).

use super::lab_files::{self, LabLaser, LabLens, LAB_FRAME};
use super::outputs::{self, Input, Output, OutputKind};
use super::signing::SigningArgs;
use crate::photo::frame::Frame;
use crate::units::signed_file;
use crate::utc_time;
use anyhow::{bail, Context};
use fslcal_core::unit_file::{FitMethod, UnitFile};
use fslcal_core::{CameraModel, LaserLine};
use serde_json::json;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// Make a signed unit file from the lab's lens and laser calibrations.
///
/// Each file may be a `.pkg` archive (`fsl calibrate-lens`, `fsl calibrate-laser`) or a JSON
/// body of the lab's API (`CameraIntrinsics`, `LaserExtrinsics`), in either order; they are
/// told apart by content. The lab's lenses are made in the TG-6's whole 4040x3016 sensor
/// readout; fslcal works in the 4000x3000 picture it develops, so the principal point moves
/// by the crop (docs/conventions.md), and `fslcal export` moves it back. The files carry no
/// covariance and no fit figures: the signed file records the laser as imported, its
/// uncertainty unknown, and where it came from (`provenance`).
#[derive(clap::Args, Debug)]
pub struct ImportArgs {
    /// The lens calibration: a `.pkg` (`_calibration_matrix.npy`,
    /// `_distortion_coefficients.npy`) or the API's `CameraIntrinsics` JSON.
    #[arg(value_name = "LENS")]
    lens: PathBuf,

    /// The laser calibration: a `.pkg` (`laser_pos.npy` in metres, `laser_axis.npy`) or the
    /// API's `LaserExtrinsics` JSON.
    #[arg(value_name = "LASER")]
    laser: PathBuf,

    #[command(flatten)]
    signing: SigningArgs,

    /// The image size the lens calibration was made at, pixels: the lab's are made on the
    /// TG-6's whole sensor readout (4040x3016). Another size is taken as is and must then be
    /// the size of the photos the unit file is used with.
    #[arg(long, visible_alias = "image-size", value_name = "WxH", default_value = LAB_FRAME, value_parser = lab_files::parse_frame)]
    lens_frame: Frame,

    /// Where the lab's files' times without a zone were written (the 2023 tools wrote local
    /// time): an IANA zone (`America/Los_Angeles`) or an offset (`-08:00`). Times that
    /// carry a zone keep it.
    #[arg(long, value_name = "ZONE", value_parser = utc_time::parse_zone, allow_hyphen_values = true)]
    timezone: Option<jiff::tz::TimeZone>,

    /// Plausible camera-to-laser baseline for the rig, millimetres (as `fslcal laser`): a
    /// laser position outside it (centimetres or millimetres where metres belong) is refused
    /// unless --force (which also replaces a signed file already at --out).
    #[arg(long, value_name = "MIN,MAX", default_value = "78,145", value_parser = super::parse::range_mm)]
    baseline_range_mm: (f64, f64),

    /// The unit file to write.
    #[arg(long, value_name = "FILE.fslcal")]
    out: PathBuf,

    /// Print one JSON object instead of the summary.
    #[arg(long)]
    json: bool,
}

/// The two files, whichever order they were given in.
fn read_pair(args: &ImportArgs) -> anyhow::Result<(LabLens, &Path, LabLaser, &Path)> {
    let zone = args.timezone.as_ref();
    let first_is_lens = lab_files::is_lab_lens(
        &std::fs::read(&args.lens).with_context(|| format!("{}: cannot read", args.lens.display()))?,
    );
    let (lens_path, laser_path) = if first_is_lens { (&args.lens, &args.laser) } else { (&args.laser, &args.lens) };
    let lens = lab_files::read_lens(lens_path, args.lens_frame, zone)?;
    let laser = lab_files::read_laser(laser_path, zone)?;
    Ok((lens, lens_path, laser, laser_path))
}

/// The lens in the frame fslcal develops photos in.
fn developed(lens: &LabLens, frame: Frame, path: &Path) -> anyhow::Result<(CameraModel, String)> {
    let map = frame.map_to(&frame.developed()).with_context(|| path.display().to_string())?;
    let note = format!("lens made in {} → {}: principal point {}", frame.describe(), map.to.describe(), map.describe());
    Ok((map.camera(&lens.camera), note))
}

pub fn run(args: ImportArgs) -> anyhow::Result<ExitCode> {
    let mut inputs = vec![Input::new("LENS.pkg", &args.lens), Input::new("LASER.pkg", &args.laser)];
    inputs.extend(args.signing.key.as_deref().map(|k| Input::new("--key", k)));
    let out = Output { option: "--out", path: &args.out, kind: OutputKind::Signed };
    outputs::check(&inputs, &[out], args.signing.force)?;
    let (unit, key) = args.signing.unit_and_key(&args.out)?;
    let (lens, lens_path, laser, laser_path) = read_pair(&args)?;
    let (camera, frame_note) = developed(&lens, args.lens_frame, lens_path)?;
    let range_m = (args.baseline_range_mm.0, args.baseline_range_mm.1);
    let (line, notes) = lab_files::laser_line(&laser, laser_path, range_m, args.signing.force)?;
    for n in &notes {
        eprintln!("warning: {n}");
    }
    let made_utc_s = made(&lens, &laser, args.timezone.as_ref(), lens_path)?;
    let serial = args.signing.camera_serial.clone().or_else(|| lens.serial.clone());
    let identity = fslcal_core::unit_file::CameraIdentity { serial: serial.as_deref(), ..args.signing.identity() };
    let contents = unit_contents(&unit, identity, camera, line, made_utc_s, args.signing.water_depth_m, &laser);
    outputs::say_if_replacing(&args.out);
    let size = signed_file::sign_to_file(&contents, &key, &args.out)?;
    let provenance = laser.format.provenance().name();
    if args.json {
        let v = json!({
            "out": args.out.display().to_string(), "unit": unit, "size_bytes": size,
            "made_utc": utc_time::format_iso(made_utc_s), "provenance": provenance,
            "camera_serial": serial, "lens_frame": args.lens_frame.to_string(),
            "image_size": [camera.width_px, camera.height_px], "warnings": notes,
        });
        println!("{v}");
    } else {
        println!(
            "{unit}: wrote {} ({size} bytes), calibrated {}, from {} ({provenance})",
            args.out.display(),
            utc_time::format_iso(made_utc_s),
            sources(&lens, &laser)
        );
        println!("  {frame_note}");
        if let Some(s) = &serial {
            let from = if args.signing.camera_serial.is_some() { "--camera-serial" } else { "the lens metadata" };
            println!("  camera serial {s} (from {from})");
        }
    }
    Ok(ExitCode::SUCCESS)
}

fn sources(lens: &LabLens, laser: &LabLaser) -> String {
    if lens.format == laser.format {
        lens.format.describe().to_string()
    } else {
        format!("a lens in {} and a laser in {}", lens.format.describe(), laser.format.describe())
    }
}

/// When the calibration was made: the later of the two files' dates; refused when neither
/// has one (API bodies with `created_at` null).
fn made(lens: &LabLens, laser: &LabLaser, zone: Option<&jiff::tz::TimeZone>, lens_path: &Path) -> anyhow::Result<i64> {
    let lens_s = lens
        .date
        .as_deref()
        .map(|d| utc_time::parse_iso_in(d, zone))
        .transpose()
        .with_context(|| format!("{}: calibrated_date", lens_path.display()))?;
    match (lens_s, laser.made_utc_s) {
        (Some(a), Some(b)) => Ok(a.max(b)),
        (Some(t), None) | (None, Some(t)) => Ok(t),
        (None, None) => bail!("neither file says when the calibration was made (the LaserExtrinsics' created_at is null); fill in created_at as ISO 8601 with a zone"),
    }
}

fn unit_contents<'a>(
    unit: &'a str,
    camera_identity: fslcal_core::unit_file::CameraIdentity<'a>,
    camera: CameraModel,
    laser: LaserLine,
    made_utc_s: i64,
    water_depth_m: Option<f32>,
    from: &LabLaser,
) -> UnitFile<'a> {
    UnitFile {
        unit,
        camera_identity,
        camera,
        laser,
        laser_covariance: [[0.0; 4]; 4],
        made_utc_s,
        water_depth_m,
        depth_range_m: None,
        fit: None,
        method: FitMethod::Imported,
        target: None,
        // The laser is the dive's calibration, the lens the camera's: the laser's file says
        // where this calibration came from.
        provenance: from.format.provenance(),
        laser_colour: None,
    }
}
