//! The three kinds of scene, composed at random for one photo of a set: a checkerboard for
//! `fslcal laser`, a taped slate, and photos without a target (fish and reef) as `check` and
//! `measure` see them.

use super::look::{CameraEffects, LightLook, WaterLook, WaterType};
use super::materials::{BoardLook, FishLook, ReefLook};
use super::render::{dot_radiance, Body, Extras, Object, PhotoPlan};
use super::unit::Unit;
use crate::fish::{fish_in_frame, FishPose, FishShape};
use crate::random::SplitMix;
use crate::scene::{board_pose, random_rotation, search_pose, to_rows, Pose, SlateTexture};
use crate::Checkerboard;
use fslcal_core::{CameraModel, Vec2, Vec3};
use std::sync::Arc;

/// Distances of board photos, metres.
pub const BOARD_DEPTHS_M: (f64, f64) = (0.55, 5.0);
/// Distances of slate photos, metres: a slate is small, divers hold it close.
pub const SLATE_DEPTHS_M: (f64, f64) = (0.5, 2.5);

/// A diver stays where the subject can still be seen (three attenuation lengths of green)
/// and, when aiming the laser, where its dot on a mid-grey surface still reaches `levels`.
fn reach_m(plan: &PhotoPlan, levels: f64) -> f64 {
    let sight = 3.0 / plan.water.attenuation_per_m[1];
    let mut z: f64 = 0.5;
    while z < sight && dot_radiance(&plan.laser_look, &plan.water, [0.5; 3], z, z) / plan.light.level >= levels {
        z += 0.05;
    }
    z.clamp(0.8, sight.max(0.8))
}

/// The core level a diver wants to see of a dot on a target, 8-bit levels.
const TARGET_DOT_LEVELS: f64 = 25.0;
/// A diver aiming at a fish or the reef sees fainter dots, or none.
const SUBJECT_DOT_LEVELS: f64 = 8.0;

/// What every photo draws for itself, whatever its kind.
pub(crate) fn base_plan(unit: &Unit, seed: u64, rng: &mut SplitMix) -> PhotoPlan {
    let scale = unit.camera.width_px as f64 / 4000.0;
    let water = WaterLook::draw(rng, scale);
    let light = LightLook::draw(rng, water.kind);
    let effects = CameraEffects::draw(rng, scale);
    PhotoPlan {
        seed,
        camera: unit.camera,
        laser: Some(unit.laser),
        unit_laser: unit.laser,
        laser_look: unit.laser_look.clone(),
        power_factor: rng.range(0.85, 1.15),
        water,
        light,
        effects,
        tone_gamma: unit.tone_gamma,
        objects: Vec::new(),
        extras: Extras::default(),
    }
}

/// Glints, the laser's reflection, bubbles, sun flecks (not in harbours).
fn draw_extras(rng: &mut SplitMix, water: WaterType, glossy: bool, near_line_share: f64) -> Extras {
    Extras {
        glints: rng.below(6) as u32 + if glossy { 2 + rng.below(6) as u32 } else { 0 },
        reflection: rng.unit() < 0.3,
        bubbles: if rng.unit() < 0.3 { 3 + rng.below(15) as u32 } else { 0 },
        flecks: if water != WaterType::Harbour && rng.unit() < 0.4 { 1 + rng.below(6) as u32 } else { 0 },
        near_line_share,
    }
}

/// A reef plane through `through_m`, facing the camera within 60 degrees, with tufts of
/// green algae: some anywhere in view, some on the laser's image.
fn reef(plan: &PhotoPlan, through_m: Vec3, rng: &mut SplitMix) -> Object {
    let r = random_rotation(rng, 60.0, 180.0);
    let pose = Pose { rotation: to_rows(&r), translation_m: [through_m.x, through_m.y, through_m.z] };
    let mut look = ReefLook::draw(rng);
    let mut object = Object { body: Body::Reef { look: look.clone() }, pose };
    let cam = &plan.camera;
    for _ in 0..rng.below(20) {
        let px = if rng.unit() < 0.4 {
            let z = rng.range(0.3f64.ln(), 6.0f64.ln()).exp();
            plan.unit_laser.pixel_at_depth(cam, z)
        } else {
            Some(Vec2::new(rng.range(0.0, cam.width_px as f64), rng.range(0.0, cam.height_px as f64)))
        };
        let Some(ray) = px.and_then(|p| cam.ray(p)) else { continue };
        let Some(t) = object.plane_t(&Vec3::zeros(), &ray) else { continue };
        let p = ray * t;
        let q = pose.to_target(&p);
        // 3-30 px in a 4000 px photo, whatever the distance.
        let size_m = rng.range(3.0, 30.0) * p.z / (cam.fx_px * 4000.0 / cam.width_px as f64);
        look.tufts.push(ReefLook::tuft(rng, [q.x, q.y], size_m));
    }
    object.body = Body::Reef { look };
    object
}

/// A fish shape no longer than a third of the frame's width at `depth_m`.
fn fish_shape(rng: &mut SplitMix, camera: &CameraModel, depth_m: f64) -> FishShape {
    let frame_m = depth_m * camera.width_px as f64 / camera.fx_px;
    FishShape {
        fork_length_m: rng.range(0.15, 0.6).min(frame_m / 3.0),
        depth: rng.range(0.22, 0.36),
        bend_rad: if rng.unit() < 0.4 { rng.range(-1.6, 1.6) } else { 0.0 },
        fork_depth: if rng.unit() < 0.75 { rng.range(0.07, 0.14) } else { 0.0 },
    }
}

/// The pose that puts plane point `spine share dot_at` (a little off the spine) of the fish
/// at camera point `at`.
fn fish_through(shape: &FishShape, at: Vec3, heading_rad: f64, dot_at: f64, mirrored: bool) -> FishPose {
    let probe = FishPose { depth_m: at.z, snout_xy_m: [0.0, 0.0], heading_rad, mirrored };
    let on_fish = probe.camera_point(
        shape.spine_point(dot_at * shape.fork_length_m) + Vec2::new(0.0, 0.1 * shape.depth * shape.fork_length_m),
    );
    FishPose { depth_m: at.z, snout_xy_m: [at.x - on_fish.x, at.y - on_fish.y], heading_rad, mirrored }
}

fn fish_object(shape: FishShape, pose: FishPose, rng: &mut SplitMix) -> Object {
    Object { body: Body::Fish { shape, look: FishLook::draw(rng), pose }, pose: pose.t_cam_target() }
}

/// A fish through camera point `at`, tried at several headings until it is in the frame.
fn fish_at(plan: &PhotoPlan, at: Vec3, rng: &mut SplitMix) -> Object {
    let mut shape = fish_shape(rng, &plan.camera, at.z);
    let mirrored = rng.unit() < 0.5;
    let margin = 10.0 * plan.camera.width_px as f64 / 4000.0;
    let mut pose = fish_through(&shape, at, rng.range(-3.1, 3.1), rng.range(0.25, 0.65), mirrored);
    for _ in 0..60 {
        if fish_in_frame(&plan.camera, &shape, &pose, margin) {
            break;
        }
        pose = fish_through(&shape, at, rng.range(-3.1, 3.1), rng.range(0.25, 0.65), mirrored);
        shape.fork_length_m *= 0.98;
    }
    fish_object(shape, pose, rng)
}

/// A fish anywhere in view at a depth in `depths_m`.
fn stray_fish(plan: &PhotoPlan, depths_m: (f64, f64), rng: &mut SplitMix) -> Option<Object> {
    let cam = &plan.camera;
    let px = Vec2::new(rng.range(0.1, 0.9) * cam.width_px as f64, rng.range(0.1, 0.9) * cam.height_px as f64);
    let n = cam.undistort(px)?;
    let z = rng.range(depths_m.0, depths_m.1.max(depths_m.0 + 0.01));
    Some(fish_at(plan, Vec3::new(n.x * z, n.y * z, z), rng))
}

/// One photo of a checkerboard calibration set: distances spread over the set, tilted up
/// to 35 degrees, the dot on a random square (a third on black ones), reef or open water
/// behind, sometimes a fish behind the board.
pub(crate) fn calibration_photo(unit: &Unit, seed: u64, index: usize, count: usize) -> PhotoPlan {
    let mut rng = SplitMix::derive(seed, 1000 + index as u64);
    let mut plan = base_plan(unit, SplitMix::derive(seed, 5000 + index as u64).next_u64(), &mut rng);
    let board = Checkerboard::fishsense();
    let look = BoardLook::draw(&mut rng, &board);
    let t = if count > 1 { index as f64 / (count - 1) as f64 } else { 0.5 };
    let (near, far) = BOARD_DEPTHS_M;
    let depth =
        (near + (far - near) * t + rng.range(-0.1, 0.1)).clamp(near, far).min(reach_m(&plan, TARGET_DOT_LEVELS));
    let pose = board_pose(&mut rng, &plan.camera, &unit.laser, &board, depth);
    let glossy = look.sheen.is_some();
    plan.objects.push(Object { body: Body::Board { board, look }, pose });
    backdrop(&mut plan, depth, &mut rng);
    plan.laser = (rng.unit() >= 0.05).then_some(unit.laser);
    plan.extras = draw_extras(&mut rng, plan.water.kind, glossy, 0.3);
    plan
}

/// Reef behind the target (70%) or open water; sometimes a fish between them.
fn backdrop(plan: &mut PhotoPlan, depth_m: f64, rng: &mut SplitMix) {
    let behind = depth_m + rng.range(0.5, 4.0);
    if rng.unit() < 0.7 {
        let r = reef(plan, Vec3::new(0.0, 0.0, behind), rng);
        plan.objects.push(r);
    }
    if rng.unit() < 0.2 {
        if let Some(f) = stray_fish(plan, (depth_m + 0.2, behind), rng) {
            plan.objects.push(f);
        }
    }
}

/// One photo of a slate set: the set's slate from 0.5 to 2.5 m, tilted up to 35 degrees,
/// the dot on it away from its edges.
pub(crate) fn slate_photo(
    unit: &Unit,
    slate: &Arc<SlateTexture>,
    green_tapes_m: &[[f64; 2]],
    seed: u64,
    index: usize,
    count: usize,
) -> PhotoPlan {
    let mut rng = SplitMix::derive(seed, 1000 + index as u64);
    let mut plan = base_plan(unit, SplitMix::derive(seed, 5000 + index as u64).next_u64(), &mut rng);
    let t = if count > 1 { index as f64 / (count - 1) as f64 } else { 0.5 };
    let (near, far) = SLATE_DEPTHS_M;
    let depth =
        (near + (far - near) * t + rng.range(-0.05, 0.05)).clamp(near, far).min(reach_m(&plan, TARGET_DOT_LEVELS));
    let hit = unit.laser.point_at_depth(depth);
    let (w, h) = (slate.width_m, slate.height_m);
    let place = |rng: &mut SplitMix, ease: f64, r: &nalgebra::Matrix3<f64>| {
        let k = 0.15 + 0.35 * (1.0 - ease);
        Some(hit - r * Vec3::new(rng.range(k, 1.0 - k) * w, rng.range(k, 1.0 - k) * h, 0.0))
    };
    let margin = 30.0 * plan.camera.width_px as f64 / 4000.0;
    let fallback = hit - Vec3::new(0.5 * w, 0.5 * h, 0.0);
    let pose = search_pose(&mut rng, &plan.camera, &slate.outline_m(), margin, place, fallback);
    let body = Body::Slate { texture: Arc::clone(slate), green_tapes_m: green_tapes_m.to_vec() };
    plan.objects.push(Object { body, pose });
    backdrop(&mut plan, depth, &mut rng);
    plan.laser = (rng.unit() >= 0.05).then_some(unit.laser);
    plan.extras = draw_extras(&mut rng, plan.water.kind, false, 0.3);
    plan
}

/// Where the laser points in a photo without a target.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Aim {
    Fish,
    Reef,
    /// A fish nearer the camera hides the dot on the reef.
    Occluded,
    /// A rock so close that the dot's image is outside the frame.
    OffFrame,
    OpenWater,
}

/// One photo without a target: the dot on a fish (52%) or the reef (25%), the laser off
/// (15%, aimed at either), the dot hidden behind a nearer fish (4%), off the frame on a rock
/// too close (2%), or lost in open water (2%); up to two more fish anywhere.
pub(crate) fn targetless_photo(unit: &Unit, seed: u64, index: usize) -> PhotoPlan {
    let mut rng = SplitMix::derive(seed, 1000 + index as u64);
    let mut plan = base_plan(unit, SplitMix::derive(seed, 5000 + index as u64).next_u64(), &mut rng);
    let u = rng.unit();
    let (aim, laser_on) = if u < 0.52 {
        (Aim::Fish, true)
    } else if u < 0.77 {
        (Aim::Reef, true)
    } else if u < 0.92 {
        (if rng.unit() < 0.5 { Aim::Fish } else { Aim::Reef }, false)
    } else if u < 0.96 {
        (Aim::Occluded, true)
    } else if u < 0.98 {
        (Aim::OffFrame, true)
    } else {
        (Aim::OpenWater, true)
    };
    let far = reach_m(&plan, SUBJECT_DOT_LEVELS).min(6.0);
    match aim {
        Aim::Fish => aim_at_fish(&mut plan, far, &mut rng),
        Aim::Reef => {
            let z = rng.range(0.5f64.ln(), far.max(0.6).ln()).exp();
            let r = reef(&plan, unit.laser.point_at_depth(z), &mut rng);
            plan.objects.push(r);
        }
        Aim::Occluded => aim_behind_fish(&mut plan, far, &mut rng),
        Aim::OffFrame => aim_too_close(&mut plan, &mut rng),
        Aim::OpenWater => {}
    }
    if aim != Aim::OffFrame {
        for _ in 0..rng.below(3) {
            if let Some(f) = stray_fish(&plan, (0.5, far.max(0.6)), &mut rng) {
                plan.objects.push(f);
            }
        }
    }
    plan.laser = laser_on.then_some(unit.laser);
    plan.extras = draw_extras(&mut rng, plan.water.kind, false, 0.5);
    plan
}

/// A fish with the dot on its flank at 0.5 m to `far_m`, reef behind it or open water.
fn aim_at_fish(plan: &mut PhotoPlan, far_m: f64, rng: &mut SplitMix) {
    let z = rng.range(0.5, far_m.clamp(0.6, 5.0));
    let f = fish_at(plan, plan.unit_laser.point_at_depth(z), rng);
    plan.objects.push(f);
    if rng.unit() < 0.75 {
        let behind = z + rng.range(0.3, 5.0);
        let r = reef(plan, Vec3::new(0.0, 0.0, behind), rng);
        plan.objects.push(r);
    }
}

/// The dot on the reef, hidden from the camera by a nearer fish that the beam passes by.
fn aim_behind_fish(plan: &mut PhotoPlan, far_m: f64, rng: &mut SplitMix) {
    let laser = plan.unit_laser;
    let z = rng.range(1.5f64.min(far_m), far_m.max(1.6));
    let dot = laser.point_at_depth(z);
    let r = reef(plan, dot, rng);
    plan.objects.push(r);
    let zf = rng.range(0.4, (z - 0.6).max(0.5));
    // Where the camera's ray to the dot crosses depth zf: the fish must cover it.
    let at = dot * (zf / dot.z);
    for _ in 0..30 {
        let shape = fish_shape(rng, &plan.camera, zf);
        let pose = fish_through(&shape, at, rng.range(-3.1, 3.1), rng.range(0.3, 0.6), rng.unit() < 0.5);
        let beam = pose.t_cam_target().to_target(&laser.point_at_depth(zf));
        if !shape.contains(Vec2::new(beam.x, beam.y)) {
            plan.objects.push(fish_object(shape, pose, rng));
            return;
        }
    }
}

/// A rock face so close that the beam meets it outside the frame.
fn aim_too_close(plan: &mut PhotoPlan, rng: &mut SplitMix) {
    let (cam, laser) = (plan.camera, plan.unit_laser);
    let mut z = 0.5;
    while z > 0.005 && laser.pixel_at_depth(&cam, z).is_some_and(|p| cam.contains(p)) {
        z *= 0.9;
    }
    let at = laser.point_at_depth(0.8 * z);
    let r = random_rotation(rng, 20.0, 180.0);
    let pose = Pose { rotation: to_rows(&r), translation_m: [at.x, at.y, at.z] };
    plan.objects.push(Object { body: Body::Reef { look: ReefLook::draw(rng) }, pose });
}
