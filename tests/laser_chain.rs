//! The laser chain end to end on rendered scenes with known truth: 4000x3000, 0.6-4.5 m, the
//! FishSense board, the true camera given.

mod common;

use calib_targets::scene::Water;
use common::{board_job, laser_set, render_set, SceneSet};
use fslcal::laser::fit::{angle_deg, FitError, Method};
use fslcal::laser::pipeline::{calibrate, HandDots, LaserCalibration, LaserError, LaserJob};
use fslcal_core::{LaserLine, Vec2};
use std::sync::OnceLock;

fn clean() -> &'static SceneSet {
    static SET: OnceLock<SceneSet> = OnceLock::new();
    SET.get_or_init(|| laser_set("laser-clean", 16, 11, Water::Clear, 0))
}

fn murky() -> &'static SceneSet {
    static SET: OnceLock<SceneSet> = OnceLock::new();
    SET.get_or_init(|| laser_set("laser-murky", 16, 23, Water::Murky, 3))
}

fn job(set: &SceneSet, method: Method) -> LaserJob {
    board_job(&set.camera_file, method)
}

fn run(set: &SceneSet, job: &LaserJob) -> LaserCalibration {
    calibrate(job, &set.photos, &|| {}).unwrap_or_else(|e| panic!("calibration failed: {e}"))
}

/// (direction error in degrees, origin error in mm) against the truth.
fn errors(fitted: &LaserLine, truth: &LaserLine) -> (f64, f64) {
    let dir = angle_deg(&fitted.direction, &truth.direction);
    let o = fitted.origin() - truth.origin();
    (dir, o.norm() * 1e3)
}

/// Every used dot within `tol_px` of its true pixel; returns the worst.
fn worst_dot_error(set: &SceneSet, cal: &LaserCalibration, tol_px: f64) -> f64 {
    let mut worst: f64 = 0.0;
    for (report, truth) in cal.photos.iter().zip(&set.truths) {
        if report.status != "used" {
            continue;
        }
        let dot = report.dot_px.expect("a used photo has a dot");
        let t = truth.dot.as_ref().unwrap_or_else(|| panic!("{}: used, but the truth has no dot", report.file));
        let e = (Vec2::new(dot[0], dot[1]) - Vec2::new(t.pixel[0], t.pixel[1])).norm();
        assert!(e <= tol_px, "{}: dot {:.2} px from truth (limit {tol_px})", report.file, e);
        worst = worst.max(e);
    }
    worst
}

/// Fits with the default method and prints the figures the closing note quotes: returns
/// the calibration and its direction (deg) and origin (mm) errors. Every used dot must be
/// within 2 px of the truth.
fn fit_and_measure(label: &str, set: &SceneSet) -> (LaserCalibration, f64, f64) {
    let cal = run(set, &job(set, Method::Reprojection));
    let (dir_deg, origin_mm) = errors(&cal.fit.laser, &set.truths[0].laser.expect("laser on"));
    let worst = worst_dot_error(set, &cal, 2.0);
    eprintln!(
        "{label}: {} used of {}, direction error {dir_deg:.4} deg, origin error {origin_mm:.3} mm, worst dot {worst:.2} px, rms {:.3} px",
        cal.fit.used,
        set.photos.len(),
        cal.fit.residual_rms_px
    );
    (cal, dir_deg, origin_mm)
}

#[test]
fn clean_water_meets_the_accuracy_targets() {
    let set = clean();
    let (cal, dir_deg, origin_mm) = fit_and_measure("clean", set);
    assert!(cal.accepted(), "gates: {:?}", cal.gates);
    assert!(cal.fit.used >= 14, "only {} of 16 clean photos used", cal.fit.used);
    assert!(dir_deg <= 0.02, "direction error {dir_deg:.4} deg");
    assert!(origin_mm <= 1.5, "origin error {origin_mm:.3} mm");
    // The reported uncertainty must be honest: the true error within 4 sigma of the origin.
    let c = cal.fit.covariance;
    let sigma_origin_mm = (c[0][0] + c[1][1]).sqrt() * 1e3;
    assert!(
        origin_mm <= 4.0 * sigma_origin_mm.max(0.05),
        "origin error {origin_mm:.3} mm vs 1-sigma {sigma_origin_mm:.3} mm"
    );
    let s = &cal.fit.distance_sigma_m;
    assert!(s[0].1 < s[1].1 && s[1].1 < s[2].1, "distance sigma must grow with distance: {s:?}");
}

#[test]
fn murky_water_with_glints_meets_the_accuracy_targets() {
    let set = murky();
    let (cal, dir_deg, origin_mm) = fit_and_measure("murky", set);
    for p in &cal.photos {
        eprintln!("  {} {} {:?}", p.file, p.status, p.reason);
    }
    assert!(cal.accepted(), "gates: {:?}", cal.gates);
    assert!(cal.fit.used >= 10, "only {} of 16 murky photos used", cal.fit.used);
    assert!(dir_deg <= 0.05, "direction error {dir_deg:.4} deg");
    assert!(origin_mm <= 3.0, "origin error {origin_mm:.3} mm");
}

#[test]
fn thesis_methods_agree_on_clean_data_and_suffer_from_an_outlier() {
    let set = clean();
    let truth = set.truths[0].laser.expect("laser on");
    let default = run(set, &job(set, Method::Reprojection));
    for method in [Method::GaussNewton, Method::Average] {
        let cal = run(set, &job(set, method));
        let (d, o) = errors(&cal.fit.laser, &default.fit.laser);
        eprintln!("clean: {method:?} differs from the default by {d:.4} deg, {o:.3} mm");
        assert!(d < 0.05 && o < 3.0, "{method:?} disagrees with the default on clean data: {d:.4} deg, {o:.3} mm");
    }

    // A mislabelled dot, 40 px off, as if clicked on the laser's reflection.
    let victim = set.truths.iter().position(|t| t.dot.as_ref().is_some_and(|d| d.depth_m > 2.0)).expect("a far dot");
    let t = set.truths[victim].dot.as_ref().expect("dot");
    let mut hand = HandDots::default();
    hand.insert(&set.photos[victim], Vec2::new(t.pixel[0] + 40.0, t.pixel[1] - 25.0));

    let mut robust_job = job(set, Method::Reprojection);
    robust_job.hand_dots = hand.clone();
    let robust = run(set, &robust_job);
    let (rd, ro) = errors(&robust.fit.laser, &truth);
    assert_eq!(robust.photos[victim].status, "skipped", "the mislabelled photo must be named an outlier");
    assert!(robust.photos[victim].reason.as_deref().unwrap_or("").starts_with("outlier"));
    assert_eq!(robust.outliers.0, 1);
    assert!(rd <= 0.02 && ro <= 1.5, "default with an outlier: {rd:.4} deg, {ro:.3} mm");
    for method in [Method::GaussNewton, Method::Average] {
        let mut j = job(set, method);
        j.hand_dots = hand.clone();
        let cal = run(set, &j);
        let (d, o) = errors(&cal.fit.laser, &truth);
        eprintln!("outlier: {method:?} {d:.4} deg, {o:.3} mm; default {rd:.4} deg, {ro:.3} mm");
        assert!(d > 3.0 * rd.max(0.002) || o > 3.0 * ro.max(0.1), "{method:?} should suffer from the outlier");
        assert!(!cal.accepted(), "the dot-offset gate must reject a thesis fit that kept an outlier");
    }
}

#[test]
fn photos_without_board_or_unreadable_are_skipped_with_a_reason() {
    let set = clean();
    let mut specs = vec![common::no_board_spec(5)];
    let extra = render_set("laser-no-board", &specs.split_off(0));
    let broken = extra.path().join("truncated.jpg");
    let bytes = std::fs::read(&set.photos[0]).unwrap();
    std::fs::write(&broken, &bytes[..bytes.len() / 3]).unwrap();
    let empty = extra.path().join("empty.jpg");
    std::fs::write(&empty, b"").unwrap();

    let mut photos = set.photos[..6].to_vec();
    photos.push(extra.photos[0].clone());
    photos.push(broken);
    photos.push(empty);
    let j = job(set, Method::Reprojection);
    let cal = calibrate(&j, &photos, &|| {}).expect("fit from the six good photos");
    let reasons: Vec<&str> = cal.photos[6..].iter().map(|p| p.reason.as_deref().unwrap_or("")).collect();
    eprintln!("reasons: {reasons:?}");
    assert!(cal.photos[6..].iter().all(|p| p.status == "skipped"));
    assert!(reasons[0].contains("no 14x10 checkerboard"), "{}", reasons[0]);
    assert!(reasons[1].contains("truncated JPEG"), "{}", reasons[1]);
    assert!(reasons[2].contains("unreadable") || reasons[2].contains("not a readable image"), "{}", reasons[2]);
    assert_eq!(cal.fit.used, 6);
}

#[test]
fn degenerate_input_is_refused_with_the_reason() {
    let set = clean();
    let j = job(set, Method::Reprojection);
    // Two photos: too few.
    match calibrate(&j, &set.photos[..2], &|| {}) {
        Err(LaserError::Fit { source: FitError::TooFewPhotos { usable: 2, needed: 3 }, .. }) => {}
        other => panic!("expected TooFewPhotos, got {:?}", other.map(|c| c.fit.used)),
    }
    // Three photos from within 0.4 m along the laser: the direction is unobservable. The
    // board slides along the laser, so the dot stays where it was on the board.
    let base = calib_targets::scene::laser_scene_set(16, 11, Water::Clear, 0).remove(4);
    let d = base.laser.expect("laser on").dir();
    let specs: Vec<_> = [-0.2, 0.0, 0.2]
        .iter()
        .map(|&shift| {
            let mut spec = base.clone();
            if let Some((_, pose)) = spec.board.as_mut() {
                for k in 0..3 {
                    pose.translation_m[k] += d[k] * shift;
                }
            }
            spec
        })
        .collect();
    let near = render_set("laser-one-distance", &specs);
    match calibrate(&j, &near.photos, &|| {}) {
        Err(LaserError::Fit { source: FitError::TooShortSpan { span_m, .. }, .. }) => assert!(span_m < 0.6),
        other => panic!("expected TooShortSpan, got {:?}", other.map(|c| c.fit.span_m)),
    }
    // A camera file for another image size.
    let mut small = j.clone();
    small.camera.width_px = 640;
    small.camera.height_px = 480;
    let err = calibrate(&small, &set.photos[..3], &|| {}).expect_err("size mismatch must be refused");
    assert!(err.to_string().contains("4000x3000") && err.to_string().contains("640x480"), "{err}");
}
