//! Rendering one planned photo: the scene's planes (board or slate, fish, reef) shaded under
//! its light and water, supersampled at hard edges; the laser dot where the beam first
//! meets something and the camera sees it; the impostors; then blur, motion blur, noise.

use super::look::{CameraEffects, LaserLook, LightLook, WaterLook};
use super::materials::noise;
use super::materials::{BoardLook, FishLook, ReefLook};
use super::truth::{DotTruth, Impostor, ImpostorKind, NoDot, SurfaceKind};
use crate::fish::{FishPose, FishShape};
use crate::random::SplitMix;
use crate::scene::{add_spot, blur, through_water, Pose, RayGrid, SlateTexture, WaterOptics};
use crate::scene::{BEAM_DIAMETER_M, LASER_RADIANCE};
use crate::Checkerboard;
use fslcal_core::{CameraModel, LaserLine, Vec2, Vec3};
use image::RgbImage;
use rayon::prelude::*;
use std::sync::Arc;

/// What a plane in the scene is.
#[derive(Clone)]
pub(crate) enum Body {
    Board {
        board: Checkerboard,
        look: BoardLook,
    },
    /// A slate, and the yellow-green tapes on it (scan metres).
    Slate {
        texture: Arc<SlateTexture>,
        green_tapes_m: Vec<[f64; 2]>,
    },
    Fish {
        shape: FishShape,
        look: FishLook,
        pose: FishPose,
    },
    Reef {
        look: ReefLook,
    },
}

impl std::fmt::Debug for Body {
    /// Everything but a slate scan's pixels (the set's digest formats every plan).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Body::Board { board, look } => write!(f, "Board {board:?} {look:?}"),
            Body::Slate { texture, green_tapes_m } => {
                write!(f, "Slate {}x{} m {green_tapes_m:?}", texture.width_m, texture.height_m)
            }
            Body::Fish { shape, look, pose } => write!(f, "Fish {shape:?} {look:?} {pose:?}"),
            Body::Reef { look } => write!(f, "Reef {look:?}"),
        }
    }
}

/// A plane in the scene and where it is (`T_cam_target`).
#[derive(Clone, Debug)]
pub(crate) struct Object {
    pub body: Body,
    pub pose: Pose,
}

/// The reef is a plane without end; beyond this range it is lost in the veil anyway.
const REEF_MAX_RANGE_M: f64 = 40.0;

impl Object {
    pub fn kind(&self) -> SurfaceKind {
        match self.body {
            Body::Board { .. } => SurfaceKind::Board,
            Body::Slate { .. } => SurfaceKind::Slate,
            Body::Fish { .. } => SurfaceKind::Fish,
            Body::Reef { .. } => SurfaceKind::Reef,
        }
    }

    /// Parameter `t` where `origin + t dir` meets this object's plane, in front of `origin`.
    pub fn plane_t(&self, origin: &Vec3, dir: &Vec3) -> Option<f64> {
        let n = self.pose.normal();
        let denom = n.dot(dir);
        if denom.abs() < 1e-12 {
            return None;
        }
        let t = n.dot(&(Vec3::from(self.pose.translation_m) - origin)) / denom;
        (t > 1e-9).then_some(t)
    }

    /// Albedo and region at a camera-frame point on the plane, `None` off the object.
    pub fn material_at(&self, p: &Vec3) -> Option<([f64; 3], u32)> {
        let q = self.pose.to_target(p);
        let q2 = Vec2::new(q.x, q.y);
        match &self.body {
            Body::Board { board, look } => look.albedo_at(board, q2),
            Body::Slate { texture, .. } => texture.albedo_at(&q).map(|a| (a, 0)),
            Body::Fish { shape, look, .. } => shape.part_at(q2).map(|part| look.albedo(part, q2)),
            Body::Reef { look } => (p.norm() < REEF_MAX_RANGE_M).then(|| look.albedo_at(q2)),
        }
    }
}

/// The nearest surface along a ray.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Hit {
    pub object: usize,
    pub albedo: [f64; 3],
    pub region: u32,
    pub point: Vec3,
}

/// The nearest object along `origin + t dir`, `t > 0`.
pub(crate) fn nearest(objects: &[Object], origin: &Vec3, dir: &Vec3) -> Option<Hit> {
    let mut best: Option<(f64, Hit)> = None;
    for (k, o) in objects.iter().enumerate() {
        let Some(t) = o.plane_t(origin, dir) else { continue };
        if best.as_ref().is_some_and(|b| b.0 <= t) {
            continue;
        }
        let point = origin + dir * t;
        if let Some((albedo, region)) = o.material_at(&point) {
            best = Some((t, Hit { object: k, albedo, region, point }));
        }
    }
    best.map(|b| b.1)
}

/// Everything that decides one photo.
#[derive(Clone, Debug)]
pub(crate) struct PhotoPlan {
    pub seed: u64,
    pub camera: CameraModel,
    /// `None`: laser off.
    pub laser: Option<LaserLine>,
    /// The unit's laser whether on or off: impostors are placed near its image.
    pub unit_laser: LaserLine,
    pub laser_look: LaserLook,
    /// This photo's power over the unit's (battery, aim).
    pub power_factor: f64,
    pub water: WaterLook,
    pub light: LightLook,
    pub effects: CameraEffects,
    /// The unit's tone curve (`Unit::tone_gamma`).
    pub tone_gamma: f64,
    pub objects: Vec<Object>,
    pub extras: Extras,
}

/// Image-space impostors to add, and how many of them sit near the laser's image.
#[derive(Clone, Debug, Default)]
pub(crate) struct Extras {
    pub glints: u32,
    pub reflection: bool,
    pub bubbles: u32,
    pub flecks: u32,
    /// Share of glints, bubbles, flecks and reflections placed within a few dozen pixels of
    /// the laser's image, where a search along the calibrated line looks.
    pub near_line_share: f64,
}

/// A rendered photo before JPEG, with its dot and impostors.
pub(crate) struct Rendered {
    pub image: RgbImage,
    pub dot: Result<DotTruth, NoDot>,
    pub impostors: Vec<Impostor>,
}

/// Renders a planned photo.
pub(crate) fn render(plan: &PhotoPlan) -> Rendered {
    let cam = &plan.camera;
    let (w, h) = (cam.width_px as usize, cam.height_px as usize);
    let optics = plan.water.optics();
    let mut img = shade(plan, &optics);
    let mut dot = laser_dot(plan, &mut img);
    let mut rng = SplitMix::derive(plan.seed, 0xE7);
    let mut impostors = super::impostors::decals(plan);
    impostors.extend(super::impostors::add_extras(plan, dot.as_ref().ok(), &mut img, &mut rng));
    blur(&mut img, w, h, plan.water.blur_sigma_px);
    motion_blur(&mut img, w, h, plan.effects.motion_blur_px, plan.effects.motion_blur_angle_deg.to_radians());
    let image = quantise(&img, w, h, &plan.effects, plan.tone_gamma, plan.seed);
    if let Ok(d) = dot.as_mut() {
        let (x, y) = (d.pixel[0].round().clamp(0.0, w as f64 - 1.0), d.pixel[1].round().clamp(0.0, h as f64 - 1.0));
        d.saturated = image.get_pixel(x as u32, y as u32).0.iter().all(|&c| c >= 250);
    }
    Rendered { image, dot, impostors }
}

/// Daylight reaching a surface point seen at pixel `(u, v)`, as a multiple of the
/// renderer's illumination: level, gradient, vignette, caustics.
fn light_at(plan: &PhotoPlan, u: f64, v: f64, p: &Vec3) -> f64 {
    let l = &plan.light;
    let cam = &plan.camera;
    let (w, h) = (cam.width_px as f64, cam.height_px as f64);
    let (du, dv) = ((u - 0.5 * w) / (0.5 * w.hypot(h)), (v - 0.5 * h) / (0.5 * w.hypot(h)));
    let a = l.gradient_angle_deg.to_radians();
    let gradient = 1.0 + 0.5 * l.gradient_strength * (du * a.cos() + dv * a.sin());
    let vignette = 1.0 - l.vignette * (du * du + dv * dv);
    let caustic = if l.caustic_strength > 0.0 {
        // Ridged noise on the horizontal plane: bright thin lines where the waves focus.
        let (x, y) = (p.x, p.z + 0.5 * p.y);
        let ridge = |s: u64, c: f64| 1.0 - (2.0 * noise(s, x, y, c) - 1.0).abs();
        let r = ridge(l.caustic_seed, l.caustic_cell_m) * ridge(l.caustic_seed ^ 1, 0.6 * l.caustic_cell_m);
        1.0 + l.caustic_strength * (3.0 * r.powi(4) - 0.4)
    } else {
        1.0
    };
    (l.level * gradient * vignette * caustic).max(0.0)
}

/// Colour of the ray through normalised coordinates `n` at pixel `(u, v)`, and its region
/// (object and region inside it; 0 for open water).
fn shade_ray(plan: &PhotoPlan, optics: &WaterOptics, n: [f64; 2], u: f64, v: f64) -> ([f64; 3], u32) {
    let ray = Vec3::new(n[0], n[1], 1.0);
    match nearest(&plan.objects, &Vec3::zeros(), &ray) {
        Some(hit) => {
            let light = light_at(plan, u, v, &hit.point);
            let lit: [f64; 3] = [0, 1, 2].map(|k| hit.albedo[k] * plan.water.light_colour[k] * light);
            let id = ((hit.object as u32 + 1) << 24) | (hit.region & 0xFF_FFFF);
            (through_water(optics, lit, hit.point.norm()), id)
        }
        None => {
            // Open water: the veil, brighter toward the surface.
            let up = 1.0 - v / plan.camera.height_px as f64;
            (optics.veil.map(|c| c * (0.8 + 0.4 * up)), 0)
        }
    }
}

/// The scene through the water: one ray per pixel, then 3x3 rays where a pixel's region
/// differs from a neighbour's (edges of boards, squares, fish, tape).
fn shade(plan: &PhotoPlan, optics: &WaterOptics) -> Vec<[f32; 3]> {
    let cam = &plan.camera;
    let (w, h) = (cam.width_px as usize, cam.height_px as usize);
    let grid = RayGrid::new(cam, 8);
    let mut first = vec![([0f32; 3], 0u32); w * h];
    first.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        for (x, out) in row.iter_mut().enumerate() {
            let (u, v) = (x as f64, y as f64);
            let (c, id) = shade_ray(plan, optics, grid.normalised(u, v), u, v);
            *out = (c.map(|k| k as f32), id);
        }
    });
    const SUB: [f64; 3] = [-1.0 / 3.0, 0.0, 1.0 / 3.0];
    let mut img = vec![[0f32; 3]; w * h];
    img.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        for (x, out) in row.iter_mut().enumerate() {
            let (c, id) = first[y * w + x];
            let edge = (x > 0 && first[y * w + x - 1].1 != id)
                || (x + 1 < w && first[y * w + x + 1].1 != id)
                || (y > 0 && first[(y - 1) * w + x].1 != id)
                || (y + 1 < h && first[(y + 1) * w + x].1 != id);
            if !edge {
                *out = c;
                continue;
            }
            let mut acc = [0.0f64; 3];
            for dy in SUB {
                for dx in SUB {
                    let (u, v) = (x as f64 + dx, y as f64 + dy);
                    let (s, _) = shade_ray(plan, optics, grid.normalised(u, v), u, v);
                    (0..3).for_each(|k| acc[k] += s[k]);
                }
            }
            *out = acc.map(|k| (k / 9.0) as f32);
        }
    });
    img
}

/// Where the beam first meets a surface and where the camera sees that point, or why there
/// is no dot.
pub(crate) fn dot_geometry(plan: &PhotoPlan) -> Result<(Hit, Vec2), NoDot> {
    let laser = plan.laser.as_ref().ok_or(NoDot::LaserOff)?;
    let hit = nearest(&plan.objects, &laser.origin(), &laser.dir()).ok_or(NoDot::NoSurface)?;
    let cam = &plan.camera;
    let px = cam.project(&hit.point).filter(|q| cam.contains(*q)).ok_or(NoDot::OffFrame)?;
    let seen = nearest(&plan.objects, &Vec3::zeros(), &hit.point).ok_or(NoDot::Occluded)?;
    if seen.object != hit.object || (seen.point - hit.point).norm() > 2e-3 {
        return Err(NoDot::Occluded);
    }
    Ok((hit, px))
}

/// The laser dot: where the beam first meets a surface, if the camera sees that point.
fn laser_dot(plan: &PhotoPlan, img: &mut [[f32; 3]]) -> Result<DotTruth, NoDot> {
    let (hit, px) = dot_geometry(plan)?;
    let laser = plan.laser.as_ref().expect("a dot only with the laser on");
    let cam = &plan.camera;
    let p = hit.point;
    let look = &plan.laser_look;
    let range = (p - laser.origin()).norm();
    // The camera exposes for the daylight: in dim light the laser stands out more.
    let radiance = dot_radiance(look, &plan.water, hit.albedo, range, p.norm()) * plan.power_factor / plan.light.level;
    let diameter = look.beam_diameter_m + look.divergence_rad * range;
    let scale = cam.width_px as f64 / 4000.0;
    let radius_px = 0.5 * diameter * cam.fx_px / p.z;
    let white = look.crosstalk * (radiance / 1000.0).min(1.0);
    let colour = look.chroma.map(|c| radiance * (c + white * (1.0 - c)));
    let halo_sigma = plan.water.halo_width * (1.5 * radius_px + 2.0 * scale);
    let (w, h) = (cam.width_px as usize, cam.height_px as usize);
    add_spot(img, w, h, px, radius_px, colour, (halo_sigma, plan.water.halo_strength));
    let bloom = look.bloom_strength * (radiance / 800.0).min(1.5);
    add_glow(img, w, h, px, look.bloom_width * (radius_px + scale), colour.map(|c| c * bloom));
    let sigma2 = plan.water.blur_sigma_px.powi(2) + plan.effects.motion_blur_px.powi(2) / 12.0 + 0.1;
    let peak = colour[1] * (1.0 - (-radius_px.powi(2) / (2.0 * sigma2)).exp());
    Ok(DotTruth {
        pixel: [px.x, px.y],
        point_m: [p.x, p.y, p.z],
        depth_m: p.z,
        range_m: range,
        surface: plan.objects[hit.object].kind(),
        radius_px,
        radiance_levels: colour[1],
        peak_levels: peak,
        saturated: false,
    })
}

/// The dot's radiance on a surface of `albedo` (its core's level before the camera's
/// colour response), for a beam that ran `range_m` from the laser and `back_m` back to the
/// camera: the reference pointer's brightness spread over the beam's footprint, the share
/// the surface returns at the laser's wavelength, the water's attenuation both ways.
pub(crate) fn dot_radiance(look: &LaserLook, water: &WaterLook, albedo: [f64; 3], range_m: f64, back_m: f64) -> f64 {
    let diameter = look.beam_diameter_m + look.divergence_rad * range_m;
    let spread = (BEAM_DIAMETER_M / diameter).powi(2);
    // The laser's own wavelength: between the green and red channels' attenuation.
    let a = &water.attenuation_per_m;
    let g = a[1] + (a[0] - a[1]) * ((look.wavelength_nm - 532.0) / 120.0).clamp(0.0, 0.25);
    let chroma_sum: f64 = look.chroma.iter().sum();
    let returned = [0, 1, 2].map(|k| albedo[k] * look.chroma[k]).iter().sum::<f64>() / chroma_sum;
    let laser_return = (returned / 0.85).clamp(0.05, 1.15);
    LASER_RADIANCE * look.power * laser_return * spread * (-g * (range_m + back_m)).exp()
}

/// A Gaussian glow (no core), added.
pub(crate) fn add_glow(img: &mut [[f32; 3]], w: usize, h: usize, centre: Vec2, sigma: f64, colour: [f64; 3]) {
    let reach = (3.5 * sigma).ceil() + 1.0;
    let x0 = (centre.x - reach).floor().max(0.0) as usize;
    let x1 = ((centre.x + reach).ceil().max(0.0) as usize).min(w.saturating_sub(1));
    let y0 = (centre.y - reach).floor().max(0.0) as usize;
    let y1 = ((centre.y + reach).ceil().max(0.0) as usize).min(h.saturating_sub(1));
    for y in y0..=y1 {
        for x in x0..=x1 {
            let d2 = (x as f64 - centre.x).powi(2) + (y as f64 - centre.y).powi(2);
            let k = (-0.5 * d2 / (sigma * sigma)).exp();
            let px = &mut img[y * w + x];
            (0..3).for_each(|c| px[c] += (colour[c] * k) as f32);
        }
    }
}

/// A straight streak of `length_px` at `angle_rad`, centred (so a blob's centroid stays).
fn motion_blur(img: &mut Vec<[f32; 3]>, w: usize, h: usize, length_px: f64, angle_rad: f64) {
    if length_px < 0.5 {
        return;
    }
    let taps = (length_px.ceil() as usize + 1).max(2);
    let offsets: Vec<(f64, f64)> = (0..taps)
        .map(|k| {
            let t = (k as f64 / (taps - 1) as f64 - 0.5) * length_px;
            (t * angle_rad.cos(), t * angle_rad.sin())
        })
        .collect();
    let src = &*img;
    let sample = |x: f64, y: f64| -> [f32; 3] {
        let (x, y) = (x.clamp(0.0, (w - 1) as f64), y.clamp(0.0, (h - 1) as f64));
        let (ix, iy) = ((x as usize).min(w - 2), (y as usize).min(h - 2));
        let (fx, fy) = ((x - ix as f64) as f32, (y - iy as f64) as f32);
        let (a, b, c, d) = (src[iy * w + ix], src[iy * w + ix + 1], src[(iy + 1) * w + ix], src[(iy + 1) * w + ix + 1]);
        [0, 1, 2].map(|k| {
            let top = a[k] + (b[k] - a[k]) * fx;
            top + (c[k] + (d[k] - c[k]) * fx - top) * fy
        })
    };
    let mut out = vec![[0f32; 3]; w * h];
    out.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        for (x, o) in row.iter_mut().enumerate() {
            let mut acc = [0f32; 3];
            for (dx, dy) in &offsets {
                let s = sample(x as f64 + dx, y as f64 + dy);
                (0..3).for_each(|k| acc[k] += s[k]);
            }
            *o = acc.map(|k| k / taps as f32);
        }
    });
    *img = out;
}

/// Read and shot noise on the sensor's linear levels, then the camera's tone curve, then
/// 8-bit quantisation; one generator per row keeps it independent of the thread count. The
/// noise is a sum of four uniforms scaled to unit variance (a normal to within what 8-bit
/// levels show, at a fraction of Box-Muller's cost). Noise before the curve, as in a camera:
/// the curve lifts the shadows' noise with their signal, so a dot's signal to noise does not
/// change with the curve, only its levels and apparent colour do.
fn quantise(img: &[[f32; 3]], w: usize, h: usize, effects: &CameraEffects, tone_gamma: f64, seed: u64) -> RgbImage {
    let (read2, gain) = (effects.noise_read_levels.powi(2), effects.noise_shot_gain as f32);
    let inverse_gamma = (1.0 / tone_gamma) as f32;
    let tone = |linear: f32| -> f32 {
        let c = linear.clamp(0.0, 255.0);
        if inverse_gamma == 1.0 {
            c
        } else {
            255.0 * (c / 255.0).powf(inverse_gamma)
        }
    };
    let mut bytes = vec![0u8; w * h * 3];
    bytes.par_chunks_mut(w * 3).zip(img.par_chunks(w)).enumerate().for_each(|(y, (out, row))| {
        let mut g = SplitMix::derive(seed ^ 0x004E_015E, y as u64);
        for (o, &c) in out.iter_mut().zip(row.iter().flatten()) {
            let r = g.next_u64();
            let sum = (r & 0xFFFF) + ((r >> 16) & 0xFFFF) + ((r >> 32) & 0xFFFF) + (r >> 48);
            // Four uniforms on [0, 1): mean 2, variance 1/3.
            let normal = (sum as f32 / 65536.0 - 2.0) * 1.732_050_8;
            let sigma = (read2 as f32 + gain * c.clamp(0.0, 255.0)).sqrt();
            *o = tone(c + sigma * normal).round() as u8;
        }
    });
    RgbImage::from_raw(w as u32, h as u32, bytes).expect("buffer matches the image size")
}

/// Whether the camera sees `object` at camera-frame point `p` (in the frame, not hidden
/// behind something nearer), and where.
pub(crate) fn visible_at(plan: &PhotoPlan, object: usize, p: &Vec3) -> Option<Vec2> {
    let px = plan.camera.project(p).filter(|q| plan.camera.contains(*q))?;
    let seen = nearest(&plan.objects, &Vec3::zeros(), p)?;
    (seen.object == object && (seen.point - p).norm() < 2e-3).then_some(px)
}

/// An impostor record.
pub(crate) fn impostor(kind: ImpostorKind, pixel: Vec2, radius_px: f64) -> Impostor {
    Impostor { kind, pixel: [pixel.x, pixel.y], radius_px }
}
