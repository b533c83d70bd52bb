//! `fslcal check` on rendered 4000x3000 photos of the example slate (the check itself uses
//! no target): 50 photos from the calibrated laser, none may flag the calibration; three
//! photos from a laser knocked by 0.4 degrees must.

mod common;

use calib_targets::rig::{fsl_laser, tg6_camera};
use calib_targets::scene::Water;
use common::slate_set;
use fslcal::calibration::Calibration;
use fslcal::drift_check::check;
use fslcal_core::LaserLine;

/// The rig's laser with the 1-sigma uncertainty a slate fit reports (origin 0.5 mm,
/// direction 0.006 deg per axis).
fn calibration() -> Calibration {
    let (so, sd) = (0.5e-3f64, 1e-4f64);
    Calibration {
        camera: tg6_camera(),
        laser: fsl_laser(),
        laser_covariance: [[so * so, 0.0, 0.0, 0.0], [0.0, so * so, 0.0, 0.0], [0.0, 0.0, sd * sd, 0.0], [0.0, 0.0, 0.0, sd * sd]],
        depth_range_m: Some((0.45, 2.2)),
        unit: None,
        camera_serial: None,
        source: "test".into(),
    }
}

/// The laser knocked by `deg` out of the plane of the camera centre and the beam, turning
/// about its origin (the clamp).
fn knocked(l: &LaserLine, deg: f64) -> LaserLine {
    let plane_normal = l.origin().cross(&l.dir());
    let axis = nalgebra::Unit::new_normalize(l.dir().cross(&plane_normal));
    let d = nalgebra::Rotation3::from_axis_angle(&axis, deg.to_radians()) * l.dir();
    LaserLine::from_point_direction(l.origin(), d).unwrap()
}

#[test]
fn a_laser_knocked_by_0_4_deg_is_flagged_from_three_photos() {
    let set = slate_set("check-knocked", knocked(&fsl_laser(), 0.4), (0.6, 2.0), 3, 41, Water::Clear, 1);
    let r = check(&calibration(), &set.photos, &|| {}).expect("check");
    for p in &r.photos {
        eprintln!("  knocked: {} offset {:?} px, sigma {:?}, flag {}, {:?}", p.file, p.offset_px, p.explained_sigma_px, p.flag, p.reason);
    }
    let implied = r.implied_direction_change_deg.expect("dots found");
    eprintln!("knocked by 0.4 deg: drifted {}, implied direction change {implied:.3} deg", r.drifted);
    assert!(r.drifted);
    assert!(r.photos.iter().all(|p| p.flag), "every photo of the knocked laser flagged");
    assert!((implied - 0.4).abs() < 0.1, "implied change {implied:.3} deg");
}

#[test]
fn fifty_photos_from_the_calibrated_laser_are_not_flagged() {
    let set = slate_set("check-calibrated", fsl_laser(), (0.45, 2.2), 50, 43, Water::Murky, 2);
    let r = check(&calibration(), &set.photos, &|| {}).expect("check");
    let with_dot = r.photos.iter().filter(|p| p.offset_px.is_some()).count();
    let flagged = r.photos.iter().filter(|p| p.flag).count();
    let worst = r.photos.iter().filter_map(|p| p.offset_px).fold(0.0f64, f64::max);
    for p in r.photos.iter().filter(|p| p.flag || p.offset_px.is_none()) {
        eprintln!("  {} offset {:?} sigma {:?} {:?}", p.file, p.offset_px, p.explained_sigma_px, p.reason);
    }
    eprintln!("calibrated laser: {with_dot} of 50 photos with a dot, false flags {flagged} of {with_dot}, worst offset {worst:.2} px, drifted {}", r.drifted);
    assert!(with_dot >= 45, "only {with_dot} of 50 dots found");
    assert!(!r.drifted);
    assert!(flagged * 50 <= with_dot, "false-flag rate {flagged} of {with_dot} (limit 2%)");
}
