//! `fslcal validate`: a known length on a target measured the way a fish is measured.
//!
//! The scale comes from the laser dot and the calibration only (the dot's distance by the
//! thesis's closest-point rule), never from the target's pose; the target's detection gives
//! only the two end points' pixels and, for the default rule, the plane's orientation. A
//! laser direction that is wrong within the plane of camera and laser changes the scale with
//! range, which one distance cannot show: with photos at several distances the slope of the
//! length error against distance is fitted and a significant trend fails the run.

use crate::calibration::Calibration;
use crate::dot::on_line::{choose, line_candidates, DotOnLineError, LineCandidate};
use crate::laser::outcome::TargetMiss;
use crate::laser::pipeline::LaserError;
use crate::laser::target::{locate_target, LocatedTarget, Target};
use crate::reason::Reason;
use fslcal_core::{DotFix, Plane, Vec2, Vec3};
use rayon::prelude::*;
use std::path::{Path, PathBuf};

pub use super::outcome::{LengthRule, PhotoValidation, ValidationOutcome, ValidationSkip};

/// Largest relative disagreement between a blob's distance by the laser and by the target's
/// plane for the blob to be taken as the dot.
const MAX_DISTANCE_DISAGREEMENT: f64 = 0.3;

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
}

/// The run's result.
#[derive(Clone, Debug)]
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
    #[error(transparent)]
    Photo(#[from] LaserError),
    #[error("the slate has no length named `{name}` (it has: {have}); see docs/slate.md")]
    NoSuchLength { name: String, have: String },
    #[error("the slate defines no known length; add a [[length]] to its TOML (docs/slate.md)")]
    NoLengths,
    #[error("a checkerboard has one known length (the first row's outermost inner corners); --length does not apply")]
    LengthOnCheckerboard,
    /// Nothing to judge; the run, with every photo's line saying why, is kept for the
    /// summary, the JSON and the report.
    #[error("no photo could be measured (each photo's reason is listed)")]
    NothingMeasured(Box<Validation>),
}

/// The length a run measures: its name and end points in the target frame, metres.
struct KnownLength {
    name: String,
    from_m: Vec3,
    to_m: Vec3,
}

impl KnownLength {
    fn true_m(&self) -> f64 {
        (self.to_m - self.from_m).norm()
    }
}

/// The known length: name and its end points in the target frame, metres.
fn known_length(job: &ValidationJob) -> Result<KnownLength, ValidationError> {
    match &job.target {
        Target::Checkerboard(b) => {
            if job.length_name.is_some() {
                return Err(ValidationError::LengthOnCheckerboard);
            }
            let far = (b.inner_cols - 1) as f64 * b.square_m;
            Ok(KnownLength {
                name: "first row of inner corners".into(),
                from_m: Vec3::zeros(),
                to_m: Vec3::new(far, 0.0, 0.0),
            })
        }
        Target::Slate(m) => {
            let l = match &job.length_name {
                Some(n) => m.slate.length(Some(n)).ok_or_else(|| ValidationError::NoSuchLength {
                    name: n.clone(),
                    have: m.slate.lengths.iter().map(|l| l.name.as_str()).collect::<Vec<_>>().join(", "),
                })?,
                None => m.slate.length(None).ok_or(ValidationError::NoLengths)?,
            };
            Ok(KnownLength {
                name: l.name.clone(),
                from_m: Vec3::new(l.from_m[0], l.from_m[1], 0.0),
                to_m: Vec3::new(l.to_m[0], l.to_m[1], 0.0),
            })
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
    let length = known_length(job)?;
    let results: Vec<PhotoValidation> = photos
        .par_iter()
        .map(|path| -> Result<PhotoValidation, ValidationError> {
            let located = locate_target(&job.target, &job.cal.camera, path);
            progress();
            Ok(measure_photo(job, &length, path, located?))
        })
        .collect::<Result<_, _>>()?;
    judge(job, length, results)
}

/// One photo's line: the known length measured on its target, or why not.
fn measure_photo(
    job: &ValidationJob,
    length: &KnownLength,
    path: &Path,
    located: Result<LocatedTarget, Reason<TargetMiss>>,
) -> PhotoValidation {
    let mut out = PhotoValidation {
        file: path.display().to_string(),
        true_mm: length.true_m() * 1e3,
        ..PhotoValidation::default()
    };
    let measured = match located {
        Ok(t) => measure_on_target(job, length, &t, &mut out).map_err(Reason::from),
        Err(miss) => Err(miss.map(ValidationSkip::Target)),
    };
    if let Err(why) = measured {
        out.reason = Some(why);
    }
    out
}

/// Finds the dot on a photo's target, measures the known length from it and judges it
/// against the tolerance. Fills `out` as far as it gets; the error says where it stopped.
fn measure_on_target(
    job: &ValidationJob,
    length: &KnownLength,
    t: &LocatedTarget,
    out: &mut PhotoValidation,
) -> Result<(), ValidationSkip> {
    let camera = &job.cal.camera;
    out.target_inliers = t.inliers;
    out.target_outline_px = t.outline_px.clone();
    let (dot_px, fix) = choose_dot(job, t)?;
    out.dot_px = Some([dot_px.x, dot_px.y]);
    out.distance_m = Some(fix.depth_m);
    let ends = [length.from_m, length.to_m].map(|p| camera.project(&t.pose.to_camera(&p)));
    let [Some(a_px), Some(b_px)] = ends else {
        return Err(ValidationSkip::EndsBehindCamera);
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
    let measured = measured.ok_or(ValidationSkip::EndsOffPlane)?;
    let true_m = length.true_m();
    let error = 100.0 * (measured - true_m) / true_m;
    out.measured_mm = Some(measured * 1e3);
    out.error_pct = Some(error);
    out.pass = Some(error.abs() <= job.tolerance_pct);
    Ok(())
}

/// The dot: a candidate along the calibrated laser's image ([`line_candidates`]: offset
/// explained by the covariance, size and signal fitting its distance) that lies on the
/// target, and whose distance by the laser agrees with where its ray meets the target's
/// plane: a choice among candidates only; the scale still comes from the dot alone. A
/// calibration wrong out of the camera-beam plane leaves nothing on its line, and nothing
/// measured fails the run.
fn choose_dot(job: &ValidationJob, t: &LocatedTarget) -> Result<(Vec2, DotFix), ValidationSkip> {
    let (camera, laser) = (&job.cal.camera, &job.cal.laser);
    let search = job.cal.line_search();
    let plane = t.pose.plane();
    let all = line_candidates(&t.photo.colour(&search.detector.colour.tone), camera, laser, &search)
        .map_err(|_| ValidationSkip::NoDot)?;
    let on_target: Vec<LineCandidate> =
        all.into_iter().filter(|c| inside_convex(&t.outline_px, c.candidate.pixel)).collect();
    // Distance by the laser against the target's plane at the blob, as a log ratio.
    let disagreement = |c: &LineCandidate| {
        crate::laser::fit::dot_point(camera, &plane, c.candidate.pixel)
            .map_or(f64::INFINITY, |p| (c.gate.depth_m / p.z).ln().abs())
    };
    // A blob whose laser distance is far from the target's is not the dot (a wrong laser
    // direction of 0.5 deg moves the distance by under 20% at 2 m).
    let (agree, disagree): (Vec<LineCandidate>, Vec<LineCandidate>) =
        on_target.into_iter().partition(|c| disagreement(c) <= MAX_DISTANCE_DISAGREEMENT.ln_1p());
    match choose(&agree, search.band_half_width_px) {
        Ok(dot) => Ok((dot.pixel, laser.fix_from_pixel(camera, dot.pixel).ok_or(ValidationSkip::NoDot)?)),
        Err(DotOnLineError::Ambiguous { candidates_px, .. }) => Err(ValidationSkip::Ambiguous { candidates_px }),
        Err(_) => {
            match disagree.iter().filter(|c| c.plausible()).max_by(|a, b| a.candidate.snr.total_cmp(&b.candidate.snr)) {
                Some(c) => Err(ValidationSkip::NotTheDot {
                    by_laser_m: c.gate.depth_m,
                    on_target_m: crate::laser::fit::dot_point(camera, &plane, c.candidate.pixel)
                        .map_or(f64::NAN, |p| p.z),
                }),
                None => Err(ValidationSkip::NoDot),
            }
        }
    }
}

/// `p` inside the convex polygon `poly` (either winding); an empty outline holds everything.
fn inside_convex(poly: &[Vec2], p: Vec2) -> bool {
    if poly.len() < 3 {
        return true;
    }
    let sides = poly.iter().zip(poly.iter().cycle().skip(1)).map(|(a, b)| (b - a).perp(&(p - a)));
    let (mut pos, mut neg) = (false, false);
    for s in sides {
        pos |= s > 0.0;
        neg |= s < 0.0;
    }
    !(pos && neg)
}

/// The calibration's verdict from every photo's: each within the tolerance, and no real
/// trend of the error with distance.
fn judge(
    job: &ValidationJob,
    length: KnownLength,
    results: Vec<PhotoValidation>,
) -> Result<Validation, ValidationError> {
    let measured: Vec<(f64, f64)> = results.iter().filter_map(|p| p.distance_m.zip(p.error_pct)).collect();
    if measured.is_empty() {
        return Err(ValidationError::NothingMeasured(Box::new(Validation {
            true_mm: length.true_m() * 1e3,
            length_name: length.name,
            rule: job.rule,
            tolerance_pct: job.tolerance_pct,
            photos: results,
            slope_pct_per_m: None,
            trend_fails: false,
            pass: false,
        })));
    }
    let slope = slope(&measured);
    // A trend fails when it is real (over 3 sigma) and large enough to matter: across the
    // photos' distances it moves the length by more than half the tolerance.
    let span = measured.iter().map(|p| p.0).fold(f64::NEG_INFINITY, f64::max)
        - measured.iter().map(|p| p.0).fold(f64::INFINITY, f64::min);
    let trend_fails = slope.is_some_and(|(b, s)| b.abs() > 3.0 * s && b.abs() * span > 0.5 * job.tolerance_pct);
    let pass = !trend_fails && results.iter().all(|p| p.pass != Some(false));
    Ok(Validation {
        true_mm: length.true_m() * 1e3,
        length_name: length.name,
        rule: job.rule,
        tolerance_pct: job.tolerance_pct,
        photos: results,
        slope_pct_per_m: slope,
        trend_fails,
        pass,
    })
}
