//! `fslcal check`: has the laser moved since it was calibrated?
//!
//! Every photo with a dot is a check, fish photos included, since no target is needed: a
//! rigid laser's dot lies on the image of the calibrated line. Drift is judged only from
//! dots the check is sure of, and a lone blob off the line is no proof of a moved laser (a
//! reflection, a glint), so the photos are judged together between two explanations:
//!
//! - **calibrated**: each photo's dot is a candidate whose offset from the line's image the
//!   calibration's covariance and its centring explain ([`fslcal_core::LaserLine::gate`]);
//! - **turned**: the beam has turned about its clamp, out of the plane of the camera centre
//!   and the beam, by one angle that every photo's candidate implies alike (the consensus
//!   angle over the photos' candidates).
//!
//! The turned laser is believed only when it explains the dots of at least
//! [`MIN_TURNED_PHOTOS`] photos and more photos than the calibrated one does. A sure dot is
//! one clear candidate under the believed explanation; it is flagged beyond [`FLAG_SIGMAS`]
//! of what the calibration explains, and the laser is called drifted when at least half the
//! sure dots are flagged. The implied direction change is the median over the sure dots.
//!
//! A laser turned *within* the plane of the camera centre and the beam moves its dot along
//! the line's image, which no dot can show: that error changes the scale with range and is
//! what `fslcal validate`'s trend test catches.

use crate::calibration::Calibration;
use crate::dot::on_line::{choose, judge_candidate, line_candidates, LineCandidate, LineDot, LineSearch, Refusal};
use crate::laser::target::strip_path;
use crate::vision::{EncodedPhoto, Photo};
use fslcal_core::{CameraModel, LaserLine};
use rayon::prelude::*;
use std::path::{Path, PathBuf};

pub use super::outcome::{CandidateCheck, CheckOutcome, CheckSkip, PhotoCheck};

/// A sure dot is flagged when its offset exceeds this many sigmas of what is explained.
pub const FLAG_SIGMAS: f64 = 5.0;
/// Fewest photos whose candidates must agree on one turn of the beam before it is believed
/// (and they must outnumber the photos the calibrated laser explains): one off-line blob is
/// a reflection or a glint, two at the same implied turn within 3.3 sigma are a moved laser.
pub const MIN_TURNED_PHOTOS: usize = 2;
/// A candidate agrees with a turn when its implied turn is within this many of its sigmas.
const TURN_AGREEMENT_SIGMAS: f64 = 3.29;

#[derive(Clone, Debug)]
pub struct DriftCheck {
    pub photos: Vec<PhotoCheck>,
    pub drifted: bool,
    /// Photos with a dot the check is sure of: the only ones drift is judged from.
    pub sure_dots: usize,
    /// Median over the sure dots of the implied change of the beam's direction, degrees.
    pub implied_direction_change_deg: Option<f64>,
}

#[derive(Debug, thiserror::Error)]
pub enum CheckError {
    #[error("{file}: the photo is {photo_w}x{photo_h} but the calibration's camera is {camera_w}x{camera_h}; use the calibration made for this camera (resized photos cannot be used)")]
    ImageSize { file: String, photo_w: u32, photo_h: u32, camera_w: u32, camera_h: u32 },
    /// Nothing to judge; every photo's line says why.
    #[error("no photo has a laser dot the check is sure of (each photo's reason is listed)")]
    NoDots { photos: Vec<PhotoCheck> },
}

/// Checks every photo against the calibration.
pub fn check(cal: &Calibration, photos: &[PathBuf], progress: &(dyn Fn() + Sync)) -> Result<DriftCheck, CheckError> {
    let search = cal.line_search();
    let found: Vec<(PhotoCheck, Vec<LineCandidate>)> = photos
        .par_iter()
        .map(|path| -> Result<(PhotoCheck, Vec<LineCandidate>), CheckError> {
            let photo = decode(path, cal);
            progress();
            let mut out = PhotoCheck { file: path.display().to_string(), ..PhotoCheck::default() };
            let candidates = match photo? {
                Ok(photo) => {
                    match line_candidates(&photo.colour(&search.detector.colour.tone), &cal.camera, &cal.laser, &search)
                    {
                        Ok(c) => c,
                        Err(e) => {
                            out.reason = Some(CheckSkip::NoDot(e).into());
                            Vec::new()
                        }
                    }
                }
                Err(why) => {
                    out.reason = Some(why.into());
                    Vec::new()
                }
            };
            Ok((out, candidates))
        })
        .collect::<Result<_, _>>()?;
    let believed = believed_laser(cal, &found);
    let mut results = Vec::with_capacity(found.len());
    for (mut out, candidates) in found {
        if out.reason.is_none() {
            judge_photo(cal, &search, &believed, &candidates, &mut out);
        }
        results.push(out);
    }
    let sure: Vec<&PhotoCheck> = results.iter().filter(|p| p.explained_sigma_px.is_some()).collect();
    if sure.is_empty() {
        return Err(CheckError::NoDots { photos: results });
    }
    let flagged = sure.iter().filter(|p| p.flag).count();
    let mut changes: Vec<f64> = sure.iter().filter_map(|p| p.direction_change_deg).collect();
    changes.sort_by(f64::total_cmp);
    let implied = (!changes.is_empty()).then(|| changes[changes.len() / 2].abs());
    Ok(DriftCheck {
        drifted: flagged > 0 && 2 * flagged >= sure.len(),
        sure_dots: sure.len(),
        photos: results,
        implied_direction_change_deg: implied,
    })
}

/// The laser the photos are judged against: the calibrated one, or the calibrated one
/// turned by the angle most photos' candidates agree on, when that explains at least
/// [`MIN_TURNED_PHOTOS`] photos and more than the calibrated laser does.
fn believed_laser(cal: &Calibration, found: &[(PhotoCheck, Vec<LineCandidate>)]) -> LaserLine {
    // Photos the calibrated laser explains: those with a plausible blob on its line, clear
    // or not, counted as the turned laser's support is (an agreeing blob, clear or not). A
    // photo withheld as ambiguous between blobs on the calibrated line is no vote for a
    // turn: counting only clear choices let two faint blobs 8 px off the line outvote two
    // photos with their dots on it and called a drift (tuning target-less seed 3).
    let calibrated = found.iter().filter(|(_, c)| c.iter().any(LineCandidate::plausible)).count();
    // Each off-line candidate's implied turn and its sigma (the gate's pixel sigma through
    // the turn's pixel rate, f * along / depth); blobs the calibrated laser explains, or
    // whose size or signal rule them out, vote for no turn.
    let turns: Vec<Vec<(f64, f64)>> = found
        .iter()
        .map(|(_, cands)| {
            cands
                .iter()
                .filter(|c| c.misfit.is_none() && !c.gate.explained())
                .map(|c| {
                    let rate_px = cal.camera.fx_px * c.gate.along_laser_m / c.gate.depth_m;
                    (c.gate.implied_turn_rad, c.gate.sigma_px / rate_px.max(1.0))
                })
                .collect()
        })
        .collect();
    let support = |turn: f64| -> Vec<(f64, f64)> {
        turns
            .iter()
            .filter_map(|photo| {
                photo
                    .iter()
                    .filter(|(t, s)| (t - turn).abs() <= TURN_AGREEMENT_SIGMAS * s)
                    .min_by(|a, b| ((a.0 - turn) / a.1).abs().total_cmp(&((b.0 - turn) / b.1).abs()))
                    .copied()
            })
            .collect()
    };
    let best = turns
        .iter()
        .flatten()
        .map(|&(t, _)| {
            let agree = support(t);
            // The agreeing candidates' weighted mean turn, then who agrees with that.
            let w: f64 = agree.iter().map(|(_, s)| 1.0 / (s * s)).sum();
            let mean = agree.iter().map(|(t, s)| t / (s * s)).sum::<f64>() / w;
            (mean, support(mean).len())
        })
        .max_by(|a, b| a.1.cmp(&b.1).then(b.0.abs().total_cmp(&a.0.abs())));
    match best {
        Some((turn, n)) if n >= MIN_TURNED_PHOTOS && n > calibrated => turned(&cal.laser, turn).unwrap_or(cal.laser),
        _ => cal.laser,
    }
}

/// `laser` turned by `turn_rad` about its origin, out of the plane of the camera centre and
/// the beam (the sign of [`fslcal_core::LineGate::implied_turn_rad`]).
pub fn turned(laser: &LaserLine, turn_rad: f64) -> Option<LaserLine> {
    let n = laser.origin().cross(&laser.dir()).try_normalize(1e-12)?;
    // Turning about d x n by a positive angle moves the direction toward +n.
    let axis = nalgebra::Unit::new_normalize(laser.dir().cross(&n));
    let d = nalgebra::Rotation3::from_axis_angle(&axis, turn_rad) * laser.dir();
    LaserLine::from_point_direction(laser.origin(), d)
}

/// One photo's dot under the believed laser and its offset from the calibrated one.
fn judge_photo(
    cal: &Calibration,
    search: &LineSearch,
    believed: &LaserLine,
    candidates: &[LineCandidate],
    out: &mut PhotoCheck,
) {
    let cam: &CameraModel = &cal.camera;
    let rejudged: Vec<Option<LineCandidate>> = if believed == &cal.laser {
        candidates.iter().cloned().map(Some).collect()
    } else {
        candidates.iter().map(|c| judge_candidate(cam, believed, search, c.candidate.clone(), c.sensitive)).collect()
    };
    out.candidates = candidates
        .iter()
        .zip(&rejudged)
        .map(|(c, r)| CandidateCheck::of(c, r.as_ref().map_or(Some(Refusal::OffLine), LineCandidate::refusal)))
        .collect();
    let rejudged: Vec<LineCandidate> = rejudged.into_iter().flatten().collect();
    let dot: LineDot = match choose(&rejudged, search.band_half_width_px) {
        Ok(d) => d,
        Err(e) => {
            out.reason = Some(CheckSkip::NoDot(e).into());
            return;
        }
    };
    // Offsets, sigmas and the implied change are against the calibrated laser.
    let Some(gate) = candidates.iter().find(|c| c.candidate.pixel == dot.pixel).map(|c| c.gate) else {
        return;
    };
    out.dot_px = Some([dot.pixel.x, dot.pixel.y]);
    out.confidence = Some(dot.confidence);
    out.offset_px = Some(gate.offset_px.abs());
    out.distance_m = Some(gate.depth_m);
    out.direction_change_deg = Some(gate.implied_turn_rad.to_degrees());
    out.explained_sigma_px = Some(gate.sigma_px);
    out.flag = gate.offset_px.abs() > FLAG_SIGMAS * gate.sigma_px;
}

/// The photo at `path`, decoded; `Ok(Err)` when it cannot be read, `Err` when it is not the
/// calibrated camera's size.
fn decode(path: &Path, cal: &Calibration) -> Result<Result<Photo, CheckSkip>, CheckError> {
    let file = path.display().to_string();
    let photo = EncodedPhoto::read(path).and_then(|e| Ok((e.dimensions()?, e.decode()?)));
    let ((w, h), photo) = match photo {
        Ok(p) => p,
        Err(e) => return Ok(Err(CheckSkip::Unreadable { detail: strip_path(&e.to_string(), &file) })),
    };
    let cam = &cal.camera;
    if (w, h) != (cam.width_px, cam.height_px) {
        return Err(CheckError::ImageSize {
            file,
            photo_w: w,
            photo_h: h,
            camera_w: cam.width_px,
            camera_h: cam.height_px,
        });
    }
    Ok(Ok(photo))
}

#[cfg(test)]
mod tests {
    use super::*;
    use calib_targets::rig::{fsl_laser, tg6_camera};

    /// The turned laser the check believes and the gate's implied turn share one sign: a
    /// dot of the laser turned by +0.4 deg implies +0.4 deg against the calibrated one.
    #[test]
    fn a_turned_laser_s_dots_imply_its_turn_with_its_sign() {
        let (camera, laser) = (tg6_camera(), fsl_laser());
        let cov = [[0.0; 4]; 4];
        for deg in [0.4f64, -0.25] {
            let t = turned(&laser, deg.to_radians()).unwrap();
            for z in [0.8, 2.0, 4.0] {
                let g = laser.gate(&camera, &cov, t.pixel_at_depth(&camera, z).unwrap(), 0.5).unwrap();
                assert!((g.implied_turn_rad.to_degrees() - deg).abs() < 0.02 * deg.abs(), "{deg} deg at {z} m: {g:?}");
            }
        }
    }

    /// The FishSense rig at 800x600, with a small covariance.
    fn calibration() -> Calibration {
        let camera = CameraModel {
            width_px: 800,
            height_px: 600,
            fx_px: 580.0,
            fy_px: 580.0,
            cx_px: 400.0,
            cy_px: 300.0,
            distortion: fslcal_core::Distortion::from_opencv([0.0; 5]),
        };
        let laser = LaserLine::from_point_direction(
            fslcal_core::Vec3::new(-0.04, -0.105, 0.0),
            fslcal_core::Vec3::new(0.0105, 0.022, 1.0),
        )
        .unwrap();
        let (o, d) = (1e-8, 1e-9);
        Calibration {
            camera,
            laser,
            laser_covariance: [[o, 0.0, 0.0, 0.0], [0.0, o, 0.0, 0.0], [0.0, 0.0, d, 0.0], [0.0, 0.0, 0.0, d]],
            depth_range_m: Some((0.5, 5.0)),
            unit: None,
            camera_serial: None,
            focal_length_mm: None,
            laser_colour: None,
            source: "test".into(),
        }
    }

    /// Two photos, each with two plausible blobs on the calibrated line (ambiguous, so no
    /// clear dot) and a faint blob off it at one implied turn: the calibrated laser still
    /// explains both photos, and two faint blobs do not outvote it. A third photo with only
    /// the off-line blob tips it: three photos agree on the turn, two on the line.
    #[test]
    fn photos_ambiguous_on_the_calibrated_line_still_vote_for_it() {
        let cal = calibration();
        let search = cal.line_search();
        let blob = |pixel: fslcal_core::Vec2, snr: f64| {
            let mut c = crate::dot::on_target::hand_candidate(pixel);
            c.radius_px = 4.0;
            c.saturated_core = true;
            c.snr = snr;
            judge_candidate(&cal.camera, &cal.laser, &search, c, false).expect("a distance on the line")
        };
        let off = turned(&cal.laser, 0.4f64.to_radians()).unwrap();
        let photo = |z: f64, on_line: bool| {
            let mut cands = vec![blob(off.pixel_at_depth(&cal.camera, z).unwrap(), 15.0)];
            if on_line {
                cands.push(blob(cal.laser.pixel_at_depth(&cal.camera, z).unwrap(), 60.0));
                cands.push(blob(cal.laser.pixel_at_depth(&cal.camera, 0.7 * z).unwrap(), 60.0));
            }
            assert!(!cands[0].gate.explained(), "the turned blob is off the calibrated line");
            (PhotoCheck::default(), cands)
        };
        let two = vec![photo(1.5, true), photo(2.5, true)];
        assert!(two.iter().all(|(_, c)| choose(c, search.band_half_width_px).is_err()), "ambiguous");
        assert_eq!(believed_laser(&cal, &two), cal.laser);
        let three = vec![photo(1.5, true), photo(2.5, true), photo(3.0, false)];
        assert_ne!(believed_laser(&cal, &three), cal.laser);
    }

    /// How `check` judges a photo whose only blob is a dot-like candidate at `pixel`.
    fn judged_alone(cal: &Calibration, pixel: fslcal_core::Vec2) -> PhotoCheck {
        let search = cal.line_search();
        let mut blob = crate::dot::on_target::hand_candidate(pixel);
        // A clear dot of 4 px radius: size and signal fit any depth the search covers.
        blob.radius_px = 4.0;
        blob.saturated_core = true;
        let candidates: Vec<LineCandidate> =
            judge_candidate(&cal.camera, &cal.laser, &search, blob, false).into_iter().collect();
        let mut out = PhotoCheck::default();
        judge_photo(cal, &search, &cal.laser, &candidates, &mut out);
        out
    }

    /// The sweep (53 of 300 photos at 800x600 were "ok" though their dot had no
    /// distance): 300 seeded dots 48-77 px off the line's image, anywhere along it in the
    /// frame. A dot without a distance is never judged; none is "ok".
    #[test]
    fn a_sweep_of_dots_off_the_line_never_calls_one_without_a_distance_ok() {
        let cal = calibration();
        let (cam, laser) = (&cal.camera, &cal.laser);
        let near = laser.pixel_at_depth(cam, 0.5).unwrap();
        let along = (cam.project(&laser.dir()).unwrap() - near).normalize();
        let across = fslcal_core::Vec2::new(-along.y, along.x);
        let mut state = 0x16_u64;
        let mut uniform = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let (mut dots, mut no_distance, mut within) = (0, 0, 0);
        while dots < 300 {
            let offset_px = 48.0 + 29.0 * uniform();
            let side = if uniform() < 0.5 { -1.0 } else { 1.0 };
            let pixel = near + along * (1000.0 * (2.0 * uniform() - 1.0)) + across * (side * offset_px);
            if !cam.contains(pixel) {
                continue;
            }
            dots += 1;
            let out = judged_alone(&cal, pixel);
            let has_distance = laser.fix_from_pixel(cam, pixel).is_some();
            no_distance += usize::from(!has_distance);
            if !has_distance {
                assert!(
                    matches!(out.outcome(), CheckOutcome::Skipped(_)) && out.explained_sigma_px.is_none(),
                    "{pixel:?} has no distance yet was judged {:?}",
                    out.outcome()
                );
            }
            within += usize::from(out.outcome() == CheckOutcome::Within);
        }
        eprintln!("300 dots 48-77 px off the line at 800x600: {no_distance} without a distance, {within} called ok");
        // The sweep reaches the case it guards, and a dot 48 px off a calibrated line is
        // never explained by a covariance this small.
        assert!(no_distance >= 30, "{no_distance} without a distance");
        assert_eq!(within, 0);
    }

    /// A dot on the line is judged and within; the same dot 48 px off it is not "ok".
    #[test]
    fn a_dot_on_the_line_is_within_and_one_far_off_it_is_not() {
        let cal = calibration();
        let at_2m = cal.laser.pixel_at_depth(&cal.camera, 2.0).unwrap();
        let out = judged_alone(&cal, at_2m);
        assert_eq!(out.outcome(), CheckOutcome::Within, "{out:?}");
        assert!((out.distance_m.unwrap() - 2.0).abs() < 1e-3);
        let normal = {
            let t = (cal.laser.pixel_at_depth(&cal.camera, 2.02).unwrap() - at_2m).normalize();
            fslcal_core::Vec2::new(-t.y, t.x)
        };
        let off = judged_alone(&cal, at_2m + normal * 48.0);
        assert_ne!(off.outcome(), CheckOutcome::Within, "{off:?}");
    }
}
