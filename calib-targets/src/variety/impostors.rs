//! Things that look like a laser dot and are not: where the scene's own impostors (tape,
//! green fins, algae tufts, a laminate's sheen) land in the photo, and the image-space ones
//! added over it (specular glints, the laser's own reflection, bubbles, sun flecks).

use super::render::{add_glow, impostor, visible_at, Body, PhotoPlan};
use super::truth::{DotTruth, Impostor, ImpostorKind};
use crate::fish::{FishPart, FishShape};
use crate::random::SplitMix;
use crate::scene::{add_spot, Pose};
use fslcal_core::{Vec2, Vec3};

/// Pixel radius of `size_m` at camera-frame point `p`.
fn radius_px(plan: &PhotoPlan, size_m: f64, p: &Vec3) -> f64 {
    size_m * plan.camera.fx_px / p.z.max(1e-6)
}

fn on_plane(pose: &Pose, q: [f64; 2]) -> Vec3 {
    pose.apply(&Vec3::new(q[0], q[1], 0.0))
}

/// The middle of a fish's dorsal fin and of its caudal fin, plane metres, when present.
fn fin_centres(shape: &FishShape) -> Vec<Vec2> {
    let l = shape.fork_length_m;
    let mut out = Vec::new();
    let caudal = shape.spine_point(0.95 * l);
    if matches!(shape.part_at(caudal), Some(FishPart::CaudalFin)) {
        out.push(caudal);
    }
    // Walk out from the spine at 42% of the length, on the dorsal side, through the fin.
    let k = shape.bend_rad / l;
    let s = 0.42 * l;
    let normal = Vec2::new(-(k * s).sin(), (k * s).cos());
    let run: Vec<f64> = (1..=60)
        .map(|i| -(i as f64) / 60.0 * 0.8 * shape.depth * l)
        .filter(|w| matches!(shape.part_at(shape.spine_point(s) + normal * *w), Some(FishPart::DorsalFin)))
        .collect();
    if let (Some(a), Some(b)) = (run.first(), run.last()) {
        out.push(shape.spine_point(s) + normal * (0.5 * (a + b)));
    }
    out
}

/// Impostors that are part of the scene's surfaces, where the camera sees them.
pub(crate) fn decals(plan: &PhotoPlan) -> Vec<Impostor> {
    let mut out = Vec::new();
    for (k, o) in plan.objects.iter().enumerate() {
        let mut add = |kind: ImpostorKind, q: [f64; 2], size_m: f64| {
            let p = on_plane(&o.pose, q);
            if let Some(px) = visible_at(plan, k, &p) {
                out.push(impostor(kind, px, radius_px(plan, size_m, &p)));
            }
        };
        match &o.body {
            Body::Board { look, .. } => {
                if let Some(t) = &look.tape {
                    add(ImpostorKind::Tape, t.centre_m, t.half_width_m);
                }
                if let Some(s) = &look.sheen {
                    add(ImpostorKind::Sheen, s.centre_m, s.radius_m);
                }
            }
            Body::Slate { green_tapes_m, .. } => {
                for c in green_tapes_m {
                    add(ImpostorKind::Tape, *c, 0.01);
                }
            }
            Body::Fish { shape, look, .. } if look.green_fins => {
                for c in fin_centres(shape) {
                    add(ImpostorKind::Fin, [c.x, c.y], 0.08 * shape.fork_length_m);
                }
            }
            Body::Fish { .. } => {}
            Body::Reef { look } => {
                for t in &look.tufts {
                    add(ImpostorKind::Algae, t.centre_m, t.radius_m);
                }
            }
        }
    }
    out
}

/// A pixel for an image-space impostor: near the laser's image (within 60 px of the line
/// at some depth 0.3-6 m) with probability `near_line_share`, anywhere otherwise.
fn place(plan: &PhotoPlan, unit_laser: &fslcal_core::LaserLine, rng: &mut SplitMix) -> Vec2 {
    let cam = &plan.camera;
    let scale = cam.width_px as f64 / 4000.0;
    let (w, h) = (cam.width_px as f64, cam.height_px as f64);
    let margin = 20.0 * scale;
    if rng.unit() < plan.extras.near_line_share {
        for _ in 0..20 {
            let z = rng.range(0.3f64.ln(), 6.0f64.ln()).exp();
            let (Some(a), Some(b)) = (unit_laser.pixel_at_depth(cam, z), unit_laser.pixel_at_depth(cam, z * 1.02))
            else {
                continue;
            };
            let Some(t) = (b - a).try_normalize(1e-9) else { continue };
            let p = a + Vec2::new(-t.y, t.x) * rng.range(-60.0, 60.0) * scale;
            if p.x > margin && p.y > margin && p.x < w - margin && p.y < h - margin {
                return p;
            }
        }
    }
    Vec2::new(rng.range(margin, w - margin), rng.range(margin, h - margin))
}

/// A bubble: a bright thin rim and a highlight, lit by the water around it.
fn add_bubble(img: &mut [[f32; 3]], w: usize, h: usize, c: Vec2, r: f64, colour: [f64; 3]) {
    let reach = r + 3.0;
    let (x0, x1) = ((c.x - reach).floor().max(0.0) as usize, ((c.x + reach).ceil().max(0.0) as usize).min(w - 1));
    let (y0, y1) = ((c.y - reach).floor().max(0.0) as usize, ((c.y + reach).ceil().max(0.0) as usize).min(h - 1));
    let spec = c - Vec2::new(0.35 * r, 0.35 * r);
    let (rim_w, spec_s) = (0.25 * r + 0.6, 0.2 * r + 0.4);
    for y in y0..=y1 {
        for x in x0..=x1 {
            let p = Vec2::new(x as f64, y as f64);
            let rim = (-((p - c).norm() - r).powi(2) / (rim_w * rim_w)).exp();
            let hl = (-(p - spec).norm_squared() / (2.0 * spec_s * spec_s)).exp();
            let k = 0.6 * rim + hl;
            let px = &mut img[y * w + x];
            (0..3).for_each(|i| px[i] += (colour[i] * k) as f32);
        }
    }
}

/// Adds the image-space impostors and returns where they are.
pub(crate) fn add_extras(
    plan: &PhotoPlan,
    dot: Option<&DotTruth>,
    img: &mut [[f32; 3]],
    rng: &mut SplitMix,
) -> Vec<Impostor> {
    let cam = &plan.camera;
    let (w, h) = (cam.width_px as usize, cam.height_px as usize);
    let scale = cam.width_px as f64 / 4000.0;
    let line = plan.unit_laser;
    let mut out = Vec::new();
    for _ in 0..plan.extras.glints {
        let c = place(plan, &line, rng);
        let r = rng.range(0.4, 4.0) * scale + 0.5;
        let level = rng.range(300.0, 1500.0);
        add_spot(img, w, h, c, r, [level; 3], (r + 1.0, 0.08));
        out.push(impostor(ImpostorKind::Glint, c, r));
    }
    if let (true, Some(_)) = (plan.extras.reflection, plan.laser) {
        let (level, r) = match dot {
            Some(d) => (d.radiance_levels * rng.range(0.08, 0.5), d.radius_px * rng.range(0.6, 1.4)),
            None => (rng.range(150.0, 600.0), rng.range(1.0, 5.0) * scale),
        };
        let c = match dot.filter(|_| rng.unit() < 0.4) {
            Some(d) => {
                let a = rng.range(0.0, std::f64::consts::TAU);
                let p =
                    Vec2::new(d.pixel[0], d.pixel[1]) + Vec2::new(a.cos(), a.sin()) * rng.range(30.0, 150.0) * scale;
                Vec2::new(p.x.clamp(5.0, w as f64 - 6.0), p.y.clamp(5.0, h as f64 - 6.0))
            }
            None => place(plan, &line, rng),
        };
        let colour = plan.laser_look.chroma.map(|k| k * level);
        add_spot(img, w, h, c, r.max(0.5), colour, (1.5 * r + 2.0 * scale, 0.06));
        out.push(impostor(ImpostorKind::Reflection, c, r));
    }
    add_bubbles(plan, img, rng, &mut out);
    for _ in 0..plan.extras.flecks {
        let c = place(plan, &line, rng);
        let sigma = rng.range(4.0, 35.0) * scale + 0.5;
        let level = rng.range(25.0, 110.0);
        add_glow(img, w, h, c, sigma, plan.water.light_colour.map(|k| k * level));
        out.push(impostor(ImpostorKind::SunFleck, c, sigma));
    }
    out
}

/// Bubbles in one to three rising columns.
fn add_bubbles(plan: &PhotoPlan, img: &mut [[f32; 3]], rng: &mut SplitMix, out: &mut Vec<Impostor>) {
    let cam = &plan.camera;
    let (w, h) = (cam.width_px as usize, cam.height_px as usize);
    let scale = cam.width_px as f64 / 4000.0;
    let n = plan.extras.bubbles;
    if n == 0 {
        return;
    }
    let columns = 1 + rng.below(3) as u32;
    let colour: [f64; 3] = plan.water.veil.map(|v| 0.8 * v + 90.0);
    let mut c = place(plan, &plan.unit_laser, rng);
    for i in 0..n {
        if i > 0 && i % n.div_ceil(columns) == 0 {
            c = place(plan, &plan.unit_laser, rng);
        }
        let r = rng.range(1.5, 12.0) * scale + 0.5;
        if c.x > r + 2.0 && c.y > r + 2.0 && c.x < w as f64 - r - 2.0 && c.y < h as f64 - r - 2.0 {
            add_bubble(img, w, h, c, r, colour);
            out.push(impostor(ImpostorKind::Bubble, c, r));
        }
        c += Vec2::new(rng.range(-4.0, 4.0) * r, -rng.range(2.5, 8.0) * r);
    }
}
