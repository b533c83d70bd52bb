//! Using a calibration: loading one (`--cal CAL`), what a change between two means,
//! validating it against a known length, and checking it for drift.
//!
//! [`Calibration`] is a unit's calibration as the commands that *use* one see it: the
//! camera, the laser line and the laser's covariance, whichever file they came from.
//!
//! Either the JSON `fslcal laser --out` writes or the signed `.fslcal` unit file (told apart
//! by its magic), so `validate`, `check` and `measure` never care which they were given.

pub mod change;
#[cfg(feature = "vision")]
pub mod drift;
pub mod outcome;
#[cfg(feature = "vision")]
pub mod validate;

use crate::documents::laser::LaserDocument;
use crate::documents::{check_schema, CameraJson, NewerSchema};
use crate::laser::fit::distance_sigma;
use fslcal_core::unit_file::{self, FormatError, LaserColour};
use fslcal_core::{CameraModel, LaserLine};
use nalgebra::Matrix4;
use std::path::{Path, PathBuf};

/// Everything a command needs to turn a dot pixel into a distance and pixels into lengths.
#[derive(Clone, Debug, PartialEq)]
pub struct Calibration {
    pub camera: CameraModel,
    pub laser: LaserLine,
    /// Covariance of (origin x m, origin y m, direction x/z, direction y/z), as
    /// `laser::fit::LaserFit::covariance`.
    pub laser_covariance: [[f64; 4]; 4],
    /// Depths the calibration's dots covered, metres: distances outside are extrapolation.
    pub depth_range_m: Option<(f64, f64)>,
    /// `FSL-NN`, when the file names its unit.
    pub unit: Option<String>,
    /// Camera body serial, when the file records it.
    pub camera_serial: Option<String>,
    /// Focal length the calibration photos were taken at (EXIF), millimetres: another
    /// means the zoom was used.
    pub focal_length_mm: Option<f64>,
    /// The laser's colour learned from the calibration's accepted dots: the dot search
    /// scores candidates along it rather than along the green prior.
    pub laser_colour: Option<LaserColour>,
    pub source: PathBuf,
}

/// How far inside the calibration's own near end a dot is searched for, as a factor on it: a
/// little nearer than the calibrated span (the line extrapolates well), not down to the
/// housing's front, where algae, fins and bubbles lie on the line's image and the
/// calibration vouches for nothing. The far end is the default search's (6 m) whatever the
/// calibration's: far dots crowd towards the line's vanishing point (a 0.1 m baseline at
/// f = 2 967 px puts 4 m and 6 m 24 px apart on the image, where 0.5 m and 0.6 m lie 95 px
/// apart), so searching beyond the calibrated span takes in little clutter, and a diver whose
/// board photos stopped at 3 m still photographs fish at 4 m. On the tuning target-less photos
/// (seeds 0-11, companion calibrations ending at 2.9-3.1 m) searching to 6 m rather than 1.25x
/// the far end found 3 more of 156 visible dots (3.8-5.1 m) and a faint one at 5.6 m, and took
/// an algae speck at 3.3 m on one more of 44 laser-off photos.
pub const SEARCH_NEAR_FACTOR: f64 = 0.85;

/// Depth the along-line search always reaches down to, metres: the near end of the working
/// range divers are given (0.5-5 m). A unit whose nearest board photo was 1.1 m away still
/// meets fish at 0.6 m, and its line there is an extrapolation the gate's covariance already
/// widens for. On held-out target-less seeds 1 000 042-1 000 081 (522 visible dots), 8 lay
/// nearer than 0.85x their calibration's near end, 7 of them on three units calibrated
/// from 1.13-1.14 m: 5 were missed and 1 taken wrong. Searched to 0.5 m, the 5 were found;
/// elsewhere 3 missed dots were taken wrong, one of them (4.7 m, 8 levels) for a
/// laser-coloured blob at 0.65 m that the nearer search let in.
pub const SEARCH_NEAR_M: f64 = 0.5;

impl Calibration {
    /// The along-line dot search for this calibration: its covariance, and depths from a
    /// little inside the near end of its range ([`SEARCH_NEAR_FACTOR`]), or from
    /// [`SEARCH_NEAR_M`] when that is nearer, to the default far end (the default depths
    /// without a range).
    pub fn line_search(&self) -> crate::dot::on_line::LineSearch {
        use crate::dot::on_line::{LineSearch, DEFAULT_SEARCH_DEPTHS_M};
        let (lo, hi) = DEFAULT_SEARCH_DEPTHS_M;
        let depths_m = self.depth_range_m.map_or(DEFAULT_SEARCH_DEPTHS_M, |(near, _)| {
            ((near * SEARCH_NEAR_FACTOR).min(SEARCH_NEAR_M).clamp(lo, hi), hi)
        });
        LineSearch { depths_m, detector: self.dot_detector(), ..LineSearch::with_covariance(self.laser_covariance) }
    }

    /// The dot detector for this unit: the default thresholds, scoring colour along the
    /// laser's learned colour (the green prior for a calibration made before it was kept).
    pub fn dot_detector(&self) -> crate::dot::candidates::DotDetectorParams {
        use crate::dot::colour::LaserColourModel;
        crate::dot::candidates::DotDetectorParams {
            colour: LaserColourModel::from_unit_or_prior(self.laser_colour.as_ref()),
            ..Default::default()
        }
    }

    /// 1-sigma distance error from the calibration alone for a dot at depth `z_m`.
    pub fn distance_sigma_m(&self, z_m: f64) -> Option<f64> {
        distance_sigma(&self.camera, &self.laser, &Matrix4::from(self.laser_covariance).transpose(), z_m)
    }
}

#[derive(Debug, thiserror::Error)]
pub enum CalibrationError {
    /// The cause is in the message, not a `source`, or `{:#}` would say it twice.
    #[error("{path}: cannot read the calibration: {cause}")]
    Io { path: String, cause: std::io::Error },
    #[error(
        "{path}: not a calibration file (expected the JSON `fslcal laser --out` writes, or a signed .fslcal); {why}"
    )]
    NotACalibration { path: String, why: String },
    #[error("{path}: the calibration is implausible ({why}); re-run `fslcal laser`")]
    Implausible { path: String, why: Implausibility },
    #[error("{path}: {cause}")]
    UnitFile { path: String, cause: FormatError },
    #[error("{path}: {cause}")]
    Newer { path: String, cause: NewerSchema },
}

/// What makes a calibration read from JSON unusable.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum Implausibility {
    #[error("camera intrinsics out of range")]
    Camera,
    #[error("laser direction not forward")]
    LaserBackward,
    #[error("laser covariance not finite")]
    Covariance,
    #[error("laser colour's tone curve gamma outside 1-3")]
    ToneCurve,
}

/// The `camera` object every JSON output uses: `image_size` [w, h] and `fx`, `fy`, `cx`, `cy`
/// in pixels, `dist` as OpenCV's `[k1, k2, p1, p2, k3]` (see [`CameraJson`]).
pub fn camera_json(c: &CameraModel) -> serde_json::Value {
    serde_json::to_value(CameraJson::from(c)).expect("numbers and arrays always serialize")
}

/// Reads a calibration from `path`.
pub fn load(path: &Path) -> Result<Calibration, CalibrationError> {
    let name = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|cause| CalibrationError::Io { path: name.clone(), cause })?;
    from_bytes(&bytes, path)
}

/// The calibration in `bytes`, read from `path`: for a command that also records which
/// file it used (its hash), from the very bytes it used.
pub fn from_bytes(bytes: &[u8], path: &Path) -> Result<Calibration, CalibrationError> {
    if bytes.starts_with(&unit_file::MAGIC) {
        parse_unit_file(bytes, path)
    } else {
        parse_laser_json(bytes, path)
    }
}

/// Reads a signed unit file whose signature matches its contents (a tampered file is
/// refused; whether the signer is trusted is for `fslcal verify` to say).
pub fn parse_unit_file(bytes: &[u8], path: &Path) -> Result<Calibration, CalibrationError> {
    let err = |cause| CalibrationError::UnitFile { path: path.display().to_string(), cause };
    let file = unit_file::SignedUnitFile::decode(bytes).map_err(err)?;
    file.check_signature().map_err(err)?;
    Ok(from_unit_file(&file, path))
}

/// The calibration a decoded unit file holds.
pub fn from_unit_file(file: &unit_file::SignedUnitFile<'_>, path: &Path) -> Calibration {
    let c = &file.contents;
    Calibration {
        camera: c.camera,
        laser: c.laser,
        laser_covariance: c.laser_covariance,
        depth_range_m: c.depth_range_m.map(|[a, b]| (a as f64, b as f64)),
        unit: Some(c.unit.to_string()),
        camera_serial: c.camera_identity.serial.map(str::to_string),
        // The unit file does not record the zoom; only the JSON result carries it.
        focal_length_mm: None,
        laser_colour: c.laser_colour,
        source: path.to_path_buf(),
    }
}

/// Reads the laser result `fslcal laser --out` writes (any schema version up to this
/// build's; a file from before `schema_version` is version 1).
fn parse_laser_json(bytes: &[u8], path: &Path) -> Result<Calibration, CalibrationError> {
    let name = path.display().to_string();
    let r: LaserDocument = serde_json::from_slice(bytes)
        .map_err(|e| CalibrationError::NotACalibration { path: name.clone(), why: e.to_string() })?;
    check_schema(r.schema_version).map_err(|cause| CalibrationError::Newer { path: name.clone(), cause })?;
    let camera = CameraModel::from(&r.camera);
    if !camera.is_plausible() {
        return Err(CalibrationError::Implausible { path: name, why: Implausibility::Camera });
    }
    let laser = LaserLine::from_point_direction(
        fslcal_core::Vec3::from(r.laser.origin_m),
        fslcal_core::Vec3::from(r.laser.direction),
    )
    .ok_or_else(|| CalibrationError::Implausible { path: name.clone(), why: Implausibility::LaserBackward })?;
    if r.laser.covariance.iter().flatten().any(|v| !v.is_finite()) {
        return Err(CalibrationError::Implausible { path: name, why: Implausibility::Covariance });
    }
    if r.laser_colour.is_some_and(|c| crate::dot::colour::ToneCurve::power(c.tone_gamma).is_none()) {
        return Err(CalibrationError::Implausible { path: name, why: Implausibility::ToneCurve });
    }
    Ok(Calibration {
        camera,
        laser,
        laser_covariance: r.laser.covariance,
        depth_range_m: r.depth_range_m,
        unit: r.unit,
        camera_serial: r.camera_serial,
        focal_length_mm: r.focal_length_mm,
        laser_colour: r.laser_colour.map(|c| LaserColour {
            rgb: c.rgb.map(|v| v as f32),
            spread_rad: c.spread_rad as f32,
            dots: c.dots,
            tone_gamma: c.tone_gamma as f32,
        }),
        source: path.to_path_buf(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dot::colour::ColourSource;
    use fslcal_core::Distortion;

    fn example() -> serde_json::Value {
        let camera = CameraModel {
            width_px: 4000,
            height_px: 3000,
            fx_px: 2900.0,
            fy_px: 2901.0,
            cx_px: 1999.5,
            cy_px: 1499.5,
            distortion: Distortion::from_opencv([-0.1, 0.03, 0.001, -0.002, 0.0]),
        };
        serde_json::json!({
            "camera": camera_json(&camera),
            "laser": {
                "origin_m": [-0.04, -0.105, 0.0],
                "direction": [0.0105, 0.022, 0.9997],
                "covariance": [[1e-8, 0.0, 0.0, 0.0], [0.0, 1e-8, 0.0, 0.0], [0.0, 0.0, 1e-9, 0.0], [0.0, 0.0, 0.0, 1e-9]],
            },
            "depth_range_m": [0.6, 4.5],
        })
    }

    #[test]
    fn reads_what_laser_out_writes() {
        let text = serde_json::to_vec(&example()).unwrap();
        let cal = parse_laser_json(&text, Path::new("x.json")).unwrap();
        assert_eq!(cal.camera.fy_px, 2901.0);
        assert_eq!(cal.camera.distortion.p2, -0.002);
        assert!((cal.laser.dir().norm() - 1.0).abs() < 1e-12);
        assert_eq!(cal.depth_range_m, Some((0.6, 4.5)));
        // Dots are searched for a little nearer than the calibrated span, and at least down
        // to the working range's 0.5 m, and out to 6 m beyond it, where far dots crowd
        // towards the line's vanishing point.
        let (near, far) = cal.line_search().depths_m;
        assert!((near - 0.5).abs() < 1e-9 && far == 6.0, "{near} {far}");
        let mut v = example();
        v["depth_range_m"] = serde_json::json!([0.5, 4.5]);
        let close = parse_laser_json(&serde_json::to_vec(&v).unwrap(), Path::new("x.json")).unwrap();
        assert!((close.line_search().depths_m.0 - 0.425).abs() < 1e-9, "{:?}", close.line_search().depths_m);
        // Depth sigma grows with depth for a fixed covariance.
        let (a, b) = (cal.distance_sigma_m(1.0).unwrap(), cal.distance_sigma_m(4.0).unwrap());
        assert!(a > 0.0 && b > 4.0 * a, "{a} {b}");
    }

    #[test]
    fn searches_along_the_learned_laser_colour_and_the_prior_without_one() {
        let plain = parse_laser_json(&serde_json::to_vec(&example()).unwrap(), Path::new("x.json")).unwrap();
        assert_eq!(plain.dot_detector().colour.source, ColourSource::Prior);
        let mut v = example();
        // A yellow-green laser: its learned direction, not the prior's, is what is scored.
        v["laser_colour"] = serde_json::json!({"rgb": [0.55, 0.82, 0.12], "spread_rad": 0.08, "dots": 11});
        let cal = parse_laser_json(&serde_json::to_vec(&v).unwrap(), Path::new("x.json")).unwrap();
        let colour = cal.line_search().detector.colour;
        assert_eq!(colour.source, ColourSource::Learned { dots: 11 });
        assert!((colour.rgb[0] - 0.55).abs() < 0.01 && (colour.rgb[2] - 0.12).abs() < 0.01, "{colour:?}");
        // A pigment of the prior's bluish green passes the prior better than this laser's colour.
        let bluish = [0.15 * 40.0, 0.9 * 40.0, 0.4 * 40.0];
        assert!(colour.score(bluish, 20, 2.0).sigmas < plain.dot_detector().colour.score(bluish, 20, 2.0).sigmas);
        // Written before the tone curve was learned: read as linear.
        assert_eq!(colour.tone.gamma(), 1.0);
    }

    #[test]
    fn reads_photos_through_the_learned_tone_curve_and_refuses_an_impossible_one() {
        let mut v = example();
        v["laser_colour"] =
            serde_json::json!({"rgb": [0.3, 0.9, 0.3], "spread_rad": 0.08, "dots": 9, "tone_gamma": 2.25});
        let cal = parse_laser_json(&serde_json::to_vec(&v).unwrap(), Path::new("x.json")).unwrap();
        let tone = cal.line_search().detector.colour.tone;
        assert_eq!(tone.gamma(), 2.25);
        // Level 128 of an sRGB-like JPEG is a fifth of white in light.
        assert_eq!(tone.table().map(|t| t[128]), Some(54));
        v["laser_colour"]["tone_gamma"] = serde_json::json!(0.4);
        let e = parse_laser_json(&serde_json::to_vec(&v).unwrap(), Path::new("x.json")).unwrap_err().to_string();
        assert!(e.starts_with("x.json") && e.contains("tone curve"), "{e}");
    }

    #[test]
    fn reads_a_signed_unit_file_and_refuses_a_tampered_one() {
        let dir = tempfile::tempdir().unwrap();
        let mut buf = [0u8; unit_file::MAX_FILE_BYTES];
        let n = unit_file::example().sign(&unit_file::EXAMPLE_SECRET_KEY, &mut buf).unwrap();
        let path = dir.path().join("FSL-03.fslcal");
        std::fs::write(&path, &buf[..n]).unwrap();
        let cal = load(&path).unwrap();
        assert_eq!(cal.unit.as_deref(), Some("FSL-03"));
        assert_eq!(cal.camera_serial.as_deref(), Some("BJ7654321"));
        assert_eq!(cal.camera.fx_px, 2912.5);
        assert_eq!(cal.laser.origin_m, [-0.0405, -0.1055, 0.0]);
        assert_eq!(cal.depth_range_m, Some((0.75, 4.5)));
        assert_eq!(cal.laser_covariance[1][0], 1.0e-9);
        // The colour the calibration learned is what the along-line search scores.
        assert_eq!(cal.line_search().detector.colour.source, ColourSource::Learned { dots: 14 });
        buf[60] ^= 0x01; // inside fx
        std::fs::write(&path, &buf[..n]).unwrap();
        let msg = load(&path).unwrap_err().to_string();
        assert!(msg.contains("FSL-03.fslcal: tampered"), "{msg}");
    }

    #[test]
    fn refuses_a_newer_schema_and_reads_an_explicit_version_1() {
        let mut v = example();
        v["schema_version"] = 1.into();
        assert!(parse_laser_json(&serde_json::to_vec(&v).unwrap(), Path::new("x.json")).is_ok());
        v["schema_version"] = 2.into();
        let msg = parse_laser_json(&serde_json::to_vec(&v).unwrap(), Path::new("new.json")).unwrap_err().to_string();
        assert!(msg.starts_with("new.json: written by a newer fslcal (schema_version 2"), "{msg}");
    }

    #[test]
    fn refuses_other_json_with_the_file_name() {
        let err = parse_laser_json(br#"{"photos": []}"#, Path::new("other.json")).unwrap_err();
        let msg = err.to_string();
        assert!(msg.starts_with("other.json: not a calibration file"), "{msg}");
        assert!(!msg.contains('\n'));
    }
}
