//! The calibration's second look (a more sensitive search where the first fit expects the
//! dot) must not take noise for a dot too faint to see. Tuning calibration seed 12 at the
//! bench's 4000x3000 has two such photos (12 and 13: dots of 4 and 8 levels, below
//! visibility): the second look found blobs 2.3 and 2.8 px from them, scoring 6-8 colour
//! sigmas, and both were used in the fit. Every dot the fit uses must be within 2 px of the
//! truth, and the visible dots the second look finds on this set must still be used.

mod common;

use calib_targets::variety::{Kind, VarietySet};
use fslcal::laser::fit::Method;
use fslcal::laser::pipeline::{calibrate, DotSource, PhotoStatus};

#[test]
fn the_second_look_takes_no_noise_for_a_dot_too_faint_to_see() {
    let dir = tempfile::tempdir().expect("temp dir");
    let set = VarietySet::plan(Kind::Calibration, 12, None, 4000).expect("plan");
    let photos = set.write(dir.path(), &mut |_| {}).expect("render");
    let job = common::board_job(&dir.path().join("camera.yml"), Method::Reprojection);
    let cal = calibrate(&job, &photos, &|| {}).expect("the set calibrates");
    let (mut used, mut second_look) = (0, 0);
    for (i, report) in cal.photos.iter().enumerate() {
        eprintln!("{}: {} ({:?})", report.file, report.status_text(), report.dot_source);
        common::assert_used_dot_is_right(report, &common::variety_truth(&photos[i]));
        if report.status != PhotoStatus::Used {
            continue;
        }
        used += 1;
        second_look += usize::from(report.dot_source == Some(DotSource::DetectedNearPrediction));
    }
    // Today: 9 used, one of them (photo 08, a visible dot at 2.65 m) found by the second look.
    assert!(used >= 9 && second_look >= 1, "{used} used, {second_look} of them by the second look");
}
