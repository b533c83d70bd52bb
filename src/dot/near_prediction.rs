//! The second look for a dot: where a first fit predicts the dot on a photo's target, a
//! more sensitive search in a small disc around the prediction. Far, faint dots in murky
//! water often fall below the first search's threshold.

use super::candidates::{ColourView, DotCandidate, DotDetectorParams, SearchRegion};
use super::on_target::{self, Surface};
use fslcal_core::Vec2;

/// Radius of the disc searched around a prediction, pixels, for a fit whose used dots lie
/// within `max_dot_offset_px` of its line.
pub fn disc_radius_px(max_dot_offset_px: f64) -> f64 {
    (4.0 * max_dot_offset_px).max(12.0)
}

/// The strongest candidate within `radius_px` of `predicted` (full-image pixels) in `view`,
/// whose top-left pixel is at `offset` in the full image, with the detector made
/// [`DotDetectorParams::sensitive`]; on a checkerboard's `squares` (full-image pixels) each
/// square's level is the background.
pub fn find_near(
    surface: Surface,
    view: &ColourView<'_>,
    offset: Vec2,
    predicted: Vec2,
    radius_px: f64,
    squares: &[[Vec2; 4]],
    detector: &DotDetectorParams,
) -> Option<DotCandidate> {
    // An octagon circumscribing the disc; the band then trims it to the disc itself.
    let polygon: Vec<Vec2> = (0..8)
        .map(|k| {
            let a = k as f64 * std::f64::consts::TAU / 8.0;
            predicted - offset + Vec2::new(a.cos(), a.sin()) * radius_px / (std::f64::consts::PI / 8.0).cos()
        })
        .collect();
    let squares = squares.iter().map(|q| q.map(|p| p - offset)).collect();
    let region =
        SearchRegion { polygon, band: Some((vec![predicted - offset], radius_px)), squares, overlapping_pieces: false };
    on_target::find(surface, view, &region, &detector.sensitive(), 1).into_iter().next().map(|mut c| {
        c.pixel += offset;
        c
    })
}
