//! Claims about the randomised scenes, checked on small photos (1000x750, the same camera
//! scaled) so that they run in seconds.

use super::render::{dot_geometry, nearest, render};
use super::*;
use fslcal_core::Vec2;
use std::collections::{BTreeMap, BTreeSet};

const SMALL: u32 = 1000;

/// Intensity-weighted centre of what the laser adds: the photo minus the same photo with
/// the laser off (same noise), in a window around `at`.
fn laser_centroid(on: &RgbImage, off: &RgbImage, at: [f64; 2], half: i64) -> Option<Vec2> {
    let (cx, cy) = (at[0].round() as i64, at[1].round() as i64);
    let (mut sx, mut sy, mut sw) = (0.0, 0.0, 0.0);
    for y in (cy - half).max(0)..=(cy + half).min(on.height() as i64 - 1) {
        for x in (cx - half).max(0)..=(cx + half).min(on.width() as i64 - 1) {
            let (a, b) = (on.get_pixel(x as u32, y as u32), off.get_pixel(x as u32, y as u32));
            let w = (a[1] as f64 - b[1] as f64).max(0.0);
            sx += w * x as f64;
            sy += w * y as f64;
            sw += w;
        }
    }
    (sw > 0.0).then(|| Vec2::new(sx / sw, sy / sw))
}

#[test]
fn the_dot_is_rendered_where_the_truth_says() {
    let mut checked = 0;
    for (kind, seed) in [(Kind::Targetless, 1), (Kind::Calibration, 2), (Kind::Slate, 3)] {
        let set = VarietySet::plan(kind, seed, Some(8), SMALL).unwrap();
        for plan in &set.plans {
            let mut plan = plan.clone();
            // Nothing else may change with the laser: no reflection, no motion streak (which
            // smears the dot into clipped neighbours).
            plan.extras.reflection = false;
            plan.effects.motion_blur_px = 0.0;
            // The difference of two photos is the laser's light only in linear levels: through
            // a tone curve, a dot on a sloping background weighs its brighter side less.
            plan.tone_gamma = 1.0;
            let on = render(&plan);
            let Ok(dot) = &on.dot else { continue };
            // Clipped or unresolved dots have no clean centroid; the truth's own formula is
            // what is checked here.
            if dot.saturated || dot.radiance_levels > 200.0 || dot.peak_levels < 20.0 || dot.radius_px < 1.0 {
                continue;
            }
            plan.laser = None;
            let off = render(&plan);
            let half = (4.0 * dot.radius_px + 6.0 * plan.water.blur_sigma_px + 4.0).ceil() as i64;
            let c = laser_centroid(&on.image, &off.image, dot.pixel, half).expect("the laser adds light");
            let err = (c - Vec2::new(dot.pixel[0], dot.pixel[1])).norm();
            assert!(err < 0.35, "{kind:?} seed {seed}: rendered centroid {err:.3} px from the truth ({dot:?})");
            checked += 1;
        }
    }
    assert!(checked >= 5, "only {checked} dots clean enough to check");
}

#[test]
fn seeds_split_at_one_million_and_sets_are_deterministic() {
    assert_eq!(SeedSplit::of(0), SeedSplit::Tuning);
    assert_eq!(SeedSplit::of(HELD_OUT_FIRST_SEED - 1), SeedSplit::Tuning);
    assert_eq!(SeedSplit::of(HELD_OUT_FIRST_SEED), SeedSplit::HeldOut);
    let a = VarietySet::plan(Kind::Targetless, 5, Some(2), SMALL).unwrap().render(1);
    let b = VarietySet::plan(Kind::Targetless, 5, Some(2), SMALL).unwrap().render(1);
    assert!(a.image.as_raw() == b.image.as_raw() && a.truth == b.truth, "same seed, different photo");
    let other = VarietySet::plan(Kind::Calibration, 5, Some(2), SMALL).unwrap();
    assert_ne!(other.unit, VarietySet::plan(Kind::Targetless, 5, Some(2), SMALL).unwrap().unit);
    assert!(VarietySet::plan(Kind::Slate, 5, None, 1001).is_err());
    assert!(VarietySet::plan(Kind::Slate, 5, Some(0), SMALL).is_err());
}

#[test]
fn every_photo_draws_its_own_look_and_the_unit_stays() {
    let set = VarietySet::plan(Kind::Calibration, 7, None, SMALL).unwrap();
    assert!((12..=16).contains(&set.len()), "{}", set.len());
    let waters: BTreeSet<_> = set.plans.iter().map(|p| p.water.kind).collect();
    let qualities: BTreeSet<_> = set.plans.iter().map(|p| p.effects.jpeg_quality).collect();
    assert!(waters.len() >= 2 && qualities.len() >= 4, "{waters:?} {qualities:?}");
    assert!(set.plans.iter().all(|p| p.laser_look == set.unit.laser_look && p.camera == set.unit.camera));
    let looks: BTreeSet<String> = (0..40)
        .map(|s| {
            format!(
                "{:.0}",
                VarietySet::plan(Kind::Targetless, s, Some(1), SMALL).unwrap().unit.laser_look.wavelength_nm
            )
        })
        .collect();
    assert!(looks.len() >= 10, "laser colours barely vary: {looks:?}");
}

#[test]
fn calibration_photos_have_the_dot_on_the_board_with_every_corner_in_frame() {
    // A target-less set's companion calibration too: the same unit, photographed on the board.
    let target_less = VarietySet::plan(Kind::Targetless, 14, None, SMALL).unwrap();
    let companion = target_less.companion_calibration(10).unwrap();
    assert_eq!(companion.unit, target_less.unit);
    assert_eq!((companion.kind, companion.len()), (Kind::Calibration, 10));
    let own = VarietySet::plan(Kind::Calibration, 14, Some(10), SMALL).unwrap();
    assert_ne!(companion.plan_digest(), own.plan_digest(), "the companion must not repeat set 14's scenes");
    for (seed, set) in [11, 12, 13]
        .map(|seed| (seed, VarietySet::plan(Kind::Calibration, seed, None, SMALL).unwrap()))
        .into_iter()
        .chain([(14, companion)])
    {
        let (mut near, mut far) = (f64::MAX, 0.0f64);
        for (i, plan) in set.plans.iter().enumerate() {
            let Body::Board { board, .. } = &plan.objects[0].body else { panic!("seed {seed} photo {i}: no board") };
            let pose = plan.objects[0].pose;
            for p in board.object_points() {
                let px = plan.camera.project(&pose.apply(&Vec3::from(p))).unwrap();
                assert!(plan.camera.contains(px), "seed {seed} photo {i}: corner {px:?} off the frame");
            }
            let hit = nearest(&plan.objects, &set.unit.laser.origin(), &set.unit.laser.dir()).unwrap();
            assert_eq!(hit.object, 0, "seed {seed} photo {i}: the beam misses the board");
            near = near.min(hit.point.z);
            far = far.max(hit.point.z);
        }
        assert!(near < 0.7 && far > 1.5, "seed {seed}: dots only from {near:.2} to {far:.2} m");
    }
}

#[test]
fn targetless_sets_cover_every_case_and_impostor_kind() {
    // The geometry of 600 photos (cheap), then 40 rendered for what only pixels tell.
    let (mut reasons, mut surfaces) = (BTreeMap::new(), BTreeSet::new());
    for seed in 0..30 {
        for plan in &VarietySet::plan(Kind::Targetless, seed, Some(20), 400).unwrap().plans {
            match dot_geometry(plan) {
                Ok((hit, _)) => _ = surfaces.insert(format!("{:?}", plan.objects[hit.object].kind())),
                Err(why) => *reasons.entry(why).or_insert(0) += 1,
            }
        }
    }
    eprintln!("600 target-less photos: no dot {reasons:?}, dots on {surfaces:?}");
    assert_eq!(reasons.len(), 4, "no-dot reasons seen: {reasons:?}");
    assert!((60..=130).contains(&reasons[&NoDot::LaserOff]), "{reasons:?}");
    assert!(surfaces.contains("Fish") && surfaces.contains("Reef"), "{surfaces:?}");
    let (mut impostors, mut faint) = (BTreeSet::new(), 0);
    for seed in 0..2 {
        let set = VarietySet::plan(Kind::Targetless, seed, Some(20), 400).unwrap();
        for i in 0..set.len() {
            let t = set.render(i).truth;
            assert_eq!(t.dot.is_none(), t.no_dot.is_some());
            assert_eq!(t.laser_on, t.no_dot != Some(NoDot::LaserOff));
            impostors.extend(t.impostors.iter().map(|i| i.kind));
            faint += (t.dot.is_some() && t.visible_dot().is_none()) as usize;
        }
    }
    for k in
        [ImpostorKind::Glint, ImpostorKind::Reflection, ImpostorKind::Bubble, ImpostorKind::Algae, ImpostorKind::Fin]
    {
        assert!(impostors.contains(&k), "no {k:?} in 40 photos: {impostors:?}");
    }
    assert!(faint > 0, "no faint dot in 40 photos");
}

#[test]
fn near_dots_clip_all_three_channels() {
    // The nearest photo (0.55 m) of calibration sets: a bright laser this close saturates
    // the sensor in all three channels, a weak one only in green or not at all.
    let mut saturated = Vec::new();
    for seed in 0..8 {
        // Half size: at a quarter, blur spreads a near dot's core below clipping.
        let set = VarietySet::plan(Kind::Calibration, seed, Some(12), 2000).unwrap();
        let dot = set.render(0).truth.dot;
        saturated.push(dot.is_some_and(|d| d.saturated));
    }
    let n = saturated.iter().filter(|s| **s).count();
    eprintln!("near dots saturated in all three channels: {saturated:?}");
    assert!((2..=7).contains(&n), "{n} of 8 near dots saturated");
}

#[test]
fn scene_impostors_are_where_the_truth_says() {
    // Each tuft, fin and tape recorded is what the camera sees at its pixel.
    let mut checked = 0;
    for (kind, seed) in [(Kind::Targetless, 21), (Kind::Calibration, 22), (Kind::Slate, 23)] {
        let set = VarietySet::plan(kind, seed, Some(10), SMALL).unwrap();
        for plan in &set.plans {
            for imp in impostors::decals(plan) {
                let ray = plan.camera.ray(Vec2::new(imp.pixel[0], imp.pixel[1])).unwrap();
                let hit = nearest(&plan.objects, &Vec3::zeros(), &ray).expect("a surface under the impostor");
                let (albedo, _) = plan.objects[hit.object].material_at(&hit.point).unwrap();
                if matches!(imp.kind, ImpostorKind::Algae | ImpostorKind::Tape | ImpostorKind::Fin) {
                    // Yellow-green: much more green than blue.
                    assert!(albedo[1] > 2.0 * albedo[2], "{kind:?} seed {seed}: {imp:?} is on {albedo:?}");
                }
                checked += 1;
            }
        }
    }
    assert!(checked >= 10, "{checked}");
}

#[test]
fn a_written_set_is_what_fslcal_reads() {
    let dir = std::env::temp_dir().join(format!("variety-write-{}", std::process::id()));
    let set = VarietySet::plan(Kind::Slate, 31, Some(2), 400).unwrap();
    let mut seen = Vec::new();
    let photos = set.write(&dir, &mut |p| seen.push(p.to_path_buf())).unwrap();
    assert_eq!(photos, seen);
    let slate = crate::Slate::load(&dir.join("slate.toml")).unwrap();
    assert!(slate.length(Some("diagonal")).unwrap().length_m() > 0.2);
    let cal: serde_json::Value = serde_json::from_slice(&std::fs::read(dir.join("cal.json")).unwrap()).unwrap();
    assert_eq!(cal["camera"]["image_size"], serde_json::json!([400, 300]));
    assert_eq!(cal["laser"]["origin_m"], serde_json::json!(set.unit.laser.origin_m));
    let truth: PhotoTruth =
        serde_json::from_slice(&std::fs::read(photos[1].with_extension("truth.json")).unwrap()).unwrap();
    assert_eq!(truth.index, 1);
    assert_eq!(image::image_dimensions(&photos[1]).unwrap(), (400, 300));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_tone_curve_is_the_units_and_maps_linear_levels_by_its_power() {
    let gammas: Vec<f64> = (0..200).map(|seed| unit::draw_unit(seed, SMALL).tone_gamma).collect();
    let (lo, hi) = unit::TONE_GAMMA_RANGE;
    assert!(gammas.iter().all(|g| (lo..=hi).contains(g)), "a gamma outside {lo}-{hi}");
    assert!(gammas.iter().filter(|&&g| g < 1.3).count() >= 30 && gammas.iter().filter(|&&g| g > 2.1).count() >= 30);
    // The curve has its own stream: the camera and laser are what they were without it.
    let unit = unit::draw_unit(5, SMALL);
    assert_eq!(unit.camera, unit::draw_camera(&mut SplitMix::derive(5, 0x0417), SMALL));

    let set = VarietySet::plan(Kind::Targetless, 4, Some(1), SMALL).unwrap();
    let mut plan = set.plans[0].clone();
    assert_eq!(plan.tone_gamma, set.unit.tone_gamma);
    plan.tone_gamma = 1.0;
    let linear = render(&plan).image;
    plan.tone_gamma = 2.2;
    let toned = render(&plan).image;
    // Same noise before the curve: each toned level is the curve of the linear one, to
    // within the two roundings (half a level, times the curve's slope, plus half a level).
    let mut compared = 0;
    for (l, t) in linear.as_raw().iter().zip(toned.as_raw()) {
        if *l < 20 || *l > 250 {
            continue;
        }
        let expected = 255.0 * (*l as f64 / 255.0).powf(1.0 / 2.2);
        let slope = expected / (2.2 * *l as f64);
        assert!((*t as f64 - expected).abs() <= 0.5 * slope + 0.5 + 1e-9, "linear {l}: toned {t}, curve {expected:.2}");
        compared += 1;
    }
    assert!(compared > linear.as_raw().len() / 4, "only {compared} levels compared");
}
