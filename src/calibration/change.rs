//! What a change of calibration means in the water: how far the laser moved, and how wrong
//! distances and fish lengths come out if the old calibration is still used after the move.

use crate::calibration::Calibration;
use crate::laser::fit::angle_deg;
use fslcal_core::Vec3;
use serde::Serialize;

/// The fish used to express length errors: 500 mm long, square to the optical axis,
/// centred on the laser dot.
pub const REFERENCE_FISH_M: f64 = 0.5;
/// Depths at which the errors are reported, metres.
pub const DEPTHS_M: [f64; 3] = [1.0, 3.0, 5.0];

/// Errors at one depth when the old calibration reads a photo taken with the new rig.
#[derive(Clone, Copy, Debug, Serialize, PartialEq)]
pub struct ErrorAtDepth {
    pub depth_m: f64,
    /// Old calibration's distance minus the true one (null where the old line has no answer).
    pub distance_error_m: Option<f64>,
    /// Length error of the reference fish, percent of its length.
    pub length_error_pct: Option<f64>,
}

#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct CalibrationChange {
    pub direction_change_deg: f64,
    pub origin_change_mm: f64,
    pub errors: Vec<ErrorAtDepth>,
}

/// Compares `old` with `new`, taking `new` as the truth.
pub fn compare(old: &Calibration, new: &Calibration) -> CalibrationChange {
    let errors = DEPTHS_M
        .iter()
        .map(|&z| {
            let dot = new.laser.point_at_depth(z);
            let old_depth =
                new.camera.project(&dot).and_then(|px| old.laser.fix_from_pixel(&old.camera, px)).map(|f| f.depth_m);
            let half = Vec3::new(REFERENCE_FISH_M / 2.0, 0.0, 0.0);
            let length = old_depth.and_then(|d| {
                let head = new.camera.project(&(dot - half))?;
                let tail = new.camera.project(&(dot + half))?;
                old.camera.length_at_depth(head, tail, d)
            });
            ErrorAtDepth {
                depth_m: z,
                distance_error_m: old_depth.map(|d| d - z),
                length_error_pct: length.map(|l| 100.0 * (l / REFERENCE_FISH_M - 1.0)),
            }
        })
        .collect();
    let (o, n) = (old.laser.origin(), new.laser.origin());
    CalibrationChange {
        direction_change_deg: angle_deg(&old.laser.direction, &new.laser.direction),
        origin_change_mm: (o - n).norm() * 1e3,
        errors,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fslcal_core::{CameraModel, Distortion, LaserLine};
    use std::path::PathBuf;

    fn cal(origin_m: Vec3, direction: Vec3) -> Calibration {
        Calibration {
            camera: CameraModel {
                width_px: 4000,
                height_px: 3000,
                fx_px: 2900.0,
                fy_px: 2900.0,
                cx_px: 2000.0,
                cy_px: 1500.0,
                distortion: Distortion::from_opencv([-0.1, 0.03, 0.0, 0.0, 0.0]),
            },
            laser: LaserLine::from_point_direction(origin_m, direction).unwrap(),
            laser_covariance: [[0.0; 4]; 4],
            depth_range_m: None,
            unit: None,
            focal_length_mm: None,
            camera_serial: None,
            laser_colour: None,
            source: PathBuf::new(),
        }
    }

    #[test]
    fn no_change_no_error() {
        let a = cal(Vec3::new(-0.04, -0.11, 0.0), Vec3::new(0.01, 0.03, 1.0));
        let c = compare(&a, &a);
        assert_eq!(c.direction_change_deg, 0.0);
        assert_eq!(c.origin_change_mm, 0.0);
        for e in &c.errors {
            assert!(e.distance_error_m.unwrap().abs() < 1e-9 && e.length_error_pct.unwrap().abs() < 1e-6, "{e:?}");
        }
    }

    #[test]
    fn a_knocked_laser_gives_the_triangulation_error() {
        // Tilting the beam 0.2 deg towards the camera in the plane of camera and laser: the
        // dot at depth z shifts by z*tan(0.2 deg) sideways, read by the old line as a depth
        // change of about z^2 tan(0.2 deg) / baseline (triangulation), growing with depth.
        // Laser straight below the camera, so camera, beam and dot stay in the y-z plane.
        let below = Vec3::new(0.0, -0.11, 0.0);
        let old = cal(below, Vec3::new(0.0, 0.0, 1.0));
        let tilt = 0.2_f64.to_radians();
        let new = cal(below, Vec3::new(0.0, tilt.tan(), 1.0));
        let c = compare(&old, &new);
        assert!((c.direction_change_deg - 0.2).abs() < 1e-9);
        assert_eq!(c.origin_change_mm, 0.0);
        for e in &c.errors {
            let z = e.depth_m;
            // The dot at (.., -0.11 + z t, z) lies on the old beam's image at depth
            // z' = 0.11 z / (0.11 - z t) (similar triangles in the y-z plane).
            let expect = 0.11 * z / (0.11 - z * tilt.tan()) - z;
            let got = e.distance_error_m.unwrap();
            assert!((got - expect).abs() < 1e-6 * z, "z {z}: {got} vs {expect}");
            // Same camera: length scales with the depth read.
            assert!((e.length_error_pct.unwrap() - 100.0 * got / z).abs() < 1e-6, "{e:?}");
        }
        assert!(c.errors[2].distance_error_m.unwrap() > 5.0 * c.errors[0].distance_error_m.unwrap());
    }
}
