//! Photo thumbnails with what the tool saw drawn on them: the detected board, the dot, the
//! laser line's image. Overlays are given in full-resolution pixels (the convention of
//! `docs/conventions.md`) and mapped onto the thumbnail here.

use crate::photo::counter::{count, Event};
use crate::photo::thumbnails::{self, Kept};
use fslcal_core::{CameraModel, LaserLine, Vec2};
use image::{imageops, ImageReader, Rgb, RgbImage};
use std::path::Path;

pub const BOARD: Rgb<u8> = Rgb([255, 215, 0]);
pub const CORNER: Rgb<u8> = Rgb([255, 140, 0]);
pub const DOT: Rgb<u8> = Rgb([255, 40, 40]);
pub const PREDICTED: Rgb<u8> = Rgb([255, 255, 255]);
pub const LASER: Rgb<u8> = Rgb([255, 0, 255]);
pub const MEASURED: Rgb<u8> = Rgb([0, 255, 120]);

/// What to draw on one thumbnail, in full-resolution pixels.
#[derive(Clone, Debug, Default)]
pub struct Overlay {
    /// Closed outlines (the detected board's grid), drawn in [`BOARD`].
    pub outlines_px: Vec<Vec<Vec2>>,
    /// Small marks (detected corners, row by row), drawn in [`CORNER`] where they are at
    /// least 6 thumbnail pixels apart.
    pub marks_px: Vec<Vec2>,
    /// Marks that stand out (corners left out of a solve), drawn in [`DOT`] always.
    pub bad_marks_px: Vec<Vec2>,
    /// Open polylines (the projected laser line), drawn in [`LASER`].
    pub polylines_px: Vec<Vec<Vec2>>,
    /// Lengths measured on the photo (end to end), drawn in [`MEASURED`].
    pub measured_px: Vec<[Vec2; 2]>,
    /// The dot used, circled in [`DOT`].
    pub dot_px: Option<Vec2>,
    /// Where the fitted line meets this photo's board, a cross in [`PREDICTED`].
    pub predicted_px: Option<Vec2>,
}

#[derive(Debug, thiserror::Error)]
pub enum ThumbnailError {
    #[error("{path}: cannot read the photo for its thumbnail: {message}")]
    Read { path: String, message: String },
    #[error("cannot encode a thumbnail: {0}")]
    Encode(String),
}

/// A drawn thumbnail: JPEG bytes and its size.
pub struct Thumbnail {
    pub jpeg: Vec<u8>,
    pub width_px: u32,
    pub height_px: u32,
}

/// The laser line's image: depths sampled densely, kept where the projection is inside the
/// frame and faithful (far outside it the distortion polynomial folds back).
pub fn laser_image_px(camera: &CameraModel, laser: &LaserLine) -> Vec<Vec<Vec2>> {
    let mut lines = vec![Vec::new()];
    for k in 0..400 {
        let z = 0.1 * (60.0f64).powf(k as f64 / 399.0);
        let p = laser.point_at_depth(z);
        let faithful = camera
            .project(&p)
            .filter(|px| camera.contains(*px))
            .filter(|px| camera.ray(*px).is_some_and(|r| r.angle(&p) < 1e-3));
        match faithful {
            Some(px) => lines.last_mut().expect("never empty").push(px),
            None if !lines.last().expect("never empty").is_empty() => lines.push(Vec::new()),
            None => {}
        }
    }
    lines.retain(|l| l.len() > 1);
    lines
}

/// `photo` scaled to `width_px` wide with `overlay` drawn on it: the thumbnail its run kept
/// from the photo's one decode (`photo::thumbnails`), or, for a photo that run did not
/// decode, read and scaled here.
pub fn draw(photo: &Path, width_px: u32, overlay: &Overlay) -> Result<Thumbnail, ThumbnailError> {
    let kept = match thumbnails::take(photo) {
        Some(k) if k.image.width() == thumbnails::size_px(k.full_width_px, k.full_height_px, width_px).0 => k,
        _ => read_and_scale(photo, width_px)?,
    };
    let mut t = kept.image;
    let (tw, th) = t.dimensions();
    draw_overlay(&mut t, tw as f64 / kept.full_width_px as f64, overlay);
    let mut jpeg = Vec::new();
    image::codecs::jpeg::JpegEncoder::new_with_quality(&mut jpeg, 82)
        .encode_image(&t)
        .map_err(|e| ThumbnailError::Encode(e.to_string()))?;
    Ok(Thumbnail { jpeg, width_px: tw, height_px: th })
}

fn read_and_scale(photo: &Path, width_px: u32) -> Result<Kept, ThumbnailError> {
    let read = |message: String| ThumbnailError::Read { path: photo.display().to_string(), message };
    count(Event::FileRead);
    count(Event::FullDecode);
    let img = ImageReader::open(photo)
        .map_err(|e| read(e.to_string()))?
        .with_guessed_format()
        .map_err(|e| read(e.to_string()))?
        .decode()
        .map_err(|e| read(e.to_string()))?;
    let (w, h) = (img.width(), img.height());
    let (tw, th) = thumbnails::size_px(w, h, width_px);
    Ok(Kept { image: imageops::thumbnail(&img.to_rgb8(), tw, th), full_width_px: w, full_height_px: h })
}

/// Draws on an image scaled by `scale` from the full-resolution photo.
pub fn draw_overlay(img: &mut RgbImage, scale: f64, overlay: &Overlay) {
    // Pixel centres: full-resolution (u, v) sits at scale (u + 0.5) - 0.5 on the thumbnail.
    let map = |p: &Vec2| Vec2::new(scale * (p.x + 0.5) - 0.5, scale * (p.y + 0.5) - 0.5);
    for outline in &overlay.outlines_px {
        let pts: Vec<Vec2> = outline.iter().map(map).collect();
        for k in 0..pts.len() {
            segment(img, pts[k], pts[(k + 1) % pts.len()], 1.0, BOARD);
        }
    }
    // Corners closer than a few thumbnail pixels would only bury the board's squares.
    let spaced = match overlay.marks_px.as_slice() {
        [a, b, ..] => (map(a) - map(b)).norm() >= 6.0,
        _ => true,
    };
    for m in overlay.marks_px.iter().filter(|_| spaced) {
        disc(img, map(m), 1.0, CORNER);
    }
    for m in &overlay.bad_marks_px {
        disc(img, map(m), 1.6, DOT);
    }
    for line in &overlay.polylines_px {
        let pts: Vec<Vec2> = line.iter().map(map).collect();
        for w in pts.windows(2) {
            segment(img, w[0], w[1], 0.8, LASER);
        }
    }
    for [a, b] in &overlay.measured_px {
        let (a, b) = (map(a), map(b));
        segment(img, a, b, 1.0, MEASURED);
        disc(img, a, 2.5, MEASURED);
        disc(img, b, 2.5, MEASURED);
    }
    if let Some(p) = &overlay.predicted_px {
        let c = map(p);
        segment(img, c - Vec2::new(5.0, 5.0), c + Vec2::new(5.0, 5.0), 0.7, PREDICTED);
        segment(img, c - Vec2::new(5.0, -5.0), c + Vec2::new(5.0, -5.0), 0.7, PREDICTED);
    }
    if let Some(p) = &overlay.dot_px {
        ring(img, map(p), 7.0, 1.2, DOT);
    }
}

fn put(img: &mut RgbImage, x: i64, y: i64, c: Rgb<u8>) {
    if x >= 0 && y >= 0 && (x as u32) < img.width() && (y as u32) < img.height() {
        img.put_pixel(x as u32, y as u32, c);
    }
}

/// A filled disc of radius `r` (pixels) at `c`.
fn disc(img: &mut RgbImage, c: Vec2, r: f64, colour: Rgb<u8>) {
    let (x0, x1) = ((c.x - r).floor() as i64, (c.x + r).ceil() as i64);
    let (y0, y1) = ((c.y - r).floor() as i64, (c.y + r).ceil() as i64);
    for y in y0..=y1 {
        for x in x0..=x1 {
            let (dx, dy) = (x as f64 - c.x, y as f64 - c.y);
            if dx * dx + dy * dy <= r * r + 0.25 {
                put(img, x, y, colour);
            }
        }
    }
}

/// A thick segment, stamped as discs every half pixel; far-off ends are clipped first so a
/// line projected from far outside the frame costs no more than one across it.
fn segment(img: &mut RgbImage, a: Vec2, b: Vec2, half_width: f64, colour: Rgb<u8>) {
    let Some((a, b)) = clip(a, b, img.width() as f64, img.height() as f64, half_width + 1.0) else { return };
    let n = ((b - a).norm() * 2.0).ceil().max(1.0) as usize;
    for k in 0..=n {
        disc(img, a + (b - a) * (k as f64 / n as f64), half_width, colour);
    }
}

/// Liang-Barsky clipping of a segment to the image grown by `margin`.
fn clip(a: Vec2, b: Vec2, w: f64, h: f64, margin: f64) -> Option<(Vec2, Vec2)> {
    if !(a.x.is_finite() && a.y.is_finite() && b.x.is_finite() && b.y.is_finite()) {
        return None;
    }
    let d = b - a;
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for (p, q) in [(-d.x, a.x + margin), (d.x, w + margin - a.x), (-d.y, a.y + margin), (d.y, h + margin - a.y)] {
        if p.abs() < 1e-12 {
            if q < 0.0 {
                return None;
            }
        } else {
            let t = q / p;
            if p < 0.0 {
                t0 = t0.max(t);
            } else {
                t1 = t1.min(t);
            }
        }
    }
    (t0 <= t1).then(|| (a + d * t0, a + d * t1))
}

fn ring(img: &mut RgbImage, c: Vec2, r: f64, half_width: f64, colour: Rgb<u8>) {
    let steps = (r * 8.0).ceil() as usize;
    for k in 0..steps {
        let (a0, a1) = (k as f64 / steps as f64, (k + 1) as f64 / steps as f64);
        let p = |t: f64| c + Vec2::new((t * std::f64::consts::TAU).cos(), (t * std::f64::consts::TAU).sin()) * r;
        segment(img, p(a0), p(a1), half_width, colour);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn overlay_lands_where_the_full_resolution_pixels_say() {
        // A 4000x3000 photo shown 400 px wide: scale 0.1.
        let mut img = RgbImage::new(400, 300);
        let overlay = Overlay {
            dot_px: Some(Vec2::new(1999.5, 1499.5)),
            polylines_px: vec![vec![Vec2::new(-50_000.0, 999.5), Vec2::new(50_000.0, 999.5)]],
            ..Overlay::default()
        };
        draw_overlay(&mut img, 0.1, &overlay);
        // The dot ring is centred on thumbnail pixel (199.5, 149.5): radius 7 around it.
        assert_eq!(*img.get_pixel(207, 149), DOT);
        assert_eq!(*img.get_pixel(199, 149), Rgb([0, 0, 0]), "ring, not a disc");
        // The far-off line is clipped, not walked: row 99.5 -> rows 99 and 100.
        assert_eq!(*img.get_pixel(0, 99), LASER);
        assert_eq!(*img.get_pixel(399, 100), LASER);
        assert_eq!(*img.get_pixel(50, 103), Rgb([0, 0, 0]));
    }

    #[test]
    fn clipping_keeps_the_inside_part() {
        let (a, b) = clip(Vec2::new(-100.0, 5.0), Vec2::new(100.0, 5.0), 10.0, 10.0, 0.0).unwrap();
        assert!((a.x - 0.0).abs() < 1e-9 && (b.x - 10.0).abs() < 1e-9);
        assert!(clip(Vec2::new(-100.0, 50.0), Vec2::new(100.0, 50.0), 10.0, 10.0, 0.0).is_none());
    }
}
