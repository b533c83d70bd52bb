//! The intrinsics solve: OpenCV's `calibrateCameraExtended` (Zhang's closed-form start, then
//! Levenberg-Marquardt over the intrinsics and every view's pose), with the 5-coefficient
//! distortion model. Outlier handling and the report live outside, in `camera::residuals`.

use crate::camera::residuals::ViewPoints;
use fslcal_core::{CameraModel, Distortion, Vec3};
use opencv::calib3d;
use opencv::core::{Mat, Point2f, Point3f, Size, TermCriteria, TermCriteria_Type, Vector, CV_64F};
use opencv::prelude::*;

#[derive(Clone, Copy, Debug, Default)]
pub struct SolveOptions {
    /// Hold k3 at zero (Bouguet's toolbox does by default; the solver golden needs it).
    pub fix_k3: bool,
}

/// What the solver returns, as OpenCV computes it.
#[derive(Clone, Debug)]
pub struct IntrinsicsSolve {
    pub camera: CameraModel,
    /// Per view: `T_cam_target` as a rotation vector (radians, axis times angle) and a
    /// translation (metres).
    pub poses: Vec<(Vec3, Vec3)>,
    /// OpenCV's `stdDeviationsIntrinsics` for fx, fy, cx, cy, k1, k2, p1, p2, k3, unscaled.
    /// OpenCV 4.6 estimates the noise variance as (sum of squared residual lengths) / (N - P)
    /// with N the number of *points*; `camera::residuals` rescales them to 1-sigma.
    pub opencv_std_dev: [f64; 9],
    /// Number of free parameters (intrinsics not fixed, plus 6 per view).
    pub free_parameters: usize,
}

fn mat_to_vec3(m: &Mat) -> opencv::Result<Vec3> {
    let mut d = Mat::default();
    m.convert_to(&mut d, CV_64F, 1.0, 0.0)?;
    let v = d.data_typed::<f64>()?;
    Ok(Vec3::new(v[0], v[1], v[2]))
}

/// Solves the intrinsics from at least 4 views (OpenCV needs 4+ points per view; a
/// checkerboard view always has them).
pub fn calibrate_intrinsics(
    views: &[ViewPoints],
    image_size: (u32, u32),
    options: SolveOptions,
) -> opencv::Result<IntrinsicsSolve> {
    let object: Vector<Vector<Point3f>> = views
        .iter()
        .map(|v| v.object_m.iter().map(|p| Point3f::new(p.x as f32, p.y as f32, p.z as f32)).collect())
        .collect();
    let image: Vector<Vector<Point2f>> =
        views.iter().map(|v| v.image_px.iter().map(|p| Point2f::new(p.x as f32, p.y as f32)).collect()).collect();
    let mut k = Mat::default();
    let mut d = Mat::default();
    let mut rvecs = Vector::<Mat>::new();
    let mut tvecs = Vector::<Mat>::new();
    let mut std_intrinsics = Mat::default();
    let mut std_extrinsics = Mat::default();
    let mut per_view = Mat::default();
    let flags = if options.fix_k3 { calib3d::CALIB_FIX_K3 } else { 0 };
    // OpenCV's default stops at 30 iterations, short of convergence on strongly distorted
    // lenses; the golden agrees to 1e-3 px only when LM runs to the end.
    let criteria =
        TermCriteria::new((TermCriteria_Type::COUNT as i32) | (TermCriteria_Type::EPS as i32), 200, f64::EPSILON)?;
    calib3d::calibrate_camera_extended(
        &object,
        &image,
        Size::new(image_size.0 as i32, image_size.1 as i32),
        &mut k,
        &mut d,
        &mut rvecs,
        &mut tvecs,
        &mut std_intrinsics,
        &mut std_extrinsics,
        &mut per_view,
        flags,
        criteria,
    )?;
    let at = |r: i32, c: i32| k.at_2d::<f64>(r, c).copied();
    let dist = d.data_typed::<f64>()?;
    let mut coefficients = [0.0; 5];
    for (c, v) in coefficients.iter_mut().zip(dist) {
        *c = *v;
    }
    let camera = CameraModel {
        width_px: image_size.0,
        height_px: image_size.1,
        fx_px: at(0, 0)?,
        fy_px: at(1, 1)?,
        cx_px: at(0, 2)?,
        cy_px: at(1, 2)?,
        distortion: Distortion::from_opencv(coefficients),
    };
    // stdDeviationsIntrinsics is (fx, fy, cx, cy, k1, k2, p1, p2, k3, k4, ...).
    let s = std_intrinsics.data_typed::<f64>()?;
    let mut opencv_std_dev = [0.0; 9];
    for (o, v) in opencv_std_dev.iter_mut().zip(s) {
        *o = *v;
    }
    let poses = rvecs
        .iter()
        .zip(tvecs.iter())
        .map(|(r, t)| Ok((mat_to_vec3(&r)?, mat_to_vec3(&t)?)))
        .collect::<opencv::Result<Vec<_>>>()?;
    let free_intrinsics = if options.fix_k3 { 8 } else { 9 };
    Ok(IntrinsicsSolve { camera, poses, opencv_std_dev, free_parameters: free_intrinsics + 6 * views.len() })
}
