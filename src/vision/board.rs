//! Checkerboard corners: search reduced images by a fixed plan of bounded steps (fast, and
//! a photo without a board is rejected in under a second), then refine every corner at full resolution with a window
//! sized from its own neighbourhood, because a fixed 11x11 window reaches into the next
//! corner on a far, small board and biases the corners (and so the focal length).

use super::{Photo, VisionError};
use fslcal_core::Vec2;
use opencv::core::{Mat, Point2f, Rect, Size, TermCriteria, TermCriteria_Type, ToInputArray, Vector};
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
    /// The quad detector on a crop at 1/`factor` size around the board, located by its
    /// corners' saddle points on the image twice as small ([`locate_by_saddles`]): a board
    /// 2.4-4.5 m away has squares of 7-13 px at 1/4 size, too small for the quads there, and
    /// the sector step found it in 0.09-0.10 s a photo (8 of the speed bench's 16 photos,
    /// 0.75 s of a 2 s run's CPU); the crop at 1/2 size finds it in milliseconds. Bounded as
    /// the others: the crop is never wider than 1100 px.
    Located { factor: u32 },
    /// A detector on the same located crop at 1/`factor` size, seen through `image`: in
    /// murky water a board's contrast can lie mostly in one channel (green water's white
    /// squares differ from black in green, clear blue water's in blue), which the grey
    /// image dilutes, and OpenCV 4.6 finds such boards only equalised or only by sectors.
    /// Tried last, when every other step has failed: 4 of 9 boards 2.5-4 m away that no
    /// other step found (tuning calibration seeds 0-15), for 0.02-0.3 s more on a photo
    /// where none is found.
    LocatedAgain { factor: u32, image: CropImage, detector: CropDetector },
    /// Tried when nothing else found the board: on the same located crop at 1/`factor`
    /// size, the sector detector finds the largest whole grid of corners it can (OpenCV's
    /// `CALIB_CB_LARGER`), at least half the board's, and the board is completed from it
    /// ([`complete_partial_board`]). A bubble over two or three corners, or a sheen across
    /// a row of them, hides a board from every detector that wants all its corners: 7 of 31
    /// boards missed on the tuning calibration photos (seeds 0-23) were plainly in view,
    /// 1.9-5 m away, with bubbles or a sheen on a few corners. The completed corners are
    /// refined and gated as any others, so a corner a bubble hides is re-seated or the board
    /// is refused. Camera calibration does not use it.
    Partial { factor: u32 },
}

/// The image a located crop is searched in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CropImage {
    Grey,
    /// One colour channel, 0 red, 1 green, 2 blue.
    Channel(u8),
}

/// The detector run on a located crop.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CropDetector {
    /// The quad detector after OpenCV's histogram equalisation, on crops up to 640 px wide
    /// as [`SearchStep::Quads`] (0.05-0.12 s on a crop of reef texture).
    QuadsNormalised,
    /// The sector detector after equalisation.
    SectorsNormalised,
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
        .chain((factor >= 2).then_some(SearchStep::Located { factor: factor / 2 }))
        .chain([true, false].map(|normalised| SearchStep::Sectors { factor, normalised }))
        .chain((factor >= 2).then(|| located_again(factor / 2)).into_iter().flatten())
        .chain((factor >= 2).then_some(SearchStep::Partial { factor: factor / 2 }))
        .collect()
}

/// The [`SearchStep::LocatedAgain`] steps at 1/`factor` size: the quads, equalised, on
/// the grey image and on each channel (milliseconds each on a crop), then the sectors on the
/// grey image. The sectors on each channel found no board the others missed (tuning
/// calibration seeds 0-15) and cost up to 0.2 s each on a photo without a board.
fn located_again(factor: u32) -> impl Iterator<Item = SearchStep> {
    [CropImage::Grey, CropImage::Channel(0), CropImage::Channel(1), CropImage::Channel(2)]
        .map(|image| SearchStep::LocatedAgain { factor, image, detector: CropDetector::QuadsNormalised })
        .into_iter()
        .chain([SearchStep::LocatedAgain { factor, image: CropImage::Grey, detector: CropDetector::SectorsNormalised }])
}

impl SearchStep {
    fn factor(self) -> u32 {
        match self {
            SearchStep::Quads { factor, .. }
            | SearchStep::Sectors { factor, .. }
            | SearchStep::Located { factor }
            | SearchStep::LocatedAgain { factor, .. }
            | SearchStep::Partial { factor } => factor,
        }
    }

    /// The board's corners in the step's image, if it found the board.
    fn detect(self, grey: &impl ToInputArray, cols: u32, rows: u32) -> Result<Option<Vec<Point2f>>, opencv::Error> {
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
            SearchStep::Located { .. } => {
                let flags = calib3d::CALIB_CB_ADAPTIVE_THRESH | calib3d::CALIB_CB_FAST_CHECK;
                calib3d::find_chessboard_corners(grey, size, &mut corners, flags)?
            }
            SearchStep::LocatedAgain { detector: CropDetector::QuadsNormalised, .. } => {
                let flags = calib3d::CALIB_CB_ADAPTIVE_THRESH
                    | calib3d::CALIB_CB_FAST_CHECK
                    | calib3d::CALIB_CB_NORMALIZE_IMAGE;
                calib3d::find_chessboard_corners(grey, size, &mut corners, flags)?
            }
            SearchStep::LocatedAgain { detector: CropDetector::SectorsNormalised, .. } => {
                calib3d::find_chessboard_corners_sb(grey, size, &mut corners, calib3d::CALIB_CB_NORMALIZE_IMAGE)?
            }
            // The last resort: an OpenCV error in it is a board not found, not a photo lost.
            SearchStep::Partial { .. } => return Ok(complete_partial_board(grey, cols, rows).unwrap_or(None)),
        };
        Ok((found && corners.len() == (cols * rows) as usize).then(|| corners.to_vec()))
    }
}

/// Finds a `cols x rows` inner-corner checkerboard in the photo at `path` by the steps of
/// [`search_plan`], every image from the photo's one decode.
pub fn find_checkerboard(photo: &Photo, path: &Path, cols: u32, rows: u32) -> Result<Option<BoardSearch>, VisionError> {
    let cv = |e| VisionError::cv(path, e);
    // The saddles' region, at 1/(2 factor) size, found once for every located step.
    let mut located: Option<Option<Rect>> = None;
    for step in search_plan(photo.width()) {
        let factor = step.factor();
        let (found, origin) = match step {
            SearchStep::Located { .. } | SearchStep::LocatedAgain { .. } | SearchStep::Partial { .. } => {
                let region = match located {
                    Some(r) => r,
                    None => {
                        let r =
                            locate_by_saddles(photo.reduced_grey(2 * factor).map_err(cv)?, cols, rows).map_err(cv)?;
                        located = Some(r);
                        r
                    }
                };
                let Some(crop) = region else {
                    continue;
                };
                let (w, h) = (photo.width() as i32 / factor as i32, photo.height() as i32 / factor as i32);
                let crop = Rect::new(2 * crop.x, 2 * crop.y, 2 * crop.width, 2 * crop.height) & Rect::new(0, 0, w, h);
                let widest = match step {
                    SearchStep::LocatedAgain { detector: CropDetector::QuadsNormalised, .. } => {
                        QUADS_NORMALISED_MAX_WIDTH_PX
                    }
                    _ => MAX_STEP_WIDTH_PX,
                };
                if crop.width > widest as i32 || crop.width < 16 || crop.height < 16 {
                    continue;
                }
                let found = match step {
                    SearchStep::LocatedAgain { image: CropImage::Channel(c), .. } => {
                        step.detect(&photo.channel_crop(crop, factor, c).map_err(cv)?, cols, rows)
                    }
                    // The grey crop is a view into the reduced image, not a copy.
                    _ => step.detect(&Mat::roi(photo.reduced_grey(factor).map_err(cv)?, crop).map_err(cv)?, cols, rows),
                };
                (found, (crop.x as f64, crop.y as f64))
            }
            _ => (step.detect(photo.reduced_grey(factor).map_err(cv)?, cols, rows), (0.0, 0.0)),
        };
        if let Some(pts) = found.map_err(cv)? {
            // A reduced pixel (i, j) covers full pixels [f i, f i + f); its centre is at
            // f i + (f - 1) / 2 in the pixel-centre convention.
            let f = factor as f64;
            let off = (f - 1.0) / 2.0;
            let corners_px: Vec<Vec2> = pts
                .iter()
                .map(|p| Vec2::new((p.x as f64 + origin.0) * f + off, (p.y as f64 + origin.1) * f + off))
                .collect();
            // A completed board's hidden corners are placed, not seen: they must still lie on
            // the photo, where they can be refined.
            let (pw, ph) = (photo.width() as f64, photo.height() as f64);
            let on_photo = |p: &Vec2| p.x >= 0.0 && p.y >= 0.0 && p.x < pw && p.y < ph;
            if matches!(step, SearchStep::Partial { .. }) && !corners_px.iter().all(on_photo) {
                return Ok(None);
            }
            return Ok(Some(BoardSearch { corners_px, found_at_factor: factor, step }));
        }
    }
    Ok(None)
}

/// Fewest corners on each side of the grid the partial search starts from.
const PARTIAL_MIN_SIDE: i32 = 5;

/// How much better than any other placement the chosen one must match the board's
/// squares, in squares' worth of contrast: one column or row of the board more or less.
const PARTIAL_MARGIN_SQUARES: f64 = 3.0;

/// The whole board's corners (row-major over `cols x rows`, in `grey`'s pixels) from the
/// largest grid of corners the sector detector finds in `grey`; `None` when it finds none
/// with at least half the board's corners, or the grid's place on the board is unclear.
///
/// A grid of W x H corners lies somewhere on the board, turned by a quarter turn or not.
/// Each place and turn says which squares around the grid are black and which white, out
/// to the board's edge, for a board with a black square at a corner (FishSense's 14 x 10
/// has all four black; a board with white corners all round would be placed a square off,
/// which keeps its plane but not its outline); the place whose
/// squares, sampled through the grid's homography, match best is the board's, and it must
/// beat every other by [`PARTIAL_MARGIN_SQUARES`]. The grid's homography then puts the
/// corners it did not see; the caller refines every corner in the photo.
fn complete_partial_board(grey: &impl ToInputArray, cols: u32, rows: u32) -> opencv::Result<Option<Vec<Point2f>>> {
    let grey = grey.input_array()?.get_mat(-1)?;
    let (mut corners, mut meta) = (Vector::<Point2f>::new(), Mat::default());
    let flags = calib3d::CALIB_CB_LARGER | calib3d::CALIB_CB_EXHAUSTIVE;
    let start = Size::new(PARTIAL_MIN_SIDE, PARTIAL_MIN_SIDE);
    if !calib3d::find_chessboard_corners_sb_with_meta(&grey, start, &mut corners, flags, &mut meta)? {
        return Ok(None);
    }
    let (w, h) = (meta.cols() as usize, meta.rows() as usize);
    let (cols, rows) = (cols as usize, rows as usize);
    if cols < 2 || rows < 2 || corners.len() != w * h || 2 * w * h < cols * rows {
        return Ok(None);
    }
    let lattice: Vector<Point2f> = (0..h).flat_map(|y| (0..w).map(move |x| Point2f::new(x as f32, y as f32))).collect();
    let hm = calib3d::find_homography(&lattice, &corners, &mut Mat::default(), 0, 3.0)?;
    if hm.empty() {
        return Ok(None);
    }
    let hm: Vec<f64> = (0..9).map(|i| hm.at_2d::<f64>(i / 3, i % 3).copied()).collect::<opencv::Result<_>>()?;
    let to_image = |x: f64, y: f64| {
        let z = hm[6] * x + hm[7] * y + hm[8];
        ((hm[0] * x + hm[1] * y + hm[2]) / z, (hm[3] * x + hm[4] * y + hm[5]) / z)
    };
    let (gw, gh) = (grey.cols(), grey.rows());
    // Mean grey level over 3 x 3 px about a lattice point; `None` off the image.
    let sample = |x: f64, y: f64| -> Option<f64> {
        let (px, py) = to_image(x, y);
        let (cx, cy) = (px.round() as i32, py.round() as i32);
        if !(px.is_finite() && py.is_finite()) || cx < 1 || cy < 1 || cx >= gw - 1 || cy >= gh - 1 {
            return None;
        }
        let mut sum = 0.0;
        for v in cy - 1..=cy + 1 {
            for u in cx - 1..=cx + 1 {
                sum += *grey.at_2d::<u8>(v, u).ok()? as f64;
            }
        }
        Some(sum / 9.0)
    };
    // The grid's own squares set the levels of black and white (meta: 1 marks a corner
    // whose square to the lower right is black, 2 white).
    let (mut dark, mut light) = ((0.0, 0usize), (0.0, 0usize));
    for y in 0..h.saturating_sub(1) {
        for x in 0..w.saturating_sub(1) {
            let Some(g) = sample(x as f64 + 0.5, y as f64 + 0.5) else { continue };
            match *meta.at_2d::<u8>(y as i32, x as i32)? {
                1 => dark = (dark.0 + g, dark.1 + 1),
                2 => light = (light.0 + g, light.1 + 1),
                _ => {}
            }
        }
    }
    if dark.1 == 0 || light.1 == 0 {
        return Ok(None);
    }
    let (dark, light) = (dark.0 / dark.1 as f64, light.0 / light.1 as f64);
    let half_contrast = 0.5 * (light - dark);
    if half_contrast <= 0.0 {
        return Ok(None);
    }
    let mid = 0.5 * (light + dark);
    // A board point (u, v) in the grid's lattice, turned by `turn` quarter turns and
    // shifted so the grid's corner (0, 0) is the board's (a, b) in the turned frame.
    let (c1, r1) = ((cols - 1) as f64, (rows - 1) as f64);
    let place = |turn: usize, a: f64, b: f64, u: f64, v: f64| -> (f64, f64) {
        let (x, y) = match turn {
            0 => (u, v),
            1 => (v, c1 - u),
            2 => (c1 - u, r1 - v),
            _ => (r1 - v, u),
        };
        (x - a, y - b)
    };
    let mut scored: Vec<(f64, usize, usize, usize)> = Vec::new();
    for turn in 0..4 {
        let (bw, bh) = if turn % 2 == 0 { (cols, rows) } else { (rows, cols) };
        if w > bw || h > bh {
            continue;
        }
        for a in 0..=bw - w {
            for b in 0..=bh - h {
                // Every square of the board, its outer ring included: black where u + v
                // is even (the board's corner squares are black).
                let mut score = 0.0;
                for v in -1..rows as i64 {
                    for u in -1..cols as i64 {
                        let (x, y) = place(turn, a as f64, b as f64, u as f64 + 0.5, v as f64 + 0.5);
                        let Some(g) = sample(x, y) else { continue };
                        let sign = if (u + v).rem_euclid(2) == 0 { -1.0 } else { 1.0 };
                        score += sign * ((g - mid) / half_contrast).clamp(-1.0, 1.0);
                    }
                }
                scored.push((score, turn, a, b));
            }
        }
    }
    scored.sort_by(|p, q| q.0.total_cmp(&p.0));
    let Some(&(best, turn, a, b)) = scored.first() else {
        return Ok(None);
    };
    // A board's half turn puts its corners on the same points (its squares' colours too,
    // when cols + rows is even): the same place, not a rival.
    let outline = |turn: usize, a: usize, b: usize| {
        let mut o = [(0.0, 0.0), (c1, 0.0), (0.0, r1), (c1, r1)]
            .map(|(u, v)| place(turn, a as f64, b as f64, u, v))
            .map(|(x, y)| ((x * 2.0).round() as i64, (y * 2.0).round() as i64));
        o.sort();
        o
    };
    let chosen = outline(turn, a, b);
    if scored.iter().find(|s| outline(s.1, s.2, s.3) != chosen).is_some_and(|s| best - s.0 < PARTIAL_MARGIN_SQUARES) {
        return Ok(None);
    }
    let full: Vec<Point2f> = (0..rows)
        .flat_map(|v| (0..cols).map(move |u| (u, v)))
        .map(|(u, v)| {
            let (x, y) = place(turn, a as f64, b as f64, u as f64, v as f64);
            let (px, py) = to_image(x, y);
            Point2f::new(px as f32, py as f32)
        })
        .collect();
    if !full.iter().all(|p| p.x.is_finite() && p.y.is_finite()) {
        return Ok(None);
    }
    // The grid's lattice may be the board's mirror image; the detectors that see the whole
    // board number its corners so that the second row lies clockwise of the first in the
    // image, and so does this one.
    let (o, along, down) = (full[0], full[1], full[cols]);
    let turn_sign = (along.x - o.x) * (down.y - o.y) - (along.y - o.y) * (down.x - o.x);
    if turn_sign < 0.0 {
        return Ok(Some(full.chunks(cols).flat_map(|row| row.iter().rev().copied()).collect()));
    }
    Ok(Some(full))
}

/// Radius within which a board's corners are each other's neighbours on the image the
/// saddles are found on, pixels: a board's corner spacing there is 7-13 px for the
/// boards the quads lose (2.4-4.5 m away at 1/4 size), so an inner corner has 8-24
/// neighbours within it, a texture's saddle few.
const SADDLE_NEIGHBOUR_PX: f64 = 20.0;

/// The region of `grey` (a reduced image) most likely to hold a `cols x rows` board:
/// strong saddle points (where the grey level's Hessian has one positive and one negative
/// curvature, as at every corner where two black squares meet) that have at least 4 others
/// within [`SADDLE_NEIGHBOUR_PX`], linked into groups; the largest group with at least a
/// third of the board's corners, its box grown by that radius. `None` when no group is
/// large enough. A wrong region costs one quad search on a crop, which the fast check
/// rejects in milliseconds.
fn locate_by_saddles(grey: &Mat, cols: u32, rows: u32) -> opencv::Result<Option<Rect>> {
    let mut blurred = Mat::default();
    imgproc::gaussian_blur(grey, &mut blurred, Size::new(0, 0), 1.0, 1.0, opencv::core::BORDER_REFLECT_101)?;
    let derivative = |dx: i32, dy: i32| -> opencv::Result<Mat> {
        let mut d = Mat::default();
        imgproc::sobel(&blurred, &mut d, opencv::core::CV_32F, dx, dy, 3, 1.0, 0.0, opencv::core::BORDER_REFLECT_101)?;
        Ok(d)
    };
    let (xx, yy, xy) = (derivative(2, 0)?, derivative(0, 2)?, derivative(1, 1)?);
    let (w, h) = (grey.cols() as usize, grey.rows() as usize);
    let (xx, yy, xy) = (xx.data_typed::<f32>()?, yy.data_typed::<f32>()?, xy.data_typed::<f32>()?);
    // Saddle strength: minus the Hessian's determinant where it is negative.
    let strength: Vec<f32> = (0..w * h).map(|i| (xy[i] * xy[i] - xx[i] * yy[i]).max(0.0)).collect();
    let mut peaks: Vec<(f32, f64, f64)> = Vec::new();
    for y in 2..h.saturating_sub(2) {
        for x in 2..w.saturating_sub(2) {
            let s = strength[y * w + x];
            if s <= 0.0 {
                continue;
            }
            let is_peak = (y - 2..=y + 2).all(|v| (x - 2..=x + 2).all(|u| (u, v) == (x, y) || strength[v * w + u] < s));
            if is_peak {
                peaks.push((s, x as f64, y as f64));
            }
        }
    }
    let corners = (cols * rows) as usize;
    peaks.sort_by(|a, b| b.0.total_cmp(&a.0));
    peaks.truncate(3 * corners);
    let r2 = SADDLE_NEIGHBOUR_PX * SADDLE_NEIGHBOUR_PX;
    let near = |a: &(f32, f64, f64), b: &(f32, f64, f64)| (a.1 - b.1).powi(2) + (a.2 - b.2).powi(2) <= r2;
    let dense: Vec<&(f32, f64, f64)> =
        peaks.iter().filter(|p| peaks.iter().filter(|q| near(p, q)).count() > 4).collect();
    // Groups of dense peaks linked within the radius (a flood over the few hundred peaks).
    let mut group = vec![usize::MAX; dense.len()];
    let mut best: Option<(usize, [f64; 4])> = None;
    for start in 0..dense.len() {
        if group[start] != usize::MAX {
            continue;
        }
        group[start] = start;
        let (mut stack, mut n) = (vec![start], 0usize);
        let mut bbox = [f64::INFINITY, f64::INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY];
        while let Some(i) = stack.pop() {
            n += 1;
            let p = dense[i];
            bbox = [bbox[0].min(p.1), bbox[1].min(p.2), bbox[2].max(p.1), bbox[3].max(p.2)];
            for j in 0..dense.len() {
                if group[j] == usize::MAX && near(p, dense[j]) {
                    group[j] = start;
                    stack.push(j);
                }
            }
        }
        if n >= corners / 3 && best.is_none_or(|(m, _)| n > m) {
            best = Some((n, bbox));
        }
    }
    Ok(best.map(|(_, [x0, y0, x1, y1])| {
        let pad = SADDLE_NEIGHBOUR_PX;
        let (x0, y0) = ((x0 - pad).max(0.0) as i32, (y0 - pad).max(0.0) as i32);
        let (x1, y1) = ((x1 + pad).min(w as f64) as i32, (y1 + pad).min(h as f64) as i32);
        Rect::new(x0, y0, x1 - x0, y1 - y0)
    }))
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
