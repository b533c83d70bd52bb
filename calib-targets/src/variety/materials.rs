//! What the things in a photo are made of, drawn at random: board papers and backings,
//! slate plastics and tapes, fish skins and fins, reef, sand and algae. Each gives an albedo
//! (0-1 per channel, R G B) and a region id at a point of its own plane (metres); region ids
//! change at hard edges, where the renderer supersamples.

use crate::random::SplitMix;
use crate::slate::{SlateLook, Tape};
use crate::Checkerboard;
use fslcal_core::Vec2;
use serde::{Deserialize, Serialize};

/// Smooth value noise in [0, 1] on a grid of `cell` units: as `scene::value_noise` but with
/// a one-round lattice hash, since textures here take tens of lookups per pixel.
pub(crate) fn noise(seed: u64, u: f64, v: f64, cell: f64) -> f64 {
    let (gx, gy) = (u / cell, v / cell);
    // floor() without a libm call: truncation, one down for negative non-integers.
    let floor = |g: f64| {
        let i = g as i64;
        i - (g < i as f64) as i64
    };
    let (ix, iy) = (floor(gx), floor(gy));
    let (fx, fy) = (gx - ix as f64, gy - iy as f64);
    let h = |x: i64, y: i64| {
        let mut z =
            (x as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ (y as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F) ^ seed;
        z = (z ^ (z >> 32)).wrapping_mul(0xD6E8_FEB8_6659_FD93);
        z = (z ^ (z >> 32)).wrapping_mul(0xD6E8_FEB8_6659_FD93);
        (z >> 11) as f64 / (1u64 << 53) as f64
    };
    let s = |t: f64| t * t * (3.0 - 2.0 * t);
    let (a, b, c, d) = (h(ix, iy), h(ix + 1, iy), h(ix, iy + 1), h(ix + 1, iy + 1));
    let (sx, sy) = (s(fx), s(fy));
    let top = a + (b - a) * sx;
    let bottom = c + (d - c) * sx;
    top + (bottom - top) * sy
}

/// Yellow-green, the colour that turns as green as a laser dot under water.
fn yellow_green(rng: &mut SplitMix) -> [f64; 3] {
    [rng.range(0.45, 0.75), rng.range(0.70, 0.90), rng.range(0.02, 0.15)]
}

fn smoothstep(a: f64, b: f64, x: f64) -> f64 {
    let t = ((x - a) / (b - a)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

fn mix(a: [f64; 3], b: [f64; 3], t: f64) -> [f64; 3] {
    [0, 1, 2].map(|k| a[k] + (b[k] - a[k]) * t)
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Paper {
    White,
    Cream,
    Grey,
    /// White paper in a glossy laminate: a broad specular sheen and glints.
    Laminated,
}

/// A strip of tape on a plane, plane metres.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TapeDecal {
    pub centre_m: [f64; 2],
    pub angle_rad: f64,
    pub half_len_m: f64,
    pub half_width_m: f64,
    pub colour: [f64; 3],
}

impl TapeDecal {
    fn covers(&self, x: f64, y: f64) -> bool {
        let (dx, dy) = (x - self.centre_m[0], y - self.centre_m[1]);
        let (c, s) = (self.angle_rad.cos(), self.angle_rad.sin());
        (dx * c + dy * s).abs() <= self.half_len_m && (-dx * s + dy * c).abs() <= self.half_width_m
    }
}

/// A broad specular highlight on a glossy surface, plane metres.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Sheen {
    pub centre_m: [f64; 2],
    pub radius_m: f64,
    /// Albedo added at the centre.
    pub strength: f64,
}

/// The printed checkerboard: paper and ink, an optional plastic backing plate around it,
/// an optional strip of yellow-green tape on its margin or backing.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BoardLook {
    pub paper: Paper,
    pub paper_albedo: [f64; 3],
    pub ink_albedo: [f64; 3],
    pub sheen: Option<Sheen>,
    /// Backing colour and how far it reaches beyond the paper, metres.
    pub backing: Option<([f64; 3], f64)>,
    pub tape: Option<TapeDecal>,
}

impl BoardLook {
    pub(crate) fn draw(rng: &mut SplitMix, board: &Checkerboard) -> BoardLook {
        let u = rng.unit();
        let (paper, paper_albedo) = if u < 0.35 {
            (Paper::White, [rng.range(0.78, 0.9); 3])
        } else if u < 0.55 {
            (Paper::Cream, [rng.range(0.85, 0.92), rng.range(0.80, 0.86), rng.range(0.62, 0.72)])
        } else if u < 0.75 {
            (Paper::Grey, [rng.range(0.45, 0.7); 3])
        } else {
            (Paper::Laminated, [rng.range(0.8, 0.9); 3])
        };
        let k = rng.range(0.03, 0.12);
        let ink_albedo = [k, k * rng.range(0.9, 1.1), k * rng.range(0.9, 1.3)];
        let o = board.outline_m();
        let (w, h) = (o[2][0] - o[0][0], o[2][1] - o[0][1]);
        let sheen = (paper == Paper::Laminated).then(|| Sheen {
            centre_m: [o[0][0] + rng.range(0.1, 0.9) * w, o[0][1] + rng.range(0.1, 0.9) * h],
            radius_m: rng.range(0.04, 0.18),
            strength: rng.range(0.3, 1.2),
        });
        let backing = (rng.unit() < 0.5).then(|| {
            let colours = [[0.15, 0.15, 0.17], [0.55, 0.56, 0.58], [0.85, 0.7, 0.1], [0.1, 0.25, 0.6], [0.9, 0.9, 0.9]];
            (colours[rng.below(colours.len() as u64) as usize], rng.range(0.02, 0.08))
        });
        let tape = (rng.unit() < 0.35).then(|| board_tape(rng, board, backing.map(|b| b.1)));
        BoardLook { paper, paper_albedo, ink_albedo, sheen, backing, tape }
    }

    /// Albedo and region at a board-frame point, `None` off the board and its backing.
    pub(crate) fn albedo_at(&self, board: &Checkerboard, q: Vec2) -> Option<([f64; 3], u32)> {
        let o = board.outline_m();
        let border = self.backing.map_or(0.0, |b| b.1);
        let outside = |m: f64| q.x < o[0][0] - m || q.x > o[2][0] + m || q.y < o[0][1] - m || q.y > o[2][1] + m;
        if outside(border) {
            return None;
        }
        if let Some(t) = self.tape.as_ref().filter(|t| t.covers(q.x, q.y)) {
            return Some((t.colour, 1));
        }
        if outside(0.0) {
            return Some((self.backing.expect("outside the paper only with a backing").0, 2));
        }
        let s = board.square_m;
        let (i, j) = ((q.x / s).floor() as i64 + 1, (q.y / s).floor() as i64 + 1);
        let on_squares = (0..=board.inner_cols as i64).contains(&i) && (0..=board.inner_rows as i64).contains(&j);
        let (mut albedo, id) = if on_squares && Checkerboard::square_colour_is_black(i, j) {
            (self.ink_albedo, 16 + (i * 64 + j) as u32)
        } else if on_squares {
            (self.paper_albedo, 16 + (i * 64 + j) as u32)
        } else {
            (self.paper_albedo, 3)
        };
        if let Some(sh) = &self.sheen {
            let d2 = (q.x - sh.centre_m[0]).powi(2) + (q.y - sh.centre_m[1]).powi(2);
            let add = sh.strength * (-0.5 * d2 / sh.radius_m.powi(2)).exp();
            albedo = albedo.map(|a| a + add);
        }
        Some((albedo, id))
    }
}

/// Yellow-green tape along one edge of the board, on its white margin or its backing.
fn board_tape(rng: &mut SplitMix, board: &Checkerboard, backing_m: Option<f64>) -> TapeDecal {
    let o = board.outline_m();
    let s = board.square_m;
    // The margin runs from the outline to the squares' outer edge (one square in from the
    // outline's -s corner); tape there or on the backing leaves every square visible.
    let margin = (s * crate::MARGIN_SQUARES, 0.5 * (o[0][0] + (-s)));
    let (band_m, offset) = match backing_m {
        Some(b) if rng.unit() < 0.5 => (b, -0.5 * b),
        _ => (margin.0, margin.1 - o[0][0]),
    };
    let half_width_m = (0.4 * band_m).min(0.012);
    let horizontal = rng.unit() < 0.5;
    let (x0, x1, y0, y1) = (o[0][0], o[2][0], o[0][1], o[2][1]);
    let far_side = rng.unit() < 0.5;
    let centre_m = if horizontal {
        let y = if far_side { y1 - offset } else { y0 + offset };
        [rng.range(x0 + 0.1, x1 - 0.1), y]
    } else {
        let x = if far_side { x1 - offset } else { x0 + offset };
        [x, rng.range(y0 + 0.1, y1 - 0.1)]
    };
    TapeDecal {
        centre_m,
        angle_rad: if horizontal { 0.0 } else { std::f64::consts::FRAC_PI_2 },
        half_len_m: rng.range(0.02, 0.06),
        half_width_m,
        colour: yellow_green(rng),
    }
}

/// A dive slate's look: plastic, rim, tapes, and sometimes a yellow-green tape on top. The
/// tapes' positions are scan millimetres.
pub(crate) fn draw_slate_look(rng: &mut SplitMix, width_mm: f64, height_mm: f64) -> SlateLook {
    let u = rng.unit();
    let plastic = if u < 0.5 {
        [0.88, 0.89, 0.87]
    } else if u < 0.7 {
        [0.90, 0.85, 0.70]
    } else if u < 0.85 {
        [0.70, 0.70, 0.71]
    } else {
        [0.86, 0.76, 0.25]
    };
    let silver = [rng.range(0.55, 0.68); 3];
    let mut palette = vec![silver, silver.map(|c| c * 0.9)];
    let extra = [[0.12, 0.12, 0.13], [0.75, 0.18, 0.15], [0.15, 0.35, 0.70], [0.9, 0.45, 0.1], [0.92, 0.92, 0.9]];
    for c in extra {
        if rng.unit() < 0.7 {
            palette.push(c);
        }
    }
    let extra_tapes = if rng.unit() < 0.35 {
        let angle = rng.range(0.0, std::f64::consts::PI);
        vec![Tape {
            centre: [rng.range(0.2, 0.8) * width_mm, rng.range(0.2, 0.8) * height_mm],
            along: [angle.cos(), angle.sin()],
            half_len: rng.range(15.0, 40.0),
            half_width: rng.range(8.0, 20.0),
            colour: yellow_green(rng),
            seed: rng.next_u64(),
        }]
    } else {
        Vec::new()
    };
    SlateLook { plastic, rim: [rng.range(0.3, 0.6); 3], palette, extra_tapes }
}

/// A fish skin's pattern.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase", tag = "kind")]
pub enum FishPattern {
    Plain,
    /// Vertical bars across the body.
    Bars {
        count: u32,
        colour: [f64; 3],
    },
    /// Stripes along the body.
    Stripes {
        count: u32,
        colour: [f64; 3],
    },
    Spots {
        cell_m: f64,
        colour: [f64; 3],
    },
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FishLook {
    pub back: [f64; 3],
    pub belly: [f64; 3],
    pub pattern: FishPattern,
    pub fins: [f64; 3],
    /// Fins in yellow-green, as green as the laser under water.
    pub green_fins: bool,
    pub seed: u64,
}

impl FishLook {
    pub(crate) fn draw(rng: &mut SplitMix) -> FishLook {
        let backs = [
            [0.45, 0.48, 0.50],
            [0.15, 0.30, 0.55],
            [0.80, 0.70, 0.10],
            [0.55, 0.25, 0.15],
            [0.30, 0.38, 0.15],
            [0.12, 0.12, 0.14],
            [0.70, 0.72, 0.74],
        ];
        let back = backs[rng.below(backs.len() as u64) as usize].map(|c| (c * rng.range(0.85, 1.15)).min(1.0));
        let belly = back.map(|c| 0.5 * c + rng.range(0.3, 0.45));
        let dark = back.map(|c| c * 0.35);
        let u = rng.unit();
        let pattern = if u < 0.35 {
            FishPattern::Plain
        } else if u < 0.6 {
            FishPattern::Bars { count: 3 + rng.below(6) as u32, colour: dark }
        } else if u < 0.8 {
            FishPattern::Stripes { count: 2 + rng.below(4) as u32, colour: dark }
        } else {
            FishPattern::Spots { cell_m: rng.range(0.008, 0.025), colour: dark }
        };
        let green_fins = rng.unit() < 0.25;
        let fins = if green_fins { yellow_green(rng) } else { mix(back, [0.5, 0.5, 0.5], rng.range(0.0, 0.6)) };
        FishLook { back, belly, pattern, fins, green_fins, seed: rng.next_u64() }
    }

    /// Albedo and region on a part of the fish; `q` is the fish's plane point (metres).
    pub(crate) fn albedo(&self, part: crate::fish::FishPart, q: Vec2) -> ([f64; 3], u32) {
        use crate::fish::FishPart;
        let (along, across) = match part {
            FishPart::Body { along, across } => (along, across),
            FishPart::CaudalFin | FishPart::DorsalFin => return (self.fins, 2),
        };
        // Dark back (the dorsal side, across = -1) over a light belly.
        let mut c = mix(self.back, self.belly, smoothstep(-0.4, 0.5, across));
        let ink = match &self.pattern {
            FishPattern::Plain => 0.0,
            FishPattern::Bars { count, .. } => {
                let phase = (along * *count as f64 * std::f64::consts::PI).sin();
                smoothstep(0.55, 0.8, phase) * smoothstep(0.1, 0.25, along)
            }
            FishPattern::Stripes { count, .. } => {
                let phase = ((across + 1.0) * *count as f64 * std::f64::consts::PI).sin();
                smoothstep(0.6, 0.85, phase)
            }
            FishPattern::Spots { cell_m, .. } => smoothstep(0.68, 0.75, noise(self.seed, q.x, q.y, *cell_m)),
        };
        if let FishPattern::Bars { colour, .. }
        | FishPattern::Stripes { colour, .. }
        | FishPattern::Spots { colour, .. } = &self.pattern
        {
            c = mix(c, *colour, ink);
        }
        (c, 1)
    }
}

/// A tuft of bright green algae on the reef, reef-plane metres.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Tuft {
    pub centre_m: [f64; 2],
    pub radius_m: f64,
    pub colour: [f64; 3],
}

/// Reef, rock and sand: patches of four materials over two scales of texture, green algae
/// covering some of it, and tufts of bright green algae.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ReefLook {
    /// Sand, rock, coral, algae.
    pub palette: [[f64; 3]; 4],
    /// Size of the patches, metres.
    pub cell_m: f64,
    /// Share covered by algae.
    pub algae_cover: f64,
    pub seed: u64,
    pub tufts: Vec<Tuft>,
}

impl ReefLook {
    pub(crate) fn draw(rng: &mut SplitMix) -> ReefLook {
        let corals =
            [[0.62, 0.40, 0.42], [0.50, 0.40, 0.52], [0.66, 0.50, 0.30], [0.60, 0.58, 0.45], [0.45, 0.45, 0.40]];
        let sand = [rng.range(0.55, 0.75), rng.range(0.5, 0.65), rng.range(0.38, 0.5)];
        let grey = rng.range(0.2, 0.38);
        let rock = [grey * rng.range(1.0, 1.2), grey, grey * rng.range(0.8, 1.0)];
        let coral = corals[rng.below(corals.len() as u64) as usize].map(|c| c * rng.range(0.85, 1.1));
        let algae = [rng.range(0.12, 0.25), rng.range(0.22, 0.38), rng.range(0.06, 0.14)];
        ReefLook {
            palette: [sand, rock, coral, algae],
            cell_m: rng.range(0.15, 0.7),
            algae_cover: rng.range(0.0, 0.4),
            seed: rng.next_u64(),
            tufts: Vec::new(),
        }
    }

    /// A tuft at reef-plane `centre_m`, about `scale_m` in radius.
    pub(crate) fn tuft(rng: &mut SplitMix, centre_m: [f64; 2], scale_m: f64) -> Tuft {
        let mut colour = yellow_green(rng);
        colour[0] *= rng.range(0.3, 1.0);
        Tuft { centre_m, radius_m: scale_m * rng.range(0.5, 1.5), colour }
    }

    pub(crate) fn albedo_at(&self, q: Vec2) -> ([f64; 3], u32) {
        for (k, t) in self.tufts.iter().enumerate() {
            let d = q - Vec2::new(t.centre_m[0], t.centre_m[1]);
            let r = d.norm();
            if r > 1.3 * t.radius_m {
                continue;
            }
            // A ragged outline and a mottled inside.
            let a = d / r.max(1e-12);
            let seed = self.seed ^ (k as u64 + 1).wrapping_mul(0x9E37_79B9);
            let edge = t.radius_m * (0.7 + 0.6 * noise(seed, 2.0 * a.x, 2.0 * a.y, 1.0));
            if r <= edge {
                let mottle = 0.75 + 0.5 * noise(seed ^ 7, q.x, q.y, 0.3 * t.radius_m);
                return (t.colour.map(|c| c * mottle), 8 + k as u32);
            }
        }
        let (x, y) = (q.x, q.y);
        let n = fbm(self.seed, x, y, self.cell_m, 3);
        let [sand, rock, coral, algae] = self.palette;
        let mut c = mix(sand, rock, smoothstep(0.38, 0.47, n));
        c = mix(c, coral, smoothstep(0.55, 0.64, n));
        let a = fbm(self.seed ^ 0xA1, x, y, 0.7 * self.cell_m, 2);
        let cover = 0.35 + 0.3 * (1.0 - self.algae_cover);
        c = mix(c, algae, smoothstep(cover - 0.04, cover + 0.04, a));
        // Lumps and crevices at a fifth of the patch size, grain below that.
        let lumps = fbm(self.seed + 1, x, y, self.cell_m / 5.0, 2);
        let grain = noise(self.seed + 2, x, y, 0.004) - 0.5;
        let shade = 0.45 + 0.75 * smoothstep(0.25, 0.7, lumps) + 0.25 * grain;
        (c.map(|k| k * shade), 0)
    }
}

/// Fractal value noise: `octaves` octaves from cell size `cell`, halving each time, in
/// [0, 1] (mostly near 0.5).
fn fbm(seed: u64, x: f64, y: f64, cell: f64, octaves: u32) -> f64 {
    let (mut sum, mut norm, mut amp, mut c) = (0.0, 0.0, 1.0, cell);
    for o in 0..octaves {
        sum += amp * noise(seed.wrapping_add(o as u64 * 0x9E37), x, y, c);
        norm += amp;
        amp *= 0.5;
        c *= 0.5;
    }
    sum / norm
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn board_tape_leaves_every_square_visible() {
        let board = Checkerboard::fishsense();
        let s = board.square_m;
        for seed in 0..300 {
            let mut rng = SplitMix::new(seed);
            let look = BoardLook::draw(&mut rng, &board);
            let Some(tape) = &look.tape else { continue };
            let (c, hw, hl) = (tape.centre_m, tape.half_width_m, tape.half_len_m);
            let reach = [c[0] - hl - hw, c[1] - hl - hw, c[0] + hl + hw, c[1] + hl + hw];
            // The squares span [-s, cols * s] x [-s, rows * s]; a vertical tape's short side is x.
            let (x0, x1, y0, y1) = if tape.angle_rad == 0.0 {
                (reach[0], reach[2], c[1] - hw, c[1] + hw)
            } else {
                (c[0] - hw, c[0] + hw, reach[1], reach[3])
            };
            let overlaps = x1 > -s && x0 < board.inner_cols as f64 * s && y1 > -s && y0 < board.inner_rows as f64 * s;
            assert!(!overlaps, "seed {seed}: tape {tape:?} covers squares");
        }
    }
}
