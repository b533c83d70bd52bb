//! The laser as a line `origin + t * direction` in the camera frame, with the origin in the
//! camera's xy-plane (z = 0), as in the thesis (§3.2). Dot depth from a pixel, the laser's
//! intersection with a plane, and its image.

use crate::{CameraModel, Vec2, Vec3};
use serde::{Deserialize, Serialize};

/// A plane `normal . p = offset_m` in the camera frame (unit normal).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plane {
    pub normal: Vec3,
    pub offset_m: f64,
}

impl Plane {
    /// The plane through `point_m` with the given normal (normalised here).
    pub fn through(point_m: Vec3, normal: Vec3) -> Self {
        let n = normal.normalize();
        Plane { normal: n, offset_m: n.dot(&point_m) }
    }

    /// Where the line `origin + t * direction` meets the plane, with its `t`.
    /// `None` when the line is (nearly) parallel to the plane.
    pub fn intersect(&self, origin: &Vec3, direction: &Vec3) -> Option<(Vec3, f64)> {
        let denom = self.normal.dot(direction);
        if denom.abs() < 1e-9 {
            return None;
        }
        let t = (self.offset_m - self.normal.dot(origin)) / denom;
        Some((origin + direction * t, t))
    }
}

/// The laser beam relative to the camera.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct LaserLine {
    /// Where the beam crosses the camera's xy-plane, metres; `z` is always 0.
    pub origin_m: [f64; 3],
    /// Unit direction of the beam, pointing away from the camera (`z > 0`).
    pub direction: [f64; 3],
}

/// Where the laser dot seen at one pixel lies, by the thesis's closest-point rule.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DotFix {
    /// The point on the camera ray closest to the laser line (the thesis's `lambda_2 v`).
    pub point_m: Vec3,
    /// Its depth, `point_m.z`: the distance `D` used for lengths.
    pub depth_m: f64,
    /// Parameter along the laser from its origin (metres, since the direction is unit).
    pub along_laser_m: f64,
    /// Gap between the camera ray and the laser line at their closest approach. Zero for a
    /// dot exactly on the calibrated line; it grows when the laser has moved.
    pub miss_m: f64,
}

impl LaserLine {
    /// Builds a line from any point on it and any direction with positive z; moves the
    /// origin to the z = 0 plane and normalises the direction.
    pub fn from_point_direction(point_m: Vec3, direction: Vec3) -> Option<Self> {
        let mut d = direction.try_normalize(1e-15)?;
        if d.z < 0.0 {
            d = -d;
        }
        if d.z < 1e-6 {
            return None;
        }
        let o = point_m - d * (point_m.z / d.z);
        Some(LaserLine { origin_m: [o.x, o.y, 0.0], direction: [d.x, d.y, d.z] })
    }

    pub fn origin(&self) -> Vec3 {
        Vec3::new(self.origin_m[0], self.origin_m[1], self.origin_m[2])
    }

    pub fn dir(&self) -> Vec3 {
        Vec3::new(self.direction[0], self.direction[1], self.direction[2])
    }

    /// The point on the beam at depth `z_m`.
    pub fn point_at_depth(&self, z_m: f64) -> Vec3 {
        let d = self.dir();
        self.origin() + d * ((z_m - self.origin_m[2]) / d.z)
    }

    /// Angle between the beam and the optical axis, radians.
    pub fn angle_to_optical_axis(&self) -> f64 {
        libm::acos(self.direction[2].clamp(-1.0, 1.0))
    }

    /// Distance from the optical centre to the beam's origin, metres (the rig's baseline).
    pub fn baseline_m(&self) -> f64 {
        libm::hypot(self.origin_m[0], self.origin_m[1])
    }

    /// The thesis's closed form (§3.3, App. A.1, with `b = -l`): the camera ray `lambda_2 v`
    /// and the beam `l + lambda_1 d` brought closest in least squares. `None` when the ray is
    /// parallel to the beam, where depth is unobservable, or the fix lies behind the camera.
    pub fn fix_from_ray(&self, ray: &Vec3) -> Option<DotFix> {
        let v = ray.normalize();
        let d = self.dir();
        let l = self.origin();
        let dv = d.dot(&v);
        let denom = 1.0 - dv * dv;
        if denom < 1e-12 {
            return None;
        }
        let lambda2 = (v.dot(&l) - d.dot(&l) * dv) / denom;
        let lambda1 = (dv * v.dot(&l) - d.dot(&l)) / denom;
        if lambda2 <= 0.0 {
            return None;
        }
        let on_ray = v * lambda2;
        let on_laser = l + d * lambda1;
        Some(DotFix { point_m: on_ray, depth_m: on_ray.z, along_laser_m: lambda1, miss_m: (on_ray - on_laser).norm() })
    }

    /// [`LaserLine::fix_from_ray`] for a dot seen at a pixel.
    pub fn fix_from_pixel(&self, camera: &CameraModel, dot_px: Vec2) -> Option<DotFix> {
        self.fix_from_ray(&camera.ray(dot_px)?)
    }

    /// Where the beam hits a plane (a target), if in front of the camera.
    pub fn hit(&self, plane: &Plane) -> Option<Vec3> {
        let (p, _) = plane.intersect(&self.origin(), &self.dir())?;
        (p.z > 0.0).then_some(p)
    }

    /// Pixel where the beam would be seen at depth `z_m`.
    pub fn pixel_at_depth(&self, camera: &CameraModel, z_m: f64) -> Option<Vec2> {
        camera.project(&self.point_at_depth(z_m))
    }

    /// Shortest distance in pixels from `pixel` to the beam's image (a curve under
    /// distortion), searched over depths `[near_m, far_m]`.
    pub fn pixel_offset(&self, camera: &CameraModel, pixel: Vec2, near_m: f64, far_m: f64) -> Option<f64> {
        // The image of a line is smooth and monotone in depth; a coarse log-spaced scan then
        // golden-section refinement finds the closest point well below 0.01 px.
        let f = |z: f64| self.pixel_at_depth(camera, z).map(|p| (p - pixel).norm());
        let n = 64;
        let (ln_a, ln_b) = (libm::log(near_m), libm::log(far_m));
        let mut best: Option<(f64, f64)> = None;
        for i in 0..=n {
            let z = libm::exp(ln_a + (ln_b - ln_a) * i as f64 / n as f64);
            if let Some(e) = f(z) {
                if best.is_none_or(|(_, b)| e < b) {
                    best = Some((z, e));
                }
            }
        }
        let (z0, _) = best?;
        let step = (ln_b - ln_a) / n as f64;
        let (mut a, mut b) = (libm::log(z0) - step, libm::log(z0) + step);
        let g = |t: f64| f(libm::exp(t)).unwrap_or(f64::INFINITY);
        let phi = 0.618_033_988_749_895;
        for _ in 0..60 {
            let c = b - phi * (b - a);
            let d = a + phi * (b - a);
            if g(c) < g(d) {
                b = d;
            } else {
                a = c;
            }
        }
        let e = g(0.5 * (a + b));
        e.is_finite().then_some(e)
    }

    /// The four free parameters of a line with its origin in the z = 0 plane: origin x and y
    /// (metres) and the direction's slopes x/z and y/z. Laser fits and their covariances use
    /// this parametrisation.
    pub fn to_params(&self) -> [f64; 4] {
        let d = &self.direction;
        [self.origin_m[0], self.origin_m[1], d[0] / d[2], d[1] / d[2]]
    }

    /// Inverse of [`LaserLine::to_params`].
    pub fn from_params(p: [f64; 4]) -> Self {
        let d = Vec3::new(p[2], p[3], 1.0).normalize();
        LaserLine { origin_m: [p[0], p[1], 0.0], direction: [d.x, d.y, d.z] }
    }

    /// 1-sigma error of the depth read from a dot seen at `dot_px`, from the calibration's
    /// covariance alone (`covariance` of [`LaserLine::to_params`], row-major): the pixel is
    /// held fixed and the line's parameters vary. First-order propagation `g^T C g` with the
    /// gradient `g` of depth by central differences, which the closed form makes exact to
    /// well below the covariance's own precision. `None` for an unknown covariance (see
    /// [`covariance_known`]): no figure at all rather than a false zero.
    pub fn depth_sigma_at_pixel(&self, camera: &CameraModel, covariance: &[[f64; 4]; 4], dot_px: Vec2) -> Option<f64> {
        if !covariance_known(covariance) {
            return None;
        }
        let ray = camera.ray(dot_px)?;
        let p = self.to_params();
        let mut g = [0.0; 4];
        for (c, gc) in g.iter_mut().enumerate() {
            let h = 1e-6;
            let (mut a, mut b) = (p, p);
            a[c] += h;
            b[c] -= h;
            let za = LaserLine::from_params(a).fix_from_ray(&ray)?.depth_m;
            let zb = LaserLine::from_params(b).fix_from_ray(&ray)?.depth_m;
            *gc = (za - zb) / (2.0 * h);
        }
        let mut var = 0.0;
        for (r, row) in covariance.iter().enumerate() {
            for (c, cov) in row.iter().enumerate() {
                var += g[r] * cov * g[c];
            }
        }
        var.is_finite().then(|| libm::sqrt(var.max(0.0)))
    }

    /// [`LaserLine::depth_sigma_at_pixel`] for the dot the line itself puts at depth `z_m`.
    pub fn depth_sigma_at_depth(&self, camera: &CameraModel, covariance: &[[f64; 4]; 4], z_m: f64) -> Option<f64> {
        self.depth_sigma_at_pixel(camera, covariance, self.pixel_at_depth(camera, z_m)?)
    }
}

/// Whether a laser covariance says anything. An all-zero covariance is what a calibration
/// imported without its fit's figures carries (the lab's `.pkg` has none): *unknown*, never
/// certainty, so no sigma may be computed from it (it would read as ±0 mm).
pub fn covariance_known(covariance: &[[f64; 4]; 4]) -> bool {
    covariance.iter().flatten().any(|v| *v != 0.0)
}

/// Least 1-sigma of a found dot's centre, pixels, at any image size: JPEG's 8 px blocks,
/// blur and the round-dot model's own limits (a tilted surface makes an ellipse) keep real
/// centres from being better than this, whatever the blob's signal-to-noise. The CLI's
/// along-line search and the companion's live distance gate with it.
pub const DOT_CENTRING_FLOOR_PX: f64 = 0.5;

/// Chi-square (1 degree of freedom) beyond which a dot's offset from the calibrated line's
/// image is not explained by the calibration's covariance and the dot's centring: the 99.9%
/// point (3.29 sigma), so a calibrated laser's dots fail it once in a thousand.
pub const LINE_GATE_CHI2: f64 = 10.83;

/// What the calibrated line says about a dot seen at one pixel: how far off the line's image
/// it is, how far that is explained, and the distance it implies.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LineGate {
    /// Depth the dot implies by the thesis's closest-point rule, metres.
    pub depth_m: f64,
    /// Parameter along the beam from its origin at that point, metres.
    pub along_laser_m: f64,
    /// Offset from the line's image across it, pixels; positive toward the image of the
    /// normal `origin x direction` of the plane holding the camera centre and the beam (the
    /// only way a turned laser's dot can leave the line's image).
    pub offset_px: f64,
    /// 1-sigma of that offset from the calibration's covariance alone, pixels.
    pub line_sigma_px: f64,
    /// 1-sigma explained in all: the line's and the dot's centring, pixels.
    pub sigma_px: f64,
    /// `(offset / sigma)^2`.
    pub chi2: f64,
    /// Turn of the beam about its origin, out of the camera-beam plane, that would put the
    /// dot here, radians (signed as `offset_px`).
    pub implied_turn_rad: f64,
}

impl LineGate {
    /// The offset is explained by the calibration ([`LINE_GATE_CHI2`]).
    pub fn explained(&self) -> bool {
        self.chi2 <= LINE_GATE_CHI2
    }
}

impl LaserLine {
    /// Unit normal of the plane through the camera centre and the beam; `None` when the beam
    /// passes through the camera centre.
    fn plane_normal(&self) -> Option<Vec3> {
        self.origin().cross(&self.dir()).try_normalize(1e-12)
    }

    /// Unit normal of the line's image at depth `z_m`, oriented as the image of
    /// [`LaserLine::plane_normal`], and the image point there.
    fn image_normal(&self, camera: &CameraModel, z_m: f64) -> Option<(Vec2, Vec2)> {
        let at = self.pixel_at_depth(camera, z_m)?;
        let tangent = (self.pixel_at_depth(camera, z_m * 1.001)? - self.pixel_at_depth(camera, z_m * 0.999)?)
            .try_normalize(1e-12)?;
        let mut normal = Vec2::new(-tangent.y, tangent.x);
        let n = self.plane_normal()?;
        let pushed = camera.project(&(self.point_at_depth(z_m) + n * (1e-3 * z_m)))?;
        if (pushed - at).dot(&normal) < 0.0 {
            normal = -normal;
        }
        Some((normal, at))
    }

    /// 1-sigma of the line image's position across itself at depth `z_m`, pixels, from the
    /// covariance of [`LaserLine::to_params`] (row-major), by first-order propagation.
    pub fn image_sigma_px(&self, camera: &CameraModel, covariance: &[[f64; 4]; 4], z_m: f64) -> Option<f64> {
        let (normal, _) = self.image_normal(camera, z_m)?;
        let p = self.to_params();
        let mut g = [0.0; 4];
        for (k, gk) in g.iter_mut().enumerate() {
            let h = 1e-7;
            let (mut a, mut b) = (p, p);
            a[k] += h;
            b[k] -= h;
            let pa = LaserLine::from_params(a).pixel_at_depth(camera, z_m)?;
            let pb = LaserLine::from_params(b).pixel_at_depth(camera, z_m)?;
            *gk = normal.dot(&(pa - pb)) / (2.0 * h);
        }
        let mut var = 0.0;
        for (r, row) in covariance.iter().enumerate() {
            for (c, cov) in row.iter().enumerate() {
                var += g[r] * cov * g[c];
            }
        }
        var.is_finite().then(|| libm::sqrt(var.max(0.0)))
    }

    /// The geometric gate of a dot candidate at `dot_px` whose centre is known to
    /// `dot_sigma_px` (1 sigma per axis): its offset from the line's image against what the
    /// calibration's `covariance` and the centring explain. `None` when the pixel gives no
    /// fix (its ray runs parallel to the beam or meets it behind the camera).
    pub fn gate(
        &self,
        camera: &CameraModel,
        covariance: &[[f64; 4]; 4],
        dot_px: Vec2,
        dot_sigma_px: f64,
    ) -> Option<LineGate> {
        let fix = self.fix_from_pixel(camera, dot_px)?;
        // The fix's depth is where the ray passes the beam; the image point nearest the pixel
        // is a little along the curve from it: two secant steps along the tangent.
        let mut z = fix.depth_m;
        for _ in 0..2 {
            let (normal, at) = self.image_normal(camera, z)?;
            let tangent = Vec2::new(normal.y, -normal.x);
            let step = self.pixel_at_depth(camera, z * 1.001)? - at;
            let rate = step.dot(&tangent) / (z * 0.001);
            let along = (dot_px - at).dot(&tangent);
            if rate.abs() < 1e-9 || (along / rate).abs() > 0.5 * z {
                break;
            }
            z += along / rate;
        }
        let (normal, at) = self.image_normal(camera, z)?;
        let offset_px = (dot_px - at).dot(&normal);
        let line_sigma_px = self.image_sigma_px(camera, covariance, z)?;
        let sigma_px = libm::sqrt(line_sigma_px * line_sigma_px + dot_sigma_px * dot_sigma_px).max(1e-6);
        let on_laser = self.origin() + self.dir() * fix.along_laser_m;
        let signed_miss_m = (fix.point_m - on_laser).dot(&self.plane_normal()?);
        Some(LineGate {
            depth_m: fix.depth_m,
            along_laser_m: fix.along_laser_m,
            offset_px,
            line_sigma_px,
            sigma_px,
            chi2: (offset_px / sigma_px) * (offset_px / sigma_px),
            implied_turn_rad: libm::atan2(signed_miss_m, fix.along_laser_m.max(1e-9)),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Distortion;

    fn cam() -> CameraModel {
        CameraModel {
            width_px: 4000,
            height_px: 3000,
            fx_px: 2900.0,
            fy_px: 2900.0,
            cx_px: 2000.0,
            cy_px: 1500.0,
            distortion: Distortion::from_opencv([-0.1, 0.03, 0.0, 0.0, 0.0]),
        }
    }

    fn laser() -> LaserLine {
        LaserLine::from_point_direction(Vec3::new(-0.04, -0.11, 0.0), Vec3::new(0.012, 0.03, 1.0)).unwrap()
    }

    #[test]
    fn closed_form_recovers_depth_of_a_dot_on_the_beam() {
        let (c, l) = (cam(), laser());
        for &z in &[0.5, 1.0, 3.0, 5.0] {
            let p = l.point_at_depth(z);
            let px = c.project(&p).unwrap();
            let fix = l.fix_from_pixel(&c, px).unwrap();
            assert!((fix.depth_m - z).abs() < 1e-9 * z, "z {z} got {}", fix.depth_m);
            assert!(fix.miss_m < 1e-9);
            assert!(c.contains(px));
        }
    }

    #[test]
    fn miss_distance_grows_off_the_beam() {
        let (c, l) = (cam(), laser());
        let p = l.point_at_depth(2.0) + Vec3::new(0.01, 0.0, 0.0);
        let fix = l.fix_from_pixel(&c, c.project(&p).unwrap()).unwrap();
        assert!(fix.miss_m > 0.005 && fix.miss_m < 0.0101, "{}", fix.miss_m);
    }

    #[test]
    fn depth_sigma_matches_a_by_hand_gradient_and_grows_with_depth() {
        let (c, l) = (cam(), laser());
        let back = LaserLine::from_params(l.to_params()).to_params();
        assert!(back.iter().zip(l.to_params()).all(|(a, b)| (a - b).abs() < 1e-15));
        // Only the slope along the baseline (y here) uncertain: sigma = |dz/dslope_y| * s.
        let s = 1e-4;
        let cov = [[0.0; 4], [0.0; 4], [0.0; 4], [0.0, 0.0, 0.0, s * s]];
        let px = l.pixel_at_depth(&c, 2.0).unwrap();
        let mut p = l.to_params();
        p[3] += 1e-5;
        let dz = (LaserLine::from_params(p).fix_from_pixel(&c, px).unwrap().depth_m - 2.0) / 1e-5;
        let sigma = l.depth_sigma_at_pixel(&c, &cov, px).unwrap();
        assert!((sigma - dz.abs() * s).abs() < 1e-3 * sigma, "{sigma} vs {}", dz.abs() * s);
        // Depth error of a slope error grows about as z^2 / baseline.
        let far = l.depth_sigma_at_depth(&c, &cov, 4.0).unwrap();
        assert!(far > 3.5 * sigma && far < 4.5 * sigma, "{sigma} {far}");
    }

    #[test]
    fn an_all_zero_covariance_is_unknown_not_certainty() {
        let (c, l) = (cam(), laser());
        let unknown = [[0.0; 4]; 4];
        assert!(!covariance_known(&unknown));
        assert_eq!(l.depth_sigma_at_depth(&c, &unknown, 2.0), None, "never a sigma of 0 m");
        let mut tiny = unknown;
        tiny[3][3] = 1e-30;
        assert!(covariance_known(&tiny));
        assert!(l.depth_sigma_at_depth(&c, &tiny, 2.0).is_some_and(|s| s >= 0.0));
    }

    #[test]
    fn plane_hit_and_pixel_offset() {
        let (c, l) = (cam(), laser());
        let plane = Plane::through(Vec3::new(0.0, 0.0, 2.0), Vec3::new(0.2, -0.1, -1.0));
        let hit = l.hit(&plane).unwrap();
        assert!((plane.normal.dot(&hit) - plane.offset_m).abs() < 1e-12);
        let on = c.project(&hit).unwrap();
        assert!(l.pixel_offset(&c, on, 0.3, 10.0).unwrap() < 1e-3);
        // 5 px perpendicular-ish to a near-vertical image line.
        let off = on + Vec2::new(5.0, 0.0);
        let e = l.pixel_offset(&c, off, 0.3, 10.0).unwrap();
        assert!(e > 4.0 && e <= 5.0 + 1e-6, "{e}");
    }

    #[test]
    fn the_gate_explains_a_dot_on_the_line_and_measures_a_turned_beam() {
        let (c, l) = (cam(), laser());
        let s = 1e-4;
        let cov = [[1e-8, 0.0, 0.0, 0.0], [0.0, 1e-8, 0.0, 0.0], [0.0, 0.0, s * s, 0.0], [0.0, 0.0, 0.0, s * s]];
        for &z in &[0.6, 2.0, 5.0] {
            let px = l.pixel_at_depth(&c, z).unwrap();
            let g = l.gate(&c, &cov, px, 0.5).unwrap();
            assert!((g.depth_m - z).abs() < 1e-6 * z && g.offset_px.abs() < 1e-3, "{g:?}");
            assert!(g.explained() && g.chi2 < 1e-5);
            // Across the line: at most fx * slope sigma (0.29 px) and fx * origin sigma / z
            // (0.48 px at 0.6 m) together, at least the slope's share across a steep line.
            let most = (0.29f64.powi(2) + (0.29 / z).powi(2)).sqrt();
            assert!(g.line_sigma_px > 0.2 && g.line_sigma_px <= most + 1e-3, "{g:?} vs {most}");
        }
        // The beam turned by 0.4 deg out of the camera-beam plane about its origin: every
        // dot implies that turn and lies about fx * 0.4 deg = 20 px off the line's image,
        // on one side.
        let n = l.origin().cross(&l.dir()).normalize();
        let axis = nalgebra::Unit::new_normalize(l.dir().cross(&n));
        let turned = LaserLine::from_point_direction(
            l.origin(),
            nalgebra::Rotation3::from_axis_angle(&axis, 0.4f64.to_radians()) * l.dir(),
        )
        .unwrap();
        for &z in &[0.6, 2.0, 5.0] {
            let g = l.gate(&c, &cov, turned.pixel_at_depth(&c, z).unwrap(), 0.5).unwrap();
            assert!((g.implied_turn_rad.to_degrees().abs() - 0.4).abs() < 0.02, "{g:?}");
            assert!(g.offset_px.abs() > 17.0 && g.offset_px.abs() < 23.0 && !g.explained(), "{g:?}");
            assert_eq!(g.offset_px.signum(), g.implied_turn_rad.signum());
        }
    }
}
