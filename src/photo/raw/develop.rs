//! From sensor samples to pictures: bilinear demosaic, the thesis's grey-world balance
//! (§2.4.1: each channel divided by its mean), and the sRGB tone curve for people and for the
//! board search. The dot detector gets a *linear* view instead, unbalanced, where 255 means
//! the sensor clipped: saturation and the dot's true colour survive only there.
//!
//! Everything streams row by row from the frame into the caller's buffers, so developing a
//! 4000x3000 photo holds the samples (24 MB) and the outputs, never a float copy.

use super::RawFrame;
use crate::photo::counter::{count, Event};

/// Grey-world gains: each channel scaled so its mean equals the mean of the three channel
/// means (the thesis divides by each mean; keeping the overall mean keeps the exposure).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GreyWorld {
    /// Mean linear level of R, G, B sites over the picture (1.0 = white level).
    pub channel_means: [f64; 3],
    pub gains: [f32; 3],
}

/// A gain above this is amplifying noise in a channel the water absorbed entirely.
const MAX_GAIN: f64 = 16.0;

impl GreyWorld {
    pub fn of(frame: &RawFrame) -> GreyWorld {
        let mut sums = [0f64; 3];
        let mut counts = [0u64; 3];
        for y in 0..frame.height {
            let row = frame.picture_row(y);
            for parity in 0..2 {
                let site = (y & 1) * 2 + parity;
                let c = frame.pattern[site] as usize;
                let black = frame.black[site];
                // Sum raw samples, subtract the black once: the per-pixel `max(0)` of
                // noise below black is negligible for a mean and this is the hot loop.
                let s: u64 = row.iter().skip(parity).step_by(2).map(|&v| v as u64).sum();
                let n = (frame.width - parity).div_ceil(2) as u64;
                sums[c] += (s as f64 - n as f64 * black as f64) / (frame.white - black) as f64;
                counts[c] += n;
            }
        }
        let channel_means = [0, 1, 2].map(|c| (sums[c] / counts[c].max(1) as f64).max(0.0));
        GreyWorld::from_means(channel_means)
    }

    pub fn from_means(channel_means: [f64; 3]) -> GreyWorld {
        let target = channel_means.iter().sum::<f64>() / 3.0;
        let gains = channel_means.map(|m| if m > 0.0 { (target / m).min(MAX_GAIN) as f32 } else { 1.0 });
        GreyWorld { channel_means, gains }
    }
}

/// For each of the 4 pattern sites and each colour, the neighbours (dx, dy) within 3x3 that
/// carry that colour: the own sample for its colour, else the bilinear neighbours.
struct Neighbours {
    offsets: [[Vec<(isize, isize)>; 3]; 4],
}

impl Neighbours {
    fn of(frame: &RawFrame) -> Neighbours {
        let offsets = std::array::from_fn(|site| {
            let (sx, sy) = ((site % 2) as isize, (site / 2) as isize);
            std::array::from_fn(|c| {
                if frame.colour_at(sx, sy) == c {
                    return vec![(0, 0)];
                }
                let mut v = Vec::new();
                for dy in -1..=1 {
                    for dx in -1..=1 {
                        if frame.colour_at(sx + dx, sy + dy) == c {
                            v.push((dx, dy));
                        }
                    }
                }
                v
            })
        });
        Neighbours { offsets }
    }
}

/// Bilinear demosaic: calls `f(y, row)` for each picture row with linear, unbalanced RGB
/// (1.0 = white level).
pub fn for_each_row(frame: &RawFrame, mut f: impl FnMut(usize, &[[f32; 3]])) {
    count(Event::FullDecode);
    let n = Neighbours::of(frame);
    let w = frame.width;
    // Three linear rows with a one-pixel margin each side, rolled down the picture.
    let load = |y: isize, buf: &mut Vec<f32>| {
        buf.clear();
        buf.extend((-1..=w as isize).map(|x| frame.linear_at(x, y)));
    };
    let mut rows: [Vec<f32>; 3] = std::array::from_fn(|_| Vec::with_capacity(w + 2));
    load(-1, &mut rows[0]);
    load(0, &mut rows[1]);
    let mut out = vec![[0f32; 3]; w];
    for y in 0..frame.height {
        load(y as isize + 1, &mut rows[2]);
        let parity_y = y & 1;
        for (x, px) in out.iter_mut().enumerate() {
            let site = parity_y * 2 + (x & 1);
            for (c, v) in px.iter_mut().enumerate() {
                let offs = &n.offsets[site][c];
                let mut s = 0.0;
                for &(dx, dy) in offs {
                    s += rows[(1 + dy) as usize][(x as isize + 1 + dx) as usize];
                }
                *v = s / offs.len() as f32;
            }
        }
        f(y, &out);
        rows.rotate_left(1);
    }
}

/// sRGB encoding of a linear level in [0, 1].
pub fn srgb_encode(v: f32) -> f32 {
    let v = v.clamp(0.0, 1.0);
    if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

/// Table of the sRGB curve over linear levels in 1/TONE_STEPS steps: `powf` per channel per
/// pixel would cost more than the demosaic.
const TONE_STEPS: usize = 1 << 14;

pub struct ToneCurve {
    table: Vec<u16>,
    max: f32,
}

impl ToneCurve {
    /// sRGB to `max` (255 for 8-bit, 65535 for 16-bit).
    pub fn srgb(max: u16) -> ToneCurve {
        let table =
            (0..=TONE_STEPS).map(|i| (srgb_encode(i as f32 / TONE_STEPS as f32) * max as f32).round() as u16).collect();
        ToneCurve { table, max: max as f32 }
    }

    /// Straight scaling to `max`, for linear outputs.
    pub fn linear(max: u16) -> ToneCurve {
        let table = (0..=TONE_STEPS).map(|i| (i as f32 / TONE_STEPS as f32 * max as f32).round() as u16).collect();
        ToneCurve { table, max: max as f32 }
    }

    #[inline]
    pub fn apply(&self, v: f32) -> u16 {
        let i = (v.clamp(0.0, 1.0) * TONE_STEPS as f32 + 0.5) as usize;
        self.table[i]
    }

    pub fn max(&self) -> f32 {
        self.max
    }
}

/// Channel order of interleaved outputs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Order {
    Rgb,
    Bgr,
}

/// Writes one demosaiced row into an interleaved 3-channel output row, balanced by `gains`
/// and shaped by `tone`.
#[inline]
pub fn write_row<T: Copy>(
    row: &[[f32; 3]],
    gains: [f32; 3],
    tone: &ToneCurve,
    order: Order,
    out: &mut [T],
    cast: fn(u16) -> T,
) {
    let (a, c) = match order {
        Order::Rgb => (0, 2),
        Order::Bgr => (2, 0),
    };
    for (px, o) in row.iter().zip(out.chunks_exact_mut(3)) {
        o[0] = cast(tone.apply(px[a] * gains[a]));
        o[1] = cast(tone.apply(px[1] * gains[1]));
        o[2] = cast(tone.apply(px[c] * gains[c]));
    }
}

/// The picture for people: grey-world balanced, sRGB, interleaved RGB, 8 bits.
pub fn developed_rgb8(frame: &RawFrame, gw: &GreyWorld) -> Vec<u8> {
    let tone = ToneCurve::srgb(255);
    let mut out = vec![0u8; frame.width * frame.height * 3];
    let stride = frame.width * 3;
    for_each_row(frame, |y, row| {
        write_row(row, gw.gains, &tone, Order::Rgb, &mut out[y * stride..(y + 1) * stride], |v| v as u8)
    });
    out
}

/// As [`developed_rgb8`] with 16 bits per channel, sRGB (`linear`: no tone curve).
pub fn developed_rgb16(frame: &RawFrame, gw: &GreyWorld, linear: bool) -> Vec<u16> {
    let tone = if linear { ToneCurve::linear(u16::MAX) } else { ToneCurve::srgb(u16::MAX) };
    let mut out = vec![0u16; frame.width * frame.height * 3];
    let stride = frame.width * 3;
    for_each_row(frame, |y, row| {
        write_row(row, gw.gains, &tone, Order::Rgb, &mut out[y * stride..(y + 1) * stride], |v| v)
    });
    out
}

/// A reduced grey picture for the board search, by averaging `factor` x `factor` blocks of
/// sensor sites per colour (no demosaic: fast), grey-world balanced, sRGB. Pixel `i` of the
/// result is centred on full-resolution `factor * i + (factor - 1) / 2`, the convention of
/// a JPEG decoded at reduced size. Returns (pixels, width, height).
pub fn binned_grey(frame: &RawFrame, gw: &GreyWorld, factor: usize) -> (Vec<u8>, usize, usize) {
    count(Event::ReducedDecode);
    let f = factor.max(2) & !1;
    let (w, h) = (frame.width / f, frame.height / f);
    let tone = ToneCurve::srgb(255);
    let mut out = vec![0u8; w * h];
    let mut sums = vec![[0f32; 3]; w];
    for by in 0..h {
        sums.iter_mut().for_each(|s| *s = [0.0; 3]);
        for y in by * f..(by + 1) * f {
            let row = frame.picture_row(y);
            for (bx, s) in sums.iter_mut().enumerate() {
                for (x, &v) in row.iter().enumerate().skip(bx * f).take(f) {
                    let site = (y & 1) * 2 + (x & 1);
                    let c = frame.pattern[site] as usize;
                    let black = frame.black[site];
                    s[c] += ((v as f32 - black) / (frame.white - black)).max(0.0);
                }
            }
        }
        // An even block holds 1/4 R, 1/2 G, 1/4 B sites.
        let per = (f * f) as f32;
        for (o, s) in out[by * w..(by + 1) * w].iter_mut().zip(&sums) {
            let rgb = [s[0] * 4.0 / per * gw.gains[0], s[1] * 2.0 / per * gw.gains[1], s[2] * 4.0 / per * gw.gains[2]];
            // Luma weights on linear light, as near to OpenCV's grey as matters for corners.
            *o = tone.apply(0.299 * rgb[0] + 0.587 * rgb[1] + 0.114 * rgb[2]) as u8;
        }
    }
    (out, w, h)
}
