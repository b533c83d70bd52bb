//! The calibration's second look (a more sensitive search where the first fit expects the
//! dot) must not take noise for a dot too faint to see. Tuning calibration seed 12 at the
//! bench's 4000x3000 has two such photos (12 and 13: dots of 4 and 8 levels, below
//! visibility): the second look found blobs 2.3 and 2.8 px from them, scoring 6-8 colour
//! sigmas, and both were used in the fit. Every dot the fit uses must be within 2 px of the
//! truth, and the visible dots the second look finds on this set must still be used.

use calib_targets::variety::{Kind, PhotoTruth, VarietySet};
use calib_targets::Checkerboard;
use fslcal::camera::opencv_yaml;
use fslcal::dot::candidates::DotDetectorParams;
use fslcal::laser::fit::{Gates, Method};
use fslcal::laser::pipeline::{calibrate, DotSource, HandDots, LaserJob, PhotoStatus};

#[test]
fn the_second_look_takes_no_noise_for_a_dot_too_faint_to_see() {
    let dir = tempfile::tempdir().expect("temp dir");
    let set = VarietySet::plan(Kind::Calibration, 12, None, 4000).expect("plan");
    let photos = set.write(dir.path(), &mut |_| {}).expect("render");
    let (camera, _) = opencv_yaml::read(&dir.path().join("camera.yml")).expect("camera file");
    let job = LaserJob {
        camera,
        target: Checkerboard::fishsense().into(),
        method: Method::Reprojection,
        gates: Gates::default(),
        detector: DotDetectorParams::default(),
        hand_dots: HandDots::default(),
    };
    let cal = calibrate(&job, &photos, &|| {}).expect("the set calibrates");
    let (mut used, mut second_look) = (0, 0);
    for (i, report) in cal.photos.iter().enumerate() {
        let text = std::fs::read_to_string(photos[i].with_extension("truth.json")).expect("truth file");
        let truth: PhotoTruth = serde_json::from_str(&text).expect("truth parses");
        eprintln!("{}: {} ({:?})", report.file, report.status_text(), report.dot_source);
        if report.status != PhotoStatus::Used {
            continue;
        }
        let dot = report.dot_px.expect("a used photo has a dot");
        let t = truth.dot.as_ref().unwrap_or_else(|| panic!("{}: used, but no dot in the truth", report.file));
        let err = (dot[0] - t.pixel[0]).hypot(dot[1] - t.pixel[1]);
        assert!(err <= 2.0, "{}: a wrong dot used in the fit, {err:.1} px from the truth", report.file);
        used += 1;
        second_look += usize::from(report.dot_source == Some(DotSource::DetectedNearPrediction));
    }
    // Today: 9 used, one of them (photo 08, a visible dot at 2.65 m) found by the second look.
    assert!(used >= 9 && second_look >= 1, "{used} used, {second_look} of them by the second look");
}
