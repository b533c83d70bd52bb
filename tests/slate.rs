//! The slate as a target, end to end on rendered 4000x3000 photos of the example taped
//! slate from 0.45 to 2.2 m: detection against the exact pose, the laser fit from slate
//! photos, and `validate` with a right and a wrong calibration.

mod common;

use calib_targets::rig::{fsl_laser, tg6_camera};
use calib_targets::scene::Water;
use common::{example_slate, example_slate_path, slate_set, SceneSet};
use fslcal::calibration::validate::{validate, LengthRule, ValidationJob};
use fslcal::calibration::Calibration;
use fslcal::dot::candidates::DotDetectorParams;
use fslcal::laser::fit::{angle_deg, Gates, Method};
use fslcal::laser::pipeline::{calibrate, HandDots, LaserJob};
use fslcal::laser::target::TargetArg;
use fslcal_core::{LaserLine, Vec3};
use std::sync::OnceLock;

/// 12 photos, murky water with glints: the laser fit's and validation's set.
fn photos() -> &'static SceneSet {
    static SET: OnceLock<SceneSet> = OnceLock::new();
    SET.get_or_init(|| slate_set("slate-murky", fsl_laser(), (0.45, 2.2), 12, 3, Water::Murky, 2))
}

fn slate_target() -> fslcal::laser::target::Target {
    TargetArg::Slate(example_slate_path()).load().expect("the example slate")
}

#[test]
fn slate_poses_match_the_truth_with_inliers_reported() {
    let set = photos();
    let target = slate_target();
    fslcal::vision::use_single_threaded_opencv();
    let centre = Vec3::new(0.15, 0.11, 0.0);
    let (mut worst_centre_mm, mut worst_normal_deg, mut least_inliers) = (0.0f64, 0.0f64, usize::MAX);
    for (p, truth) in set.photos.iter().zip(&set.truths) {
        let located = fslcal::laser::target::locate_target(&target, &tg6_camera(), p)
            .expect("right size")
            .unwrap_or_else(|why| panic!("{}: {why}", p.display()));
        let pose = truth.t_cam_target.unwrap();
        let e = (located.pose.to_camera(&centre) - pose.apply(&centre)).norm() * 1e3;
        let n = located.pose.rotation.column(2).angle(&pose.normal()).to_degrees();
        let inliers = located.inliers.expect("a slate reports inliers");
        eprintln!(
            "{}: {:.2} m, {inliers} inliers, centre {e:.2} mm, normal {n:.3} deg",
            p.display(),
            pose.apply(&centre).z
        );
        worst_centre_mm = worst_centre_mm.max(e / pose.apply(&centre).z);
        worst_normal_deg = worst_normal_deg.max(n);
        least_inliers = least_inliers.min(inliers);
    }
    eprintln!("slate poses: worst centre error {worst_centre_mm:.2} mm per m of distance, worst normal {worst_normal_deg:.2} deg, fewest inliers {least_inliers}");
    assert!(worst_centre_mm < 6.0 && worst_normal_deg < 3.0 && least_inliers >= 30);
}

#[test]
fn a_photo_without_the_slate_is_refused_with_the_reason() {
    let set = common::render_set("slate-none", &[common::no_board_spec(5)]);
    let r = fslcal::laser::target::locate_target(&slate_target(), &tg6_camera(), &set.photos[0]).expect("right size");
    let why = r.err().expect("no slate in the photo");
    assert!(why.starts_with("no slate found") || why.starts_with("weak slate match"), "{why}");
}

fn laser_fit(set: &SceneSet) -> fslcal::laser::pipeline::LaserCalibration {
    let job = LaserJob {
        camera: tg6_camera(),
        target: slate_target(),
        method: Method::Reprojection,
        gates: Gates::default(),
        detector: DotDetectorParams::default(),
        hand_dots: HandDots::default(),
    };
    calibrate(&job, &set.photos, &|| {}).expect("slate calibration")
}

#[test]
fn laser_fit_from_slate_photos_meets_the_accuracy_targets() {
    let set = photos();
    let cal = laser_fit(set);
    for p in &cal.photos {
        eprintln!("  {} {} {:?} inliers {:?}", p.file, p.status, p.reason, p.target_inliers);
    }
    let truth = fsl_laser();
    let dir = angle_deg(&cal.fit.laser.direction, &truth.direction);
    let origin_mm = (cal.fit.laser.origin() - truth.origin()).norm() * 1e3;
    eprintln!(
        "slate laser fit: {} of {} used, direction error {dir:.4} deg, origin error {origin_mm:.3} mm",
        cal.fit.used,
        set.photos.len()
    );
    assert!(cal.accepted(), "gates: {:?}", cal.gates);
    assert!(dir <= 0.1, "direction error {dir:.4} deg");
    assert!(origin_mm <= 5.0, "origin error {origin_mm:.3} mm");
}

/// The slate fit's calibration: origin 0.1 mm and slope 3e-5 1-sigma per axis.
fn calibration(laser: LaserLine) -> Calibration {
    common::tg6_calibration(laser, 1e-8, 1e-9)
}

/// The laser turned by `deg` within the plane of the camera centre and the beam: the error
/// that changes the scale with range.
fn turned_in_plane(l: &LaserLine, deg: f64) -> LaserLine {
    let axis = nalgebra::Unit::new_normalize(l.origin().cross(&l.dir()));
    let d = nalgebra::Rotation3::from_axis_angle(&axis, deg.to_radians()) * l.dir();
    LaserLine::from_point_direction(l.origin(), d).unwrap()
}

#[test]
fn validation_passes_a_right_calibration_and_fails_a_laser_off_by_half_a_degree() {
    let set = photos();
    let slate = example_slate();
    let job = |laser: LaserLine, rule: LengthRule| ValidationJob {
        cal: calibration(laser),
        target: slate_target(),
        length_name: None,
        rule,
        tolerance_pct: 3.0,
    };
    let right = validate(&job(fsl_laser(), LengthRule::TiltedPlane), &set.photos, &|| {}).unwrap();
    let worst = right.photos.iter().filter_map(|p| p.error_pct).fold(0.0f64, |a, e| a.max(e.abs()));
    let measured = right.photos.iter().filter(|p| p.error_pct.is_some()).count();
    eprintln!(
        "validate, right calibration: {measured} photos measured, worst error {worst:.3}%, slope {:?} %/m, pass {}",
        right.slope_pct_per_m, right.pass
    );
    for p in &right.photos {
        eprintln!("  {} {:?} {:?} {:?}", p.file, p.distance_m, p.error_pct, p.reason);
    }
    assert!(measured >= 6, "only {measured} of 12 photos measured");
    assert!(worst <= 1.0, "worst length error {worst:.3}% with the right calibration");
    assert!(right.pass);
    assert_eq!(slate.length(None).unwrap().name, "diagonal");

    let wrong =
        validate(&job(turned_in_plane(&fsl_laser(), 0.5), LengthRule::TiltedPlane), &set.photos, &|| {}).unwrap();
    let failed = wrong.photos.iter().filter(|p| p.pass == Some(false)).count();
    eprintln!(
        "validate, laser off by 0.5 deg: {failed} photos fail, slope {:?} %/m, trend fail {}, pass {}",
        wrong.slope_pct_per_m, wrong.trend_fails, wrong.pass
    );
    assert!(!wrong.pass && wrong.trend_fails);
}
