//! The laser chain: photos of a target (a checkerboard or a taped slate) with the laser dot
//! on it, to a fitted laser line with its quality gates.
//!
//! Per photo (in parallel): find the target at reduced size, refine it at full resolution,
//! solve `T_cam_target`, look for dot candidates only on the physical target's image, and
//! turn them into a [`DotObservation`]. Then fit. Photos where the first search
//! found nothing usable get a second, more sensitive look near where the first fit says the
//! dot must be, and the fit is repeated.

use super::consensus::{self, Choice, PhotoCandidates};
use super::gates::{self, GateResult};
use super::target::{locate_target, LocatedTarget, Target};
use crate::dot::candidates::SearchRegion;
use crate::dot::candidates::{ChannelOrder, ColourView, DotCandidate, DotDetectorParams};
use crate::dot::colour::{ColourSource, LaserColourModel, MeasuredColour, ToneCurve};
use crate::dot::near_prediction;
use crate::dot::on_line::{misfit, too_large, Refusal};
use crate::dot::on_target::{self, detected_sigma_px, hand_candidate, Surface, HAND_DOT_SIGMA_PX};
use crate::laser::fit::{self, DotObservation, FitError, Gates, LaserFit, Method};
use crate::reason::Reason;
use crate::vision::{self, EncodedPhoto, Photo, TargetPose};
use fslcal_core::{CameraModel, LaserLine, Plane, Vec2, Vec3};
use rayon::prelude::*;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

pub use super::outcome::{
    BoardInImage, CandidateReport, CandidateRole, DotSource, PhotoReport, PhotoStatus, SkipReason, TargetMiss,
};

/// What was learned from one photo before fitting.
#[derive(Clone, Debug)]
pub struct PhotoEvidence {
    pub image_size: (u32, u32),
    pub pose: TargetPose,
    /// The physical board's outline in the image (padded), pixels.
    pub board_outline_px: Vec<Vec2>,
    /// A checkerboard's inner corners as refined, row by row (a slate has none), pixels.
    pub corners_px: Vec<Vec2>,
    /// Dot candidates the fit may use, best first: after the consensus over photos, the
    /// chosen one alone (or none).
    pub candidates: Vec<DotCandidate>,
    /// Every candidate the search found on the target, as found (for the report).
    pub found: Vec<DotCandidate>,
    /// What the consensus over photos chose (`None`: hand-given dot, or no consensus).
    pub choice: Option<Choice>,
    pub dot_source: DotSource,
    /// Reduction factor the board was found at (4 = quarter size).
    pub found_at_factor: u32,
    /// Feature inliers of a slate's match.
    pub target_inliers: Option<usize>,
    /// The board's pixels, kept when small, so a second look for the dot needs no second
    /// decode of the whole photo.
    board_pixels: Option<PixelCrop>,
}

/// A rectangle of a photo's colour pixels (BGR), in full-image coordinates.
#[derive(Clone, Debug)]
struct PixelCrop {
    x0: usize,
    y0: usize,
    width: usize,
    height: usize,
    data: Vec<u8>,
}

/// Largest board crop kept per photo (pixels): far boards, whose faint dots are the ones
/// that need a second look, are far smaller; near boards' dots are found at once.
const MAX_KEPT_CROP_PX: usize = 2_000_000;

/// What the kept board crops of one run may hold together, bytes: memory stays bounded
/// however many photos a run has; a photo past it that needs a second look is decoded
/// again. A dive's 10-20 calibration photos fit (the 16-photo bench set's far boards take
/// under 16 MB); at 64 MB a 300-photo run's peak was 390-410 MB against 310-334 MB here.
const KEPT_CROPS_BYTES: usize = 16 << 20;

/// The bytes left for kept board crops in a run.
struct CropBudget(AtomicUsize);

impl CropBudget {
    fn new() -> CropBudget {
        CropBudget(AtomicUsize::new(KEPT_CROPS_BYTES))
    }

    /// Takes `bytes` from the budget, or nothing when fewer are left.
    fn take(&self, bytes: usize) -> bool {
        self.0.fetch_update(Ordering::Relaxed, Ordering::Relaxed, |left| left.checked_sub(bytes)).is_ok()
    }
}

impl PixelCrop {
    fn of(view: &ColourView, outline: &[Vec2], budget: &CropBudget) -> Option<PixelCrop> {
        let pad = 8.0;
        let x0 = (outline.iter().map(|p| p.x).fold(f64::INFINITY, f64::min) - pad).max(0.0) as usize;
        let y0 = (outline.iter().map(|p| p.y).fold(f64::INFINITY, f64::min) - pad).max(0.0) as usize;
        let x1 = ((outline.iter().map(|p| p.x).fold(f64::NEG_INFINITY, f64::max) + pad) as usize).min(view.width);
        let y1 = ((outline.iter().map(|p| p.y).fold(f64::NEG_INFINITY, f64::max) + pad) as usize).min(view.height);
        if x1 <= x0 || y1 <= y0 || (x1 - x0) * (y1 - y0) > MAX_KEPT_CROP_PX || !budget.take(3 * (x1 - x0) * (y1 - y0)) {
            return None;
        }
        let (width, height) = (x1 - x0, y1 - y0);
        let mut data = Vec::with_capacity(width * height * 3);
        for y in y0..y1 {
            let row = y * view.stride + 3 * x0;
            let bytes = view.data.get(row..row + 3 * width)?;
            match view.tone {
                None => data.extend_from_slice(bytes),
                Some(t) => data.extend(bytes.iter().map(|&b| t[b as usize])),
            }
        }
        Some(PixelCrop { x0, y0, width, height, data })
    }

    fn view(&self) -> ColourView<'_> {
        ColourView {
            width: self.width,
            height: self.height,
            stride: self.width * 3,
            order: ChannelOrder::Bgr,
            // Kept read through the tone curve already.
            data: &self.data,
            tone: None,
        }
    }

    fn offset(&self) -> Vec2 {
        Vec2::new(self.x0 as f64, self.y0 as f64)
    }
}

/// Outcome of the per-photo stage: evidence, or why the photo's target cannot be used.
pub type PhotoResult = Result<PhotoEvidence, Reason<TargetMiss>>;

/// Everything `fslcal laser` reports.
#[derive(Clone, Debug)]
pub struct LaserCalibration {
    pub fit: LaserFit,
    pub photos: Vec<PhotoReport>,
    pub gates: Vec<GateResult>,
    /// "x of N": photos whose dot disagreed with the line and were left out.
    pub outliers: (usize, usize),
    /// The laser's colour learned from the used, detected dots (`None` below three).
    pub laser_colour: Option<LaserColourModel>,
    /// Why the photos were read through another tone curve than the job's, when they were
    /// and that reading was kept.
    pub tone_retry: Option<ToneRetry>,
}

/// Why a calibration read as linear was read again through other camera tone curves.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ToneRetry {
    /// The fit of the linear reading was refused.
    LinearRefused,
    /// The linear reading's dots spread this much in colour (over [`TONE_RETRY_SPREAD_RAD`]).
    LinearScattered { spread_rad: f64 },
}

impl LaserCalibration {
    pub fn accepted(&self) -> bool {
        self.gates.iter().all(|g| g.pass)
    }
}

#[derive(Debug, thiserror::Error)]
pub enum LaserError {
    #[error("{file}: the photo is {photo_w}x{photo_h} but the camera file describes a {camera_w}x{camera_h} image; use the camera file made for these photos (resized or cropped photos cannot be used)")]
    ImageSize { file: String, photo_w: u32, photo_h: u32, camera_w: u32, camera_h: u32 },
    #[error("cannot fit the laser: {source}")]
    Fit {
        #[source]
        source: FitError,
        photos: Vec<PhotoReport>,
    },
}

/// Settings of one run.
#[derive(Clone, Debug)]
pub struct LaserJob {
    pub camera: CameraModel,
    pub target: Target,
    pub method: Method,
    pub gates: Gates,
    pub detector: DotDetectorParams,
    /// Hand-given dots by photo (as given on the command line, or by file name).
    pub hand_dots: HandDots,
}

/// Hand-given dot pixels, looked up by the path as given or by file name alone (labelling
/// tools export file names without the folders the photos sit in on this machine).
#[derive(Clone, Debug, Default)]
pub struct HandDots {
    by_path: HashMap<PathBuf, Vec2>,
    by_name: HashMap<String, Vec2>,
}

impl HandDots {
    pub fn insert(&mut self, photo: &Path, px: Vec2) {
        self.by_path.insert(photo.to_path_buf(), px);
        if let Some(name) = photo.file_name() {
            self.by_name.insert(name.to_string_lossy().into_owned(), px);
        }
    }

    pub fn get(&self, photo: &Path) -> Option<Vec2> {
        self.by_path.get(photo).copied().or_else(|| {
            let name = photo.file_name()?.to_string_lossy();
            self.by_name.get(name.as_ref()).copied()
        })
    }

    pub fn len(&self) -> usize {
        self.by_path.len()
    }

    pub fn is_empty(&self) -> bool {
        self.by_path.is_empty()
    }
}

/// Dot candidates a photo keeps for the consensus and its report.
const CANDIDATES_KEPT: usize = 8;

/// Whether a dot's size is held to its distance on this job's target ([`too_large`]). Not
/// on a slate: seen at 0.45 m on white in murky water, the dot blooms past the limit (tuning
/// slate seed 1: cores of 34-51 px, limit 41 px).
fn size_follows_distance(job: &LaserJob) -> bool {
    job.target.surface() == Surface::Checkerboard
}

/// Whether a blob on a board is no larger than a dot at the depth where its ray meets the
/// board ([`too_large`]): sun flecks and glints are large wherever they lie. A blob whose ray
/// misses the plane passes, and every blob on a slate ([`size_follows_distance`]).
fn sized_like_a_dot(job: &LaserJob, plane: &Plane, c: &DotCandidate) -> bool {
    !size_follows_distance(job)
        || fit::dot_point(&job.camera, plane, c.pixel).is_none_or(|p| !too_large(&job.camera, c, p.z))
}

/// Stage one for one photo: target, pose, dot candidates.
pub fn examine_photo(job: &LaserJob, path: &Path) -> Result<PhotoResult, LaserError> {
    examine(job, path, &CropBudget::new())
}

/// A checkerboard target's squares in the image, from its refined inner corners; none for
/// a slate.
fn board_squares(job: &LaserJob, corners: &[Vec2]) -> Vec<[Vec2; 4]> {
    match &job.target {
        Target::Checkerboard(b) => on_target::board_squares(corners, b.inner_cols as usize, b.inner_rows as usize),
        _ => Vec::new(),
    }
}

/// Where a reading located a photo's target: a reading through another tone curve reuses
/// it, since only the dot search depends on the curve (the board search, OpenCV's, is by
/// far the slower part).
#[derive(Clone, Debug)]
struct Placement {
    pose: TargetPose,
    outline_px: Vec<Vec2>,
    corners_px: Vec<Vec2>,
    found_at_factor: u32,
    inliers: Option<usize>,
}

impl PhotoEvidence {
    fn placement(&self) -> Placement {
        Placement {
            pose: self.pose.clone(),
            outline_px: self.board_outline_px.clone(),
            corners_px: self.corners_px.clone(),
            found_at_factor: self.found_at_factor,
            inliers: self.target_inliers,
        }
    }
}

/// [`examine_photo`], keeping the board's pixels while `budget` allows.
fn examine(job: &LaserJob, path: &Path, budget: &CropBudget) -> Result<PhotoResult, LaserError> {
    let located = match locate_target(&job.target, &job.camera, path)? {
        Ok(l) => l,
        Err(reason) => return Ok(Err(reason)),
    };
    let LocatedTarget { pose, outline_px, photo, found_at_factor, inliers, corners_px } = located;
    let placement = Placement { pose, outline_px, corners_px, found_at_factor, inliers };
    Ok(Ok(search_target(job, path, &photo, placement, budget)))
}

/// A photo read again through `job`'s tone curve, its target where `before` placed it.
fn reexamine(job: &LaserJob, path: &Path, before: &PhotoResult, budget: &CropBudget) -> PhotoResult {
    let placement = before.as_ref().map_err(Clone::clone)?.placement();
    let photo = EncodedPhoto::read(path)
        .and_then(|e| e.decode())
        .map_err(|e| Reason::from(super::target::unreadable(path, &e)))?;
    Ok(search_target(job, path, &photo, placement, budget))
}

/// The dot candidates on a located target (or the hand-given dot), read through the job's
/// tone curve.
fn search_target(job: &LaserJob, path: &Path, photo: &Photo, at: Placement, budget: &CropBudget) -> PhotoEvidence {
    let Placement { pose, outline_px: outline, corners_px: corners, found_at_factor, inliers } = at;
    let colour = photo.colour(&job.detector.colour.tone);
    let (candidates, dot_source) = match job.hand_dots.get(path) {
        Some(px) => (vec![hand_candidate(px)], DotSource::Hand),
        None => {
            let squares = board_squares(job, &corners);
            let region = SearchRegion { polygon: outline.clone(), band: None, squares, overlapping_pieces: false };
            // Blobs no dot could be at the target's distance are dropped before the cap, so
            // a crowd of them cannot push the dot out.
            let plane = pose.plane();
            let found = job.target.find_dots(&colour, &region, &job.detector, 4 * CANDIDATES_KEPT);
            let sized = found.into_iter().filter(|c| sized_like_a_dot(job, &plane, c));
            (sized.take(CANDIDATES_KEPT).collect(), DotSource::Detected)
        }
    };
    let board_pixels = PixelCrop::of(&colour, &outline, budget);
    PhotoEvidence {
        board_pixels,
        image_size: (photo.width(), photo.height()),
        pose,
        board_outline_px: outline,
        corners_px: corners,
        found: candidates.clone(),
        candidates,
        choice: None,
        dot_source,
        found_at_factor,
        target_inliers: inliers,
    }
}

fn observation(e: &PhotoEvidence) -> Option<DotObservation> {
    if e.candidates.is_empty() {
        return None;
    }
    let sigma_px = match e.dot_source {
        DotSource::Hand => HAND_DOT_SIGMA_PX,
        _ => detected_sigma_px(&e.candidates[0]),
    };
    Some(DotObservation { plane: e.pose.plane(), candidates: e.candidates.iter().map(|c| c.pixel).collect(), sigma_px })
}

/// Second look for a photo whose dot was not found or disagreed with the first fit, near
/// where `line` meets this photo's target (see [`near_prediction`]). What it finds must
/// still be a dot at that distance ([`misfit`]: size where [`size_follows_distance`],
/// signal, outline); the sensitive detector it uses keeps only blobs that show the
/// laser's colour clearly ([`crate::dot::candidates::DotDetectorParams::sensitive`]).
fn search_near_prediction(
    job: &LaserJob,
    path: &Path,
    evidence: &PhotoEvidence,
    line: &LaserLine,
) -> Option<DotCandidate> {
    let hit = line.hit(&evidence.pose.plane())?;
    look_near(job, path, evidence, hit).filter(|c| match misfit(&job.camera, c, hit.z) {
        None => true,
        Some(Refusal::TooLarge) => !size_follows_distance(job),
        Some(_) => false,
    })
}

/// The second look's candidate near `hit` (camera frame, metres), before it is judged.
fn look_near(job: &LaserJob, path: &Path, evidence: &PhotoEvidence, hit: Vec3) -> Option<DotCandidate> {
    let predicted = job.camera.project(&hit)?;
    let radius = near_prediction::disc_radius_px(job.gates.max_dot_offset_px);
    let surface = job.target.surface();
    // Each square's own level is the background, as in the first look: a light square whose
    // green and blue clip is seen through its red, at a level of its own, and against the
    // disc's mean over it and its neighbours the whole square was one blob (tuning
    // calibration seed 30 photo 9).
    let squares = board_squares(job, &evidence.corners_px);
    // The kept board pixels serve when the search disc (plus the background window) lies
    // inside them; otherwise decode the photo again.
    if let Some(crop) = &evidence.board_pixels {
        let margin = radius + job.detector.background_radius_px as f64;
        let o = crop.offset();
        let inside = predicted.x - margin >= o.x
            && predicted.y - margin >= o.y
            && predicted.x + margin <= o.x + crop.width as f64
            && predicted.y + margin <= o.y + crop.height as f64;
        if inside {
            return near_prediction::find_near(surface, &crop.view(), o, predicted, radius, &squares, &job.detector);
        }
    }
    let photo: Photo = EncodedPhoto::read(path).ok()?.decode().ok()?;
    near_prediction::find_near(
        surface,
        &photo.colour(&job.detector.colour.tone),
        Vec2::zeros(),
        predicted,
        radius,
        &squares,
        &job.detector,
    )
}

/// The laser colour's spread above which a calibration read as linear is tried through
/// the camera tone curves of [`TONE_TRIALS`]: under an in-camera curve a dot's chroma moves
/// with the level of the surface under it, and the accepted dots' colours scatter. On the
/// target-less sets' companion calibrations (10 photos each) read as linear, the spread
/// was 3.9-5.4 degrees for all 24 linear units (seeds 1000396-407, 3010-3021) and 4.1-18.4
/// for 12 units rendered through a curve of gamma 1.0-2.2 (seeds 1000408-419): above 6 for
/// 4 of them (gamma 2.0-2.19), and one refused outright (gamma 2.21).
const TONE_RETRY_SPREAD_RAD: f64 = 6.0 * core::f64::consts::PI / 180.0;

/// Camera tone curves a calibration is tried through when the linear reading scatters
/// ([`TONE_RETRY_SPREAD_RAD`]) or fails: the one whose dots agree best on one colour
/// is kept. sRGB is about 2.2.
const TONE_TRIALS: [f64; 3] = [1.4, 1.8, 2.2];

/// Runs the whole chain. `progress` is called once per photo examined (in the first
/// reading; a reading through another tone curve reports none).
///
/// A unit's camera tone curve is learned here: the photos are first read as linear; when
/// that reading is refused or its dots scatter in colour, they are read again through each
/// of [`TONE_TRIALS`] and the reading whose dots agree best on one colour is kept, its
/// curve stored with the colour. Not with hand-given dots or a colour already known. A
/// reading again decodes each photo and searches its target for dots where the first
/// reading located it; it does not search for the target again.
pub fn calibrate(
    job: &LaserJob,
    photos: &[PathBuf],
    progress: &(dyn Fn() + Sync),
) -> Result<LaserCalibration, LaserError> {
    vision::use_single_threaded_opencv();
    let budget = CropBudget::new();
    let read: Vec<PhotoResult> = photos
        .par_iter()
        .map(|p| {
            let r = examine(job, p, &budget);
            progress();
            r
        })
        .collect::<Result<_, _>>()?;
    let learns_tone = job.hand_dots.is_empty()
        && job.detector.colour.source == ColourSource::Prior
        && job.detector.colour.tone.table().is_none();
    if !learns_tone {
        return calibrate_from(job, photos, read);
    }
    let first = calibrate_from(job, photos, read.clone());
    let spread = |r: &Result<LaserCalibration, LaserError>| match r {
        Ok(c) => c.laser_colour.map(|m| m.spread_rad),
        Err(_) => None,
    };
    let retry = match &first {
        Ok(_) => spread(&first)
            .filter(|&s| s > TONE_RETRY_SPREAD_RAD)
            .map(|spread_rad| ToneRetry::LinearScattered { spread_rad }),
        Err(LaserError::Fit { .. }) => Some(ToneRetry::LinearRefused),
        Err(_) => None,
    };
    let Some(retry) = retry else {
        return first;
    };
    let mut best = first;
    for gamma in TONE_TRIALS {
        let mut through = job.clone();
        through.detector.colour = through.detector.colour.through(ToneCurve::power(gamma).expect("a gamma in range"));
        let budget = CropBudget::new();
        let again: Vec<PhotoResult> =
            photos.par_iter().zip(&read).map(|(p, before)| reexamine(&through, p, before, &budget)).collect();
        let r = calibrate_from(&through, photos, again);
        let better = match (spread(&r), spread(&best)) {
            (Some(s), Some(b)) => s < b,
            (Some(_), None) => true,
            _ => false,
        };
        if better {
            best = r.map(|c| LaserCalibration { tone_retry: Some(retry), ..c });
        }
    }
    best
}

/// [`calibrate`] from the photos as read through the job's tone curve: the choice of each
/// photo's dot over all photos, the fit, a second look near the fitted line, the gates.
fn calibrate_from(
    job: &LaserJob,
    photos: &[PathBuf],
    mut results: Vec<PhotoResult>,
) -> Result<LaserCalibration, LaserError> {
    choose_jointly(job, &mut results);
    let observations = |results: &[PhotoResult]| -> Vec<Option<DotObservation>> {
        results.iter().map(|r| r.as_ref().ok().and_then(observation)).collect()
    };
    let first = fit::fit(&job.camera, &observations(&results), job.method, &job.gates);

    // Second pass for the robust fit: photos with a board but no usable dot.
    let fit = match (first, job.method) {
        (Ok(first), Method::Reprojection) => {
            let retry: Vec<usize> = results
                .iter()
                .enumerate()
                .filter(|(i, r)| match r {
                    // An ambiguous photo stays withheld: a second look near the line
                    // would only pick one of its rivals.
                    Ok(e) => {
                        e.dot_source != DotSource::Hand
                            && !matches!(e.choice, Some(Choice::Ambiguous { .. }))
                            && first.photos[*i].as_ref().is_none_or(|p| p.outlier.is_some())
                    }
                    Err(_) => false,
                })
                .map(|(i, _)| i)
                .collect();
            // The second look knows the laser's colour from the first fit's dots.
            let mut second = job.clone();
            if let Some(colour) = learn_colour(&results, &first, job.detector.colour.tone) {
                second.detector.colour = colour;
            }
            let found: Vec<(usize, Option<DotCandidate>)> = retry
                .par_iter()
                .map(|&i| {
                    let e = results[i].as_ref().expect("retry holds only photos with evidence");
                    (i, search_near_prediction(&second, &photos[i], e, &first.laser))
                })
                .collect();
            let mut changed = false;
            for (i, c) in found {
                if let (Some(c), Ok(e)) = (c, results[i].as_mut()) {
                    if e.candidates.first().map(|k| k.pixel) != Some(c.pixel) {
                        e.candidates.insert(0, c);
                        e.dot_source = DotSource::DetectedNearPrediction;
                        changed = true;
                    }
                }
            }
            if changed {
                fit::fit(&job.camera, &observations(&results), job.method, &job.gates)
            } else {
                Ok(first)
            }
        }
        (first, _) => first,
    };

    let fit = match fit {
        Ok(f) => f,
        Err(source) => {
            let photos = report_photos(&job.camera, photos, &results, None);
            return Err(LaserError::Fit { source, photos });
        }
    };
    let photo_reports = report_photos(&job.camera, photos, &results, Some(&fit));
    let present = fit.photos.iter().flatten().count();
    let outliers = (present - fit.used, present);
    let gates = gates::gate(job, &fit, outliers);
    let laser_colour = learn_colour(&results, &fit, job.detector.colour.tone);
    Ok(LaserCalibration { fit, photos: photo_reports, gates, outliers, laser_colour, tone_retry: None })
}

/// Each photo's dot chosen jointly over photos ([`consensus::choose`]): the fit sees the
/// chosen candidate alone, or nothing for a photo the consensus line misses or cannot
/// decide. Without a consensus the candidates stay as found, for the fit to refuse with
/// its reason.
fn choose_jointly(job: &LaserJob, results: &mut [PhotoResult]) {
    let detected: Vec<usize> = results
        .iter()
        .enumerate()
        .filter(|(_, r)| r.as_ref().is_ok_and(|e| e.dot_source == DotSource::Detected))
        .map(|(i, _)| i)
        .collect();
    let photos: Vec<PhotoCandidates> = detected
        .iter()
        .map(|&i| {
            let e = results[i].as_ref().expect("filtered to evidence");
            PhotoCandidates { plane: e.pose.plane(), candidates: &e.found }
        })
        .collect();
    let prior = consensus::LinePrior {
        gate_px: 3.0 * job.gates.max_dot_offset_px,
        baseline_range_m: job.gates.baseline_range_m,
    };
    let Some(choices) = consensus::choose(&job.camera, &photos, &prior, job.gates.min_photos) else {
        return;
    };
    for (&i, choice) in detected.iter().zip(choices) {
        let e = results[i].as_mut().expect("filtered to evidence");
        e.candidates = match choice {
            Choice::OnLine { index, .. } | Choice::StrongOffLine { index, .. } => vec![e.found[index].clone()],
            Choice::Ambiguous { .. } | Choice::None | Choice::Empty => Vec::new(),
        };
        e.choice = Some(choice);
    }
}

/// The laser's colour from the used photos' detected dots (hand-given dots have none), as
/// measured through `tone`.
fn learn_colour(results: &[PhotoResult], fit: &LaserFit, tone: ToneCurve) -> Option<LaserColourModel> {
    let dots: Vec<MeasuredColour> = results
        .iter()
        .zip(&fit.photos)
        .filter_map(|(r, pf)| {
            let e = r.as_ref().ok()?;
            let used = pf.as_ref().is_some_and(|p| p.outlier.is_none());
            let c = e.candidates.first().filter(|_| used && e.dot_source != DotSource::Hand)?;
            Some(MeasuredColour {
                excess_rgb: c.judged_excess_rgb,
                angle_sigma_rad: c.colour_angle_sigma_rad,
                filled_in: c.colour_filled_in,
            })
        })
        .collect();
    LaserColourModel::learn(&dots).map(|m| m.through(tone))
}

fn report_photos(
    camera: &CameraModel,
    paths: &[PathBuf],
    results: &[PhotoResult],
    fit: Option<&LaserFit>,
) -> Vec<PhotoReport> {
    paths
        .iter()
        .zip(results)
        .enumerate()
        .map(|(i, (path, r))| {
            let file = path.display().to_string();
            match r {
                Err(miss) => PhotoReport::new(file, Some(miss.clone().map(SkipReason::Target))),
                Ok(e) => {
                    let mut rep = report_photo(file, e, fit, fit.and_then(|f| f.photos[i].as_ref()));
                    rep.candidates = candidate_reports(camera, e, fit.map(|f| &f.laser));
                    rep
                }
            }
        })
        .collect()
}

/// Every candidate found on a photo's target with what the consensus made of it and its
/// offset from the fitted line's image.
fn candidate_reports(camera: &CameraModel, e: &PhotoEvidence, line: Option<&LaserLine>) -> Vec<CandidateReport> {
    if e.dot_source == DotSource::Hand {
        return Vec::new();
    }
    let q = line.and_then(|l| l.hit(&e.pose.plane())).and_then(|p| camera.project(&p));
    e.found
        .iter()
        .enumerate()
        .map(|(k, c)| {
            let role = match e.choice {
                None => CandidateRole::Undecided,
                Some(Choice::OnLine { index, .. }) if index == k => CandidateRole::Chosen,
                Some(Choice::StrongOffLine { index, .. }) if index == k => CandidateRole::StrongOffLine,
                Some(Choice::Ambiguous { first, second }) if first == k || second == k => CandidateRole::Ambiguous,
                Some(_) => CandidateRole::OffLine,
            };
            CandidateReport {
                px: [c.pixel.x, c.pixel.y],
                colour_score: c.colour_score,
                colour_angle_deg: c.colour_angle_rad.to_degrees(),
                snr: c.snr,
                peak_levels: c.peak_green,
                radius_px: c.radius_px,
                saturated_px: c.saturated_px,
                line_offset_px: q.map(|q| (q - c.pixel).norm()),
                role,
            }
        })
        .collect()
}

/// The line of a photo whose target was found: used, an outlier, or why its dot is missing.
fn report_photo(file: String, e: &PhotoEvidence, fit: Option<&LaserFit>, pf: Option<&fit::PhotoFit>) -> PhotoReport {
    let why_not = match (pf, e.candidates.is_empty(), fit) {
        (Some(pf), _, _) => pf.outlier.map(SkipReason::Outlier),
        (None, true, _) if matches!(e.choice, Some(Choice::Ambiguous { .. })) => {
            Some(SkipReason::AmbiguousDot { candidates: e.found.len() })
        }
        (None, true, _) if !e.found.is_empty() => Some(SkipReason::NoUsableDot),
        (None, true, _) => Some(SkipReason::NoDotOnTarget),
        (None, false, None) => Some(SkipReason::NotFitted),
        (None, false, Some(_)) => Some(SkipReason::NoUsableDot),
    };
    let mut rep = PhotoReport::new(file, why_not.map(Reason::from));
    rep.board_rms_px = Some(e.pose.rms_px);
    rep.board = Some(BoardInImage {
        outline_px: e.board_outline_px.clone(),
        corners_px: e.corners_px.clone(),
        plane: e.pose.plane(),
    });
    rep.target_inliers = e.target_inliers;
    if let Some(pf) = pf {
        rep.dot_px = Some(pf.dot_px);
        rep.dot_source = Some(e.dot_source);
        rep.distance_m = Some(pf.distance_m);
        rep.residual_px = Some(pf.residual_px);
    }
    rep
}
