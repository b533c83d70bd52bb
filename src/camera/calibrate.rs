//! The camera chain: checkerboard photos to intrinsics, with the figures that say how far
//! to trust them.
//!
//! Per photo (in parallel): find the board at reduced size and refine its corners at full
//! resolution with windows sized from each corner's own square. Then solve
//! (`vision::calibrate_intrinsics`), cull outlier corners and photos (`camera::residuals::cull`),
//! and solve again until nothing changes.

use crate::camera::residuals::{
    corner_limit_px, coverage, cull, one_sigma_from_opencv46, residuals_px, rms_px, Coverage, Inliers, OutlierRules,
    ViewPoints,
};
use crate::vision::{self, EncodedPhoto, SolveOptions, VisionError};
use calib_targets::Checkerboard;
use fslcal_core::{CameraModel, Vec2, Vec3};
use rayon::prelude::*;
use std::path::PathBuf;

pub use super::outcome::{CameraPhotoReport, CameraPhotoStatus, CornerResiduals};

/// Fewer views leave the focal length and the principal point confounded with the poses.
pub const MIN_VIEWS: usize = 4;

#[derive(Clone, Debug)]
pub struct CameraJob {
    pub board: Checkerboard,
    pub rules: OutlierRules,
    pub solve: SolveOptions,
}

impl CameraJob {
    pub fn new(board: Checkerboard) -> Self {
        CameraJob {
            board,
            rules: OutlierRules { min_views: MIN_VIEWS, ..OutlierRules::default() },
            solve: SolveOptions::default(),
        }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum CameraError {
    /// The message already names the photo; not a `source`, or `{:#}` would say it twice.
    #[error("{0}; remove the photo or copy it again")]
    Photo(VisionError),
    #[error("{file}: {w}x{h}, but {first} is {first_w}x{first_h}; calibrate one camera mode at a time (all photos the size the camera writes, none resized or cropped)")]
    MixedSizes { file: String, w: u32, h: u32, first: String, first_w: u32, first_h: u32 },
    #[error("no {cols}x{rows} checkerboard found in any of the {count} photos; --board counts inner corners (where four squares meet), and the whole board must be in the frame")]
    NoBoard { cols: u32, rows: u32, count: usize },
    #[error("the {cols}x{rows} board was found in only {found} of {count} photos; at least {MIN_VIEWS} are needed (take 10-20, board filling different parts of the frame)")]
    TooFewViews { cols: u32, rows: u32, found: usize, count: usize },
    #[error("the intrinsics solve failed ({0}); the photos may show the board from too similar angles: tilt it differently in each")]
    Solve(String),
    #[error("the solve gave an implausible camera (fx {fx:.1}, fy {fy:.1}, cx {cx:.1}, cy {cy:.1} px); tilt the board differently in each photo and cover the frame")]
    Implausible { fx: f64, fy: f64, cx: f64, cy: f64 },
}

impl From<VisionError> for CameraError {
    fn from(e: VisionError) -> Self {
        CameraError::Photo(e)
    }
}

/// Everything `fslcal camera` reports.
#[derive(Clone, Debug)]
pub struct CameraCalibration {
    pub camera: CameraModel,
    /// 1-sigma of fx, fy, cx, cy, k1, k2, p1, p2, k3 (see `one_sigma_from_opencv46`).
    pub sigma: [f64; 9],
    /// OpenCV 4.6's `stdDeviationsIntrinsics` as returned, for comparison.
    pub opencv_std_dev: [f64; 9],
    /// Corners in the final solve, and the solve's free parameters.
    pub points: usize,
    pub free_parameters: usize,
    /// Per point, over the corners in the solve.
    pub rms_px: f64,
    pub worst_px: f64,
    /// Index into `photos` of the photo with the worst corner.
    pub worst_photo: usize,
    /// "x of N" over the used photos' corners, and over the photos with a board.
    pub corner_outliers: (usize, usize),
    pub photo_outliers: (usize, usize),
    /// A corner was an outlier beyond this many of its photo's robust sigmas.
    pub k_corner: f64,
    pub coverage: Coverage,
    pub photos: Vec<CameraPhotoReport>,
    /// Solves run (1 when nothing was culled).
    pub solves: usize,
}

impl CameraCalibration {
    pub fn used_photos(&self) -> usize {
        self.photos.iter().filter(|p| p.status == CameraPhotoStatus::Used).count()
    }
}

struct Detection {
    size: (u32, u32),
    corners: Option<Vec<Vec2>>,
}

fn examine(board: &Checkerboard, path: &std::path::Path) -> Result<Detection, VisionError> {
    let (cols, rows) = (board.inner_cols, board.inner_rows);
    let encoded = EncodedPhoto::read(path)?;
    let size = encoded.dimensions()?;
    let photo = encoded.decode()?;
    let Some(search) = vision::find_checkerboard(&photo, path, cols, rows)? else {
        return Ok(Detection { size, corners: None });
    };
    // Corners a partial grid completes were placed through a homography and refined beside
    // whatever hid them: good enough for a board's plane, not for the lens's distortion.
    if matches!(search.step, vision::SearchStep::Partial { .. }) {
        return Ok(Detection { size, corners: None });
    }
    let mut corners = search.corners_px;
    vision::refine_corners(&photo, &mut corners, cols, rows)
        .map_err(|e| VisionError::OpenCv { path: path.display().to_string(), message: e.message })?;
    Ok(Detection { size, corners: Some(corners) })
}

/// Runs the whole chain. `progress` is called once per photo examined.
pub fn calibrate(
    job: &CameraJob,
    photos: &[PathBuf],
    progress: &(dyn Fn() + Sync),
) -> Result<CameraCalibration, CameraError> {
    vision::use_single_threaded_opencv();
    let (cols, rows) = (job.board.inner_cols, job.board.inner_rows);
    let detections: Vec<Detection> = photos
        .par_iter()
        .map(|p| {
            let d = examine(&job.board, p);
            progress();
            d
        })
        .collect::<Result<_, _>>()?;
    let Some(first) = detections.first() else {
        return Err(CameraError::NoBoard { cols, rows, count: 0 });
    };
    let size = first.size;
    for (p, d) in photos.iter().zip(&detections) {
        if d.size != size {
            return Err(CameraError::MixedSizes {
                file: p.display().to_string(),
                w: d.size.0,
                h: d.size.1,
                first: photos[0].display().to_string(),
                first_w: size.0,
                first_h: size.1,
            });
        }
    }
    let found: Vec<usize> =
        detections.iter().enumerate().filter(|(_, d)| d.corners.is_some()).map(|(i, _)| i).collect();
    if found.is_empty() {
        return Err(CameraError::NoBoard { cols, rows, count: photos.len() });
    }
    if found.len() < MIN_VIEWS {
        return Err(CameraError::TooFewViews { cols, rows, found: found.len(), count: photos.len() });
    }
    let object: Vec<Vec3> = job.board.object_points().iter().map(|p| Vec3::new(p[0], p[1], p[2])).collect();
    let views: Vec<ViewPoints> = found
        .iter()
        .map(|&i| ViewPoints { object_m: object.clone(), image_px: detections[i].corners.clone().unwrap_or_default() })
        .collect();
    solve_views(job, &views, size).map(|fit| report(job, photos, &found, &views, fit))
}

/// The final solve with its residuals and inlier set.
pub struct ViewsFit {
    pub solve: vision::IntrinsicsSolve,
    /// Per view, residual lengths of all its corners (`None` for a rejected view).
    pub lengths: Vec<Option<Vec<f64>>>,
    pub inliers: Inliers,
    pub solves: usize,
}

/// Solve, cull, re-solve until the inlier set stops changing.
pub fn solve_views(job: &CameraJob, views: &[ViewPoints], size: (u32, u32)) -> Result<ViewsFit, CameraError> {
    let mut inliers = Inliers::all(views);
    let mut solves = 0;
    loop {
        let (selected, index) = inliers.select(views);
        let solve =
            vision::calibrate_intrinsics(&selected, size, job.solve).map_err(|e| CameraError::Solve(e.message))?;
        solves += 1;
        let c = &solve.camera;
        if !c.is_plausible() {
            return Err(CameraError::Implausible { fx: c.fx_px, fy: c.fy_px, cx: c.cx_px, cy: c.cy_px });
        }
        let mut lengths = vec![None; views.len()];
        for (k, &i) in index.iter().enumerate() {
            lengths[i] = Some(residuals_px(c, &solve.poses[k], &views[i]).iter().map(|r| r.norm()).collect());
        }
        let next = cull(&lengths, &inliers, &job.rules);
        if next == inliers || solves >= job.rules.max_rounds {
            return Ok(ViewsFit { solve, lengths, inliers, solves });
        }
        inliers = next;
    }
}

fn report(
    job: &CameraJob,
    photos: &[PathBuf],
    found: &[usize],
    views: &[ViewPoints],
    fit: ViewsFit,
) -> CameraCalibration {
    let (reports, inlier_lengths) = photo_reports(job, photos, found, views, &fit);
    let (worst_photo, worst_px) = reports
        .iter()
        .enumerate()
        .filter(|(_, r)| r.status == CameraPhotoStatus::Used)
        .filter_map(|(i, r)| Some((i, r.worst_px?)))
        .fold((0, 0.0), |worst, (i, w)| if w > worst.1 { (i, w) } else { worst });
    let camera = fit.solve.camera;
    let (points, all_corners) = fit.inliers.corner_count();
    let boards: Vec<&[Vec2]> = fit.inliers.used_views().map(|v| views[v].image_px.as_slice()).collect();
    let (cols, rows) = (job.board.inner_cols as usize, job.board.inner_rows as usize);
    let cov = coverage(&boards, cols, rows, (camera.width_px, camera.height_px));
    let sigma = fit.solve.opencv_std_dev.map(|o| one_sigma_from_opencv46(o, points, fit.solve.free_parameters));
    let rejected = fit.inliers.views.iter().filter(|u| !**u).count();
    CameraCalibration {
        camera,
        sigma,
        opencv_std_dev: fit.solve.opencv_std_dev,
        points,
        free_parameters: fit.solve.free_parameters,
        rms_px: rms_px(inlier_lengths.iter().copied()),
        worst_px,
        worst_photo,
        corner_outliers: (all_corners - points, all_corners),
        photo_outliers: (rejected, found.len()),
        k_corner: job.rules.k_corner,
        coverage: cov,
        photos: reports,
        solves: fit.solves,
    }
}

/// Every photo's line, and the residual lengths of all corners in the final solve.
fn photo_reports(
    job: &CameraJob,
    photos: &[PathBuf],
    found: &[usize],
    views: &[ViewPoints],
    fit: &ViewsFit,
) -> (Vec<CameraPhotoReport>, Vec<f64>) {
    let mut reports: Vec<CameraPhotoReport> =
        photos.iter().map(|p| CameraPhotoReport::no_board(p.display().to_string())).collect();
    let pose_index: std::collections::HashMap<usize, usize> =
        fit.inliers.used_views().enumerate().map(|(k, v)| (v, k)).collect();
    let mut inlier_lengths = Vec::new();
    for (v, &photo) in found.iter().enumerate() {
        let r = &mut reports[photo];
        r.corners_found = Some(views[v].image_px.len());
        match &fit.lengths[v] {
            Some(lengths) => {
                let pose = pose_index.get(&v).copied();
                inlier_lengths.extend(used_view(job, fit, (v, &views[v]), pose, lengths, r));
            }
            None => rejected_view(&fit.solve.camera, &views[v], r),
        }
    }
    (reports, inlier_lengths)
}

/// Fills a used photo's line from the final solve (view number `v`, its pose `pose` among
/// the solve's); returns the residual lengths of its corners in the solve.
fn used_view(
    job: &CameraJob,
    fit: &ViewsFit,
    (v, view): (usize, &ViewPoints),
    pose: Option<usize>,
    lengths: &[f64],
    r: &mut CameraPhotoReport,
) -> Vec<f64> {
    let kept: Vec<f64> = lengths.iter().zip(&fit.inliers.corners[v]).filter(|(_, k)| **k).map(|(l, _)| *l).collect();
    r.status = CameraPhotoStatus::Used;
    r.rms_px = Some(rms_px(kept.iter().copied()));
    r.worst_px = Some(kept.iter().copied().fold(0.0, f64::max));
    r.corners_used = Some(kept.len());
    r.corner_limit_px = Some(corner_limit_px(lengths, &job.rules));
    if let Some(k) = pose {
        r.corners = Some(CornerResiduals {
            corners_px: view.image_px.clone(),
            residuals_px: residuals_px(&fit.solve.camera, &fit.solve.poses[k], view),
            inlier: fit.inliers.corners[v].clone(),
        });
    }
    kept
}

/// Fills a rejected photo's line: how far off it is under the final camera, from its own
/// best pose.
fn rejected_view(camera: &CameraModel, view: &ViewPoints, r: &mut CameraPhotoReport) {
    r.status = CameraPhotoStatus::Rejected;
    r.corners_used = Some(0);
    let Ok(Some(pose)) = vision::solve_pose(camera, &view.object_m, &view.image_px) else { return };
    r.rms_px = Some(pose.rms_px);
    r.worst_px = Some(pose.worst_px);
    let residuals = view
        .object_m
        .iter()
        .zip(&view.image_px)
        .map(|(o, i)| camera.project(&pose.to_camera(o)).map_or(Vec2::new(f64::INFINITY, f64::INFINITY), |q| i - q))
        .collect();
    r.corners = Some(CornerResiduals {
        corners_px: view.image_px.clone(),
        residuals_px: residuals,
        inlier: vec![false; view.image_px.len()],
    });
}
