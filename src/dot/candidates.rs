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

use super::centre::{refine_centre, weighted_centre, Glint};
use super::colour::{beyond_colour_gate, with_chroma_of, LaserColourModel, ToneCurve};
use super::outline::{clipped_at_centre, hollow, outline_roughness, ContrastMap};
use fslcal_core::Vec2;

/// An 8-bit level at or above which a channel is taken as clipped (JPEG rounding keeps
/// clipped pixels a few levels below 255).
pub(super) const CLIPPED: i32 = 250;

/// The channels the laser lights: at least half as strong in its colour as its strongest.
/// Only these clipping makes a pixel a dot's core. A channel the laser barely adds to may
/// be clipped by the scene alone: in clear blue water a white square's blue is at 255 all
/// over, and taking that for a core lost dots on it (with [`surface_background`], 3 more of 129
/// tuning calibration dots found).
fn lit_channels(colour: &LaserColourModel) -> [bool; 3] {
    let top = colour.rgb.iter().copied().fold(0.0, f64::max);
    colour.rgb.map(|c| c >= 0.5 * top)
}

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
    /// Each byte read through this table ([`ToneCurve::table`]), or as it is.
    pub tone: Option<&'a [u8; 256]>,
}

impl<'a> ColourView<'a> {
    /// The view read through `tone`'s inverse: linear levels.
    pub fn through(self, tone: &'a ToneCurve) -> ColourView<'a> {
        ColourView { tone: tone.table(), ..self }
    }

    #[inline]
    pub(crate) fn rgb(&self, x: usize, y: usize) -> (i32, i32, i32) {
        let i = y * self.stride + 3 * x;
        let (a, b, c) = match self.tone {
            None => (self.data[i], self.data[i + 1], self.data[i + 2]),
            Some(t) => (t[self.data[i] as usize], t[self.data[i + 1] as usize], t[self.data[i + 2] as usize]),
        };
        let (a, b, c) = (a as i32, b as i32, c as i32);
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
    /// A checkerboard's squares as image quads (corners in order around each), when known:
    /// a pixel's background is then its own square's level, not a window's mean over black
    /// and white squares ([`board_background`]).
    pub squares: Vec<[Vec2; 4]>,
    /// One of several regions that overlap by more than a blob's reach (the pieces of the
    /// band along a laser line): a blob this region's edge cuts is seen whole in another,
    /// and is left to it ([`cut_by_region`]).
    pub overlapping_pieces: bool,
}

/// One dot-like blob.
#[derive(Clone, Debug, PartialEq)]
pub struct DotCandidate {
    /// Sub-pixel centre (pixel-centre convention).
    pub pixel: Vec2,
    /// Matched-filter signal-to-noise of the blob's excess along the laser's colour.
    pub snr: f64,
    /// Peak excess along the laser's colour (white removed) over the local background, in
    /// 8-bit levels, of the blob's unclipped pixels.
    pub peak_green: f64,
    /// Equivalent radius of the blob in pixels (its core and its halo above half the
    /// detection threshold).
    pub radius_px: f64,
    /// Equivalent radius of the blob's part at or above half its peak, clipped pixels
    /// included: the dot's own size. A bright dot's blur and scatter reach the detection
    /// threshold far out (its `radius_px` grows with its brightness); at half its peak it
    /// is as wide as its beam.
    pub core_radius_px: f64,
    /// True when the blob is clipped at its centre (a near dot, or a glint); clipped pixels
    /// elsewhere in it (a bubble's rim in a tuft) make no clipped core.
    pub saturated_core: bool,
    /// Pixels of the blob with a clipped channel.
    pub saturated_px: usize,
    /// Pixels of the blob where all three channels clip. A bright dot's own channel clips
    /// far out in its glow, the other two only at its centre; a glint or a sun fleck is
    /// white throughout its clipped core.
    pub white_px: usize,
    /// Pixels around the white part where the laser's own channels clip, white included
    /// ([`lit_clipped_around`]); 0 without a white part, or where they clip over more than a
    /// dot's glow could (a bright surface).
    pub lit_clipped_px: usize,
    /// Contrast along the laser's colour over the local background, less the off-colour
    /// part, in noise sigmas ([`LaserColourModel::score`]), scored on the blob's unclipped
    /// pixels and, for a clipped core, its fringe.
    pub colour_score: f64,
    /// Angle between the blob's chroma and the laser's, radians: for a blob whose core is
    /// clipped over less than `CLIPPED_COLOUR_SHARE` of it, read against the surface just
    /// around its core (`LOCAL_BACKGROUND_GAP_PX`), else against the ring `excess_rgb` is
    /// read against.
    pub colour_angle_rad: f64,
    /// 1-sigma uncertainty of `colour_angle_rad`, radians: the map's noise over the scored
    /// pixels, and for a clipped blob at least [`CLIPPED_CHROMA_SIGMA_RAD`].
    pub colour_angle_sigma_rad: f64,
    /// 1-sigma uncertainty of `colour_angle_rad` from the texture of the surface around it
    /// ([`TEXTURE_ERROR_SHARE`]), radians; 0 where its hue is read against the ring. Its
    /// colour is judged with both ([`Self::colour_sigmas`]); a unit's colour is
    /// learned with `colour_angle_sigma_rad` alone, whose scatter tells a wrong tone curve.
    pub colour_texture_sigma_rad: f64,
    /// How far the white part of its excess (`excess_rgb`) falls short of the laser's,
    /// radians ([`LaserColourModel::white_deficit_rad`]): a pigment darkens a channel the
    /// laser's light would lift.
    pub white_deficit_rad: f64,
    /// How far its half-peak outline departs from an ellipse, as a share of its radius
    /// ([`super::outline::outline_roughness`]); `None` when not measured (a blob too small
    /// or too faint for its outline to mean anything, or clipped at its centre). 1 when a
    /// clipped part of [`CLIPPED_MIN_RADIUS_PX`] or more lies around its centre and not at
    /// it ([`super::outline::clipped_at_centre`]), or when its middle is dim against its
    /// bright part ([`super::outline::hollow`], a bubble's rim): no beam's footprint.
    pub outline_roughness: Option<f64>,
    /// Found as a spot of its own inside a larger blob: beside a glint's clipped part
    /// (`beside_clipped`), or on a surface the blob floods over (`peak_inside`). The larger
    /// blob is a candidate too when it is one and is not centred on the spot (then the spot
    /// stands in for it: [`DotCandidate::enclosed_by`]).
    pub split_from_blob: bool,
    /// The blob this spot was found in (`peak_inside`) when that blob's candidate is centred
    /// on it: the spot stands in for the blob, measured on its own pixels, but a blob too
    /// large for a dot at its distance makes its middle no dot either (an algae tuft's
    /// brightest 4 px in its 15 px core).
    pub enclosed_by: Option<Box<DotCandidate>>,
    /// Mean excess (R, G, B) of the scored pixels over the local background, 8-bit levels.
    pub excess_rgb: [f64; 3],
    /// The excess whose chroma `colour_angle_rad` judged: `excess_rgb`'s white part and
    /// length, and for a blob whose colour was read against the surface just around its core,
    /// that reading's chroma ([`with_chroma_of`]). What a calibration learns the laser's
    /// colour from, so that the colour it learns is read as its dots are judged: learned
    /// against the ring (which may lie on another surface, [`LOCAL_BACKGROUND_GAP_PX`]),
    /// five tuning units' colours lay 8-12 degrees off their lasers', and their dots on
    /// fish, read against the band around them, were refused as off-colour; learned as
    /// judged, 0.6-4.6 degrees.
    pub judged_excess_rgb: [f64; 3],
    /// `excess_rgb` has a channel filled in from the laser's colour because that channel
    /// clips on the blob's surface ([`seen_through_clipping`]): its chroma repeats the model
    /// it was filled from, so it is no evidence of the laser's colour.
    pub colour_filled_in: bool,
}

impl DotCandidate {
    /// How far its colour lies from `colour`, in sigmas of the laser's spread, its own noise
    /// and the texture around it ([`LaserColourModel::colour_sigmas_on_texture`]); `None`
    /// under the prior.
    pub fn colour_sigmas(&self, colour: &LaserColourModel) -> Option<f64> {
        colour.colour_sigmas_on_texture(
            self.colour_angle_rad,
            self.white_deficit_rad,
            self.colour_angle_sigma_rad,
            self.colour_texture_sigma_rad,
        )
    }
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
    /// The laser's colour: the map the detector thresholds and the candidates' colour
    /// score. The green prior until a calibration has learned the unit's own.
    pub colour: LaserColourModel,
    /// Candidates whose colour score ([`DotCandidate::colour_score`]) is below this many
    /// sigmas are not returned: a white glint's fringe or an off-colour pigment.
    pub min_colour_sigmas: f64,
    /// Whether a surface whose lit channel clips all over is searched in its other channels
    /// (its red where green and blue clip, read along the laser's colour); only where a dot
    /// is expected.
    pub see_through_clipped_surfaces: bool,
}

impl Default for DotDetectorParams {
    fn default() -> Self {
        DotDetectorParams {
            threshold_sigma: 5.0,
            min_excess_levels: 10.0,
            min_snr: 8.0,
            max_area_px: 20_000,
            background_radius_px: 40,
            colour: LaserColourModel::green_prior(),
            min_colour_sigmas: 4.0,
            see_through_clipped_surfaces: false,
        }
    }
}

/// Least colour score of a blob the sensitive look keeps, in noise sigmas. It searches with
/// a lower threshold where a dot is expected, and where the dot is too faint to see it
/// finds noise: on tuning calibration seeds 0-23 the calibration's second look found specks
/// 2-13 px from a dot below visibility scoring 6-8 sigmas (three were used in fits), and 34
/// true dots scoring 11 or more; along the calibrated line on the tuning target-less seeds
/// 0-5 a speck of 5 sigmas on a photo without a dot was taken for it, and no true dot the
/// search took scored under 15.
const SENSITIVE_MIN_COLOUR_SIGMAS: f64 = 10.0;

impl DotDetectorParams {
    /// The same detector made more sensitive, for a second look where a dot is expected (a
    /// small region, or a narrow band around the laser's image): far, faint dots in murky
    /// water fall below the first search's threshold.
    pub fn sensitive(&self) -> DotDetectorParams {
        DotDetectorParams {
            threshold_sigma: 3.5,
            min_excess_levels: 5.0,
            min_snr: 5.0,
            min_colour_sigmas: SENSITIVE_MIN_COLOUR_SIGMAS,
            see_through_clipped_surfaces: true,
            ..self.clone()
        }
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
    let Some(roi) = region_of_interest(img, &region.polygon) else {
        return Vec::new();
    };
    let mut maps = RoiMaps::new(img, roi, params, &region.squares);
    let mut candidates = Vec::new();
    let mut next = 1u32;
    for start in 0..roi.w * roi.h {
        // A clipped pixel seeds a blob too: near a dot's core the unclipped channels keep
        // rising while the laser's own has stopped, so the core's colour drifts off the
        // laser's (a yellow-green dot's core turns yellow, then white) and its contrast
        // along the laser's colour can fall below zero. Its fringe's colour decides.
        if maps.label[start] != 0 || (maps.excess[start] < maps.threshold && !maps.saturated[start]) {
            continue;
        }
        let (sx, sy) = (start % roi.w, start / roi.w);
        if !point_in_convex_polygon(&region.polygon, roi.image_point(sx, sy)) {
            continue;
        }
        let id = next;
        next += 1;
        let pixels = maps.flood_fill(start, id, params.max_area_px);
        let mut whole = blob_candidate(img, region, params, &maps, &pixels, id);
        // Spots are split from a blob only where a band is known (along a line, or around a
        // calibration's predicted dot), whose gate judges a spot against its parent. On a
        // whole target the consensus over photos picks among the candidates; an earlier form
        // of the glint's split there changed three tuning companion calibrations.
        let Some(band) = &region.band else {
            candidates.extend(whole);
            continue;
        };
        if whole.as_ref().is_some_and(|c| c.saturated_core) {
            if let Some(spot) = beside_clipped(img, &mut maps, &pixels, id, next) {
                candidates.extend(split_candidate(img, region, params, &maps, &spot, next, whole.as_ref()));
                next += 1;
            }
        }
        let mut spot = peak_inside(&mut maps, &pixels, (id, next), band, whole.is_none());
        if spot.is_none() {
            spot = on_line_inside(&mut maps, &pixels, (id, next), band, whole.as_ref());
        }
        if let Some(spot) = spot {
            match blob_candidate(img, region, params, &maps, &spot, next) {
                Some(c) if apart(&c, whole.as_ref()) => candidates.push(DotCandidate { split_from_blob: true, ..c }),
                // The blob centred on its own peak: the spot measures it, the blob's colour
                // and size being its surface's (a dot on a green fin read 86 degrees off its
                // unit's colour over the fin's 2 400 px, 20 against its own spot: fresh
                // target-less 1000091/16). It is judged by that blob's size too, unless the
                // two are of different lights ([`another_light`]).
                Some(c) => {
                    let enclosed_by = whole.filter(|w| !another_light(&params.colour, &c, w)).map(Box::new);
                    whole = Some(DotCandidate { enclosed_by, ..c })
                }
                None => {}
            }
            next += 1;
        }
        candidates.extend(whole);
    }
    candidates.sort_by(|a, b| b.snr.total_cmp(&a.snr));
    candidates.truncate(max);
    candidates
}

/// Whether a spot found at a blob's middle is a light of its own rather than the blob's
/// brightest part: its colour is the laser's (within the learned colour's gate) where the
/// blob's is not. A tuft's middle has the tuft's colour, as the blob around it does; a dot
/// on a tuft or a fin adds the laser's, and the blob's colour is the pigment's, read over
/// its many pixels. Judged by the tuft's size, dots of 145 and 170 levels sitting on algae
/// were refused as too large (target-less 1000208/08, 1000163/19: spots 0.02 and 0.17
/// sigmas off their units' colours, the tufts 5.2 and 5.7). The spot's colour is judged
/// against the laser's spread alone, as if read without error: a clipped spot's chroma is
/// given a wide uncertainty (`CLIPPED_CHROMA_SIGMA_RAD`) that admitted a spot 39 degrees off
/// (a dot's white core merged with a tuft 15 px away and centred 4.3 px toward it, fresh
/// target-less 1000230/06, then taken as a wrong dot); that is no evidence against the
/// blob's size. Under the prior, which judges no colour, a spot always stands for its blob.
fn another_light(colour: &LaserColourModel, spot: &DotCandidate, blob: &DotCandidate) -> bool {
    let spot_sigmas = colour.colour_sigmas(spot.colour_angle_rad, spot.white_deficit_rad, 0.0);
    let blob_sigmas = blob.colour_sigmas(colour);
    spot_sigmas.is_some() && !beyond_colour_gate(spot_sigmas) && beyond_colour_gate(blob_sigmas)
}

/// The candidate of a spot split from a blob (labelled `id`), unless the blob's own
/// candidate (`whole`) is centred on it: then it is no second spot.
fn split_candidate(
    img: &ColourView,
    region: &SearchRegion,
    params: &DotDetectorParams,
    maps: &RoiMaps,
    spot: &[usize],
    id: u32,
    whole: Option<&DotCandidate>,
) -> Option<DotCandidate> {
    let c = blob_candidate(img, region, params, maps, spot, id)?;
    apart(&c, whole).then_some(DotCandidate { split_from_blob: true, ..c })
}

/// Whether a spot's candidate `c` lies apart from its blob's own (`whole`), as a second
/// spot, rather than where the blob is centred.
fn apart(c: &DotCandidate, whole: Option<&DotCandidate>) -> bool {
    whole.is_none_or(|w| (c.pixel - w.pixel).norm() >= 2.0 * c.radius_px.max(2.0))
}

/// Least distance, pixels (8-connected steps), from a blob's clipped part at which a peak of
/// its own is a second spot ([`beside_clipped`]): a clipped core's fringe lies within two or
/// three pixels of it.
const BESIDE_CLIPPED_GAP_PX: u16 = 4;

/// The fringe of a clipped part, pixels (8-connected steps): where its colour is read.
const CLIPPED_FRINGE_PX: u16 = 2;

/// Least ratio of a clipped part's fringe's mean excess (R, G, B averaged) to the length of
/// its chroma at which the clipped part is a glint's: light of the water's own colour, near
/// white. On the tuning target-less photos two glints' fringes measured 8.7-11.4 (one, in
/// four pieces of the band) and 14.3, a clipped dot's fringe 1.05 and another clipped
/// blob's 1.4.
const GLINT_FRINGE_WHITENESS: f64 = 3.0;

/// A second spot inside a blob whose candidate sits on a glint's clipped part: a dot beside
/// a glint, which the glint's clipped core bridges into one blob centred on the glint, off
/// the laser's line (tuning target-less seed 4 photo 8: a dot 13 px from a glint, one
/// 458 px blob). The clipped part is a glint's when its fringe is fainter along the laser's
/// colour than the spot and near white ([`GLINT_FRINGE_WHITENESS`]); a dot's clipped core
/// is ringed by its own brightest unclipped pixels, of the laser's colour. The spot is the
/// blob's unclipped pixel of most contrast at least [`BESIDE_CLIPPED_GAP_PX`] from every
/// clipped one, when it is a local peak above the map's threshold (a clipped core's own
/// fringe rises toward the core, so its farthest pixels are no peak). Its pixels, those
/// reached from it at half its contrast or more and clear of the fringe, are labelled `id`
/// and returned.
fn beside_clipped(img: &ColourView, maps: &mut RoiMaps, pixels: &[usize], own: u32, id: u32) -> Option<Vec<usize>> {
    let (w, h) = (maps.roi.w, maps.roi.h);
    let (x0, x1, y0, y1) = blob_box(pixels, w);
    // Steps from the clipped part over the blob's box (multi-source breadth first).
    let bw = x1 - x0 + 1;
    let cell = |i: usize| (i / w - y0) * bw + (i % w - x0);
    let mut steps = vec![u16::MAX; bw * (y1 - y0 + 1)];
    let mut queue: Vec<usize> = pixels.iter().copied().filter(|&i| maps.saturated[i]).collect();
    if queue.is_empty() || queue.len() == pixels.len() {
        return None;
    }
    for &i in &queue {
        steps[cell(i)] = 0;
    }
    let mut k = 0;
    while k < queue.len() {
        let i = queue[k];
        k += 1;
        let next = steps[cell(i)].saturating_add(1);
        for (x, y) in neighbours8(i % w, i / w, w, h) {
            if (x0..=x1).contains(&x) && (y0..=y1).contains(&y) && steps[cell(y * w + x)] > next {
                steps[cell(y * w + x)] = next;
                queue.push(y * w + x);
            }
        }
    }
    let unclipped = || pixels.iter().copied().filter(|&i| !maps.saturated[i]);
    let peak = unclipped()
        .filter(|&i| maps.excess[i] >= maps.threshold && steps[cell(i)] >= BESIDE_CLIPPED_GAP_PX)
        .max_by(|&a, &b| maps.excess[a].total_cmp(&maps.excess[b]))?;
    let level = maps.excess[peak];
    let is_peak = neighbours8(peak % w, peak / w, w, h)
        .all(|(x, y)| !maps.saturated[y * w + x] && maps.excess[y * w + x] <= level);
    let fringe: Vec<usize> = unclipped().filter(|&i| steps[cell(i)] <= CLIPPED_FRINGE_PX).collect();
    let fringe_level = fringe.iter().map(|&i| maps.excess[i] as f64).sum::<f64>() / fringe.len().max(1) as f64;
    if !is_peak || fringe.is_empty() || fringe_level >= level as f64 {
        return None;
    }
    // The fringe's colour over the blob's surroundings (unlabelled pixels up to 4 px out).
    let mean_rgb = |idx: &mut dyn Iterator<Item = usize>| {
        let (mut sum, mut n) = ([0f64; 3], 0f64);
        for i in idx {
            let (r, g, b) = img.rgb(maps.roi.x0 + i % w, maps.roi.y0 + i / w);
            sum = [sum[0] + r as f64, sum[1] + g as f64, sum[2] + b as f64];
            n += 1.0;
        }
        (n > 0.0).then(|| sum.map(|v| v / n))
    };
    let (ax, bx, ay, by) = (x0.saturating_sub(4), (x1 + 4).min(w - 1), y0.saturating_sub(4), (y1 + 4).min(h - 1));
    let label = &maps.label;
    let around = mean_rgb(&mut (ay..=by).flat_map(|y| (ax..=bx).map(move |x| y * w + x)).filter(|&i| label[i] == 0))?;
    let lit = mean_rgb(&mut fringe.iter().copied())?;
    let excess = [lit[0] - around[0], lit[1] - around[1], lit[2] - around[2]];
    let grey = (excess[0] + excess[1] + excess[2]) / 3.0;
    let chroma = excess.iter().map(|e| (e - grey).powi(2)).sum::<f64>().sqrt();
    if grey < GLINT_FRINGE_WHITENESS * chroma {
        return None;
    }
    let mut spot = vec![peak];
    maps.label[peak] = id;
    let mut k = 0;
    while k < spot.len() {
        let i = spot[k];
        k += 1;
        for (x, y) in neighbours8(i % w, i / w, w, h) {
            let j = y * w + x;
            let clear = (x0..=x1).contains(&x) && (y0..=y1).contains(&y) && steps[cell(j)] > CLIPPED_FRINGE_PX;
            if maps.label[j] == own && clear && maps.excess[j] >= 0.5 * level {
                maps.label[j] = id;
                spot.push(j);
            }
        }
    }
    Some(spot)
}

/// Least blob, pixels, searched for a dot inside it ([`peak_inside`]). On the tuning
/// target-less photos, 800 px (a disc 32 px across) found three dots inside fish and reef
/// blobs of 1 500-8 900 px and lost none; 400 px found two more but split a fin's 708 px
/// blob into a speck beside a dot (ambiguous) and took a speck for a faint dot; 1 500 px
/// found one fewer.
const PEAK_INSIDE_MIN_BLOB_PX: usize = 800;

/// Largest share of its blob that a spot found inside it may cover: a larger one is the
/// blob's own bright part, not a dot on it.
const PEAK_INSIDE_MAX_SHARE: f64 = 0.25;

/// Least blob, pixels, that [`peak_inside`] searches below [`PEAK_INSIDE_MIN_BLOB_PX`]:
/// only a blob refused whole, and only for a clipped core, which may then cover up to
/// [`REFUSED_BLOB_MAX_SHARE`] of it. A near dot on an algae tuft clips its green while the
/// tuft does not, and the two make one blob of the tuft's colour (tuning target-less
/// 3007/04: a dot of 139 levels, radius 9.5 px, in a 343 px blob read 300 sigmas off the
/// unit's colour). Held-out 1000360-395 (640 photos): one more dot, no other answer
/// changed. Unclipped peaks were tried too: three more dots on 1000384-395 but a dot on a
/// laser-off photo (1000371/12, a 28-level speck).
const REFUSED_BLOB_MIN_PX: usize = 200;

/// Largest share of a refused small blob its clipped spot may cover ([`REFUSED_BLOB_MIN_PX`]):
/// the dot is most of it; the rest is the surface flooded in around it. 0.5-0.9 found the
/// same dots on tuning.
const REFUSED_BLOB_MAX_SHARE: f64 = 0.7;

/// A dot inside a larger blob: on a fish or a reef lit brighter than the water along the
/// laser's colour, the surface floods into one blob with the dot, and the blob's centre is
/// the surface's, off the line (tuning target-less 16/15: a dot of 152 levels in a fish's
/// 8 900 px blob centred 80 px from it). The spot is the blob's brightest part on the band,
/// a clipped part first (a near dot's core clips); its pixels are those reached from it at
/// half its level or more, or, where that floods the surface, at half its level over the
/// blob's median. It must be a local peak and at most [`PEAK_INSIDE_MAX_SHARE`] of the
/// blob. When the brightest part makes no spot, the pixel standing most above the ring
/// around it ([`prominent_peak`]) is tried, its spot cut halfway up from that ring. A
/// smaller blob that made no candidate whole (`refused`) is searched for a clipped core
/// only ([`REFUSED_BLOB_MIN_PX`]). Its pixels are labelled `id` and returned.
fn peak_inside(
    maps: &mut RoiMaps,
    pixels: &[usize],
    (own, id): (u32, u32),
    band: &(Vec<Vec2>, f64),
    refused: bool,
) -> Option<Vec<usize>> {
    let small = pixels.len() < PEAK_INSIDE_MIN_BLOB_PX;
    if small && !(refused && pixels.len() >= REFUSED_BLOB_MIN_PX) {
        return None;
    }
    let share = if small { REFUSED_BLOB_MAX_SHARE } else { PEAK_INSIDE_MAX_SHARE };
    let w = maps.roi.w;
    let (line, half) = band;
    let rank = |i: usize| maps.rank(i);
    let mut peak: Option<usize> = None;
    for &i in pixels {
        // The band's distance only for a pixel that would be the new peak.
        if peak.is_none_or(|p| rank(i) > rank(p))
            && distance_to_polyline(line, maps.roi.image_point(i % w, i / w)) <= *half
        {
            peak = Some(i);
        }
    }
    if small && !maps.saturated[peak?] {
        return None;
    }
    if let Some(spot) = spot_at_peak(maps, pixels, (own, id), peak?, share) {
        return Some(spot);
    }
    if small {
        return None;
    }
    // The brightest part was no spot: a glint's or a bubble's clipped speck, or the bright
    // body itself. A dot stands above its own ring wherever it lies on the surface (tuning
    // target-less 1000127/13: a dot of 50 levels 16 px from a clipped speck on a reef).
    let (peak, cut) = prominent_peak(maps, pixels, band)?;
    maps.label[peak] = id;
    let most = (PEAK_INSIDE_MAX_SHARE * pixels.len() as f64) as usize;
    let spot = grow_spot(maps, &[peak], (own, id), cut, most).filter(|s| s.len() >= 2);
    if spot.is_none() {
        // A spot that flooded the blob leaves only its seed labelled.
        maps.label[peak] = own;
    }
    spot
}

/// Half-width, pixels, of the strip along the line's image in which [`on_line_inside`]
/// looks for a dot inside a blob centred off it: a calibrated line's image lies within a
/// pixel or two of its dots at 0.5-5 m.
const ON_LINE_STRIP_PX: f64 = 4.0;

/// Least blob, pixels, [`on_line_inside`] searches: a far dot's half-peak core is a few to 20
/// pixels, and one merged with a neighbour makes more; smaller blobs are measured whole.
const ON_LINE_MIN_BLOB_PX: usize = 40;

/// Least ratio of an unclipped peak found by [`on_line_inside`] to its blob's median
/// excess: a dot stands out of what it merged with (3.4 and 4.1 times on the tuning and
/// reported target-less photos where it was found), a fin's or tuft's brightest part on the
/// line does not (1.8 times on a fin crossing the line, tuning 3032/16).
const ON_LINE_PEAK_OVER_MEDIAN: f64 = 2.5;

/// A dot merged with a tuft, a fin's spot or a glint beside it: the two make one blob
/// centred off the line, at their joint centre, and too wide for a dot, though the dot's
/// part lies on the line (reported target-less 1000441/09: a dot of 17 levels in a blob of
/// 790 px whose median was 4). The blob's brightest part within
/// [`ON_LINE_STRIP_PX`] of the line, when it is the blob's brightest and stands out of it
/// ([`ON_LINE_PEAK_OVER_MEDIAN`]), is grown as [`peak_inside`] grows a spot, up to
/// [`REFUSED_BLOB_MAX_SHARE`] of the blob. Only for a blob whose centre lies off that
/// strip; its pixels are labelled `id`. On the tuning and reported target-less sets (300
/// photos, 228 with a dot) it found 3 more dots and changed no other answer; without the
/// median's test (with or without [`prominent_peak`] as a fallback) it also took a fin
/// crossing the line for a dot of 5 levels (tuning 3032/16).
fn on_line_inside(
    maps: &mut RoiMaps,
    pixels: &[usize],
    (own, id): (u32, u32),
    (line, _): &(Vec<Vec2>, f64),
    whole: Option<&DotCandidate>,
) -> Option<Vec<usize>> {
    // Along a line only: around a calibration's predicted dot (a one-point band) the fit's
    // consensus over photos judges the whole blobs, and it was not measured there.
    let centred = |c: &DotCandidate| distance_to_polyline(line, c.pixel) <= ON_LINE_STRIP_PX;
    if line.len() < 2 || pixels.len() < ON_LINE_MIN_BLOB_PX || whole.is_some_and(centred) {
        return None;
    }
    // A dot outshines the tuft or fin it merged with; a fin crossing the line has its
    // brightest part on the line only by chance. The line's distance is taken only for the
    // blob's brightest pixels.
    let w = maps.roi.w;
    let brightest = pixels.iter().map(|&i| maps.rank(i)).fold(f32::MIN, f32::max);
    let on_strip = |i: usize| distance_to_polyline(line, maps.roi.image_point(i % w, i / w)) <= ON_LINE_STRIP_PX;
    let peak = pixels.iter().rev().copied().find(|&i| maps.rank(i) == brightest && on_strip(i))?;
    if !maps.saturated[peak]
        && f64::from(maps.excess[peak]) < ON_LINE_PEAK_OVER_MEDIAN * f64::from(maps.median_excess(pixels))
    {
        return None;
    }
    spot_at_peak(maps, pixels, (own, id), peak, REFUSED_BLOB_MAX_SHARE)
}

/// Radius of the ring a spot inside a blob must stand above ([`prominent_peak`]), pixels:
/// wider than most dots' half-peak core (1.5-5 px at 0.5-5 m), narrow enough that the
/// surface around it is the dot's own.
const PROMINENCE_RING_PX: f64 = 6.0;

/// Which of the ring's 16 levels, counted from the lowest, a spot must stand above: the
/// upper quartile, so that the surface's edge (half the ring off the surface) or a thin
/// streak across the ring does not make a pixel stand out.
const PROMINENCE_RANK: usize = 11;

/// The pixel of blob `pixels` on the band that stands most above its ring (its level over
/// the ring's [`PROMINENCE_RANK`]th, unclipped pixels only), when it is a local peak that
/// stands at least the map's threshold above; with the level halfway from that ring level
/// to its own, where its spot is cut.
fn prominent_peak(maps: &RoiMaps, pixels: &[usize], (line, half): &(Vec<Vec2>, f64)) -> Option<(usize, f32)> {
    let (w, h) = (maps.roi.w, maps.roi.h);
    let ring: Vec<(i64, i64)> = (0..16)
        .map(|k| {
            let a = k as f64 * core::f64::consts::PI / 8.0;
            ((PROMINENCE_RING_PX * a.cos()).round() as i64, (PROMINENCE_RING_PX * a.sin()).round() as i64)
        })
        .collect();
    let level_around = |i: usize| -> Option<f32> {
        let (x, y) = ((i % w) as i64, (i / w) as i64);
        let mut levels = [0f32; 16];
        for (level, &(dx, dy)) in levels.iter_mut().zip(&ring) {
            let (u, v) = (x + dx, y + dy);
            if u < 0 || v < 0 || u >= w as i64 || v >= h as i64 {
                return None;
            }
            *level = maps.excess[v as usize * w + u as usize];
        }
        levels.sort_by(|a, b| a.total_cmp(b));
        Some(levels[PROMINENCE_RANK])
    };
    let mut best: Option<(usize, f32, f32)> = None;
    for &i in pixels.iter().filter(|&&i| !maps.saturated[i]) {
        let Some(around) = level_around(i) else { continue };
        let prominence = maps.excess[i] - around;
        if best.is_none_or(|b| prominence > b.1)
            && distance_to_polyline(line, maps.roi.image_point(i % w, i / w)) <= *half
        {
            best = Some((i, prominence, around));
        }
    }
    let (peak, prominence, around) = best?;
    let level = maps.excess[peak];
    let is_peak = neighbours8(peak % w, peak / w, w, h).all(|(x, y)| maps.excess[y * w + x] <= level);
    (is_peak && prominence >= maps.threshold).then_some((peak, around + 0.5 * prominence))
}

/// The spot [`peak_inside`] grows from `peak`: its pixels, labelled `id`, or `None` (the
/// labels left as they were) when it is no local peak, covers more than `share` of the
/// blob, or is one pixel.
fn spot_at_peak(
    maps: &mut RoiMaps,
    pixels: &[usize],
    (own, id): (u32, u32),
    peak: usize,
    share: f64,
) -> Option<Vec<usize>> {
    let (w, h) = (maps.roi.w, maps.roi.h);
    maps.label[peak] = id;
    // A clipped peak brings its whole clipped part, whose level is its brightest unclipped
    // neighbour's.
    let seeds =
        if maps.saturated[peak] { grow_spot(maps, &[peak], (own, id), f32::INFINITY, usize::MAX)? } else { vec![peak] };
    let level = if maps.saturated[peak] {
        let fringe = seeds.iter().flat_map(|&i| neighbours8(i % w, i / w, w, h)).map(|(x, y)| y * w + x);
        fringe.filter(|&j| maps.label[j] == own).map(|j| maps.excess[j]).fold(0f32, f32::max)
    } else {
        maps.excess[peak]
    };
    let is_peak =
        maps.saturated[peak] || neighbours8(peak % w, peak / w, w, h).all(|(x, y)| maps.excess[y * w + x] <= level);
    let most = (share * pixels.len() as f64) as usize;
    let spot = if is_peak {
        grow_spot(maps, &seeds, (own, id), 0.5 * level, most).or_else(|| {
            let base = maps.median_excess(pixels);
            let cut = base + 0.5 * (level - base);
            (level - base >= maps.threshold).then(|| grow_spot(maps, &seeds, (own, id), cut, most)).flatten()
        })
    } else {
        None
    };
    match spot {
        Some(spot) if spot.len() >= 2 => Some(spot),
        _ => {
            for &i in &seeds {
                maps.label[i] = own;
            }
            None
        }
    }
}

/// The pixels of blob `labels.0` reached from `seeds` (already labelled `labels.1`) through
/// pixels clipped or of excess `cut` or more, labelled `labels.1`; `None`, with only the
/// seeds left labelled, when they are more than `most`.
fn grow_spot(maps: &mut RoiMaps, seeds: &[usize], (own, id): (u32, u32), cut: f32, most: usize) -> Option<Vec<usize>> {
    let (w, h) = (maps.roi.w, maps.roi.h);
    let mut spot = seeds.to_vec();
    let mut k = 0;
    while k < spot.len() && spot.len() <= most {
        let i = spot[k];
        k += 1;
        for (x, y) in neighbours8(i % w, i / w, w, h) {
            let j = y * w + x;
            if maps.label[j] == own && (maps.saturated[j] || maps.excess[j] >= cut) {
                maps.label[j] = id;
                spot.push(j);
            }
        }
    }
    if spot.len() > most {
        for &i in &spot[seeds.len()..] {
            maps.label[i] = own;
        }
        return None;
    }
    Some(spot)
}

/// The searched part of the image: the search polygon's bounding box clipped to the image,
/// with its origin in image pixels and its size.
#[derive(Clone, Copy, Debug)]
pub(super) struct Roi {
    pub(super) x0: usize,
    pub(super) y0: usize,
    pub(super) w: usize,
    pub(super) h: usize,
}

impl Roi {
    /// The image pixel of the ROI's pixel `(x, y)`.
    fn image_point(&self, x: usize, y: usize) -> Vec2 {
        Vec2::new((self.x0 + x) as f64, (self.y0 + y) as f64)
    }
}

/// The polygon's bounding box, clipped to the image (the whole image for no polygon); `None`
/// when too small to hold a dot and its background.
fn region_of_interest(img: &ColourView, polygon: &[Vec2]) -> Option<Roi> {
    let (mut x0, mut y0, mut x1, mut y1) = (0usize, 0usize, img.width, img.height);
    if polygon.len() >= 3 {
        let minx = polygon.iter().map(|p| p.x).fold(f64::INFINITY, f64::min);
        let maxx = polygon.iter().map(|p| p.x).fold(f64::NEG_INFINITY, f64::max);
        let miny = polygon.iter().map(|p| p.y).fold(f64::INFINITY, f64::min);
        let maxy = polygon.iter().map(|p| p.y).fold(f64::NEG_INFINITY, f64::max);
        x0 = minx.floor().clamp(0.0, img.width as f64) as usize;
        x1 = (maxx.ceil() + 1.0).clamp(0.0, img.width as f64) as usize;
        y0 = miny.floor().clamp(0.0, img.height as f64) as usize;
        y1 = (maxy.ceil() + 1.0).clamp(0.0, img.height as f64) as usize;
    }
    if x1 <= x0 + 4 || y1 <= y0 + 4 {
        return None;
    }
    Some(Roi { x0, y0, w: x1 - x0, h: y1 - y0 })
}

/// The detector's per-pixel maps over the ROI, row-major `w * h`.
pub(super) struct RoiMaps {
    pub(super) roi: Roi,
    /// Contrast along the laser's colour over the local background, 8-bit levels.
    pub(super) excess: Vec<f32>,
    /// Some channel is clipped.
    pub(super) saturated: Vec<bool>,
    /// Blob id of each pixel, 0 for none yet.
    pub(super) label: Vec<u32>,
    /// Robust noise sigma of `excess`, 8-bit levels.
    pub(super) sigma: f64,
    /// Green excess that seeds a blob, 8-bit levels.
    pub(super) threshold: f32,
    /// The map's weights (R, G, B): the laser's colour matched against the ROI's own.
    pub(super) weights: [f64; 3],
}

impl RoiMaps {
    /// A pixel's rank as a blob's peak: a clipped one above every unclipped excess.
    fn rank(&self, i: usize) -> f32 {
        if self.saturated[i] {
            f32::INFINITY
        } else {
            self.excess[i]
        }
    }

    /// The median excess over a blob's `pixels`.
    fn median_excess(&self, pixels: &[usize]) -> f32 {
        let mut levels: Vec<f32> = pixels.iter().map(|&i| self.excess[i]).collect();
        let mid = levels.len() / 2;
        *levels.select_nth_unstable_by(mid, |a, b| a.total_cmp(b)).1
    }

    fn new(img: &ColourView, roi: Roi, params: &DotDetectorParams, squares: &[[Vec2; 4]]) -> RoiMaps {
        let weights = params.colour.matched_weights(scene_samples(img, roi), SCENE_NOISE_LEVELS);
        let lit = lit_channels(&params.colour);
        let see = params.see_through_clipped_surfaces.then_some(params.colour.rgb);
        let limits =
            CoreLimits { any_px: largest_core_px(params.max_area_px, squares), round_white_px: params.max_area_px };
        let (g, saturated) = laser_contrast(img, roi, weights, lit, see, limits);
        let mut excess = minus_local_background(&g, roi, params.background_radius_px);
        board_background(&g, roi, squares, &mut excess);
        let sigma = robust_noise(&excess, &square_edges(roi, squares));
        let threshold = (params.threshold_sigma * sigma).max(params.min_excess_levels) as f32;
        // Freed before the labels are made: on a near board's ROI each map is tens of MB.
        drop(g);
        RoiMaps { roi, excess, saturated, label: vec![0u32; roi.w * roi.h], sigma, threshold, weights }
    }

    /// Labels the blob grown from `start` as `id`: 8-connected pixels whose excess is above
    /// half the threshold or that are saturated (the white core of a near dot has no green
    /// excess of its own). Returns its pixels in the order reached, no more than
    /// `max_area_px + 1`: a longer list is a blob too large for a dot. The whole blob is
    /// labelled even so: a fill cut short left the rest of a large blob unlabelled, to seed
    /// blobs of its own.
    fn flood_fill(&mut self, start: usize, id: u32, max_area_px: usize) -> Vec<usize> {
        let (w, h) = (self.roi.w, self.roi.h);
        self.label[start] = id;
        let mut stack = vec![start];
        let mut pixels = Vec::new();
        while let Some(i) = stack.pop() {
            if pixels.len() <= max_area_px {
                pixels.push(i);
            }
            for (nx, ny) in neighbours8(i % w, i / w, w, h) {
                let j = ny * w + nx;
                if self.label[j] == 0 && (self.excess[j] >= self.threshold * 0.5 || self.saturated[j]) {
                    self.label[j] = id;
                    stack.push(j);
                }
            }
        }
        pixels
    }
}

/// Largest clipped region taken for a dot's core, pixels: the detector's dot size, and on a
/// board at most [`CORE_SQUARE_SHARE`] of its median square. A bright square whose green
/// clips all over is no core, yet at 1.5 m it is 7 000 px, within a near dot's 20 000: a
/// dot on it merged with it into one blob whose colour was the square's (tuning calibration
/// seeds 2 and 9).
fn largest_core_px(max_area_px: usize, squares: &[[Vec2; 4]]) -> usize {
    let mut areas: Vec<f64> = squares.iter().map(quad_area).collect();
    if areas.is_empty() {
        return max_area_px;
    }
    let mid = areas.len() / 2;
    let median = *areas.select_nth_unstable_by(mid, |a, b| a.total_cmp(b)).1;
    max_area_px.min((CORE_SQUARE_SHARE * median) as usize)
}

/// Largest connected clipped regions taken for a dot's core, pixels ([`clipped_cores`]).
#[derive(Clone, Copy, Debug)]
struct CoreLimits {
    /// Any clipped region ([`largest_core_px`]).
    any_px: usize,
    /// A round white region ([`round`]): a very near dot's white core may cover more of a
    /// board's square than any other clipped region.
    round_white_px: usize,
}

/// The share of a board's square a dot's clipped core may cover: a dot at 0.55 m clips
/// about 270 px, its square there 52 000 px.
const CORE_SQUARE_SHARE: f64 = 0.25;

/// Area of a quad whose corners go round it, pixels squared (the shoelace formula).
fn quad_area(q: &[Vec2; 4]) -> f64 {
    0.5 * (0..4).map(|i| q[i].x * q[(i + 1) % 4].y - q[(i + 1) % 4].x * q[i].y).sum::<f64>().abs()
}

/// Noise per channel the scene-adapted map keeps as its floor, 8-bit levels: a scene with
/// little colour variation is weighted along the laser's colour itself.
const SCENE_NOISE_LEVELS: f64 = 3.0;

/// Every 7th pixel of the ROI, unclipped, as (R, G, B): the scene's colour variation.
fn scene_samples<'a>(img: &'a ColourView<'a>, roi: Roi) -> impl Iterator<Item = [f64; 3]> + 'a {
    (0..roi.w * roi.h).step_by(7).filter_map(move |i| {
        let (r, g, b) = img.rgb(roi.x0 + i % roi.w, roi.y0 + i / roi.w);
        (r.max(g).max(b) < CLIPPED).then_some([r as f64, g as f64, b as f64])
    })
}

/// The laser's contrast over the ROI: each pixel projected on the laser's colour with white
/// removed (`weights`, [`LaserColourModel::matched_weights`]), and where a core clips
/// ([`clip_bits`]) but the surface around it does not ([`clipped_cores`]).
fn laser_contrast(
    img: &ColourView,
    roi: Roi,
    weights: [f64; 3],
    lit: [bool; 3],
    see: Option<[f64; 3]>,
    limits: CoreLimits,
) -> (Vec<f32>, Vec<bool>) {
    let (w, h) = (roi.w, roi.h);
    let [wr, wg, wb] = weights.map(|v| v as f32);
    let mut g = vec![0f32; w * h];
    let mut clips = vec![0u8; w * h];
    for y in 0..h {
        for x in 0..w {
            let (r, gg, b) = img.rgb(roi.x0 + x, roi.y0 + y);
            g[y * w + x] = wr * r as f32 + wg * gg as f32 + wb * b as f32;
            clips[y * w + x] = clip_bits(lit, (r, gg, b));
        }
    }
    let Some(laser_rgb) = see else {
        return (g, clipped_cores(clips, roi, limits));
    };
    let surface = clipped_surfaces(&clips, roi);
    let mut cores = clipped_cores(clips, roi, limits);
    for (c, &s) in cores.iter_mut().zip(&surface) {
        *c &= !s;
    }
    see_through_clipped_surfaces(img, roi, weights, laser_rgb, &surface, &mut g);
    (g, cores)
}

/// The pixels where a lit channel clips over a region that reaches the search's edge: a
/// surface, where a search around an expected dot holds the dot's core inside it.
fn clipped_surfaces(clips: &[u8], roi: Roi) -> Vec<bool> {
    let (w, h) = (roi.w, roi.h);
    let lit = |i: usize| clips[i] & 0x07 != 0;
    let mut surface = vec![false; w * h];
    let mut stack: Vec<usize> = (0..w * h)
        .filter(|&i| {
            let (x, y) = (i % w, i / w);
            (x == 0 || y == 0 || x + 1 == w || y + 1 == h) && lit(i)
        })
        .collect();
    for &i in &stack {
        surface[i] = true;
    }
    while let Some(i) = stack.pop() {
        for (nx, ny) in neighbours8(i % w, i / w, w, h) {
            let j = ny * w + nx;
            if !surface[j] && lit(j) {
                surface[j] = true;
                stack.push(j);
            }
        }
    }
    surface
}

/// Where a lit channel clips over the surface itself (not a dot's core), the laser's
/// contrast as its unclipped channels show it: a cyan square in clear water clips green and
/// blue, and a dot on it shows only in red, which the map's weights count against it (a dot
/// 145 levels over the square in red scored below the square). There each pixel's unclipped
/// channels are read along the laser's colour ([`along_seen`], as the colour fill-in reads
/// them).
fn see_through_clipped_surfaces(
    img: &ColourView,
    roi: Roi,
    weights: [f64; 3],
    laser_rgb: [f64; 3],
    surface: &[bool],
    g: &mut [f32],
) {
    let full = (0..3).map(|k| weights[k] * laser_rgb[k]).sum::<f64>();
    for (i, v) in g.iter_mut().enumerate() {
        if !surface[i] {
            continue;
        }
        let (r, gg, b) = img.rgb(roi.x0 + i % roi.w, roi.y0 + i / roi.w);
        let px = [r, gg, b];
        if let Some(along) = along_seen(px.map(|c| c as f64), px.map(|c| c < CLIPPED), laser_rgb) {
            *v = (along * full) as f32;
        }
    }
}

/// Where a core may clip: bit `k` where lit channel `k` clips (a clipped lit channel shows
/// no contrast however bright the dot is), bit 3 where all three clip.
#[inline]
fn clip_bits(lit: [bool; 3], (r, g, b): (i32, i32, i32)) -> u8 {
    let c = [r >= CLIPPED, g >= CLIPPED, b >= CLIPPED];
    let all = (c[0] && c[1] && c[2]) as u8;
    (0..3).fold(all << 3, |m, k| m | (((lit[k] && c[k]) as u8) << k))
}

/// The pixels whose clipping is a core's: each clipping condition of `clips`
/// ([`clip_bits`]) counts only over a connected region no larger than a dot
/// (`limits`). A surface clipped over a larger region is the background's: a white
/// square near the camera's lamp in clear green water clips green and blue over 20 000 px
/// and more, and every pixel of it counted as a dot's core merged the squares and the dot
/// on them into one blob too large for a dot (tuning calibration seed 9, dots at 0.55-1.5
/// m). There the dot shows in the channels that do not clip. `limits` holds that limit
/// and a larger one for a round white region: a dot of 6 100 levels at 0.57 m clipped white
/// over 9 500 px, 0.3 of its tilted board's median square (held-out calibration
/// 1000075/00), while a square clipped all over is no disc ([`round`]).
fn clipped_cores(mut clips: Vec<u8>, roi: Roi, limits: CoreLimits) -> Vec<bool> {
    let (w, h) = (roi.w, roi.h);
    let mut stack = Vec::new();
    let mut region = Vec::new();
    let present = clips.iter().fold(0u8, |a, &c| a | c);
    for bit in (0..4u8).filter(|b| present & (1 << b) != 0) {
        let (on, seen) = (1u8 << bit, 0x10u8 << bit);
        for start in 0..w * h {
            if clips[start] & (on | seen) != on {
                continue;
            }
            clips[start] |= seen;
            stack.push(start);
            region.clear();
            while let Some(i) = stack.pop() {
                region.push(i as u32);
                for (nx, ny) in neighbours8(i % w, i / w, w, h) {
                    let j = ny * w + nx;
                    if clips[j] & (on | seen) == on {
                        clips[j] |= seen;
                        stack.push(j);
                    }
                }
            }
            let round_core = bit == 3 && region.len() <= limits.round_white_px && round(&region, w);
            if region.len() > limits.any_px && !round_core {
                for &i in &region {
                    clips[i as usize] &= !on;
                }
            }
        }
    }
    clips.into_iter().map(|c| c & 0x0f != 0).collect()
}

/// Whether a region (row-major indices into a map `w` pixels wide) is round: it fills at
/// least [`ROUND_FILL`] of the disc about its centroid through its farthest pixel. A disc
/// fills all of it, a square 0.64.
fn round(region: &[u32], w: usize) -> bool {
    let n = region.len() as f64;
    let at = |i: u32| Vec2::new((i as usize % w) as f64, (i as usize / w) as f64);
    let centroid = region.iter().fold(Vec2::zeros(), |s, &i| s + at(i)) / n;
    let far = region.iter().map(|&i| (at(i) - centroid).norm()).fold(0.0, f64::max) + 0.5;
    n >= ROUND_FILL * core::f64::consts::PI * far * far
}

/// Least share of its circumscribed disc a round region fills ([`round`]).
const ROUND_FILL: f64 = 0.8;

/// The 8-connected neighbours of `(x, y)` inside a `w x h` grid.
pub(super) fn neighbours8(x: usize, y: usize, w: usize, h: usize) -> impl Iterator<Item = (usize, usize)> {
    (-1i64..=1)
        .flat_map(move |dy| (-1i64..=1).map(move |dx| (x as i64 + dx, y as i64 + dy)))
        .filter(move |&(nx, ny)| {
            (nx, ny) != (x as i64, y as i64) && nx >= 0 && ny >= 0 && nx < w as i64 && ny < h as i64
        })
        .map(|(nx, ny)| (nx as usize, ny as usize))
}

/// `g` less its local background, the box mean within `radius` px. The window is much
/// larger than a dot, so a dot barely lifts its own background. The sums slide down the ROI
/// a row at a time (one running sum per column) rather than coming from an integral image:
/// a near board's ROI is up to 7 Mpx, and an integral image's 8 bytes a pixel made this map
/// the largest allocation of a run (issue 17's memory).
fn minus_local_background(g: &[f32], roi: Roi, radius: usize) -> Vec<f32> {
    let (w, h, r) = (roi.w, roi.h, radius);
    let mut columns = vec![0f64; w];
    let mut prefix = vec![0f64; w + 1];
    let mut excess = vec![0f32; w * h];
    // Rows `top..bottom` are in `columns`.
    let (mut top, mut bottom) = (0usize, 0usize);
    for y in 0..h {
        let (ya, yb) = (y.saturating_sub(r), (y + r + 1).min(h));
        for row in bottom..yb {
            columns.iter_mut().zip(&g[row * w..(row + 1) * w]).for_each(|(c, &v)| *c += v as f64);
        }
        for row in top..ya {
            columns.iter_mut().zip(&g[row * w..(row + 1) * w]).for_each(|(c, &v)| *c -= v as f64);
        }
        (top, bottom) = (ya, yb);
        for x in 0..w {
            prefix[x + 1] = prefix[x] + columns[x];
        }
        let rows = (yb - ya) as f64;
        for x in 0..w {
            let (xa, xb) = (x.saturating_sub(r), (x + r + 1).min(w));
            let mean = (prefix[xb] - prefix[xa]) / (rows * (xb - xa) as f64);
            excess[y * w + x] = g[y * w + x] - mean as f32;
        }
    }
    excess
}

/// Each square's share of its side by which its quad is grown for [`board_background`]: a
/// pixel this near a brighter square is measured against that square, so the blurred
/// edge between squares is no ribbon of excess on the dark side.
const SQUARE_EDGE_SHARE: f64 = 0.12;

/// Replaces the excess of every pixel on a board's square by its contrast over that
/// square's own level (the median of the square's middle), or over a brighter neighbour's
/// within [`SQUARE_EDGE_SHARE`] of its edge. A window's mean over black and white squares
/// is neither: in green water, where the squares' contrast lies along a green laser's
/// colour, it made the map's noise 24 levels and the threshold 120, over a dot of 71
/// (tuning calibration seed 14).
fn board_background(g: &[f32], roi: Roi, squares: &[[Vec2; 4]], excess: &mut [f32]) {
    if squares.is_empty() {
        return;
    }
    // The highest level over a pixel is its lowest contrast, so the pixels the squares
    // cover are first cleared to +inf and then take the least contrast over each square:
    // no level map beside `excess` (4 bytes a pixel on a near board's ROI).
    let levels: Vec<([Vec2; 4], f32)> = squares
        .iter()
        .filter_map(|quad| Some((scaled_quad(quad, 1.0 + 2.0 * SQUARE_EDGE_SHARE), square_level(g, roi, quad)?)))
        .collect();
    for (grown, _) in &levels {
        for_pixels_in(roi, grown, |i| excess[i] = f32::INFINITY);
    }
    for (grown, own) in &levels {
        for_pixels_in(roi, grown, |i| excess[i] = excess[i].min(g[i] - own));
    }
}

/// The pixels of the ROI near a square's edge (within [`SQUARE_EDGE_SHARE`] of its side,
/// either way), where [`board_background`] leaves the blur between a black and a white
/// square: not the photo's noise. A board at 3-5 m has squares of 30-50 px whose blurred
/// edges cover a third of them, and counted in the noise they set the threshold over a
/// dot's contrast of 29 levels (tuning calibration seed 27 photo 7: noise 7.2 levels,
/// threshold 36; off the edges 3.6 and 18). On the tuning calibration seeds 0-31, 5 more
/// dots right of 356, one more wrong dot caught as an outlier, none used; on the earlier
/// held-out sets 13 more right of 549, and 3 more dots centred 3.6-4.5 px off used in fits
/// (the fit's gate let them in). Empty without squares.
fn square_edges(roi: Roi, squares: &[[Vec2; 4]]) -> Vec<bool> {
    if squares.is_empty() {
        return Vec::new();
    }
    let mut edges = vec![false; roi.w * roi.h];
    for quad in squares {
        for_pixels_in(roi, &scaled_quad(quad, 1.0 + 2.0 * SQUARE_EDGE_SHARE), |i| edges[i] = true);
    }
    for quad in squares {
        for_pixels_in(roi, &scaled_quad(quad, 1.0 - 2.0 * SQUARE_EDGE_SHARE), |i| edges[i] = false);
    }
    edges
}

/// The median of `g` over the middle half (by side) of a square, sampled on a grid of at
/// most 24 x 24; `None` when the square has no sample in the ROI.
fn square_level(g: &[f32], roi: Roi, quad: &[Vec2; 4]) -> Option<f32> {
    let middle = scaled_quad(quad, 0.5);
    let side = (quad[0] - quad[2]).norm().max((quad[1] - quad[3]).norm());
    let step = ((side / 24.0).floor() as usize).max(1);
    let mut samples = Vec::new();
    for_pixels_in(roi, &middle, |i| {
        let (x, y) = (i % roi.w, i / roi.w);
        if x % step == 0 && y % step == 0 {
            samples.push(g[i]);
        }
    });
    if samples.is_empty() {
        return None;
    }
    let mid = samples.len() / 2;
    Some(*samples.select_nth_unstable_by(mid, |a, b| a.total_cmp(b)).1)
}

/// A quad scaled by `factor` about its centroid.
fn scaled_quad(quad: &[Vec2; 4], factor: f64) -> [Vec2; 4] {
    let c = (quad[0] + quad[1] + quad[2] + quad[3]) / 4.0;
    quad.map(|p| c + (p - c) * factor)
}

/// Calls `f` with the ROI index of every ROI pixel inside the convex quad, row by row: a
/// row crosses a convex quad in one span, found from its edges.
fn for_pixels_in(roi: Roi, quad: &[Vec2; 4], mut f: impl FnMut(usize)) {
    let local = quad.map(|p| Vec2::new(p.x - roi.x0 as f64, p.y - roi.y0 as f64));
    let miny = local.iter().map(|p| p.y).fold(f64::INFINITY, f64::min);
    let maxy = local.iter().map(|p| p.y).fold(f64::NEG_INFINITY, f64::max);
    let (y0, y1) = (miny.ceil().max(0.0) as usize, (maxy.floor() + 1.0).clamp(0.0, roi.h as f64) as usize);
    for y in y0..y1 {
        let yf = y as f64;
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for k in 0..4 {
            let (a, b) = (local[k], local[(k + 1) % 4]);
            if (a.y <= yf && yf <= b.y) || (b.y <= yf && yf <= a.y) {
                // An edge lying along the row covers its whole length.
                let (x0, x1) = if (b.y - a.y).abs() < 1e-12 {
                    (a.x.min(b.x), a.x.max(b.x))
                } else {
                    let x = a.x + (yf - a.y) * (b.x - a.x) / (b.y - a.y);
                    (x, x)
                };
                lo = lo.min(x0);
                hi = hi.max(x1);
            }
        }
        if lo > hi {
            continue;
        }
        let (x0, x1) = (lo.ceil().max(0.0) as usize, (hi.floor() + 1.0).clamp(0.0, roi.w as f64) as usize);
        for x in x0..x1 {
            f(y * roi.w + x);
        }
    }
}

/// Robust noise sigma of the excess: the median absolute deviation over a subsample of the
/// pixels off the squares' edges (`edges`, empty when there are none), never below half a
/// level.
fn robust_noise(excess: &[f32], edges: &[bool]) -> f64 {
    let on_edge = |i: usize| edges.get(i).copied().unwrap_or(false);
    let mut sample: Vec<f32> = (0..excess.len()).step_by(7).filter(|&i| !on_edge(i)).map(|i| excess[i]).collect();
    if sample.len() < excess.len() / 70 {
        // Edges cover nearly all of the ROI: the squares are too small to have a middle.
        sample = excess.iter().step_by(7).copied().collect();
    }
    if sample.is_empty() {
        return 1.0;
    }
    let mid = sample.len() / 2;
    let med = *sample.select_nth_unstable_by(mid, |a, b| a.total_cmp(b)).1;
    for s in sample.iter_mut() {
        *s = (*s - med).abs();
    }
    let mad = *sample.select_nth_unstable_by(mid, |a, b| a.total_cmp(b)).1;
    (1.4826 * mad as f64).max(0.5)
}

/// Bounding box of a blob in ROI pixels, inclusive: `(min x, max x, min y, max y)`.
pub(super) type BlobBox = (usize, usize, usize, usize);

/// The [`BlobBox`] of `pixels` (row-major indices into a map `w` pixels wide).
fn blob_box(pixels: &[usize], w: usize) -> BlobBox {
    pixels.iter().fold((usize::MAX, 0, usize::MAX, 0), |(a, b, c, d), &i| {
        (a.min(i % w), b.max(i % w), c.min(i / w), d.max(i / w))
    })
}

/// What a blob that looks like a dot measures.
struct BlobMeasures {
    /// Peak contrast of its unclipped pixels (the threshold if it has none), 8-bit levels.
    peak: f64,
    /// Matched-filter SNR, clipped pixels counted at `peak`.
    snr: f64,
    /// Pixels at or above half the peak, or clipped.
    core_pixels: usize,
    saturated_pixels: usize,
    /// Mean position of the clipped pixels (ROI pixels); `None` when none clip.
    clipped_centroid: Option<Vec2>,
    bbox: BlobBox,
}

impl BlobMeasures {
    /// The SNR with the clipped pixels counted at `core_levels` where that is more than the
    /// peak they were counted at.
    fn snr_with_core_at(&self, core_levels: f64, sigma: f64, area_px: usize) -> f64 {
        let lift = (core_levels - self.peak).max(0.0) * self.saturated_pixels as f64;
        self.snr + lift / (sigma * (area_px as f64).sqrt())
    }
}

/// The contrast a clipped core has at least: its fringe's along the map's colour
/// (`weights`), 8-bit levels; 0 without a clipped pixel. A core clipped throughout shows no
/// contrast of its own and counted only at the threshold, so a near dot washed white on a
/// bright cyan square (1 059 levels at 0.93 m, fringe 75 levels over the square) ranked
/// below eight algae tufts off the board and was cut (tuning calibration seed 9). A glint's
/// fringe is white, which the map's weights remove: it gains nothing.
fn fringe_contrast(weights: [f64; 3], fringe_excess: [f64; 3], saturated_px: usize) -> f64 {
    if saturated_px == 0 {
        return 0.0;
    }
    (0..3).map(|c| weights[c] * fringe_excess[c]).sum::<f64>().max(0.0)
}

/// Whether image point `p` lies on a blob other than `id`: a pixel labelled another blob's,
/// or one a later flood fill will label (above half the threshold, or clipped).
fn on_another_blob(maps: &RoiMaps, id: u32, p: Vec2) -> bool {
    let (x, y) = (p.x.round() - maps.roi.x0 as f64, p.y.round() - maps.roi.y0 as f64);
    if x < 0.0 || y < 0.0 || x >= maps.roi.w as f64 || y >= maps.roi.h as f64 {
        return false;
    }
    let i = y as usize * maps.roi.w + x as usize;
    maps.label[i] != id && (maps.label[i] != 0 || maps.excess[i] >= 0.5 * maps.threshold || maps.saturated[i])
}

/// The dot candidate a labelled blob makes, or `None` when it is no dot (too small or too
/// large, a streak, outside the band, too faint, not the laser's colour).
fn blob_candidate(
    img: &ColourView,
    region: &SearchRegion,
    params: &DotDetectorParams,
    maps: &RoiMaps,
    pixels: &[usize],
    id: u32,
) -> Option<DotCandidate> {
    if pixels.len() > params.max_area_px || pixels.len() < 2 {
        return None;
    }
    let m = measure_blob(maps, pixels)?;
    if region.overlapping_pieces && cut_by_region(m.bbox, maps.roi, img) {
        return None;
    }
    // Centre: intensity-weighted centroid of the blob (the core weighted at the peak),
    // over the blob's pixels grown by two, so the weights fall off symmetrically.
    if m.snr < params.min_snr {
        return None;
    }
    let (cx, cy) = weighted_centre(maps, id, m.bbox, m.peak as f32);
    let rough = Vec2::new((maps.roi.x0 as f64) + cx, (maps.roi.y0 as f64) + cy);
    let radius_px = (pixels.len() as f64 / core::f64::consts::PI).sqrt();
    // Colour before centring: most blobs of a textured scene fail it, and the centring
    // (three background fits and a matched filter) is the costly step.
    let core_radius_px = (m.core_pixels as f64 / core::f64::consts::PI).sqrt();
    let clipped_colour = m.saturated_pixels as f64 >= (CLIPPED_COLOUR_SHARE * m.core_pixels as f64).max(1.0);
    let mut colour = blob_colour(img, maps, id, rough, (radius_px, core_radius_px), clipped_colour, params.colour.rgb)?;
    let mut score = params.colour.score_with(maps.weights, colour.excess_rgb, colour.pixels, maps.sigma);
    if score.sigmas < params.min_colour_sigmas {
        return None;
    }
    // The hue only for the blobs that pass: its medians are wasted on the rest.
    let mut judged_excess_rgb = colour.excess_rgb;
    let mut texture_sigma_rad = 0.0;
    if !colour.band.is_empty() {
        let texture = params.colour.texture_across_levels(&colour.surround, maps.sigma);
        let hue = local_hue(colour.core_mean_rgb, colour.pixels, &mut colour.band);
        let local = params.colour.score_with(maps.weights, hue.excess_rgb, hue.equivalent_pixels, maps.sigma);
        texture_sigma_rad = (TEXTURE_ERROR_SHARE * texture / params.colour.chroma_levels(hue.excess_rgb).max(1e-9))
            .min(MAX_TEXTURE_SIGMA_RAD);
        (score.angle_rad, score.angle_sigma_rad) = (local.angle_rad, local.angle_sigma_rad);
        judged_excess_rgb = with_chroma_of(colour.excess_rgb, hue.excess_rgb);
    }
    let snr = m.snr_with_core_at(
        fringe_contrast(maps.weights, colour.excess_rgb, m.saturated_pixels),
        maps.sigma,
        pixels.len(),
    );
    // Centred on the dot's own size (at half its peak), not its halo's: against a board
    // square's level a near dot's halo reaches the threshold 30 px out, and a disc that
    // wide took in a bubble 42 px away and moved the centre 12 px (tuning seed 2).
    // A wide blob's centring disc may reach a brighter blob beside it and settle there: its
    // centre is then that blob's, measured with this one's size and SNR (a green fish's
    // 7 400 px body centred on a dot 40 px away in a dark band across it stood in for the
    // dot, and was refused as too large: tuning target-less 1000119/14).
    let centred =
        refine_centre(img, rough, core_radius_px.max(1.5), &params.colour).filter(|c| !on_another_blob(maps, id, c.at));
    let centre = centred.as_ref().map_or(rough, |c| c.at);
    if let Some((line, half)) = &region.band {
        if distance_to_polyline(line, centre) > *half {
            return None;
        }
    }
    let at = centre - Vec2::new(maps.roi.x0 as f64, maps.roi.y0 as f64);
    // A glint the centring told apart is no part of the blob's shape: with its clipped
    // pixels counted, a dot 13 px from a glint read as a blob clipped off its centre
    // (tuning target-less 4/08).
    let glint = centred.as_ref().map(|c| glint_mask(&c.glint, maps.roi)).filter(|g| g.iter().any(|&h| h));
    let own = |i: &usize| glint.as_ref().is_none_or(|g| !g[*i]);
    let hidden = centred
        .as_ref()
        .map(|c| glint_mask(&c.glint.union(&c.over).copied().collect(), maps.roi))
        .filter(|g| g.iter().any(|&h| h));
    let (clipped_px, clipped_centroid) = if glint.is_some() {
        clipped_part(pixels.iter().copied().filter(own).filter(|&i| maps.saturated[i]), maps.roi.w)
    } else {
        (m.saturated_pixels, m.clipped_centroid)
    };
    // Clipped pixels away from the centre are no dot's core: a tuft's lightest patches, or a
    // bubble's rim inside a tuft's blob. Such a blob is judged as unclipped (its core's
    // size, its colour's noise), and when the clipped part is large enough to place, as no
    // spot at all.
    let clipped_map =
        ContrastMap { excess: None, clipped: &maps.saturated, hidden: None, width: maps.roi.w, height: maps.roi.h };
    let clipped_core = clipped_px > 0 && clipped_at_centre(&clipped_map, at);
    let clipped_radius_px = (clipped_px as f64 / core::f64::consts::PI).sqrt();
    let clipped_off_centre = clipped_radius_px >= CLIPPED_MIN_RADIUS_PX
        && clipped_centroid.is_some_and(|c| (c - at).norm() > CLIPPED_OFF_CENTRE_SHARE * clipped_radius_px);
    let own_pixels: Vec<usize> = pixels.iter().copied().filter(own).collect();
    let outline_roughness = if clipped_core {
        None
    } else if clipped_off_centre || hollow_blob(img, maps, &own_pixels, at, m.peak) {
        Some(1.0)
    } else {
        (core_radius_px >= OUTLINE_MIN_RADIUS_PX && m.peak >= OUTLINE_MIN_PEAK_SIGMAS * maps.sigma)
            .then(|| {
                let map = ContrastMap {
                    excess: Some(&maps.excess),
                    clipped: &maps.saturated,
                    hidden: hidden.as_deref(),
                    width: maps.roi.w,
                    height: maps.roi.h,
                };
                outline_roughness(&map, at, m.peak, maps.sigma, 3.0 * core_radius_px + 4.0)
            })
            .flatten()
    };
    let white: Vec<usize> = pixels.iter().copied().filter(|&i| white_at(img, maps.roi, i)).collect();
    let lit_clipped_px = if clipped_core && !white.is_empty() {
        lit_clipped_around(img, maps, &white, lit_channels(&params.colour), LIT_GLOW_AREA_FACTOR * params.max_area_px)
    } else {
        0
    };
    Some(DotCandidate {
        pixel: centre,
        snr,
        peak_green: m.peak,
        radius_px,
        core_radius_px,
        saturated_core: clipped_core,
        saturated_px: m.saturated_pixels,
        white_px: white.len(),
        lit_clipped_px,
        colour_score: score.sigmas,
        colour_angle_rad: score.angle_rad,
        colour_angle_sigma_rad: if clipped_core {
            score.angle_sigma_rad.max(CLIPPED_CHROMA_SIGMA_RAD)
        } else {
            score.angle_sigma_rad
        },
        colour_texture_sigma_rad: texture_sigma_rad,
        white_deficit_rad: params.colour.white_deficit_rad(colour.excess_rgb),
        outline_roughness,
        split_from_blob: false,
        enclosed_by: None,
        excess_rgb: colour.excess_rgb,
        judged_excess_rgb,
        colour_filled_in: colour.filled_in,
    })
}

/// Whether a blob's box (ROI pixels) reaches an edge of the region's ROI that is not the
/// photo's: only part of the blob is measured there, its background window one-sided. Of
/// such measures, along a laser line whose pieces overlap, 10 px of a faint dot and 55 px of
/// texture beside it read as one plausible blob centred 6 px off the dot and taken (fresh
/// target-less 1000252/03), where the piece that saw the dot whole had refused it; a
/// tuft's piece, plausible as a dot, was taken on a laser-off photo (1000251/18). Left to
/// the pieces that see blobs whole: on the tuning and looked-at target-less sets and
/// 1000224-247 (1580 photos) right 908 -> 909, wrong 15 -> 13; on fresh 1000248-263 (320
/// photos) right 177 -> 177, wrong 7 -> 4. Two dots were found only in such a part (176
/// and 441 levels on bright surfaces, their whole blobs' colour read off the laser's) and
/// are lost.
fn cut_by_region((x0, x1, y0, y1): BlobBox, roi: Roi, img: &ColourView) -> bool {
    (x0 == 0 && roi.x0 > 0)
        || (y0 == 0 && roi.y0 > 0)
        || (x1 + 1 == roi.w && roi.x0 + roi.w < img.width)
        || (y1 + 1 == roi.h && roi.y0 + roi.h < img.height)
}

/// Most pixels a dot's lit glow clips over, in dots' largest areas ([`lit_clipped_around`]).
const LIT_GLOW_AREA_FACTOR: usize = 2;

/// The pixels 8-connected to a blob's `white` ones ([`white_at`]) where a channel the laser
/// lights (`lit`) clips, white included: a near dot's glow clips its own
/// channel well beyond its white core. Read from the photo, not the maps, whose clipped
/// regions stop at a dot's size. 0 when they reach more than `most` (a surface whose lit
/// channel clips all over).
fn lit_clipped_around(img: &ColourView, maps: &RoiMaps, white: &[usize], lit: [bool; 3], most: usize) -> usize {
    let (w, h, roi) = (maps.roi.w, maps.roi.h, maps.roi);
    let clip = |i: usize| {
        let (r, g, b) = img.rgb(roi.x0 + i % w, roi.y0 + i / w);
        [r, g, b].map(|c| c >= CLIPPED)
    };
    let mut queue = white.to_vec();
    let mut seen: std::collections::HashSet<usize> = queue.iter().copied().collect();
    let mut k = 0;
    while k < queue.len() {
        if queue.len() > most {
            return 0;
        }
        let i = queue[k];
        k += 1;
        for (x, y) in neighbours8(i % w, i / w, w, h) {
            let j = y * w + x;
            if clip(j).iter().zip(lit).any(|(&c, l)| c && l) && seen.insert(j) {
                queue.push(j);
            }
        }
    }
    queue.len()
}

/// Whether ROI pixel `i` is white: all three channels clipped.
fn white_at(img: &ColourView, roi: Roi, i: usize) -> bool {
    let (r, g, b) = img.rgb(roi.x0 + i % roi.w, roi.y0 + i / roi.w);
    r.min(g).min(b) >= CLIPPED
}

/// Whether the blob of `pixels` is dim at `at` (ROI pixels) against its core ([`hollow`]).
/// A clipped pixel counts at the peak, and so does a white one: on a surface clipped all
/// over, the clipped map leaves out a dot's core (white) and its contrast map reads it by
/// its unclipped channels, which it has none of.
fn hollow_blob(img: &ColourView, maps: &RoiMaps, pixels: &[usize], at: Vec2, peak: f64) -> bool {
    let roi = maps.roi;
    let level = |i: usize| {
        if maps.saturated[i] || white_at(img, roi, i) {
            peak
        } else {
            maps.excess[i] as f64
        }
    };
    let half = 0.5 * peak;
    let core: Vec<usize> = pixels.iter().copied().filter(|&i| level(i) >= half).collect();
    hollow(&level, (roi.w, roi.h), &core, at, maps.sigma)
}

/// Smallest half-peak radius whose outline's shape is measured, pixels: below it the pixel
/// grid and the blur make every blob round.
const OUTLINE_MIN_RADIUS_PX: f64 = 4.0;
/// Least 1-sigma uncertainty of a clipped blob's chroma angle, radians. Its colour is read
/// off the fringe around the clipped pixels, where the laser's own channel is truncated
/// (blur and JPEG spread the clipped core's cut-off values into it) and crosstalk whitens
/// it. On the README demo's photos the 11 clipped dots' chroma lay 2-37 degrees from the
/// learned colour (the far ones, 3.5-4.5 m on bright squares in clear water, 16-37), the 5
/// unclipped dots' 1-13 with their noise explaining the 13. The colour of a clipped blob
/// says this much less, both when a calibration learns from it and when a search judges it.
const CLIPPED_CHROMA_SIGMA_RAD: f64 = 0.25;

/// Smallest equivalent radius of a clipped part off a blob's centre that makes the blob no
/// spot, pixels: on the tuning target-less scenes 5 of 6 algae tufts clipping in green
/// (clipped parts 19-24 px) had no clipped centre, and none of 17 true dots clipped over
/// 4 px or more. A smaller clipped speck off the centre is a bubble's or a glint's.
const CLIPPED_MIN_RADIUS_PX: f64 = 4.0;
/// How far from a blob's centre, in its clipped part's equivalent radii, that part's mean
/// position lies when it is off the centre. A near dot whose laser channel only just clips
/// clips in a mottle of pixels (JPEG noise at 246-255), so its centre's 3 x 3 pixels need
/// not be half clipped, yet the mottle is centred on it: on the tuning target-less seeds
/// 0-17 two such dots (clipped parts of 5.7 and 6.2 px) lay 0.05 and 1.03 radii off, and
/// were refused as no spot; the clipped parts of algae, glare and texture that reach
/// [`CLIPPED_MIN_RADIUS_PX`] lay 2.1-17 radii off. One bubble's clipped highlight lay 0.12
/// radii off: it is now judged by its middle and outline, which refuse it too (seed 9
/// photo 3).
const CLIPPED_OFF_CENTRE_SHARE: f64 = 1.5;

/// Least peak, in noise sigmas, whose outline's shape is measured.
const OUTLINE_MIN_PEAK_SIGMAS: f64 = 5.0;

/// A blob's colour: the mean excess of its scored pixels over a ring of background.
struct BlobColour {
    excess_rgb: [f64; 3],
    pixels: usize,
    filled_in: bool,
    /// Mean (R, G, B) of the scored pixels, 8-bit levels.
    core_mean_rgb: [f64; 3],
    /// The pixels of the band just outside its core that its hue is read against
    /// ([`LOCAL_BACKGROUND_GAP_PX`]); empty when the hue is the ring's.
    band: Vec<[f64; 3]>,
    /// Those of `band`'s pixels outside the blob itself: the surface's texture is read on
    /// them, not on the blob's own rim (a bubble's ring reaches the band). Empty with fewer
    /// than [`MIN_BAND_PX`].
    surround: Vec<[f64; 3]>,
}

/// A blob's mean excess over the median of the pixels just outside its core, and the
/// count of pixels whose mean, alone, would be as noisy.
struct LocalHue {
    excess_rgb: [f64; 3],
    equivalent_pixels: usize,
}

/// Measures blob `id`'s colour around `centre` (image pixels) against the mean of a ring
/// well outside it (beyond the blob's radius, `radii.0`). Scored pixels, none with a channel
/// clipped: around a clipped core, the blob's own and its fringe within three pixels of the
/// blob (a near dot clips all of R, G and B; its colour survives only where the light falls
/// off); else the disc of the blob's core (pixels at half its peak or more, radius
/// `radii.1`) and [`CORE_DISC_MARGIN_PX`]. `None` with fewer than 3 scored pixels or 12
/// background pixels.
fn blob_colour(
    img: &ColourView,
    maps: &RoiMaps,
    id: u32,
    centre: Vec2,
    radii: (f64, f64),
    clipped_core: bool,
    laser_rgb: [f64; 3],
) -> Option<BlobColour> {
    // A disc, not only the pixels the threshold picked: a speck of noise picked for being
    // bright along the laser's colour would otherwise score as that colour.
    let (radius_px, core_radius_px) = radii;
    let fringe = if clipped_core { radius_px + 3.0 } else { core_radius_px.max(1.5) + CORE_DISC_MARGIN_PX };
    let ring = (radius_px * 1.5 + 4.0, radius_px * 1.5 + 8.0);
    let roi = maps.roi;
    let lx = (centre.x - roi.x0 as f64 - ring.1).floor().max(0.0) as usize;
    let hx = ((centre.x - roi.x0 as f64 + ring.1).ceil().max(0.0) as usize).min(roi.w - 1);
    let ly = (centre.y - roi.y0 as f64 - ring.1).floor().max(0.0) as usize;
    let hy = ((centre.y - roi.y0 as f64 + ring.1).ceil().max(0.0) as usize).min(roi.h - 1);
    let mut sig = [0f64; 3];
    let (mut scored_px, mut ring_px, mut near, mut local) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let mut surround = Vec::new();
    for y in ly..=hy {
        for x in lx..=hx {
            if maps.saturated[y * roi.w + x] {
                continue;
            }
            let (r, g, b) = img.rgb(roi.x0 + x, roi.y0 + y);
            let px = [r as f64, g as f64, b as f64];
            let d = ((roi.x0 + x) as f64 - centre.x).hypot((roi.y0 + y) as f64 - centre.y);
            let label = maps.label[y * roi.w + x];
            let scored = if clipped_core {
                label == id || (label == 0 && d <= fringe)
            } else {
                (label == id || label == 0) && d <= fringe
            };
            if scored {
                sig = [sig[0] + px[0], sig[1] + px[1], sig[2] + px[2]];
                scored_px.push(px);
                continue;
            }
            let beyond = d - fringe - LOCAL_BACKGROUND_GAP_PX;
            if !clipped_core && (label == id || label == 0) && beyond > 0.0 && beyond <= LOCAL_BACKGROUND_PX {
                local.push(px);
                if label == 0 {
                    surround.push(px);
                }
            }
            if label != id && d >= ring.0 && d <= ring.1 {
                ring_px.push(px);
            } else if label != id && d > fringe && d < ring.0 {
                near.push(px[0] + px[1] + px[2]);
            }
        }
    }
    let n_sig = scored_px.len();
    let bg = surface_background(&ring_px, &near, &scored_px, laser_rgb, clipped_core)?;
    if n_sig < 3 {
        return None;
    }
    let core_mean_rgb = sig.map(|v| v / n_sig as f64);
    let excess_rgb = [0, 1, 2].map(|c| core_mean_rgb[c] - bg.mean_rgb[c]);
    // A near dot's glow clips a bright surface's channels over its whole fringe where the
    // surface itself does not clip: those channels' excess is cut at the clip as surely.
    let fringe = if clipped_core { clipped_share(&scored_px) } else { [0.0; 3] };
    let blind = [0, 1, 2].map(|c| bg.clipped_share[c] > BLIND_SHARE || fringe[c] > BLIND_SHARE);
    let seen = seen_through_clipping(excess_rgb, blind, laser_rgb);
    let filled_in = seen != excess_rgb;
    // A channel clipped on the surface has no local contrast either: its fill stands.
    if filled_in || local.len() < MIN_BAND_PX {
        local.clear();
    }
    if local.is_empty() || surround.len() < MIN_BAND_PX {
        surround.clear();
    }
    Some(BlobColour { excess_rgb: seen, pixels: n_sig, filled_in, core_mean_rgb, band: local, surround })
}

/// The share of `pixels` (R, G, B levels) clipped in each channel; NaN for none.
fn clipped_share(pixels: &[[f64; 3]]) -> [f64; 3] {
    let n = pixels.len() as f64;
    [0, 1, 2].map(|c| pixels.iter().filter(|p| p[c] >= CLIPPED as f64).count() as f64 / n)
}

/// Share of pixels clipped in a channel beyond which that channel is blind to a blob's
/// contrast ([`seen_through_clipping`]): of the ring's (the surface clips), or of a clipped
/// core's fringe (its glow clips the surface). A dot of 3 671 levels at 1.5 m on a cyan
/// square (green 215, blue 225) clipped green and blue over its 361 fringe pixels, read
/// (144, 20, 42) levels of excess, far off the laser's colour, and was no candidate: that
/// companion calibration (target-less 1000178) was refused, and calibration 1000173/00 (7 271
/// levels) lost its dot.
const BLIND_SHARE: f64 = 0.5;

/// Least share of a blob's core (its pixels at half its peak or more) that must clip for
/// its colour to be read as a clipped core's (from the blob and its fringe, against the
/// ring beyond its halo). A core that only touches the clip level keeps its colour in the
/// rest of it, and is read as an unclipped one's, against the surface right around it:
/// held-out target-less 1000068/09, a dot of 139 levels on a striped fish with 6 of its 199
/// core pixels clipped by noise, read 16 degrees off its unit's colour against the ring
/// (the water beyond the fish's edge, bluer) and was refused; against the band around its
/// core, 5.8 degrees. At a tenth, tuning target-less 0-17 answered exactly as before, and
/// of the held-out target-less photos (1000042-81) only that dot changed (found). Every
/// clipped pixel read that way lost two tuning dots clipped over a fifth to a half of their
/// cores (4/11, 7/18).
const CLIPPED_COLOUR_SHARE: f64 = 0.1;

/// How far beyond a blob's core disc the band begins whose median is the background its
/// hue is read against, pixels. The ring the contrast is read against lies beyond the
/// blob's halo, 12-20 px out for a faint dot, and on a fish's edge or in a shaded hollow of
/// reef it sits on another surface than the dot: its mean was off by a few levels per
/// channel, and over a 30-40 level dot that turned the hue 14-20 degrees off the unit's
/// colour (tuning target-less seeds 1 photo 8, 4 photo 19), and the dot was refused. Nearer
/// in, the band carries the dot's own halo, but that is the laser's colour: it takes from
/// the contrast, not from the hue. Not right at the core: a JPEG stores colour at half the
/// resolution and rings around a small dot's colour, and a band touching a 2.5 px core read
/// its hue 40 degrees off (seed 3 photo 5). Gaps of 2-8 px answered within one photo of
/// each other; at 4 px the tuning target-less photos went 52 -> 56 right of 79, none lost,
/// and calibration 235 -> 236 of 260. On seeds 6-11, rendered after this was chosen, 52 ->
/// 56 of 77, one lost; wrong dots 3 -> 3.
const LOCAL_BACKGROUND_GAP_PX: f64 = 4.0;
/// How wide that band is, pixels.
const LOCAL_BACKGROUND_PX: f64 = 3.0;

/// Fewest pixels of that band a hue is read against, and of its part outside the blob that
/// its texture is read on; with fewer the ring stands in, and the texture counts nothing.
const MIN_BAND_PX: usize = 12;

/// Share of the surface's own spread across the laser's colour around a blob, beyond the
/// camera's noise ([`LaserColourModel::texture_across_levels`] over the band its hue is read
/// against, the blob's own pixels left out), that the band's median may be off by under the
/// blob: its chroma angle is judged with that error beside the background's level
/// (`BACKGROUND_ERROR_LEVELS`). The surface under a dot is not seen. On a flat one the band's
/// median is it to a level; a dot between a fish's stripes, on a stripe's edge or on mottled
/// reef sits on a surface that varies across the laser's colour by several levels within a
/// few pixels, and read with one level's error a 37-level dot between a fish's dark stripes
/// was refused 6.7 sigmas off its unit's colour (tuning target-less 3031/03). On the
/// tuning and reported target-less photos (3030-3034, 1000432-441: 300 photos, 72 without a
/// dot) right 169 -> 175, wrong 3 -> 3, every photo without a dot still "no dot"; at 1, one
/// right dot withheld beside a tuft now within the gate (3034/02) and one wrong dot
/// (1000436/12). Read over the blob's own pixels too, a bubble's rim in the band passed a
/// bubble on the line of a laser-off photo as the dot (1000452/14). The unit's colour is
/// still learned with the noise alone (`DotCandidate::colour_angle_sigma_rad`): learned
/// with the texture, a companion calibration chose the wrong tone curve (1000432).
const TEXTURE_ERROR_SHARE: f64 = 0.5;

/// Most the surface's texture adds to a blob's chroma uncertainty ([`TEXTURE_ERROR_SHARE`]),
/// radians (11.5 degrees). A faint blob on a busy surface has a chroma the texture could
/// turn anywhere; uncapped, its angle counted as known to 48 degrees and a blob 63 degrees
/// off its unit's colour passed as the dot on a laser-off photo (held-out target-less
/// 1000460/16). Texture that large leaves the colour unmeasured, which is no evidence for the
/// laser. On the tuning and reported target-less photos (300) right 175 -> 174 against no
/// cap (wrong 3 -> 3); at 0.15, 172.
const MAX_TEXTURE_SIGMA_RAD: f64 = 0.2;

/// Variance of a median of normal samples over that of their mean, for large counts (pi/2).
const MEDIAN_VARIANCE_RATIO: f64 = core::f64::consts::FRAC_PI_2;

/// The hue of a blob's core (`core_mean`, over `core_pixels`) against the per-channel median
/// of `band`, the pixels just outside it: a median, because the band may still cross an
/// edge of the surface.
fn local_hue(core_mean: [f64; 3], core_pixels: usize, band: &mut [[f64; 3]]) -> LocalHue {
    let mid = band.len() / 2;
    let median = [0, 1, 2].map(|c| band.select_nth_unstable_by(mid, |a, b| a[c].total_cmp(&b[c])).1[c]);
    let excess_rgb = [0, 1, 2].map(|c| core_mean[c] - median[c]);
    // The difference of two noisy means: 1/n_eq = 1/n_core + (pi/2)/n_band.
    let equivalent = 1.0 / (1.0 / core_pixels as f64 + MEDIAN_VARIANCE_RATIO / band.len() as f64);
    LocalHue { excess_rgb, equivalent_pixels: (equivalent.round() as usize).max(1) }
}

/// How far beyond a blob's core its colour is read, pixels. A faint dot's halo (out to the
/// threshold, 2-3x its core) carries little excess over a ring whose level is off by a few
/// levels (a stripe's edge, shading, JPEG's blocks), so its mean chroma strays where the
/// core's does not. On the tuning target-less scenes the units' learned spreads narrowed
/// (5.6 -> 3.4 and 6.1 -> 3.4 degrees) and three photos whose dots had been refused as
/// 13-37 degrees off their unit's colour were answered right, none lost; 0, 1 and 2 px
/// beyond the core scored within one photo of each other.
const CORE_DISC_MARGIN_PX: f64 = 0.5;

/// Least share of the laser's brightest channel that the channels not clipped on a surface
/// must carry (as a root-sum-square) for a contrast read in them to stand for the laser's: a
/// green laser of chroma (0.11, 0.89, 0.44) shows on a cyan square clipped in green and blue
/// only in red, at 145 levels for a dot at 1.7 m.
const SEEN_SHARE: f64 = 0.1;

/// `excess` with each channel clipped on the blob's surface (`blind`) filled in as the
/// laser's colour (`laser_rgb`) would have it, at the contrast the other channels show
/// along that colour. A clipped channel shows no excess whatever lies on it: a dot on a
/// white square whose green and blue clip shows only in red, and scored as red, off the
/// laser's colour, it was dropped. Where only clipped channels would show the laser, the
/// excess stays as measured.
fn seen_through_clipping(excess: [f64; 3], blind: [bool; 3], laser_rgb: [f64; 3]) -> [f64; 3] {
    if !blind.iter().any(|&b| b) {
        return excess;
    }
    match along_seen(excess, blind.map(|b| !b), laser_rgb) {
        Some(along) => [0, 1, 2].map(|c| if blind[c] { along * laser_rgb[c] } else { excess[c] }),
        None => excess,
    }
}

/// The multiple of the laser's colour `laser_rgb` that `values` (R, G, B) show in the
/// channels `seen`, by least squares over them; `None` when those channels carry less than
/// [`SEEN_SHARE`] of the laser's brightest.
fn along_seen(values: [f64; 3], seen: [bool; 3], laser_rgb: [f64; 3]) -> Option<f64> {
    let norm: f64 = (0..3).filter(|&k| seen[k]).map(|k| laser_rgb[k] * laser_rgb[k]).sum();
    let top = laser_rgb.iter().copied().fold(0.0, f64::max);
    (norm >= (SEEN_SHARE * top).powi(2))
        .then(|| (0..3).filter(|&k| seen[k]).map(|k| values[k] * laser_rgb[k]).sum::<f64>() / norm)
}

/// The background a blob's scored pixels are read against: the ring's mean on the
/// surface they lie on, and the share of those ring pixels clipped in each channel.
struct SurfaceBackground {
    mean_rgb: [f64; 3],
    clipped_share: [f64; 3],
}

/// The background of a blob's `scored` pixels from the `ring` around it. A ring that
/// crosses a board square's edge holds two surfaces, and its mean is neither: a dot on a
/// white square near a black one measured blue "excess" of 81 levels against a ring half on
/// the black square, scored far off the laser's colour and was lost (tuning calibration
/// seed 6). When the ring's brightness (R + G + B) splits into two clusters far apart, the
/// scored pixels are read against the cluster of their own surface: each pixel's, told by
/// its colour across the laser's (which the dot's light does not change), when the two
/// surfaces differ there by [`SURFACE_ACROSS_LASER_LEVELS`]; else all against the cluster
/// nearer the pixels just outside the blob (`near`). A dot on a stripe's edge lies on both:
/// held-out target-less 1000104/10, a 143-level dot on a cyan fish whose fringe reached a
/// dark stripe, read a "excess" of (-1, -6, -26) levels against the fish alone and was lost.
/// `None` with fewer than 12 ring pixels on the surfaces used.
fn surface_background(
    ring: &[[f64; 3]],
    near: &[f64],
    scored: &[[f64; 3]],
    laser_rgb: [f64; 3],
    clipped_core: bool,
) -> Option<SurfaceBackground> {
    let of = |pixels: &[[f64; 3]]| {
        let n = pixels.len() as f64;
        SurfaceBackground {
            mean_rgb: [0, 1, 2].map(|c| pixels.iter().map(|p| p[c]).sum::<f64>() / n),
            clipped_share: clipped_share(pixels),
        }
    };
    let (dark, bright, split) = match ring_surfaces(ring, near, clipped_core) {
        RingSurfaces::One(pixels) => return (pixels.len() >= 12).then(|| of(&pixels)),
        RingSurfaces::Two { dark, bright, split } => (dark, bright, split),
    };
    let (d, b) = (of(&dark), of(&bright));
    let across = |p: [f64; 3]| {
        let along: f64 = (0..3).map(|c| p[c] * laser_rgb[c]).sum();
        [0, 1, 2].map(|c| p[c] - along * laser_rgb[c])
    };
    let apart = |p: [f64; 3], q: [f64; 3]| (0..3).map(|c| (p[c] - q[c]).powi(2)).sum::<f64>().sqrt();
    let (d_across, b_across) = (across(d.mean_rgb), across(b.mean_rgb));
    let by_pixel = apart(d_across, b_across) >= SURFACE_ACROSS_LASER_LEVELS
        && dark.len().min(bright.len()) >= 12
        && !scored.is_empty();
    let bright_share = if by_pixel {
        let on_bright = scored.iter().map(|&p| across(p)).filter(|&p| apart(p, b_across) < apart(p, d_across)).count();
        on_bright as f64 / scored.len() as f64
    } else {
        let mut near = near.to_vec();
        let mid = near.len() / 2;
        let reference = *near.select_nth_unstable_by(mid, |a, b| a.total_cmp(b)).1;
        if reference >= split {
            1.0
        } else {
            0.0
        }
    };
    let used = match bright_share {
        0.0 => dark.len(),
        1.0 => bright.len(),
        _ => dark.len().min(bright.len()),
    };
    let mix = |x: [f64; 3], y: [f64; 3]| [0, 1, 2].map(|c| (1.0 - bright_share) * x[c] + bright_share * y[c]);
    (used >= 12).then(|| SurfaceBackground {
        mean_rgb: mix(d.mean_rgb, b.mean_rgb),
        clipped_share: mix(d.clipped_share, b.clipped_share),
    })
}

/// Least distance between two ring surfaces' mean colours across the laser's colour,
/// 8-bit levels, for a blob's pixels to be told apart by surface one by one.
const SURFACE_ACROSS_LASER_LEVELS: f64 = 20.0;

/// A blob's ring of background, as one surface or two.
enum RingSurfaces {
    One(Vec<[f64; 3]>),
    /// Two, and the brightness (R + G + B, levels) between them.
    Two {
        dark: Vec<[f64; 3]>,
        bright: Vec<[f64; 3]>,
        split: f64,
    },
}

/// The ring's pixels split into two surfaces when their brightness (R + G + B) falls into
/// two clusters far apart; one surface otherwise, or when `near` (the pixels just outside
/// the blob) is empty and no surface could be told for the blob.
///
/// Far apart is [`SURFACE_SPLIT_LEVELS`] and, around an unclipped blob, a gap of
/// [`SURFACE_SPLIT_SPREADS`] times the clusters' summed spreads: a shading gradient across
/// the ring splits into two halves whose gap is only 1.7 times their spreads, two flat
/// surfaces into clusters as tight as the noise. The older rule, the brighter at least 1.5
/// times the darker, still holds around a clipped core, whose colour is read from its
/// fringe: read there against one of two surfaces, a glint beside algae came within
/// 0.5 sigmas of its unit's colour and was taken for the dot (held-out target-less
/// 1000367/01). Under that rule a dot in a dark stripe across a bright green fish was read
/// against the whole ring, (0, 7, 10) levels, 4 sigmas; against its stripe (6, 32, 12), 80
/// sigmas (tuning target-less 3002/11: the stripe 143 levels, the fish 203, 1.42 times).
fn ring_surfaces(ring: &[[f64; 3]], near: &[f64], clipped_core: bool) -> RingSurfaces {
    let sums: Vec<f64> = ring.iter().map(|p| p[0] + p[1] + p[2]).collect();
    if sums.len() < 24 || near.is_empty() {
        return RingSurfaces::One(ring.to_vec());
    }
    // Two means in 1D, from the extremes.
    let (mut lo, mut hi) =
        (sums.iter().copied().fold(f64::INFINITY, f64::min), sums.iter().copied().fold(0.0, f64::max));
    for _ in 0..8 {
        let split = 0.5 * (lo + hi);
        let (a, b): (Vec<f64>, Vec<f64>) = sums.iter().partition(|&&v| v < split);
        if a.is_empty() || b.is_empty() {
            return RingSurfaces::One(ring.to_vec());
        }
        lo = a.iter().sum::<f64>() / a.len() as f64;
        hi = b.iter().sum::<f64>() / b.len() as f64;
    }
    if hi - lo < SURFACE_SPLIT_LEVELS {
        return RingSurfaces::One(ring.to_vec());
    }
    let split = 0.5 * (lo + hi);
    // The spreads only for the rings the gap has not settled: most are one surface.
    let one = if clipped_core {
        hi < 1.5 * lo
    } else {
        let (mut squares, mut counts) = ([0.0f64; 2], [0usize; 2]);
        for &v in &sums {
            let side = usize::from(v >= split);
            squares[side] += (v - [lo, hi][side]).powi(2);
            counts[side] += 1;
        }
        let spread = |side: usize| (squares[side] / counts[side].max(1) as f64).sqrt();
        hi - lo < SURFACE_SPLIT_SPREADS * (spread(0) + spread(1))
    };
    if one {
        return RingSurfaces::One(ring.to_vec());
    }
    let (bright, dark): (Vec<_>, Vec<_>) = ring.iter().zip(&sums).partition(|(_, &v)| v >= split);
    let pixels = |part: Vec<(&[f64; 3], &f64)>| part.into_iter().map(|(p, _)| *p).collect();
    RingSurfaces::Two { dark: pixels(dark), bright: pixels(bright), split }
}

/// Brightness difference (R + G + B, 8-bit levels) between two clusters of a ring beyond
/// which they are two surfaces.
const SURFACE_SPLIT_LEVELS: f64 = 60.0;

/// Least gap between a ring's two brightness clusters, in their summed spreads, for an
/// unclipped blob's ring to hold two surfaces ([`ring_surfaces`]).
const SURFACE_SPLIT_SPREADS: f64 = 2.0;

/// How many of `clipped` (ROI pixels, row-major over `width`) there are, and their mean
/// position (ROI pixels; `None` when there are none).
fn clipped_part(clipped: impl Iterator<Item = usize>, width: usize) -> (usize, Option<Vec2>) {
    let (n, sum) = clipped
        .fold((0usize, Vec2::zeros()), |(n, sum), i| (n + 1, sum + Vec2::new((i % width) as f64, (i / width) as f64)));
    (n, (n > 0).then(|| sum / n as f64))
}

/// A glint's pixels (image x, y) as a mask over `roi`'s pixels.
fn glint_mask(glint: &Glint, roi: Roi) -> Vec<bool> {
    let mut mask = vec![false; if glint.is_empty() { 0 } else { roi.w * roi.h }];
    for &(x, y) in glint {
        let (x, y) = (x - roi.x0 as i64, y - roi.y0 as i64);
        if (0..roi.w as i64).contains(&x) && (0..roi.h as i64).contains(&y) {
            mask[y as usize * roi.w + x as usize] = true;
        }
    }
    mask
}

/// A blob's peak, SNR and box; `None` for an elongated blob.
fn measure_blob(maps: &RoiMaps, pixels: &[usize]) -> Option<BlobMeasures> {
    let (saturated, w) = (&maps.saturated, maps.roi.w);
    let (sat_count, clipped_centroid) = clipped_part(pixels.iter().copied().filter(|&i| saturated[i]), w);
    let green: Vec<f32> = pixels.iter().filter(|&&i| !saturated[i]).map(|&i| maps.excess[i].max(0.0)).collect();
    // A core clipped throughout shows no contrast of its own: count it at the threshold, and
    // let its fringe's colour decide (in `blob_colour`).
    let peak = green.iter().copied().fold(maps.threshold, f32::max) as f64;
    let mass: f64 = green.iter().map(|&e| e as f64).sum();
    let core_pixels = sat_count + green.iter().filter(|&&e| e as f64 >= 0.5 * peak).count();
    // Matched-filter SNR of the halo; a clipped pixel counts at the peak level or at the
    // contrast its unclipped channels still show, whichever is more. At the peak alone a
    // near dot on a square whose green and blue clip (its halo hidden, only its core
    // showing) ranked below eight blobs of algae and was cut (tuning seed 9).
    let snr = (mass + sat_count as f64 * peak) / (maps.sigma * (pixels.len() as f64).sqrt());
    // Elongated blobs are edges or streaks, not a dot.
    let (mnx, mxx, mny, mxy) = blob_box(pixels, w);
    let (bw, bh) = ((mxx - mnx + 1) as f64, (mxy - mny + 1) as f64);
    if bw.max(bh) / bw.min(bh) > 3.0 || (pixels.len() as f64) < 0.3 * bw * bh {
        return None;
    }
    Some(BlobMeasures {
        peak,
        snr,
        core_pixels,
        saturated_pixels: sat_count,
        clipped_centroid,
        bbox: (mnx, mxx, mny, mxy),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A `w x h` RGB image whose pixel (x, y) is `colour(x, y)`, levels clipped to 0-255 as a
    /// sensor clips them.
    fn paint(w: usize, h: usize, colour: impl Fn(usize, usize) -> [f64; 3]) -> Vec<u8> {
        let mut data = vec![0u8; w * h * 3];
        for y in 0..h {
            for x in 0..w {
                let i = (y * w + x) * 3;
                for (c, v) in colour(x, y).into_iter().enumerate() {
                    data[i + c] = v.clamp(0.0, 255.0) as u8;
                }
            }
        }
        data
    }

    /// A camera's tone curve bends the light a laser adds: read as it is, the same dot's
    /// chroma differs over a dark and a light surface; read through the curve, it is the
    /// laser's own on both.
    #[test]
    fn reads_a_dot_through_the_cameras_tone_curve_as_the_lasers_colour() {
        let (w, h, gamma) = (160, 80, 2.2);
        let laser = [0.25, 0.9, 0.35];
        // Linear light: dark blue-green water on the left, pale paper on the right, a dot on
        // each; the JPEG's levels are that light through the curve.
        let dots = [(Vec2::new(40.0, 40.0), [4.0, 18.0, 30.0]), (Vec2::new(120.0, 40.0), [170.0, 150.0, 110.0])];
        let data = paint(w, h, |x, y| {
            let (centre, surface) = if x < w / 2 { dots[0] } else { dots[1] };
            let lit = spot(x, y, centre, 70.0, 2.5);
            core::array::from_fn(|i| 255.0 * ((surface[i] + laser[i] * lit) / 255.0f64).min(1.0).powf(1.0 / gamma))
        });
        let unit = crate::dot::colour::linear_unit_colour([0.25, 0.9, 0.35], 0.06, 8);
        let angles = |tone: ToneCurve| -> Vec<f64> {
            let params = DotDetectorParams {
                colour: LaserColourModel::from_unit(&unit).unwrap().through(tone),
                ..DotDetectorParams::default()
            };
            let found = find_dot_candidates(&view(&data, w, h).through(&tone), &SearchRegion::default(), &params, 4);
            dots.iter()
                .map(|(centre, _)| {
                    let c = found.iter().find(|c| (c.pixel - centre).norm() < 1.0).expect("each dot found");
                    c.colour_angle_rad.to_degrees()
                })
                .collect()
        };
        // Measured: 28.5 and 6.9 degrees read as is, 0.24 and 0.17 through the curve.
        let curved = angles(ToneCurve::linear());
        let linearised = angles(ToneCurve::power(gamma).unwrap());
        assert!(linearised.iter().all(|a| *a < 1.0), "{linearised:?}");
        assert!(curved[0] > 15.0 && curved[1] > 4.0, "{curved:?}");
    }

    fn view(data: &[u8], w: usize, h: usize) -> ColourView<'_> {
        ColourView { width: w, height: h, stride: w * 3, order: ChannelOrder::Rgb, data, tone: None }
    }

    /// The level a Gaussian spot of `peak` levels and `sigma_px` centred at `centre` has at
    /// pixel (x, y).
    fn spot(x: usize, y: usize, centre: Vec2, peak: f64, sigma_px: f64) -> f64 {
        let d2 = (x as f64 - centre.x).powi(2) + (y as f64 - centre.y).powi(2);
        peak * (-d2 / (2.0 * sigma_px.powi(2))).exp()
    }

    /// The candidate within 1 px of `truth` that a search of the whole image returns (at most
    /// 4 candidates); panics, listing them, when there is none.
    fn candidate_at(data: &[u8], (w, h): (usize, usize), truth: Vec2, params: &DotDetectorParams) -> DotCandidate {
        let c = find_dot_candidates(&view(data, w, h), &SearchRegion::default(), params, 4);
        let dot = c.iter().find(|c| (c.pixel - truth).norm() < 1.0).cloned();
        dot.unwrap_or_else(|| panic!("no candidate at the dot: {c:?}"))
    }

    /// A unit's learned colour for a green laser with a blue second channel, from 7 dots.
    fn green_laser_with_blue() -> LaserColourModel {
        let unit = crate::dot::colour::linear_unit_colour([0.31, 0.88, 0.36], 0.08, 7);
        LaserColourModel::from_unit(&unit).expect("a green laser with blue")
    }

    /// A surface's colour lit by `dot` levels of a laser of colour `laser`, with `noise`.
    fn lit(surface: [f64; 3], laser: [f64; 3], dot: f64, noise: f64) -> [f64; 3] {
        [0, 1, 2].map(|c| surface[c] + laser[c] * dot + noise)
    }

    /// A fixed grain of -2.4 to +2.4 levels.
    fn grain(x: usize, y: usize) -> f64 {
        (((x * 31 + y * 17) % 7) as f64 - 3.0) * 0.8
    }

    /// The squares of a board of 9 x 6 inner corners at multiples of `side` px (where four
    /// squares meet), its border squares extrapolated to the image's edges.
    fn board_9x6(side: usize) -> Vec<[Vec2; 4]> {
        let (cols, rows) = (9usize, 6usize);
        let corners: Vec<Vec2> = (0..cols * rows)
            .map(|k| Vec2::new((side * (1 + k % cols)) as f64, (side * (1 + k / cols)) as f64))
            .collect();
        crate::dot::on_target::board_squares(&corners, cols, rows)
    }

    /// The search over the whole board of [`board_9x6`] with `side` px squares (10 x 7 of
    /// them, border squares included), on its `squares`.
    fn over_board_9x6(side: usize, squares: Vec<[Vec2; 4]>) -> SearchRegion {
        let (x1, y1) = ((10 * side - 1) as f64, (7 * side - 1) as f64);
        SearchRegion {
            polygon: vec![Vec2::new(0.0, 0.0), Vec2::new(x1, 0.0), Vec2::new(x1, y1), Vec2::new(0.0, y1)],
            band: None,
            squares,
            overlapping_pieces: false,
        }
    }

    /// Whether pixel (x, y) lies on a white square of a board of `side` px squares.
    fn on_white(x: usize, y: usize, side: usize) -> bool {
        ((x / side) + (y / side)) % 2 == 0
    }

    /// A blue-green background with a Gaussian green dot and a white glint.
    fn synthetic(dot: Vec2, glint: Vec2, with_core: bool) -> (Vec<u8>, usize, usize) {
        let (w, h) = (200usize, 150usize);
        let data = paint(w, h, |x, y| {
            let halo = spot(x, y, dot, 140.0, 4.0);
            let core = if with_core { spot(x, y, dot, 300.0, 1.5) } else { 0.0 };
            let gl = spot(x, y, glint, 400.0, 3.0);
            [20.0 + core + gl, 90.0 + halo + core + gl, 100.0 + core + gl]
        });
        (data, w, h)
    }

    #[test]
    fn finds_the_green_dot_not_the_brighter_white_glint() {
        let truth = Vec2::new(61.3, 80.7);
        let (data, w, h) = synthetic(truth, Vec2::new(150.0, 40.0), true);
        let c = find_dot_candidates(&view(&data, w, h), &SearchRegion::default(), &DotDetectorParams::default(), 4);
        assert_eq!(c.len(), 1, "{c:?}");
        assert!(c[0].saturated_core);
        assert!((c[0].pixel - truth).norm() < 0.15, "{:?}", c[0].pixel);
    }

    /// A near dot of 2 000 levels clips its own green out to 26.3 px and white only to
    /// 16.5 px (where its 0.27 crosstalk lifts red and blue past the clip); a glint of the
    /// same white size clips all three channels together. The green ring tells them apart
    /// (`lit_clipped_px`), and a clipped surface counts as no ring at all.
    #[test]
    fn a_bright_dot_clips_its_own_channel_beyond_its_white_core_and_a_glint_does_not() {
        let (w, h) = (240usize, 160usize);
        let (dot, glint) = (Vec2::new(70.3, 80.6), Vec2::new(170.8, 79.4));
        let disc = |r: f64, p: f64| std::f64::consts::PI * r * r * p;
        let data = paint(w, h, |x, y| {
            let d = spot(x, y, dot, 2000.0, 12.0);
            let inside = (Vec2::new(x as f64, y as f64) - glint).norm() <= 16.5;
            let g = if inside { 400.0 } else { spot(x, y, glint, 400.0, 16.5 / 2.0) * 0.02 };
            let noise = grain(x, y);
            [40.0 + 0.27 * d + g + noise, 70.0 + d + g + noise, 60.0 + 0.27 * d + g + noise]
        });
        let c = find_dot_candidates(&view(&data, w, h), &SearchRegion::default(), &DotDetectorParams::default(), 4);
        let near = |at: Vec2| c.iter().find(|c| (c.pixel - at).norm() < 2.0);
        let d = near(dot).unwrap_or_else(|| panic!("no candidate at the dot: {c:?}"));
        assert!((d.white_px as f64 - disc(16.5, 1.0)).abs() < disc(16.5, 0.1), "{d:?}");
        assert!((d.lit_clipped_px as f64 - disc(26.3, 1.0)).abs() < disc(26.3, 0.1), "{d:?}");
        // The glint is white, not the laser's colour: whether or not it is a candidate, its
        // green clips no further than its white.
        let view = view(&data, w, h);
        let maps = RoiMaps::new(&view, Roi { x0: 0, y0: 0, w, h }, &DotDetectorParams::default(), &[]);
        let at = (glint.y.round() as usize) * w + glint.x.round() as usize;
        let lit = lit_channels(&LaserColourModel::green_prior());
        let ring = lit_clipped_around(&view, &maps, &[at], lit, 40_000);
        assert!((ring as f64) < disc(16.5, 1.1), "{ring}");
        assert_eq!(lit_clipped_around(&view, &maps, &[at], lit, 500), 0, "a clipped surface");
    }

    /// A 200 x 150 image whose pixel (x, y) is `colour(x, y, t)` plus a fixed grain, `t` 1
    /// inside an elliptic tuft (7 x 5 px) at `tuft` and 0 outside.
    fn beside_tuft(tuft: Vec2, colour: impl Fn(usize, usize, f64) -> [f64; 3]) -> (Vec<u8>, usize, usize) {
        let (w, h) = (200usize, 150usize);
        let data = paint(w, h, |x, y| {
            let (dx, dy) = (x as f64 - tuft.x, y as f64 - tuft.y);
            let t = if (dx / 7.0).powi(2) + (dy / 5.0).powi(2) <= 1.0 { 1.0 } else { 0.0 };
            colour(x, y, t).map(|v| v + grain(x, y))
        });
        (data, w, h)
    }

    /// A near dot whose core clips white, touching a tuft whose green clips: the tuft's
    /// clipped green and fringe would pull a centroid over both 2-5 px toward it (tuning
    /// seeds: a dot on algae 6.4 px off, one beside a sun fleck 5.4 px off); the white core
    /// alone is round about the dot's centre.
    #[test]
    fn a_white_core_is_centred_on_itself_not_on_the_tuft_beside_it() {
        let truth = Vec2::new(90.4, 70.7);
        let (data, w, h) = beside_tuft(Vec2::new(101.0, 74.0), |x, y, t| {
            let core = spot(x, y, truth, 600.0, 3.0);
            let halo = spot(x, y, truth, 120.0, 6.0);
            [30.0 + core + 0.2 * halo + 40.0 * t, 80.0 + core + halo + 200.0 * t, 90.0 + core + 0.3 * halo + 10.0 * t]
        });
        let c = find_dot_candidates(&view(&data, w, h), &SearchRegion::default(), &DotDetectorParams::default(), 4);
        let dot = c.iter().find(|c| (c.pixel - truth).norm() < 6.0);
        let dot = dot.unwrap_or_else(|| panic!("no candidate near the dot: {c:?}"));
        assert!((dot.pixel - truth).norm() < 0.5, "{:?}", dot.pixel);
    }

    /// The same dot smeared by the camera's motion into a streak 7 px long (centred on it, as
    /// a steady drift during the exposure draws it) across toward the tuft: its white core
    /// is drawn out about 2.5 times as long as wide in its second moments, and is still its
    /// centre. Refused as not round, the centre was the disc's centroid, pulled toward the
    /// tuft (held-out target-less 1000435/12, 1000438/10, 1000439/12: 3.1-6.6 px off, wrong
    /// dots).
    #[test]
    fn a_white_core_drawn_out_by_motion_is_centred_on_itself_not_on_the_tuft_beside_it() {
        let truth = Vec2::new(90.4, 70.7);
        let taps = 15;
        let streak = |x: usize, y: usize, peak: f64, sigma_px: f64| {
            let along = |k: usize| truth + Vec2::new(7.0 * (k as f64 / (taps - 1) as f64 - 0.5), 0.0);
            (0..taps).map(|k| spot(x, y, along(k), peak, sigma_px)).sum::<f64>() / taps as f64
        };
        let (data, w, h) = beside_tuft(Vec2::new(102.0, 74.0), |x, y, t| {
            let core = streak(x, y, 900.0, 2.2);
            let halo = streak(x, y, 160.0, 6.0);
            [30.0 + core + 0.2 * halo + 40.0 * t, 80.0 + core + halo + 200.0 * t, 90.0 + core + 0.3 * halo + 10.0 * t]
        });
        let white: Vec<(usize, usize)> = (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .filter(|&(x, y)| data[(y * w + x) * 3..(y * w + x) * 3 + 3].iter().all(|&v| v >= CLIPPED as u8))
            .collect();
        let n = white.len() as f64;
        let (mx, my) = white.iter().fold((0.0, 0.0), |a, &(x, y)| (a.0 + x as f64 / n, a.1 + y as f64 / n));
        let (vx, vy) = white
            .iter()
            .fold((0.0, 0.0), |a, &(x, y)| (a.0 + (x as f64 - mx).powi(2) / n, a.1 + (y as f64 - my).powi(2) / n));
        assert!((2.0..3.0).contains(&(vx / vy)), "the core is drawn out: {vx:.2} / {vy:.2} over {n} px");
        let c = find_dot_candidates(&view(&data, w, h), &SearchRegion::default(), &DotDetectorParams::default(), 4);
        let dot = c.iter().find(|c| (c.pixel - truth).norm() < 8.0);
        let dot = dot.unwrap_or_else(|| panic!("no candidate near the dot: {c:?}"));
        assert!((dot.pixel - truth).norm() < 0.5, "{:?}", dot.pixel);
    }

    /// A yellow-green dot whose green and red clip (not white: its blue stays low), touching a
    /// green tuft (red 2% of its green) whose green clips too: every clipped-green pixel
    /// weighed alike, the centre is pulled 3.4 px toward the tuft (seeds 1000100/00 and
    /// 1000101/11: 6.9 px). Under the unit's learned colour the tuft's pixels, which lack the
    /// laser's red, weigh next to nothing (0.3 px off); under the prior, which knows no
    /// second channel, the core clipped in both red and green is the dot's (pulled 3.4 px
    /// when that core was not looked for).
    #[test]
    fn a_clipped_dot_is_centred_on_the_laser_s_colour_not_on_a_clipped_tuft_beside_it() {
        let truth = Vec2::new(90.4, 70.7);
        let (data, w, h) = beside_tuft(Vec2::new(99.5, 72.0), |x, y, t| {
            let dot = spot(x, y, truth, 600.0, 3.0) + spot(x, y, truth, 60.0, 6.0);
            [40.0 + 0.6 * dot + 5.0 * t, 70.0 + dot + 220.0 * t, 60.0 + 0.1 * dot + 5.0 * t]
        });
        let centre = |colour: LaserColourModel| {
            let params = DotDetectorParams { colour, ..DotDetectorParams::default() };
            let c = find_dot_candidates(&view(&data, w, h), &SearchRegion::default(), &params, 4);
            let dot = c.iter().find(|c| (c.pixel - truth).norm() < 8.0).map(|c| c.pixel);
            dot.unwrap_or_else(|| panic!("no candidate near the dot: {c:?}"))
        };
        let unit = crate::dot::colour::linear_unit_colour([0.51, 0.85, 0.085], 0.06, 8);
        let learned = centre(LaserColourModel::from_unit(&unit).expect("a yellow-green laser"));
        let prior = centre(LaserColourModel::green_prior());
        assert!((learned - truth).norm() < 0.5, "learned colour: {learned:?}");
        assert!((prior - truth).norm() < 0.5, "the prior: {prior:?}");
    }

    /// A bright dot on a bright green fish (green 236, blue shaded by 0.5 levels per pixel
    /// across it), its core clipped white in one pixel: the dot's glow lifts the fish's green
    /// to the clip 6 px around the core, where the laser adds about 19 levels of green and 8
    /// of blue, less than the fish's shading varies over the ring. Judged by their blue, the
    /// glow's pixels on the fish's bluer side weighed as the laser's light and those on the
    /// other as a pigment's, and the centre went 2.2 px up the shading (target-less
    /// 1000200/08: a 490-level dot centred 3.6 px off, a wrong dot); where the laser's blue
    /// would be lost in the ring's scatter a pixel is not judged (0.1 px off).
    #[test]
    fn a_dot_whose_glow_clips_a_bright_fish_is_centred_on_the_glow_not_up_its_shading() {
        let (w, h) = (200usize, 150usize);
        let truth = Vec2::new(100.3, 75.6);
        let laser = [0.26, 1.0, 0.34];
        let data = paint(w, h, |x, y| {
            let dot = spot(x, y, truth, 650.0, 1.5) + spot(x, y, truth, 30.0, 7.0);
            let shade = 0.5 * (x as f64 - truth.x) + 0.3 * (y as f64 - truth.y);
            lit([88.0, 236.0, 78.0 + shade], laser, dot, grain(x, y))
        });
        let colour = green_laser_with_blue();
        let dot = candidate_at(&data, (w, h), truth, &DotDetectorParams { colour, ..DotDetectorParams::default() });
        assert!((dot.pixel - truth).norm() < 0.5, "{:?} against {truth:?}", dot.pixel);
    }

    /// A green dot on a white square 12 px from a black one, in clear blue water: its colour
    /// is measured against the white square, not against a ring half on the black one
    /// (measured so, the chroma angle was 0.85 rad; against the white square, 0.11).
    #[test]
    fn a_dot_beside_a_square_edge_keeps_its_colour() {
        let (w, h) = (200usize, 150usize);
        let truth = Vec2::new(112.4, 75.6);
        let data = paint(w, h, |x, y| {
            let dot = spot(x, y, truth, 70.0, 2.5);
            let [r, g, b] = if x < 100 { [20.0, 30.0, 35.0] } else { [68.0, 190.0, 240.0] };
            let noise = ((x * 7 + y * 13) % 5) as f64 - 2.0;
            [r + 0.2 * dot + noise, g + dot + noise, b + 0.3 * dot + noise]
        });
        let dot = candidate_at(&data, (w, h), truth, &DotDetectorParams::default());
        assert!(dot.colour_angle_rad < 0.3, "{dot:?}");
    }

    /// A clipped dot of 150 levels on a cyan fish whose dark stripe begins 2 px below the
    /// dot's centre: the fringe its colour is read on lies on both. Against the fish alone
    /// (the ring's cluster nearer the blob) the stripe's pixels read as a deficit and the
    /// dot scores no colour (no candidate here; (-2, -10, -30) levels of excess on held-out
    /// target-less 1000104/10, lost); each pixel read against its own surface, told by its
    /// colour across the laser's, gives back the laser's hue.
    #[test]
    fn a_clipped_dot_on_a_stripe_s_edge_is_read_against_each_surface_it_lies_on() {
        let (w, h) = (200usize, 150usize);
        let truth = Vec2::new(100.4, 75.3);
        let laser = [0.25, 1.0, 0.26];
        let data = paint(w, h, |x, y| {
            let dot = spot(x, y, truth, 150.0, 2.0);
            let noise = grain(x, y);
            let [r, g, b] = if (y as f64) < truth.y + 2.0 { [55.0, 195.0, 205.0] } else { [30.0, 86.0, 87.0] };
            lit([r, g, b], laser, dot, noise)
        });
        let p = DotDetectorParams::default();
        let dot = candidate_at(&data, (w, h), truth, &p);
        assert!(dot.saturated_core, "{dot:?}");
        let true_angle = p.colour.angle_rad(laser);
        assert!((dot.colour_angle_rad - true_angle).abs() < 0.15, "{} against {true_angle}", dot.colour_angle_rad);
    }

    /// Two flat surfaces 1.49 times apart in brightness are two; a ramp from 1 to 3 times a
    /// surface's brightness is one (its halves' means 1.67 times apart, so the factor rule
    /// alone split it); around a clipped core the factor rule stays.
    #[test]
    fn a_ring_is_two_surfaces_when_its_brightness_falls_in_two_tight_clusters() {
        let flat = |k: usize| if k % 2 == 0 { [25.0, 60.0, 55.0] } else { [36.0, 100.0, 72.0] };
        let jitter = |k: usize| ((k * 7) % 5) as f64 - 2.0;
        let two: Vec<[f64; 3]> = (0..60).map(|k| flat(k).map(|v| v + jitter(k))).collect();
        let ramp: Vec<[f64; 3]> =
            (0..60).map(|k| [25.0, 60.0, 55.0].map(|v| v * (1.0 + 2.0 * k as f64 / 59.0))).collect();
        let near = [150.0; 8];
        assert!(matches!(ring_surfaces(&two, &near, false), RingSurfaces::Two { .. }));
        assert!(matches!(ring_surfaces(&ramp, &near, false), RingSurfaces::One(_)));
        assert!(matches!(ring_surfaces(&two, &near, true), RingSurfaces::One(_)));
        assert!(matches!(ring_surfaces(&ramp, &near, true), RingSurfaces::Two { .. }));
    }

    /// A near dot of 3 000 levels on a bright cyan square of a board (green 215, blue 225,
    /// never clipped itself): its white core is 9 px across, its glow clips green and blue
    /// over the fringe its colour is read on but not over the ring beyond, and the clipped
    /// green, wider than a quarter square, is the surface's to the core test. Its contrast
    /// shows only in red: read as measured it scored far off the laser's colour and was no
    /// candidate. With those channels blind it is found, its colour filled in from the
    /// laser's (no evidence of it).
    #[test]
    fn a_near_dots_glow_clipping_a_bright_square_is_seen_in_its_other_channel() {
        let side = 56usize;
        let (w, h) = (10 * side, 7 * side);
        let truth = Vec2::new(252.3, 140.6);
        let laser = [0.29, 1.0, 0.31];
        let data = paint(w, h, |x, y| {
            let dot = spot(x, y, truth, 3000.0, 5.0) + spot(x, y, truth, 400.0, 8.0);
            let surface = if on_white(x, y, side) { [40.0, 215.0, 225.0] } else { [20.0, 40.0, 45.0] };
            lit(surface, laser, dot, grain(x, y))
        });
        let region = over_board_9x6(side, board_9x6(side));
        let c = find_dot_candidates(&view(&data, w, h), &region, &DotDetectorParams::default(), 8);
        let dot = c.iter().find(|c| (c.pixel - truth).norm() < 1.0);
        let dot = dot.unwrap_or_else(|| panic!("no candidate at the dot: {c:?}"));
        assert!(dot.saturated_core && dot.colour_filled_in, "{dot:?}");
    }

    /// A near dot dim enough not to clip is a flat disc 15 px in radius, 50 levels over a
    /// surface that brightens by 0.3 levels per pixel across it. Smoothed by a filter much
    /// narrower than the disc, its top stays flat and the peak lands wherever the gradient
    /// and the grain tip it: 3.3 px off on held-out target-less 1000100/17, refused as off
    /// the line, and 3.1 px here. A filter wide enough to reach the disc's edge peaks within
    /// 0.5 px of its centre (the gradient the ring's background model leaves still tips it a
    /// little).
    #[test]
    fn a_large_flat_dot_is_centred_on_its_disc_whatever_the_surface_s_gradient() {
        let (w, h) = (200usize, 150usize);
        let truth = Vec2::new(100.4, 74.7);
        let laser = [0.1, 1.0, 0.48];
        let data = paint(w, h, |x, y| {
            let d = (x as f64 - truth.x).hypot(y as f64 - truth.y);
            // A disc with a one-pixel blurred edge.
            let dot = 50.0 * (15.0 - d + 0.5).clamp(0.0, 1.0);
            let slope = 0.3 * (x as f64 + 0.5 * y as f64);
            let noise = grain(x, y);
            lit([90.0 + 0.3 * slope, 110.0 + slope, 80.0 + 0.2 * slope], laser, dot, noise)
        });
        let dot = candidate_at(&data, (w, h), truth, &DotDetectorParams::default());
        assert!((dot.pixel - truth).norm() < 1.0, "{:?} against {truth:?}", dot.pixel);
    }

    /// A dot of 40 levels on a fish, 8 px from the edge of a lighter, bluer stripe that the
    /// background ring half lies on. The ring's level is off by a few levels; over the dot's
    /// faint halo (the whole blob the threshold picks) that bias read 0.26 rad of chroma, 0.15
    /// more than the dot's own colour has; over its core it stays within 0.02.
    #[test]
    fn a_dot_near_a_stripe_is_scored_by_its_core_not_its_halo() {
        let (w, h) = (200usize, 150usize);
        let truth = Vec2::new(100.3, 75.6);
        let laser = [0.2, 1.0, 0.3];
        let data = paint(w, h, |x, y| {
            let dot = spot(x, y, truth, 40.0, 3.0);
            let stripe = if x >= 108 { 1.0 } else { 0.0 };
            let noise = grain(x, y);
            let [r, g, b] = [40.0 + 2.0 * stripe, 110.0 + 14.0 * stripe, 60.0 + 18.0 * stripe];
            lit([r, g, b], laser, dot, noise)
        });
        let p = DotDetectorParams::default();
        let dot = candidate_at(&data, (w, h), truth, &p);
        let true_angle = p.colour.angle_rad(laser);
        assert!((dot.colour_angle_rad - true_angle).abs() < 0.02, "{} against {true_angle}", dot.colour_angle_rad);
    }

    /// A dot of 35 levels in a shaded hollow of reef: the surface darkens towards the dot
    /// in green and blue (the water's cast), by 25 levels under it, half that at 12 px. The
    /// ring beyond its halo is a dozen levels brighter than the surface under the dot, and
    /// the hue read against it is 0.20 rad off the laser's; against the band just outside
    /// the core, on the hollow's floor, 0.02. A calibration learns from the hue judged.
    #[test]
    fn a_dot_in_a_shaded_hollow_is_read_against_the_surface_right_around_it() {
        let (dot, true_angle, p) = dot_in_a_hollow((35.0, 2.0), (25.0, 12.0));
        let ring_angle = p.colour.angle_rad(dot.excess_rgb);
        assert!(ring_angle - true_angle > 0.15, "the ring's hue: {ring_angle} against {true_angle}");
        assert!((dot.colour_angle_rad - true_angle).abs() < 0.04, "{} against {true_angle}", dot.colour_angle_rad);
        let learned_angle = p.colour.angle_rad(dot.judged_excess_rgb);
        assert!((learned_angle - dot.colour_angle_rad).abs() < 1e-9, "learned from {learned_angle}");
    }

    /// The candidate the default detector finds for a dot of a laser (0.2, 1.0, 0.3) of
    /// `(peak, sigma)` in a hollow of reef of `(depth, sigma)` that darkens towards it in
    /// green and blue (the water's cast), with the laser's hue angle and the detector.
    fn dot_in_a_hollow(dot: (f64, f64), hollow: (f64, f64)) -> (DotCandidate, f64, DotDetectorParams) {
        let (w, h) = (200usize, 150usize);
        let truth = Vec2::new(100.4, 74.7);
        let laser = [0.2, 1.0, 0.3];
        let data = paint(w, h, |x, y| {
            let d = spot(x, y, truth, dot.0, dot.1);
            let under = spot(x, y, truth, hollow.0, hollow.1);
            let noise = grain(x, y);
            let [r, g, b] = [30.0, 120.0 - 0.5 * under, 140.0 - under];
            lit([r, g, b], laser, d, noise)
        });
        let p = DotDetectorParams::default();
        let found = candidate_at(&data, (w, h), truth, &p);
        let true_angle = p.colour.angle_rad(laser);
        (found, true_angle, p)
    }

    /// A wider hollow under a dot bright enough that 7 pixels of its 109 px core clip: a core
    /// that only touches the clip level keeps its colour in the rest of it, and is read as
    /// an unclipped one's, against the surface right around it: 0.06 rad off the laser's hue
    /// (the hollow still deepens between the band and the core). Read as a clipped core's,
    /// against the ring beyond its halo, it was 0.17 off.
    #[test]
    fn a_dot_whose_core_barely_clips_is_read_against_the_surface_right_around_it() {
        let (dot, true_angle, _) = dot_in_a_hollow((166.0, 5.0), (60.0, 25.0));
        let core_px = (core::f64::consts::PI * dot.core_radius_px.powi(2)).round() as usize;
        assert!(dot.saturated_px >= 1 && 10 * dot.saturated_px < core_px, "{dot:?}");
        assert!((dot.colour_angle_rad - true_angle).abs() < 0.07, "{} against {true_angle}", dot.colour_angle_rad);
    }

    /// A bubble in green water, lit along the laser's hue: a rim 30 levels bright around a
    /// clear middle, with a highlight 3 px off its centre. Its outline is no beam's (1); a
    /// dot of the same peak and size beside it is smooth.
    #[test]
    fn a_bubble_is_no_beams_footprint_and_a_dot_beside_it_is() {
        let (w, h) = (200usize, 120usize);
        let (bubble, truth) = (Vec2::new(60.4, 60.2), Vec2::new(140.3, 59.6));
        let data = paint(w, h, |x, y| {
            let d = (x as f64 - bubble.x).hypot(y as f64 - bubble.y);
            let rim = 30.0 * (-(d - 9.0).powi(2) / (2.0 * 1.3f64.powi(2))).exp();
            let glint = spot(x, y, bubble - Vec2::new(2.0, 2.0), 40.0, 1.2);
            let lit = rim + glint + spot(x, y, truth, 40.0, 4.0);
            let noise = grain(x, y);
            [30.0 + 0.3 * lit + noise, 90.0 + lit + noise, 70.0 + 0.3 * lit + noise]
        });
        let params = DotDetectorParams::default();
        let dot = candidate_at(&data, (w, h), truth, &params);
        assert!(dot.outline_roughness.is_some_and(|r| r < 0.05), "{dot:?}");
        let c = find_dot_candidates(&view(&data, w, h), &SearchRegion::default(), &params, 4);
        let rim = c.iter().find(|c| (c.pixel - bubble).norm() < 9.0).expect("the bubble is a candidate");
        assert_eq!(rim.outline_roughness, Some(1.0), "{rim:?}");
    }

    /// A near dot whose laser channel only just clips: JPEG noise leaves a mottle of clipped
    /// pixels across its top, fewer than half of the 3 x 3 at its centre. The mottle is
    /// centred on the dot, so it is the dot's core, not a clipped patch off a tuft's centre;
    /// a tuft whose clipped patch lies to one side is still no spot.
    #[test]
    fn a_dot_clipped_in_a_mottle_is_a_spot_and_a_tuft_clipped_to_one_side_is_not() {
        let (w, h) = (220usize, 120usize);
        let (truth, tuft) = (Vec2::new(50.3, 60.6), Vec2::new(140.0, 60.0));
        let patch = tuft + Vec2::new(16.0, 0.0);
        let data = paint(w, h, |x, y| {
            let d = (x as f64 - truth.x).hypot(y as f64 - truth.y);
            let top = 157.0 * (-(d - 7.5).max(0.0).powi(2) / 2.0).exp();
            let mottle = if d >= 7.5 {
                0.0
            } else if (x * 7 + y * 13) % 5 < 2 {
                4.0
            } else {
                -4.0
            };
            let dot = top + mottle;
            let tuft = 100.0 / (1.0 + (((x as f64 - tuft.x).hypot(y as f64 - tuft.y) - 24.0) / 1.5).exp())
                + 70.0 / (1.0 + (((x as f64 - patch.x).hypot(y as f64 - patch.y) - 6.5) / 1.0).exp());
            let noise = grain(x, y);
            [30.0 + 0.1 * (dot + tuft) + noise, 93.0 + dot + tuft + noise, 60.0 + 0.5 * (dot + tuft) + noise]
        });
        let params = DotDetectorParams::default();
        let c = find_dot_candidates(&view(&data, w, h), &SearchRegion::default(), &params, 4);
        let dot = c.iter().find(|c| (c.pixel - truth).norm() < 1.0).expect("the dot is a candidate");
        assert!(!dot.saturated_core && dot.saturated_px >= 50, "a mottle, not a clipped centre: {dot:?}");
        assert!(dot.outline_roughness.is_some_and(|r| r < 0.1), "{dot:?}");
        let tuft = c.iter().find(|c| (c.pixel - tuft).norm() < 24.0).expect("the tuft is a candidate");
        assert_eq!(tuft.outline_roughness, Some(1.0), "{tuft:?}");
    }

    /// A dot 13 px from a glint: the glint's core clips white and its halo, the light's own
    /// near-white colour with a little of the water's green, bridges the two into one blob
    /// whose candidate sits on the glint. The water is green enough that green clips on the
    /// glint's rim, so its white passes for a dot's core (a glint with no green rim is no
    /// core: `a_glint_on_a_dots_halo_is_not_taken_for_its_white_core`). Along a line through
    /// the dot, the dot is found as a spot of its own beside the glint; a search of the whole
    /// image (no line) does not split.
    #[test]
    fn a_dot_beside_a_glint_is_found_apart_from_it() {
        let (w, h) = (200usize, 120usize);
        let (glint, truth) = (Vec2::new(90.0, 60.0), Vec2::new(103.2, 60.4));
        let data = paint(w, h, |x, y| {
            let d = (x as f64 - glint.x).hypot(y as f64 - glint.y);
            let core = if d <= 3.0 { 255.0 } else { 0.0 };
            let halo = 70.0 * (-d * d / (2.0 * 6.0 * 6.0)).exp();
            let dot = spot(x, y, truth, 50.0, 2.5);
            let noise = grain(x, y);
            [
                30.0 + core + halo + 0.25 * dot + noise,
                185.0 + core + 1.2 * halo + dot + noise,
                70.0 + core + halo + 0.4 * dot + noise,
            ]
        });
        let params = DotDetectorParams::default();
        let line = vec![Vec2::new(0.0, 60.4), Vec2::new(199.0, 60.4)];
        let polygon = vec![Vec2::new(0.0, 30.0), Vec2::new(199.0, 30.0), Vec2::new(199.0, 90.0), Vec2::new(0.0, 90.0)];
        let band = SearchRegion {
            polygon: polygon.clone(),
            band: Some((line, 30.0)),
            squares: Vec::new(),
            overlapping_pieces: false,
        };
        let c = find_dot_candidates(&view(&data, w, h), &band, &params, 8);
        let on_glint = c.iter().find(|c| (c.pixel - glint).norm() < 3.0);
        assert!(on_glint.is_some_and(|g| g.saturated_core), "the merged blob sits on the glint: {c:?}");
        let dot = c.iter().find(|c| (c.pixel - truth).norm() < 1.0);
        assert!(dot.is_some_and(|d| d.split_from_blob), "{c:?}");
        let whole = SearchRegion { polygon, band: None, squares: Vec::new(), overlapping_pieces: false };
        let c = find_dot_candidates(&view(&data, w, h), &whole, &params, 8);
        assert!(c.iter().all(|c| (c.pixel - truth).norm() >= 1.0 && !c.split_from_blob), "{c:?}");
    }

    /// The candidates (at most `max`) of a search along a vertical laser line at `x` with
    /// half-width `half`, over the strip from x `left` to `right` of a `w` x `h` image.
    fn along_vertical_line(
        data: &[u8],
        (w, h): (usize, usize),
        (x, half): (f64, f64),
        (left, right): (f64, f64),
        params: &DotDetectorParams,
        max: usize,
    ) -> Vec<DotCandidate> {
        let bottom = (h - 1) as f64;
        let line = vec![Vec2::new(x, 0.0), Vec2::new(x, bottom)];
        let polygon =
            vec![Vec2::new(left, 0.0), Vec2::new(right, 0.0), Vec2::new(right, bottom), Vec2::new(left, bottom)];
        let band = SearchRegion { polygon, band: Some((line, half)), squares: Vec::new(), overlapping_pieces: false };
        find_dot_candidates(&view(data, w, h), &band, params, max)
    }

    /// The sensitive search along a vertical laser line at x = 80.4 (a 4 px band) of a
    /// `w` x `h` image.
    fn along_line_at_x_80(data: &[u8], w: usize, h: usize) -> Vec<DotCandidate> {
        along_vertical_line(data, (w, h), (80.4, 4.0), (50.0, 110.0), &DotDetectorParams::default().sensitive(), 4)
    }

    /// A glint 3 px across on the halo of a dot of 180 levels, 12 px from it, in bright blue
    /// water: the glint is the only white in reach, and its channels fall off together, so
    /// its rim clips no green (tuning target-less 16/00, where the dot was centred on the
    /// glint and refused as off the line). The dot is centred on itself.
    #[test]
    fn a_glint_on_a_dots_halo_is_not_taken_for_its_white_core() {
        let (w, h) = (160usize, 120usize);
        let (truth, glint) = (Vec2::new(80.4, 70.3), Vec2::new(80.9, 58.2));
        let data = paint(w, h, |x, y| {
            let dot = spot(x, y, truth, 180.0, 3.5);
            let gl = spot(x, y, glint, 400.0, 1.6);
            let noise = grain(x, y);
            [35.0 + 0.08 * dot + gl + noise, 110.0 + dot + gl + noise, 212.0 + 0.5 * dot + gl + noise]
        });
        let c = along_line_at_x_80(&data, w, h);
        let dot = c.iter().find(|c| (c.pixel - truth).norm() < 0.6);
        assert!(dot.is_some(), "no candidate within 0.6 px of the dot: {c:?}");
    }

    /// A dot of 70 levels in green water with a glint 7 px across 11 px from it, their halos
    /// touching (tuning target-less 4/08): one blob, clipped only in the glint. The glint's
    /// pixels and its halo are left out of the blob's shape, so the dot is not a blob
    /// clipped off its centre, nor an outline bulging toward the glint.
    #[test]
    fn a_glint_beside_a_dot_is_no_part_of_its_outline() {
        let (w, h) = (160usize, 120usize);
        let (truth, glint) = (Vec2::new(80.4, 60.3), Vec2::new(88.9, 66.9));
        let data = paint(w, h, |x, y| {
            let dot = spot(x, y, truth, 70.0, 3.0);
            let gl = spot(x, y, glint, 3000.0, 1.6);
            let noise = grain(x, y);
            [27.0 + 0.3 * dot + 0.9 * gl + noise, 138.0 + dot + gl + noise, 70.0 + 0.4 * dot + 0.9 * gl + noise]
        });
        let c = along_line_at_x_80(&data, w, h);
        let dot = c.iter().find(|c| (c.pixel - truth).norm() < 0.6);
        let dot = dot.unwrap_or_else(|| panic!("no candidate within 0.6 px of the dot: {c:?}"));
        assert!(dot.outline_roughness.is_some_and(|r| r < 0.06), "{dot:?}");
    }

    /// A fish lit greener than the blue water it swims in, 140 x 32 px, with the laser's
    /// line crossing it 50 px from its middle, at x = 120.4.
    fn fish_across_the_line(dot: Option<(Vec2, f64)>) -> (Vec<u8>, usize, usize) {
        let (w, h) = (240usize, 200usize);
        let data = paint(w, h, |x, y| {
            let (u, v) = ((x as f64 - 70.0) / 70.0, (y as f64 - 100.0) / 16.0);
            // Lit across a 2 px edge, as a blurred outline.
            let body = (1.0 - (u * u + v * v).sqrt()).clamp(-0.04, 0.04) / 0.08 + 0.5;
            let d = dot.map_or(0.0, |(at, peak)| spot(x, y, at, peak, 3.0));
            let noise = grain(x, y);
            [
                20.0 + 10.0 * body + 0.1 * d + noise,
                80.0 + 50.0 * body + d + noise,
                110.0 + 12.0 * body + 0.5 * d + noise,
            ]
        });
        (data, w, h)
    }

    fn along_line_at_x_120(data: &[u8], w: usize, h: usize) -> Vec<DotCandidate> {
        along_vertical_line(data, (w, h), (120.4, 20.0), (80.0, 160.0), &DotDetectorParams::default(), 16)
    }

    /// A dot of 90 levels on a fish whose body stands 40 levels over the water along the
    /// laser's colour: the body floods into one blob with the dot, centred on the body 13 px
    /// off the line (tuning target-less 16/15, a dot of 152 levels lost in a fish's 8 900 px
    /// blob). The dot is found as a spot of its own inside it; without a dot, the body's
    /// brightest pixel on the line is no spot.
    #[test]
    fn a_dot_on_a_bright_fish_is_found_inside_the_fishs_blob() {
        let truth = Vec2::new(120.4, 104.3);
        let (data, w, h) = fish_across_the_line(Some((truth, 90.0)));
        let c = along_line_at_x_120(&data, w, h);
        let dot = c.iter().find(|c| (c.pixel - truth).norm() < 0.6);
        let dot = dot.unwrap_or_else(|| panic!("no candidate within 0.6 px of the dot: {c:?}"));
        assert!(dot.split_from_blob, "split from the fish's blob: {dot:?}");
        assert!(dot.radius_px < 6.0, "the dot's own size, not the fish's: {dot:?}");
        let (data, w, h) = fish_across_the_line(None);
        let c = along_line_at_x_120(&data, w, h);
        assert!(c.iter().all(|c| !c.split_from_blob), "{c:?}");
    }

    /// A dot of 150 levels 8 px from the edge of a yellow-green fin 32 px in radius, their
    /// blobs apart: the fin's centring disc reaches the dot, and against a background model
    /// fitted across fin and water (green following red) the fin fades and the dot stands
    /// out. The fin is not centred on the dot (tuning target-less 1000119/14, where a green
    /// fish's body centred there stood in for the dot with its own size and SNR, and was
    /// refused as too large); the dot is a candidate of its own size.
    #[test]
    fn a_wide_blob_is_not_centred_on_a_dot_beside_it() {
        let (w, h) = (240usize, 200usize);
        let (truth, fin) = (Vec2::new(120.4, 100.3), Vec2::new(160.4, 100.3));
        let data = paint(w, h, |x, y| {
            let lit = 60.0 * ((32.0 - (x as f64 - fin.x).hypot(y as f64 - fin.y)) / 1.5).clamp(0.0, 1.0);
            let d = spot(x, y, truth, 150.0, 2.5);
            let noise = grain(x, y);
            [20.0 + 0.5 * lit + 0.1 * d + noise, 80.0 + lit + d + noise, 110.0 + 0.15 * lit + 0.5 * d + noise]
        });
        let c = along_line_at_x_120(&data, w, h);
        let at_dot: Vec<&DotCandidate> = c.iter().filter(|c| (c.pixel - truth).norm() < 2.0).collect();
        assert!(!at_dot.is_empty(), "no candidate at the dot: {c:?}");
        assert!(at_dot.iter().all(|c| c.radius_px < 6.0), "the fin's blob centred on the dot: {at_dot:?}");
    }

    /// A dot of 60 levels on a fish whose body stands 40 levels over the water, and 16 px
    /// from it on the line a clipped speck (a bubble's glint): the speck is the blob's
    /// brightest part but makes no spot; the dot, standing above the body around it, does
    /// (tuning target-less 1000127/13).
    #[test]
    fn a_dot_beside_a_clipped_speck_on_a_bright_fish_is_found_inside_the_fishs_blob() {
        let (truth, speck) = (Vec2::new(120.4, 104.3), Vec2::new(120.6, 88.2));
        let (w, h) = (240usize, 200usize);
        let data = paint(w, h, |x, y| {
            let (u, v) = ((x as f64 - 70.0) / 70.0, (y as f64 - 100.0) / 16.0);
            let body = (1.0 - (u * u + v * v).sqrt()).clamp(-0.04, 0.04) / 0.08 + 0.5;
            let d = spot(x, y, truth, 60.0, 2.5);
            let glint = spot(x, y, speck, 600.0, 1.2);
            let noise = grain(x, y);
            [
                20.0 + 10.0 * body + 0.1 * d + glint + noise,
                80.0 + 50.0 * body + d + glint + noise,
                110.0 + 12.0 * body + 0.5 * d + glint + noise,
            ]
        });
        let c = along_line_at_x_120(&data, w, h);
        let dot = c.iter().find(|c| (c.pixel - truth).norm() < 0.6);
        let dot = dot.unwrap_or_else(|| panic!("no candidate within 0.6 px of the dot: {c:?}"));
        assert!(dot.split_from_blob && dot.radius_px < 6.0, "the dot's own spot: {dot:?}");
    }

    /// A dot of 90 levels in the middle of a yellow-green fin 20 px in radius, lit above the
    /// blue water along the laser's colour: fin and dot flood into one blob centred on the
    /// dot, whose size (and the ring its colour is read against) are the fin's (fresh target-less
    /// 1000091/16: a dot on a green fin read 86 degrees off its unit's colour over the fin's
    /// 2 400 px and was refused). The dot's own spot stands in for the blob, and keeps the
    /// blob it was found in.
    #[test]
    fn a_dot_in_the_middle_of_a_fin_is_measured_on_its_own_spot() {
        let (w, h) = (240usize, 200usize);
        let truth = Vec2::new(120.4, 100.3);
        let paint_fin = || {
            paint(w, h, |x, y| {
                let r = (x as f64 - truth.x).hypot(y as f64 - truth.y);
                let fin = ((20.0 - r) / 2.0).clamp(0.0, 1.0);
                let d = spot(x, y, truth, 90.0, 2.5);
                let noise = grain(x, y);
                [20.0 + 30.0 * fin + 0.33 * d + noise, 80.0 + 45.0 * fin + d + noise, 110.0 + 0.33 * d + noise]
            })
        };
        let c = along_line_at_x_120(&paint_fin(), w, h);
        let dot = c.iter().find(|c| (c.pixel - truth).norm() < 0.6);
        let dot = dot.unwrap_or_else(|| panic!("no candidate within 0.6 px of the dot: {c:?}"));
        let fin = dot.enclosed_by.as_deref().unwrap_or_else(|| panic!("found in the fin's blob: {dot:?}"));
        assert!(!dot.split_from_blob && fin.radius_px > 15.0, "{dot:?}");
        assert!(dot.radius_px < 6.0, "the dot's own size, not the fin's: {dot:?}");
        assert!(dot.colour_angle_rad < 0.1, "the laser's colour: {dot:?}");
    }

    /// A dot of 90 levels in the middle of an algae tuft 20 px in radius, under a unit's
    /// learned colour (green with blue): tuft and dot flood into one blob centred on the dot,
    /// its colour the tuft's pigment (green up, red and blue down), and the dot's spot stands
    /// in for it. Judged by the tuft's size as well, such dots were refused as too large
    /// (target-less 1000208/08, 1000163/19); the spot, of the laser's colour where the tuft is
    /// not, is a light of its own. A tuft whose middle is brighter pigment and no dot keeps
    /// its size.
    #[test]
    fn a_dot_on_an_algae_tuft_is_not_judged_by_the_tufts_size() {
        let (w, h) = (240usize, 200usize);
        let truth = Vec2::new(120.4, 100.3);
        let colour = green_laser_with_blue();
        let params = DotDetectorParams { colour, ..DotDetectorParams::default() };
        let tuft = |dot: f64, middle: f64| {
            paint(w, h, |x, y| {
                let r = (x as f64 - truth.x).hypot(y as f64 - truth.y);
                let pigment = ((20.0 - r) / 2.0).clamp(0.0, 1.0) + spot(x, y, truth, middle, 2.5);
                let (d, noise) = (spot(x, y, truth, dot, 2.5), grain(x, y));
                [
                    40.0 - 15.0 * pigment + 0.35 * d + noise,
                    70.0 + 60.0 * pigment + d + noise,
                    90.0 - 30.0 * pigment + 0.41 * d + noise,
                ]
            })
        };
        let c = along_vertical_line(&tuft(90.0, 0.0), (w, h), (120.4, 20.0), (80.0, 160.0), &params, 16);
        let dot = c.iter().find(|c| (c.pixel - truth).norm() < 0.6);
        let dot = dot.unwrap_or_else(|| panic!("no candidate within 0.6 px of the dot: {c:?}"));
        assert!(dot.radius_px < 6.0 && dot.colour_angle_rad < 0.1, "the dot's own spot: {dot:?}");
        assert!(dot.enclosed_by.is_none(), "not the tuft's middle: {dot:?}");
        let c = along_vertical_line(&tuft(0.0, 1.5), (w, h), (120.4, 20.0), (80.0, 160.0), &params, 16);
        let middle = c.iter().filter(|c| (c.pixel - truth).norm() < 3.0).collect::<Vec<_>>();
        assert!(!middle.is_empty() && middle.iter().all(|c| c.radius_px > 15.0 || c.enclosed_by.is_some()), "{c:?}");
    }

    /// A near dot whose green clips, on a yellow-green algae tuft 20 px in radius: tuft and
    /// dot make one blob of some 250 px, below the size searched for spots inside, whose
    /// colour is the tuft's pigment (2 000 sigmas off the laser's), so the blob is refused
    /// whole (tuning target-less 3007/04). Its clipped core is a spot of its own, read
    /// against the tuft around it; the tuft alone, or with an unclipped bright middle,
    /// gives no candidate. (A smaller tuft leaves the spot's ring on the water, and the
    /// spot is refused for the tuft's colour in turn.)
    #[test]
    fn a_clipped_dot_on_a_small_tuft_is_found_inside_the_refused_blob() {
        let (w, h) = (240usize, 200usize);
        let truth = Vec2::new(120.4, 100.3);
        let params = DotDetectorParams { colour: green_laser_with_blue(), ..DotDetectorParams::default() };
        let tuft = |dot: f64, middle: f64| {
            paint(w, h, |x, y| {
                let r = (x as f64 - truth.x).hypot(y as f64 - truth.y);
                let pigment = ((20.0 - r) / 2.0).clamp(0.0, 1.0);
                let (d, m, noise) = (spot(x, y, truth, dot, 3.5), spot(x, y, truth, middle, 3.5), grain(x, y));
                [
                    40.0 + 50.0 * pigment + 0.9 * m + 0.35 * d + noise,
                    70.0 + 60.0 * pigment + m + d + noise,
                    90.0 - 40.0 * pigment + 0.1 * m + 0.41 * d + noise,
                ]
            })
        };
        let search = |data: &[u8]| along_vertical_line(data, (w, h), (120.4, 20.0), (80.0, 160.0), &params, 16);
        let c = search(&tuft(400.0, 0.0));
        let dot = c.iter().find(|c| (c.pixel - truth).norm() < 1.0);
        let dot = dot.unwrap_or_else(|| panic!("no candidate within 1 px of the dot: {c:?}"));
        assert!(dot.split_from_blob && dot.saturated_core, "the dot's clipped spot: {dot:?}");
        for middle in [0.0, 60.0] {
            let c = search(&tuft(0.0, middle));
            assert!(c.iter().all(|c| (c.pixel - truth).norm() > 20.0), "middle {middle}: {c:?}");
        }
    }

    /// A board in green water, where the squares' contrast lies along a green laser's
    /// colour: against a window's mean over black and white squares the map's noise hides
    /// the dot; against its own square's level it stands out.
    #[test]
    fn a_dot_on_a_board_in_green_water_is_found_against_its_square() {
        let (w, h, side) = (400usize, 300usize, 40usize);
        let truth = Vec2::new(171.3, 128.6);
        let data = paint(w, h, |x, y| {
            let [r, g, b] = if on_white(x, y, side) { [82.0, 141.0, 27.0] } else { [48.0, 70.0, 18.0] };
            let (dot, noise) = (spot(x, y, truth, 70.0, 3.0), grain(x, y));
            [r + 0.19 * dot + noise, g + dot + noise, b + 0.42 * dot + noise]
        });
        let squares = board_9x6(side);
        assert_eq!(squares.len(), 10 * 7);
        assert_eq!(squares[0][0], Vec2::new(0.0, 0.0), "the border squares are extrapolated");
        let region = over_board_9x6(side, squares);
        let c = find_dot_candidates(&view(&data, w, h), &region, &DotDetectorParams::default(), 8);
        let dot = c.iter().find(|c| (c.pixel - truth).norm() < 0.5);
        assert!(dot.is_some(), "{c:?}");
        assert_eq!(c.len(), 1, "no square edge or corner is a candidate: {c:?}");
    }

    /// A far board (30 px squares) whose squares' edges are blurred over about 5 px: the blur
    /// is no noise, and a faint dot in a square's middle stands out against the noise of the
    /// squares' middles. Counted in the noise, the edges set the threshold over the dot.
    #[test]
    fn a_faint_dot_on_a_far_board_is_judged_against_the_squares_noise_not_their_edges() {
        let (w, h, side) = (300usize, 210usize, 30usize);
        let truth = Vec2::new(136.4, 104.7);
        let k = side as f64 / (2.5 * std::f64::consts::PI);
        let data = paint(w, h, |x, y| {
            let across = |v: usize| (k * (std::f64::consts::PI * v as f64 / side as f64).sin()).tanh();
            let white = 0.5 + 0.5 * across(x) * across(y);
            let [r, g, b] = [40.0 + 100.0 * white, 60.0 + 150.0 * white, 20.0 + 40.0 * white];
            let (dot, noise) = (spot(x, y, truth, 20.0, 2.2), 1.5 * grain(x, y));
            [r + 0.19 * dot + noise, g + dot + noise, b + 0.42 * dot + noise]
        });
        let region = over_board_9x6(side, board_9x6(side));
        let c = find_dot_candidates(&view(&data, w, h), &region, &DotDetectorParams::default(), 8);
        assert!(c.iter().any(|c| (c.pixel - truth).norm() < 0.5), "{c:?}");
        assert_eq!(c.len(), 1, "no square edge or corner is a candidate: {c:?}");
    }

    /// A near dot on a white square whose green and blue clip under the lamp (a region of
    /// 40 000 px, twice the largest dot): the dot shows only in red, its core clips all
    /// three. Counted as a dot's core, the clipped square merged with the dot into one blob
    /// too large for a dot; as the background's clipping, the dot is found, and the square
    /// alone gives no candidate.
    #[test]
    fn a_dot_on_a_square_whose_green_clips_is_found() {
        let (w, h) = (400usize, 300usize);
        let truth = Vec2::new(201.4, 148.3);
        let render = |with_dot: bool| {
            paint(w, h, |x, y| {
                let square = (100..300).contains(&x) && (50..250).contains(&y);
                let dot = if with_dot { spot(x, y, truth, 180.0, 5.0) } else { 0.0 };
                let noise = grain(x, y);
                let [r, g, b] = if square { [150.0, 255.0, 255.0] } else { [40.0, 120.0, 110.0] };
                [r + dot + noise, g + dot + noise, b + 0.4 * dot + noise]
            })
        };
        let p = DotDetectorParams::default();
        let data = render(true);
        let c = find_dot_candidates(&view(&data, w, h), &SearchRegion::default(), &p, 8);
        let dot = c.iter().find(|c| (c.pixel - truth).norm() < 1.0);
        assert!(dot.is_some_and(|d| d.saturated_core), "no candidate at the dot: {c:?}");
        let data = render(false);
        let c = find_dot_candidates(&view(&data, w, h), &SearchRegion::default(), &p, 8);
        assert!(c.is_empty(), "the clipped square alone gave candidates: {c:?}");
    }

    /// A cyan square in clear water clips green and blue all round a dot, which shows only in
    /// red (tuning calibration seed 21: 88 -> 233 levels in red). The map's weights count red
    /// against a green laser, so the first look sees nothing there; the second look, around
    /// where the fit expects the dot, reads the square's unclipped red along the laser's
    /// colour and finds it, and finds nothing on the square without a dot.
    #[test]
    fn the_second_look_sees_a_dot_in_the_one_channel_its_square_leaves_unclipped() {
        use crate::dot::near_prediction::find_near;
        use crate::dot::on_target::Surface;
        let (w, h) = (200usize, 150usize);
        let truth = Vec2::new(100.3, 74.6);
        let render = |with_dot: bool| {
            paint(w, h, |x, y| {
                let dot = if with_dot { spot(x, y, truth, 1200.0, 4.0) } else { 0.0 };
                let noise = grain(x, y);
                [88.0 + 0.12 * dot + noise, 262.0 + dot + noise, 258.0 + 0.5 * dot + noise]
            })
        };
        let unit = crate::dot::colour::linear_unit_colour([0.108, 0.893, 0.438], 0.06, 8);
        let p = DotDetectorParams {
            colour: LaserColourModel::from_unit(&unit).expect("a green laser"),
            ..Default::default()
        };
        let data = render(true);
        let first = find_dot_candidates(&view(&data, w, h), &SearchRegion::default(), &p, 8);
        assert!(first.iter().all(|c| (c.pixel - truth).norm() > 5.0), "the first look saw it: {first:?}");
        let look =
            |data: &[u8]| find_near(Surface::Checkerboard, &view(data, w, h), Vec2::zeros(), truth, 16.0, &[], &p);
        let dot = look(&data).expect("the second look finds the dot");
        assert!((dot.pixel - truth).norm() < 1.0, "{:?}", dot.pixel);
        assert!(look(&render(false)).is_none(), "a clipped square alone is no dot");
    }

    /// The same light square on a board, the dot 8 px from its edge: the second look's disc
    /// takes in the dark square beside it. Seen through its red, the clipped square sits at a
    /// level of its own; against the disc's mean over both squares it floods as one blob
    /// with no background left to read its colour against, and the dot is lost. Against each
    /// square's own level the dot is found.
    #[test]
    fn the_second_look_on_a_board_reads_a_clipped_square_against_its_own_level() {
        use crate::dot::near_prediction::find_near;
        use crate::dot::on_target::Surface;
        let (w, h, side) = (400usize, 300usize, 40usize);
        // On the white square spanning x 80-120, y 80-120, 8 px from its left edge.
        let truth = Vec2::new(88.3, 101.6);
        assert!(on_white(88, 101, side) && !on_white(79, 101, side));
        let data = paint(w, h, |x, y| {
            let dot = spot(x, y, truth, 60.0, 2.5);
            let noise = grain(x, y);
            if on_white(x, y, side) {
                [36.0 + 0.45 * dot + noise, 262.0 + dot + noise, 262.0 + 0.2 * dot + noise]
            } else {
                [18.0 + 0.45 * dot + noise, 120.0 + dot + noise, 125.0 + 0.2 * dot + noise]
            }
        });
        let unit = crate::dot::colour::linear_unit_colour([0.49, 0.86, 0.13], 0.06, 8);
        let p = DotDetectorParams {
            colour: LaserColourModel::from_unit(&unit).expect("a green laser"),
            ..Default::default()
        };
        let squares = board_9x6(side);
        let look = |squares: &[[Vec2; 4]]| {
            find_near(Surface::Checkerboard, &view(&data, w, h), Vec2::zeros(), truth, 16.0, squares, &p)
        };
        let dot = look(&squares).expect("against each square's level the dot is found");
        assert!((dot.pixel - truth).norm() < 1.0, "{:?}", dot.pixel);
        // Against the disc's mean the dot floods into one blob with its square; only a spot
        // split from that blob ([`peak_inside`]) finds it there.
        let whole = look(&[]).is_none_or(|c| (c.pixel - truth).norm() > 1.0 || c.split_from_blob);
        assert!(whole, "against the disc's mean the dot's own blob was lost");
    }

    /// A 9 x 6 board of 60 px squares with a near dot on the one white square whose green
    /// clips all over (3 600 px, within the 20 000 px a near dot's core may cover, but no
    /// dot's on a board of this size): the clipped square is the surface's, and the dot is
    /// found at its own centre rather than merged with its square.
    #[test]
    fn a_dot_on_a_board_whose_white_squares_clip_is_not_merged_with_its_square() {
        let (w, h, side) = (600usize, 420usize, 60usize);
        let truth = Vec2::new(273.6, 151.2);
        let data = paint(w, h, |x, y| {
            // The lamp lights the dot's square most: its green alone clips.
            let lit = (x / side, y / side) == (4, 2);
            let [r, g, b] = match (on_white(x, y, side), lit) {
                (true, true) => [110.0, 255.0, 225.0],
                (true, false) => [95.0, 225.0, 200.0],
                _ => [25.0, 55.0, 60.0],
            };
            let (dot, noise) = (spot(x, y, truth, 600.0, 4.0), grain(x, y));
            [r + 0.3 * dot + noise, g + dot + noise, b + 0.3 * dot + noise]
        });
        let squares = board_9x6(side);
        assert_eq!(largest_core_px(20_000, &squares), 900, "a quarter of a 60 px square");
        let region = over_board_9x6(side, squares);
        let c = find_dot_candidates(&view(&data, w, h), &region, &DotDetectorParams::default(), 8);
        let dot = c.iter().find(|c| (c.pixel - truth).norm() < 1.0);
        assert!(dot.is_some_and(|d| d.saturated_core), "no candidate at the dot: {c:?}");
    }

    /// A near dot washed white on a surface whose green clips all over (30 000 px, the
    /// background's clipping, not a core): the dot shows only in red and blue, and its own
    /// core, where all three clip, is the whole blob. Counted at the threshold, that core
    /// ranked below a faint green patch on the unclipped half of the photo, and a cap of one
    /// candidate lost it (tuning calibration seed 9: below eight algae tufts, a cap of
    /// eight). Counted at its fringe's contrast (its red and blue seen along the laser's
    /// colour), it ranks first.
    #[test]
    fn a_washed_white_dot_outranks_a_faint_green_patch() {
        let (w, h) = (300usize, 200usize);
        let truth = Vec2::new(70.3, 100.6);
        let patch = Vec2::new(225.0, 100.0);
        let data = paint(w, h, |x, y| {
            let (dot, green, noise) = (spot(x, y, truth, 900.0, 2.5), spot(x, y, patch, 30.0, 7.0), grain(x, y));
            let [r, g, b] = if x < 150 { [70.0, 255.0, 200.0] } else { [60.0, 180.0, 190.0] };
            [r + 0.3 * dot + 0.2 * green + noise, g + dot + green + noise, b + 0.3 * dot + 0.3 * green + noise]
        });
        let view = view(&data, w, h);
        let all = find_dot_candidates(&view, &SearchRegion::default(), &DotDetectorParams::default(), 8);
        assert!(all.iter().any(|c| (c.pixel - patch).norm() < 2.0), "the patch is a candidate too: {all:?}");
        let best = find_dot_candidates(&view, &SearchRegion::default(), &DotDetectorParams::default(), 1);
        assert!(best.len() == 1 && (best[0].pixel - truth).norm() < 1.0, "{all:?}");
        assert!(best[0].saturated_core);
    }

    #[test]
    fn region_and_band_exclude_the_dot() {
        let truth = Vec2::new(61.3, 80.7);
        let (data, w, h) = synthetic(truth, Vec2::new(150.0, 40.0), false);
        let view = view(&data, w, h);
        let p = DotDetectorParams::default();
        let right_half = SearchRegion {
            polygon: vec![
                Vec2::new(100.0, 0.0),
                Vec2::new(199.0, 0.0),
                Vec2::new(199.0, 149.0),
                Vec2::new(100.0, 149.0),
            ],
            band: None,
            squares: Vec::new(),
            overlapping_pieces: false,
        };
        assert!(find_dot_candidates(&view, &right_half, &p, 4).is_empty());
        let band = SearchRegion {
            band: Some((vec![Vec2::new(0.0, 10.0), Vec2::new(199.0, 10.0)], 20.0)),
            ..Default::default()
        };
        assert!(find_dot_candidates(&view, &band, &p, 4).is_empty());
        let band = SearchRegion {
            band: Some((vec![Vec2::new(0.0, 75.0), Vec2::new(199.0, 85.0)], 20.0)),
            ..Default::default()
        };
        let c = find_dot_candidates(&view, &band, &p, 4);
        assert_eq!(c.len(), 1);
        assert!((c[0].pixel - truth).norm() < 0.15, "{:?}", c[0].pixel);
    }

    /// A region's edge that cuts a blob leaves only part of it to measure: one of several
    /// overlapping pieces leaves it to the piece that sees it whole, a lone region keeps it.
    /// The dot lies 2 px inside the left edge of the piece: measured there it is half a dot
    /// centred off the truth.
    #[test]
    fn a_blob_cut_by_an_overlapping_pieces_edge_is_left_to_another_piece() {
        let truth = Vec2::new(61.3, 80.7);
        let (data, w, h) = synthetic(truth, Vec2::new(150.0, 40.0), false);
        let view = view(&data, w, h);
        let p = DotDetectorParams::default();
        let piece = |x0: f64, overlapping_pieces: bool| SearchRegion {
            polygon: vec![Vec2::new(x0, 0.0), Vec2::new(199.0, 0.0), Vec2::new(199.0, 149.0), Vec2::new(x0, 149.0)],
            band: Some((vec![Vec2::new(0.0, 80.0), Vec2::new(199.0, 80.0)], 20.0)),
            squares: Vec::new(),
            overlapping_pieces,
        };
        let near = |c: &[DotCandidate]| c.iter().any(|c| (c.pixel - truth).norm() < 8.0);
        let lone = find_dot_candidates(&view, &piece(59.0, false), &p, 4);
        assert!(near(&lone), "a lone region measures the part it holds: {lone:?}");
        let cut = find_dot_candidates(&view, &piece(59.0, true), &p, 4);
        assert!(!near(&cut), "{cut:?}");
        let whole = find_dot_candidates(&view, &piece(30.0, true), &p, 4);
        assert!(whole.len() == 1 && (whole[0].pixel - truth).norm() < 0.15, "{whole:?}");
    }
}
