//! `fslcal validate`: a known length on a target measured the way a fish is measured.
//!
//! The scale comes from the laser dot and the calibration only (the dot's distance by the
//! thesis's closest-point rule), never from the target's pose; the target's detection gives
//! only the two end points' pixels and, for the default rule, the plane's orientation. A
//! laser direction that is wrong within the plane of camera and laser changes the scale with
//! range, which one distance cannot show: with photos at several distances the slope of the
//! length error against distance is fitted and a significant trend fails the run.

use crate::calibration::Calibration;
use crate::dot::candidates::{DotDetectorParams, SearchRegion};
use crate::dot::on_line::{laser_image_polyline, DEFAULT_BAND_HALF_WIDTH_PX, DEFAULT_SEARCH_DEPTHS_M};
use crate::laser::pipeline::LaserError;
use crate::laser::target::{locate_target, Target};
use fslcal_core::{Plane, Vec2, Vec3};
use rayon::prelude::*;
use serde::Serialize;
use std::path::PathBuf;

/// Largest relative disagreement between a blob's distance by the laser and by the target's
/// plane for the blob to be taken as the dot.
const MAX_DISTANCE_DISAGREEMENT: f64 = 0.3;

/// How the two end points are put into 3D.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum LengthRule {
    /// The plane through the dot's 3D point with the target's detected orientation
    /// (orientation only, no distance): judges the calibration, not the photo's tilt.
    TiltedPlane,
    /// The thesis's rule: both ends at the dot's depth, as for a fish.
    FrontoParallel,
}

/// Settings of one run.
#[derive(Clone, Debug)]
pub struct ValidationJob {
    pub cal: Calibration,
    pub target: Target,
    /// A slate's named length; `None`: its first (a checkerboard has one).
    pub length_name: Option<String>,
    pub rule: LengthRule,
    /// Pass when |error| is at most this, percent.
    pub tolerance_pct: f64,
    pub detector: DotDetectorParams,
}

/// One photo's line.
#[derive(Clone, Debug, Serialize)]
pub struct PhotoValidation {
    pub file: String,
    pub measured_mm: Option<f64>,
    pub true_mm: f64,
    pub error_pct: Option<f64>,
    /// `None` for a skipped photo.
    pub pass: Option<bool>,
    pub distance_m: Option<f64>,
    pub dot_px: Option<[f64; 2]>,
    pub target_inliers: Option<usize>,
    pub reason: Option<String>,
    /// The target's outline and the length's end points in the image, pixels; kept for the
    /// HTML report, not the JSON.
    #[serde(skip)]
    pub target_outline_px: Vec<Vec2>,
    #[serde(skip)]
    pub ends_px: Option<[Vec2; 2]>,
}

/// The run's result.
#[derive(Clone, Debug, Serialize)]
pub struct Validation {
    pub length_name: String,
    pub true_mm: f64,
    pub rule: LengthRule,
    pub tolerance_pct: f64,
    pub photos: Vec<PhotoValidation>,
    /// Slope of the length error against distance, percent per metre, and its 1 sigma;
    /// `None` with fewer than three measured photos or less than 0.5 m between them.
    pub slope_pct_per_m: Option<(f64, f64)>,
    pub trend_fails: bool,
    pub pass: bool,
}

#[derive(Debug, thiserror::Error)]
pub enum ValidationError {
    #[error("{0}")]
    Photo(#[from] LaserError),
    #[error("the slate has no length named `{name}` (it has: {have}); see docs/slate.md")]
    NoSuchLength { name: String, have: String },
    #[error("the slate defines no known length; add a [[length]] to its TOML (docs/slate.md)")]
    NoLengths,
    #[error("a checkerboard has one known length (the first row's outermost inner corners); --length does not apply")]
    LengthOnCheckerboard,
    #[error("no photo could be measured; see the reasons above")]
    NothingMeasured,
}

/// The known length: name and its end points in the target frame, metres.
fn known_length(job: &ValidationJob) -> Result<(String, Vec3, Vec3), ValidationError> {
    match &job.target {
        Target::Checkerboard(b) => {
            if job.length_name.is_some() {
                return Err(ValidationError::LengthOnCheckerboard);
            }
            let far = (b.inner_cols - 1) as f64 * b.square_m;
            Ok(("first row of inner corners".into(), Vec3::zeros(), Vec3::new(far, 0.0, 0.0)))
        }
        Target::Slate(m) => {
            let l = match &job.length_name {
                Some(n) => m.slate.length(Some(n)).ok_or_else(|| ValidationError::NoSuchLength {
                    name: n.clone(),
                    have: m.slate.lengths.iter().map(|l| l.name.as_str()).collect::<Vec<_>>().join(", "),
                })?,
                None => m.slate.length(None).ok_or(ValidationError::NoLengths)?,
            };
            Ok((l.name.clone(), Vec3::new(l.from_m[0], l.from_m[1], 0.0), Vec3::new(l.to_m[0], l.to_m[1], 0.0)))
        }
    }
}

/// Least-squares slope of `y` against `x` and its 1 sigma from the scatter.
fn slope(points: &[(f64, f64)]) -> Option<(f64, f64)> {
    let n = points.len() as f64;
    if points.len() < 3 {
        return None;
    }
    let (mx, my) = (points.iter().map(|p| p.0).sum::<f64>() / n, points.iter().map(|p| p.1).sum::<f64>() / n);
    let sxx: f64 = points.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let (lo, hi) = points.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |a, p| (a.0.min(p.0), a.1.max(p.0)));
    if hi - lo < 0.5 {
        return None;
    }
    let b = points.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum::<f64>() / sxx;
    let ss: f64 = points.iter().map(|p| (p.1 - my - b * (p.0 - mx)).powi(2)).sum();
    Some((b, (ss / (n - 2.0) / sxx).sqrt()))
}

/// Measures the known length in every photo and judges the calibration.
pub fn validate(
    job: &ValidationJob,
    photos: &[PathBuf],
    progress: &(dyn Fn() + Sync),
) -> Result<Validation, ValidationError> {
    crate::vision::use_single_threaded_opencv();
    let (name, from_t, to_t) = known_length(job)?;
    let true_m = (to_t - from_t).norm();
    let (camera, laser) = (&job.cal.camera, &job.cal.laser);
    let line = laser_image_polyline(camera, laser, DEFAULT_SEARCH_DEPTHS_M);
    let results: Vec<PhotoValidation> = photos
        .par_iter()
        .map(|path| -> Result<PhotoValidation, ValidationError> {
            let mut out = PhotoValidation {
                file: path.display().to_string(),
                measured_mm: None,
                true_mm: true_m * 1e3,
                error_pct: None,
                pass: None,
                distance_m: None,
                dot_px: None,
                target_inliers: None,
                reason: None,
                target_outline_px: Vec::new(),
                ends_px: None,
            };
            let located = locate_target(&job.target, camera, path);
            progress();
            let t = match located? {
                Ok(t) => t,
                Err(why) => {
                    out.reason = Some(why);
                    return Ok(out);
                }
            };
            out.target_inliers = t.inliers;
            out.target_outline_px = t.outline_px.clone();
            // The dot: on the target, near the calibrated laser's image (a band wide enough
            // for a wrong calibration's dot, which is what this command must catch).
            let region = SearchRegion { polygon: t.outline_px.clone(), band: Some((line.clone(), DEFAULT_BAND_HALF_WIDTH_PX)) };
            // Among several blobs, the dot is the one whose distance by the laser agrees best
            // with where its ray meets the target's plane: a choice among candidates only;
            // the scale still comes from the dot alone.
            let plane = t.pose.plane();
            let candidates = job.target.find_dots(&t.photo.colour(), &region, &job.detector, 8);
            let chosen = candidates
                .iter()
                .filter_map(|c| {
                    let fix = laser.fix_from_pixel(camera, c.pixel)?;
                    let on_plane = crate::laser::fit::dot_point(camera, &plane, c.pixel)?;
                    Some((c, fix, (fix.depth_m / on_plane.z).ln().abs()))
                })
                .min_by(|a, b| a.2.total_cmp(&b.2));
            let Some((dot, fix, disagreement)) = chosen else {
                out.reason = Some("no laser dot found on the target near the calibrated laser's image".into());
                return Ok(out);
            };
            // A blob whose laser distance is far from the target's is not the dot (a wrong
            // laser direction of 0.5 deg moves the distance by under 20% at 2 m); a
            // calibration that wrong everywhere leaves nothing measured, which fails too.
            if disagreement > MAX_DISTANCE_DISAGREEMENT.ln_1p() {
                let on_plane = crate::laser::fit::dot_point(camera, &plane, dot.pixel).map_or(f64::NAN, |p| p.z);
                out.reason = Some(format!(
                    "the best dot-like blob gives {:.2} m by the laser but lies on the target at {on_plane:.2} m: not the dot, or a badly wrong calibration",
                    fix.depth_m
                ));
                return Ok(out);
            }
            out.dot_px = Some([dot.pixel.x, dot.pixel.y]);
            out.distance_m = Some(fix.depth_m);
            let ends = [from_t, to_t].map(|p| camera.project(&t.pose.to_camera(&p)));
            let [Some(a_px), Some(b_px)] = ends else {
                out.reason = Some("the length's end points are behind the camera".into());
                return Ok(out);
            };
            out.ends_px = Some([a_px, b_px]);
            let measured = match job.rule {
                LengthRule::FrontoParallel => camera.length_at_depth(a_px, b_px, fix.depth_m),
                LengthRule::TiltedPlane => {
                    let plane = Plane::through(fix.point_m, t.pose.rotation.column(2).into_owned());
                    let hit = |px| camera.ray(px).and_then(|r| plane.intersect(&Vec3::zeros(), &r)).map(|(p, _)| p);
                    hit(a_px).zip(hit(b_px)).map(|(a, b)| (a - b).norm())
                }
            };
            let Some(measured) = measured else {
                out.reason = Some("the length's end points could not be put on the plane".into());
                return Ok(out);
            };
            let error = 100.0 * (measured - true_m) / true_m;
            out.measured_mm = Some(measured * 1e3);
            out.error_pct = Some(error);
            out.pass = Some(error.abs() <= job.tolerance_pct);
            Ok(out)
        })
        .collect::<Result<_, _>>()?;
    let measured: Vec<(f64, f64)> = results.iter().filter_map(|p| p.distance_m.zip(p.error_pct)).collect();
    if measured.is_empty() {
        return Err(ValidationError::NothingMeasured);
    }
    let slope = slope(&measured);
    // A trend fails when it is real (over 3 sigma) and large enough to matter: across the
    // photos' distances it moves the length by more than half the tolerance.
    let span = measured.iter().map(|p| p.0).fold(f64::NEG_INFINITY, f64::max)
        - measured.iter().map(|p| p.0).fold(f64::INFINITY, f64::min);
    let trend_fails = slope.is_some_and(|(b, s)| b.abs() > 3.0 * s && b.abs() * span > 0.5 * job.tolerance_pct);
    let pass = !trend_fails && results.iter().all(|p| p.pass != Some(false));
    Ok(Validation {
        length_name: name,
        true_mm: true_m * 1e3,
        rule: job.rule,
        tolerance_pct: job.tolerance_pct,
        photos: results,
        slope_pct_per_m: slope,
        trend_fails,
        pass,
    })
}
