//! `fslcal import`: a signed unit file from the FishSense lab's lens and laser `.pkg` files.

use super::outputs::{self, Input, Output, OutputKind};
use super::signing::SigningArgs;
use crate::camera::opencv_yaml::{camera_from_opencv, OpencvCameraProblem};
use crate::units::lab_pkg::{LaserPkg, LensPkg};
use crate::units::signed_file;
use crate::utc_time;
use anyhow::Context;
use fslcal_core::unit_file::{FitMethod, Provenance, UnitFile};
use fslcal_core::{CameraModel, LaserLine, Vec3};
use serde_json::json;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// Make a signed unit file from the lab's lens and laser calibrations (.pkg archives).
///
/// The .pkg files carry no image size, no covariance and no fit figures: the size comes
/// from --image-size, and the file records the laser as imported with unknown covariance.
#[derive(clap::Args, Debug)]
pub struct ImportArgs {
    /// The lens calibration (`_calibration_matrix.npy`, `_distortion_coefficients.npy`).
    #[arg(value_name = "LENS.pkg")]
    lens: PathBuf,

    /// The laser calibration (`laser_pos.npy`, `laser_axis.npy`).
    #[arg(value_name = "LASER.pkg")]
    laser: PathBuf,

    #[command(flatten)]
    signing: SigningArgs,

    /// Image size the lens calibration was made at, pixels.
    #[arg(long, value_name = "WxH", default_value = "4000x3000", value_parser = super::parse::image_size)]
    image_size: (u32, u32),

    /// The unit file to write.
    #[arg(long, value_name = "FILE.fslcal")]
    out: PathBuf,

    /// Print one JSON object instead of the summary.
    #[arg(long)]
    json: bool,
}

fn read(path: &Path) -> anyhow::Result<Vec<u8>> {
    std::fs::read(path).with_context(|| format!("{}: cannot read", path.display()))
}

/// The camera a lens `.pkg` describes, at `size`.
fn camera_of(lens: &LensPkg, size: (u32, u32), path: &Path) -> anyhow::Result<CameraModel> {
    camera_from_opencv(size.0, size.1, &lens.camera_matrix, &lens.distortion).map_err(|problem| match problem {
        OpencvCameraProblem::Distortion(n) => {
            anyhow::anyhow!("{}: {n} distortion coefficients; fslcal uses OpenCV's 5-term model (k1, k2, p1, p2, k3)", path.display())
        }
        OpencvCameraProblem::Implausible => anyhow::anyhow!(
            "{}: the camera matrix is not plausible for a {}x{} image (focal lengths must be positive, the principal point inside; give the right --image-size)",
            path.display(),
            size.0,
            size.1
        ),
    })
}

pub fn run(args: ImportArgs) -> anyhow::Result<ExitCode> {
    let mut inputs = vec![Input::new("LENS.pkg", &args.lens), Input::new("LASER.pkg", &args.laser)];
    inputs.extend(args.signing.key.as_deref().map(|k| Input::new("--key", k)));
    let out = Output { option: "--out", path: &args.out, kind: OutputKind::Signed };
    outputs::check(&inputs, &[out], args.signing.force)?;
    let (unit, key) = args.signing.unit_and_key(&args.out)?;
    let lens = LensPkg::read(&read(&args.lens)?).with_context(|| format!("{}", args.lens.display()))?;
    let laser_pkg = LaserPkg::read(&read(&args.laser)?).with_context(|| format!("{}", args.laser.display()))?;
    let camera = camera_of(&lens, args.image_size, &args.lens)?;
    let (p, a) = (laser_pkg.position_m, laser_pkg.axis);
    let as_given = LaserLine { origin_m: p, direction: a };
    // Taken as stored when it already is a unit direction from the z = 0 plane, so that an
    // export gives NumPy back the very same numbers; moved and normalised otherwise.
    let laser = if p[2] == 0.0 && a[2] > 0.0 && (as_given.dir().norm() - 1.0).abs() < 1e-12 {
        Some(as_given)
    } else {
        LaserLine::from_point_direction(Vec3::from(p), Vec3::from(a))
    }
    .filter(|_| p.iter().chain(&a).all(|v| v.is_finite()))
    .with_context(|| format!("{}: the laser axis does not point forward (z > 0)", args.laser.display()))?;
    let made_utc_s = lens.calibrated_utc_s.max(laser_pkg.calibrated_utc_s);
    let contents = UnitFile {
        unit: &unit,
        camera_identity: args.signing.identity(),
        camera,
        laser,
        laser_covariance: [[0.0; 4]; 4],
        made_utc_s,
        water_depth_m: args.signing.water_depth_m,
        depth_range_m: None,
        fit: None,
        method: FitMethod::Imported,
        target: None,
        provenance: Provenance::LabPkg,
        laser_colour: None,
    };
    outputs::say_if_replacing(&args.out);
    let size = signed_file::sign_to_file(&contents, &key, &args.out)?;
    if args.json {
        println!(
            "{}",
            json!({ "out": args.out.display().to_string(), "unit": unit, "size_bytes": size, "made_utc": utc_time::format_iso(made_utc_s) })
        );
    } else {
        println!(
            "{unit}: wrote {} ({size} bytes), calibrated {}",
            args.out.display(),
            utc_time::format_iso(made_utc_s)
        );
    }
    Ok(ExitCode::SUCCESS)
}
