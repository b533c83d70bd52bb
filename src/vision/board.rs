//! Checkerboard corners: search a reduced image (fast, and a photo without a board is
//! rejected in milliseconds), then refine every corner at full resolution with a window
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
}

fn detect(grey: &Mat, cols: u32, rows: u32, flags: i32) -> Result<Option<Vec<Point2f>>, opencv::Error> {
    let mut corners = Vector::<Point2f>::new();
    let found = calib3d::find_chessboard_corners(grey, Size::new(cols as i32, rows as i32), &mut corners, flags)?;
    Ok(found.then(|| corners.to_vec()))
}

/// Finds a `cols x rows` inner-corner checkerboard in the photo at `path`: at 1/4 size,
/// then 1/2 (a far board's squares are too small at 1/4), then, for small images, at full
/// size; every image from the photo's one decode.
pub fn find_checkerboard(photo: &Photo, path: &Path, cols: u32, rows: u32) -> Result<Option<BoardSearch>, VisionError> {
    let flags = calib3d::CALIB_CB_ADAPTIVE_THRESH | calib3d::CALIB_CB_NORMALIZE_IMAGE | calib3d::CALIB_CB_FAST_CHECK;
    let cv = |e| VisionError::cv(path, e);
    for factor in [4u32, 2, 1] {
        let grey = photo.reduced_grey(factor).map_err(cv)?;
        // Below ~480 px wide a further reduction loses the board; search at what we have.
        if factor > 1 && grey.cols() < 400 {
            continue;
        }
        let found = detect(grey, cols, rows, flags).map_err(cv)?;
        if let Some(pts) = found {
            // A reduced JPEG pixel (i, j) covers full pixels [f i, f i + f); its centre is at
            // f i + (f - 1) / 2 in the pixel-centre convention.
            let f = factor as f64;
            let off = (f - 1.0) / 2.0;
            let corners_px = pts.iter().map(|p| Vec2::new(p.x as f64 * f + off, p.y as f64 * f + off)).collect();
            return Ok(Some(BoardSearch { corners_px, found_at_factor: factor }));
        }
        // A full-resolution pass only pays for small images (e.g. 640x480).
        if factor == 2 && photo.width() > 1600 {
            break;
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
