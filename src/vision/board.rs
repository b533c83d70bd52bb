//! Checkerboard corners: search reduced images by a fixed plan of bounded steps (fast, and
//! a photo without a board is rejected in under a second), then refine every corner at full resolution with a window
//! sized from its own neighbourhood, because a fixed 11x11 window reaches into the next
//! corner on a far, small board and biases the corners (and so the focal length).

use super::{Photo, VisionError};
use fslcal_core::Vec2;
use opencv::core::{Mat, Point2f, Size, TermCriteria, TermCriteria_Type, Vector};
use opencv::prelude::*;
use opencv::{calib3d, imgproc};
use std::path::Path;

/// What the search found, before refinement.
pub struct BoardSearch {
    /// Corners in full-resolution pixels, row-major over inner corners.
    pub corners_px: Vec<Vec2>,
    /// The reduction factor the board was found at.
    pub found_at_factor: u32,
    /// The search step that found it.
    pub step: SearchStep,
}

/// One step of the board search. Each runs on an image at most 1100 px wide, so a photo's
/// search costs at most the sum of its steps whatever the photo holds (on a 4000x3000
/// photo under a second on one core).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SearchStep {
    /// OpenCV's quad detector (`findChessboardCorners`, adaptive threshold, fast check) on
    /// the grey image at 1/`factor` size: milliseconds on most photos, and a photo without a
    /// board is rejected at once; it loses small boards whose squares are under about 12 px
    /// at that size. `normalised`: with OpenCV's histogram equalisation first, which is
    /// what makes it grind on a textured photo with a board (equalised texture is a sea of
    /// quads: 0.6-2.7 s at 1000 px wide on 3 of 30 tuning calibration photos, 3.5 s on a
    /// held-out one, over 100 s at 2000 px), so it runs equalised only on images up to 640
    /// px wide. Without it the same 1000 px search took at most 0.39 s on 114 tuning
    /// calibration photos (median 12 ms) and found boards the equalised one ground on and
    /// lost; at 2000 px it still took up to 9 s, so it is never run wider than 1100 px.
    Quads { factor: u32, normalised: bool },
    /// OpenCV's sector-based detector (`findChessboardCornersSB`) at 1/`factor` size: finds
    /// boards with 4-8 px squares and low contrast that the quad detector misses, in 0.1-0.2
    /// s on a 1000x750 image (and an open-ended time on a large one, hence the reduction).
    /// `normalised`: with OpenCV's histogram equalisation first. OpenCV 4.6 finds some
    /// boards only with it and others (a laminated board under a sheen, in green water) only
    /// without it, so both are tried.
    Sectors { factor: u32, normalised: bool },
}

/// Widest image any step runs on, pixels.
const MAX_STEP_WIDTH_PX: u32 = 1100;

/// Widest image the equalised quad step runs on, pixels (see [`SearchStep::Quads`]).
const QUADS_NORMALISED_MAX_WIDTH_PX: u32 = 640;

/// The steps for a photo `width_px` wide, cheapest first: quads on every reduction 400-1100
/// px wide (the whole photo when it is narrower than 400 px), equalised up to 640 px, then
/// sectors at the reduction that makes the image at most 1100 px wide, equalised, then not.
pub fn search_plan(width_px: u32) -> Vec<SearchStep> {
    let factor = [1u32, 2, 4, 8].into_iter().find(|f| width_px / f <= MAX_STEP_WIDTH_PX).unwrap_or(8);
    [8u32, 4, 2, 1]
        .into_iter()
        .filter(|f| (400..=MAX_STEP_WIDTH_PX).contains(&(width_px / f)) || (*f == 1 && width_px < 400))
        .map(|factor| SearchStep::Quads { factor, normalised: width_px / factor <= QUADS_NORMALISED_MAX_WIDTH_PX })
        .chain([true, false].map(|normalised| SearchStep::Sectors { factor, normalised }))
        .collect()
}

impl SearchStep {
    fn factor(self) -> u32 {
        match self {
            SearchStep::Quads { factor, .. } | SearchStep::Sectors { factor, .. } => factor,
        }
    }

    /// The board's corners in the step's image, if it found the board.
    fn detect(self, grey: &Mat, cols: u32, rows: u32) -> Result<Option<Vec<Point2f>>, opencv::Error> {
        let size = Size::new(cols as i32, rows as i32);
        let mut corners = Vector::<Point2f>::new();
        let found = match self {
            SearchStep::Quads { normalised, .. } => {
                let equalise = if normalised { calib3d::CALIB_CB_NORMALIZE_IMAGE } else { 0 };
                let flags = calib3d::CALIB_CB_ADAPTIVE_THRESH | calib3d::CALIB_CB_FAST_CHECK | equalise;
                calib3d::find_chessboard_corners(grey, size, &mut corners, flags)?
            }
            // Not EXHAUSTIVE: it finds the same boards here at up to three times the cost
            // on a photo without one.
            SearchStep::Sectors { normalised, .. } => {
                let flags = if normalised { calib3d::CALIB_CB_NORMALIZE_IMAGE } else { 0 };
                calib3d::find_chessboard_corners_sb(grey, size, &mut corners, flags)?
            }
        };
        Ok((found && corners.len() == (cols * rows) as usize).then(|| corners.to_vec()))
    }
}

/// Finds a `cols x rows` inner-corner checkerboard in the photo at `path` by the steps of
/// [`search_plan`], every image from the photo's one decode.
pub fn find_checkerboard(photo: &Photo, path: &Path, cols: u32, rows: u32) -> Result<Option<BoardSearch>, VisionError> {
    let cv = |e| VisionError::cv(path, e);
    for step in search_plan(photo.width()) {
        let factor = step.factor();
        let grey = photo.reduced_grey(factor).map_err(cv)?;
        if let Some(pts) = step.detect(grey, cols, rows).map_err(cv)? {
            // A reduced pixel (i, j) covers full pixels [f i, f i + f); its centre is at
            // f i + (f - 1) / 2 in the pixel-centre convention.
            let f = factor as f64;
            let off = (f - 1.0) / 2.0;
            let corners_px = pts.iter().map(|p| Vec2::new(p.x as f64 * f + off, p.y as f64 * f + off)).collect();
            return Ok(Some(BoardSearch { corners_px, found_at_factor: factor, step }));
        }
    }
    Ok(None)
}

/// Local square size at each corner: the shortest distance to a grid neighbour.
pub fn local_square_px(corners: &[Vec2], cols: u32, rows: u32) -> Vec<f64> {
    let (c, r) = (cols as usize, rows as usize);
    (0..corners.len())
        .map(|i| {
            let (x, y) = (i % c, i / c);
            let mut best = f64::INFINITY;
            let mut consider = |j: usize| best = best.min((corners[i] - corners[j]).norm());
            if x > 0 {
                consider(i - 1);
            }
            if x + 1 < c {
                consider(i + 1);
            }
            if y > 0 {
                consider(i - c);
            }
            if y + 1 < r {
                consider(i + c);
            }
            best
        })
        .collect()
}

/// Refines corners at full resolution. Each corner's window half-size is about a third of
/// its local square (at least 2 px, at most 12 px), so the window never reaches a
/// neighbouring corner.
pub fn refine_corners(photo: &Photo, corners: &mut [Vec2], cols: u32, rows: u32) -> Result<(), opencv::Error> {
    let squares = local_square_px(corners, cols, rows);
    let criteria = TermCriteria::new((TermCriteria_Type::COUNT as i32) | (TermCriteria_Type::EPS as i32), 40, 0.001)?;
    // Group corners by window size: one cornerSubPix call per size.
    let mut by_half: std::collections::BTreeMap<i32, Vec<usize>> = Default::default();
    for (i, s) in squares.iter().enumerate() {
        let half = ((s / 3.0).floor() as i32).clamp(2, 12);
        by_half.entry(half).or_default().push(i);
    }
    for (half, idx) in by_half {
        let mut pts: Vector<Point2f> =
            idx.iter().map(|&i| Point2f::new(corners[i].x as f32, corners[i].y as f32)).collect();
        imgproc::corner_sub_pix(photo.grey()?, &mut pts, Size::new(half, half), Size::new(-1, -1), criteria)?;
        for (k, &i) in idx.iter().enumerate() {
            let p = pts.get(k)?;
            corners[i] = Vec2::new(p.x as f64, p.y as f64);
        }
    }
    Ok(())
}
