//! Finding the laser dot in a photo.
//!
//! Not the brightest and not the greenest pixel: the FishSense lab's worst lengths (+137%)
//! came from dots taken on the laser's reflection, and sun glints on a slate or bubbles are
//! brighter than a far dot. The detector looks for compact blobs of *green excess over the
//! local background* (a 532 nm dot is green where it is not saturated; its saturated white
//! core is counted only where a green halo surrounds it), only inside a search region (the
//! target, and once a laser fit exists, a band around the laser's image), and returns a
//! ranked list of candidates so the caller can pick by geometry rather than brightness.
//!
//! Pure Rust on an image view: the vision module hands in the pixels.

use fslcal_core::Vec2;

/// An 8-bit level at or above which a channel is taken as clipped (JPEG rounding keeps
/// clipped pixels a few levels below 255).
const CLIPPED: i32 = 250;

/// Channel order of an interleaved 8-bit 3-channel image.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ChannelOrder {
    Rgb,
    Bgr,
}

/// A borrowed interleaved 8-bit colour image.
#[derive(Clone, Copy, Debug)]
pub struct ColourView<'a> {
    pub width: usize,
    pub height: usize,
    /// Bytes from one row to the next.
    pub stride: usize,
    pub order: ChannelOrder,
    pub data: &'a [u8],
}

impl ColourView<'_> {
    #[inline]
    fn rgb(&self, x: usize, y: usize) -> (i32, i32, i32) {
        let i = y * self.stride + 3 * x;
        let (a, b, c) = (self.data[i] as i32, self.data[i + 1] as i32, self.data[i + 2] as i32);
        match self.order {
            ChannelOrder::Rgb => (a, b, c),
            ChannelOrder::Bgr => (c, b, a),
        }
    }
}

/// Where to look.
#[derive(Clone, Debug, Default)]
pub struct SearchRegion {
    /// Convex polygon in pixels (the target's outline, padded). Empty: the whole image.
    pub polygon: Vec<Vec2>,
    /// Optional band around the predicted laser image: a polyline and a half-width in px.
    pub band: Option<(Vec<Vec2>, f64)>,
}

/// One dot-like blob.
#[derive(Clone, Debug, PartialEq)]
pub struct DotCandidate {
    /// Sub-pixel centre (pixel-centre convention).
    pub pixel: Vec2,
    /// Matched-filter signal-to-noise of the blob's green excess.
    pub snr: f64,
    /// Peak green excess over the local background, in 8-bit levels.
    pub peak_green: f64,
    /// Equivalent radius of the blob in pixels.
    pub radius_px: f64,
    /// True when the blob has a saturated core inside its green halo (a near dot).
    pub saturated_core: bool,
}

/// Tuning of the detector; the defaults suit 8-bit photos from 640 px to 4000 px wide.
#[derive(Clone, Debug)]
pub struct DotDetectorParams {
    /// A candidate's green excess must exceed this many robust noise sigmas...
    pub threshold_sigma: f64,
    /// ...and at least this many 8-bit levels.
    pub min_excess_levels: f64,
    /// Candidates below this matched-filter SNR are not returned.
    pub min_snr: f64,
    /// Blobs larger than this (px) are scenery (green algae, a green slate), not a dot.
    pub max_area_px: usize,
    /// Half-size of the background window, px.
    pub background_radius_px: usize,
}

impl Default for DotDetectorParams {
    fn default() -> Self {
        DotDetectorParams {
            threshold_sigma: 5.0,
            min_excess_levels: 10.0,
            min_snr: 8.0,
            max_area_px: 20_000,
            background_radius_px: 40,
        }
    }
}

impl DotDetectorParams {
    /// The same detector made more sensitive, for a second look where a dot is expected (a
    /// small region, or a narrow band around the laser's image): far, faint dots in murky
    /// water fall below the first search's threshold.
    pub fn sensitive(&self) -> DotDetectorParams {
        DotDetectorParams { threshold_sigma: 3.5, min_excess_levels: 5.0, min_snr: 5.0, ..self.clone() }
    }
}

fn point_in_convex_polygon(poly: &[Vec2], p: Vec2) -> bool {
    if poly.len() < 3 {
        return true;
    }
    let mut sign = 0.0f64;
    for i in 0..poly.len() {
        let a = poly[i];
        let b = poly[(i + 1) % poly.len()];
        let cross = (b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x);
        if cross.abs() < 1e-12 {
            continue;
        }
        if sign == 0.0 {
            sign = cross.signum();
        } else if cross.signum() != sign {
            return false;
        }
    }
    true
}

/// Distance from `p` to a polyline.
pub fn distance_to_polyline(line: &[Vec2], p: Vec2) -> f64 {
    match line.len() {
        0 => f64::INFINITY,
        1 => (line[0] - p).norm(),
        _ => line
            .windows(2)
            .map(|w| {
                let (a, b) = (w[0], w[1]);
                let ab = b - a;
                let t = ((p - a).dot(&ab) / ab.norm_squared().max(1e-12)).clamp(0.0, 1.0);
                (a + ab * t - p).norm()
            })
            .fold(f64::INFINITY, f64::min),
    }
}

/// Finds up to `max` dot candidates, best first.
pub fn find_dot_candidates(
    img: &ColourView,
    region: &SearchRegion,
    params: &DotDetectorParams,
    max: usize,
) -> Vec<DotCandidate> {
    // Region of interest: the polygon's bounding box, clipped to the image.
    let (mut x0, mut y0, mut x1, mut y1) = (0usize, 0usize, img.width, img.height);
    if region.polygon.len() >= 3 {
        let minx = region.polygon.iter().map(|p| p.x).fold(f64::INFINITY, f64::min);
        let maxx = region.polygon.iter().map(|p| p.x).fold(f64::NEG_INFINITY, f64::max);
        let miny = region.polygon.iter().map(|p| p.y).fold(f64::INFINITY, f64::min);
        let maxy = region.polygon.iter().map(|p| p.y).fold(f64::NEG_INFINITY, f64::max);
        x0 = minx.floor().clamp(0.0, img.width as f64) as usize;
        x1 = (maxx.ceil() + 1.0).clamp(0.0, img.width as f64) as usize;
        y0 = miny.floor().clamp(0.0, img.height as f64) as usize;
        y1 = (maxy.ceil() + 1.0).clamp(0.0, img.height as f64) as usize;
    }
    if x1 <= x0 + 4 || y1 <= y0 + 4 {
        return Vec::new();
    }
    let (w, h) = (x1 - x0, y1 - y0);

    // Green excess g = G - max(R, B), and saturation, over the ROI.
    let mut g = vec![0i32; w * h];
    let mut saturated = vec![false; w * h];
    for y in 0..h {
        for x in 0..w {
            let (r, gg, b) = img.rgb(x0 + x, y0 + y);
            g[y * w + x] = gg - r.max(b);
            // The laser's green clips first; a clipped green channel shows no green excess
            // however bright the dot is, so it counts as core.
            saturated[y * w + x] = gg >= CLIPPED;
        }
    }

    // Local background of g: box mean via an integral image. The window is much larger than
    // a dot, so a dot barely lifts its own background.
    let mut integral = vec![0i64; (w + 1) * (h + 1)];
    for y in 0..h {
        let mut row = 0i64;
        for x in 0..w {
            row += g[y * w + x] as i64;
            integral[(y + 1) * (w + 1) + x + 1] = integral[y * (w + 1) + x + 1] + row;
        }
    }
    let r = params.background_radius_px;
    let mut excess = vec![0f32; w * h];
    for y in 0..h {
        let ya = y.saturating_sub(r);
        let yb = (y + r + 1).min(h);
        for x in 0..w {
            let xa = x.saturating_sub(r);
            let xb = (x + r + 1).min(w);
            let sum = integral[yb * (w + 1) + xb] - integral[ya * (w + 1) + xb] - integral[yb * (w + 1) + xa]
                + integral[ya * (w + 1) + xa];
            let n = ((yb - ya) * (xb - xa)) as f32;
            excess[y * w + x] = g[y * w + x] as f32 - sum as f32 / n;
        }
    }

    // Robust noise of the excess: median absolute deviation over a subsample.
    let mut sample: Vec<f32> = excess.iter().step_by(7).copied().collect();
    let sigma = if sample.is_empty() {
        1.0
    } else {
        let mid = sample.len() / 2;
        let med = *sample.select_nth_unstable_by(mid, |a, b| a.total_cmp(b)).1;
        for s in sample.iter_mut() {
            *s = (*s - med).abs();
        }
        let mad = *sample.select_nth_unstable_by(mid, |a, b| a.total_cmp(b)).1;
        (1.4826 * mad as f64).max(0.5)
    };
    let threshold = (params.threshold_sigma * sigma).max(params.min_excess_levels) as f32;

    // Blob mask: green excess above threshold, plus saturated pixels (the white core of a
    // near dot has no green excess of its own).
    let inside =
        |x: usize, y: usize| point_in_convex_polygon(&region.polygon, Vec2::new((x0 + x) as f64, (y0 + y) as f64));
    let mut label = vec![0u32; w * h];
    let mut candidates = Vec::new();
    let mut stack = Vec::new();
    let mut next = 1u32;
    for start in 0..w * h {
        if label[start] != 0 || excess[start] < threshold {
            continue;
        }
        let (sx, sy) = (start % w, start / w);
        if !inside(sx, sy) {
            continue;
        }
        // Flood fill over (excess > threshold/2 or saturated), 8-connected.
        let id = next;
        next += 1;
        label[start] = id;
        stack.push(start);
        let mut pixels = Vec::new();
        while let Some(i) = stack.pop() {
            pixels.push(i);
            if pixels.len() > params.max_area_px {
                break;
            }
            let (x, y) = (i % w, i / w);
            for dy in -1i32..=1 {
                for dx in -1i32..=1 {
                    let (nx, ny) = (x as i32 + dx, y as i32 + dy);
                    if nx < 0 || ny < 0 || nx >= w as i32 || ny >= h as i32 {
                        continue;
                    }
                    let j = ny as usize * w + nx as usize;
                    if label[j] == 0 && (excess[j] >= threshold * 0.5 || saturated[j]) {
                        label[j] = id;
                        stack.push(j);
                    }
                }
            }
        }
        stack.clear();
        if pixels.len() > params.max_area_px || pixels.len() < 2 {
            continue;
        }
        let sat_count = pixels.iter().filter(|&&i| saturated[i]).count();
        let green: Vec<f32> = pixels.iter().filter(|&&i| !saturated[i]).map(|&i| excess[i].max(0.0)).collect();
        if green.is_empty() {
            continue;
        }
        let peak = green.iter().copied().fold(0f32, f32::max) as f64;
        let mass: f64 = green.iter().map(|&e| e as f64).sum();
        // Matched-filter SNR of the green halo; the core counts as signal at the peak level.
        let snr = (mass + sat_count as f64 * peak) / (sigma * (pixels.len() as f64).sqrt());
        // A white glint has saturated pixels and at most a thin green fringe: demand that the
        // green part be substantial where a core exists.
        if sat_count > 0 && green.len() < sat_count / 2 {
            continue;
        }
        // Elongated blobs are edges or streaks, not a dot.
        let (mut mnx, mut mxx, mut mny, mut mxy) = (usize::MAX, 0, usize::MAX, 0);
        for &i in &pixels {
            let (x, y) = (i % w, i / w);
            mnx = mnx.min(x);
            mxx = mxx.max(x);
            mny = mny.min(y);
            mxy = mxy.max(y);
        }
        let (bw, bh) = ((mxx - mnx + 1) as f64, (mxy - mny + 1) as f64);
        if bw.max(bh) / bw.min(bh) > 3.0 || (pixels.len() as f64) < 0.3 * bw * bh {
            continue;
        }
        // Centre: intensity-weighted centroid of the blob (the core weighted at the peak),
        // over the blob's pixels grown by two, so the weights fall off symmetrically.
        let bbox = (mnx, mxx, mny, mxy);
        let (cx, cy) = weighted_centre(&excess, &saturated, (w, h), &label, id, bbox, peak as f32, threshold);
        let rough = Vec2::new((x0 as f64) + cx, (y0 as f64) + cy);
        let radius = (pixels.len() as f64 / core::f64::consts::PI).sqrt();
        let centre = refine_centre(img, rough, radius).unwrap_or(rough);
        if let Some((line, half)) = &region.band {
            if distance_to_polyline(line, centre) > *half {
                continue;
            }
        }
        if snr < params.min_snr {
            continue;
        }
        candidates.push(DotCandidate {
            pixel: centre,
            snr,
            peak_green: peak,
            radius_px: (pixels.len() as f64 / core::f64::consts::PI).sqrt(),
            saturated_core: sat_count > 0,
        });
    }
    candidates.sort_by(|a, b| b.snr.total_cmp(&a.snr));
    candidates.truncate(max);
    candidates
}

/// Re-centres a dot against a background model that the checkerboard cannot bias.
///
/// Under water, the board's colour in each channel is an affine function of its albedo
/// (attenuated light plus backscatter veil), so across black and white squares green is an
/// affine function of blue: `G = a + b B`. Fitted on a ring around the dot, that model
/// predicts the background under the dot even where the dot straddles a square's edge,
/// which a local mean cannot (it pulls the centre toward the white square by up to a
/// pixel). The laser adds much more green than blue, so `G - (a + b B)` is the dot alone.
/// The centroid is taken over a disc centred on the current estimate, three times, so the
/// window is symmetric about the answer.
fn refine_centre(img: &ColourView, rough: Vec2, blob_radius_px: f64) -> Option<Vec2> {
    let r_in = blob_radius_px * 1.6 + 3.0;
    let (ring_a, ring_b) = (r_in + 2.0, r_in + 6.0);
    let mut c = rough;
    for _ in 0..3 {
        let x0 = (c.x - ring_b).floor() as i64;
        let x1 = (c.x + ring_b).ceil() as i64;
        let y0 = (c.y - ring_b).floor() as i64;
        let y1 = (c.y + ring_b).ceil() as i64;
        if x0 < 0 || y0 < 0 || x1 >= img.width as i64 || y1 >= img.height as i64 {
            return None;
        }
        // Least squares G = a + b B on the ring (unsaturated pixels only).
        let (mut n, mut sb, mut sg, mut sbb, mut sbg) = (0f64, 0f64, 0f64, 0f64, 0f64);
        for y in y0..=y1 {
            for x in x0..=x1 {
                let d = ((x as f64 - c.x).powi(2) + (y as f64 - c.y).powi(2)).sqrt();
                if d < ring_a || d > ring_b {
                    continue;
                }
                let (_, g, b) = img.rgb(x as usize, y as usize);
                if g >= CLIPPED || b >= CLIPPED {
                    continue;
                }
                let (g, b) = (g as f64, b as f64);
                n += 1.0;
                sb += b;
                sg += g;
                sbb += b * b;
                sbg += b * g;
            }
        }
        if n < 12.0 {
            return None;
        }
        let var_b = sbb / n - (sb / n).powi(2);
        // A uniform ring gives no slope: fall back to a constant background.
        let slope = if var_b > 4.0 { ((sbg / n - sb / n * sg / n) / var_b).clamp(0.0, 3.0) } else { 0.0 };
        let offset = sg / n - slope * sb / n;
        let residual = |g: f64, b: f64| g - (offset + slope * b);
        let mut ss = 0.0;
        for y in y0..=y1 {
            for x in x0..=x1 {
                let d = ((x as f64 - c.x).powi(2) + (y as f64 - c.y).powi(2)).sqrt();
                if d >= ring_a && d <= ring_b {
                    let (_, g, b) = img.rgb(x as usize, y as usize);
                    ss += residual(g as f64, b as f64).powi(2);
                }
            }
        }
        let floor = 2.0 * (ss / n).sqrt();
        let mut peak = 0f64;
        let mut acc = (0f64, 0f64, 0f64);
        let mut saturated = Vec::new();
        for y in y0..=y1 {
            for x in x0..=x1 {
                let d = ((x as f64 - c.x).powi(2) + (y as f64 - c.y).powi(2)).sqrt();
                if d > r_in {
                    continue;
                }
                let (_, g, b) = img.rgb(x as usize, y as usize);
                if g >= CLIPPED {
                    saturated.push((x as f64, y as f64));
                    continue;
                }
                let e = residual(g as f64, b as f64);
                peak = peak.max(e);
                let w = e - floor;
                if w > 0.0 {
                    acc = (acc.0 + w, acc.1 + w * x as f64, acc.2 + w * y as f64);
                }
            }
        }
        // A faint dot (nothing clipped) is found better by a matched filter than by a
        // thresholded centroid, whose few surviving pixels are at the noise's mercy.
        if saturated.is_empty() {
            let found = matched_filter_peak(img, c, r_in, blob_radius_px, &residual)?;
            let moved = (found - c).norm();
            c = found;
            if moved > r_in {
                return None;
            }
            if moved < 1e-3 {
                break;
            }
            continue;
        }
        // The clipped core carries at least the brightest unclipped level.
        let core_w = (peak - floor).max(1.0);
        for (x, y) in saturated {
            acc = (acc.0 + core_w, acc.1 + core_w * x, acc.2 + core_w * y);
        }
        if acc.0 <= 0.0 {
            return None;
        }
        let next = Vec2::new(acc.1 / acc.0, acc.2 / acc.0);
        let moved = (next - c).norm();
        c = next;
        if moved > r_in {
            return None;
        }
        if moved < 1e-3 {
            break;
        }
    }
    Some(c)
}

/// Location of the peak of the dot signal `signal(G, B)` smoothed by a Gaussian the size of
/// the dot, within `reach` of `c`, to sub-pixel by a quadratic through the peak's
/// neighbours. For a known spot shape in white noise this is the maximum-likelihood centre.
fn matched_filter_peak(
    img: &ColourView,
    c: Vec2,
    reach: f64,
    blob_radius_px: f64,
    signal: &dyn Fn(f64, f64) -> f64,
) -> Option<Vec2> {
    let sigma = (0.7 * blob_radius_px).clamp(1.0, 4.0);
    let k = (3.0 * sigma).ceil() as i64;
    let half = reach.ceil() as i64 + k + 1;
    let (cx, cy) = (c.x.round() as i64, c.y.round() as i64);
    if cx - half < 0 || cy - half < 0 || cx + half >= img.width as i64 || cy + half >= img.height as i64 {
        return None;
    }
    let n = (2 * half + 1) as usize;
    let mut e = vec![0f64; n * n];
    for y in 0..n {
        for x in 0..n {
            let (_, g, b) = img.rgb((cx - half) as usize + x, (cy - half) as usize + y);
            e[y * n + x] = signal(g as f64, b as f64);
        }
    }
    let kernel: Vec<f64> = (-k..=k).map(|i| (-0.5 * (i as f64 / sigma).powi(2)).exp()).collect();
    let smooth = |data: &[f64], horizontal: bool| -> Vec<f64> {
        let mut out = vec![0f64; n * n];
        for y in 0..n {
            for x in 0..n {
                let mut acc = 0.0;
                for (t, w) in kernel.iter().enumerate() {
                    let o = t as i64 - k;
                    let (xx, yy) = if horizontal { (x as i64 + o, y as i64) } else { (x as i64, y as i64 + o) };
                    if xx >= 0 && yy >= 0 && (xx as usize) < n && (yy as usize) < n {
                        acc += w * data[yy as usize * n + xx as usize];
                    }
                }
                out[y * n + x] = acc;
            }
        }
        out
    };
    let f = smooth(&smooth(&e, true), false);
    let lim = reach.ceil() as i64;
    let (mut best, mut bx, mut by) = (f64::NEG_INFINITY, 0i64, 0i64);
    for dy in -lim..=lim {
        for dx in -lim..=lim {
            if (dx * dx + dy * dy) as f64 > reach * reach {
                continue;
            }
            let v = f[((half + dy) as usize) * n + (half + dx) as usize];
            if v > best {
                (best, bx, by) = (v, dx, dy);
            }
        }
    }
    let at = |dx: i64, dy: i64| f[((half + dy) as usize) * n + (half + dx) as usize];
    let vertex = |m: f64, z: f64, p: f64| {
        let d = m - 2.0 * z + p;
        if d < 0.0 {
            (0.5 * (m - p) / d).clamp(-0.5, 0.5)
        } else {
            0.0
        }
    };
    let ox = vertex(at(bx - 1, by), best, at(bx + 1, by));
    let oy = vertex(at(bx, by - 1), best, at(bx, by + 1));
    Some(Vec2::new((cx + bx) as f64 + ox, (cy + by) as f64 + oy))
}

#[allow(clippy::too_many_arguments)]
fn weighted_centre(
    excess: &[f32],
    saturated: &[bool],
    (w, h): (usize, usize),
    label: &[u32],
    id: u32,
    (mnx, mxx, mny, mxy): (usize, usize, usize, usize),
    peak: f32,
    threshold: f32,
) -> (f64, f64) {
    let grow = 2;
    let (ax, bx) = (mnx.saturating_sub(grow), (mxx + grow + 1).min(w));
    let (ay, by) = (mny.saturating_sub(grow), (mxy + grow + 1).min(h));
    // Subtract a floor so background noise around the blob adds no pull toward the box
    // centre, but keep the halo's tails that lie above it.
    let floor = 0.25 * threshold;
    let (mut sw, mut sx, mut sy) = (0f64, 0f64, 0f64);
    for y in ay..by {
        for x in ax..bx {
            let i = y * w + x;
            let wt = if saturated[i] && (label[i] == id) { peak - floor } else { excess[i] - floor };
            if wt > 0.0 && (label[i] == id || label[i] == 0) {
                sw += wt as f64;
                sx += wt as f64 * x as f64;
                sy += wt as f64 * y as f64;
            }
        }
    }
    if sw <= 0.0 {
        return (0.5 * (mnx + mxx) as f64, 0.5 * (mny + mxy) as f64);
    }
    (sx / sw, sy / sw)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A blue-green background with a Gaussian green dot and a white glint.
    fn synthetic(dot: Vec2, glint: Vec2, with_core: bool) -> (Vec<u8>, usize, usize) {
        let (w, h) = (200usize, 150usize);
        let mut data = vec![0u8; w * h * 3];
        for y in 0..h {
            for x in 0..w {
                let d2 = (x as f64 - dot.x).powi(2) + (y as f64 - dot.y).powi(2);
                let halo = 140.0 * (-d2 / (2.0 * 4.0f64.powi(2))).exp();
                let core = if with_core { 300.0 * (-d2 / (2.0 * 1.5f64.powi(2))).exp() } else { 0.0 };
                let gd2 = (x as f64 - glint.x).powi(2) + (y as f64 - glint.y).powi(2);
                let gl = 400.0 * (-gd2 / (2.0 * 3.0f64.powi(2))).exp();
                let (r, g, b) = (20.0 + core + gl, 90.0 + halo + core + gl, 100.0 + core + gl);
                let i = (y * w + x) * 3;
                data[i] = r.min(255.0) as u8;
                data[i + 1] = g.min(255.0) as u8;
                data[i + 2] = b.min(255.0) as u8;
            }
        }
        (data, w, h)
    }

    #[test]
    fn finds_the_green_dot_not_the_brighter_white_glint() {
        let truth = Vec2::new(61.3, 80.7);
        let (data, w, h) = synthetic(truth, Vec2::new(150.0, 40.0), true);
        let view = ColourView { width: w, height: h, stride: w * 3, order: ChannelOrder::Rgb, data: &data };
        let c = find_dot_candidates(&view, &SearchRegion::default(), &DotDetectorParams::default(), 4);
        assert_eq!(c.len(), 1, "{c:?}");
        assert!(c[0].saturated_core);
        assert!((c[0].pixel - truth).norm() < 0.15, "{:?}", c[0].pixel);
    }

    #[test]
    fn region_and_band_exclude_the_dot() {
        let truth = Vec2::new(61.3, 80.7);
        let (data, w, h) = synthetic(truth, Vec2::new(150.0, 40.0), false);
        let view = ColourView { width: w, height: h, stride: w * 3, order: ChannelOrder::Rgb, data: &data };
        let p = DotDetectorParams::default();
        let right_half = SearchRegion {
            polygon: vec![
                Vec2::new(100.0, 0.0),
                Vec2::new(199.0, 0.0),
                Vec2::new(199.0, 149.0),
                Vec2::new(100.0, 149.0),
            ],
            band: None,
        };
        assert!(find_dot_candidates(&view, &right_half, &p, 4).is_empty());
        let band =
            SearchRegion { polygon: vec![], band: Some((vec![Vec2::new(0.0, 10.0), Vec2::new(199.0, 10.0)], 20.0)) };
        assert!(find_dot_candidates(&view, &band, &p, 4).is_empty());
        let band =
            SearchRegion { polygon: vec![], band: Some((vec![Vec2::new(0.0, 75.0), Vec2::new(199.0, 85.0)], 20.0)) };
        let c = find_dot_candidates(&view, &band, &p, 4);
        assert_eq!(c.len(), 1);
        assert!((c[0].pixel - truth).norm() < 0.15, "{:?}", c[0].pixel);
    }
}
