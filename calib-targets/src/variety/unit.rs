//! A unit at random: one TG-6-like camera and one laser pointer clamped somewhere around the
//! lens, fixed for a whole set of photos, and its truth written as a calibration file.

use super::look::LaserLook;
use crate::random::SplitMix;
use fslcal_core::{CameraModel, Distortion, LaserLine, Vec3};
use serde::{Deserialize, Serialize};

/// One camera and one laser, as they really are.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Unit {
    pub camera: CameraModel,
    pub laser: LaserLine,
    pub laser_look: LaserLook,
    /// The camera's tone curve: an in-camera JPEG's level is `255 (linear / 255)^(1 /
    /// tone_gamma)` (1: linear, as a raw developed flat; sRGB is close to 2.2).
    #[serde(default = "linear_tone")]
    pub tone_gamma: f64,
}

fn linear_tone() -> f64 {
    1.0
}

/// Tone curves drawn, gamma: from a flat (linear) development to a contrasty in-camera JPEG.
pub const TONE_GAMMA_RANGE: (f64, f64) = (1.0, 2.4);

/// A photo `width_px` wide (4:3) from a TG-6 behind a corrective port, intrinsics varied
/// as between bodies and ports: focal length ±3%, principal point ±25 px, barrel distortion
/// of varying strength. Smaller widths scale the same camera down.
pub(crate) fn draw_camera(rng: &mut SplitMix, width_px: u32) -> CameraModel {
    let scale = width_px as f64 / 4000.0;
    let fx = 2950.0 * rng.range(0.97, 1.03);
    let fy = fx * rng.range(0.998, 1.002);
    let cx = 1999.5 + rng.range(-25.0, 25.0);
    let cy = 1499.5 + rng.range(-25.0, 25.0);
    let dist = [
        rng.range(-0.22, -0.14),
        rng.range(0.05, 0.12),
        rng.range(-0.001, 0.001),
        rng.range(-0.001, 0.001),
        rng.range(-0.04, 0.0),
    ];
    // Pixel-centre convention: a pixel's centre at i in the full photo is at (i + 0.5) s - 0.5.
    CameraModel {
        width_px,
        height_px: width_px * 3 / 4,
        fx_px: fx * scale,
        fy_px: fy * scale,
        cx_px: (cx + 0.5) * scale - 0.5,
        cy_px: (cy + 0.5) * scale - 0.5,
        distortion: Distortion::from_opencv(dist),
    }
}

/// A laser clamped 85-135 mm from the lens at any angle around it, aimed to cross the
/// optical axis somewhere between 4 m and far beyond (or to run parallel), knocked up to
/// 0.3 degrees off that aim by the mount.
pub(crate) fn draw_laser(rng: &mut SplitMix) -> LaserLine {
    let around = rng.range(0.0, std::f64::consts::TAU);
    let baseline = rng.range(0.085, 0.135);
    let origin = Vec3::new(baseline * around.cos(), baseline * around.sin(), 0.0);
    // 1/D uniform: convergence at 4 m to parallel.
    let converge_per_m = rng.range(0.0, 0.25);
    let knock = 0.3f64.to_radians();
    let direction = Vec3::new(
        -origin.x * converge_per_m + rng.range(-knock, knock),
        -origin.y * converge_per_m + rng.range(-knock, knock),
        1.0,
    );
    LaserLine::from_point_direction(origin, direction).expect("the laser points forward")
}

pub(crate) fn draw_unit(seed: u64, width_px: u32) -> Unit {
    let mut rng = SplitMix::derive(seed, 0x0417);
    let (camera, laser, laser_look) =
        (draw_camera(&mut rng, width_px), draw_laser(&mut rng), LaserLook::draw(&mut rng));
    // Its own stream, so that adding the curve left every other draw of a seed as it was.
    let tone_gamma = SplitMix::derive(seed, 0x70_4E).range(TONE_GAMMA_RANGE.0, TONE_GAMMA_RANGE.1);
    Unit { camera, laser, laser_look, tone_gamma }
}

/// The unit's truth as a calibration file fslcal reads with `--cal`: the JSON `fslcal laser
/// --out` writes (`camera`, `laser` with a covariance, `depth_range_m`). The covariance is
/// what a good 15-photo fit reports (0.5 mm on the origin, 0.2 mrad on the direction).
pub fn calibration_json(unit: &Unit, depth_range_m: (f64, f64)) -> serde_json::Value {
    let c = &unit.camera;
    let (o, d) = (0.5e-3f64.powi(2), 0.2e-3f64.powi(2));
    serde_json::json!({
        "camera": {
            "image_size": [c.width_px, c.height_px],
            "fx": c.fx_px, "fy": c.fy_px, "cx": c.cx_px, "cy": c.cy_px,
            "dist": c.distortion.to_opencv(),
        },
        "laser": {
            "origin_m": unit.laser.origin_m,
            "direction": unit.laser.direction,
            "covariance": [[o, 0.0, 0.0, 0.0], [0.0, o, 0.0, 0.0], [0.0, 0.0, d, 0.0], [0.0, 0.0, 0.0, d]],
        },
        "depth_range_m": [depth_range_m.0, depth_range_m.1],
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn units_keep_the_dot_in_frame_and_the_baseline_plausible() {
        for seed in 0..200 {
            let unit = draw_unit(seed, 4000);
            let b = unit.laser.baseline_m();
            assert!((0.085..=0.135).contains(&b), "seed {seed}: baseline {b}");
            for z in [0.5, 1.0, 2.5, 5.0] {
                let p = unit.laser.pixel_at_depth(&unit.camera, z).unwrap();
                assert!(unit.camera.contains(p), "seed {seed}: dot at {z} m is at {p:?}");
            }
        }
    }

    #[test]
    fn a_smaller_photo_is_the_same_camera_scaled() {
        let (a, b) = (draw_unit(7, 4000), draw_unit(7, 1000));
        assert_eq!(a.laser, b.laser);
        let p = Vec3::new(0.3, -0.2, 2.0);
        let (pa, pb) = (a.camera.project(&p).unwrap(), b.camera.project(&p).unwrap());
        // Pixel centres: (i + 0.5) / 4 - 0.5.
        assert!(((pa.x + 0.5) / 4.0 - 0.5 - pb.x).abs() < 1e-9 && ((pa.y + 0.5) / 4.0 - 0.5 - pb.y).abs() < 1e-9);
    }
}
