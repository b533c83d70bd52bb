//! `fslcal laser` learns a unit's camera tone curve from its calibration photos (issue 14,
//! docs/scene-variety.md): a randomised calibration set whose unit's JPEGs pass a strong
//! curve is read through one close to it, and the same set rendered linear stays linear.
//! Tuning calibration seed 3016 (gamma 2.04): read as linear its dots' colours spread 9.5
//! degrees; through the kept curve, 4.1.

mod common;

use calib_targets::variety::{Kind, VarietySet};
use fslcal::laser::fit::Method;
use fslcal::laser::pipeline::{calibrate, LaserCalibration, ToneRetry};

const SEED: u64 = 3016;

/// `fslcal laser`'s reading of `set` as rendered, with what it kept printed and every used
/// dot checked against the truth.
fn calibrated(set: &VarietySet, what: &str) -> LaserCalibration {
    let dir = tempfile::tempdir().expect("temp dir");
    let photos = set.write(dir.path(), &mut |_| {}).expect("render");
    let job = common::board_job(&dir.path().join("camera.yml"), Method::Reprojection);
    let cal = calibrate(&job, &photos, &|| {}).expect("the set calibrates");
    if let Some(colour) = &cal.laser_colour {
        eprintln!(
            "{what}: kept {:.2}, spread {:.1} deg, {:?}",
            colour.tone.gamma(),
            colour.spread_rad.to_degrees(),
            cal.tone_retry
        );
    }
    for (report, photo) in cal.photos.iter().zip(&photos) {
        common::assert_used_dot_is_right(report, &common::variety_truth(photo));
    }
    cal
}

#[test]
fn a_strong_tone_curve_is_learned_and_a_linear_camera_stays_linear() {
    let set = VarietySet::plan(Kind::Calibration, SEED, Some(10), 4000).expect("plan");
    let truth = set.unit.tone_gamma;
    assert!(truth > 1.9, "seed {SEED} draws gamma {truth:.2}: the test needs a strong curve");

    let cal = calibrated(&set, &format!("true gamma {truth:.2}"));
    let colour = cal.laser_colour.expect("a learned colour");
    let Some(ToneRetry::LinearScattered { spread_rad }) = cal.tone_retry else {
        panic!("the linear reading was kept or refused: {:?}", cal.tone_retry)
    };
    assert!((colour.tone.gamma() - truth).abs() <= 0.4, "kept gamma {:.2} for a true {truth:.2}", colour.tone.gamma());
    assert!(
        colour.spread_rad < 0.6 * spread_rad,
        "spread {:.3} rad through the curve, {spread_rad:.3} linear",
        colour.spread_rad
    );

    let linear = calibrated(&set.with_tone_gamma(1.0), "linear");
    let colour = linear.laser_colour.expect("a learned colour");
    assert!(
        colour.tone.table().is_none() && linear.tone_retry.is_none(),
        "a linear camera read through gamma {:.2}",
        colour.tone.gamma()
    );
}
