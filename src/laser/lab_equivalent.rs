//! What the FishSense lab's own `fsl calibrate-laser` would have fitted on fslcal's dots,
//! and how far that lies from fslcal's fit, so a lab member can judge the switch on their
//! own data.
//!
//! The lab's tool (fishsense-lite `calibrate_laser.py`, pyfishsensedev's
//! `atanasov_calibration_method`) takes every labelled dot whose board it found, puts it on
//! the board's plane, and fits the line by the thesis's averaging rule (§3.4.2): the
//! direction is the normalised sum of the pairwise differences, the origin where the line
//! through the dots' centroid crosses z = 0. No dot is weighed by what its pixel tells and
//! none is left out. It orients each difference by depth where [`fit::fit_average`] orders
//! the dots by range; the two agree whenever the dots' depth order is their range order, as
//! it is for dots along a laser within a few degrees of the optical axis.

use super::fit::{self, LaserFit};
use fslcal_core::{CameraModel, LaserLine, Vec3};

/// The lab's fit beside fslcal's.
#[derive(Clone, Debug, PartialEq)]
pub struct LabEquivalent {
    pub laser: LaserLine,
    /// Dots it was fitted on: every photo with a dot on its target, fslcal's outliers too.
    pub dots: usize,
    /// Of those, the ones fslcal left out as outliers.
    pub left_out_by_fslcal: usize,
    /// Angle between the two directions, degrees.
    pub angle_deg: f64,
    /// Distance between the two origins (both on z = 0), millimetres.
    pub origin_difference_mm: f64,
    /// For a dot fslcal puts at depth z (m): the lab's depth for the same pixel minus z,
    /// metres. `None` where the lab's line gives no depth for that pixel.
    pub distance_difference_m: Vec<(f64, Option<f64>)>,
}

/// The depths the comparison is made at, metres (those of the predicted sigma).
pub const DEPTHS_M: [f64; 3] = [1.0, 3.0, 5.0];

/// The lab's averaging fit on the dots of `fslcal_fit`, compared with it. `None` with fewer
/// than two dots or a degenerate average.
pub fn lab_equivalent(camera: &CameraModel, fslcal_fit: &LaserFit) -> Option<LabEquivalent> {
    let dots: Vec<&fit::PhotoFit> = fslcal_fit.photos.iter().flatten().collect();
    let points: Vec<Vec3> = dots.iter().map(|p| Vec3::from(p.point_m)).collect();
    let laser = fit::fit_average(&points)?;
    let ours = &fslcal_fit.laser;
    let distance_difference_m = DEPTHS_M
        .iter()
        .map(|&z| {
            let px = ours.pixel_at_depth(camera, z)?;
            Some(laser.fix_from_pixel(camera, px)?.depth_m - z)
        })
        .zip(DEPTHS_M)
        .map(|(d, z)| (z, d))
        .collect();
    Some(LabEquivalent {
        laser,
        dots: dots.len(),
        left_out_by_fslcal: dots.iter().filter(|p| p.outlier.is_some()).count(),
        angle_deg: fit::angle_deg(&laser.direction, &ours.direction),
        origin_difference_mm: (laser.origin() - ours.origin()).norm() * 1e3,
        distance_difference_m,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::laser::fit::{DotObservation, Gates, Method};
    use fslcal_core::{Distortion, Plane, Vec2};

    fn camera() -> CameraModel {
        CameraModel {
            width_px: 4000,
            height_px: 3000,
            fx_px: 2950.0,
            fy_px: 2950.0,
            cx_px: 2000.0,
            cy_px: 1500.0,
            distortion: Distortion::from_opencv([-0.15, 0.07, 0.0, 0.0, -0.01]),
        }
    }

    /// Dots on slightly tilted boards at 0.6-4.5 m from `truth`; `bad` moves one dot by a push.
    fn observations(truth: &LaserLine, bad: Option<(usize, Vec2)>) -> Vec<Option<DotObservation>> {
        (0..10)
            .map(|i| {
                let z = 0.6 + 3.9 * i as f64 / 9.0;
                let plane = Plane::through(truth.point_at_depth(z), Vec3::new(0.05, -0.03, -1.0));
                let mut px = camera().project(&truth.hit(&plane).unwrap()).unwrap();
                if let Some((_, push)) = bad.filter(|(k, _)| *k == i) {
                    px += push;
                }
                Some(DotObservation { plane, candidates: vec![px], sigma_px: 0.5 })
            })
            .collect()
    }

    #[test]
    fn on_clean_dots_the_lab_fit_is_fslcals_and_a_bad_dot_pulls_only_the_lab_fit() {
        let truth =
            LaserLine::from_point_direction(Vec3::new(-0.04, -0.105, 0.0), Vec3::new(0.01, 0.025, 1.0)).unwrap();
        let f = fit::fit(&camera(), &observations(&truth, None), Method::Reprojection, &Gates::default()).unwrap();
        let lab = lab_equivalent(&camera(), &f).unwrap();
        assert_eq!((lab.dots, lab.left_out_by_fslcal), (10, 0));
        assert!(lab.angle_deg < 1e-6 && lab.origin_difference_mm < 1e-6, "{lab:?}");
        assert!(lab.distance_difference_m.iter().all(|(_, d)| d.unwrap().abs() < 1e-6), "{lab:?}");

        // A dot clicked 30 px off on the far board: fslcal leaves it out, the lab's fit
        // takes it and reads a far fish's distance differently.
        let obs = observations(&truth, Some((9, Vec2::new(30.0, -30.0))));
        let f = fit::fit(&camera(), &obs, Method::Reprojection, &Gates::default()).unwrap();
        let lab = lab_equivalent(&camera(), &f).unwrap();
        assert_eq!((lab.dots, lab.left_out_by_fslcal), (10, 1));
        assert!(fit::angle_deg(&f.laser.direction, &truth.direction) < 1e-6);
        let at5 = lab.distance_difference_m[2];
        assert_eq!(at5.0, 5.0);
        assert!(lab.angle_deg > 0.01 && at5.1.unwrap().abs() > 0.01, "{lab:?}");
    }
}
