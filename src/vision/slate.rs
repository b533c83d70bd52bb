//! Finding a taped dive slate and its pose from its scan.
//!
//! Coarse: features on the photo decoded at 1/4 size (a far slate: 1/2), matched to the
//! scan's with the ratio test, a homography by RANSAC. Fine: the slate's bounding box cut
//! from the full-resolution photo and reduced by the integer factor that brings the slate
//! to about the scan's resolution, features again (matched only near where the coarse
//! homography puts them), a second homography, then `T_cam_target` by PnP from every inlier
//! with the scan points at their physical positions. Every step that can be weak says so:
//! a photo whose match is thin or whose pose is implausible is refused with the reason
//! rather than given a confident wrong pose (the lab's retired estimator's failure).

use super::{solve_pose, EncodedPhoto, Photo, TargetPose, VisionError};
use calib_targets::Slate;
use fslcal_core::{CameraModel, Vec2, Vec3};
use opencv::core::{
    no_array, DMatch, KeyPoint, Mat, Point, Point2f, Rect, Scalar, Size, ToInputArray, Vector, CV_8UC1, NORM_HAMMING,
    NORM_L2,
};
use opencv::features2d::{BFMatcher, AKAZE, ORB, SIFT};
use opencv::prelude::*;
use opencv::{calib3d, imgproc};
use std::path::Path;
use std::str::FromStr;

/// Which features to match. SIFT is the default by measurement (see `docs/slate.md` and
/// `cargo bench --bench slate_detection`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Features {
    Sift,
    Orb,
    Akaze,
}

impl FromStr for Features {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "sift" => Ok(Features::Sift),
            "orb" => Ok(Features::Orb),
            "akaze" => Ok(Features::Akaze),
            _ => Err(format!("unknown features `{s}`: expected sift, orb or akaze")),
        }
    }
}

/// Lowe's ratio: a match must be this much better than the second best.
const RATIO: f32 = 0.75;
/// The coarse homography needs this many inliers to be believed at all.
const MIN_COARSE_INLIERS: usize = 15;
/// The fine match needs this many inliers for a pose.
pub const MIN_INLIERS: usize = 30;
/// Inliers must cover at least this share of the slate (their convex hull), or the pose
/// hangs on one corner.
const MIN_HULL_SHARE: f64 = 0.08;
/// Largest acceptable RMS reprojection error of the inliers under the pose, pixels of the
/// fine crop.
const MAX_POSE_RMS_PX: f64 = 2.0;
/// A slate seen more obliquely than this is refused (its pose is ill-conditioned).
const MAX_OBLIQUITY_DEG: f64 = 70.0;
/// Most features kept per image.
const MAX_FEATURES: i32 = 4000;

fn detector(kind: Features) -> opencv::Result<opencv::core::Ptr<opencv::features2d::Feature2D>> {
    Ok(match kind {
        Features::Sift => SIFT::create(MAX_FEATURES, 3, 0.03, 10.0, 1.6)?.into(),
        Features::Orb => {
            ORB::create(MAX_FEATURES, 1.2, 8, 31, 0, 2, opencv::features2d::ORB_ScoreType::HARRIS_SCORE, 31, 10)?.into()
        }
        Features::Akaze => AKAZE::create_def()?.into(),
    })
}

/// Keypoint positions (pixel-centre convention) and descriptors of one image.
struct FeatureSet {
    points_px: Vec<Vec2>,
    descriptors: Mat,
}

fn detect(kind: Features, grey: &impl ToInputArray, mask: &impl ToInputArray) -> opencv::Result<FeatureSet> {
    let mut d = detector(kind)?;
    let mut keypoints = Vector::<KeyPoint>::new();
    let mut descriptors = Mat::default();
    d.detect_and_compute(grey, mask, &mut keypoints, &mut descriptors, false)?;
    let points_px = keypoints.iter().map(|k| Vec2::new(k.pt().x as f64, k.pt().y as f64)).collect();
    Ok(FeatureSet { points_px, descriptors })
}

/// Ratio-tested matches `(query index, train index)` of `query` against `train`.
fn ratio_matches(kind: Features, query: &FeatureSet, train: &FeatureSet) -> opencv::Result<Vec<(usize, usize)>> {
    if query.points_px.len() < 2 || train.points_px.len() < 2 {
        return Ok(Vec::new());
    }
    let norm = if kind == Features::Sift { NORM_L2 } else { NORM_HAMMING };
    let matcher = BFMatcher::create(norm, false)?;
    let mut knn = Vector::<Vector<DMatch>>::new();
    matcher.knn_train_match(&query.descriptors, &train.descriptors, &mut knn, 2, &no_array(), false)?;
    Ok(knn
        .iter()
        .filter(|m| m.len() == 2)
        .filter_map(|m| {
            let (a, b) = (m.get(0).ok()?, m.get(1).ok()?);
            (a.distance < RATIO * b.distance).then_some((a.query_idx as usize, a.train_idx as usize))
        })
        .collect())
}

/// A 3x3 homography, row-major, mapping scan pixels to image pixels.
#[derive(Clone, Copy, Debug)]
struct Homography([[f64; 3]; 3]);

impl Homography {
    fn apply(&self, p: Vec2) -> Option<Vec2> {
        let h = &self.0;
        let w = h[2][0] * p.x + h[2][1] * p.y + h[2][2];
        if w.abs() < 1e-12 {
            return None;
        }
        Some(Vec2::new((h[0][0] * p.x + h[0][1] * p.y + h[0][2]) / w, (h[1][0] * p.x + h[1][1] * p.y + h[1][2]) / w))
    }
}

/// RANSAC homography from `src` to `dst`; the homography and the inlier indices.
fn ransac_homography(
    src: &[Vec2],
    dst: &[Vec2],
    threshold_px: f64,
) -> opencv::Result<Option<(Homography, Vec<usize>)>> {
    if src.len() < 4 {
        return Ok(None);
    }
    let to_cv = |v: &[Vec2]| v.iter().map(|p| Point2f::new(p.x as f32, p.y as f32)).collect::<Vector<Point2f>>();
    let mut mask = Mat::default();
    let h =
        calib3d::find_homography_ext(&to_cv(src), &to_cv(dst), calib3d::RANSAC, threshold_px, &mut mask, 5000, 0.999)?;
    if h.empty() {
        return Ok(None);
    }
    let m = Homography(std::array::from_fn(|i| {
        std::array::from_fn(|j| *h.at_2d::<f64>(i as i32, j as i32).unwrap_or(&f64::NAN))
    }));
    if m.0.iter().flatten().any(|v| !v.is_finite()) {
        return Ok(None);
    }
    let flags = mask.data_bytes()?;
    let inliers = (0..src.len()).filter(|&i| flags.get(i).is_some_and(|&f| f != 0)).collect();
    Ok(Some((m, inliers)))
}

/// The scan, its features, and the slate's definition: built once per run.
pub struct SlateModel {
    pub slate: Slate,
    pub features: Features,
    scan_size: (u32, u32),
    scan: FeatureSet,
}

impl SlateModel {
    pub fn new(slate: Slate, features: Features) -> Result<SlateModel, VisionError> {
        let cv = |e: opencv::Error| VisionError::cv(&slate.scan, e);
        let scan = imgcodecs_read_grey(&slate.scan)?;
        let scan_size = (scan.cols() as u32, scan.rows() as u32);
        let set = detect(features, &scan, &no_array()).map_err(cv)?;
        if set.points_px.len() < 2 * MIN_INLIERS {
            return Err(VisionError::OpenCv {
                path: slate.scan.display().to_string(),
                message: format!(
                    "only {} features on the scan: a slate needs texture (tape, writing) to be found",
                    set.points_px.len()
                ),
            });
        }
        Ok(SlateModel { slate, features, scan_size, scan: set })
    }

    /// Target-frame point (metres) of a scan pixel.
    fn scan_point_m(&self, p: Vec2) -> Vec3 {
        Vec3::from(self.slate.scan_px_to_m(self.scan_size, p.x, p.y))
    }

    /// The slate's outline in scan pixels (the scan's edges).
    fn outline_scan_px(&self) -> [Vec2; 4] {
        let (w, h) = (self.scan_size.0 as f64 - 0.5, self.scan_size.1 as f64 - 0.5);
        [Vec2::new(-0.5, -0.5), Vec2::new(w, -0.5), Vec2::new(w, h), Vec2::new(-0.5, h)]
    }

    pub fn scan_features(&self) -> usize {
        self.scan.points_px.len()
    }
}

fn imgcodecs_read_grey(path: &Path) -> Result<Mat, VisionError> {
    let m = opencv::imgcodecs::imread(&path.display().to_string(), opencv::imgcodecs::IMREAD_GRAYSCALE)
        .map_err(|e| VisionError::cv(path, e))?;
    if m.empty() {
        return Err(VisionError::Undecodable { path: path.display().to_string() });
    }
    Ok(m)
}

/// A slate found in a photo.
pub struct SlateDetection {
    pub pose: TargetPose,
    /// Ratio-tested matches and RANSAC inliers of the fine stage.
    pub matches: usize,
    pub inliers: usize,
    /// Reduction of the coarse search (4 = quarter size) and of the fine crop.
    pub found_at_factor: u32,
    pub fine_factor: u32,
    /// The full-resolution photo, decoded for the fine stage, for the dot search.
    pub photo: Photo,
}

/// Why a photo's slate was not accepted; the text is the skip reason.
#[derive(Debug, thiserror::Error)]
pub enum SlateMiss {
    #[error("no slate found ({inliers} feature matches agree on a homography, need {MIN_COARSE_INLIERS}; the whole slate must be in the frame)")]
    NotFound { inliers: usize },
    #[error("weak slate match: {inliers} inliers of {matches} matches (need {needed})")]
    Weak { inliers: usize, matches: usize, needed: usize },
    #[error("implausible slate pose: {0}")]
    Implausible(String),
    #[error(transparent)]
    Vision(#[from] VisionError),
}

/// Converts a reduced image's pixel to full resolution (`docs/conventions.md`).
fn to_full(p: Vec2, factor: u32, origin: Vec2) -> Vec2 {
    let f = factor as f64;
    origin + p * f + Vec2::repeat((f - 1.0) / 2.0)
}

/// Coarse stage: the scan-to-photo homography in full-resolution pixels, and the factor.
fn coarse(model: &SlateModel, photo: &Photo, path: &Path) -> Result<(Homography, u32), SlateMiss> {
    let mut best = 0;
    for factor in [4u32, 2] {
        let cv = |e: opencv::Error| SlateMiss::Vision(VisionError::cv(path, e));
        let grey = photo.reduced_grey(factor).map_err(cv)?;
        let set = detect(model.features, grey, &no_array()).map_err(cv)?;
        let m = ratio_matches(model.features, &model.scan, &set).map_err(cv)?;
        let src: Vec<Vec2> = m.iter().map(|&(s, _)| model.scan.points_px[s]).collect();
        let dst: Vec<Vec2> = m.iter().map(|&(_, p)| to_full(set.points_px[p], factor, Vec2::zeros())).collect();
        if let Some((h, inliers)) = ransac_homography(&src, &dst, 3.0 * factor as f64).map_err(cv)? {
            if inliers.len() >= MIN_COARSE_INLIERS {
                return Ok((h, factor));
            }
            best = best.max(inliers.len());
        }
    }
    Err(SlateMiss::NotFound { inliers: best })
}

fn convex_hull_area(points: &[Vec2]) -> f64 {
    let mut p: Vec<Vec2> = points.to_vec();
    p.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    if p.len() < 3 {
        return 0.0;
    }
    let cross = |o: Vec2, a: Vec2, b: Vec2| (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x);
    let mut hull: Vec<Vec2> = Vec::new();
    for pass in 0..2 {
        let start = hull.len();
        let iter: Box<dyn Iterator<Item = &Vec2>> =
            if pass == 0 { Box::new(p.iter()) } else { Box::new(p.iter().rev()) };
        for &q in iter {
            while hull.len() >= start + 2 && cross(hull[hull.len() - 2], hull[hull.len() - 1], q) <= 0.0 {
                hull.pop();
            }
            hull.push(q);
        }
        hull.pop();
    }
    let n = hull.len();
    (0..n).map(|i| cross(Vec2::zeros(), hull[i], hull[(i + 1) % n])).sum::<f64>().abs() / 2.0
}

/// Finds the slate in `photo` and its pose `T_cam_target`.
pub fn find_slate(
    model: &SlateModel,
    encoded: &EncodedPhoto,
    camera: &CameraModel,
) -> Result<SlateDetection, SlateMiss> {
    let photo = encoded.decode()?;
    let (coarse_h, found_at_factor) = coarse(model, &photo, encoded.path)?;
    let cv = |e: opencv::Error| SlateMiss::Vision(VisionError::cv(encoded.path, e));
    let outline: Vec<Vec2> = model.outline_scan_px().iter().filter_map(|p| coarse_h.apply(*p)).collect();
    if outline.len() < 4 {
        return Err(SlateMiss::Implausible("the slate's outline does not map into the photo".into()));
    }
    let crop = FineCrop::cut(model, &photo, &outline, encoded.path)?;
    let mask = crop.slate_mask(&outline).map_err(cv)?;
    let set = detect(model.features, &crop.small, &mask).map_err(cv)?;
    let matches = ratio_matches(model.features, &model.scan, &set).map_err(cv)?;
    let f = crop.factor as f64;
    let (coarse_src, coarse_dst) = guided_pairs(model, &set, &matches, &coarse_h, &crop, found_at_factor);
    // Guided again by the first fine homography: the coarse one, from a reduced image, can
    // be a few pixels off at the slate's far edge, where it left good matches out.
    let (src, dst, inliers) = match ransac_homography(&coarse_src, &coarse_dst, 2.0 * f).map_err(cv)? {
        Some((fine_h, first)) if first.len() >= MIN_INLIERS => {
            let (src, dst) = guided_pairs(model, &set, &matches, &fine_h, &crop, crop.factor);
            let inliers = ransac_homography(&src, &dst, 2.0 * f).map_err(cv)?.map_or(Vec::new(), |r| r.1);
            (src, dst, inliers)
        }
        first => (coarse_src, coarse_dst, first.map_or(Vec::new(), |r| r.1)),
    };
    if inliers.len() < MIN_INLIERS {
        return Err(SlateMiss::Weak { inliers: inliers.len(), matches: matches.len(), needed: MIN_INLIERS });
    }
    let hull: Vec<Vec2> = inliers.iter().map(|&i| src[i]).collect();
    check_coverage(model, &hull)?;
    let object: Vec<Vec3> = inliers.iter().map(|&i| model.scan_point_m(src[i])).collect();
    let image: Vec<Vec2> = inliers.iter().map(|&i| dst[i]).collect();
    let pose = match solve_pose(camera, &object, &image) {
        Ok(Some(p)) => p,
        Ok(None) | Err(_) => return Err(SlateMiss::Implausible("PnP found no pose in front of the camera".into())),
    };
    check_pose(&pose, model, f)?;
    Ok(SlateDetection {
        pose,
        matches: matches.len(),
        inliers: inliers.len(),
        found_at_factor,
        fine_factor: crop.factor,
        photo,
    })
}

/// The fine stage's image: the slate's box cut from the full-resolution photo and reduced
/// by `factor`; `origin` is the box's corner in full-resolution pixels.
struct FineCrop {
    small: Mat,
    origin: Vec2,
    factor: u32,
}

impl FineCrop {
    /// The slate's box (from its `outline` in the photo), padded, at the factor that brings
    /// the slate near the scan's size.
    fn cut(model: &SlateModel, photo: &Photo, outline: &[Vec2], path: &Path) -> Result<FineCrop, SlateMiss> {
        let cv = |e: opencv::Error| SlateMiss::Vision(VisionError::cv(path, e));
        let (w, h) = (photo.width() as f64, photo.height() as f64);
        let (minx, maxx) = outline.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |a, p| (a.0.min(p.x), a.1.max(p.x)));
        let (miny, maxy) = outline.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |a, p| (a.0.min(p.y), a.1.max(p.y)));
        let pad = 0.04 * (maxx - minx).max(maxy - miny);
        let (x0, y0) = ((minx - pad).floor().max(0.0), (miny - pad).floor().max(0.0));
        let (x1, y1) = ((maxx + pad).ceil().min(w), (maxy + pad).ceil().min(h));
        if x1 - x0 < 32.0 || y1 - y0 < 32.0 {
            return Err(SlateMiss::Implausible(format!("the slate would be only {:.0}x{:.0} px", x1 - x0, y1 - y0)));
        }
        let slate_px = (maxx - minx).max(maxy - miny);
        let scan_px = model.scan_size.0.max(model.scan_size.1) as f64;
        let factor = ((slate_px / scan_px).round() as u32).clamp(1, 8);
        let rect = Rect::new(x0 as i32, y0 as i32, (x1 - x0) as i32, (y1 - y0) as i32);
        let crop = Mat::roi(photo.grey().map_err(cv)?, rect).map_err(cv)?;
        let small = if factor > 1 {
            let mut s = Mat::default();
            let size = Size::new(rect.width / factor as i32, rect.height / factor as i32);
            // Exactly `factor` pixels per reduced pixel, so `to_full` holds.
            let cropped = Mat::roi(&crop, Rect::new(0, 0, size.width * factor as i32, size.height * factor as i32))
                .map_err(cv)?;
            imgproc::resize(&cropped, &mut s, size, 0.0, 0.0, imgproc::INTER_AREA).map_err(cv)?;
            s
        } else {
            crop.try_clone().map_err(cv)?
        };
        Ok(FineCrop { small, origin: Vec2::new(x0, y0), factor })
    }

    /// Features only on the slate: a mask of its `outline` (full-resolution pixels) in the crop.
    fn slate_mask(&self, outline: &[Vec2]) -> opencv::Result<Mat> {
        let f = self.factor as f64;
        let mut mask =
            Mat::new_rows_cols_with_default(self.small.rows(), self.small.cols(), CV_8UC1, Scalar::all(0.0))?;
        let poly: Vector<Point> = outline
            .iter()
            .map(|p| {
                let q = (p - self.origin - Vec2::repeat((f - 1.0) / 2.0)) / f;
                Point::new(q.x.round() as i32, q.y.round() as i32)
            })
            .collect();
        imgproc::fill_convex_poly(&mut mask, &poly, Scalar::all(255.0), imgproc::LINE_8, 0)?;
        Ok(mask)
    }
}

/// The fine stage's matches as (scan px, full-resolution photo px) pairs, guided: a match
/// must land within 6 pixels of the image at 1/`guide_factor` size that `guide` was
/// found on, from where `guide` puts its scan point.
fn guided_pairs(
    model: &SlateModel,
    set: &FeatureSet,
    matches: &[(usize, usize)],
    guide: &Homography,
    crop: &FineCrop,
    guide_factor: u32,
) -> (Vec<Vec2>, Vec<Vec2>) {
    let near = 6.0 * guide_factor as f64;
    let pairs: Vec<(Vec2, Vec2)> = matches
        .iter()
        .filter_map(|&(s, p)| {
            let scan = model.scan.points_px[s];
            let img = to_full(set.points_px[p], crop.factor, crop.origin);
            ((guide.apply(scan)? - img).norm() <= near).then_some((scan, img))
        })
        .collect();
    let src: Vec<Vec2> = pairs.iter().map(|p| p.0).collect();
    let dst: Vec<Vec2> = pairs.iter().map(|p| p.1).collect();
    (src, dst)
}

/// Refuses inliers (scan pixels) that cover too little of the slate to hold a pose.
fn check_coverage(model: &SlateModel, inliers_scan_px: &[Vec2]) -> Result<(), SlateMiss> {
    let share = convex_hull_area(inliers_scan_px) / (model.scan_size.0 as f64 * model.scan_size.1 as f64);
    if share < MIN_HULL_SHARE {
        return Err(SlateMiss::Implausible(format!(
            "the {} inliers cover only {:.0}% of the slate (need {:.0}%): the pose would hang on one corner",
            inliers_scan_px.len(),
            100.0 * share,
            100.0 * MIN_HULL_SHARE
        )));
    }
    Ok(())
}

fn check_pose(pose: &TargetPose, model: &SlateModel, fine_factor: f64) -> Result<(), SlateMiss> {
    // Features are localised at the fine crop's scale, a fraction of its pixel; a near slate's
    // crop is reduced, so its full-resolution residuals are larger by the factor.
    if pose.rms_px > MAX_POSE_RMS_PX * fine_factor {
        return Err(SlateMiss::Implausible(format!(
            "the inliers reproject {:.1} px RMS from the pose (limit {:.1} px): the slate is bent, or the camera file is wrong",
            pose.rms_px,
            MAX_POSE_RMS_PX * fine_factor
        )));
    }
    let centre = pose.to_camera(&Vec3::new(0.5 * model.slate.width_m, 0.5 * model.slate.height_m, 0.0));
    if !(0.1..=12.0).contains(&centre.z) {
        return Err(SlateMiss::Implausible(format!("the slate would be {:.2} m away", centre.z)));
    }
    // The target's z axis points into the slate, away from a camera that sees its front.
    let n = pose.rotation.column(2);
    let facing = n.dot(&(centre / centre.norm()));
    let obliquity = facing.clamp(-1.0, 1.0).acos().to_degrees();
    if facing <= 0.0 || obliquity > MAX_OBLIQUITY_DEG {
        return Err(SlateMiss::Implausible(format!(
            "the slate would be seen {obliquity:.0} deg from face-on (limit {MAX_OBLIQUITY_DEG:.0})"
        )));
    }
    Ok(())
}
