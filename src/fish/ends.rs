//! A fish's end points from its mask: the thesis's rule and fork length along the body.
//!
//! The thesis (§2.4.3) takes the principal axis of the outline and the outline's extremes
//! along it. That reaches the tips of the tail fin (length in this field is *fork* length:
//! snout to the notch between the caudal lobes) and cuts across a bent body. Here:
//!
//! 1. the body: the mask opened with a disc of a third of its greatest half-thickness, which
//!    strips fins, fin lobes and stray thin parts;
//! 2. its spine: the cheapest path between the body's geodesic extremes when a step costs
//!    more the closer it runs to the outline (a medial path), then a smooth curve fitted to it
//!    (a cubic bow in the frame of its chord), so pixel staircases add no length and a bent
//!    body keeps its bend;
//! 3. at each end, the whole fish's outline beyond the spine's end, along the spine's end
//!    direction: its rear profile (how far the fish reaches in each column across) and its
//!    width profile. A fork is a valley in the rear profile between two lobes reaching
//!    further; a caudal fin narrows to the peduncle and flares again, a head only narrows;
//! 4. the head point is the most anterior point of the head (the further jaw of an open
//!    mouth); the tail point is the bottom of the fork, or where the spine leaves a tail
//!    without one; when neither end tells, the result says so (the length does not depend
//!    on which end is which);
//! 5. the length runs along the spine from the snout to the fork.

use super::mask::Mask;
use super::FishError;
use fslcal_core::Vec2;
use serde::{Deserialize, Serialize};
use std::cmp::Reverse;
use std::collections::{BinaryHeap, VecDeque};

/// The centreline is searched on a copy of the fish reduced to about this many pixels along
/// its longer side: the medial path is smooth, and the ends are refined at full resolution.
const WORKING_SIZE_PX: usize = 400;

/// A tail valley counts as a fork when it is at least this share of the fish's length deep
/// (a rounded or square tail has none; pixel noise on the outline stays well below).
const MIN_FORK_DEPTH: f64 = 0.015;

/// How the end points were told apart.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum HeadCall {
    /// Only one end has a fork notch (and its peduncle does not say otherwise).
    ForkNotch,
    /// One end narrows to a caudal peduncle much more than the other.
    NarrowPeduncle,
    /// Given by a person (labels).
    Labelled,
    /// The mask does not tell: `head_px` and `tail_px` may be swapped.
    Unknown,
}

/// What the tail end point is.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum TailPoint {
    /// The bottom of the notch between the caudal lobes, `depth_px` behind the lobe tips.
    Fork { depth_px: f64 },
    /// No notch: where the centreline leaves the fish.
    Tip,
}

/// A fish's end points in pixels (docs/conventions.md).
#[derive(Clone, Debug, PartialEq)]
pub struct FishEnds {
    pub head_px: Vec2,
    pub tail_px: Vec2,
    /// Snout to fork (or tail tip) as a measuring board reads it with the fish laid straight:
    /// along the spine for a bent fish, else straight.
    pub length_px: f64,
    /// Straight from `head_px` to `tail_px`.
    pub chord_px: f64,
    /// The spine bows clearly: `length_px` follows it.
    pub bent: bool,
    pub head_call: HeadCall,
    pub tail_point: TailPoint,
    /// The fish touches the image border: part of it may be outside the frame.
    pub cut_by_edge: bool,
    /// The smoothed centreline, head to tail, pixels.
    pub centreline_px: Vec<Vec2>,
}

/// The thesis's rule (§2.4.3): the principal axis of the outline points (fish pixels with
/// a background 4-neighbour) of the largest piece, and the two outline points farthest
/// along it either way.
pub fn principal_axis_ends(mask: &Mask) -> Option<(Vec2, Vec2)> {
    let fish = mask.largest_component();
    let outline: Vec<Vec2> = fish
        .pixels()
        .filter(|&(x, y)| {
            let (x, y) = (x as i64, y as i64);
            !(fish.at(x + 1, y) && fish.at(x - 1, y) && fish.at(x, y + 1) && fish.at(x, y - 1))
        })
        .map(|(x, y)| Vec2::new(x as f64, y as f64))
        .collect();
    if outline.len() < 2 {
        return None;
    }
    let mean = outline.iter().sum::<Vec2>() / outline.len() as f64;
    let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
    for p in &outline {
        let d = p - mean;
        sxx += d.x * d.x;
        sxy += d.x * d.y;
        syy += d.y * d.y;
    }
    // Major eigenvector of the 2x2 scatter matrix.
    let angle = 0.5 * (2.0 * sxy).atan2(sxx - syy);
    let axis = Vec2::new(angle.cos(), angle.sin());
    let along = |p: &&Vec2| (*p - mean).dot(&axis);
    let lo = outline.iter().min_by(|a, b| along(a).total_cmp(&along(b)))?;
    let hi = outline.iter().max_by(|a, b| along(a).total_cmp(&along(b)))?;
    Some((*lo, *hi))
}

/// Margin (share of the image's larger side) within which a fish counts as touching the
/// frame: segmentation masks stop a few pixels short of the fish's real outline.
const EDGE_MARGIN: f64 = 0.005;

/// A fish's end points and fork length from its mask (see the module docs).
pub fn fish_ends(mask: &Mask) -> Result<FishEnds, FishError> {
    // Work on the mask's content only: a fish fills a few percent of a 12-megapixel frame.
    let (cx0, cy0, cx1, cy1) = bounding_box(mask).ok_or(FishError::TooSmall { pixels: 0 })?;
    let fish = mask.crop(cx0, cy0, cx1 - cx0 + 1, cy1 - cy0 + 1).largest_component();
    if fish.count() < 50 {
        return Err(FishError::TooSmall { pixels: fish.count() });
    }
    let cut_by_edge = touches_frame(mask, &fish, (cx0, cy0));
    let offset = Vec2::new(cx0 as f64, cy0 as f64);
    let spine = body_spine(&fish, &WorkingCopy::of(&fish))?;

    let bent = spine.bow() > BENT_BOW;
    let end_a = examine_end(&fish, &spine, false, bent);
    let end_b = examine_end(&fish, &spine, true, bent);
    let (tail_is_b, head_call) = tell_ends(&end_a, &end_b);
    let (head, tail) = if tail_is_b { (&end_a, &end_b) } else { (&end_b, &end_a) };
    let head_px = head.anterior_px;
    let (tail_px, tail_point) = match tail.fork {
        Some((p, depth)) => (p, TailPoint::Fork { depth_px: depth }),
        None => (tail.exit_px, TailPoint::Tip),
    };
    let centre = centreline(&spine, tail_is_b, (head, head_px), (tail, tail_px));
    let chord_px = (tail_px - head_px).norm();
    Ok(FishEnds {
        head_px: head_px + offset,
        tail_px: tail_px + offset,
        length_px: if bent { arc_length(&centre).max(chord_px) } else { chord_px },
        chord_px,
        bent,
        head_call,
        tail_point,
        cut_by_edge,
        centreline_px: centre.into_iter().map(|p| p + offset).collect(),
    })
}

/// Whether `fish` (cropped from `mask` at `origin`) comes within the edge margin of the frame.
fn touches_frame(mask: &Mask, fish: &Mask, (cx0, cy0): (usize, usize)) -> bool {
    let margin = (EDGE_MARGIN * mask.width.max(mask.height) as f64).round() as usize;
    fish.pixels().any(|(x, y)| {
        let (x, y) = (x + cx0, y + cy0);
        x <= margin || y <= margin || x + margin >= mask.width - 1 || y + margin >= mask.height - 1
    })
}

/// The fish reduced by `factor` to about [`WORKING_SIZE_PX`], with one working pixel of
/// background all round; `(ox, oy)` is its origin in the fish's pixels.
struct WorkingCopy {
    work: Mask,
    factor: usize,
    ox: i64,
    oy: i64,
}

impl WorkingCopy {
    fn of(fish: &Mask) -> WorkingCopy {
        let (x0, y0, x1, y1) = bounding_box(fish).expect("the fish has pixels");
        let factor = ((x1 - x0 + 1).max(y1 - y0 + 1)).div_ceil(WORKING_SIZE_PX).max(1);
        // Crop with a margin of one working pixel of background all round.
        let (ox, oy) = (x0 as i64 - factor as i64, y0 as i64 - factor as i64);
        let (cw, ch) = (x1 - x0 + 1 + 2 * factor, y1 - y0 + 1 + 2 * factor);
        let mut crop = Mask::new(cw, ch);
        for (x, y) in fish.pixels() {
            crop.bits[(y as i64 - oy) as usize * cw + (x as i64 - ox) as usize] = true;
        }
        WorkingCopy { work: crop.reduce(factor).largest_component(), factor, ox, oy }
    }

    /// The fish pixel at the centre of working pixel `i`.
    fn to_full(&self, i: usize) -> Vec2 {
        let (x, y) = (i % self.work.width, i / self.work.width);
        let half = (self.factor as f64 - 1.0) / 2.0;
        Vec2::new(self.ox as f64 + (self.factor * x) as f64 + half, self.oy as f64 + (self.factor * y) as f64 + half)
    }
}

/// The body's spine in the fish's pixels: the body is the working copy opened to strip
/// fins, and the spine a smooth curve through the medial path between its geodesic extremes.
fn body_spine(fish: &Mask, working: &WorkingCopy) -> Result<Spine, FishError> {
    let work = &working.work;
    let clearance = work.distance_to_background();
    let thickest = clearance.iter().cloned().fold(0.0, f64::max);
    let mut body = work.opened(&clearance, (thickest / 3.0).max(1.0)).largest_component();
    if body.count() < 10 {
        body = work.clone();
    }
    let body_clearance = body.distance_to_background();
    let start = (0..body_clearance.len()).max_by(|&a, &b| body_clearance[a].total_cmp(&body_clearance[b])).unwrap_or(0);
    let a = farthest_inside(&body, start);
    let b = farthest_inside(&body, a);
    if a == b {
        return Err(FishError::TooSmall { pixels: fish.count() });
    }
    let path: Vec<Vec2> = medial_path(&body, &body_clearance, a, b).into_iter().map(|i| working.to_full(i)).collect();
    Ok(Spine::fit(&path))
}

/// Which end is the tail (true: the spine's end `b`) and how that was told.
fn tell_ends(end_a: &EndLook, end_b: &EndLook) -> (bool, HeadCall) {
    match (end_a.flare, end_b.flare, end_a.fork.is_some(), end_b.fork.is_some()) {
        (fa, fb, _, _) if fb >= FLARE && fa < FLARE && fb > 1.3 * fa => (true, HeadCall::NarrowPeduncle),
        (fa, fb, _, _) if fa >= FLARE && fb < FLARE && fa > 1.3 * fb => (false, HeadCall::NarrowPeduncle),
        (_, _, false, true) => (true, HeadCall::ForkNotch),
        (_, _, true, false) => (false, HeadCall::ForkNotch),
        // Unknown: the end with the deeper valley or the stronger flare is the likelier tail.
        _ => {
            let score = |e: &EndLook| e.fork.map_or(0.0, |f| f.1) + e.flare;
            (score(end_b) >= score(end_a), HeadCall::Unknown)
        }
    }
}

/// The centreline from the head point to the tail point: the spine's samples between them.
fn centreline(
    spine: &Spine,
    tail_is_b: bool,
    (head, head_px): (&EndLook, Vec2),
    (tail, tail_px): (&EndLook, Vec2),
) -> Vec<Vec2> {
    let mut centre: Vec<Vec2> = vec![head_px];
    let samples = spine.samples(400);
    let ordered: Vec<Vec2> = if tail_is_b { samples } else { samples.into_iter().rev().collect() };
    centre.extend(
        ordered
            .into_iter()
            .filter(|p| (p - head_px).dot(&head.outward) < 0.0 && (p - tail_px).dot(&tail.outward) < 0.0),
    );
    centre.push(tail_px);
    centre
}

fn bounding_box(m: &Mask) -> Option<(usize, usize, usize, usize)> {
    let (mut x0, mut y0, mut x1, mut y1) = (usize::MAX, usize::MAX, 0, 0);
    for (x, y) in m.pixels() {
        x0 = x0.min(x);
        y0 = y0.min(y);
        x1 = x1.max(x);
        y1 = y1.max(y);
    }
    (x0 <= x1).then_some((x0, y0, x1, y1))
}

const STEPS: [(i64, i64, f64); 8] = [
    (1, 0, 1.0),
    (-1, 0, 1.0),
    (0, 1, 1.0),
    (0, -1, 1.0),
    (1, 1, std::f64::consts::SQRT_2),
    (1, -1, std::f64::consts::SQRT_2),
    (-1, 1, std::f64::consts::SQRT_2),
    (-1, -1, std::f64::consts::SQRT_2),
];

/// The fish pixel farthest from `start` in steps inside the fish (breadth first).
fn farthest_inside(m: &Mask, start: usize) -> usize {
    let mut seen = vec![false; m.bits.len()];
    let mut queue = VecDeque::from([start]);
    seen[start] = true;
    let mut last = start;
    while let Some(i) = queue.pop_front() {
        last = i;
        let (x, y) = ((i % m.width) as i64, (i / m.width) as i64);
        for &(dx, dy, _) in &STEPS {
            if m.at(x + dx, y + dy) {
                let j = (y + dy) as usize * m.width + (x + dx) as usize;
                if !seen[j] {
                    seen[j] = true;
                    queue.push_back(j);
                }
            }
        }
    }
    last
}

/// Cheapest 8-connected path from `a` to `b` inside the fish when a step costs its length
/// times `(max clearance / clearance)²`: it keeps to the middle of the body.
fn medial_path(m: &Mask, clearance: &[f64], a: usize, b: usize) -> Vec<usize> {
    let peak = clearance.iter().cloned().fold(1.0, f64::max);
    let mut cost = vec![f64::INFINITY; m.bits.len()];
    let mut from = vec![usize::MAX; m.bits.len()];
    // Costs as fixed-point integers keep the heap's ordering total.
    let mut heap = BinaryHeap::new();
    cost[a] = 0.0;
    heap.push(Reverse((0u64, a)));
    while let Some(Reverse((c, i))) = heap.pop() {
        if i == b {
            break;
        }
        if (c as f64) / 1e6 > cost[i] + 1e-6 {
            continue;
        }
        let (x, y) = ((i % m.width) as i64, (i / m.width) as i64);
        for &(dx, dy, len) in &STEPS {
            if !m.at(x + dx, y + dy) {
                continue;
            }
            let j = (y + dy) as usize * m.width + (x + dx) as usize;
            let r = peak / clearance[j].max(0.5);
            let next = cost[i] + len * r * r;
            if next < cost[j] {
                cost[j] = next;
                from[j] = i;
                heap.push(Reverse(((next * 1e6) as u64, j)));
            }
        }
    }
    let mut path = vec![b];
    let mut i = b;
    while i != a && from[i] != usize::MAX {
        i = from[i];
        path.push(i);
    }
    path.reverse();
    path
}

fn arc_length(points: &[Vec2]) -> f64 {
    points.windows(2).map(|w| (w[1] - w[0]).norm()).sum()
}

/// A smooth spine: in the frame of the chord from `start` to `start + along * length`, the
/// offset across is the cubic bow `length t (1 - t) (c0 + c1 t)` at `t` along (0 to 1). A
/// fish bends in a C or a gentle S; a path's staircase and wobble do not survive the fit.
struct Spine {
    start: Vec2,
    along: Vec2,
    across: Vec2,
    length: f64,
    c: [f64; 2],
}

impl Spine {
    fn fit(path: &[Vec2]) -> Spine {
        let (p0, p1) = (path[0], path[path.len() - 1]);
        let length = (p1 - p0).norm().max(1e-9);
        let along = (p1 - p0) / length;
        let across = Vec2::new(-along.y, along.x);
        // Least squares for (c0, c1): v / length = t (1 - t) (c0 + c1 t).
        let (mut a00, mut a01, mut a11, mut b0, mut b1) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for p in path {
            let t = (p - p0).dot(&along) / length;
            let v = (p - p0).dot(&across) / length;
            let g = t * (1.0 - t);
            let (f0, f1) = (g, g * t);
            a00 += f0 * f0;
            a01 += f0 * f1;
            a11 += f1 * f1;
            b0 += f0 * v;
            b1 += f1 * v;
        }
        let det = a00 * a11 - a01 * a01;
        let c = if det.abs() > 1e-12 { [(a11 * b0 - a01 * b1) / det, (a00 * b1 - a01 * b0) / det] } else { [0.0, 0.0] };
        Spine { start: p0, along, across, length, c }
    }

    fn at(&self, t: f64) -> Vec2 {
        let v = self.length * t * (1.0 - t) * (self.c[0] + self.c[1] * t);
        self.start + self.along * (t * self.length) + self.across * v
    }

    /// Largest offset of the spine from its chord, over the chord's length.
    fn bow(&self) -> f64 {
        (0..=50)
            .map(|k| {
                let t = k as f64 / 50.0;
                (t * (1.0 - t) * (self.c[0] + self.c[1] * t)).abs()
            })
            .fold(0.0, f64::max)
    }

    /// `n + 1` points along the body, `t` from 0 to 1.
    fn samples(&self, n: usize) -> Vec<Vec2> {
        (0..=n).map(|k| self.at(k as f64 / n as f64)).collect()
    }
}

/// A spine bowing more than this share of its chord is a bent fish, measured along it. Real
/// fish seen from the side have a mid-depth line that bows with their humped back (up to 9%
/// on the lab's straight fish), so only a clear bend counts: a fish bent less loses up to
/// 2.5% of its length to the straight line (arc over chord at a 0.1 bow).
const BENT_BOW: f64 = 0.1;

/// A tail fin widens again behind the peduncle by at least this factor; a head does not.
const FLARE: f64 = 1.25;

/// What one end of the fish looks like.
struct EndLook {
    /// Unit direction out of the fish at this end.
    outward: Vec2,
    /// The fish's farthest point along `outward`: the snout tip if this is the head.
    anterior_px: Vec2,
    /// Where the spine's line leaves the fish: a tail's end when it has no fork.
    exit_px: Vec2,
    /// Bottom of the notch between two lobes, and its depth, when deep enough.
    fork: Option<(Vec2, f64)>,
    /// Widest width behind the narrowest point over the narrowest (1 for a tapering end).
    flare: f64,
}

/// Looks at the end of the spine (`t = 1` when `at_end`, else `t = 0`) of a `bent` or
/// straight fish in the whole full-resolution `fish`.
fn examine_end(fish: &Mask, spine: &Spine, at_end: bool, bent: bool) -> EndLook {
    // The end's direction over its last 40% (the fitted bow's very end tangent swings with
    // the fins), over its last 20% on a bent fish, whose end turns away.
    let span = if bent { 0.2 } else { 0.4 };
    let (t_end, t_base, t_mid) = if at_end { (1.0, 0.9, 1.0 - span) } else { (0.0, 0.1, span) };
    let outward = (spine.at(t_end) - spine.at(t_mid)).try_normalize(1e-9).unwrap_or(spine.along);
    let across = Vec2::new(-outward.y, outward.x);
    let base = spine.at(t_base);
    let total = spine.length;
    let EndProfiles { reach_px, profile, widths } = EndProfiles::of(fish, base, outward, total);
    let point = |bin: usize| base + outward * profile[bin] + across * (bin as f64 - reach_px);
    let filled: Vec<usize> = (0..profile.len()).filter(|&b| profile[b].is_finite()).collect();
    if filled.is_empty() {
        let p = spine.at(t_end);
        return EndLook { outward, anterior_px: p, exit_px: p, fork: None, flare: 1.0 };
    }
    let far = *filled.iter().max_by(|&&a, &&b| profile[a].total_cmp(&profile[b])).expect("not empty");
    // A tail without a fork ends in the middle of its rear edge: the columns of the fin that
    // reach within a twentieth of the length of the farthest, so a square or slanted edge ends
    // in its middle and a rounded one at its apex.
    let fin: Vec<usize> = filled
        .iter()
        .copied()
        .filter(|&b| profile[b] >= profile[far] - 0.05 * total && (b as f64 - reach_px).abs() < 0.2 * total)
        .collect();
    let exit_px = match (fin.first(), fin.last()) {
        (Some(&lo), Some(&hi)) => {
            let mid = (lo + hi) / 2;
            let nearest = *fin.iter().min_by_key(|&&b| b.abs_diff(mid)).expect("not empty");
            point(nearest)
        }
        _ => point(far),
    };
    // A fork's bottom lies behind the body, within the caudal fin's spread of the spine.
    let body_end = (spine.at(t_end) - base).dot(&outward);
    let (best_k, depth) = deepest_valley(&profile, &filled, reach_px, body_end, total);
    let fork = (depth >= MIN_FORK_DEPTH * total).then(|| (point(filled[best_k]), depth));
    EndLook { outward, anterior_px: point(far), exit_px, fork, flare: flare(&widths) }
}

/// The fish beyond an end's base, along `outward`, out to half its length.
struct EndProfiles {
    /// Half-width of the columns across, px.
    reach_px: f64,
    /// For each column across (`reach_px` is the spine's), how far out the fish reaches, px;
    /// minus infinity where it has no pixel.
    profile: Vec<f64>,
    /// Pixels of the fish in each slice out (a sixtieth of the length thick).
    widths: Vec<usize>,
}

impl EndProfiles {
    fn of(fish: &Mask, base: Vec2, outward: Vec2, total: f64) -> EndProfiles {
        let across = Vec2::new(-outward.y, outward.x);
        // Columns across as far as a caudal fin spreads, rows out as far as a head or tail reaches.
        let reach_px = 0.5 * total;
        let bins = (2.0 * reach_px).ceil() as usize + 1;
        let slice_px = (total / 60.0).max(1.0);
        let mut profile = vec![f64::NEG_INFINITY; bins];
        let mut widths = vec![0usize; (0.5 * total / slice_px).ceil() as usize + 1];
        for (x, y) in fish.pixels() {
            let d = Vec2::new(x as f64, y as f64) - base;
            let (s, w) = (d.dot(&outward), d.dot(&across));
            if s < 0.0 || s > 0.5 * total || w.abs() >= reach_px {
                continue;
            }
            let bin = (w + reach_px).round() as usize;
            profile[bin] = profile[bin].max(s);
            widths[(s / slice_px) as usize] += 1;
        }
        EndProfiles { reach_px, profile, widths }
    }
}

/// The deepest valley of the rear profile behind `body_end` and within the caudal fin's
/// spread of the spine: its index in `filled` and its depth below the lower of the highest
/// columns either side, px (`(0, 0.0)` for none).
fn deepest_valley(profile: &[f64], filled: &[usize], reach_px: f64, body_end: f64, total: f64) -> (usize, f64) {
    // Valleys: each column against the highest column on either side of it.
    let mut left_max = vec![f64::NEG_INFINITY; filled.len()];
    let mut right_max = vec![f64::NEG_INFINITY; filled.len()];
    for k in 1..filled.len() {
        left_max[k] = left_max[k - 1].max(profile[filled[k - 1]]);
    }
    for k in (0..filled.len() - 1).rev() {
        right_max[k] = right_max[k + 1].max(profile[filled[k + 1]]);
    }
    (0..filled.len())
        .filter(|&k| profile[filled[k]] > body_end && (filled[k] as f64 - reach_px).abs() < 0.2 * total)
        .map(|k| (k, left_max[k].min(right_max[k]) - profile[filled[k]]))
        // Deepest; between near ties the one nearer the spine.
        .max_by(|a, b| {
            let near = |k: usize| (filled[k] as f64 - reach_px).abs();
            (a.1.round()).total_cmp(&b.1.round()).then_with(|| near(b.0).total_cmp(&near(a.0)))
        })
        .unwrap_or((0, 0.0))
}

/// Width profile: the widest slice behind the narrowest in the first 60% of the reach, over
/// the narrowest.
fn flare(widths: &[usize]) -> f64 {
    let last = widths.iter().rposition(|&n| n > 0).unwrap_or(0);
    let first_part = ((last as f64 * 0.6).round() as usize).max(1);
    let (neck, narrowest) =
        widths[..first_part].iter().enumerate().min_by_key(|&(_, &n)| n).map(|(k, &n)| (k, n)).unwrap_or((0, 1));
    let widest_behind = widths[neck..=last].iter().copied().max().unwrap_or(narrowest);
    widest_behind as f64 / narrowest.max(1) as f64
}
