//! The dot's search on a target's image (a checkerboard or a taped slate), and the sigma a
//! found or hand-given dot carries into the fit.

use super::candidates::{find_dot_candidates, ColourView, DotCandidate, DotDetectorParams, SearchRegion};
use fslcal_core::Vec2;

/// The surface the dot lies on, as far as the dot's search cares.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Surface {
    /// Two colours, few dot-like blobs.
    Checkerboard,
    /// A scanned slate's texture: tape edges, pencil, light patches.
    Slate,
}

/// Dot candidates inside `region`, best first. A slate's texture (tape edges, pencil, light
/// patches under a green-blue veil) makes more dot-like blobs than a board's two colours,
/// so its candidates must be [`SLATE_SNR_FACTOR`] times as strong; its dots are seen
/// closer (0.45 m) than a board's, where murky water's forward scatter makes the halo
/// larger than the detector's usual limit.
pub fn find(
    surface: Surface,
    img: &ColourView<'_>,
    region: &SearchRegion,
    params: &DotDetectorParams,
    max: usize,
) -> Vec<DotCandidate> {
    match surface {
        Surface::Checkerboard => find_dot_candidates(img, region, params, max),
        Surface::Slate => {
            let params = DotDetectorParams {
                max_area_px: params.max_area_px.max(SLATE_MAX_DOT_AREA_PX),
                min_snr: params.min_snr * SLATE_SNR_FACTOR,
                ..params.clone()
            };
            find_dot_candidates(img, region, &params, max)
        }
    }
}

/// A checkerboard's squares as image quads, from its inner corners (`cols` x `rows`,
/// row-major) and one extrapolated row or column beyond each side for the border squares.
/// Each quad's corners go round it. Empty unless the corners make the full grid.
pub fn board_squares(corners: &[Vec2], cols: usize, rows: usize) -> Vec<[Vec2; 4]> {
    if cols < 2 || rows < 2 || corners.len() != cols * rows {
        return Vec::new();
    }
    // Grid with a ring of extrapolated corners: index (i, j) for i in -1..=cols, j in -1..=rows.
    let at = |i: isize, j: isize| -> Vec2 {
        let clamp = |v: isize, n: usize| v.clamp(0, n as isize - 1);
        let (ci, cj) = (clamp(i, cols), clamp(j, rows));
        let c = |i: isize, j: isize| corners[j as usize * cols + i as usize];
        let mut p = c(ci, cj);
        if i != ci {
            let inward = if i < 0 { ci + 1 } else { ci - 1 };
            p += c(ci, cj) - c(inward, cj);
        }
        if j != cj {
            let inward = if j < 0 { cj + 1 } else { cj - 1 };
            p += c(ci, cj) - c(ci, inward);
        }
        p
    };
    let mut squares = Vec::with_capacity((cols + 1) * (rows + 1));
    for j in -1..rows as isize {
        for i in -1..cols as isize {
            squares.push([at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)]);
        }
    }
    squares
}

/// On a slate, dot candidates need this many times the detector's usual SNR: measured on
/// the synthetic slate scenes, scenery blobs reach SNR 16 and the dots score 56 or more.
pub const SLATE_SNR_FACTOR: f64 = 2.5;

/// Largest dot blob on a slate, pixels: a saturated dot at 0.45 m in murky water with its
/// scattered halo.
const SLATE_MAX_DOT_AREA_PX: usize = 80_000;

/// Localisation of a dot clicked by hand, pixels (1 sigma per axis): people click the
/// visual centre of a blob to about a pixel.
pub const HAND_DOT_SIGMA_PX: f64 = 1.0;

/// Sub-pixel localisation of a detected dot, 1 sigma in pixels: the blob's size over its
/// signal-to-noise, floored where JPEG and the model's own limits take over.
pub fn detected_sigma_px(c: &DotCandidate) -> f64 {
    (c.radius_px / c.snr.max(1.0)).clamp(0.1, 1.5)
}

/// A hand-given dot as a candidate: certain by fiat, with no blob measured.
pub fn hand_candidate(px: Vec2) -> DotCandidate {
    DotCandidate {
        pixel: px,
        snr: f64::INFINITY,
        peak_green: 0.0,
        radius_px: 0.0,
        core_radius_px: 0.0,
        saturated_core: false,
        saturated_px: 0,
        white_px: 0,
        lit_clipped_px: 0,
        colour_score: f64::INFINITY,
        colour_angle_rad: 0.0,
        colour_angle_sigma_rad: 0.0,
        colour_texture_sigma_rad: 0.0,
        white_deficit_rad: 0.0,
        outline_roughness: None,
        split_from_blob: false,
        enclosed_by: None,
        excess_rgb: [0.0; 3],
        judged_excess_rgb: [0.0; 3],
        colour_filled_in: false,
    }
}
