//! Synthetic underwater calibration photos with their ground truth.
//!
//! A checkerboard at a known pose `T_cam_target`, seen through a distorting pinhole camera
//! (every pixel's ray is the model's own inverse, so the truth is exact), under water:
//! per-channel attenuation with path length (red goes first), a blue-green backscatter veil,
//! blur and sensor noise. Where the known laser line meets the board there is a laser dot
//! that looks like real ones: a saturated white core in a green halo up close, small and
//! faint at 4-5 m, dimmer on a black square. White specular glints, and sometimes a green
//! reflection of the laser somewhere else, are there to fool a detector that takes the
//! brightest or greenest blob.

use crate::random::SplitMix;
use crate::Checkerboard;
use fslcal_core::{CameraModel, LaserLine, Plane, Vec2, Vec3};
use image::RgbImage;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::str::FromStr;

/// Water between the camera and the target.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Water {
    Clear,
    Murky,
}

impl FromStr for Water {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "clear" => Ok(Water::Clear),
            "murky" => Ok(Water::Murky),
            _ => Err(format!("unknown water `{s}`: expected clear or murky")),
        }
    }
}

/// Optical properties of the water, per channel (R, G, B).
pub(crate) struct WaterOptics {
    /// Attenuation coefficient, 1/m.
    pub attenuation_per_m: [f64; 3],
    /// Backscatter veil at infinite range, 8-bit levels.
    pub veil: [f64; 3],
    /// Gaussian blur of the whole image, pixels.
    pub blur_sigma_px: f64,
    /// Sensor noise, 8-bit levels, 1 sigma.
    pub noise_levels: f64,
    /// Forward scatter around the laser dot: halo width factor and relative strength.
    pub halo_width: f64,
    pub halo_strength: f64,
}

impl Water {
    fn optics(self) -> WaterOptics {
        match self {
            Water::Clear => WaterOptics {
                attenuation_per_m: [0.35, 0.07, 0.11],
                veil: [8.0, 55.0, 62.0],
                blur_sigma_px: 0.7,
                noise_levels: 2.0,
                halo_width: 1.0,
                halo_strength: 0.06,
            },
            Water::Murky => WaterOptics {
                attenuation_per_m: [0.60, 0.22, 0.30],
                veil: [18.0, 88.0, 80.0],
                blur_sigma_px: 1.6,
                noise_levels: 5.0,
                halo_width: 2.0,
                halo_strength: 0.12,
            },
        }
    }
}

/// `T_cam_target`: a target point `p` is at `rotation * p + translation_m` in the camera
/// frame. `rotation` is row-major.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Pose {
    pub rotation: [[f64; 3]; 3],
    pub translation_m: [f64; 3],
}

impl Pose {
    pub fn apply(&self, p: &Vec3) -> Vec3 {
        let r = &self.rotation;
        Vec3::new(
            r[0][0] * p.x + r[0][1] * p.y + r[0][2] * p.z + self.translation_m[0],
            r[1][0] * p.x + r[1][1] * p.y + r[1][2] * p.z + self.translation_m[1],
            r[2][0] * p.x + r[2][1] * p.y + r[2][2] * p.z + self.translation_m[2],
        )
    }

    /// The target's z axis (its normal) in the camera frame.
    pub fn normal(&self) -> Vec3 {
        Vec3::new(self.rotation[0][2], self.rotation[1][2], self.rotation[2][2])
    }

    pub fn plane(&self) -> Plane {
        Plane::through(Vec3::from(self.translation_m), self.normal())
    }

    /// Target-frame coordinates of a camera-frame point.
    pub fn to_target(&self, p: &Vec3) -> Vec3 {
        let d = p - Vec3::from(self.translation_m);
        let r = &self.rotation;
        Vec3::new(
            r[0][0] * d.x + r[1][0] * d.y + r[2][0] * d.z,
            r[0][1] * d.x + r[1][1] * d.y + r[2][1] * d.z,
            r[0][2] * d.x + r[1][2] * d.y + r[2][2] * d.z,
        )
    }
}

/// Everything that decides one rendered photo.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SceneSpec {
    pub camera: CameraModel,
    /// `None`: laser off.
    pub laser: Option<LaserLine>,
    /// `None`: a photo with no board in it, only the background.
    pub board: Option<(Checkerboard, Pose)>,
    pub water: Water,
    /// Number of white specular glints.
    pub glints: u32,
    /// Whether a green reflection of the laser appears somewhere other than the dot.
    pub impostor: bool,
    pub seed: u64,
}

/// The laser dot's ground truth.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DotTruth {
    /// Centre of the dot, pixels (OpenCV pixel-centre convention).
    pub pixel: [f64; 2],
    /// Where the laser meets the board, camera frame, metres.
    pub point_m: [f64; 3],
    pub depth_m: f64,
    pub on_black_square: bool,
    /// Whether the core is clipped to white in all three channels.
    pub saturated: bool,
}

/// What a rendered photo shows, exactly.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SceneTruth {
    pub camera: CameraModel,
    pub laser: Option<LaserLine>,
    pub board: Option<Checkerboard>,
    #[serde(rename = "T_cam_target")]
    pub t_cam_target: Option<Pose>,
    pub water: Water,
    pub seed: u64,
    pub dot: Option<DotTruth>,
    /// Centres of the white glints, pixels.
    pub glints: Vec<[f64; 2]>,
    /// Centre of the green reflection that is not the dot, pixels.
    pub impostor: Option<[f64; 2]>,
    /// Projected inner corners in `object_points` order, pixels.
    pub corners_px: Vec<[f64; 2]>,
}

pub struct RenderedScene {
    pub image: RgbImage,
    pub truth: SceneTruth,
}

/// Normalised (undistorted) coordinates of every pixel, from a coarse grid of exact
/// inverses, bilinearly interpolated: a Newton solve per sub-pixel sample would be slow, and
/// the distortion field is smooth enough that the interpolation error stays far below
/// anything a detector resolves (measured in a test).
pub struct RayGrid {
    step_px: f64,
    origin_px: f64,
    cols: usize,
    rows: usize,
    xy: Vec<[f64; 2]>,
}

impl RayGrid {
    pub fn new(camera: &CameraModel, step_px: usize) -> RayGrid {
        let step = step_px as f64;
        let origin = -2.0 * step;
        let cols = (camera.width_px as f64 / step).ceil() as usize + 5;
        let rows = (camera.height_px as f64 / step).ceil() as usize + 5;
        let xy: Vec<[f64; 2]> = (0..rows * cols)
            .into_par_iter()
            .map(|i| {
                let p = Vec2::new(origin + (i % cols) as f64 * step, origin + (i / cols) as f64 * step);
                camera.undistort(p).map_or([f64::NAN, f64::NAN], |n| [n.x, n.y])
            })
            .collect();
        RayGrid { step_px: step, origin_px: origin, cols, rows, xy }
    }

    /// Normalised coordinates of a (sub-)pixel position.
    #[inline]
    pub fn normalised(&self, u: f64, v: f64) -> [f64; 2] {
        let gx = ((u - self.origin_px) / self.step_px).clamp(0.0, (self.cols - 2) as f64);
        let gy = ((v - self.origin_px) / self.step_px).clamp(0.0, (self.rows - 2) as f64);
        let (ix, iy) =
            (gx.floor().min((self.cols - 2) as f64) as usize, gy.floor().min((self.rows - 2) as f64) as usize);
        let (fx, fy) = (gx - ix as f64, gy - iy as f64);
        let i = iy * self.cols + ix;
        let (a, b, c, d) = (self.xy[i], self.xy[i + 1], self.xy[i + self.cols], self.xy[i + self.cols + 1]);
        let lerp = |k: usize| {
            let top = a[k] + (b[k] - a[k]) * fx;
            let bottom = c[k] + (d[k] - c[k]) * fx;
            top + (bottom - top) * fy
        };
        [lerp(0), lerp(1)]
    }
}

/// Reflectances of the printed board.
const WHITE: f64 = 0.85;
const BLACK: f64 = 0.06;
/// Light falling on the scene, 8-bit levels for a perfect white at zero range.
pub(crate) const ILLUMINATION: f64 = 265.0;
/// The background (sand and reef) sits this far behind everything.
const BACKGROUND_RANGE_M: f64 = 7.0;
/// Laser: radiance of the dot on white at zero range before divergence, 8-bit levels; the
/// beam's diameter at the exit and its full divergence.
pub(crate) const LASER_RADIANCE: f64 = 1200.0;
pub(crate) const BEAM_DIAMETER_M: f64 = 0.003;
pub(crate) const BEAM_DIVERGENCE_RAD: f64 = 0.0008;
/// How a 532 nm dot lands in the camera's channels (colour filter cross-talk).
const LASER_COLOUR: [f64; 3] = [0.30, 1.0, 0.40];
/// A black square returns this share of what a white one returns of the laser.
const LASER_ON_BLACK: f64 = 0.3;

/// A slate's scan as the renderer samples it: linear albedo per scan pixel, and the physical
/// size the scan covers.
#[derive(Clone, Debug, PartialEq)]
pub struct SlateTexture {
    pub width_m: f64,
    pub height_m: f64,
    cols: usize,
    rows: usize,
    albedo: Vec<[f32; 3]>,
}

impl SlateTexture {
    /// The scan taken as albedo (8-bit level / 255) over `width_m x height_m`.
    pub fn new(scan: &RgbImage, width_m: f64, height_m: f64) -> SlateTexture {
        let albedo = scan.pixels().map(|p| p.0.map(|c| c as f32 / 255.0)).collect();
        SlateTexture { width_m, height_m, cols: scan.width() as usize, rows: scan.height() as usize, albedo }
    }

    pub fn from_slate(slate: &crate::Slate) -> Result<SlateTexture, crate::SlateError> {
        Ok(SlateTexture::new(&slate.read_scan()?, slate.width_m, slate.height_m))
    }

    pub fn outline_m(&self) -> [[f64; 3]; 4] {
        let (w, h) = (self.width_m, self.height_m);
        [[0.0, 0.0, 0.0], [w, 0.0, 0.0], [w, h, 0.0], [0.0, h, 0.0]]
    }

    /// Bilinear albedo at a target-frame point, `None` off the slate.
    pub(crate) fn albedo_at(&self, q: &Vec3) -> Option<[f64; 3]> {
        if q.x < 0.0 || q.y < 0.0 || q.x > self.width_m || q.y > self.height_m {
            return None;
        }
        // Scan pixel centres sit at (i + 0.5) * size / count.
        let gx = (q.x / self.width_m * self.cols as f64 - 0.5).clamp(0.0, (self.cols - 1) as f64);
        let gy = (q.y / self.height_m * self.rows as f64 - 0.5).clamp(0.0, (self.rows - 1) as f64);
        let (ix, iy) = ((gx as usize).min(self.cols - 2), (gy as usize).min(self.rows - 2));
        let (fx, fy) = ((gx - ix as f64) as f32, (gy - iy as f64) as f32);
        let i = iy * self.cols + ix;
        let (a, b, c, d) =
            (self.albedo[i], self.albedo[i + 1], self.albedo[i + self.cols], self.albedo[i + self.cols + 1]);
        Some([0, 1, 2].map(|k| {
            let top = a[k] + (b[k] - a[k]) * fx;
            let bottom = c[k] + (d[k] - c[k]) * fx;
            (top + (bottom - top) * fy) as f64
        }))
    }
}

/// What is printed or stuck on the target, or the target itself: a fish's flank in its
/// plane (`crate::fish`).
#[derive(Clone, Copy)]
pub(crate) enum Surface<'a> {
    Board(Checkerboard),
    Slate(&'a SlateTexture),
    Fish(&'a crate::fish::FishShape),
}

impl Surface<'_> {
    /// Albedo at a target-frame point, `None` off the target.
    fn albedo_at(&self, q: &Vec3) -> Option<[f64; 3]> {
        match self {
            Surface::Board(board) => {
                let o = board.outline_m();
                if q.x < o[0][0] || q.x > o[2][0] || q.y < o[0][1] || q.y > o[2][1] {
                    return None;
                }
                let s = board.square_m;
                let i = (q.x / s).floor() as i64 + 1;
                let j = (q.y / s).floor() as i64 + 1;
                let on_squares =
                    (0..=board.inner_cols as i64).contains(&i) && (0..=board.inner_rows as i64).contains(&j);
                Some([if on_squares && Checkerboard::square_colour_is_black(i, j) { BLACK } else { WHITE }; 3])
            }
            Surface::Slate(t) => t.albedo_at(q),
            Surface::Fish(f) => f.albedo_at(q),
        }
    }

    /// Share of the laser a white square would return that this albedo returns.
    fn laser_return(&self, albedo: [f64; 3]) -> f64 {
        match self {
            Surface::Board(_) => {
                if albedo[1] == BLACK {
                    LASER_ON_BLACK
                } else {
                    1.0
                }
            }
            Surface::Slate(_) | Surface::Fish(_) => (albedo[1] / WHITE).clamp(LASER_ON_BLACK, 1.0),
        }
    }
}

/// The target's surface under a camera-frame ray: `Some(albedo)` on the target, `None` off it.
struct TargetShader<'a> {
    surface: Surface<'a>,
    pose: Pose,
    normal: Vec3,
    normal_dot_t: f64,
}

impl<'a> TargetShader<'a> {
    fn new(surface: Surface<'a>, pose: Pose) -> TargetShader<'a> {
        let normal = pose.normal();
        TargetShader { surface, pose, normal, normal_dot_t: normal.dot(&Vec3::from(pose.translation_m)) }
    }

    /// Albedo at a target-frame point, `None` outside the target.
    fn albedo_at(&self, q: &Vec3) -> Option<[f64; 3]> {
        self.surface.albedo_at(q)
    }

    /// Albedo and range along the ray through normalised coordinates `n`.
    #[inline]
    fn shade(&self, n: [f64; 2]) -> Option<([f64; 3], f64)> {
        let ray = Vec3::new(n[0], n[1], 1.0);
        let denom = self.normal.dot(&ray);
        if denom.abs() < 1e-12 {
            return None;
        }
        let t = self.normal_dot_t / denom;
        if t <= 0.0 {
            return None;
        }
        let p = ray * t;
        let albedo = self.albedo_at(&self.pose.to_target(&p))?;
        Some((albedo, p.norm()))
    }
}

/// Smooth value noise in [0, 1] on a grid of `cell` units (the background, the slate's scan).
pub(crate) fn value_noise(seed: u64, u: f64, v: f64, cell: f64) -> f64 {
    let (gx, gy) = (u / cell, v / cell);
    let (ix, iy) = (gx.floor() as i64, gy.floor() as i64);
    let (fx, fy) = (gx - ix as f64, gy - iy as f64);
    let h = |x: i64, y: i64| SplitMix::derive(seed, (x as u64).wrapping_mul(0x1_0000_0001) ^ (y as u64)).unit();
    let s = |t: f64| t * t * (3.0 - 2.0 * t);
    let (a, b, c, d) = (h(ix, iy), h(ix + 1, iy), h(ix, iy + 1), h(ix + 1, iy + 1));
    let top = a + (b - a) * s(fx);
    let bottom = c + (d - c) * s(fx);
    top + (bottom - top) * s(fy)
}

pub(crate) fn through_water(optics: &WaterOptics, albedo: [f64; 3], range_m: f64) -> [f64; 3] {
    let mut out = [0.0; 3];
    for k in 0..3 {
        let t = (-optics.attenuation_per_m[k] * range_m).exp();
        out[k] = albedo[k] * ILLUMINATION * t + optics.veil[k] * (1.0 - t);
    }
    out
}

/// A soft-edged disc plus a Gaussian halo, added to a float RGB image. The profile is
/// radially symmetric about `centre`, so its intensity-weighted centre is `centre`.
pub(crate) fn add_spot(
    img: &mut [[f32; 3]],
    width: usize,
    height: usize,
    centre: Vec2,
    radius_px: f64,
    radiance: [f64; 3],
    halo: (f64, f64),
) {
    let (halo_sigma, halo_strength) = halo;
    let edge = 0.45;
    let reach = (radius_px + 6.0 * edge).max(3.5 * halo_sigma).ceil() + 1.0;
    let x0 = (centre.x - reach).floor().max(0.0) as usize;
    let x1 = ((centre.x + reach).ceil() as usize).min(width.saturating_sub(1));
    let y0 = (centre.y - reach).floor().max(0.0) as usize;
    let y1 = ((centre.y + reach).ceil() as usize).min(height.saturating_sub(1));
    for y in y0..=y1 {
        for x in x0..=x1 {
            let d = ((x as f64 - centre.x).powi(2) + (y as f64 - centre.y).powi(2)).sqrt();
            let core = 1.0 / (1.0 + ((d - radius_px) / edge).exp());
            let glow = halo_strength * (-0.5 * (d / halo_sigma).powi(2)).exp();
            let w = core + glow;
            let px = &mut img[y * width + x];
            for k in 0..3 {
                px[k] += (radiance[k] * w) as f32;
            }
        }
    }
}

/// Separable Gaussian blur in place.
pub(crate) fn blur(img: &mut Vec<[f32; 3]>, width: usize, height: usize, sigma: f64) {
    if sigma <= 0.0 {
        return;
    }
    let r = (3.0 * sigma).ceil() as i64;
    let kernel: Vec<f32> = (-r..=r).map(|i| (-0.5 * (i as f64 / sigma).powi(2)).exp() as f32).collect();
    let sum: f32 = kernel.iter().sum();
    let kernel: Vec<f32> = kernel.iter().map(|k| k / sum).collect();
    let horizontal: Vec<[f32; 3]> = (0..height)
        .into_par_iter()
        .flat_map_iter(|y| {
            let row = &img[y * width..(y + 1) * width];
            let kernel = &kernel;
            (0..width).map(move |x| {
                let mut acc = [0f32; 3];
                for (k, w) in kernel.iter().enumerate() {
                    let xi = (x as i64 + k as i64 - r).clamp(0, width as i64 - 1) as usize;
                    for c in 0..3 {
                        acc[c] += row[xi][c] * w;
                    }
                }
                acc
            })
        })
        .collect();
    let src = &horizontal;
    *img = (0..height)
        .into_par_iter()
        .flat_map_iter(|y| {
            let kernel = &kernel;
            (0..width).map(move |x| {
                let mut acc = [0f32; 3];
                for (k, w) in kernel.iter().enumerate() {
                    let yi = (y as i64 + k as i64 - r).clamp(0, height as i64 - 1) as usize;
                    for c in 0..3 {
                        acc[c] += src[yi * width + x][c] * w;
                    }
                }
                acc
            })
        })
        .collect();
}

/// Renders one photo and its truth.
pub fn render(spec: &SceneSpec) -> RenderedScene {
    let setup = Setup {
        camera: spec.camera,
        laser: spec.laser,
        target: spec.board.map(|(b, p)| (Surface::Board(b), p)),
        water: spec.water,
        glints: spec.glints,
        impostor: spec.impostor,
        seed: spec.seed,
    };
    let mut scene = render_setup(&setup);
    scene.truth.board = spec.board.map(|(b, _)| b);
    scene.truth.corners_px = spec
        .board
        .map(|(b, pose)| {
            b.object_points()
                .iter()
                .filter_map(|p| spec.camera.project(&pose.apply(&Vec3::from(*p))))
                .map(|p| [p.x, p.y])
                .collect()
        })
        .unwrap_or_default();
    scene
}

/// One photo of a taped dive slate.
#[derive(Clone, Debug)]
pub struct SlateSpec {
    pub camera: CameraModel,
    pub laser: Option<LaserLine>,
    /// `T_cam_target` of the slate (target frame: docs/slate.md).
    pub pose: Pose,
    pub water: Water,
    pub glints: u32,
    pub impostor: bool,
    pub seed: u64,
}

/// Renders a photo of `slate` and its truth (`board` and `corners_px` empty).
pub fn render_slate(slate: &SlateTexture, spec: &SlateSpec) -> RenderedScene {
    render_setup(&Setup {
        camera: spec.camera,
        laser: spec.laser,
        target: Some((Surface::Slate(slate), spec.pose)),
        water: spec.water,
        glints: spec.glints,
        impostor: spec.impostor,
        seed: spec.seed,
    })
}

/// What decides a photo, whatever the target.
pub(crate) struct Setup<'a> {
    pub camera: CameraModel,
    pub laser: Option<LaserLine>,
    pub target: Option<(Surface<'a>, Pose)>,
    pub water: Water,
    pub glints: u32,
    pub impostor: bool,
    pub seed: u64,
}

/// Renders a photo of `spec`: the scene through the water, the laser dot, glints and the
/// laser's reflection, blur, then sensor noise.
pub(crate) fn render_setup(spec: &Setup) -> RenderedScene {
    let cam = &spec.camera;
    let (w, h) = (cam.width_px as usize, cam.height_px as usize);
    let optics = spec.water.optics();
    let shader = spec.target.map(|(s, p)| TargetShader::new(s, p));
    let mut img = shade_scene(cam, &optics, shader.as_ref(), spec.seed ^ 0xB6);
    let dot = match (&spec.laser, &shader) {
        (Some(laser), Some(shader)) => add_laser_dot(&mut img, cam, &optics, laser, shader),
        _ => None,
    };
    // Glints first, then the reflection: they share one stream, in this order.
    let mut rng = SplitMix::derive(spec.seed, 1);
    let glints = add_glints(&mut img, w, h, spec.glints, &mut rng);
    let impostor = if spec.impostor { add_laser_reflection(&mut img, w, h, dot.as_ref(), &mut rng) } else { None };
    blur(&mut img, w, h, optics.blur_sigma_px);
    let image = quantise_with_noise(&img, w, h, optics.noise_levels, spec.seed);
    RenderedScene {
        image,
        truth: SceneTruth {
            camera: *cam,
            laser: spec.laser,
            board: None,
            t_cam_target: spec.target.map(|(_, p)| p),
            water: spec.water,
            seed: spec.seed,
            dot,
            glints,
            impostor,
            corners_px: Vec::new(),
        },
    }
}

/// The target (if any) and the background behind it, through the water, each pixel
/// supersampled 3x3 where the target is.
fn shade_scene(cam: &CameraModel, optics: &WaterOptics, shader: Option<&TargetShader>, bg_seed: u64) -> Vec<[f32; 3]> {
    let (w, h) = (cam.width_px as usize, cam.height_px as usize);
    let grid = RayGrid::new(cam, 8);
    const SUB: [f64; 3] = [-1.0 / 3.0, 0.0, 1.0 / 3.0];
    (0..h)
        .into_par_iter()
        .flat_map_iter(|y| {
            let grid = &grid;
            (0..w).map(move |x| {
                let (u, v) = (x as f64, y as f64);
                let background = || {
                    let n = 0.6 * value_noise(bg_seed, u, v, 180.0) + 0.4 * value_noise(bg_seed + 1, u, v, 37.0);
                    let albedo = [0.30 + 0.25 * n, 0.28 + 0.22 * n, 0.20 + 0.15 * n];
                    through_water(optics, albedo, BACKGROUND_RANGE_M)
                };
                let Some(shader) = shader else {
                    let c = background();
                    return [c[0] as f32, c[1] as f32, c[2] as f32];
                };
                let mut acc = [0.0f64; 3];
                let mut bg: Option<[f64; 3]> = None;
                for dy in SUB {
                    for dx in SUB {
                        let c = match shader.shade(grid.normalised(u + dx, v + dy)) {
                            Some((albedo, range)) => through_water(optics, albedo, range),
                            None => *bg.get_or_insert_with(background),
                        };
                        for k in 0..3 {
                            acc[k] += c[k];
                        }
                    }
                }
                [(acc[0] / 9.0) as f32, (acc[1] / 9.0) as f32, (acc[2] / 9.0) as f32]
            })
        })
        .collect()
}

/// The laser dot where the line meets the physical target, if it does so inside the frame.
fn add_laser_dot(
    img: &mut [[f32; 3]],
    cam: &CameraModel,
    optics: &WaterOptics,
    laser: &LaserLine,
    shader: &TargetShader,
) -> Option<DotTruth> {
    let (w, h) = (cam.width_px as usize, cam.height_px as usize);
    let hit = laser.hit(&shader.pose.plane())?;
    let albedo = shader.albedo_at(&shader.pose.to_target(&hit))?;
    let px = cam.project(&hit)?;
    if !(hit.z > 0.0 && cam.contains(px)) {
        return None;
    }
    let range = (hit - laser.origin()).norm();
    let back = hit.norm();
    let diameter = BEAM_DIAMETER_M + BEAM_DIVERGENCE_RAD * range;
    let laser_return = shader.surface.laser_return(albedo);
    let spread = (BEAM_DIAMETER_M / diameter).powi(2);
    let g = optics.attenuation_per_m[1];
    let radiance = LASER_RADIANCE * laser_return * spread * (-g * (range + back)).exp();
    let radius_px = 0.5 * diameter * cam.fx_px / hit.z;
    let colour = LASER_COLOUR.map(|c| c * radiance);
    let halo_sigma = optics.halo_width * (1.5 * radius_px + 2.0);
    add_spot(img, w, h, px, radius_px, colour, (halo_sigma, optics.halo_strength));
    let centre = img[(px.y.round() as usize).min(h - 1) * w + (px.x.round() as usize).min(w - 1)];
    Some(DotTruth {
        pixel: [px.x, px.y],
        point_m: [hit.x, hit.y, hit.z],
        depth_m: hit.z,
        on_black_square: laser_return < 0.5,
        saturated: centre.iter().all(|&v| v >= 255.0),
    })
}

/// Specular glints: bright, small, colourless. Returns their centres.
fn add_glints(img: &mut [[f32; 3]], w: usize, h: usize, count: u32, rng: &mut SplitMix) -> Vec<[f64; 2]> {
    (0..count)
        .map(|_| {
            let c = Vec2::new(rng.range(40.0, w as f64 - 40.0), rng.range(40.0, h as f64 - 40.0));
            let r = rng.range(1.0, 6.0);
            add_spot(img, w, h, c, r, [900.0, 900.0, 900.0], (r + 1.0, 0.08));
            [c.x, c.y]
        })
        .collect()
}

/// A green reflection of the laser somewhere at least 60 px from the dot. Returns its centre.
fn add_laser_reflection(
    img: &mut [[f32; 3]],
    w: usize,
    h: usize,
    dot: Option<&DotTruth>,
    rng: &mut SplitMix,
) -> Option<[f64; 2]> {
    for _ in 0..100 {
        let c = Vec2::new(rng.range(60.0, w as f64 - 60.0), rng.range(60.0, h as f64 - 60.0));
        if dot.is_none_or(|d| (Vec2::new(d.pixel[0], d.pixel[1]) - c).norm() >= 60.0) {
            let r = rng.range(2.0, 6.0);
            let level = rng.range(120.0, 400.0);
            add_spot(img, w, h, c, r, LASER_COLOUR.map(|k| k * level), (1.5 * r + 2.0, 0.06));
            return Some([c.x, c.y]);
        }
    }
    None
}

/// Sensor noise and 8-bit quantisation; one generator per row keeps it independent of the
/// thread count.
pub(crate) fn quantise_with_noise(img: &[[f32; 3]], w: usize, h: usize, noise: f64, seed: u64) -> RgbImage {
    let bytes: Vec<u8> = img
        .par_chunks(w)
        .enumerate()
        .flat_map_iter(|(y, row)| {
            let mut g = SplitMix::derive(seed ^ 0x004E_015E, y as u64);
            row.iter()
                .flat_map(|p| *p)
                .map(move |c| (c as f64 + noise * g.gaussian()).round().clamp(0.0, 255.0) as u8)
                .collect::<Vec<_>>()
        })
        .collect();
    RgbImage::from_raw(w as u32, h as u32, bytes).expect("buffer matches the image size")
}

/// Rotation by `angle` about the unit `axis` (Rodrigues), row-major.
pub(crate) fn axis_angle(axis: Vec3, angle: f64) -> nalgebra::Matrix3<f64> {
    nalgebra::Rotation3::from_axis_angle(&nalgebra::Unit::new_normalize(axis), angle).into_inner()
}

pub(crate) fn to_rows(m: &nalgebra::Matrix3<f64>) -> [[f64; 3]; 3] {
    [0, 1, 2].map(|i| [0, 1, 2].map(|j| m[(i, j)]))
}

/// A random board orientation: turned in its plane by up to `inplane_deg`, tilted about a
/// random axis in the image plane by up to `tilt_deg`.
pub(crate) fn random_rotation(rng: &mut SplitMix, tilt_deg: f64, inplane_deg: f64) -> nalgebra::Matrix3<f64> {
    let phi = rng.range(0.0, std::f64::consts::TAU);
    let tilt = rng.range(0.0, tilt_deg).to_radians();
    let spin = rng.range(-inplane_deg, inplane_deg).to_radians();
    axis_angle(Vec3::new(phi.cos(), phi.sin(), 0.0), tilt) * axis_angle(Vec3::z(), spin)
}

/// Whether the whole physical board (sampled along its edges) is in the image, at least
/// `margin_px` from the border.
pub(crate) fn target_in_frame(camera: &CameraModel, o: &[[f64; 3]; 4], pose: &Pose, margin_px: f64) -> bool {
    (0..4).all(|k| {
        let (a, b) = (Vec3::from(o[k]), Vec3::from(o[(k + 1) % 4]));
        (0..=8).all(|i| {
            let p = pose.apply(&(a + (b - a) * (i as f64 / 8.0)));
            p.z > 0.1
                && camera.project(&p).is_some_and(|q| {
                    q.x >= margin_px
                        && q.y >= margin_px
                        && q.x <= camera.width_px as f64 - 1.0 - margin_px
                        && q.y <= camera.height_px as f64 - 1.0 - margin_px
                })
        })
    })
}

/// Tries up to 600 random board orientations, each placed by `place` (which returns the
/// translation for a rotation and an "ease" running from 1 down to 0 as attempts fail, so
/// placements can get tamer), until the whole board is in the frame; falls back to a
/// face-on board at `fallback_m`.
pub(crate) fn search_pose(
    rng: &mut SplitMix,
    camera: &CameraModel,
    outline_m: &[[f64; 3]; 4],
    margin_px: f64,
    mut place: impl FnMut(&mut SplitMix, f64, &nalgebra::Matrix3<f64>) -> Option<Vec3>,
    fallback_m: Vec3,
) -> Pose {
    for attempt in 0..600 {
        // Shrink the tilt as attempts fail: up close the board only just fits.
        let ease = 1.0 - attempt as f64 / 600.0;
        let r = random_rotation(rng, 35.0 * ease, 15.0 * ease);
        let Some(t) = place(rng, ease, &r) else { continue };
        let pose = Pose { rotation: to_rows(&r), translation_m: [t.x, t.y, t.z] };
        if target_in_frame(camera, outline_m, &pose, margin_px) {
            return pose;
        }
    }
    Pose {
        rotation: to_rows(&nalgebra::Matrix3::identity()),
        translation_m: [fallback_m.x, fallback_m.y, fallback_m.z],
    }
}

/// A board pose with the laser's dot on it at `depth_m` on a random square (about a third
/// black), the whole board in the frame with a 30 px margin at 4000 px wide; face-on with
/// the dot wherever the board's centre puts it as a last resort.
pub(crate) fn board_pose(
    rng: &mut SplitMix,
    camera: &CameraModel,
    laser: &LaserLine,
    board: &Checkerboard,
    depth_m: f64,
) -> Pose {
    let s = board.square_m;
    let hit = laser.point_at_depth(depth_m);
    let want_black = rng.unit() < 1.0 / 3.0;
    let centre = Vec3::new(0.5 * (board.inner_cols - 1) as f64 * s, 0.5 * (board.inner_rows - 1) as f64 * s, 0.0);
    let place = |rng: &mut SplitMix, _ease: f64, r: &nalgebra::Matrix3<f64>| {
        let (i_sq, j_sq) = loop {
            let i_sq = rng.below(board.inner_cols as u64 + 1) as i64;
            let j_sq = rng.below(board.inner_rows as u64 + 1) as i64;
            if Checkerboard::square_colour_is_black(i_sq, j_sq) == want_black {
                break (i_sq, j_sq);
            }
        };
        let on_board = Vec3::new(
            (i_sq - 1) as f64 * s + rng.range(0.2, 0.8) * s,
            (j_sq - 1) as f64 * s + rng.range(0.2, 0.8) * s,
            0.0,
        );
        Some(hit - r * on_board)
    };
    let margin = 30.0 * camera.width_px as f64 / 4000.0;
    search_pose(rng, camera, &board.outline_m(), margin, place, hit - centre)
}

/// A dive's laser calibration photos: the FishSense board from 0.6 to 4.5 m (evenly spread,
/// jittered), tilted up to 35 degrees, turned up to 15 degrees in its plane, placed so that
/// the TG-6 rig's laser dot lands on it at a random spot (about a third on black squares),
/// the whole board in the frame. With glints, about one photo in four also has a green
/// reflection of the laser elsewhere.
pub fn laser_scene_set(count: usize, seed: u64, water: Water, glints: u32) -> Vec<SceneSpec> {
    let camera = crate::rig::tg6_camera();
    let laser = crate::rig::fsl_laser();
    let board = Checkerboard::fishsense();
    (0..count)
        .map(|i| {
            let mut rng = SplitMix::derive(seed, i as u64);
            let t = if count > 1 { i as f64 / (count - 1) as f64 } else { 0.25 };
            let depth = (0.6 + 3.9 * t + rng.range(-0.05, 0.05)).clamp(0.6, 4.5);
            let pose = board_pose(&mut rng, &camera, &laser, &board, depth);
            SceneSpec {
                camera,
                laser: Some(laser),
                board: Some((board, pose)),
                water,
                glints,
                impostor: glints > 0 && i % 4 == 1,
                seed: seed.wrapping_mul(1000).wrapping_add(i as u64),
            }
        })
        .collect()
}

/// Photos of a taped slate with the laser dot on it, as a diver takes them for the laser or
/// to validate: from `depths_m.0` to `depths_m.1` (evenly spread, jittered), tilted up to
/// 35 degrees, turned up to 15 degrees in its plane, the dot at a random spot on the slate
/// away from its edges, the whole slate in the frame. With glints, about one photo in four
/// also has a green reflection of the laser elsewhere.
pub fn slate_scene_set(
    slate: &SlateTexture,
    laser: LaserLine,
    depths_m: (f64, f64),
    count: usize,
    seed: u64,
    water: Water,
    glints: u32,
) -> Vec<SlateSpec> {
    let camera = crate::rig::tg6_camera();
    let outline = slate.outline_m();
    let centre = Vec3::new(0.5 * slate.width_m, 0.5 * slate.height_m, 0.0);
    (0..count)
        .map(|i| {
            let mut rng = SplitMix::derive(seed ^ 0x51A7E, i as u64);
            let t = if count > 1 { i as f64 / (count - 1) as f64 } else { 0.5 };
            let span = depths_m.1 - depths_m.0;
            let depth = (depths_m.0 + span * t + rng.range(-0.02, 0.02) * span).clamp(depths_m.0, depths_m.1);
            let hit = laser.point_at_depth(depth);
            let place = |rng: &mut SplitMix, ease: f64, r: &nalgebra::Matrix3<f64>| {
                // Up close the slate only just fits: aim the dot nearer its middle as tries fail.
                let k = 0.15 + 0.35 * (1.0 - ease);
                let on_slate =
                    Vec3::new(rng.range(k, 1.0 - k) * slate.width_m, rng.range(k, 1.0 - k) * slate.height_m, 0.0);
                Some(hit - r * on_slate)
            };
            let pose = search_pose(&mut rng, &camera, &outline, 30.0, place, hit - centre);
            SlateSpec {
                camera,
                laser: Some(laser),
                pose,
                water,
                glints,
                impostor: glints > 0 && i % 4 == 1,
                seed: seed.wrapping_mul(1000).wrapping_add(700 + i as u64),
            }
        })
        .collect()
}

/// Photos for calibrating the intrinsics: the FishSense board from 0.5 to 1.6 m, tilted up
/// to 35 degrees, placed in turn over a 3x3 grid of the frame so the corners cover the
/// whole image including its corners. Laser off.
pub fn camera_scene_set(count: usize, seed: u64, water: Water) -> Vec<SceneSpec> {
    let camera = crate::rig::tg6_camera();
    let board = Checkerboard::fishsense();
    let s = board.square_m;
    let centre = Vec3::new(0.5 * (board.inner_cols - 1) as f64 * s, 0.5 * (board.inner_rows - 1) as f64 * s, 0.0);
    (0..count)
        .map(|i| {
            let mut rng = SplitMix::derive(seed ^ 0xCA11, i as u64);
            let depth = 0.5 + 1.1 * ((i as f64 + rng.unit()) / count as f64);
            let cell = i % 9;
            let (cu, cv) = ((cell % 3) as f64, (cell / 3) as f64);
            let place = |rng: &mut SplitMix, ease: f64, r: &nalgebra::Matrix3<f64>| {
                // Aim the board's centre at its cell, drifting to the middle as attempts fail.
                let u = camera.width_px as f64 * (0.5 + ease * ((cu + 0.5) / 3.0 - 0.5) * 1.3 + rng.range(-0.03, 0.03));
                let v =
                    camera.height_px as f64 * (0.5 + ease * ((cv + 0.5) / 3.0 - 0.5) * 1.3 + rng.range(-0.03, 0.03));
                let n = camera.undistort(Vec2::new(u, v))?;
                let depth = depth.max(0.5 + 0.6 * (1.0 - ease));
                Some(Vec3::new(n.x, n.y, 1.0) * depth - r * centre)
            };
            let pose =
                search_pose(&mut rng, &camera, &board.outline_m(), 10.0, place, Vec3::new(0.0, 0.0, 1.2) - centre);
            SceneSpec {
                camera,
                laser: None,
                board: Some((board, pose)),
                water,
                glints: 0,
                impostor: false,
                seed: seed.wrapping_mul(1000).wrapping_add(500 + i as u64),
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rig::{fsl_laser, tg6_camera};

    #[test]
    fn ray_grid_interpolation_is_far_below_a_hundredth_of_a_pixel() {
        let cam = tg6_camera();
        let grid = RayGrid::new(&cam, 8);
        let mut rng = SplitMix::new(3);
        let mut worst: f64 = 0.0;
        for _ in 0..20_000 {
            let p = Vec2::new(rng.range(-0.5, 3999.5), rng.range(-0.5, 2999.5));
            let n = grid.normalised(p.x, p.y);
            let back = cam.pixel_of_normalised(Vec2::new(n[0], n[1]));
            worst = worst.max((back - p).norm());
        }
        eprintln!("ray grid: worst reprojection error {worst:.5} px over 20000 random pixels");
        assert!(worst < 0.01, "{worst}");
    }

    fn face_on_spec(depth: f64, water: Water) -> SceneSpec {
        let laser = fsl_laser();
        let board = Checkerboard::fishsense();
        let s = board.square_m;
        // Dot in the middle of the white square (2, 1).
        let on_board = Vec3::new(1.5 * s, 0.5 * s, 0.0);
        let t = laser.point_at_depth(depth) - on_board;
        let pose =
            Pose { rotation: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], translation_m: [t.x, t.y, t.z] };
        SceneSpec {
            camera: tg6_camera(),
            laser: Some(laser),
            board: Some((board, pose)),
            water,
            glints: 0,
            impostor: false,
            seed: 9,
        }
    }

    /// Intensity-weighted centre of the green excess over its local median, around `at`.
    fn green_centroid(img: &RgbImage, at: [f64; 2], half: i64) -> Vec2 {
        let (cx, cy) = (at[0].round() as i64, at[1].round() as i64);
        let excess = |x: i64, y: i64| {
            let p = img.get_pixel(x as u32, y as u32);
            p[1] as f64 - (p[0].max(p[2])) as f64
        };
        let mut ring: Vec<f64> =
            (-half..=half).flat_map(|d| [excess(cx + d, cy - half), excess(cx + d, cy + half)]).collect();
        ring.sort_by(f64::total_cmp);
        let bg = ring[ring.len() / 2];
        let (mut sx, mut sy, mut sw) = (0.0, 0.0, 0.0);
        for y in cy - half..=cy + half {
            for x in cx - half..=cx + half {
                let w = (excess(x, y) - bg - 8.0).max(0.0);
                sx += w * x as f64;
                sy += w * y as f64;
                sw += w;
            }
        }
        Vec2::new(sx / sw, sy / sw)
    }

    #[test]
    fn the_dot_is_rendered_where_the_truth_says() {
        let scene = render(&face_on_spec(2.0, Water::Clear));
        let dot = scene.truth.dot.clone().expect("the laser hits the board");
        assert!(!dot.on_black_square && !dot.saturated);
        let c = green_centroid(&scene.image, dot.pixel, 12);
        let err = (c - Vec2::new(dot.pixel[0], dot.pixel[1])).norm();
        eprintln!("dot at 2 m: rendered centroid {err:.3} px from the truth");
        assert!(err < 0.3, "{err}");
        // Squares alternate: the centres of squares (1, 4) (white) and (2, 4) (black).
        let b = Checkerboard::fishsense();
        let pose = scene.truth.t_cam_target.unwrap();
        let at = |x: f64, y: f64| {
            let p = tg6_camera().project(&pose.apply(&Vec3::new(x * b.square_m, y * b.square_m, 0.0))).unwrap();
            let px = scene.image.get_pixel(p.x.round() as u32, p.y.round() as u32);
            px[1] as i32
        };
        let (white, black) = (at(0.5, 3.5), at(1.5, 3.5));
        assert!(white > black + 80, "white {white}, black {black}");
    }

    #[test]
    fn near_dots_saturate_far_dots_are_faint() {
        let near = render(&face_on_spec(0.7, Water::Clear)).truth.dot.unwrap();
        let far = render(&face_on_spec(4.4, Water::Murky)).truth.dot.unwrap();
        assert!(near.saturated && !far.saturated);
    }

    #[test]
    fn rendering_is_deterministic_and_a_no_board_scene_has_no_dot() {
        let mut spec = laser_scene_set(3, 5, Water::Murky, 3).remove(1);
        assert!(spec.impostor);
        let a = render(&spec);
        let b = render(&spec);
        assert!(a.image.as_raw() == b.image.as_raw(), "same seed, different pixels");
        assert!(a.truth.impostor.is_some() && a.truth.glints.len() == 3);
        spec.board = None;
        let t = std::time::Instant::now();
        let empty = render(&spec);
        eprintln!("no-board render: {:.2} s", t.elapsed().as_secs_f64());
        assert!(empty.truth.dot.is_none() && empty.truth.corners_px.is_empty());
    }

    #[test]
    fn scene_sets_keep_the_board_in_frame_with_the_dot_on_it() {
        let cam = tg6_camera();
        let specs = laser_scene_set(16, 11, Water::Clear, 0);
        let mut black = 0;
        for (i, s) in specs.iter().enumerate() {
            let (b, pose) = s.board.unwrap();
            assert!(target_in_frame(&cam, &b.outline_m(), &pose, 29.0), "photo {i}: board leaves the frame");
            let hit = s.laser.unwrap().hit(&pose.plane()).unwrap();
            let q = pose.to_target(&hit);
            let sh = TargetShader::new(Surface::Board(b), pose);
            let albedo = sh.albedo_at(&q).unwrap_or_else(|| panic!("photo {i}: the dot misses the board"));
            black += (albedo[1] == BLACK) as usize;
        }
        assert!((0.6..=4.5).contains(&specs[0].laser.unwrap().hit(&specs[0].board.unwrap().1.plane()).unwrap().z));
        assert!((2..=10).contains(&black), "{black} of 16 dots on black squares");
        for s in camera_scene_set(12, 4, Water::Clear) {
            let (b, pose) = s.board.unwrap();
            assert!(target_in_frame(&cam, &b.outline_m(), &pose, 9.0));
        }
    }
}
