//! The FishSense Lite rig as the synthetic scenes model it.

use fslcal_core::{CameraModel, Distortion, LaserLine, Vec3};

/// An Olympus TG-6 behind its housing's wide-angle corrective port, calibrated under water:
/// 4000x3000, strong barrel distortion.
pub fn tg6_camera() -> CameraModel {
    CameraModel {
        width_px: 4000,
        height_px: 3000,
        fx_px: 2950.0,
        fy_px: 2948.0,
        cx_px: 2004.5,
        cy_px: 1497.0,
        distortion: Distortion::from_opencv([-0.18, 0.09, 0.0006, -0.0004, -0.02]),
    }
}

/// A laser clamped left of and below the lens, converging slightly on the optical axis, as
/// on a 3D-printed FSL mount: baseline 11.2 cm.
pub fn fsl_laser() -> LaserLine {
    LaserLine::from_point_direction(Vec3::new(-0.040, -0.105, 0.0), Vec3::new(0.0105, 0.0220, 1.0))
        .expect("the rig's laser points forward")
}
