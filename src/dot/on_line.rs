//! Finding the laser dot in a photo with no target in it (a fish, a drift-check photo): a
//! rigid laser's dot can only be on the image of the calibrated laser line, so the search
//! runs along that curve (projected with the camera model, distortion included) over the
//! depths a dot can have, in a band wide enough to still find the dot of a laser that has
//! moved a little (the drift check measures exactly that offset).
//!
//! The detector is [`crate::dot::candidates::find_dot_candidates`]; this module only decides where it
//! looks and which candidate it believes.

use crate::dot::candidates::{find_dot_candidates, ColourView, DotCandidate, DotDetectorParams, SearchRegion};
use fslcal_core::{CameraModel, LaserLine, Vec2};

/// Depths searched when the caller has nothing better, metres: from the closest a fish is
/// photographed to beyond where the dot is still visible in clear water.
pub const DEFAULT_SEARCH_DEPTHS_M: (f64, f64) = (0.3, 6.0);

/// Default half-width of the band around the laser's image, pixels. A laser knocked by 1
/// degree moves its dot by about `f * 0.017` = 50 px on the TG-6; a wider band lets glints
/// and green reflections compete with the dot.
pub const DEFAULT_BAND_HALF_WIDTH_PX: f64 = 80.0;

/// Half-width of the band of the second, more sensitive search, pixels.
const SENSITIVE_HALF_WIDTH_PX: f64 = 16.0;

/// An unclipped blob wider than this (equivalent radius, px) is scenery, not a dot.
const MAX_UNCLIPPED_RADIUS_PX: f64 = 10.0;
/// A candidate further than [`ON_LINE_PX`] from the laser's image needs this SNR: measured
/// on the synthetic slate scenes, texture specks score 8-18 and dots off a knocked laser's
/// line far more.
const OFF_LINE_MIN_SNR: f64 = 20.0;
const ON_LINE_PX: f64 = 10.0;

/// Where and how to search.
#[derive(Clone, Debug)]
pub struct LineSearch {
    /// Depth range of the search along the laser, metres.
    pub depths_m: (f64, f64),
    /// Half-width of the band around the laser's image, pixels.
    pub band_half_width_px: f64,
    pub detector: DotDetectorParams,
}

impl Default for LineSearch {
    fn default() -> Self {
        LineSearch {
            depths_m: DEFAULT_SEARCH_DEPTHS_M,
            band_half_width_px: DEFAULT_BAND_HALF_WIDTH_PX,
            detector: DotDetectorParams::default(),
        }
    }
}

/// The dot found near the laser's image.
#[derive(Clone, Debug, PartialEq)]
pub struct LineDot {
    /// Sub-pixel centre (pixel-centre convention).
    pub pixel: Vec2,
    /// Matched-filter signal-to-noise of the chosen blob (the detector's score).
    pub snr: f64,
    /// Perpendicular distance from the laser's image, pixels.
    pub offset_px: f64,
    /// The chosen candidate as the detector returned it.
    pub candidate: DotCandidate,
    /// Other dot-like blobs in the band (reflections, glints with a green fringe).
    pub rivals: usize,
}

#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum DotOnLineError {
    #[error("the calibrated laser's image does not cross this {width}x{height} photo between {near_m} and {far_m} m (wrong calibration for this camera?)")]
    LineOutsideImage { width: usize, height: usize, near_m: f64, far_m: f64 },
    #[error("{count} faint dot-like blobs on the laser's image and no clear dot; give the dot by hand")]
    Ambiguous { count: usize },
    #[error("no laser dot within {half_width_px:.0} px of the calibrated laser's image (laser off, dot off the subject, or the laser has moved a lot: recalibrate)")]
    NoDot { half_width_px: f64 },
}

/// The laser's image as a polyline over `depths_m`, the points inside the image only.
pub fn laser_image_polyline(camera: &CameraModel, laser: &LaserLine, depths_m: (f64, f64)) -> Vec<Vec2> {
    // Log-spaced: near depths move the dot fast, far depths crowd toward the vanishing point.
    let n = 96;
    let (a, b) = (depths_m.0.ln(), depths_m.1.ln());
    (0..=n)
        .filter_map(|i| laser.pixel_at_depth(camera, (a + (b - a) * i as f64 / n as f64).exp()))
        .filter(|p| camera.contains(*p))
        .collect()
}

/// Finds the laser dot in `img` (the full-resolution photo the `camera` describes) along the
/// image of `laser`. The best candidate by signal-to-noise wins: inside a narrow band the
/// dot is nearly always the strongest green blob, and the drift check needs the dot even
/// when it is off the line, so distance to the line does not rank.
pub fn find_dot_on_laser_line(
    img: &ColourView,
    camera: &CameraModel,
    laser: &LaserLine,
    search: &LineSearch,
) -> Result<LineDot, DotOnLineError> {
    let line = laser_image_polyline(camera, laser, search.depths_m);
    if line.len() < 2 {
        return Err(DotOnLineError::LineOutsideImage {
            width: img.width,
            height: img.height,
            near_m: search.depths_m.0,
            far_m: search.depths_m.1,
        });
    }
    let hw = search.band_half_width_px;
    // The detector's region of interest is the bounding box of its polygon; a diagonal line's
    // box is mostly empty, so search in pieces about a band-width long, each a padded
    // rectangle around its piece (the padding keeps the background window off the box's
    // edge), and keep only centres inside the band.
    let pad = hw + search.detector.background_radius_px as f64;
    let piece_px = (4.0 * hw).max(200.0);
    let mut pieces: Vec<Vec<Vec2>> = vec![vec![line[0]]];
    let mut run = 0.0;
    for w in line.windows(2) {
        run += (w[1] - w[0]).norm();
        pieces.last_mut().expect("starts with one piece").push(w[1]);
        if run >= piece_px {
            pieces.push(vec![w[1]]);
            run = 0.0;
        }
    }
    let mut found = search_pieces(img, &line, &pieces, hw, pad, &search.detector);
    if found.is_empty() {
        // Far dots in murky water are faint: a second, more sensitive look, only close to
        // the line (in the whole band it finds noise). Near the noise floor a lone blob is
        // believed, several are noise or texture and none of them is.
        found = search_pieces(img, &line, &pieces, hw.min(SENSITIVE_HALF_WIDTH_PX), pad, &search.detector.sensitive());
        if found.len() > 1 {
            return Err(DotOnLineError::Ambiguous { count: found.len() });
        }
    }
    // Scenery that passes for a dot: light patches between dark ones are large and never
    // clipped (a near dot that large has a clipped core), and a dot off the line is a claim
    // of drift that needs a strong blob, not a speck of texture.
    found.retain(|c| c.saturated_core || c.radius_px <= MAX_UNCLIPPED_RADIUS_PX);
    found.retain(|c| {
        c.snr >= OFF_LINE_MIN_SNR || crate::dot::candidates::distance_to_polyline(&line, c.pixel) <= ON_LINE_PX
    });
    let Some(best) = found.first().cloned() else {
        return Err(DotOnLineError::NoDot { half_width_px: hw });
    };
    let offset_px = laser
        .pixel_offset(camera, best.pixel, search.depths_m.0 * 0.5, search.depths_m.1 * 2.0)
        .unwrap_or_else(|| crate::dot::candidates::distance_to_polyline(&line, best.pixel));
    Ok(LineDot { pixel: best.pixel, snr: best.snr, offset_px, rivals: found.len() - 1, candidate: best })
}

/// Candidates in every piece of the band, one per blob, best first.
fn search_pieces(
    img: &ColourView,
    line: &[Vec2],
    pieces: &[Vec<Vec2>],
    hw: f64,
    pad: f64,
    params: &DotDetectorParams,
) -> Vec<DotCandidate> {
    let mut found: Vec<DotCandidate> = Vec::new();
    for piece in pieces.iter().filter(|p| p.len() >= 2) {
        let (a, b) = (piece[0], piece[piece.len() - 1]);
        let along = (b - a).try_normalize(1e-9).unwrap_or(Vec2::new(1.0, 0.0));
        let across = Vec2::new(-along.y, along.x);
        // The piece may bow a little under distortion: widen by its largest sag.
        let sag = piece.iter().map(|p| ((p - a).dot(&across)).abs()).fold(0.0, f64::max);
        let (s, t) = (along * pad, across * (pad + sag));
        let polygon = vec![a - s - t, b + s - t, b + s + t, a - s + t];
        let region = SearchRegion { polygon, band: Some((line.to_vec(), hw)) };
        for c in find_dot_candidates(img, &region, params, 8) {
            // Neighbouring pieces overlap: one blob, one candidate.
            if !found.iter().any(|f| (f.pixel - c.pixel).norm() < 2.0 * f.radius_px.max(c.radius_px).max(2.0)) {
                found.push(c);
            }
        }
    }
    found.sort_by(|a, b| b.snr.total_cmp(&a.snr));
    found
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dot::candidates::ChannelOrder;
    use calib_targets::rig::{fsl_laser, tg6_camera};
    use calib_targets::scene::{laser_scene_set, render, Water};

    fn view(img: &image::RgbImage) -> ColourView<'_> {
        ColourView {
            width: img.width() as usize,
            height: img.height() as usize,
            stride: img.width() as usize * 3,
            order: ChannelOrder::Rgb,
            data: img.as_raw(),
        }
    }

    /// Rendered 4000x3000 scenes near and far, with glints and a green reflection elsewhere:
    /// the dot is found on the line without the board, within a pixel of the truth.
    #[test]
    fn finds_the_dot_along_the_line_without_a_target() {
        let murky = laser_scene_set(8, 5, Water::Murky, 3);
        let clear = laser_scene_set(8, 5, Water::Clear, 3);
        let (camera, laser) = (tg6_camera(), fsl_laser());
        for (i, spec) in [(0usize, &murky[0]), (1, &murky[1]), (4, &murky[4]), (7, &murky[7]), (6, &clear[6])] {
            let scene = render(spec);
            let truth = scene.truth.dot.clone().expect("dot on the board");
            let found = find_dot_on_laser_line(&view(&scene.image), &camera, &laser, &LineSearch::default());
            // A 4.5 m dot on a black square is at the noise floor: it may be refused, never
            // taken from a wrong blob.
            if i == 7 {
                if let Err(e) = &found {
                    eprintln!(
                        "photo {i} ({:?}, {:.2} m, on black: {}): refused: {e}",
                        spec.water, truth.depth_m, truth.on_black_square
                    );
                    continue;
                }
            }
            let dot = found.unwrap_or_else(|e| panic!("photo {i} at {:.2} m: {e}", truth.depth_m));
            let err = (dot.pixel - Vec2::new(truth.pixel[0], truth.pixel[1])).norm();
            eprintln!(
                "photo {i}: depth {:.2} m, dot {err:.2} px from truth, offset {:.2} px, snr {:.0}, rivals {}",
                truth.depth_m, dot.offset_px, dot.snr, dot.rivals
            );
            assert!(err < 1.0, "photo {i}: {err:.2} px from the truth");
            assert!(dot.offset_px < 1.0, "photo {i}: the true laser's dot is {:.2} px off its line", dot.offset_px);
        }
    }

    #[test]
    fn a_photo_with_the_laser_off_has_no_dot_and_a_foreign_line_misses_the_image() {
        let mut spec = laser_scene_set(3, 6, Water::Clear, 2).remove(1);
        spec.laser = None;
        let scene = render(&spec);
        let (camera, laser) = (tg6_camera(), fsl_laser());
        let e = find_dot_on_laser_line(&view(&scene.image), &camera, &laser, &LineSearch::default()).unwrap_err();
        assert!(matches!(e, DotOnLineError::NoDot { .. }), "{e}");
        // A line pointing out of the frame sideways.
        let away = LaserLine::from_point_direction(
            fslcal_core::Vec3::new(2.0, 0.0, 0.0),
            fslcal_core::Vec3::new(1.0, 0.0, 0.3),
        )
        .unwrap();
        let e = find_dot_on_laser_line(&view(&scene.image), &camera, &away, &LineSearch::default()).unwrap_err();
        assert!(matches!(e, DotOnLineError::LineOutsideImage { .. }), "{e}");
    }
}
