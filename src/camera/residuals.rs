//! The honest half of the camera calibration, in plain Rust: per-corner residuals, the
//! iterated k-sigma culling of corners and photos, the 1-sigma convention, and how much of
//! the frame the corners cover. The solve itself is `vision::calibrate_intrinsics`.

use fslcal_core::{CameraModel, Vec2, Vec3};
use nalgebra::Rotation3;

/// One photo's correspondences: target points (metres, z = 0) and their pixels.
#[derive(Clone, Debug, Default)]
pub struct ViewPoints {
    pub object_m: Vec<Vec3>,
    pub image_px: Vec<Vec2>,
}

/// Residual vectors (observed minus projected, pixels) of a view's points seen from
/// `T_cam_target` given as a rotation vector and a translation. A point behind the camera
/// gets an infinite residual.
pub fn residuals_px(camera: &CameraModel, pose: &(Vec3, Vec3), view: &ViewPoints) -> Vec<Vec2> {
    let rotation = Rotation3::from_scaled_axis(pose.0);
    view.object_m
        .iter()
        .zip(&view.image_px)
        .map(|(o, i)| {
            camera.project(&(rotation * o + pose.1)).map_or(Vec2::new(f64::INFINITY, f64::INFINITY), |q| i - q)
        })
        .collect()
}

/// Root mean square of residual lengths, "per point" as OpenCV reports it: the square root
/// of the mean squared distance between a corner and its reprojection.
pub fn rms_px(lengths: impl IntoIterator<Item = f64>) -> f64 {
    let (sum, n) = lengths.into_iter().fold((0.0, 0usize), |(s, n), r| (s + r * r, n + 1));
    if n == 0 {
        0.0
    } else {
        (sum / n as f64).sqrt()
    }
}

/// When a corner or a photo counts as an outlier.
#[derive(Clone, Copy, Debug)]
pub struct OutlierRules {
    /// A corner is an outlier when its residual length exceeds `k_corner` times its photo's
    /// per-coordinate noise sigma. Were the noise Gaussian, 4 would flag 1 good corner in
    /// 3000; real corner noise has heavier tails (it grows towards a tilted board's far side),
    /// and at 4 a clean rendered set lost 3% of its corners, at 5 under 1%. A misdetected
    /// corner is off by a pixel or more, tens of sigmas.
    pub k_corner: f64,
    /// A photo is an outlier when its corners' RMS exceeds the photos' median RMS by
    /// `k_photo` robust sigmas (1.4826 MAD) of the photos' RMS values...
    pub k_photo: f64,
    /// ...and is also at least this many times the median (so a set of near-identical photos
    /// does not lose its slightly worst one).
    pub min_photo_ratio: f64,
    /// A photo that loses more than this share of its corners is a misdetected board.
    pub max_corner_loss: f64,
    /// Never cull below this many photos (OpenCV needs 4 views for a stable solve).
    pub min_views: usize,
    pub max_rounds: usize,
}

impl Default for OutlierRules {
    fn default() -> Self {
        OutlierRules {
            k_corner: 5.0,
            k_photo: 4.0,
            min_photo_ratio: 2.0,
            max_corner_loss: 0.25,
            min_views: 4,
            max_rounds: 8,
        }
    }
}

/// Which corners and photos are in the solve.
#[derive(Clone, Debug, PartialEq)]
pub struct Inliers {
    /// Per view (photos with a board only), per corner.
    pub corners: Vec<Vec<bool>>,
    pub views: Vec<bool>,
}

impl Inliers {
    pub fn all(views: &[ViewPoints]) -> Self {
        Inliers {
            corners: views.iter().map(|v| vec![true; v.image_px.len()]).collect(),
            views: vec![true; views.len()],
        }
    }

    /// The used views with only their inlier corners, and the index of each in `views`.
    pub fn select(&self, views: &[ViewPoints]) -> (Vec<ViewPoints>, Vec<usize>) {
        let mut out = Vec::new();
        let mut index = Vec::new();
        for (i, v) in views.iter().enumerate().filter(|(i, _)| self.views[*i]) {
            let keep = &self.corners[i];
            out.push(ViewPoints {
                object_m: v.object_m.iter().zip(keep).filter(|(_, k)| **k).map(|(p, _)| *p).collect(),
                image_px: v.image_px.iter().zip(keep).filter(|(_, k)| **k).map(|(p, _)| *p).collect(),
            });
            index.push(i);
        }
        (out, index)
    }

    pub fn corner_count(&self) -> (usize, usize) {
        let used = self.used_views().map(|i| self.corners[i].iter().filter(|k| **k).count()).sum();
        let all = self.used_views().map(|i| self.corners[i].len()).sum();
        (used, all)
    }

    pub fn used_views(&self) -> impl Iterator<Item = usize> + '_ {
        self.views.iter().enumerate().filter(|(_, u)| **u).map(|(i, _)| i)
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Per-coordinate noise sigma from residual lengths, robustly: for 2D Gaussian noise of sigma
/// s the length's median is s sqrt(2 ln 2), and a few gross outliers do not move a median.
pub fn robust_sigma_px(lengths: &[f64]) -> f64 {
    median(lengths.to_vec()) / (2.0 * std::f64::consts::LN_2).sqrt()
}

/// The residual length beyond which a corner of one photo is an outlier: `k_corner` robust
/// sigmas of that photo's corners. Per photo, because noise differs between photos (a far,
/// murky board's corners scatter several times more than a near one's) and a pooled sigma
/// would cull the noisier photos' good corners. All corners count, outliers included: the
/// median does not need them removed, and a sigma over the inliers alone would shrink with
/// every round.
pub fn corner_limit_px(lengths: &[f64], rules: &OutlierRules) -> f64 {
    rules.k_corner * robust_sigma_px(lengths)
}

/// One culling round. `lengths[i]` holds the residual lengths of every corner of view `i`
/// (inliers and outliers alike) under the current solve, or `None` for a view not in it.
/// Corners are re-decided from scratch each round (a corner culled early may come back once
/// the solve has moved); at most one photo, the worst, is dropped per round, since one bad
/// photo drags the others' residuals. Returns the new inlier set.
pub fn cull(lengths: &[Option<Vec<f64>>], current: &Inliers, rules: &OutlierRules) -> Inliers {
    let mut next = current.clone();
    for (i, l) in lengths.iter().enumerate() {
        if let Some(l) = l {
            let limit = corner_limit_px(l, rules);
            next.corners[i] = l.iter().map(|r| *r <= limit).collect();
        }
    }
    let photo_rms: Vec<(usize, f64, f64)> = lengths
        .iter()
        .enumerate()
        .filter_map(|(i, l)| l.as_ref().map(|l| (i, l)))
        .map(|(i, l)| {
            let kept = l.iter().zip(&next.corners[i]).filter(|(_, k)| **k).map(|(r, _)| *r);
            let lost = next.corners[i].iter().filter(|k| !**k).count() as f64 / l.len().max(1) as f64;
            (i, rms_px(kept), lost)
        })
        .collect();
    let med = median(photo_rms.iter().map(|p| p.1).collect());
    let mad = median(photo_rms.iter().map(|p| (p.1 - med).abs()).collect());
    let photo_limit = (med + rules.k_photo * 1.4826 * mad).max(rules.min_photo_ratio * med);
    let worst = photo_rms
        .iter()
        .filter(|(_, rms, lost)| *rms > photo_limit || *lost > rules.max_corner_loss)
        .max_by(|a, b| (a.1 / photo_limit).max(a.2).total_cmp(&(b.1 / photo_limit).max(b.2)));
    let dropped = worst.map(|w| w.0).filter(|_| current.used_views().count() > rules.min_views);
    if let Some(i) = dropped {
        next.views[i] = false;
    }
    // Other photos that lost too many corners keep them this round: culling is one photo at
    // a time, and a board stripped to a few corners would pin its pose on nothing.
    for &(i, _, lost) in &photo_rms {
        if lost > rules.max_corner_loss && Some(i) != dropped {
            next.corners[i] = current.corners[i].clone();
        }
    }
    next
}

/// Convert OpenCV 4.6's `stdDeviationsIntrinsics` to 1-sigma. OpenCV 4.6 estimates the noise
/// variance as the sum of squared residual lengths over (N - P), N the number of points and
/// P the free parameters; the residual has 2N coordinates, so the unbiased per-coordinate
/// variance divides by (2N - P) (OpenCV corrected this in 4.7, pull request 22992). The
/// figures are then the usual 1-sigma of a least-squares fit: sqrt(diag((JᵀJ)⁻¹) σ²).
pub fn one_sigma_from_opencv46(opencv_std_dev: f64, points: usize, free_parameters: usize) -> f64 {
    let (n, p) = (points as f64, free_parameters as f64);
    if 2.0 * n <= p || n <= p {
        return f64::NAN;
    }
    opencv_std_dev * ((n - p) / (2.0 * n - p)).sqrt()
}

/// How much of the frame the boards covered.
#[derive(Clone, Debug, PartialEq)]
pub struct Coverage {
    /// Share of the image area inside at least one used board's outline of detected corners.
    pub share: f64,
    /// Frame corners ("top-left", ...) with no detected corner near them: the distortion
    /// model is extrapolated there.
    pub uncovered_frame_corners: Vec<&'static str>,
}

/// Even-odd rule; the outline may be slightly non-convex under distortion.
fn inside(poly: &[Vec2], p: Vec2) -> bool {
    let mut c = false;
    for (a, b) in poly.iter().zip(poly.iter().cycle().skip(1)) {
        if (a.y > p.y) != (b.y > p.y) && p.x < a.x + (p.y - a.y) * (b.x - a.x) / (b.y - a.y) {
            c = !c;
        }
    }
    c
}

/// The outline of a `cols x rows` grid of corners (row-major): its perimeter corners in order.
fn outline(corners: &[Vec2], cols: usize, rows: usize) -> Vec<Vec2> {
    let at = |c: usize, r: usize| corners[r * cols + c];
    let mut o: Vec<Vec2> = (0..cols).map(|c| at(c, 0)).collect();
    o.extend((1..rows).map(|r| at(cols - 1, r)));
    o.extend((0..cols - 1).rev().map(|c| at(c, rows - 1)));
    o.extend((1..rows - 1).rev().map(|r| at(0, r)));
    o
}

/// A frame corner counts as covered when a detected corner lies within this share of the
/// width and height from it.
pub const FRAME_CORNER_SHARE: f64 = 0.15;

/// Coverage of the frame by the boards' full-grid corner sets (`cols x rows`, row-major),
/// sampled on a 1%-of-the-side grid.
pub fn coverage(boards: &[&[Vec2]], cols: usize, rows: usize, size: (u32, u32)) -> Coverage {
    let (w, h) = (size.0 as f64, size.1 as f64);
    let outlines: Vec<Vec<Vec2>> =
        boards.iter().filter(|b| b.len() == cols * rows).map(|b| outline(b, cols, rows)).collect();
    let n = 100;
    let mut covered = 0;
    for j in 0..n {
        for i in 0..n {
            let p = Vec2::new((i as f64 + 0.5) / n as f64 * w - 0.5, (j as f64 + 0.5) / n as f64 * h - 0.5);
            if outlines.iter().any(|o| inside(o, p)) {
                covered += 1;
            }
        }
    }
    let near = |fx: f64, fy: f64| {
        boards.iter().flat_map(|b| b.iter()).any(|c| {
            let dx = if fx == 0.0 { c.x + 0.5 } else { w - 0.5 - c.x };
            let dy = if fy == 0.0 { c.y + 0.5 } else { h - 0.5 - c.y };
            dx <= FRAME_CORNER_SHARE * w && dy <= FRAME_CORNER_SHARE * h
        })
    };
    let uncovered_frame_corners =
        [("top-left", 0.0, 0.0), ("top-right", 1.0, 0.0), ("bottom-left", 0.0, 1.0), ("bottom-right", 1.0, 1.0)]
            .into_iter()
            .filter(|(_, fx, fy)| !near(*fx, *fy))
            .map(|(name, _, _)| name)
            .collect();
    Coverage { share: covered as f64 / (n * n) as f64, uncovered_frame_corners }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn opencv46_sigma_rescale() {
        // With N >> P the factor tends to 1/sqrt(2).
        let s = one_sigma_from_opencv46(1.0, 1_000_000, 10);
        assert!((s - std::f64::consts::FRAC_1_SQRT_2).abs() < 1e-5, "{s}");
        // calib1: 245 points, 8 intrinsics + 7 poses.
        let s = one_sigma_from_opencv46(1.0, 245, 50);
        assert!((1.0 / s - 1.502).abs() < 1e-3, "{s}");
        assert!(one_sigma_from_opencv46(1.0, 10, 30).is_nan());
    }

    #[test]
    fn robust_sigma_of_rayleigh_lengths() {
        // Deterministic Rayleigh quantiles for sigma 0.3.
        let n = 2001;
        let lengths: Vec<f64> = (1..n).map(|i| 0.3 * (-2.0 * (1.0 - i as f64 / n as f64).ln()).sqrt()).collect();
        let s = robust_sigma_px(&lengths);
        assert!((s - 0.3).abs() < 0.002, "{s}");
    }

    fn synthetic(lengths_per_view: &[Vec<f64>]) -> (Vec<Option<Vec<f64>>>, Inliers) {
        let l: Vec<Option<Vec<f64>>> = lengths_per_view.iter().cloned().map(Some).collect();
        let inl = Inliers {
            corners: lengths_per_view.iter().map(|v| vec![true; v.len()]).collect(),
            views: vec![true; l.len()],
        };
        (l, inl)
    }

    #[test]
    fn culls_a_gross_corner_and_the_worst_photo_only() {
        // Eight photos with residuals 0.1-0.3 px; photo 5 has one corner 3 px off; photo 2
        // is five times noisier than the rest.
        let base: Vec<f64> = (0..40).map(|i| 0.1 + 0.2 * ((i * 7) % 40) as f64 / 40.0).collect();
        let mut views = vec![base.clone(); 8];
        views[5][10] = 3.0;
        views[2] = base.iter().map(|r| r * 5.0).collect();
        let (l, inl) = synthetic(&views);
        let next = cull(&l, &inl, &OutlierRules::default());
        assert!(!next.views[2], "the noisy photo goes");
        assert_eq!(next.views.iter().filter(|u| !**u).count(), 1);
        assert!(!next.corners[5][10]);
        assert_eq!(next.corners[5].iter().filter(|k| !**k).count(), 1);
        // Nothing to do on clean photos.
        let (l, inl) = synthetic(&vec![base; 8]);
        assert_eq!(cull(&l, &inl, &OutlierRules::default()), inl);
    }

    #[test]
    fn never_culls_below_the_minimum_views() {
        let base: Vec<f64> = (0..40).map(|i| 0.1 + 0.01 * i as f64).collect();
        let mut views = vec![base.clone(); 4];
        views[0] = base.iter().map(|r| r * 10.0).collect();
        let (l, inl) = synthetic(&views);
        assert!(cull(&l, &inl, &OutlierRules::default()).views.iter().all(|u| *u));
    }

    #[test]
    fn coverage_of_one_centred_board() {
        // A 3x3 grid spanning the middle half of a 400x300 frame covers a quarter of it.
        let corners: Vec<Vec2> = (0..3)
            .flat_map(|r| (0..3).map(move |c| Vec2::new(99.5 + 100.0 * c as f64, 74.5 + 75.0 * r as f64)))
            .collect();
        let cov = coverage(&[&corners], 3, 3, (400, 300));
        assert!((cov.share - 0.25).abs() < 0.02, "{}", cov.share);
        assert_eq!(cov.uncovered_frame_corners.len(), 4);
        let corner: Vec<Vec2> =
            (0..3).flat_map(|r| (0..3).map(move |c| Vec2::new(2.0 + 10.0 * c as f64, 2.0 + 10.0 * r as f64))).collect();
        let cov = coverage(&[&corners, &corner], 3, 3, (400, 300));
        assert_eq!(cov.uncovered_frame_corners, vec!["top-right", "bottom-left", "bottom-right"]);
    }

    #[test]
    fn residuals_vanish_for_the_true_pose() {
        let camera = CameraModel {
            width_px: 640,
            height_px: 480,
            fx_px: 500.0,
            fy_px: 501.0,
            cx_px: 320.0,
            cy_px: 240.0,
            distortion: fslcal_core::Distortion::from_opencv([-0.2, 0.05, 0.001, 0.0, 0.0]),
        };
        let pose = (Vec3::new(0.1, -0.2, 0.05), Vec3::new(-0.05, 0.02, 0.6));
        let object_m: Vec<Vec3> =
            (0..12).map(|i| Vec3::new(0.02 * (i % 4) as f64, 0.02 * (i / 4) as f64, 0.0)).collect();
        let r = Rotation3::from_scaled_axis(pose.0);
        let image_px = object_m.iter().map(|o| camera.project(&(r * o + pose.1)).unwrap()).collect();
        let view = ViewPoints { object_m, image_px };
        assert!(residuals_px(&camera, &pose, &view).iter().all(|e| e.norm() < 1e-12));
    }
}
