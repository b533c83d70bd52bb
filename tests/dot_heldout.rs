//! The calibration's dot choice on a held-out randomised set (issue 14, docs/scene-variety.md):
//! a seed nobody tuned on, rendered at 3000x2250 to keep CI short (at 2000x1500 the board
//! finder loses most boards beyond 2 m). Every used dot must be
//! the right one (within 2 px of the truth), and most photos whose board was found and whose
//! dot is visible must use it. Photos whose board the finder loses at this size are not the
//! dot search's to answer.

mod common;

use calib_targets::variety::{Kind, VarietySet, HELD_OUT_FIRST_SEED};
use fslcal::laser::fit::Method;
use fslcal::laser::pipeline::{calibrate, PhotoStatus, SkipReason};

/// Held-out seeds of this test: after the bench's default ones (1 000 000 and 1 000 001).
const SEED: u64 = HELD_OUT_FIRST_SEED + 8;

/// Share of the photos with a found board and a visible dot whose right dot is used: a floor
/// under today's 8 of 9 on this seed (rendered through its unit's tone curve since stop 62),
/// so a regression of two photos fails. The target is 95% (issue 14); this set does
/// not meet it yet (one visible dot missed).
const MIN_RIGHT_SHARE: f64 = 0.75;

#[test]
fn held_out_calibration_uses_only_right_dots() {
    let dir = tempfile::tempdir().expect("temp dir");
    let set = VarietySet::plan(Kind::Calibration, SEED, Some(10), 3000).expect("plan");
    let photos = set.write(dir.path(), &mut |_| {}).expect("render");
    let job = common::board_job(&dir.path().join("camera.yml"), Method::Reprojection);
    let cal = calibrate(&job, &photos, &|| {}).expect("the set calibrates");
    let (mut eligible, mut right) = (0, 0);
    for (i, report) in cal.photos.iter().enumerate() {
        let truth = common::variety_truth(&photos[i]);
        let board_found = !matches!(report.reason.as_ref().and_then(|r| r.kind()), Some(SkipReason::Target(_)));
        common::assert_used_dot_is_right(report, &truth);
        if board_found && truth.visible_dot().is_some() {
            eligible += 1;
            right += usize::from(report.status == PhotoStatus::Used);
        }
        eprintln!(
            "{}: {} (board found {board_found}, visible {})",
            report.file,
            report.status_text(),
            truth.visible_dot().is_some()
        );
    }
    eprintln!("right dot used in {right} of {eligible} photos with a board and a visible dot");
    assert!(eligible >= 4, "only {eligible} photos with a board and a visible dot: the set tests nothing");
    assert!(right as f64 >= MIN_RIGHT_SHARE * eligible as f64, "right dot in {right} of {eligible}");
}
