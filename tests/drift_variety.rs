//! `fslcal check` on randomised target-less photos (fish and reef in any water, glints,
//! algae, the laser's reflection, laser-off photos; calib-targets `variety`, 1000x750 to
//! keep CI cheap): on 100 photos of calibrated lasers no photo is flagged, and a laser
//! knocked by 0.4 deg out of the camera-beam plane is flagged, with the implied change of
//! direction from the sure dots within 20% of the knock. The knock is the calibration's:
//! photos of the true laser checked against a calibration turned by -0.4 deg are photos of
//! a laser turned by 0.4 deg from the calibrated one.

use calib_targets::variety::{Kind, PhotoTruth, VarietySet};
use fslcal::calibration::drift::{check, turned, DriftCheck};
use fslcal::calibration::Calibration;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// Tuning seeds (under 1 000 000, docs/scene-variety.md): five sets of 20 photos.
const SEEDS: [u64; 5] = [101, 102, 103, 104, 105];
const WIDTH_PX: u32 = 1000;

struct Set {
    photos: Vec<PathBuf>,
    truths: Vec<PhotoTruth>,
    cal: Calibration,
}

fn sets() -> &'static Vec<Set> {
    static SETS: OnceLock<Vec<Set>> = OnceLock::new();
    SETS.get_or_init(|| SEEDS.iter().map(|&s| render(s)).collect())
}

fn render(seed: u64) -> Set {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("drift-variety-{seed}"));
    let _ = std::fs::remove_dir_all(&dir);
    let set = VarietySet::plan(Kind::Targetless, seed, None, WIDTH_PX).expect("plan");
    let photos = set.write(&dir, &mut |_| {}).expect("render");
    let truths = photos
        .iter()
        .map(|p| {
            let t = std::fs::read(p.with_extension("truth.json")).expect("truth");
            serde_json::from_slice(&t).expect("truth parses")
        })
        .collect();
    let cal = fslcal::calibration::load(&dir.join("cal.json")).expect("the set's calibration");
    Set { photos, truths, cal }
}

/// Sure dots within 2 px of the truth, and those elsewhere (a wrong dot or none there).
fn tally(r: &DriftCheck, truths: &[PhotoTruth]) -> (usize, usize) {
    let mut right = 0;
    let mut wrong = 0;
    for (p, t) in r.photos.iter().zip(truths) {
        let Some(d) = p.dot_px.filter(|_| p.explained_sigma_px.is_some()) else { continue };
        match &t.dot {
            Some(truth) if (d[0] - truth.pixel[0]).hypot(d[1] - truth.pixel[1]) <= 2.0 => right += 1,
            _ => wrong += 1,
        }
    }
    (right, wrong)
}

#[test]
fn a_hundred_photos_of_calibrated_lasers_raise_no_flag() {
    let (mut photos, mut sure, mut flagged, mut right, mut wrong) = (0, 0, 0, 0, 0);
    for (set, seed) in sets().iter().zip(SEEDS) {
        let r = check(&set.cal, &set.photos, &|| {}).expect("check");
        let (ok, bad) = tally(&r, &set.truths);
        let f = r.photos.iter().filter(|p| p.flag).count();
        eprintln!(
            "seed {seed}: {} photos, {} sure dots ({ok} right, {bad} wrong), {f} flagged, implied change {:.3} deg",
            r.photos.len(),
            r.sure_dots,
            r.implied_direction_change_deg.unwrap_or(f64::NAN)
        );
        assert!(!r.drifted, "seed {seed}: a calibrated laser called drifted");
        photos += r.photos.len();
        sure += r.sure_dots;
        flagged += f;
        right += ok;
        wrong += bad;
    }
    eprintln!("calibrated lasers: {photos} photos, {sure} sure dots ({right} right, {wrong} wrong), {flagged} flagged");
    assert_eq!(photos, 100);
    assert_eq!(flagged, 0, "no photo of a calibrated laser may be flagged");
    assert!(sure >= 40, "only {sure} sure dots in 100 photos");
}

#[test]
fn a_laser_knocked_by_0_4_deg_is_flagged_with_the_implied_change() {
    let knock_deg: f64 = 0.4;
    for (set, seed) in sets().iter().zip(SEEDS).take(2) {
        let mut cal = set.cal.clone();
        cal.laser = turned(&set.cal.laser, -knock_deg.to_radians()).expect("a turnable laser");
        let r = check(&cal, &set.photos, &|| {}).expect("check");
        let flagged = r.photos.iter().filter(|p| p.flag).count();
        let (right, wrong) = tally(&r, &set.truths);
        let implied = r.implied_direction_change_deg.expect("sure dots");
        eprintln!(
            "seed {seed} knocked {knock_deg} deg: {} sure dots ({right} right, {wrong} wrong), {flagged} flagged, drifted {}, implied change {implied:.3} deg",
            r.sure_dots, r.drifted
        );
        assert!(r.drifted, "seed {seed}: a knocked laser not called drifted");
        assert!((implied - knock_deg).abs() <= 0.2 * knock_deg, "seed {seed}: implied {implied:.3} deg");
    }
}
