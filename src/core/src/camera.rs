//! Pinhole camera with OpenCV's 5-coefficient (k1, k2, p1, p2, k3) distortion model.

use crate::{Vec2, Vec3};
use serde::{Deserialize, Serialize};

/// OpenCV's radial-tangential distortion, in OpenCV's order `[k1, k2, p1, p2, k3]`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, Default)]
pub struct Distortion {
    pub k1: f64,
    pub k2: f64,
    pub p1: f64,
    pub p2: f64,
    pub k3: f64,
}

impl Distortion {
    pub const NONE: Distortion = Distortion { k1: 0.0, k2: 0.0, p1: 0.0, p2: 0.0, k3: 0.0 };

    pub fn from_opencv(c: [f64; 5]) -> Self {
        Distortion { k1: c[0], k2: c[1], p1: c[2], p2: c[3], k3: c[4] }
    }

    pub fn to_opencv(&self) -> [f64; 5] {
        [self.k1, self.k2, self.p1, self.p2, self.k3]
    }

    /// Maps ideal normalised coordinates to distorted normalised coordinates.
    pub fn apply(&self, x: Vec2) -> Vec2 {
        let (a, b) = (x.x, x.y);
        let r2 = a * a + b * b;
        let radial = 1.0 + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3));
        Vec2::new(
            a * radial + 2.0 * self.p1 * a * b + self.p2 * (r2 + 2.0 * a * a),
            b * radial + self.p1 * (r2 + 2.0 * b * b) + 2.0 * self.p2 * a * b,
        )
    }

    /// Jacobian of [`Distortion::apply`] with respect to its input, row-major 2x2.
    fn jacobian(&self, x: Vec2) -> [[f64; 2]; 2] {
        let (a, b) = (x.x, x.y);
        let r2 = a * a + b * b;
        let radial = 1.0 + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3));
        // d(radial)/d(r2)
        let dr = self.k1 + r2 * (2.0 * self.k2 + 3.0 * r2 * self.k3);
        [
            [
                radial + a * dr * 2.0 * a + 2.0 * self.p1 * b + 6.0 * self.p2 * a,
                a * dr * 2.0 * b + 2.0 * self.p1 * a + 2.0 * self.p2 * b,
            ],
            [
                b * dr * 2.0 * a + 2.0 * self.p1 * a + 2.0 * self.p2 * b,
                radial + b * dr * 2.0 * b + 6.0 * self.p1 * b + 2.0 * self.p2 * a,
            ],
        ]
    }

    /// Inverts [`Distortion::apply`] by Newton's method. `None` where it does not converge
    /// (far outside the region the model was fitted on, where the polynomial folds over).
    pub fn remove(&self, distorted: Vec2) -> Option<Vec2> {
        let mut x = distorted;
        for _ in 0..50 {
            let f = self.apply(x) - distorted;
            if f.x.abs() < 1e-14 && f.y.abs() < 1e-14 {
                return Some(x);
            }
            let j = self.jacobian(x);
            let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
            if !det.is_finite() || det.abs() < 1e-12 {
                return None;
            }
            let dx = (j[1][1] * f.x - j[0][1] * f.y) / det;
            let dy = (-j[1][0] * f.x + j[0][0] * f.y) / det;
            x -= Vec2::new(dx, dy);
            if !x.x.is_finite() || !x.y.is_finite() {
                return None;
            }
        }
        let f = self.apply(x) - distorted;
        (f.norm() < 1e-9).then_some(x)
    }
}

/// A calibrated camera: image size, focal lengths and principal point, distortion.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CameraModel {
    /// Image width and height in pixels.
    pub width_px: u32,
    pub height_px: u32,
    /// Focal lengths in pixels.
    pub fx_px: f64,
    pub fy_px: f64,
    /// Principal point in pixels (OpenCV pixel-centre convention).
    pub cx_px: f64,
    pub cy_px: f64,
    pub distortion: Distortion,
}

impl CameraModel {
    /// Normalised image coordinates (x/z, y/z) of a camera-frame point, before distortion.
    /// `None` for points at or behind the camera.
    pub fn normalise(p_cam: &Vec3) -> Option<Vec2> {
        (p_cam.z > 1e-12).then(|| Vec2::new(p_cam.x / p_cam.z, p_cam.y / p_cam.z))
    }

    /// Pixel of ideal normalised coordinates, distortion applied.
    pub fn pixel_of_normalised(&self, x: Vec2) -> Vec2 {
        let d = self.distortion.apply(x);
        Vec2::new(self.fx_px * d.x + self.cx_px, self.fy_px * d.y + self.cy_px)
    }

    /// Pixel where a camera-frame point appears. `None` behind the camera.
    pub fn project(&self, p_cam: &Vec3) -> Option<Vec2> {
        Self::normalise(p_cam).map(|x| self.pixel_of_normalised(x))
    }

    /// Ideal normalised coordinates of a pixel (distortion removed).
    pub fn undistort(&self, pixel: Vec2) -> Option<Vec2> {
        let d = Vec2::new((pixel.x - self.cx_px) / self.fx_px, (pixel.y - self.cy_px) / self.fy_px);
        self.distortion.remove(d)
    }

    /// Unit ray through a pixel, camera frame (z > 0).
    pub fn ray(&self, pixel: Vec2) -> Option<Vec3> {
        self.undistort(pixel).map(|x| Vec3::new(x.x, x.y, 1.0).normalize())
    }

    /// True when the pixel lies inside the image (pixel-centre convention).
    pub fn contains(&self, pixel: Vec2) -> bool {
        pixel.x >= -0.5
            && pixel.y >= -0.5
            && pixel.x <= self.width_px as f64 - 0.5
            && pixel.y <= self.height_px as f64 - 0.5
    }

    /// Camera-frame distance between the points seen at two pixels, both taken at depth
    /// `depth_m`: the thesis's `L = D n w / f`, with distortion removed first.
    pub fn length_at_depth(&self, a_px: Vec2, b_px: Vec2, depth_m: f64) -> Option<f64> {
        let a = self.undistort(a_px)?;
        let b = self.undistort(b_px)?;
        Some((a - b).norm() * depth_m)
    }

    /// Sanity of the numbers themselves (not of the calibration): positive focal lengths,
    /// principal point inside the image, all finite.
    pub fn is_plausible(&self) -> bool {
        let d = self.distortion.to_opencv();
        self.width_px > 0
            && self.height_px > 0
            && self.fx_px.is_finite()
            && self.fy_px.is_finite()
            && self.fx_px > 0.0
            && self.fy_px > 0.0
            && self.cx_px > 0.0
            && self.cy_px > 0.0
            && self.cx_px < self.width_px as f64
            && self.cy_px < self.height_px as f64
            && d.iter().all(|c| c.is_finite())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tg6_like() -> CameraModel {
        CameraModel {
            width_px: 4000,
            height_px: 3000,
            fx_px: 2900.0,
            fy_px: 2905.0,
            cx_px: 2010.0,
            cy_px: 1490.0,
            distortion: Distortion::from_opencv([-0.12, 0.05, 0.0008, -0.0005, -0.01]),
        }
    }

    #[test]
    fn project_then_ray_round_trips_across_the_frame() {
        let cam = tg6_like();
        for &(u, v) in &[(0.0, 0.0), (3999.0, 2999.0), (2000.0, 1500.0), (123.4, 2870.9)] {
            let px = Vec2::new(u, v);
            let ray = cam.ray(px).unwrap();
            let back = cam.project(&(ray * 2.5)).unwrap();
            assert!((back - px).norm() < 1e-8, "{px:?} -> {back:?}");
        }
    }

    #[test]
    fn distortion_jacobian_matches_finite_differences() {
        let d = tg6_like().distortion;
        let x = Vec2::new(0.41, -0.33);
        let j = d.jacobian(x);
        let h = 1e-7;
        for col in 0..2 {
            let mut e = Vec2::zeros();
            e[col] = h;
            let fd = (d.apply(x + e) - d.apply(x - e)) / (2.0 * h);
            assert!((fd.x - j[0][col]).abs() < 1e-6);
            assert!((fd.y - j[1][col]).abs() < 1e-6);
        }
    }

    #[test]
    fn length_at_depth_is_the_pinhole_rule_without_distortion() {
        let mut cam = tg6_like();
        cam.distortion = Distortion::NONE;
        // 290 px apart at 2 m with f = 2900 px: 0.2 m.
        let l = cam.length_at_depth(Vec2::new(2010.0, 1490.0), Vec2::new(2300.0, 1490.0), 2.0).unwrap();
        assert!((l - 0.2).abs() < 1e-12);
    }
}
