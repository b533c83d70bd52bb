//! Choosing each calibration photo's dot jointly: one candidate or none per photo, so that
//! the chosen dots lie on one 3D line, before the robust fit sees them.
//!
//! The strongest blob of a photo is often not the dot (a glint, the laser's reflection, tape
//! on the board's margin); what is true of every real dot is that it lies on the laser. A
//! RANSAC over pairs of photos and their candidates proposes lines; the line that explains
//! the most photos, then the most colour evidence, wins. A photo gets the candidate the line
//! passes closest to, when it is within the gate and no rival is nearly as close (then it is
//! ambiguous and withheld); a photo the line misses gets none, unless its best candidate is
//! so strong a dot that leaving it out would hide a laser that moved: that one goes to the
//! fit as it is, to be named an outlier there.
//!
//! A proposed line must also be one the rig can hold: its origin (where it crosses the
//! camera's z = 0 plane) within the unit's plausible baseline, widened for the error of a
//! line through two dots. Glints and algae line up by chance; a chance line through blobs
//! at 0.9, 1.8 and 3.8 m started half a metre below the camera and outvoted the dots' own
//! line (tuning calibration seed 9), which the fit then refused on its baseline gate.

use crate::dot::candidates::DotCandidate;
use crate::laser::fit::dot_point;
use fslcal_core::{CameraModel, LaserLine, Plane, Vec2};

/// Candidates per photo the consensus looks at, best colour score first. A scene's sun
/// flecks and algae on and around the board outscore a far dot: on tuning calibration seed 7
/// photo 7 the dot at 3.3 m (colour score 21, 0.3 px from the line the other photos agree
/// on) ranked 7th behind six larger blobs and was never looked at. From 6 to 10: on the
/// tuning calibration seeds 0-31 (356 photos with a visible dot) that dot found, no other
/// answer changed.
const CANDIDATES_PER_PHOTO: usize = 10;

/// A line through two dots may start this much nearer or farther (as a factor of the
/// baseline range's ends) than the fit's gate allows: two dots 0.2 m apart, each a few
/// pixels off, move the extrapolated origin by centimetres, never by the tens of
/// centimetres a chance line through impostors is off.
const BASELINE_SLACK: (f64, f64) = (0.5, 1.5);

/// A candidate this many colour sigmas strong is a dot whatever the line says: off the
/// consensus, it is evidence that the laser moved, not noise to drop.
pub const STRONG_COLOUR_SIGMAS: f64 = 60.0;

/// A rival candidate within this factor of the chosen one's distance to the line, or within
/// half the gate, makes the photo ambiguous: a line through two photos' dots is uncertain
/// by a few pixels, so two blobs that close to it are both on it.
const RIVAL_RATIO: f64 = 2.0;

/// One photo's input: its target's plane and its candidates.
pub struct PhotoCandidates<'a> {
    pub plane: Plane,
    pub candidates: &'a [DotCandidate],
}

/// What the consensus decided for one photo.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Choice {
    /// Candidate `index` lies on the consensus line, `offset_px` from its image.
    OnLine { index: usize, offset_px: f64 },
    /// Two candidates lie on the line's image within the gate, too close to tell apart.
    Ambiguous { first: usize, second: usize },
    /// The line misses every candidate; the best one is strong enough to be a dot and lies
    /// on a second line with others like it (kept for the fit to judge).
    StrongOffLine { index: usize, offset_px: f64 },
    /// No candidate near the line, and none strong on a second line: no usable dot.
    None,
    /// The photo had no candidates.
    Empty,
}

/// Candidate indices of a photo, best colour score first, at most [`CANDIDATES_PER_PHOTO`].
fn ranked(c: &[DotCandidate]) -> Vec<usize> {
    let mut idx: Vec<usize> = (0..c.len()).collect();
    idx.sort_by(|&a, &b| c[b].colour_score.total_cmp(&c[a].colour_score));
    idx.truncate(CANDIDATES_PER_PHOTO);
    idx
}

/// What the consensus may assume of the laser and how close a dot must come to it.
#[derive(Clone, Copy, Debug)]
pub struct LinePrior {
    /// How far a chosen dot may lie from the line's image (before the fit refines the
    /// line), pixels.
    pub gate_px: f64,
    /// The unit's plausible camera-to-laser baseline, metres (the fit's gate).
    pub baseline_range_m: (f64, f64),
}

impl LinePrior {
    /// Whether a line through two dots can be the rig's laser.
    fn holds(&self, line: &LaserLine) -> bool {
        let (lo, hi) = self.baseline_range_m;
        (lo * BASELINE_SLACK.0..=hi * BASELINE_SLACK.1).contains(&line.baseline_m())
    }
}

/// Each photo's choice under the line that the most photos agree with. `None` when fewer
/// than `min_photos` photos agree on any line the rig can hold.
pub fn choose(
    camera: &CameraModel,
    photos: &[PhotoCandidates],
    prior: &LinePrior,
    min_photos: usize,
) -> Option<Vec<Choice>> {
    let ranks: Vec<Vec<usize>> = photos.iter().map(|p| ranked(p.candidates)).collect();
    let (n, line) = best_line(camera, photos, &ranks, prior)?;
    if n < min_photos {
        return None;
    }
    let mut choices: Vec<Choice> =
        photos.iter().zip(&ranks).map(|(p, r)| choice(camera, p, r, &line, prior.gate_px)).collect();
    keep_strong_only_on_a_second_line(camera, photos, &mut choices, prior);
    Some(choices)
}

/// Strong blobs off the consensus line are kept for the fit only where they lie on a line
/// of their own through at least [`SECOND_LINE_PHOTOS`] photos: that is a laser that moved
/// during the session, and the fit must see it to refuse. Scattered strong blobs (sun
/// flecks, glints, bright algae) lie on no line; sent to the fit, four of them made it
/// refuse a set whose five dots were right (tuning calibration seed 1).
fn keep_strong_only_on_a_second_line(
    camera: &CameraModel,
    photos: &[PhotoCandidates],
    choices: &mut [Choice],
    prior: &LinePrior,
) {
    let strong: Vec<(usize, usize)> = choices
        .iter()
        .enumerate()
        .filter_map(|(i, c)| match c {
            Choice::StrongOffLine { index, .. } => Some((i, *index)),
            _ => None,
        })
        .collect();
    let alone: Vec<PhotoCandidates> = strong
        .iter()
        .map(|&(i, k)| PhotoCandidates { plane: photos[i].plane, candidates: &photos[i].candidates[k..=k] })
        .collect();
    let only_one = vec![vec![0usize]; alone.len()];
    let second = best_line(camera, &alone, &only_one, prior).filter(|(n, _)| *n >= SECOND_LINE_PHOTOS);
    for (&(i, _), p) in strong.iter().zip(&alone) {
        let on_second = second
            .as_ref()
            .and_then(|(_, line)| nearest(camera, p, &[0], line))
            .is_some_and(|(_, d)| d <= prior.gate_px);
        if !on_second {
            choices[i] = Choice::None;
        }
    }
}

/// Photos whose strong off-line blobs must share a line before they count as a moved laser:
/// any two blobs make a line, a third tests it.
const SECOND_LINE_PHOTOS: usize = 3;

/// The line through two photos' candidates that the rig can hold and the most photos
/// support (then the most colour evidence), and how many photos support it.
fn best_line(
    camera: &CameraModel,
    photos: &[PhotoCandidates],
    ranks: &[Vec<usize>],
    prior: &LinePrior,
) -> Option<(usize, LaserLine)> {
    let points: Vec<Vec<(usize, fslcal_core::Vec3)>> = photos
        .iter()
        .zip(ranks)
        .map(|(p, r)| {
            r.iter().filter_map(|&k| dot_point(camera, &p.plane, p.candidates[k].pixel).map(|q| (k, q))).collect()
        })
        .collect();
    let mut best: Option<(usize, f64, LaserLine)> = None;
    for i in 0..photos.len() {
        for j in i + 1..photos.len() {
            for (_, a) in &points[i] {
                for (_, b) in &points[j] {
                    if (a - b).norm() < 0.2 {
                        continue;
                    }
                    let Some(line) = LaserLine::from_point_direction(*a, b - a).filter(|l| prior.holds(l)) else {
                        continue;
                    };
                    let (n, evidence) = support(camera, photos, ranks, &line, prior.gate_px);
                    let better = best.as_ref().is_none_or(|(bn, be, _)| n > *bn || (n == *bn && evidence > *be));
                    if better {
                        best = Some((n, evidence, line));
                    }
                }
            }
        }
    }
    best.map(|(n, _, line)| (n, line))
}

/// Photos with a candidate within the gate of `line`'s image, and the colour evidence of
/// those candidates (the sum of their scores' logarithms, so a crowd of faint blobs does
/// not outvote a few clear dots).
fn support(
    camera: &CameraModel,
    photos: &[PhotoCandidates],
    ranks: &[Vec<usize>],
    line: &LaserLine,
    gate_px: f64,
) -> (usize, f64) {
    let mut n = 0;
    let mut evidence = 0.0;
    for (p, r) in photos.iter().zip(ranks) {
        if let Some((k, _)) = nearest(camera, p, r, line).filter(|(_, d)| *d <= gate_px) {
            n += 1;
            evidence += p.candidates[k].colour_score.max(1.0).ln();
        }
    }
    (n, evidence)
}

/// The candidate nearest where `line` meets the photo's target, and its distance, pixels.
fn nearest(camera: &CameraModel, p: &PhotoCandidates, rank: &[usize], line: &LaserLine) -> Option<(usize, f64)> {
    let q: Vec2 = camera.project(&line.hit(&p.plane)?)?;
    rank.iter().map(|&k| (k, (p.candidates[k].pixel - q).norm())).min_by(|a, b| a.1.total_cmp(&b.1))
}

fn choice(camera: &CameraModel, p: &PhotoCandidates, rank: &[usize], line: &LaserLine, gate_px: f64) -> Choice {
    if rank.is_empty() {
        return Choice::Empty;
    }
    let Some(q) = line.hit(&p.plane).and_then(|x| camera.project(&x)) else {
        return Choice::None;
    };
    let mut by_distance: Vec<(usize, f64)> = rank.iter().map(|&k| (k, (p.candidates[k].pixel - q).norm())).collect();
    by_distance.sort_by(|a, b| a.1.total_cmp(&b.1));
    let (k, d) = by_distance[0];
    if d <= gate_px {
        // A rival inside the gate and about as close: the line cannot tell them apart. Two
        // blobs of one dot (a core and a detached halo piece) lie within a dot's radius.
        if let Some(&(k2, d2)) = by_distance.get(1) {
            let same_dot = (p.candidates[k].pixel - p.candidates[k2].pixel).norm()
                <= p.candidates[k].radius_px.max(p.candidates[k2].radius_px) + 1.0;
            if d2 <= gate_px && d2 <= (RIVAL_RATIO * d).max(0.5 * gate_px) && !same_dot {
                return Choice::Ambiguous { first: k, second: k2 };
            }
        }
        return Choice::OnLine { index: k, offset_px: d };
    }
    let strongest = rank[0];
    if p.candidates[strongest].colour_score >= STRONG_COLOUR_SIGMAS {
        let offset_px = (p.candidates[strongest].pixel - q).norm();
        return Choice::StrongOffLine { index: strongest, offset_px };
    }
    Choice::None
}

#[cfg(test)]
mod tests {
    use super::*;
    use fslcal_core::Vec3;

    fn camera() -> CameraModel {
        CameraModel {
            width_px: 2000,
            height_px: 1500,
            fx_px: 1475.0,
            fy_px: 1475.0,
            cx_px: 1000.0,
            cy_px: 750.0,
            distortion: fslcal_core::Distortion::from_opencv([-0.15, 0.07, 0.0, 0.0, -0.01]),
        }
    }

    fn prior(gate_px: f64) -> LinePrior {
        LinePrior { gate_px, baseline_range_m: crate::laser::fit::Gates::default().baseline_range_m }
    }

    fn candidate(px: Vec2, score: f64) -> DotCandidate {
        DotCandidate {
            pixel: px,
            snr: score,
            peak_green: 20.0,
            radius_px: 3.0,
            core_radius_px: 2.0,
            saturated_core: false,
            saturated_px: 0,
            white_px: 0,
            lit_clipped_px: 0,
            colour_score: score,
            colour_angle_rad: 0.1,
            colour_angle_sigma_rad: 0.02,
            colour_texture_sigma_rad: 0.0,
            white_deficit_rad: 0.0,
            outline_roughness: None,
            split_from_blob: false,
            enclosed_by: None,
            excess_rgb: [10.0, 30.0, 10.0],
            judged_excess_rgb: [10.0, 30.0, 10.0],
            colour_filled_in: false,
        }
    }

    /// The rig's laser in these tests: 11 cm from the camera, turned a little across.
    fn rig_laser() -> LaserLine {
        LaserLine::from_point_direction(Vec3::new(0.1, -0.05, 0.0), Vec3::new(-0.02, 0.01, 1.0)).unwrap()
    }

    /// A board facing the camera at `z_m`.
    fn board_at(z_m: f64) -> Plane {
        Plane::through(Vec3::new(0.0, 0.0, z_m), Vec3::new(0.0, 0.0, -1.0))
    }

    /// Eight fronto-parallel boards from 0.6 to 4 m; in every photo a brighter impostor
    /// somewhere on the board, in one photo two blobs both on the line's image.
    #[test]
    fn the_dots_on_one_line_win_over_stronger_impostors() {
        let cam = camera();
        let truth = rig_laser();
        let mut cands: Vec<Vec<DotCandidate>> = Vec::new();
        let mut planes = Vec::new();
        for i in 0..8 {
            let z = 0.6 + 0.5 * i as f64;
            let plane = board_at(z);
            let dot = cam.project(&truth.hit(&plane).unwrap()).unwrap();
            let mut c = vec![candidate(Vec2::new(300.0 + 90.0 * i as f64, 1200.0 - 70.0 * i as f64), 200.0)];
            c.push(candidate(dot + Vec2::new(0.3, -0.2), 15.0));
            if i == 5 {
                c.push(candidate(dot + Vec2::new(4.0, 3.0), 12.0));
            }
            cands.push(c);
            planes.push(plane);
        }
        let photos: Vec<PhotoCandidates> =
            planes.iter().zip(&cands).map(|(p, c)| PhotoCandidates { plane: *p, candidates: c }).collect();
        let choices = choose(&cam, &photos, &prior(12.0), 3).expect("seven photos agree");
        for (i, ch) in choices.iter().enumerate() {
            match (i, ch) {
                (5, Choice::Ambiguous { .. }) => {}
                (5, other) => panic!("photo 5 has two blobs on the line: {other:?}"),
                (_, Choice::StrongOffLine { .. }) | (_, Choice::None) | (_, Choice::Empty) => {
                    panic!("photo {i}: {ch:?}")
                }
                (_, Choice::OnLine { index, offset_px }) => {
                    assert_eq!(*index, 1, "photo {i}");
                    assert!(*offset_px < 3.0, "photo {i}: {offset_px}");
                }
                (_, Choice::Ambiguous { .. }) => panic!("photo {i}: {ch:?}"),
            }
        }
    }

    /// Six boards, each with its dot; on the farthest, six stronger blobs off the line (sun
    /// flecks and algae on the board) outrank the dot. It is still looked at and chosen.
    #[test]
    fn a_far_dot_behind_six_stronger_blobs_is_still_looked_at() {
        let cam = camera();
        let truth = rig_laser();
        let planes: Vec<Plane> = (0..6).map(|i| board_at(0.6 + 0.6 * i as f64)).collect();
        let cands: Vec<Vec<DotCandidate>> = planes
            .iter()
            .enumerate()
            .map(|(i, plane)| {
                let dot = cam.project(&truth.hit(plane).unwrap()).unwrap();
                let mut c: Vec<DotCandidate> = Vec::new();
                if i == 5 {
                    c.extend((0..6).map(|k| candidate(Vec2::new(200.0 + 150.0 * k as f64, 300.0), 40.0 + k as f64)));
                }
                c.push(candidate(dot + Vec2::new(0.2, 0.1), 21.0));
                c
            })
            .collect();
        let photos: Vec<PhotoCandidates> =
            planes.iter().zip(&cands).map(|(p, c)| PhotoCandidates { plane: *p, candidates: c }).collect();
        let choices = choose(&cam, &photos, &prior(12.0), 3).expect("six photos agree");
        assert!(matches!(choices[5], Choice::OnLine { index: 6, .. }), "{:?}", choices[5]);
    }

    /// Six photos' dots on the laser; three more photos with only a strong blob each off
    /// it. Scattered, the blobs are dropped; on a line of their own (the laser moved after
    /// the sixth photo), they go to the fit for it to refuse.
    #[test]
    fn strong_blobs_off_the_line_count_only_when_they_share_a_line() {
        let cam = camera();
        let before = rig_laser();
        let after = LaserLine::from_point_direction(Vec3::new(0.1, -0.05, 0.0), Vec3::new(0.15, 0.1, 1.0)).unwrap();
        let plane = |i: usize| board_at(0.6 + 0.45 * i as f64);
        let run = |moved: bool| {
            let planes: Vec<Plane> = (0..9).map(plane).collect();
            let cands: Vec<Vec<DotCandidate>> = planes
                .iter()
                .enumerate()
                .map(|(i, pl)| {
                    let px = if i < 6 {
                        cam.project(&before.hit(pl).unwrap()).unwrap()
                    } else if moved {
                        cam.project(&after.hit(pl).unwrap()).unwrap()
                    } else {
                        Vec2::new(200.0 + 400.0 * (i - 6) as f64, 300.0 + 250.0 * ((i * 7) % 4) as f64)
                    };
                    vec![candidate(px, if i < 6 { 20.0 } else { 2.0 * STRONG_COLOUR_SIGMAS })]
                })
                .collect();
            let photos: Vec<PhotoCandidates> =
                planes.iter().zip(&cands).map(|(p, c)| PhotoCandidates { plane: *p, candidates: c }).collect();
            choose(&cam, &photos, &prior(12.0), 3).expect("six photos agree")
        };
        for (moved, want_strong) in [(false, 0), (true, 3)] {
            let choices = run(moved);
            let on_line = choices[..6].iter().filter(|c| matches!(c, Choice::OnLine { .. })).count();
            let strong = choices[6..].iter().filter(|c| matches!(c, Choice::StrongOffLine { .. })).count();
            let none = choices[6..].iter().filter(|c| matches!(c, Choice::None)).count();
            assert_eq!((on_line, strong, none), (6, want_strong, 3 - want_strong), "moved {moved}: {choices:?}");
        }
    }

    /// Three photos' dots on the laser, and in three other photos bright blobs that happen to
    /// line up on a line starting half a metre below the camera: as many photos, more colour
    /// evidence. Only the rig's baseline tells them apart.
    #[test]
    fn a_chance_line_the_rig_cannot_hold_loses_to_the_dots() {
        let cam = camera();
        let laser = rig_laser();
        let chance = LaserLine::from_point_direction(Vec3::new(-0.1, 0.5, 0.0), Vec3::new(0.06, -0.1, 1.0)).unwrap();
        assert!(chance.baseline_m() > 0.5);
        let planes: Vec<Plane> = (0..6).map(|i| board_at(0.6 + 0.6 * i as f64)).collect();
        let cands: Vec<Vec<DotCandidate>> = planes
            .iter()
            .enumerate()
            .map(|(i, pl)| {
                let (line, score) = if i % 2 == 0 { (&laser, 10.0) } else { (&chance, 100.0) };
                vec![candidate(cam.project(&line.hit(pl).unwrap()).unwrap(), score)]
            })
            .collect();
        let photos: Vec<PhotoCandidates> =
            planes.iter().zip(&cands).map(|(p, c)| PhotoCandidates { plane: *p, candidates: c }).collect();
        let on_line = |prior: &LinePrior| -> Vec<usize> {
            let choices = choose(&cam, &photos, prior, 3).expect("three photos agree");
            (0..6).filter(|&i| matches!(choices[i], Choice::OnLine { .. })).collect()
        };
        assert_eq!(on_line(&prior(12.0)), vec![0, 2, 4]);
        let any_baseline = LinePrior { gate_px: 12.0, baseline_range_m: (0.0, f64::INFINITY) };
        assert_eq!(on_line(&any_baseline), vec![1, 3, 5], "without the rig's baseline the chance line wins");
    }

    #[test]
    fn too_few_photos_on_any_line_is_no_consensus() {
        let cam = camera();
        let planes: Vec<Plane> = (0..3).map(|i| board_at(1.0 + i as f64)).collect();
        let cands = [
            vec![candidate(Vec2::new(100.0, 100.0), 20.0)],
            vec![candidate(Vec2::new(1900.0, 200.0), 20.0)],
            vec![candidate(Vec2::new(500.0, 1400.0), 20.0)],
        ];
        let photos: Vec<PhotoCandidates> =
            planes.iter().zip(&cands).map(|(p, c)| PhotoCandidates { plane: *p, candidates: c }).collect();
        assert!(choose(&cam, &photos, &prior(8.0), 3).is_none());
    }
}
