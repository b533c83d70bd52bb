//! The FishSense lab's calibration files as the commands take them, told apart by content:
//! a lens (`.pkg` archive or API `CameraIntrinsics` JSON) in the frame it was made in, and a
//! laser (`.pkg` or API `LaserExtrinsics` JSON) checked against the rig's gates.

use crate::camera::opencv_yaml::{camera_from_opencv, OpencvCameraProblem};
use crate::photo::frame::Frame;
use crate::units::lab_api::{self, ApiBody};
use crate::units::lab_pkg::{LaserPkg, LensPkg};
use crate::utc_time;
use anyhow::{bail, Context};
use fslcal_core::unit_file::Provenance;
use fslcal_core::{CameraModel, LaserLine, Vec3};
use std::path::Path;

/// The frame the lab's lens calibrations are made in: the TG-6's whole readout, which its
/// `fsl preprocess` develops (their files are named `...-lens-raw.pkg`).
pub const LAB_FRAME: &str = "4040x3016";

/// `WxH` in pixels, as a frame.
pub fn parse_frame(s: &str) -> Result<Frame, String> {
    super::parse::image_size(s).map(|(w, h)| Frame::of_size(w, h))
}

/// Which of the lab's formats a file was.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LabFormat {
    Pkg,
    Api,
}

impl LabFormat {
    pub fn provenance(self) -> Provenance {
        match self {
            LabFormat::Pkg => Provenance::LabPkg,
            LabFormat::Api => Provenance::LabApi,
        }
    }

    pub fn describe(self) -> &'static str {
        match self {
            LabFormat::Pkg => "the lab's .pkg",
            LabFormat::Api => "the lab's API JSON",
        }
    }
}

/// gzip's magic: a `.pkg` archive.
fn is_pkg(bytes: &[u8]) -> bool {
    bytes.starts_with(&[0x1f, 0x8b])
}

/// Whether `bytes` are one of the lab's lens files (a `.pkg`, or a JSON body with a
/// `camera_matrix`), rather than an OpenCV camera file or a unit file.
pub fn is_lab_lens(bytes: &[u8]) -> bool {
    is_pkg(bytes) || (lab_api::looks_like_json_object(bytes) && matches!(body(bytes), Some(Ok(ApiBody::Intrinsics(_)))))
}

fn body(bytes: &[u8]) -> Option<Result<ApiBody, lab_api::ApiError>> {
    std::str::from_utf8(bytes).ok().map(ApiBody::parse)
}

/// A lens as the lab's file gives it, in the frame it was made in.
#[derive(Clone, Debug)]
pub struct LabLens {
    pub camera: CameraModel,
    pub format: LabFormat,
    /// `calibrated_date` as written (a `.pkg`'s; API intrinsics carry none).
    pub date: Option<String>,
    /// The camera's serial number (the 2023 lens metadata's `serial_number`).
    pub serial: Option<String>,
}

/// Reads a lens file made in `frame`. A `.pkg`'s date is placed in `zone` when it has none
/// of its own; `None` refuses such a date (`Some(UTC)` where the date is not used).
pub fn read_lens(path: &Path, frame: Frame, zone: Option<&jiff::tz::TimeZone>) -> anyhow::Result<LabLens> {
    let bytes = std::fs::read(path).with_context(|| format!("{}: cannot read", path.display()))?;
    let name = path.display();
    let (k, d, format, date, serial) = if is_pkg(&bytes) {
        let (lens, meta) = LensPkg::read_with_metadata(&bytes, zone).with_context(|| name.to_string())?;
        (lens.camera_matrix, lens.distortion, LabFormat::Pkg, Some(meta.calibrated_date), meta.serial_number)
    } else {
        match body(&bytes) {
            Some(Ok(ApiBody::Intrinsics(i))) => {
                (i.matrix_row_major(), i.distortion_coefficients, LabFormat::Api, None, None)
            }
            Some(Ok(ApiBody::Extrinsics(_))) => {
                bail!("{name}: this is the lab's LaserExtrinsics (a laser), not a lens calibration")
            }
            Some(Err(e)) => bail!("{name}: {e}"),
            None => bail!("{name}: neither a lab .pkg archive nor the lab's API JSON"),
        }
    };
    let camera = camera_in(&k, &d, frame, path)?;
    Ok(LabLens { camera, format, date, serial })
}

/// The camera a lens's matrix and coefficients describe in `frame`.
fn camera_in(k: &[f64; 9], d: &[f64], frame: Frame, path: &Path) -> anyhow::Result<CameraModel> {
    camera_from_opencv(frame.width_px, frame.height_px, k, d).map_err(|problem| match problem {
        OpencvCameraProblem::Distortion(n) => {
            anyhow::anyhow!("{}: {n} distortion coefficients; fslcal uses OpenCV's 5-term model (k1, k2, p1, p2, k3)", path.display())
        }
        OpencvCameraProblem::Implausible => anyhow::anyhow!(
            "{}: the camera matrix is not plausible for a {frame} image (focal lengths must be positive, the principal point inside; give the frame it was made in with --lens-frame)",
            path.display(),
        ),
    })
}

/// A laser as the lab's file gives it.
#[derive(Clone, Debug)]
pub struct LabLaser {
    pub position_m: [f64; 3],
    pub axis: [f64; 3],
    pub format: LabFormat,
    /// When it was made, seconds since 1970 UTC (`None`: an API body with `created_at`
    /// null).
    pub made_utc_s: Option<i64>,
}

/// Reads a laser file; a date without a zone is placed in `zone`, refused without one.
pub fn read_laser(path: &Path, zone: Option<&jiff::tz::TimeZone>) -> anyhow::Result<LabLaser> {
    let bytes = std::fs::read(path).with_context(|| format!("{}: cannot read", path.display()))?;
    let name = path.display();
    if is_pkg(&bytes) {
        let (l, _) = LaserPkg::read_with_metadata(&bytes, zone).with_context(|| name.to_string())?;
        return Ok(LabLaser {
            position_m: l.position_m,
            axis: l.axis,
            format: LabFormat::Pkg,
            made_utc_s: Some(l.calibrated_utc_s),
        });
    }
    match body(&bytes) {
        Some(Ok(ApiBody::Extrinsics(e))) => {
            let made_utc_s = e
                .created_at
                .as_deref()
                .map(|t| utc_time::parse_iso_in(t, zone))
                .transpose()
                .with_context(|| format!("{name}: created_at"))?;
            Ok(LabLaser { position_m: e.laser_position, axis: e.laser_axis, format: LabFormat::Api, made_utc_s })
        }
        Some(Ok(ApiBody::Intrinsics(_))) => {
            bail!("{name}: this is the lab's CameraIntrinsics (a lens), not a laser calibration")
        }
        Some(Err(e)) => bail!("{name}: {e}"),
        None => bail!("{name}: neither a lab .pkg archive nor the lab's API JSON"),
    }
}

/// The laser line a lab file's numbers describe, checked as `fslcal laser` checks a fit:
/// the baseline within `baseline_range_m` (a position in centimetres or millimetres is off
/// by 100 or 1000), unless `force`. Taken exactly as stored when it already is a unit
/// direction from the z = 0 plane, so that an export gives the lab the very same numbers;
/// otherwise moved and normalised, each change said in the returned notes.
pub fn laser_line(
    laser: &LabLaser,
    path: &Path,
    baseline_range_m: (f64, f64),
    force: bool,
) -> anyhow::Result<(LaserLine, Vec<String>)> {
    let (p, a) = (laser.position_m, laser.axis);
    let name = path.display();
    if !p.iter().chain(&a).all(|v| v.is_finite()) {
        bail!("{name}: the laser's position or axis is not a finite number");
    }
    let as_given = LaserLine { origin_m: p, direction: a };
    let norm = as_given.dir().norm();
    let mut notes = Vec::new();
    let line = if p[2] == 0.0 && a[2] > 0.0 && (norm - 1.0).abs() < 1e-12 {
        as_given
    } else {
        let l = LaserLine::from_point_direction(Vec3::from(p), Vec3::from(a)).with_context(|| {
            format!("{name}: the laser axis ({}, {}, {}) is not a direction with z != 0", a[0], a[1], a[2])
        })?;
        if (norm - 1.0).abs() >= 1e-12 {
            notes.push(format!("{name}: the laser axis has length {norm:.9}, not 1: normalised"));
        }
        if a[2] < 0.0 {
            notes.push(format!("{name}: the laser axis points back into the camera (z < 0): flipped to point forward"));
        }
        if p[2] != 0.0 {
            notes.push(format!(
                "{name}: the laser position is {:.4} m off the camera's z = 0 plane: moved along the axis onto it",
                p[2]
            ));
        }
        l
    };
    let baseline_m = line.baseline_m();
    let (lo, hi) = baseline_range_m;
    if !(lo..=hi).contains(&baseline_m) {
        let why = format!(
            "{name}: the laser position gives a {} baseline, outside the rig's {:.0}-{:.0} mm{}",
            if baseline_m >= 1.0 { format!("{baseline_m:.2} m") } else { format!("{:.1} mm", baseline_m * 1e3) },
            lo * 1e3,
            hi * 1e3,
            unit_hint(baseline_m, baseline_range_m)
        );
        if !force {
            bail!("{why}; pass --force to sign a rig outside them (--baseline-range-mm sets the range)");
        }
        notes.push(format!("{why}; signed anyway (--force)"));
    }
    Ok((line, notes))
}

/// What the number would be if it were centimetres or millimetres, when that fits.
fn unit_hint(baseline_m: f64, (lo, hi): (f64, f64)) -> String {
    [(100.0, "centimetres"), (1000.0, "millimetres")]
        .iter()
        .find(|(f, _)| (lo..=hi).contains(&(baseline_m / f)))
        .map(|(f, unit)| {
            format!(" (as {unit} it would be {:.1} mm: fslcal and the lab's API take metres)", baseline_m / f * 1e3)
        })
        .unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn laser(position_m: [f64; 3], axis: [f64; 3]) -> LabLaser {
        LabLaser { position_m, axis, format: LabFormat::Pkg, made_utc_s: Some(0) }
    }

    #[test]
    fn a_unit_laser_is_kept_bit_exact_and_any_change_is_said() {
        let p = Path::new("l.pkg");
        let a = [0.0098, 0.0199, (1.0f64 - 0.0098f64.powi(2) - 0.0199f64.powi(2)).sqrt()];
        let (l, notes) = laser_line(&laser([-0.0412, -0.1067, 0.0], a), p, (0.078, 0.145), false).unwrap();
        assert_eq!((l.origin_m, l.direction), ([-0.0412, -0.1067, 0.0], a));
        assert!(notes.is_empty());
        let (l, notes) =
            laser_line(&laser([-0.0412, -0.1067, 0.0], [-0.0196, -0.0398, -2.0]), p, (0.078, 0.145), false).unwrap();
        assert!(l.direction[2] > 0.0 && (l.dir().norm() - 1.0).abs() < 1e-15);
        assert_eq!(notes.len(), 2, "{notes:?}");
        assert!(notes[0].contains("normalised") && notes[1].contains("flipped"), "{notes:?}");
    }

    #[test]
    fn centimetres_and_millimetres_are_refused_unless_forced() {
        let p = Path::new("l.pkg");
        let a = [0.0, 0.0, 1.0];
        let e = laser_line(&laser([-4.12, -10.67, 0.0], a), p, (0.078, 0.145), false).unwrap_err().to_string();
        assert!(e.contains("11.44 m baseline") && e.contains("as centimetres it would be 114.4 mm"), "{e}");
        assert!(e.contains("--force"), "{e}");
        let e = laser_line(&laser([-41.2, -106.7, 0.0], a), p, (0.078, 0.145), false).unwrap_err().to_string();
        assert!(e.contains("as millimetres it would be 114.4 mm"), "{e}");
        let (_, notes) = laser_line(&laser([-4.12, -10.67, 0.0], a), p, (0.078, 0.145), true).unwrap();
        assert!(notes[0].contains("signed anyway"), "{notes:?}");
    }

    #[test]
    fn frames_parse_and_place() {
        assert_eq!(parse_frame(LAB_FRAME).unwrap(), Frame::of_size(4040, 3016));
        assert!(parse_frame("4000x").is_err() && parse_frame("0x10").is_err() && parse_frame("99999999x2").is_err());
    }
}
