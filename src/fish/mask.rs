//! A binary fish mask (fish pixels non-zero) and the raster operations the end-point finder
//! needs: the largest 8-connected piece, reduction, and the exact Euclidean distance to the
//! background.

use super::FishError;
use std::collections::VecDeque;
use std::path::Path;

/// A binary image, row-major, `true` on the fish.
#[derive(Clone, Debug, PartialEq)]
pub struct Mask {
    pub width: usize,
    pub height: usize,
    pub bits: Vec<bool>,
}

impl Mask {
    pub fn new(width: usize, height: usize) -> Mask {
        Mask { width, height, bits: vec![false; width * height] }
    }

    /// Reads a mask image (PNG, JPEG or anything `image` decodes): non-zero is fish. A
    /// colour image counts a pixel as fish when any channel is non-zero.
    pub fn load(path: &Path) -> Result<Mask, FishError> {
        let name = path.display().to_string();
        let img = image::open(path).map_err(|e| FishError::Mask { path: name.clone(), why: e.to_string() })?;
        let (w, h) = (img.width() as usize, img.height() as usize);
        // The usual 8-bit masks straight from the decoded bytes: converting a 12-megapixel
        // mask to a new grey or RGB image first took 25-35 ms of a 35 ms load.
        let bits: Vec<bool> = match &img {
            image::DynamicImage::ImageLuma8(g) => g.as_raw().iter().map(|&v| v > 0).collect(),
            image::DynamicImage::ImageRgb8(c) => c.as_raw().chunks_exact(3).map(|p| (p[0] | p[1] | p[2]) > 0).collect(),
            image::DynamicImage::ImageRgba8(c) => {
                c.as_raw().chunks_exact(4).map(|p| (p[0] | p[1] | p[2]) > 0).collect()
            }
            other if other.color().has_color() => {
                other.to_rgb8().pixels().map(|p| p.0.iter().any(|&c| c > 0)).collect()
            }
            other => other.to_luma8().pixels().map(|p| p.0[0] > 0).collect(),
        };
        let mask = Mask { width: w, height: h, bits };
        if mask.count() == 0 {
            return Err(FishError::Mask { path: name, why: "no fish pixels (expected non-zero on the fish)".into() });
        }
        Ok(mask)
    }

    #[inline]
    pub fn get(&self, x: usize, y: usize) -> bool {
        self.bits[y * self.width + x]
    }

    /// Whether `(x, y)` (signed) is inside the image and on the fish.
    #[inline]
    pub fn at(&self, x: i64, y: i64) -> bool {
        x >= 0 && y >= 0 && (x as usize) < self.width && (y as usize) < self.height && self.get(x as usize, y as usize)
    }

    pub fn count(&self) -> usize {
        self.bits.iter().filter(|&&b| b).count()
    }

    /// Pixels on the fish as `(x, y)`.
    pub fn pixels(&self) -> impl Iterator<Item = (usize, usize)> + '_ {
        self.bits.iter().enumerate().filter(|(_, &b)| b).map(move |(i, _)| (i % self.width, i / self.width))
    }

    /// The largest 8-connected piece: a segmenter's stray blobs (bubbles, a second fish's
    /// fin) would otherwise pull the principal axis and the extremes.
    pub fn largest_component(&self) -> Mask {
        let (w, h) = (self.width, self.height);
        let mut label = vec![0u32; w * h];
        let mut best = (0u32, 0usize);
        let mut queue = VecDeque::new();
        let mut next = 0u32;
        for start in 0..w * h {
            if !self.bits[start] || label[start] != 0 {
                continue;
            }
            next += 1;
            label[start] = next;
            queue.push_back(start);
            let mut size = 0;
            while let Some(i) = queue.pop_front() {
                size += 1;
                let (x, y) = ((i % w) as i64, (i / w) as i64);
                for dy in -1..=1 {
                    for dx in -1..=1 {
                        let (nx, ny) = (x + dx, y + dy);
                        if self.at(nx, ny) {
                            let j = ny as usize * w + nx as usize;
                            if label[j] == 0 {
                                label[j] = next;
                                queue.push_back(j);
                            }
                        }
                    }
                }
            }
            if size > best.1 {
                best = (next, size);
            }
        }
        Mask { width: w, height: h, bits: label.iter().map(|&l| l == best.0 && l != 0).collect() }
    }

    /// The `width x height` window with its top-left pixel at `(x0, y0)` (inside the mask).
    pub fn crop(&self, x0: usize, y0: usize, width: usize, height: usize) -> Mask {
        let mut out = Mask::new(width, height);
        for y in 0..height {
            let row = (y0 + y) * self.width + x0;
            out.bits[y * width..(y + 1) * width].copy_from_slice(&self.bits[row..row + width]);
        }
        out
    }

    /// Whether the fish comes within `margin_px` of the image border: part of it may be
    /// outside the frame (segmenters stop a few pixels short of the edge).
    pub fn near_border(&self, margin_px: usize) -> bool {
        let (w, h) = (self.width, self.height);
        self.pixels().any(|(x, y)| x <= margin_px || y <= margin_px || x + margin_px >= w - 1 || y + margin_px >= h - 1)
    }

    /// Reduced by `factor`: a block is fish when at least half its pixels are. A reduced
    /// pixel `i` stands for full-resolution `factor * i + (factor - 1) / 2`
    /// (docs/conventions.md).
    pub fn reduce(&self, factor: usize) -> Mask {
        if factor <= 1 {
            return self.clone();
        }
        let (w, h) = (self.width.div_ceil(factor), self.height.div_ceil(factor));
        let mut counts = vec![0u32; w * h];
        for (x, y) in self.pixels() {
            counts[(y / factor) * w + x / factor] += 1;
        }
        let half = (factor * factor).div_ceil(2) as u32;
        Mask { width: w, height: h, bits: counts.iter().map(|&c| c >= half).collect() }
    }

    /// Morphological opening with a disc of radius `radius_px`, given this mask's
    /// [`Mask::distance_to_background`]: what remains is the thick body, without thin fins
    /// and fin lobes.
    pub fn opened(&self, clearance: &[f64], radius_px: f64) -> Mask {
        let pad = radius_px.ceil() as usize + 1;
        let (pw, ph) = (self.width + 2 * pad, self.height + 2 * pad);
        // Background of `far` = the eroded core; its distance transform is the distance to it.
        let mut far = Mask { width: pw, height: ph, bits: vec![true; pw * ph] };
        for y in 0..self.height {
            for x in 0..self.width {
                if clearance[y * self.width + x] > radius_px {
                    far.bits[(y + pad) * pw + x + pad] = false;
                }
            }
        }
        let to_core = far.distance_to_background();
        let mut out = Mask::new(self.width, self.height);
        for y in 0..self.height {
            for x in 0..self.width {
                out.bits[y * self.width + x] = self.get(x, y) && to_core[(y + pad) * pw + x + pad] <= radius_px;
            }
        }
        out
    }

    /// Exact Euclidean distance from each fish pixel to the nearest background pixel (0 on
    /// the background; the image outside counts as background), by Felzenszwalb and
    /// Huttenlocher's two-pass lower envelope of parabolas.
    pub fn distance_to_background(&self) -> Vec<f64> {
        let (w, h) = (self.width, self.height);
        let inf = 1e20;
        // Pad by one pixel of background so the frame edge counts as outside.
        let (pw, ph) = (w + 2, h + 2);
        let mut d: Vec<f64> = vec![0.0; pw * ph];
        for y in 0..h {
            for x in 0..w {
                if self.get(x, y) {
                    d[(y + 1) * pw + x + 1] = inf;
                }
            }
        }
        let mut f = vec![0.0; pw.max(ph)];
        let mut out = vec![0.0; pw.max(ph)];
        for x in 0..pw {
            for y in 0..ph {
                f[y] = d[y * pw + x];
            }
            squared_distance_1d(&f[..ph], &mut out[..ph]);
            for y in 0..ph {
                d[y * pw + x] = out[y];
            }
        }
        for y in 0..ph {
            f[..pw].copy_from_slice(&d[y * pw..(y + 1) * pw]);
            squared_distance_1d(&f[..pw], &mut out[..pw]);
            d[y * pw..(y + 1) * pw].copy_from_slice(&out[..pw]);
        }
        let mut dist = vec![0.0; w * h];
        for y in 0..h {
            for x in 0..w {
                dist[y * w + x] = d[(y + 1) * pw + x + 1].sqrt();
            }
        }
        dist
    }
}

/// 1-D squared distance transform of a sampled function (Felzenszwalb & Huttenlocher 2012).
fn squared_distance_1d(f: &[f64], out: &mut [f64]) {
    let n = f.len();
    let mut v = vec![0usize; n];
    let mut z = vec![0.0f64; n + 1];
    let mut k = 0usize;
    z[0] = f64::NEG_INFINITY;
    z[1] = f64::INFINITY;
    let meet = |q: usize, p: usize| ((f[q] + (q * q) as f64) - (f[p] + (p * p) as f64)) / (2.0 * (q as f64 - p as f64));
    for q in 1..n {
        let mut s = meet(q, v[k]);
        // z[0] is minus infinity, so this stops at k = 0.
        while s <= z[k] {
            k -= 1;
            s = meet(q, v[k]);
        }
        k += 1;
        v[k] = q;
        z[k] = s;
        z[k + 1] = f64::INFINITY;
    }
    k = 0;
    for (q, o) in out.iter_mut().enumerate() {
        while z[k + 1] < q as f64 {
            k += 1;
        }
        let p = v[k];
        *o = (q as f64 - p as f64).powi(2) + f[p];
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distance_transform_is_exact_on_a_disc() {
        let mut m = Mask::new(61, 61);
        for y in 0..61 {
            for x in 0..61 {
                m.bits[y * 61 + x] = ((x as f64 - 30.0).powi(2) + (y as f64 - 30.0).powi(2)).sqrt() <= 20.0;
            }
        }
        let d = m.distance_to_background();
        // The nearest background pixel to the centre is (50, 31): sqrt(401).
        assert!((d[30 * 61 + 30] - 401f64.sqrt()).abs() < 1e-9, "{}", d[30 * 61 + 30]);
        assert_eq!(d[0], 0.0);
        // Brute force on a few pixels.
        for &(x, y) in &[(30usize, 15usize), (22, 40), (45, 31)] {
            let brute = (0..61 * 61)
                .filter(|&i| !m.bits[i])
                .map(|i| (((i % 61) as f64 - x as f64).powi(2) + ((i / 61) as f64 - y as f64).powi(2)).sqrt())
                .fold(f64::INFINITY, f64::min);
            assert!((d[y * 61 + x] - brute).abs() < 1e-9, "({x},{y}) {} vs {brute}", d[y * 61 + x]);
        }
    }

    #[test]
    fn largest_component_drops_stray_blobs_and_border_is_seen() {
        let mut m = Mask::new(20, 10);
        for x in 2..12 {
            m.bits[5 * 20 + x] = true;
        }
        m.bits[20 + 17] = true;
        let c = m.largest_component();
        assert_eq!(c.count(), 10);
        assert!(!c.near_border(0) && c.near_border(2));
        m.bits[9 * 20 + 19] = true;
        assert!(m.near_border(0));
        assert_eq!(m.reduce(2).width, 10);
    }
}
