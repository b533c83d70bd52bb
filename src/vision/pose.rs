//! A planar target's pose from its corners: IPPE for the start, then Levenberg-Marquardt.

use fslcal_core::{CameraModel, Plane, Vec2, Vec3};
use nalgebra::Matrix3;
use opencv::calib3d;
use opencv::core::{Mat, Point2d, Point3d, TermCriteria, TermCriteria_Type, Vector, CV_64F};
use opencv::prelude::*;

/// `T_cam_target`: target points `p_t` appear at `rotation * p_t + translation_m` in the
/// camera frame.
#[derive(Clone, Debug)]
pub struct TargetPose {
    pub rotation: Matrix3<f64>,
    pub translation_m: Vec3,
    /// RMS reprojection error of the target's points, pixels.
    pub rms_px: f64,
    pub worst_px: f64,
}

impl TargetPose {
    /// The target's plane (its z = 0) in the camera frame.
    pub fn plane(&self) -> Plane {
        Plane::through(self.translation_m, self.rotation.column(2).into_owned())
    }

    pub fn to_camera(&self, p_target: &Vec3) -> Vec3 {
        self.rotation * p_target + self.translation_m
    }
}

fn camera_matrices(camera: &CameraModel) -> opencv::Result<(Mat, Mat)> {
    let k =
        Mat::from_slice_2d(&[[camera.fx_px, 0.0, camera.cx_px], [0.0, camera.fy_px, camera.cy_px], [0.0, 0.0, 1.0]])?;
    let d = Mat::from_slice(&camera.distortion.to_opencv())?.try_clone()?;
    Ok((k, d))
}

/// Solves `T_cam_target` from matching target points (metres, z = 0) and pixels.
pub fn solve_pose(camera: &CameraModel, object_m: &[Vec3], image_px: &[Vec2]) -> opencv::Result<Option<TargetPose>> {
    let obj: Vector<Point3d> = object_m.iter().map(|p| Point3d::new(p.x, p.y, p.z)).collect();
    let img: Vector<Point2d> = image_px.iter().map(|p| Point2d::new(p.x, p.y)).collect();
    let (k, d) = camera_matrices(camera)?;
    let mut rvec = Mat::default();
    let mut tvec = Mat::default();
    if !calib3d::solve_pnp(&obj, &img, &k, &d, &mut rvec, &mut tvec, false, calib3d::SOLVEPNP_IPPE)? {
        return Ok(None);
    }
    let criteria = TermCriteria::new((TermCriteria_Type::COUNT as i32) | (TermCriteria_Type::EPS as i32), 50, 1e-12)?;
    calib3d::solve_pnp_refine_lm(&obj, &img, &k, &d, &mut rvec, &mut tvec, criteria)?;
    let mut rmat = Mat::default();
    calib3d::rodrigues(&rvec, &mut rmat, &mut Mat::default())?;
    let mut r64 = Mat::default();
    rmat.convert_to(&mut r64, CV_64F, 1.0, 0.0)?;
    let rotation = Matrix3::from_fn(|i, j| *r64.at_2d::<f64>(i as i32, j as i32).unwrap_or(&f64::NAN));
    let t = tvec.data_typed::<f64>()?;
    let translation_m = Vec3::new(t[0], t[1], t[2]);
    if !rotation.iter().all(|v| v.is_finite()) || translation_m.z <= 0.0 {
        return Ok(None);
    }
    let mut pose = TargetPose { rotation, translation_m, rms_px: 0.0, worst_px: 0.0 };
    let errs: Vec<f64> = object_m
        .iter()
        .zip(image_px)
        .map(|(o, i)| camera.project(&pose.to_camera(o)).map_or(f64::INFINITY, |q| (q - i).norm()))
        .collect();
    pose.rms_px = (errs.iter().map(|e| e * e).sum::<f64>() / errs.len() as f64).sqrt();
    pose.worst_px = errs.iter().copied().fold(0.0, f64::max);
    Ok(Some(pose))
}
