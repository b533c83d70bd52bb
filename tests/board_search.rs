//! The board search finds small, low-contrast boards and stays bounded (issue 17): a plainly
//! visible 13x9 board, small in the frame in green water, was missed by the reduced search
//! and then stalled a run. Photos of such boards in green and brown water, and far boards in
//! the randomised coastal and harbour water of `calib_targets::variety`, must be found with
//! their corners where the renderer put them; a photo without a board must be rejected.
//! (The time per photo is the speed bench's line "slowest ... small 13x9 boards".)

mod common;

use calib_targets::variety::look::WaterType;
use calib_targets::variety::{Kind, TargetTruth, VarietySet};
use common::tinted::{board_13x9, small_board_set, SmallBoard, Tint};
use fslcal::vision::{
    find_checkerboard, refine_corners, search_plan, CropDetector, CropImage, EncodedPhoto, SearchStep,
};
use fslcal_core::Vec2;
use rayon::prelude::*;
use std::path::{Path, PathBuf};

/// What the search made of one photo: the step that found the board and each refined
/// corner's distance from the truth, pixels, smallest first.
#[derive(Debug)]
struct Found {
    step: SearchStep,
    errors_px: Vec<f64>,
}

impl Found {
    fn worst_px(&self) -> f64 {
        *self.errors_px.last().unwrap()
    }

    fn median_px(&self) -> f64 {
        self.errors_px[self.errors_px.len() / 2]
    }

    fn beyond(&self, px: f64) -> usize {
        self.errors_px.iter().filter(|&&e| e > px).count()
    }
}

/// Searches `photo` for a `cols x rows` board and refines what it finds against `truth`
/// (inner corners in object-point order; the search may number them from the far end).
fn search(photo: &Path, cols: u32, rows: u32, truth: &[[f64; 2]]) -> Option<Found> {
    let encoded = EncodedPhoto::read(photo).unwrap();
    let decoded = encoded.decode().unwrap();
    let found = find_checkerboard(&decoded, photo, cols, rows).unwrap()?;
    let mut corners = found.corners_px;
    refine_corners(&decoded, &mut corners, cols, rows).unwrap();
    let errors = |order: &mut dyn Iterator<Item = &[f64; 2]>| {
        let mut e: Vec<f64> = corners.iter().zip(order).map(|(c, t)| (c - Vec2::new(t[0], t[1])).norm()).collect();
        e.sort_by(f64::total_cmp);
        e
    };
    let (direct, reversed) = (errors(&mut truth.iter()), errors(&mut truth.iter().rev()));
    let errors_px = if direct[direct.len() / 2] <= reversed[reversed.len() / 2] { direct } else { reversed };
    Some(Found { step: found.step, errors_px })
}

/// The bench's scenes: 13x9 boards of 30 mm squares at 3 and 4 m (squares of 22-30 px in a
/// 4000x3000 photo), seen through green or brown water at 30-35% transmission, and two
/// photos without a board.
fn tinted_scenes() -> Vec<SmallBoard> {
    let boards = [(Tint::Green, 3.0, 0.35), (Tint::Green, 4.0, 0.3), (Tint::Brown, 3.0, 0.35), (Tint::Brown, 4.0, 0.3)];
    let with = boards.iter().enumerate().map(|(i, &(tint, depth_m, transmission))| SmallBoard {
        board: Some(board_13x9()),
        depth_m,
        yaw_rad: 0.3,
        at: (0.35 - 0.2 * i as f64, -0.2 + 0.1 * i as f64),
        tint,
        transmission,
        seed: 40 + i as u64,
    });
    let without = [Tint::Green, Tint::Brown].into_iter().enumerate().map(|(i, tint)| SmallBoard {
        board: None,
        depth_m: 3.0,
        yaw_rad: 0.0,
        at: (0.0, 0.0),
        tint,
        transmission: 0.35,
        seed: 50 + i as u64,
    });
    with.chain(without).collect()
}

#[test]
fn small_boards_in_green_and_brown_water_are_found_and_empty_photos_rejected() {
    let set = small_board_set("board-search-tinted", &tinted_scenes());
    let results: Vec<Option<Found>> =
        set.photos.par_iter().zip(&set.truths).map(|(p, t)| search(p, 13, 9, &t.corners_px)).collect();
    for (i, r) in results.iter().enumerate() {
        println!("tinted photo {i}: {:?}", r.as_ref().map(|r| (r.step, r.median_px(), r.worst_px())));
    }
    for (i, r) in results[..4].iter().enumerate() {
        let r = r.as_ref().unwrap_or_else(|| panic!("board {i} not found"));
        assert!(r.worst_px() < 0.75, "board {i}: a corner {:.2} px from the truth", r.worst_px());
    }
    // The 4 m boards are the ones the quad detector loses even at 1/2 size.
    assert!(results[..4].iter().flatten().any(|r| matches!(r.step, SearchStep::Sectors { .. })));
    assert!(results[4..].iter().all(Option::is_none), "a board found in a photo without one");
}

/// Far boards (beyond 2.5 m) of randomised calibration sets in green (coastal) and
/// brown-green (harbour) water, rendered 2000x1500: their squares are 12-25 px in the
/// photo, 3-6 px at the quads' 1/4 size.
#[test]
fn far_boards_in_coastal_and_harbour_water_are_found() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("board-search-variety");
    std::fs::create_dir_all(&dir).unwrap();
    let mut photos: Vec<(PathBuf, Vec<[f64; 2]>, String)> = Vec::new();
    for seed in [11u64, 12, 13, 14] {
        let set = VarietySet::plan(Kind::Calibration, seed, None, 2000).unwrap();
        let rendered: Vec<_> = (0..set.len())
            .into_par_iter()
            .filter_map(|i| {
                let photo = set.render(i);
                let Some(TargetTruth::Board { corners_px, t_cam_target, .. }) = &photo.truth.target else {
                    return None;
                };
                let depth_m = t_cam_target.translation_m[2];
                if photo.truth.water.kind == WaterType::Ocean || depth_m < 2.5 {
                    return None;
                }
                let name = format!("set{seed}_{i:02}");
                let q = photo.truth.effects.jpeg_quality;
                calib_targets::write_photo(&dir, &name, &photo.image, q, &photo.truth).unwrap();
                let what = format!("{name} {} at {depth_m:.1} m", photo.truth.water.kind.name());
                Some((dir.join(format!("{name}.jpg")), corners_px.clone(), what))
            })
            .collect();
        photos.extend(rendered);
    }
    assert!(photos.len() >= 4, "only {} far boards in green or brown water", photos.len());
    let results: Vec<Option<Found>> = photos.par_iter().map(|(p, truth, _)| search(p, 14, 10, truth)).collect();
    let mut found = 0;
    for ((_, _, what), r) in photos.iter().zip(&results) {
        println!("{what}: {:?}", r.as_ref().map(|r| (r.step, r.median_px(), r.worst_px())));
        if let Some(r) = r {
            // A corner under the laser's dot or a glint refines off; the pose fit's
            // reprojection gate deals with a few of those. (set14_08, a 3.5 m board in green
            // water that only the plain sector step finds, has 3 of 140 over 1 px, worst 1.7.)
            assert!(r.median_px() < 0.3, "{what}: corners {:.2} px from the truth", r.median_px());
            assert!(r.beyond(1.0) <= 3, "{what}: {} corners over 1 px from the truth", r.beyond(1.0));
            found += 1;
        }
    }
    // Seeds 11-14 give six such photos (all coastal), none of which the quad steps find
    // on the whole image. The quads on a crop located by the corners' saddle points find
    // all six (before that step, the equalised sector step found five, the plain one the
    // sixth, set14_08, at 0.1-0.2 s a photo).
    assert_eq!(found, photos.len(), "{found} of {} far boards found", photos.len());
    let located = results.iter().flatten().filter(|r| matches!(r.step, SearchStep::Located { .. })).count();
    assert!(located >= 5, "only {located} of {} far boards found on a located crop", photos.len());
}

#[test]
fn the_search_plan_is_bounded_for_every_photo_size() {
    // No step runs on an image wider than 1100 px (a quad search on a 2000 px image ground
    // for 9 s on a tuning photo without equalisation, over 100 s on two held-out photos
    // with it), and the equalised quad search never on one wider than 640 px (3.5 s at
    // 1000 px on another). Both sector variants run (OpenCV 4.6 finds some boards only with
    // equalisation, others only without).
    for width in [640u32, 1000, 1600, 2000, 4000, 6000, 8000] {
        let plan = search_plan(width);
        println!("{width}: {plan:?}");
        for step in &plan {
            match *step {
                SearchStep::Sectors { factor, .. } => assert!(width / factor <= 1100, "{width}: {step:?}"),
                // Its crop is bounded where it is cut (`find_checkerboard`); the saddles are
                // found on the image the sector steps run on.
                SearchStep::Located { factor }
                | SearchStep::LocatedAgain { factor, .. }
                | SearchStep::Partial { factor } => {
                    assert!(width / (2 * factor) <= 1100, "{width}: {step:?}")
                }
                SearchStep::Quads { factor, normalised } => {
                    assert!(width / factor >= 400 || factor == 1, "{width}: {step:?}");
                    assert!(width / factor <= if normalised { 640 } else { 1100 }, "{width}: {step:?}");
                }
            }
        }
        for normalised in [true, false] {
            assert!(plan.iter().any(|s| matches!(s, SearchStep::Sectors { normalised: n, .. } if *n == normalised)));
        }
        // Some quad step runs on an image 400-1100 px wide, however large the photo.
        assert!(plan.iter().any(|s| matches!(*s, SearchStep::Quads { .. })), "{width}: {plan:?}");
    }
    assert_eq!(
        search_plan(4000),
        [
            SearchStep::Quads { factor: 8, normalised: true },
            SearchStep::Quads { factor: 4, normalised: false },
            SearchStep::Located { factor: 2 },
            SearchStep::Sectors { factor: 4, normalised: true },
            SearchStep::Sectors { factor: 4, normalised: false },
            SearchStep::LocatedAgain { factor: 2, image: CropImage::Grey, detector: CropDetector::QuadsNormalised },
            SearchStep::LocatedAgain {
                factor: 2,
                image: CropImage::Channel(0),
                detector: CropDetector::QuadsNormalised
            },
            SearchStep::LocatedAgain {
                factor: 2,
                image: CropImage::Channel(1),
                detector: CropDetector::QuadsNormalised
            },
            SearchStep::LocatedAgain {
                factor: 2,
                image: CropImage::Channel(2),
                detector: CropDetector::QuadsNormalised
            },
            SearchStep::LocatedAgain { factor: 2, image: CropImage::Grey, detector: CropDetector::SectorsNormalised },
            SearchStep::Partial { factor: 2 },
        ]
    );
}

/// Renders photo `i` of tuning calibration seed `seed` at the bench's 4000x3000 for each
/// `(seed, i)` into `dir` as `set{seed}_{i:02}.jpg`, with its board's true corners.
fn tuning_boards(dir: &Path, photos: &[(u64, usize)]) -> Vec<(PathBuf, Vec<[f64; 2]>)> {
    photos
        .par_iter()
        .map(|&(seed, i)| {
            // Chosen, before the renderer drew a tone curve, for how their boards look in linear
            // levels (as a raw developed flat): through a curve some are found sooner.
            let set = VarietySet::plan(Kind::Calibration, seed, None, 4000).unwrap().with_tone_gamma(1.0);
            let photo = set.render(i);
            let Some(TargetTruth::Board { corners_px, .. }) = &photo.truth.target else {
                panic!("seed {seed} photo {i} has no board");
            };
            let name = format!("set{seed}_{i:02}");
            calib_targets::write_photo(dir, &name, &photo.image, photo.truth.effects.jpeg_quality, &photo.truth)
                .unwrap();
            (dir.join(format!("{name}.jpg")), corners_px.clone())
        })
        .collect()
}

/// Four far boards (2.5-4 m, tuning calibration seeds 5, 6, 9 and 14 at the bench's
/// 4000x3000) that no step on the grey image found: their squares differ mostly in one
/// channel (green in green water, blue in clear blue) or show only equalised. The later
/// steps on the located crop find them: two in one channel, two equalised in grey.
#[test]
fn far_boards_seen_in_one_channel_are_found_on_the_located_crop() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("board-search-channels");
    std::fs::create_dir_all(&dir).unwrap();
    let photos = tuning_boards(&dir, &[(5, 8), (6, 9), (9, 7), (14, 9)]);
    for (path, truth) in &photos {
        let found = search(path, 14, 10, truth);
        println!("{}: {:?}", path.display(), found.as_ref().map(|r| (r.step, r.median_px(), r.worst_px())));
        let r = found.unwrap_or_else(|| panic!("{}: no board found", path.display()));
        assert!(matches!(r.step, SearchStep::LocatedAgain { .. }), "{}: found by {:?}", path.display(), r.step);
        assert!(r.median_px() < 0.3, "{}: corners {:.2} px from the truth", path.display(), r.median_px());
        // A corner under the dot, a glint or a laminate's sheen refines off (set5_08, under
        // a sheen: 5 of 140 over 1 px, worst 4 px; set9_07, at 2.75 m in murky green water
        // at JPEG quality 76: 9, worst 12 px); the pose fit weighs 140 corners and its
        // reprojection gate deals with worse.
        assert!(r.beyond(1.0) <= 10, "{}: {} corners over 1 px from the truth", path.display(), r.beyond(1.0));
    }
}

/// Boards in plain view with bubbles or a sheen over a few corners (tuning calibration seed
/// 6 photo 8, 3.5 m in coastal water; seed 9 photo 9, 2.5 m in harbour water): no detector
/// that wants every corner finds them, and the partial step completes each from the corners
/// it sees, all but the hidden few within a fraction of a pixel of the truth.
#[test]
fn boards_with_bubbles_over_a_few_corners_are_completed_from_the_rest() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("board-search-bubbles");
    std::fs::create_dir_all(&dir).unwrap();
    let photos = tuning_boards(&dir, &[(6, 8), (9, 9)]);
    for (path, truth) in &photos {
        let r = search(path, 14, 10, truth).unwrap_or_else(|| panic!("{}: board not found", path.display()));
        println!(
            "{}: {:?} median {:.2} worst {:.2} over 1 px {}",
            path.display(),
            r.step,
            r.median_px(),
            r.worst_px(),
            r.beyond(1.0)
        );
        assert!(matches!(r.step, SearchStep::Partial { .. }), "{:?}", r.step);
        assert!(r.median_px() < 0.3, "corners {:.2} px from the truth", r.median_px());
        assert!(r.beyond(1.0) <= 8, "{} corners over 1 px from the truth", r.beyond(1.0));
    }
}
