//! `fslcal inspect`: everything a unit file says, without needing to trust its signer.

use crate::calibration::camera_json;
use crate::units::keys::hex;
use crate::units::signed_file::{self, UnitFileError};
use crate::utc_time;
use fslcal_core::covariance_known;
use fslcal_core::unit_file::{Provenance, SignedUnitFile};
use serde_json::json;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// Show what a signed unit file (.fslcal) holds and whether its signature matches.
///
/// Whether the signer is one you trust is `fslcal verify`'s question; this only says whether
/// the file is intact as its signer made it. A file whose signature does not match is still
/// shown (to see what was changed), and the exit status is 1.
#[derive(clap::Args, Debug)]
pub struct InspectArgs {
    /// The unit file.
    #[arg(value_name = "FILE")]
    file: PathBuf,

    /// Print one JSON object instead of the summary.
    #[arg(long)]
    json: bool,
}

/// Reads and decodes a unit file (the signature unchecked), naming the file in any error.
pub(super) fn decode<'a>(path: &Path, bytes: &'a [u8]) -> Result<SignedUnitFile<'a>, UnitFileError> {
    SignedUnitFile::decode(bytes).map_err(UnitFileError::at(path))
}

/// The JSON description of a unit file every command that reports one uses.
pub(super) fn unit_file_json(path: &Path, size_bytes: usize, f: &SignedUnitFile<'_>) -> serde_json::Value {
    let c = &f.contents;
    let l = &c.laser;
    json!({
        "file": path.display().to_string(),
        "format_version": f.version,
        "size_bytes": size_bytes,
        "unit": c.unit,
        "camera_identity": {
            "make": c.camera_identity.make,
            "model": c.camera_identity.model,
            "serial": c.camera_identity.serial,
        },
        "camera": camera_json(&c.camera),
        "laser": {
            "origin_m": l.origin_m,
            "direction": l.direction,
            "baseline_m": l.baseline_m(),
            "angle_to_optical_axis_deg": l.angle_to_optical_axis().to_degrees(),
            // null when unknown (all zero: imported without the fit's figures), never zeros
            // a reader would take for certainty.
            "covariance": covariance_known(&c.laser_covariance).then_some(c.laser_covariance),
            "covariance_parameters": ["origin_x_m", "origin_y_m", "direction_x_over_z", "direction_y_over_z"],
        },
        "made_utc": utc_time::format_iso(c.made_utc_s),
        "water_depth_m": c.water_depth_m,
        "depth_range_m": c.depth_range_m,
        "method": c.method.name(),
        "provenance": c.provenance.name(),
        "fit": c.fit.map(|q| json!({
            "photos_used": q.photos_used,
            "photos_total": q.photos_total,
            // As `fslcal laser` counts them: of the photos with a dot.
            "outliers": format!("{} of {}", q.outliers, q.photos_used + q.outliers),
            "residual_rms_px": q.residual_rms_px,
            "residual_worst_px": q.residual_worst_px,
            "residual_rms_mm": q.residual_rms_mm,
            "residual_worst_mm": q.residual_worst_mm,
            "span_m": q.span_m,
        })),
        "target": c.target,
        "signer": f.key_id().to_string(),
        "signer_public_key": hex(&f.signer),
        "signature": if f.check_signature().is_ok() { "valid" } else { "invalid" },
    })
}

fn summary(path: &Path, size: usize, f: &SignedUnitFile<'_>) -> String {
    let c = &f.contents;
    let (cam, l) = (&c.camera, &c.laser);
    let id = &c.camera_identity;
    let mut s = format!("{}: unit {}, format version {}, {size} bytes\n", path.display(), c.unit, f.version);
    s += &format!("camera    {} {}, serial {}\n", id.make, id.model, id.serial.unwrap_or("-"));
    s += &format!(
        "          {}x{} px, f ({:.2}, {:.2}) px, centre ({:.2}, {:.2}) px, dist {:?}\n",
        cam.width_px,
        cam.height_px,
        cam.fx_px,
        cam.fy_px,
        cam.cx_px,
        cam.cy_px,
        cam.distortion.to_opencv()
    );
    let cov = &c.laser_covariance;
    let (origin_sigma, direction_sigma) = if covariance_known(cov) {
        (
            format!(" ±({:.2}, {:.2}) mm", cov[0][0].sqrt() * 1e3, cov[1][1].sqrt() * 1e3),
            format!(" ±{:.4} deg", (cov[2][2] + cov[3][3]).sqrt().atan().to_degrees()),
        )
    } else {
        (" ± unknown".to_string(), " ± unknown".to_string())
    };
    s += &format!(
        "laser     origin ({:.2}, {:.2}, 0) mm{origin_sigma}, direction ({:.5}, {:.5}, {:.5}){direction_sigma}, {:.3} deg off axis\n",
        l.origin_m[0] * 1e3,
        l.origin_m[1] * 1e3,
        l.direction[0],
        l.direction[1],
        l.direction[2],
        l.angle_to_optical_axis().to_degrees()
    );
    if !covariance_known(cov) {
        s += "          covariance unknown (the file records none, as an import of the lab's files): no 1-sigma can be given\n";
    }
    s += &format!(
        "made      {}{}, target {}, method {}\n",
        utc_time::format_iso(c.made_utc_s),
        c.water_depth_m.map_or(String::new(), |w| format!(" at {w:.1} m water depth")),
        c.target.unwrap_or("-"),
        c.method.name()
    );
    s += &format!("source    {}\n", provenance_text(c.provenance));
    if let Some(r) = c.depth_range_m {
        s += &format!("dots      {:.2}-{:.2} m deep\n", r[0], r[1]);
    }
    if let Some(q) = c.fit {
        s += &format!(
            "fit       RMS {:.2} px ({:.2} mm), worst {:.2} px ({:.2} mm); {} of {} photos used, outliers {} of {}; span {:.2} m\n",
            q.residual_rms_px,
            q.residual_rms_mm,
            q.residual_worst_px,
            q.residual_worst_mm,
            q.photos_used,
            q.photos_total,
            q.outliers,
            q.photos_used + q.outliers,
            q.span_m
        );
    }
    let verdict = match f.check_signature() {
        Ok(()) => "valid (whether the signer is trusted: `fslcal verify --trust`)".to_string(),
        Err(e) => format!("INVALID: {e}"),
    };
    s += &format!("signer    {} (public key {})\nsignature {verdict}\n", f.key_id(), hex(&f.signer));
    s
}

/// Where a calibration came from, in words.
pub(super) fn provenance_text(p: Provenance) -> &'static str {
    match p {
        Provenance::Fitted => "fitted by fslcal from calibration photos",
        Provenance::LabPkg => "imported from the lab's .pkg files (no fit figures, uncertainty unknown)",
        Provenance::LabApi => "imported from the lab's API JSON (no fit figures, uncertainty unknown)",
    }
}

pub fn run(args: InspectArgs) -> anyhow::Result<ExitCode> {
    let bytes = signed_file::read_bytes(&args.file)?;
    let file = decode(&args.file, &bytes)?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&unit_file_json(&args.file, bytes.len(), &file))?);
    } else {
        print!("{}", summary(&args.file, bytes.len(), &file));
    }
    // Shown, but not passed: a script that inspects before use must not take it as sound.
    file.check_signature().map_err(UnitFileError::at(&args.file))?;
    Ok(ExitCode::SUCCESS)
}
