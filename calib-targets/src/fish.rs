//! Synthetic fish with exact snout, fork and fork length, photographed under water with the
//! laser dot on them, for testing `fslcal measure` end to end.
//!
//! A fish is a flat silhouette in the plane `z = depth_m` (fronto-parallel, as the thesis's
//! `L = D n w / f` assumes). Its spine is a circular arc from the snout (arc length 0) to the
//! fork (arc length `fork_length_m`, the truth), so a bent fish's fork length is measured
//! along its body as on a measuring board. Around the spine: a rounded head, a deep body,
//! a dorsal fin, a narrow caudal peduncle and a caudal fin whose two lobes reach
//! `fork_depth` beyond the fork. The photo comes from the same renderer as the board scenes
//! (`scene::render_setup`, the fish as a target surface): water, blur, noise, the laser dot where the laser meets the fish.

use crate::random::SplitMix;
use crate::scene::{render_setup, DotTruth, Pose, RayGrid, Setup, Surface, Water};
use fslcal_core::{CameraModel, LaserLine, Vec2, Vec3};
use image::{GrayImage, RgbImage};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// A fish's shape, in shares of its fork length.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct FishShape {
    /// Snout to fork along the spine, metres: the truth.
    pub fork_length_m: f64,
    /// Greatest body depth over fork length.
    pub depth: f64,
    /// Total turn of the spine from snout to fork, radians (0: straight).
    pub bend_rad: f64,
    /// How far the caudal lobes reach behind the fork, over fork length (0: square tail).
    pub fork_depth: f64,
}

/// Grey reflectance of the fish's flank.
const FISH_ALBEDO: f64 = 0.5;
/// Where the body is deepest, the peduncle starts, and the caudal fin starts (shares of the
/// fork length along the spine); the peduncle's half-depth over the body's.
const DEEPEST: f64 = 0.38;
const PEDUNCLE: f64 = 0.80;
const FIN_START: f64 = 0.87;
const PEDUNCLE_DEPTH: f64 = 0.28;

impl FishShape {
    /// Spine coordinates `(s, w)` (metres along the spine from the snout, metres across it,
    /// positive to the inside of the bend) of a point in the fish's plane frame (snout at the
    /// origin, heading along +x, bending toward +y).
    fn spine_coordinates(&self, q: Vec2) -> (f64, f64) {
        let k = self.bend_rad / self.fork_length_m;
        if k.abs() < 1e-9 {
            return (q.x, q.y);
        }
        let r = 1.0 / k;
        let d = q - Vec2::new(0.0, r);
        // Angle swept from the snout, around the bend's centre.
        let phi = d.x.atan2(-d.y * r.signum());
        (phi * r.abs(), r.abs() - d.norm())
    }

    /// A point on the spine at arc length `s` in the plane frame.
    pub(crate) fn spine_point(&self, s: f64) -> Vec2 {
        let k = self.bend_rad / self.fork_length_m;
        if k.abs() < 1e-9 {
            return Vec2::new(s, 0.0);
        }
        Vec2::new((k * s).sin() / k, (1.0 - (k * s).cos()) / k)
    }

    /// Whether a plane-frame point is on the fish.
    pub(crate) fn contains(&self, q: Vec2) -> bool {
        self.part_at(q).is_some()
    }

    /// Which part of the fish a plane-frame point is on, `None` off the fish.
    pub(crate) fn part_at(&self, q: Vec2) -> Option<FishPart> {
        let (s, w) = self.spine_coordinates(q);
        let l = self.fork_length_m;
        let t = s / l;
        let body = 0.5 * self.depth * l;
        let lobes = self.fork_depth * l;
        if !(0.0..=1.0 + self.fork_depth).contains(&t) {
            return None;
        }
        let half = if t < DEEPEST {
            // A rounded head.
            body * (1.0 - ((DEEPEST - t) / DEEPEST).powi(2)).sqrt()
        } else if t < PEDUNCLE {
            let u = (t - DEEPEST) / (PEDUNCLE - DEEPEST);
            body * (PEDUNCLE_DEPTH + (1.0 - PEDUNCLE_DEPTH) * 0.5 * (1.0 + (std::f64::consts::PI * u).cos()))
        } else if t < FIN_START {
            body * PEDUNCLE_DEPTH
        } else {
            // The caudal fin fans out to 1.1 body depths at the lobe tips; its rear edge is a V
            // from the fork (on the spine at s = l) to the lobe tips `lobes` further back.
            let span = 1.1 * body;
            let u = (s - FIN_START * l) / (l + lobes - FIN_START * l).max(1e-9);
            let half = body * PEDUNCLE_DEPTH + (span - body * PEDUNCLE_DEPTH) * u.clamp(0.0, 1.0);
            let rear = l + lobes * (w.abs() / (0.8 * span)).min(1.0);
            if s > rear {
                return None;
            }
            half
        };
        // A dorsal fin on the outside of the bend (w < 0), between 35% and 62% of the length.
        let dorsal = if (0.35..0.62).contains(&t) && w < 0.0 { 0.35 * body * (1.0 - (t - 0.35) / 0.27) } else { 0.0 };
        if w.abs() <= half {
            Some(if t < FIN_START {
                FishPart::Body { along: t, across: w / half.max(1e-12) }
            } else {
                FishPart::CaudalFin
            })
        } else if w < 0.0 && -w <= half + dorsal {
            Some(FishPart::DorsalFin)
        } else {
            None
        }
    }

    /// Albedo at a target-frame point (the fish's plane frame), `None` off the fish.
    pub(crate) fn albedo_at(&self, q: &Vec3) -> Option<[f64; 3]> {
        self.contains(Vec2::new(q.x, q.y)).then_some([FISH_ALBEDO; 3])
    }

    /// Points around the outline, plane frame, for keeping the fish in the frame.
    pub(crate) fn outline_samples(&self) -> Vec<Vec2> {
        let l = self.fork_length_m;
        let k = self.bend_rad / l;
        let mut out = Vec::new();
        for i in 0..=40 {
            let s = (1.0 + self.fork_depth) * l * i as f64 / 40.0;
            let p = self.spine_point(s);
            let normal = Vec2::new(-(k * s).sin(), (k * s).cos());
            for w in [-0.8 * self.depth * l, 0.0, 0.8 * self.depth * l] {
                out.push(p + normal * w);
            }
        }
        out
    }
}

/// A part of a fish's silhouette, for painting it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum FishPart {
    /// Head, body and peduncle: `along` the spine as a share of the fork length, `across`
    /// from -1 (the outside of the bend, where the dorsal fin is) to 1.
    Body {
        along: f64,
        across: f64,
    },
    CaudalFin,
    DorsalFin,
}

/// Where a fish is and which way it swims.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct FishPose {
    pub depth_m: f64,
    /// The snout's position in the camera frame (its z is `depth_m`).
    pub snout_xy_m: [f64; 2],
    /// Direction the spine leaves the snout, radians from the camera's +x toward +y.
    pub heading_rad: f64,
    /// Mirror the fish across its spine (bend to the other side, dorsal fin below).
    pub mirrored: bool,
}

impl FishPose {
    /// Camera-frame point of a plane-frame point.
    pub(crate) fn camera_point(&self, q: Vec2) -> Vec3 {
        self.t_cam_target().apply(&Vec3::new(q.x, q.y, 0.0))
    }

    /// `T_cam_target` with the fish's plane frame as the target: turned by the heading about
    /// the optical axis, mirrored across the spine when asked (a reflection, still orthogonal).
    pub fn t_cam_target(&self) -> Pose {
        let (c, s) = (self.heading_rad.cos(), self.heading_rad.sin());
        let m = if self.mirrored { -1.0 } else { 1.0 };
        Pose {
            rotation: [[c, -s * m, 0.0], [s, c * m, 0.0], [0.0, 0.0, 1.0]],
            translation_m: [self.snout_xy_m[0], self.snout_xy_m[1], self.depth_m],
        }
    }
}

/// Everything that decides one fish photo.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FishSpec {
    pub camera: CameraModel,
    pub laser: Option<LaserLine>,
    pub shape: FishShape,
    pub pose: FishPose,
    pub water: Water,
    pub seed: u64,
}

/// What a fish photo shows, exactly: its spec, and where the snout, fork and dot appear.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FishTruth {
    #[serde(flatten)]
    pub spec: FishSpec,
    /// Snout tip and fork (the notch's bottom), pixels.
    pub snout_px: [f64; 2],
    pub fork_px: [f64; 2],
    pub fork_length_m: f64,
    pub dot: Option<DotTruth>,
}

pub struct RenderedFish {
    pub image: RgbImage,
    /// 255 on the fish (each pixel's centre), 0 elsewhere: what a perfect segmenter gives.
    pub mask: GrayImage,
    pub truth: FishTruth,
}

/// Renders a fish photo, its mask and its truth.
pub fn render_fish(spec: &FishSpec) -> RenderedFish {
    let pose = spec.pose.t_cam_target();
    let photo = render_setup(&Setup {
        camera: spec.camera,
        laser: spec.laser,
        target: Some((Surface::Fish(&spec.shape), pose)),
        water: spec.water,
        glints: 0,
        impostor: false,
        seed: spec.seed,
    });
    let cam = &spec.camera;
    let grid = RayGrid::new(cam, 8);
    let (w, h) = (cam.width_px as usize, cam.height_px as usize);
    let z = spec.pose.depth_m;
    let bits: Vec<u8> = (0..h)
        .into_par_iter()
        .flat_map_iter(|y| {
            let (grid, shape) = (&grid, &spec.shape);
            (0..w).map(move |x| {
                let n = grid.normalised(x as f64, y as f64);
                let q = pose.to_target(&Vec3::new(n[0] * z, n[1] * z, z));
                if shape.contains(Vec2::new(q.x, q.y)) {
                    255
                } else {
                    0
                }
            })
        })
        .collect();
    let mask = GrayImage::from_raw(w as u32, h as u32, bits).expect("buffer matches the image size");
    let project = |s: f64| {
        let p = cam
            .project(&spec.pose.camera_point(spec.shape.spine_point(s)))
            .expect("the fish is in front of the camera");
        [p.x, p.y]
    };
    RenderedFish {
        image: photo.image,
        mask,
        truth: FishTruth {
            spec: spec.clone(),
            snout_px: project(0.0),
            fork_px: project(spec.shape.fork_length_m),
            fork_length_m: spec.shape.fork_length_m,
            dot: photo.truth.dot,
        },
    }
}

/// Whether the whole fish is in the image, `margin_px` from the border.
pub(crate) fn fish_in_frame(camera: &CameraModel, shape: &FishShape, pose: &FishPose, margin_px: f64) -> bool {
    shape.outline_samples().iter().all(|q| {
        camera.project(&pose.camera_point(*q)).is_some_and(|p| {
            p.x >= margin_px
                && p.y >= margin_px
                && p.x <= camera.width_px as f64 - 1.0 - margin_px
                && p.y <= camera.height_px as f64 - 1.0 - margin_px
        })
    })
}

/// The pose that puts the laser dot on the fish's flank at `dot_at` of its length (a little
/// off the spine), heading `heading_rad`: the diver aims the laser at the fish.
pub fn pose_with_dot(
    shape: &FishShape,
    laser: &LaserLine,
    depth_m: f64,
    heading_rad: f64,
    dot_at: f64,
    mirrored: bool,
) -> FishPose {
    let hit = laser.point_at_depth(depth_m);
    let probe = FishPose { depth_m, snout_xy_m: [0.0, 0.0], heading_rad, mirrored };
    let on_fish = probe.camera_point(
        shape.spine_point(dot_at * shape.fork_length_m) + Vec2::new(0.0, 0.1 * shape.depth * shape.fork_length_m),
    );
    FishPose { depth_m, snout_xy_m: [hit.x - on_fish.x, hit.y - on_fish.y], heading_rad, mirrored }
}

/// A dive's fish photos: the TG-6 rig, fish of 0.18-0.5 m fork length (no longer than a
/// third of the frame's width at their distance), at distances spread evenly over
/// `near_m..far_m`, every other one bent into a C (75-95 degrees from snout to fork), most
/// with forked tails, the laser dot on each.
pub fn fish_scene_set(count: usize, seed: u64, water: Water, near_m: f64, far_m: f64) -> Vec<FishSpec> {
    let camera = crate::rig::tg6_camera();
    let laser = crate::rig::fsl_laser();
    (0..count)
        .map(|i| {
            let mut rng = SplitMix::derive(seed ^ 0xF15E, i as u64);
            let t = if count > 1 { i as f64 / (count - 1) as f64 } else { 0.5 };
            let depth_m = near_m + (far_m - near_m) * t;
            let frame_m = depth_m * camera.width_px as f64 / camera.fx_px;
            let mut shape = FishShape {
                fork_length_m: rng.range(0.18, 0.5).min(frame_m / 3.0),
                depth: rng.range(0.24, 0.34),
                bend_rad: if i % 2 == 1 { rng.range(1.3, 1.7) } else { 0.0 },
                fork_depth: if i % 4 == 3 { 0.0 } else { rng.range(0.07, 0.14) },
            };
            let mirrored = rng.unit() < 0.5;
            let mut pose = pose_with_dot(&shape, &laser, depth_m, rng.range(-3.1, 3.1), 0.4, mirrored);
            for _ in 0..200 {
                if fish_in_frame(&camera, &shape, &pose, 40.0) {
                    break;
                }
                let heading = rng.range(-3.1, 3.1);
                pose = pose_with_dot(&shape, &laser, depth_m, heading, rng.range(0.3, 0.6), mirrored);
                shape.fork_length_m *= 0.99;
            }
            FishSpec {
                camera,
                laser: Some(laser),
                shape,
                pose,
                water,
                seed: seed.wrapping_mul(1000).wrapping_add(700 + i as u64),
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spine_coordinates_invert_the_spine() {
        for bend in [0.0, 0.8, -0.5] {
            let shape = FishShape { fork_length_m: 0.3, depth: 0.3, bend_rad: bend, fork_depth: 0.1 };
            for s in [0.0, 0.1, 0.3] {
                let (s2, w) = shape.spine_coordinates(shape.spine_point(s));
                assert!((s2 - s).abs() < 1e-12 && w.abs() < 1e-12, "bend {bend} s {s}: {s2} {w}");
            }
            // The fork is a notch: just behind it on the spine is water, beside it fin.
            assert!(shape.contains(shape.spine_point(0.29)));
            assert!(!shape.contains(shape.spine_point(0.305)));
        }
    }

    #[test]
    fn scene_set_keeps_fish_in_frame_with_the_dot_on_them() {
        let cam = crate::rig::tg6_camera();
        for spec in fish_scene_set(8, 4, Water::Clear, 0.6, 4.0) {
            assert!(fish_in_frame(&cam, &spec.shape, &spec.pose, 40.0), "{spec:?}");
            let hit = spec.laser.unwrap().point_at_depth(spec.pose.depth_m);
            let q = spec.pose.t_cam_target().to_target(&hit);
            assert!(spec.shape.contains(Vec2::new(q.x, q.y)), "dot misses the fish: {spec:?}");
        }
    }
}
