//! Centring a dot blob to sub-pixel: its weighted centroid on the detector's maps, then a
//! re-centring on the photo against a background model that a checkerboard cannot bias.

use super::candidates::{neighbours8, BlobBox, ColourView, RoiMaps, CLIPPED};
use super::colour::{ColourSource, LaserColourModel};
use fslcal_core::Vec2;

/// Intensity-weighted centroid of blob `id` in ROI pixels (its clipped core weighted at
/// `peak`), over its box grown by two pixels so the weights fall off symmetrically.
pub(super) fn weighted_centre(maps: &RoiMaps, id: u32, (mnx, mxx, mny, mxy): BlobBox, peak: f32) -> (f64, f64) {
    let (w, h) = (maps.roi.w, maps.roi.h);
    let (excess, saturated, label) = (&maps.excess, &maps.saturated, &maps.label);
    let grow = 2;
    let (ax, bx) = (mnx.saturating_sub(grow), (mxx + grow + 1).min(w));
    let (ay, by) = (mny.saturating_sub(grow), (mxy + grow + 1).min(h));
    // Subtract a floor so background noise around the blob adds no pull toward the box
    // centre, but keep the halo's tails that lie above it.
    let floor = 0.25 * maps.threshold;
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

/// Re-centres a dot against a background model that the checkerboard cannot bias.
///
/// Under water, the board's colour in each channel is an affine function of its albedo
/// (attenuated light plus backscatter veil), so across black and white squares green is an
/// affine function of blue or of red: `G = a + b X` ([`Background`]). Fitted on a ring
/// around the dot, that model predicts the background under the dot even where the dot
/// straddles a square's edge, which a local mean cannot (it pulls the centre toward the
/// white square by up to a pixel). The laser adds much more green than `b` times what it
/// adds to `X`, so `G - (a + b X)` is the dot alone.
/// The centroid is taken over a disc centred on the current estimate, three times, so the
/// window is symmetric about the answer. A core clipped white is centred on its white pixels
/// alone ([`clipped_core_centre`]): the beam clips white where it is brightest, round about
/// its centre, while clipped green and a fringe above the floor take in whatever bright
/// green touches the dot (an algae tuft, a sun fleck's glow). Under a learned colour each
/// bright pixel of a clipped core is also weighed by how far it shows the laser's second
/// channel ([`Background::agreement`]), unless that moves the centre beyond the blob's
/// radius: a blob whose pixels mostly lack the laser's colour is no dot, and (with every
/// pixel judged) its few agreeing ones walked its centre 14.0 px onto the line (seed
/// 1000100/17, an algae tuft 78 px from the dot).
pub(super) fn refine_centre(
    img: &ColourView,
    rough: Vec2,
    blob_radius_px: f64,
    laser: &LaserColourModel,
) -> Option<Centred> {
    let (plain, clipped) = centre_with(img, rough, blob_radius_px, laser.rgb, None)?;
    // A disc with no clipped green at any step is centred by its matched filter alone, which
    // no agreement weighs: the second pass would give the same centre.
    let Some(second) = second_channel(laser).filter(|_| clipped) else { return Some(plain) };
    match centre_with(img, rough, blob_radius_px, laser.rgb, Some(second)) {
        Some((agreeing, _)) if (agreeing.at - plain.at).norm() <= blob_radius_px => Some(agreeing),
        _ => Some(plain),
    }
}

/// [`refine_centre`] with pixels weighed by their agreement with the laser's `second`
/// channel, or not; and whether its disc held clipped green at any step.
fn centre_with(
    img: &ColourView,
    rough: Vec2,
    blob_radius_px: f64,
    laser_rgb: [f64; 3],
    second: Option<SecondChannel>,
) -> Option<(Centred, bool)> {
    let r_in = blob_radius_px * 1.6 + 3.0;
    let ring = (r_in + 2.0, r_in + 6.0);
    let mut c = rough;
    let (mut glint, mut over) = (Glint::new(), Glint::new());
    let (mut step, mut clipped) = (0, false);
    // A glint beside the dot, left out with its mirror image (which moves with the centre),
    // moves the centre a pixel or more per step: it takes more steps to settle.
    while step < if glint.is_empty() { 3 } else { 8 } {
        step += 1;
        let window = Window::around(img, c, ring.1)?;
        let background = Background::fit(img, &window, c, ring, laser_rgb, second)?;
        let disc = DiscSignal::sum(img, &window, c, r_in, &background, &Glint::new());
        clipped |= !disc.saturated.is_empty();
        let next = if disc.saturated.is_empty() {
            // A faint dot (nothing clipped) is found better by a matched filter than by a
            // thresholded centroid, whose few surviving pixels are at the noise's mercy.
            matched_filter_peak(img, c, r_in, blob_radius_px, &|r, g, b| background.residual(r, g, b))?
        } else {
            match disc.nearest_white.map(|seed| white_core(img, &window, c, r_in, seed)) {
                Some(WhiteCore::Dot(at)) => {
                    glint.clear();
                    over.clear();
                    at
                }
                Some(WhiteCore::Glint(found)) => {
                    // A glint on the dot itself (1 px off on tuning target-less 7/18): its
                    // halo is the dot's light too, and only its clipped pixels are left out.
                    // It stays a clipped core for what judges the blob after.
                    if found.contains(&(c.x.round() as i64, c.y.round() as i64)) {
                        glint.clear();
                        over = with_halo(&found);
                        disc.without(&found).centroid_with_core(background.floor)?
                    } else {
                        over.clear();
                        glint = with_halo(&found);
                        DiscSignal::sum(img, &window, c, r_in, &background, &glint)
                            .centroid_with_core(background.floor)?
                    }
                }
                // A glint found at an earlier step stays one when the centre has moved so far
                // from it that only its halo is left in the disc.
                Some(WhiteCore::Unsure) | None if !glint.is_empty() => {
                    DiscSignal::sum(img, &window, c, r_in, &background, &glint).centroid_with_core(background.floor)?
                }
                Some(WhiteCore::Unsure) | None => {
                    let plain = disc.centroid_with_core(background.floor)?;
                    match most_clipped_core(img, &window, c, r_in) {
                        Some(core) if (core - plain).norm() > CORE_DISAGREEMENT_PX => core,
                        _ => plain,
                    }
                }
            }
        };
        let moved = (next - c).norm();
        c = next;
        if moved > r_in {
            return None;
        }
        if moved < 1e-3 {
            break;
        }
    }
    Some((Centred { at: c, glint, over }, clipped))
}

/// Image pixels (x, y) of a glint.
pub(super) type Glint = std::collections::HashSet<(i64, i64)>;

/// A glint's pixels with its halo, those within [`GLINT_HALO_PX`] of them.
fn with_halo(glint: &Glint) -> Glint {
    let reach = GLINT_HALO_PX as i64;
    let disc: Vec<(i64, i64)> = (-reach..=reach)
        .flat_map(|dy| (-reach..=reach).map(move |dx| (dx, dy)))
        .filter(|&(dx, dy)| dx * dx + dy * dy <= reach * reach)
        .collect();
    glint.iter().flat_map(|&(x, y)| disc.iter().map(move |&(dx, dy)| (x + dx, y + dy))).collect()
}

/// How far beyond its near-white rim a glint's light still lifts the dot's signal, pixels:
/// the optics' blur, over which the glint of tuning target-less 4/08 fell from white to its
/// green water's level (about 3 px). Left in, that halo read as a bulge of the dot's
/// outline toward the glint (0.110 rough against 0.10) and pulls a centroid toward it.
const GLINT_HALO_PX: f64 = 3.0;

/// The pixel that mirrors `(x, y)` through `c`.
fn mirror(c: Vec2, x: i64, y: i64) -> (i64, i64) {
    ((2.0 * c.x).round() as i64 - x, (2.0 * c.y).round() as i64 - y)
}

/// A blob's refined centre ([`refine_centre`]).
pub(super) struct Centred {
    /// The dot's centre, image pixels.
    pub at: Vec2,
    /// The glint found beside it and left out of the centring, its halo included (empty if
    /// none): its pixels are no part of the dot's outline either.
    pub glint: Glint,
    /// A glint over the dot itself, its halo included (empty if none): the dot's clipped
    /// core may lie under it, but its outline there is the glint's.
    pub over: Glint,
}

/// The pixel square (inclusive bounds) that holds the disc of `radius` around `c`.
struct Window {
    x0: i64,
    x1: i64,
    y0: i64,
    y1: i64,
}

impl Window {
    /// `None` when the square leaves the image.
    fn around(img: &ColourView, c: Vec2, radius: f64) -> Option<Window> {
        let x0 = (c.x - radius).floor() as i64;
        let x1 = (c.x + radius).ceil() as i64;
        let y0 = (c.y - radius).floor() as i64;
        let y1 = (c.y + radius).ceil() as i64;
        if x0 < 0 || y0 < 0 || x1 >= img.width as i64 || y1 >= img.height as i64 {
            return None;
        }
        Some(Window { x0, x1, y0, y1 })
    }

    /// Each pixel of the window with its distance from `c`, row by row.
    fn pixels(&self, c: Vec2) -> impl Iterator<Item = (i64, i64, f64)> + '_ {
        (self.y0..=self.y1).flat_map(move |y| {
            (self.x0..=self.x1).map(move |x| (x, y, ((x as f64 - c.x).powi(2) + (y as f64 - c.y).powi(2)).sqrt()))
        })
    }
}

/// The background model `G = offset + slope X` fitted on a ring, where `X` is blue or red:
/// the one that follows the ring best among those that leave at least half the laser's
/// own green standing (the laser adds to `X` too, and `slope` times that is taken off).
/// The squares' contrast shows in blue in clear water but barely in green water (blue 18
/// -> 27 between squares where red goes 48 -> 82), where a slope on blue cannot follow an
/// edge; a yellow-green laser adds red, where a slope on red would cancel the dot. A noise
/// floor: twice the RMS of the ring's residuals.
struct Background {
    offset: f64,
    slope: f64,
    /// The regressor is red, not blue.
    on_red: bool,
    floor: f64,
    /// The ring's mean (R, G, B), levels.
    mean_rgb: [f64; 3],
    /// Twice the ring's RMS scatter about `mean_rgb` in the laser's second channel, levels
    /// (0 without a second channel) ([`Background::agreement`]).
    second_floor: f64,
    /// The laser's second channel ([`second_channel`]), when its colour is learned.
    second: Option<SecondChannel>,
}

/// The channel besides green in which a learned laser colour shows most (red for a
/// yellow-green laser, blue for a bluish one), and its level per level of green.
#[derive(Clone, Copy, Debug)]
struct SecondChannel {
    channel: usize,
    per_green: f64,
}

/// Share of the way from a ring's green to the clip below which a pixel's agreement with the
/// laser's colour is not judged ([`Background::agreement`]): a dim pixel's second channel is
/// at the mercy of a level or two of error in its background. Judged on every pixel above
/// the floor, the fringe of a clipped bluish dot of 430 levels moved its centre 3.2 px (seed
/// 1000119/03) and a merged blob's few agreeing pixels walked it onto the line elsewhere.
const BRIGHT_SHARE: f64 = 0.5;

/// Least share of green a laser's second channel must carry to tell its light from a
/// pigment's: a pure green laser's red and blue (0.1-0.25 of its green) are as low as an
/// algae tuft's.
const MIN_SECOND_PER_GREEN: f64 = 0.3;

/// The laser's second channel, for a learned colour that has one ([`MIN_SECOND_PER_GREEN`]);
/// `None` under the prior, which spans lasers from bluish to yellow-green.
fn second_channel(laser: &LaserColourModel) -> Option<SecondChannel> {
    if !matches!(laser.source, ColourSource::Learned { .. }) {
        return None;
    }
    let rgb = laser.rgb;
    let channel = if rgb[0] > rgb[2] { 0 } else { 2 };
    let per_green = rgb[channel] / rgb[1].max(1e-6);
    (per_green >= MIN_SECOND_PER_GREEN).then_some(SecondChannel { channel, per_green })
}

/// Share of the laser's green a background model must leave in its residual.
const MIN_KEPT_SIGNAL: f64 = 0.5;

impl Background {
    /// Least squares on the ring `ring.0..=ring.1` px from `c` (unclipped pixels only), for
    /// a laser of colour `laser_rgb`; `None` for fewer than 12 of them.
    fn fit(
        img: &ColourView,
        window: &Window,
        c: Vec2,
        (ring_a, ring_b): (f64, f64),
        laser_rgb: [f64; 3],
        second: Option<SecondChannel>,
    ) -> Option<Background> {
        let mut ring = Vec::new();
        for (x, y, d) in window.pixels(c) {
            if d < ring_a || d > ring_b {
                continue;
            }
            let (r, g, b) = img.rgb(x as usize, y as usize);
            if g >= CLIPPED || b >= CLIPPED || r >= CLIPPED {
                continue;
            }
            ring.push([r as f64, g as f64, b as f64]);
        }
        if ring.len() < 12 {
            return None;
        }
        let fit_on = |on_red: bool| -> (Background, f64) {
            let k = if on_red { 0 } else { 2 };
            let n = ring.len() as f64;
            let (mut sx, mut sg, mut sxx, mut sxg) = (0f64, 0f64, 0f64, 0f64);
            for p in &ring {
                sx += p[k];
                sg += p[1];
                sxx += p[k] * p[k];
                sxg += p[k] * p[1];
            }
            let var_x = sxx / n - (sx / n).powi(2);
            // A uniform ring gives no slope: fall back to a constant background.
            let slope = if var_x > 4.0 { ((sxg / n - sx / n * sg / n) / var_x).clamp(0.0, 3.0) } else { 0.0 };
            let offset = sg / n - slope * sx / n;
            let mut model =
                Background { offset, slope, on_red, floor: 0.0, mean_rgb: [0.0; 3], second_floor: 0.0, second };
            let ss: f64 = ring.iter().map(|p| model.residual(p[0], p[1], p[2]).powi(2)).sum();
            model.floor = 2.0 * (ss / n).sqrt();
            let kept = 1.0 - slope * laser_rgb[k] / laser_rgb[1].max(1e-6);
            (model, kept)
        };
        let (blue, red) = (fit_on(false), fit_on(true));
        let choice = match (blue.1 >= MIN_KEPT_SIGNAL, red.1 >= MIN_KEPT_SIGNAL) {
            (true, true) => {
                if red.0.floor < blue.0.floor {
                    red
                } else {
                    blue
                }
            }
            (true, false) => blue,
            (false, true) => red,
            (false, false) => {
                if red.1 > blue.1 {
                    red
                } else {
                    blue
                }
            }
        };
        let mut model = choice.0;
        let n = ring.len() as f64;
        model.mean_rgb = [0, 1, 2].map(|k| ring.iter().map(|p| p[k]).sum::<f64>() / n);
        if let Some(s) = second {
            let mean = model.mean_rgb[s.channel];
            model.second_floor = 2.0 * (ring.iter().map(|p| (p[s.channel] - mean).powi(2)).sum::<f64>() / n).sqrt();
        }
        Some(model)
    }

    /// How far a pixel's excess over the ring is the laser's light, 0 to 1: its second
    /// channel's excess over what the laser adds there with the pixel's green excess. Where
    /// green clips, every pixel of a dot and of a bright tuft touching it weighs alike in a
    /// centroid, and a tuft of another hue pulled the centre 7 px toward it (seeds 1000100/00,
    /// a bluish dot, and 1000101/11, a yellow-green one); the laser's own pixels carry its red
    /// or blue as well, a green pigment's do not. A pixel whose green is clipped reads too
    /// little green, so the dot's own clipped pixels stay at 1. Pixels less than
    /// [`BRIGHT_SHARE`] of the way from the ring's green to the clip keep their weight, and so
    /// do those where the laser's share of the second channel would be lost in the ring's
    /// scatter there (`second_floor`). On a bright green fish a dot's glow clips green with a
    /// few levels of its own, and across a fish's edge the ring's blue varies by tens of
    /// levels: there the second channel's shading, not the laser, set the weights (a
    /// 490-level dot centred 3.6 px up a bright fish's blue shading, target-less 1000200/08;
    /// a 343-level one on a fish's edge refused as off the line, 1000202/07; a 788-level one
    /// beside a clipped algae tuft, lost, 1000162/08).
    fn agreement(&self, r: f64, g: f64, b: f64) -> f64 {
        let Some(SecondChannel { channel, per_green }) = self.second else { return 1.0 };
        let green = g - self.mean_rgb[1];
        let expected = per_green * green;
        if green < BRIGHT_SHARE * (CLIPPED as f64 - self.mean_rgb[1]) || green <= 1.0 || expected < self.second_floor {
            return 1.0;
        }
        (([r, g, b][channel] - self.mean_rgb[channel]) / expected).clamp(0.0, 1.0)
    }

    /// The dot's signal: green above what the background model predicts.
    fn residual(&self, r: f64, g: f64, b: f64) -> f64 {
        g - (self.offset + self.slope * if self.on_red { r } else { b })
    }
}

/// What the white region nearest a dot's centre is ([`white_core`]).
enum WhiteCore {
    /// The dot's own core, centred here.
    Dot(Vec2),
    /// A glint: white with no clipped green around it. Its pixels (image x, y), near-white
    /// ones and its rim included.
    Glint(Glint),
    /// Neither can be told: too small, not round, or reaching the disc's edge.
    Unsure,
}

/// The white region (all channels clipped) that holds `seed`, the white pixel nearest `c`
/// ([`DiscSignal::nearest_white`]): its white pixels joined through near-white ones (JPEG
/// leaves a clipped core speckled). It is the dot's core unless its rim is a glint's
/// ([`glint_rim`]), and then centred on when it has at least `MIN_CORE_PX` white pixels
/// and lies wholly within `EDGE_SHARE` of the disc of `r_in`.
/// A glint's channels fall off together: a glint 3 px across on a dot's halo, 12 px from
/// the dot, was centred on as the dot's core, off the laser's line (tuning target-less
/// 16/00).
fn white_core(img: &ColourView, window: &Window, c: Vec2, r_in: f64, (sx0, sy0): (i64, i64)) -> WhiteCore {
    let w = (window.x1 - window.x0 + 1) as usize;
    let h = (window.y1 - window.y0 + 1) as usize;
    let level = |i: usize| {
        let (r, g, b) = img.rgb(window.x0 as usize + i % w, window.y0 as usize + i / w);
        r.min(g).min(b)
    };
    let dist = |i: usize| ((window.x0 + (i % w) as i64) as f64 - c.x).hypot((window.y0 + (i / w) as i64) as f64 - c.y);
    let seed = (sy0 - window.y0) as usize * w + (sx0 - window.x0) as usize;
    let mut seen = vec![false; w * h];
    seen[seed] = true;
    let mut stack = vec![seed];
    let (mut region, mut rim, mut reaches_edge) = (Vec::new(), Vec::new(), false);
    let mut core = Moments::default();
    while let Some(i) = stack.pop() {
        reaches_edge |= dist(i) > EDGE_SHARE * r_in;
        region.push(i);
        let (x, y) = (i % w, i / w);
        // A region the window cuts has no whole rim to judge, and lies past `EDGE_SHARE`:
        // neither a glint told apart nor a core centred on. Stopping here bounds the fill on
        // a white surface.
        if x == 0 || y == 0 || x + 1 == w || y + 1 == h {
            return WhiteCore::Unsure;
        }
        if level(i) >= CLIPPED {
            core.add(x as f64, y as f64);
        }
        for (nx, ny) in neighbours8(x, y, w, h) {
            let j = ny * w + nx;
            if !seen[j] {
                seen[j] = true;
                if level(j) >= NEAR_WHITE {
                    stack.push(j);
                } else {
                    rim.push(j);
                }
            }
        }
    }
    let pixel = |i: usize| (window.x0 as usize + i % w, window.y0 as usize + i / w);
    if glint_rim(rim.iter().map(|&i| img.rgb(pixel(i).0, pixel(i).1))) {
        return WhiteCore::Glint(
            region.into_iter().chain(rim).map(|i| (pixel(i).0 as i64, pixel(i).1 as i64)).collect(),
        );
    }
    if reaches_edge {
        return WhiteCore::Unsure;
    }
    // A core with a glint's white lobe joined to it is no longer round: its centroid lies
    // between the two (a slate dot 2.9 px off); the fringe's centroid is better there.
    match core.round_centre() {
        Some(at) => WhiteCore::Dot(Vec2::new(window.x0 as f64 + at.x, window.y0 as f64 + at.y)),
        None => WhiteCore::Unsure,
    }
}

/// Pixel count and sums of a region's pixel positions, for its centroid and second moments.
#[derive(Default)]
struct Moments {
    n: usize,
    sx: f64,
    sy: f64,
    sxx: f64,
    syy: f64,
    sxy: f64,
}

impl Moments {
    fn add(&mut self, x: f64, y: f64) {
        self.n += 1;
        (self.sx, self.sy) = (self.sx + x, self.sy + y);
        (self.sxx, self.syy, self.sxy) = (self.sxx + x * x, self.syy + y * y, self.sxy + x * y);
    }

    /// The centroid of a region of at least [`MIN_CORE_PX`] pixels that is round (its second
    /// moments' axes within [`MAX_CORE_ELONGATION`]); `None` otherwise.
    fn round_centre(&self) -> Option<Vec2> {
        if self.n < MIN_CORE_PX {
            return None;
        }
        let k = self.n as f64;
        let (mx, my) = (self.sx / k, self.sy / k);
        let (cxx, cyy, cxy) = (self.sxx / k - mx * mx, self.syy / k - my * my, self.sxy / k - mx * my);
        let (half_trace, det) = (0.5 * (cxx + cyy), cxx * cyy - cxy * cxy);
        let spread = (half_trace * half_trace - det).max(0.0).sqrt();
        let (major, minor) = (half_trace + spread, (half_trace - spread).max(1e-9));
        (major <= MAX_CORE_ELONGATION * minor).then_some(Vec2::new(mx, my))
    }
}

/// How far, pixels, the centroid of a clipped disc may lie from the core clipped in the
/// most channels before the core is taken for the centre ([`most_clipped_core`]). The disc's
/// centroid is the finer measure of a dot alone in it (sub-pixel, where the core's is a
/// count of whole pixels: on the 38 tuning target-less sets, taking the core everywhere moved
/// 41 answers, 24 of them further off, median 0.17 -> 0.23 px); a pixel apart, something
/// else in the disc pulls it.
const CORE_DISAGREEMENT_PX: f64 = 1.0;

/// The centre of the core clipped in the most channels (two at least) within `r_in` of `c`,
/// when it lies within [`EDGE_SHARE`] of the disc and is round ([`Moments::round_centre`]).
/// A bright dot of a yellow-green or cyan-green laser clips green and red or blue at its core
/// where a green tuft or a green fish beside it clips green alone; a centroid over the whole
/// disc's clipped pixels is pulled toward them (tuning target-less 1000154/17, 1000182/12,
/// 1000182/01: 7.2, 5.3 and 3.1 px off, taken as wrong dots; on the core 0.4, 0.1 and 0.2).
fn most_clipped_core(img: &ColourView, window: &Window, c: Vec2, r_in: f64) -> Option<Vec2> {
    let clipped_channels = |x: i64, y: i64| {
        let (r, g, b) = img.rgb(x as usize, y as usize);
        [r, g, b].iter().filter(|&&v| v >= CLIPPED).count()
    };
    let disc = || window.pixels(c).filter(|&(_, _, d)| d <= r_in);
    let most = disc().map(|(x, y, _)| clipped_channels(x, y)).max()?;
    if most < 2 {
        return None;
    }
    let mut core = Moments::default();
    for (x, y, d) in disc().filter(|&(x, y, _)| clipped_channels(x, y) == most) {
        if d > EDGE_SHARE * r_in {
            return None;
        }
        core.add(x as f64, y as f64);
    }
    core.round_centre()
}

/// Whether a white region whose rim (the pixels next to it, not white) reads `rim` is a
/// glint's: fewer than [`DOT_RIM_SHARE`] of them clip as a dot's glow does, green (the
/// beam's green clips well beyond where its weaker channels do) or red and blue both (a
/// dot on a surface clipped in those). A glint's channels fall off together.
fn glint_rim(rim: impl Iterator<Item = (i32, i32, i32)>) -> bool {
    let (mut n, mut like_dot) = (0usize, 0usize);
    for (r, g, b) in rim {
        n += 1;
        like_dot += (g >= CLIPPED || r.min(b) >= CLIPPED) as usize;
    }
    (like_dot as f64) < DOT_RIM_SHARE * n as f64
}

/// Least share of a white region's rim that clips as a dot's glow does, for the region to
/// be taken for a dot's core ([`glint_rim`]). A dot's rim clips green all round (31-541
/// of 34-541 rim pixels on tuning calibration seed 31's near dots), the glint of tuning
/// target-less 16/00 on 9 of 34.
const DOT_RIM_SHARE: f64 = 0.5;

/// Least level of all three channels that joins white pixels into one white region (JPEG
/// leaves a clipped core speckled).
const NEAR_WHITE: i32 = 220;

/// Largest ratio of a white core's second moments (major over minor axis, squared) that
/// is taken for one round core. A dot's core is drawn out by the camera's motion (a streak
/// centred on the dot, which leaves its centroid where it was) and read ragged through
/// JPEG; a glint's white lobe joined to it draws it out further. At 2, clipped dots
/// smeared by 4.6-10.7 px were centred by their disc's centroid instead, 3.1-6.6 px
/// toward what else lay in the disc, and taken as wrong dots (reported held-out
/// target-less 1000435/12, 1000438/10, 1000439/12), and a 28 px core at 2.15 made a dot
/// of 898 levels miss the line (1000433/03). On the tuning target-less seeds 3030-3034
/// and those reported seeds 1000432-441 (300 photos, 202 visible dots): at 2.5, right 159
/// -> 162 and wrong 5 -> 4 (with the brighter-blob rule); at 3, 163 and 1; at 4, 162 and
/// 1 (a dot on 3034/19 lost). `fslcal laser` on 16 calibration sets (1000432-437,
/// 3010-3017) gave the same answers at 2 and 3.
const MAX_CORE_ELONGATION: f64 = 3.0;

/// Share of the disc a white core must lie within: one that reaches its edge is no dot's
/// core alone (a glint beside it, a clipped surface).
const EDGE_SHARE: f64 = 0.8;
/// Fewest white pixels centred on: fewer are JPEG speckle on a core that barely clips.
const MIN_CORE_PX: usize = 5;

/// The dot's signal over the disc of `r_in` around the current centre.
struct DiscSignal {
    /// Largest unclipped residual.
    peak: f64,
    /// Sums of weight, weight x and weight y over unclipped pixels above the floor.
    acc: (f64, f64, f64),
    /// Pixels with clipped green, and how far each is the laser's light
    /// ([`Background::agreement`]).
    saturated: Vec<(f64, f64, f64)>,
    /// The pixel clipped in all three channels nearest the centre, if any.
    nearest_white: Option<(i64, i64)>,
}

impl DiscSignal {
    /// Over the disc less the pixels of `glint` and their mirror images through `c`.
    fn sum(
        img: &ColourView,
        window: &Window,
        c: Vec2,
        r_in: f64,
        background: &Background,
        glint: &Glint,
    ) -> DiscSignal {
        let mut disc = DiscSignal { peak: 0f64, acc: (0f64, 0f64, 0f64), saturated: Vec::new(), nearest_white: None };
        let mut white_d = f64::INFINITY;
        for (x, y, d) in window.pixels(c) {
            // A glint's pixels and their mirror images through the centre: left out on one
            // side only, the dot's own light there would be missed and the centroid pushed
            // away from the glint (1.1 px for a glint 9 px off).
            if d > r_in || (!glint.is_empty() && (glint.contains(&(x, y)) || glint.contains(&mirror(c, x, y)))) {
                continue;
            }
            let (r, g, b) = img.rgb(x as usize, y as usize);
            let agreement = background.agreement(r as f64, g as f64, b as f64);
            if g >= CLIPPED {
                disc.saturated.push((x as f64, y as f64, agreement));
                if r.min(b) >= CLIPPED && d < white_d {
                    (white_d, disc.nearest_white) = (d, Some((x, y)));
                }
                continue;
            }
            let e = background.residual(r as f64, g as f64, b as f64);
            disc.peak = disc.peak.max(e);
            let w = e - background.floor;
            if w > 0.0 {
                let (w, acc) = (w * agreement, disc.acc);
                disc.acc = (acc.0 + w, acc.1 + w * x as f64, acc.2 + w * y as f64);
            }
        }
        disc
    }

    /// The signal without a glint's pixels among the clipped ones.
    fn without(mut self, glint: &Glint) -> DiscSignal {
        self.saturated.retain(|&(x, y, _)| !glint.contains(&(x as i64, y as i64)));
        self
    }

    /// The centroid with the clipped core weighted at least the brightest unclipped level.
    fn centroid_with_core(self, floor: f64) -> Option<Vec2> {
        let core_w = (self.peak - floor).max(1.0);
        let mut acc = self.acc;
        for (x, y, agreement) in self.saturated {
            let w = core_w * agreement;
            acc = (acc.0 + w, acc.1 + w * x, acc.2 + w * y);
        }
        if acc.0 <= 0.0 {
            return None;
        }
        Some(Vec2::new(acc.1 / acc.0, acc.2 / acc.0))
    }
}

/// Widest Gaussian [`matched_filter_peak`] smooths with, 1 sigma in pixels. Capped at 4 px,
/// the filter was far narrower than a near unclipped dot, whose flat top it left flat: the
/// peak fell where the surface's gradient and grain tipped it, 3.3 px off a disc of 15.5 px
/// (held-out target-less 1000100/17), and the dot was refused as off the line. At 8 px a
/// 15 px disc is centred within 0.5 px (0.7 of the largest dot's half-peak radius, 17 px
/// for a 2.5 mm beam spreading 0.75 mrad seen from 0.5 m, would be 12 px, centred no
/// better and costing the along-line search's slowest photo 38-48 ms against 32 ms before).
const MAX_FILTER_SIGMA_PX: f64 = 8.0;

/// Location of the peak of the dot signal `signal(G, B)` smoothed by a Gaussian the size of
/// the dot, within `reach` of `c`, to sub-pixel by a quadratic through the peak's
/// neighbours. For a known spot shape in white noise this is the maximum-likelihood centre.
fn matched_filter_peak(
    img: &ColourView,
    c: Vec2,
    reach: f64,
    blob_radius_px: f64,
    signal: &dyn Fn(f64, f64, f64) -> f64,
) -> Option<Vec2> {
    let sigma = (0.7 * blob_radius_px).clamp(1.0, MAX_FILTER_SIGMA_PX);
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
            let (r, g, b) = img.rgb((cx - half) as usize + x, (cy - half) as usize + y);
            e[y * n + x] = signal(r as f64, g as f64, b as f64);
        }
    }
    let kernel: Vec<f64> = (-k..=k).map(|i| (-0.5 * (i as f64 / sigma).powi(2)).exp()).collect();
    // The peak is sought within `reach` and its neighbours: the smoothed map is needed
    // only that near the centre.
    let m = reach.ceil() as usize + 1;
    let f = smoothed_near_centre(&e, n, &kernel, m);
    let (bx, by, ox, oy) = sub_pixel_peak(&f, 2 * m + 1, m as i64, reach);
    Some(Vec2::new((cx + bx) as f64 + ox, (cy + by) as f64 + oy))
}

/// The square `n x n` image `data` filtered by the separable odd `kernel` along rows, then
/// columns, outside the square counting as nothing; only the `(2m + 1)^2` pixels within `m`
/// of its centre are returned (row-major), and only what they need is computed: filtering
/// the whole window of every candidate was a third of a slow photo's search.
fn smoothed_near_centre(data: &[f64], n: usize, kernel: &[f64], m: usize) -> Vec<f64> {
    let (k, c, w) = ((kernel.len() / 2) as i64, (n / 2) as i64, 2 * m + 1);
    let near = (c - m as i64)..=(c + m as i64);
    // The kernel's taps that land inside the square around index `i`, and the first index.
    let taps = |i: i64| {
        let (lo, hi) = ((k - i).max(0) as usize, (n as i64 - 1 - i + k).min(2 * k) as usize);
        (&kernel[lo..=hi], (i + lo as i64 - k) as usize)
    };
    let mut rows = vec![0f64; n * w];
    for y in 0..n {
        for (cx, x) in near.clone().enumerate() {
            let (ks, first) = taps(x);
            rows[y * w + cx] = ks.iter().zip(&data[y * n + first..]).map(|(a, b)| a * b).sum();
        }
    }
    let mut out = vec![0f64; w * w];
    for (cy, y) in near.enumerate() {
        let (ks, first) = taps(y);
        for cx in 0..w {
            out[cy * w + cx] = ks.iter().zip(rows[first * w + cx..].iter().step_by(w)).map(|(a, b)| a * b).sum();
        }
    }
    out
}

/// The largest value of the square `n x n` image `f` within `reach` of its centre `(half,
/// half)`: its offset from the centre in whole pixels and the sub-pixel vertex of a
/// quadratic through its neighbours, per axis.
fn sub_pixel_peak(f: &[f64], n: usize, half: i64, reach: f64) -> (i64, i64, f64, f64) {
    let at = |dx: i64, dy: i64| f[((half + dy) as usize) * n + (half + dx) as usize];
    let lim = reach.ceil() as i64;
    let (mut best, mut bx, mut by) = (f64::NEG_INFINITY, 0i64, 0i64);
    for dy in -lim..=lim {
        for dx in -lim..=lim {
            if (dx * dx + dy * dy) as f64 > reach * reach {
                continue;
            }
            let v = at(dx, dy);
            if v > best {
                (best, bx, by) = (v, dx, dy);
            }
        }
    }
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
    (bx, by, ox, oy)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_smoothed_centre_is_the_whole_windows_filter_there() {
        // A 2-D sum over every tap inside the square, against the two passes near the centre.
        let n = 21;
        let data: Vec<f64> = (0..n * n).map(|i| ((i * 7919) % 97) as f64 - 40.0).collect();
        let kernel = [0.2, 0.6, 1.0, 0.6, 0.2];
        // Near the centre, and out to the window's edge where taps fall outside it.
        for m in [4, n / 2] {
            let f = smoothed_near_centre(&data, n, &kernel, m);
            let (c, w) = (n as i64 / 2, 2 * m + 1);
            for cy in 0..w {
                for cx in 0..w {
                    let (x, y) = (c - m as i64 + cx as i64, c - m as i64 + cy as i64);
                    let mut want = 0.0;
                    for (ty, wy) in kernel.iter().enumerate() {
                        for (tx, wx) in kernel.iter().enumerate() {
                            let (xx, yy) = (x + tx as i64 - 2, y + ty as i64 - 2);
                            if (0..n as i64).contains(&xx) && (0..n as i64).contains(&yy) {
                                want += wy * wx * data[yy as usize * n + xx as usize];
                            }
                        }
                    }
                    assert!((f[cy * w + cx] - want).abs() < 1e-9, "({cx}, {cy}): {} {want}", f[cy * w + cx]);
                }
            }
        }
        // Reaching the window's edge, taps outside it count as nothing.
        let edge = smoothed_near_centre(&vec![1.0; n * n], n, &kernel, n / 2);
        assert!((edge[0] - 1.8 * 1.8).abs() < 1e-12 && (edge[n * (n / 2) + n / 2] - 2.6 * 2.6).abs() < 1e-12);
    }
}
