//! A fish's length from its end points, the laser dot and a calibration, with its 1-sigma,
//! and the reasons to withhold a number rather than print a wrong one.

use crate::calibration::Calibration;
use crate::dot::on_line::DotOnLineError;
use crate::photo::exif::PhotoExif;
use crate::photo::identity::{check_photo, ExpectedCamera};
use crate::reason::Reason;
use fslcal_core::{CameraModel, Vec2};
use serde::{Deserialize, Serialize};
use std::fmt;
use std::path::{Path, PathBuf};

/// Why a fish's length is not given; in JSON an object whose `flag` names the kind.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "flag")]
pub enum Withheld {
    /// No laser dot in the photo (or none clear enough): no distance.
    NoDot { why: Reason<DotMissing> },
    /// The dot is farther from the calibrated laser's image than the calibration's
    /// uncertainty and the dot's localisation explain: the laser has moved, or the dot is
    /// a reflection; the calibration does not hold for this photo. Pixels.
    DotOffLaserLine { offset_px: f64, allowed_px: f64 },
    /// The dot's distance lies outside the depths the calibration's dots covered, metres.
    OutsideCalibratedRange { distance_m: f64, range_m: (f64, f64) },
    /// Part of the fish may be outside the frame.
    CutByEdge,
    /// The photo cannot come from the calibrated camera body (or mode).
    OtherCameraBody { why: Reason<BodyMismatch> },
    /// The fish's end points could not be found.
    NoEnds { why: Reason<EndsMissing> },
    /// The geometry failed (ray parallel to the laser, pixels outside the model's range).
    Geometry { why: Reason<GeometryFailure> },
}

impl Withheld {
    /// The `flag` the JSON and the CSV name this kind by.
    pub fn flag_name(&self) -> &'static str {
        match self {
            Withheld::NoDot { .. } => "no_dot",
            Withheld::DotOffLaserLine { .. } => "dot_off_laser_line",
            Withheld::OutsideCalibratedRange { .. } => "outside_calibrated_range",
            Withheld::CutByEdge => "cut_by_edge",
            Withheld::OtherCameraBody { .. } => "other_camera_body",
            Withheld::NoEnds { .. } => "no_ends",
            Withheld::Geometry { .. } => "geometry",
        }
    }

    /// One line for the summary table.
    pub fn describe(&self) -> String {
        self.to_string()
    }
}

impl fmt::Display for Withheld {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Withheld::NoDot { why } => write!(f, "no laser dot: {why}"),
            Withheld::DotOffLaserLine { offset_px, allowed_px } => write!(
                f,
                "dot {offset_px:.1} px off the laser line (allowed {allowed_px:.1} px): calibration does not hold"
            ),
            Withheld::OutsideCalibratedRange { distance_m, range_m } => {
                write!(f, "distance {distance_m:.2} m outside the calibrated {:.2}-{:.2} m", range_m.0, range_m.1)
            }
            Withheld::CutByEdge => f.write_str("fish cut by the frame edge"),
            Withheld::OtherCameraBody { why } => write!(f, "another camera: {why}"),
            Withheld::NoEnds { why } => write!(f, "no end points: {why}"),
            Withheld::Geometry { why } => f.write_str(why),
        }
    }
}

/// Why a fish photo has no dot to measure with.
#[derive(Clone, Debug, PartialEq)]
pub enum DotMissing {
    /// The search along the calibrated laser's image found no clear dot.
    NotFound(DotOnLineError),
    /// The photo could not be decoded for the search; the decoder's message.
    Unreadable { message: String },
    /// This build cannot search photos for dots.
    NoVision,
}

impl fmt::Display for DotMissing {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            DotMissing::NotFound(e) => e.fmt(f),
            DotMissing::Unreadable { message } => f.write_str(message),
            DotMissing::NoVision => {
                f.write_str("built without the vision feature, so dots must be given (--dot, --dots or labels)")
            }
        }
    }
}

/// Why a photo cannot come from the calibrated camera.
#[derive(Clone, Debug, PartialEq)]
pub enum BodyMismatch {
    /// Another image size, pixels: another camera or mode.
    ImageSize { photo: (u32, u32), calibration: (u32, u32) },
    /// Another body serial in the photo's EXIF.
    Serial { photo: String, calibration: String },
}

impl fmt::Display for BodyMismatch {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            BodyMismatch::ImageSize { photo, calibration } => write!(
                f,
                "photo is {}x{}, the calibration is for {}x{}",
                photo.0, photo.1, calibration.0, calibration.1
            ),
            BodyMismatch::Serial { photo, calibration } => {
                write!(f, "taken with body {photo}, the calibration is for body {calibration}")
            }
        }
    }
}

/// Why a fish's end points are not known.
#[derive(Clone, Debug, PartialEq)]
pub enum EndsMissing {
    /// The photo itself cannot be read; the reader's message.
    PhotoUnreadable { message: String },
    /// No mask in the masks folder names the photo.
    NoMask { dir: PathBuf },
    /// The mask is unusable or shows no fish whose ends can be found; the mask's error.
    Mask { message: String },
    /// The mask is not the photo's size.
    MaskSize { mask: PathBuf },
    /// The labels were clicked on an image that cannot be placed on the photo (neither is a
    /// known crop of the other); the frame's message.
    LabelFrame { message: String },
}

impl fmt::Display for EndsMissing {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            EndsMissing::PhotoUnreadable { message } => write!(f, "cannot read the photo: {message}"),
            EndsMissing::NoMask { dir } => write!(f, "no mask for it in {}", dir.display()),
            EndsMissing::Mask { message } => f.write_str(message),
            EndsMissing::MaskSize { mask } => write!(f, "{}: mask size differs from the photo's", mask.display()),
            EndsMissing::LabelFrame { message } => f.write_str(message),
        }
    }
}

/// Where the geometry of a measurement has no answer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GeometryFailure {
    RayMissesLaser,
    LaserImageUndefined,
    EndOutsideModel,
}

impl fmt::Display for GeometryFailure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            GeometryFailure::RayMissesLaser => "the dot's ray never meets the laser in front of the camera",
            GeometryFailure::LaserImageUndefined => "the laser's image is not defined here",
            GeometryFailure::EndOutsideModel => "an end point is outside the camera model's range",
        })
    }
}

impl From<GeometryFailure> for Withheld {
    fn from(why: GeometryFailure) -> Self {
        Withheld::Geometry { why: why.into() }
    }
}

/// How much to trust the inputs besides the calibration.
#[derive(Clone, Copy, Debug)]
pub struct MeasureParams {
    /// 1-sigma of the dot's centre, pixels.
    pub dot_sigma_px: f64,
    /// A dot farther than this many sigmas from the laser's image is off the line.
    pub max_dot_offset_sigma: f64,
    /// Measure photos from another camera body than the calibration's.
    pub allow_other_body: bool,
}

impl Default for MeasureParams {
    fn default() -> Self {
        MeasureParams { dot_sigma_px: 1.0, max_dot_offset_sigma: 3.0, allow_other_body: false }
    }
}

/// A length with where it came from: metres, and the dot's offset from the laser's image in
/// pixels. The 1-sigmas that need the calibration's covariance are `None` when it is
/// unknown (an imported calibration): the dot's part alone would understate them.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Length {
    pub length_m: f64,
    pub distance_m: f64,
    pub length_sigma_m: Option<f64>,
    pub distance_sigma_m: Option<f64>,
    /// The distance's 1-sigma from the calibration's covariance alone, and from the dot's
    /// localisation alone.
    pub distance_sigma_calibration_m: Option<f64>,
    pub distance_sigma_dot_m: f64,
    pub dot_offset_px: f64,
}

/// The laser's image near depth `z_m` moves by this covariance of its pixel
/// (2x2, from the calibration's 4x4 covariance of origin and direction slopes).
fn laser_pixel_covariance(cal: &Calibration, z_m: f64) -> Option<[[f64; 2]; 2]> {
    let base = cal.laser.pixel_at_depth(&cal.camera, z_m)?;
    let o = cal.laser.origin();
    let d = cal.laser.dir();
    let (sx, sy) = (d.x / d.z, d.y / d.z);
    let params = [o.x, o.y, sx, sy];
    let mut jac = [[0.0; 4]; 2];
    for k in 0..4 {
        let h = if k < 2 { 1e-6 } else { 1e-7 };
        let mut p = params;
        p[k] += h;
        let line = fslcal_core::LaserLine::from_point_direction(
            fslcal_core::Vec3::new(p[0], p[1], 0.0),
            fslcal_core::Vec3::new(p[2], p[3], 1.0),
        )?;
        let moved = line.pixel_at_depth(&cal.camera, z_m)?;
        jac[0][k] = (moved.x - base.x) / h;
        jac[1][k] = (moved.y - base.y) / h;
    }
    let c = &cal.laser_covariance;
    let mut out = [[0.0; 2]; 2];
    for i in 0..2 {
        for j in 0..2 {
            out[i][j] = (0..4).map(|a| (0..4).map(|b| jac[i][a] * c[a][b] * jac[j][b]).sum::<f64>()).sum();
        }
    }
    Some(out)
}

/// The fish's length at the dot's distance, or why not. `length_over_chord` scales the
/// straight pixel length for a fish measured along its bent spine (1 otherwise).
pub fn measure(
    cal: &Calibration,
    head_px: Vec2,
    tail_px: Vec2,
    length_over_chord: f64,
    dot_px: Vec2,
    params: &MeasureParams,
) -> Result<Length, Withheld> {
    let camera: &CameraModel = &cal.camera;
    let fix = cal.laser.fix_from_pixel(camera, dot_px).ok_or(GeometryFailure::RayMissesLaser)?;
    let z = fix.depth_m;
    // Off the line: against the laser image's uncertainty across the line plus the dot's own.
    let offset_px = cal.laser.pixel_offset(camera, dot_px, 0.05, 50.0).ok_or(GeometryFailure::LaserImageUndefined)?;
    let along = match (cal.laser.pixel_at_depth(camera, z * 0.99), cal.laser.pixel_at_depth(camera, z * 1.01)) {
        (Some(a), Some(b)) => (b - a).try_normalize(1e-12),
        _ => None,
    }
    .unwrap_or(Vec2::x());
    let across = Vec2::new(-along.y, along.x);
    let cov = laser_pixel_covariance(cal, z).unwrap_or([[0.0; 2]; 2]);
    let across_var =
        across.x * across.x * cov[0][0] + 2.0 * across.x * across.y * cov[0][1] + across.y * across.y * cov[1][1];
    let allowed_px = params.max_dot_offset_sigma * (across_var.max(0.0) + params.dot_sigma_px.powi(2)).sqrt();
    if offset_px > allowed_px {
        return Err(Withheld::DotOffLaserLine { offset_px, allowed_px });
    }
    if let Some((near, far)) = cal.depth_range_m {
        if !(near..=far).contains(&z) {
            return Err(Withheld::OutsideCalibratedRange { distance_m: z, range_m: (near, far) });
        }
    }
    let chord_m = camera.length_at_depth(head_px, tail_px, z).ok_or(GeometryFailure::EndOutsideModel)?;
    let length_m = chord_m * length_over_chord;
    // The dot's localisation moves the distance along the laser's image.
    let depth_at = |p: Vec2| cal.laser.fix_from_pixel(camera, p).map(|f| f.depth_m);
    let sigma_dot = match (depth_at(dot_px - along * 0.5), depth_at(dot_px + along * 0.5)) {
        (Some(a), Some(b)) => (b - a).abs() * params.dot_sigma_px,
        _ => 0.0,
    };
    // Unknown when the calibration's covariance is (never taken as zero, which would leave
    // the dot's part alone and read as far more certain than it is).
    let sigma_cal = cal.distance_sigma_m(z);
    let distance_sigma_m = sigma_cal.map(|c| c.hypot(sigma_dot));
    Ok(Length {
        length_m,
        distance_m: z,
        // Length is proportional to distance (L = D n w / f).
        length_sigma_m: distance_sigma_m.map(|s| length_m * s / z),
        distance_sigma_m,
        distance_sigma_calibration_m: sigma_cal,
        distance_sigma_dot_m: sigma_dot,
        dot_offset_px: offset_px,
    })
}

/// Whether the photo at `photo`, of `size`, can come from the calibrated camera: the same
/// image size, and (where both record one) the same body serial in its EXIF, unless
/// `allow_other_body`.
pub fn camera_body_mismatch(
    cal: &Calibration,
    photo: &Path,
    size: (u32, u32),
    allow_other_body: bool,
) -> Option<Withheld> {
    let want = (cal.camera.width_px, cal.camera.height_px);
    if size != want {
        let why = BodyMismatch::ImageSize { photo: size, calibration: want };
        return Some(Withheld::OtherCameraBody { why: why.into() });
    }
    let expected = ExpectedCamera::from(cal);
    expected.serial.as_ref()?;
    let exif = PhotoExif::read_file(photo);
    check_photo(&expected, photo, exif.as_ref(), allow_other_body).err().map(|refusal| {
        let why = BodyMismatch::Serial { photo: refusal.photo_serial, calibration: refusal.expected_serial };
        Withheld::OtherCameraBody { why: why.into() }
    })
}

/// Whether labelled end points lie within `margin_px` of the frame: the fish may run out of it.
pub fn ends_at_edge(size: (u32, u32), ends: [Vec2; 2], margin_px: f64) -> bool {
    ends.iter().any(|p| {
        p.x < margin_px - 0.5
            || p.y < margin_px - 0.5
            || p.x > size.0 as f64 - 0.5 - margin_px
            || p.y > size.1 as f64 - 0.5 - margin_px
    })
}

/// A length distribution: count, mean, percentiles and a histogram with a round bin width.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Distribution {
    pub n: usize,
    pub mean_m: f64,
    /// (percent, length in metres) for 5, 25, 50, 75, 95.
    pub percentiles_m: Vec<(u32, f64)>,
    pub bin_width_m: f64,
    /// (from, to, count), from the first non-empty bin to the last.
    pub histogram: Vec<(f64, f64, usize)>,
}

/// Percentile by linear interpolation between order statistics.
fn percentile(sorted: &[f64], p: f64) -> f64 {
    let r = p / 100.0 * (sorted.len() - 1) as f64;
    let (i, f) = (r.floor() as usize, r - r.floor());
    sorted[i] + (sorted[(i + 1).min(sorted.len() - 1)] - sorted[i]) * f
}

/// The distribution of `lengths_m`; `None` when empty.
pub fn distribution(lengths_m: &[f64]) -> Option<Distribution> {
    let mut s: Vec<f64> = lengths_m.iter().copied().filter(|v| v.is_finite()).collect();
    if s.is_empty() {
        return None;
    }
    s.sort_by(f64::total_cmp);
    let (lo, hi) = (s[0], s[s.len() - 1]);
    // About ten bins of 1, 2 or 5 times a power of ten (at least a millimetre).
    let raw = ((hi - lo) / 10.0).max(1e-3);
    let mag = 10f64.powf(raw.log10().floor());
    let width = [1.0, 2.0, 5.0, 10.0].iter().map(|m| m * mag).find(|w| *w >= raw * (1.0 - 1e-9)).unwrap_or(10.0 * mag);
    let first = (lo / width).floor() as i64;
    let last = (hi / width).floor() as i64;
    let histogram = (first..=last)
        .map(|k| {
            let (a, b) = (k as f64 * width, (k + 1) as f64 * width);
            (a, b, s.iter().filter(|&&v| v >= a && (v < b || (k == last && v <= b))).count())
        })
        .collect();
    Some(Distribution {
        n: s.len(),
        mean_m: s.iter().sum::<f64>() / s.len() as f64,
        percentiles_m: [5, 25, 50, 75, 95].iter().map(|&p| (p, percentile(&s, p as f64))).collect(),
        bin_width_m: width,
        histogram,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distribution_bins_and_percentiles() {
        let v: Vec<f64> = (0..101).map(|i| 0.20 + 0.001 * i as f64).collect();
        let d = distribution(&v).unwrap();
        assert_eq!(d.n, 101);
        assert!((d.percentiles_m[2].1 - 0.25).abs() < 1e-12);
        assert!((d.bin_width_m - 0.01).abs() < 1e-12);
        assert_eq!(d.histogram.iter().map(|h| h.2).sum::<usize>(), 101);
        assert!(distribution(&[]).is_none());
    }

    #[test]
    fn flags_are_named_as_serde_tags_them_and_read_back() {
        let all = [
            Withheld::NoDot {
                why: DotMissing::NotFound(DotOnLineError::NoDot { half_width_px: 80.0, refused: Vec::new() }).into(),
            },
            Withheld::DotOffLaserLine { offset_px: 25.3, allowed_px: 3.1 },
            Withheld::OutsideCalibratedRange { distance_m: 1.03, range_m: (0.5, 0.8) },
            Withheld::CutByEdge,
            Withheld::OtherCameraBody {
                why: BodyMismatch::ImageSize { photo: (800, 600), calibration: (4000, 3000) }.into(),
            },
            Withheld::NoEnds { why: EndsMissing::NoMask { dir: "masks".into() }.into() },
            GeometryFailure::EndOutsideModel.into(),
        ];
        for w in &all {
            let v = serde_json::to_value(w).unwrap();
            assert_eq!(v["flag"], w.flag_name());
            let back: Withheld = serde_json::from_value(v.clone()).unwrap();
            assert_eq!(serde_json::to_value(&back).unwrap(), v);
            assert_eq!(back.describe(), w.describe());
        }
        assert_eq!(serde_json::to_value(&all[4]).unwrap()["why"], "photo is 800x600, the calibration is for 4000x3000");
        assert_eq!(all[5].describe(), "no end points: no mask for it in masks");
    }
}
