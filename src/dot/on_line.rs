//! Finding the laser dot in a photo with no target in it (a fish, a drift-check photo): a
//! rigid laser's dot can only be on the image of the calibrated laser line, so the search
//! runs along that curve (projected with the camera model, distortion included) over the
//! depths a dot can have, in a band wide enough to still see the dot of a laser that has
//! moved a little (the drift check judges exactly that offset, over many photos).
//!
//! Geometry chooses, not brightness: a candidate is the dot only when its offset from the
//! line's image is explained by the calibration's covariance and its own centring
//! ([`fslcal_core::LaserLine::gate`], the same rule the companion firmware uses) and its size
//! agrees with the distance its place on the line implies. One such candidate clearly ahead
//! of the others is the dot, with a confidence; several are withheld as ambiguous with
//! their pixels listed; none is "no dot".
//!
//! The detector is [`crate::dot::candidates::find_dot_candidates`]; this module only decides where it
//! looks and which candidate it believes.

use crate::dot::candidates::{find_dot_candidates, ColourView, DotCandidate, DotDetectorParams, SearchRegion};
use crate::dot::colour::{beyond_colour_gate, OFF_COLOUR_SIGMAS};
use crate::dot::on_target::detected_sigma_px;
use fslcal_core::{CameraModel, LaserLine, LineGate, Vec2};

/// Depths searched when the caller has nothing better, metres: from the closest a fish is
/// photographed to beyond where the dot is still visible in clear water.
pub const DEFAULT_SEARCH_DEPTHS_M: (f64, f64) = (0.3, 6.0);

/// Default half-width of the band around the laser's image, pixels. A laser knocked by 1
/// degree moves its dot by about `f * 0.017` = 50 px on the TG-6: candidates that far off
/// are collected for the drift check's consensus over photos, never taken as a dot alone.
pub const DEFAULT_BAND_HALF_WIDTH_PX: f64 = 80.0;

/// Half-width of the band of the second, more sensitive search, pixels.
const SENSITIVE_HALF_WIDTH_PX: f64 = 16.0;
/// Half-size of the background window of the second search, pixels: several times a far
/// dot's size, small enough to stay on the patch the dot lies on.
const SENSITIVE_BACKGROUND_PX: usize = 12;

/// Most candidates kept from one piece of the band. A board's white squares between black
/// ones are strong blobs of green excess over their background: with a few kept per piece,
/// a dozen squares crowd a far dot out before the geometry ever sees it.
const PIECE_CANDIDATES: usize = 256;

/// Floor of a detected dot's centring sigma, pixels: the core's, which the companion's live
/// distance uses too.
pub const CENTRING_FLOOR_PX: f64 = fslcal_core::DOT_CENTRING_FLOOR_PX;

/// Largest beam radius at the laser's exit, metres (beams of 1.5-5 mm).
const BEAM_RADIUS_M: f64 = 2.5e-3;
/// Largest half-angle divergence of the beam, radians (0.5-1.5 mrad full angle).
const BEAM_HALF_DIVERGENCE_RAD: f64 = 0.75e-3;
/// Blur, forward scatter and the detector's half-threshold halo around an unclipped dot,
/// pixels at 4000 px wide, and never less than [`HALO_FLOOR_PX`] (JPEG blocks and the
/// detector's grain do not shrink with the photo). A board's light square between dark ones
/// is a larger blob than any unclipped dot at its distance.
const HALO_PX: f64 = 5.0;
const HALO_FLOOR_PX: f64 = 2.5;
/// Blur and motion around an unclipped dot's half-peak core, pixels at 4000 px wide: less
/// than the threshold's [`HALO_PX`], as half the peak lies inside the blur's reach. On the
/// tuning scenes (seeds 0, docs/scene-variety.md) true dots' cores reach 0.74 of this limit
/// and the flat green blobs it must refuse (algae, fins on the line) 1.05-1.2.
const CORE_BLUR_PX: f64 = 2.5;
/// How far blooming may widen a clipped core beyond the widest unclipped dot at its
/// distance: a dot's light falls with distance, so a wide clipped blob that implies a far
/// dot is a sun fleck, a glint or a lamp. Tuning scenes (core radii, before a clipped blob
/// was judged by its white part, [`clipped_radius_px`]): true clipped dots reach 1.4,
/// clipped impostors 1.96-2.4. A dot of 3400 levels at 0.55 m on a white square (tuning
/// calibration seed 24 photo 0) blooms to a white core 1.82 times the widest unclipped dot
/// there, and at 1.75 its photo was left without a dot.
const BLOOM_FACTOR: f64 = 1.85;
/// How far a clipped core ringed by the laser's glow may widen beyond the widest
/// unclipped dot at its distance ([`too_large`]): a dot bright enough to bloom that far
/// lights its surroundings in its own colour at least a dot's width beyond its white core.
/// A dot of 6 100 levels at 0.57 m on a white square (held-out calibration 1000075/00)
/// clipped white over 2.8 times the widest dot, its glow 23 px beyond.
const FLARE_FACTOR: f64 = 3.5;
/// Smallest beam radius at the laser's exit, metres; a dot's blob is at least half the
/// disc this makes at its distance.
const BEAM_MIN_RADIUS_M: f64 = 0.75e-3;
/// Least signal-to-noise of an unclipped dot at 1 m in a 4000 px wide photo (in proportion
/// to the width in others), rising as `1/z` nearer: the dot's
/// light falls with distance (spreading, and attenuation there and back), so a faint speck
/// whose place implies a near dot is texture, not the dot. Far dots are judged by the
/// detector's own floor.
const MIN_SNR_AT_1M: f64 = 20.0;

/// Largest roughness of a dot's half-peak outline ([`DotCandidate::outline_roughness`]): on
/// the tuning target-less scenes (seeds 0-5) the 17 true dots whose outline was measured
/// stayed below it (at most 0.083) and it refused 18 blobs on the line's image, 16 of them
/// algae tufts.
pub const MAX_OUTLINE_ROUGHNESS: f64 = 0.10;

/// Share of a look-alike's weight (a blob on the line refused for its colour or outline)
/// that counts against the chosen candidate's confidence. On the tuning target-less scenes
/// (seeds 0-5, 120 photos), from 0 to 0.12: wrong dots 15 -> 11, phantoms on photos without
/// a dot 6 -> 3, right 46 -> 43; at 0.3 two more right dots were withheld for no fewer wrong,
/// at 0.05 two more wrong.
const LOOKALIKE_SHARE: f64 = 0.12;

/// Sigmas of the learned colour at which a blob's colour is as likely the laser's as an
/// impostor's that slipped through the off-colour gate, for weighing the chosen blob
/// against the look-alikes beside it. The laser's colour falls off as a normal; an
/// impostor's is flat over the gate: on the target-less sets 1000098-129 and 1000138-153
/// (every unclipped blob on the line, against the colour each unit's calibration, fitted by
/// this code, learned), the true dots outnumbered the other blobs 54 to 6 within 0.5 sigmas
/// and 6 to 22 between 2.5 and 3, a ratio falling as `exp(-z^2 / 2)` does. Weighing the
/// look-alikes by the chosen blob's own colour likelihood, as before, took its colour for
/// no evidence against them: a dot 0.2 sigmas off its unit's colour was withheld beside
/// algae 25 degrees short in white (1000143/03). On the six sets 1000098-153 (960 photos,
/// 661 visible dots), from the chosen blob's likelihood to a flat one at 2 sigmas: right
/// 473 -> 481, wrong 20 -> 19 (a laser-off photo's phantom withheld); at 1 and 1.5 sigmas,
/// 475 and 477 right; at 2.5 and 3, 485 with the phantom back (20 wrong).
const LOOKALIKE_COLOUR_SIGMAS: f64 = 2.0;

/// Times the chosen blob's peak at which a blob the line passes through, refused as off the
/// line or too large, may hide the dot and withholds the choice ([`LineCandidate::may_hide`]).
/// On the tuning target-less seeds 3030-3034 and the already reported held-out 1000432-441
/// (300 photos), such blobs beside 16 right dots had 0.2-1.8 times their peak and beside the
/// one wrong dot (tuning 3033/08: a speck of 5 levels chosen, the dot merged with algae into a
/// blob of 73) 14.6; weighed against every right dot regardless of peak they withheld 10.
const HIDING_PEAK_RATIO: f64 = 3.0;

/// Times the off-colour limit ([`OFF_COLOUR_SIGMAS`] sigmas of the
/// unit's spread and the blob's noise) beyond which a blob's chroma makes it no look-alike:
/// a tuft 30-50 degrees off a laser of 4 degrees' spread is another pigment, and one of its
/// kind is no likelier to have slipped through the colour test than anything else. On the
/// tuning target-less seeds 12-17 four visible dots were withheld beside such a tuft (49, 45
/// and 37, 32, 21 degrees off) and none was wrong. At 3 (from counting every look-alike):
/// 2 of them found, nothing else changed on seeds 0-17; at 2: 3 found and one dot
/// centred 3.4 px off taken on seed 5 (a tuft 147 degrees off had withheld it); at 1.5 also
/// a phantom on a laser-off photo.
const UNLIKE_COLOUR_RATIO: f64 = 3.0;

/// Weight of a dot-like blob's signal in the choice between plausible candidates: a
/// candidate's relative likelihood is `exp(-chi2 / 2) * snr^SNR_POWER` times its colour's
/// (`LineCandidate::colour_likelihood`). With the colour's term, 1.5 and 2.5 changed one
/// answer each on the tuning target-less seeds 0-17 (one more right; one more wrong and a
/// phantom).
const SNR_POWER: f64 = 2.0;
/// How much likelier the dot is a blob clipped at its centre than one that is not, in the
/// choice between plausible candidates. A pigment lit by the water's light seldom clips where
/// the surface around it does not; a near or bright dot often does. Of the plausible blobs on
/// the line in the tuning and held-out target-less photos, 310 of 652 true dots clipped at
/// their centre, and 8 of 160 others (3 algae tufts, 3 glints, a bubble, a speck): odds of
/// about 17. At 4, on the tuning seeds 0-17 a wrong dot (15/18, a tuft beside a clipped dot)
/// was withheld instead, and nothing else changed; at 16 a clipped glint was taken for an
/// unclipped dot (7/17). Look-alikes are counted only of the chosen blob's kind, so the
/// factor weighs on both sides of its confidence alike.
const CLIPPED_ODDS: f64 = 4.0;
/// Distance within which an unclipped blob is less likely the dot than one farther off, in
/// proportion to the square of its distance over this one, metres. A dot's light falls
/// with its distance (its footprint's spreading and the water's attenuation there and
/// back), so a near dot mostly clips and an unclipped blob that implies a near dot is more
/// often a pigment lit by the water's light. Of the plausible blobs on the line in the tuning
/// and held-out target-less photos (seeds 0-9, 1000042-73 and 1000090-97), 27 of 106 true
/// dots nearer than 1 m were unclipped and 42 of 45 other blobs; from 1 to 2 m, 74 of 143
/// and 27 of 29: unclipped, a blob there is still about half as likely the dot, which 1 m
/// ignored. On the tuning target-less seeds 3000-3023 (480 photos, 338 visible dots) the
/// wrong dots taken or nearly taken (confidence 0.5-0.9) implied 0.5-1.4 m and the right
/// dots withheld there 2.4-5.2 m. With [`CLEAR_CONFIDENCE_OF_LASER_COLOUR`], from 1 to 1.5
/// m: right 270 -> 268 and wrong dots and phantoms 4 -> 4 on the tuning seeds; on seeds
/// 1000324-347, 274 -> 274 and 6 -> 5 (an algae tuft at 1.0 m withheld).
const UNCLIPPED_NEAR_M: f64 = 1.5;
/// Spread of a dot's outline roughness ([`DotCandidate::outline_roughness`]) in the choice
/// between candidates: a blob is the less likely the dot the rougher its half-peak outline,
/// as a normal of this sigma. The gate ([`MAX_OUTLINE_ROUGHNESS`]) refuses only beyond 0.10;
/// under it, of the plausible unclipped blobs on the line in the tuning and held-out
/// target-less photos whose outline was measured, the 94 true dots' roughness had a median
/// of 0.023 (a half-normal of sigma 0.034), the 45 others' 0.063. Alone it changed 2 of
/// those 800 photos (one more right, one wrong fewer).
const OUTLINE_ROUGHNESS_SIGMA: f64 = 0.035;
/// Signal-to-noise of a lone plausible blob on the line's centre, unclipped, beyond 1 m,
/// smooth and of the unit's colour, in a 4000 px wide photo ([`LineCandidate::photo_scale`]),
/// that is as likely an impostor as the dot: the weight of "none of them is the dot" (the
/// laser off, the dot hidden or too faint, and a look-alike on the line) set against the
/// candidates' in the confidence. Without it a lone blob was the dot with confidence 1
/// whatever it looked like, and a tuft on a laser-off photo was a dot. On the tuning and
/// held-out target-less photos (seeds 0-9, 1000042-73 and 1000090-97; 527 visible dots in
/// 800 photos), before the outline and near terms: right 406, wrong dots (on visible or
/// faint dots, or on photos without one) 46; at 3, 395 and 36; at 5, 384 and 26; at 8, 371
/// and 23. Each wrong dot is a fish measured wrong with
/// confidence, each withheld one a photo to measure by hand: 5 is where the wrong ones
/// stop falling about as fast as the right ones.
const NO_DOT_SNR: f64 = 5.0;
/// A candidate is the dot when it carries at least this share of the plausible candidates'
/// weight and that of none being the dot ([`NO_DOT_SNR`]); below it the photo is ambiguous
/// and withheld.
pub const CLEAR_CONFIDENCE: f64 = 0.9;
/// The share that makes a candidate the dot when its colour lies within
/// [`LOOKALIKE_COLOUR_SIGMAS`] of the unit's learned laser colour, where its colour is
/// likelier the laser's than an impostor's: its colour is evidence the weights count only
/// as a likelihood, not as the rarity of impostors of that colour. Beyond, or under the
/// prior colour, [`CLEAR_CONFIDENCE`] holds. Against 0.9 for every blob (and
/// [`UNCLIPPED_NEAR_M`] at 1 m), on the tuning target-less seeds 3000-3023 (480 photos, 338
/// visible dots): right 259 -> 268, wrong dots and phantoms 4 -> 4; 0.8 whatever the colour
/// gave 272 and 4 there, but on seeds 1000324-347 (rendered after, 480 photos, 328 visible)
/// 265 -> 274 right for 4 -> 7 wrong, each new wrong dot an algae tuft 2.0-2.7 sigmas off
/// the laser's colour taken at 0.81-0.85; with this rule 274 and 5 (those seeds were looked
/// at to make it, the figures on fresh ones are in the changelog). At 0.75, 270 and 4 on the
/// tuning seeds and 274 and 6 on those; at 0.85, 262 and 4, and 272 and 4.
pub const CLEAR_CONFIDENCE_OF_LASER_COLOUR: f64 = 0.8;

/// Where and how to search.
#[derive(Clone, Debug)]
pub struct LineSearch {
    /// Depth range of the search along the laser, metres.
    pub depths_m: (f64, f64),
    /// Half-width of the band around the laser's image, pixels.
    pub band_half_width_px: f64,
    pub detector: DotDetectorParams,
    /// Covariance of the laser's [`LaserLine::to_params`], row-major: what explains a dot's
    /// offset from the line besides its centring.
    pub laser_covariance: [[f64; 4]; 4],
}

impl Default for LineSearch {
    fn default() -> Self {
        LineSearch {
            depths_m: DEFAULT_SEARCH_DEPTHS_M,
            band_half_width_px: DEFAULT_BAND_HALF_WIDTH_PX,
            detector: DotDetectorParams::default(),
            laser_covariance: [[0.0; 4]; 4],
        }
    }
}

impl LineSearch {
    /// The default search for a calibration with this laser covariance.
    pub fn with_covariance(laser_covariance: [[f64; 4]; 4]) -> Self {
        LineSearch { laser_covariance, ..LineSearch::default() }
    }
}

/// One dot-like blob in the band and what the calibrated line makes of it.
#[derive(Clone, Debug, PartialEq)]
pub struct LineCandidate {
    pub candidate: DotCandidate,
    /// Offset from the line's image against what is explained, and the implied distance.
    pub gate: LineGate,
    /// Its size and signal fit the distance its place on the line implies; `Some` refusal
    /// when not.
    pub misfit: Option<Refusal>,
    /// Found by the second, more sensitive look.
    pub sensitive: bool,
    /// How far its colour lies from the unit's learned laser colour (its chroma angle and
    /// its white part's deficit,
    /// [`crate::dot::colour::LaserColourModel::colour_sigmas`]) in sigmas of the colour's
    /// spread and the blob's own noise; `None` under the prior.
    pub colour_sigmas: Option<f64>,
    /// The photo's width over 4000 px. A matched filter's SNR grows with a blob's linear
    /// size, so the same scene photographed 1000 px wide gives every blob a quarter of
    /// the SNR: weighed against none of them being the dot ([`NO_DOT_SNR`], set on 4000 px
    /// photos), a blob's signal counts as it would 4000 px wide.
    pub photo_scale: f64,
}

impl LineCandidate {
    /// Could be the dot of the calibrated laser.
    pub fn plausible(&self) -> bool {
        self.gate.explained() && self.misfit.is_none()
    }

    /// Its chroma lies beyond [`UNLIKE_COLOUR_RATIO`] times the off-colour limit: refused or
    /// not for its look, it is no kin of the laser's dot.
    pub fn unlike_colour(&self) -> bool {
        self.colour_sigmas.is_some_and(|z| z > UNLIKE_COLOUR_RATIO * OFF_COLOUR_SIGMAS)
    }

    /// Relative likelihood among the plausible candidates: its place, its signal and
    /// clipping, its colour and its outline.
    fn weight(&self) -> f64 {
        self.look_weight() * self.colour_likelihood() * self.outline_likelihood()
    }

    /// How likely a beam's footprint is to have its outline's roughness (a normal of
    /// [`OUTLINE_ROUGHNESS_SIGMA`]); 1 where the outline was not measured.
    fn outline_likelihood(&self) -> f64 {
        normal_likelihood(
            self.candidate.outline_roughness.map(|r| r.min(MAX_OUTLINE_ROUGHNESS) / OUTLINE_ROUGHNESS_SIGMA),
        )
    }

    /// How likely an impostor that slipped through the colour gate is to have this blob's
    /// colour, on the scale of [`Self::colour_likelihood`]: flat
    /// ([`LOOKALIKE_COLOUR_SIGMAS`]); 1 under the prior, which weighs no colour.
    fn impostor_colour_likelihood(&self) -> f64 {
        normal_likelihood(self.colour_sigmas.map(|_| LOOKALIKE_COLOUR_SIGMAS))
    }

    /// How likely the laser's light is to have its chroma (a normal in the angle's
    /// sigmas); 1 under the prior, which tells no green from another. The off-colour gate
    /// only refuses beyond 3 sigmas; within them a blob nearer the unit's colour is still
    /// likelier the dot: a dot clipped white (its chroma barely measured) lost to an
    /// unclipped tuft 2.8 sigmas off only for the tuft's signal (tuning target-less 6/07).
    fn colour_likelihood(&self) -> f64 {
        normal_likelihood(self.colour_sigmas)
    }

    /// Its place, signal and clipping alone: what a look-alike refused for its colour or
    /// outline is weighed by, since its colour has already told against it.
    fn look_weight(&self) -> f64 {
        (-0.5 * self.gate.chi2).exp() * self.signal_weight()
    }

    /// Its signal and clipping, wherever on the band it lies: the look of a blob as if on
    /// the line's centre.
    fn signal_weight(&self) -> f64 {
        let clipped = if self.candidate.saturated_core {
            CLIPPED_ODDS
        } else {
            (self.gate.depth_m / UNCLIPPED_NEAR_M).min(1.0).powi(2)
        };
        let snr = self.candidate.snr / self.photo_scale;
        snr.max(1.0).powf(SNR_POWER) * clipped
    }

    /// What a look-alike (refused for its colour or outline) counts against the chosen dot:
    /// its look, less as its chroma lies further beyond the off-colour gate. A blob just
    /// beyond the gate may be the dot mis-measured (a clipped fringe, a coloured surface); one
    /// at twice the limit is less likely to be, though no Gaussian tail would give it any
    /// chance: the falloff is the square of the limit over its sigmas. On the tuning
    /// target-less seeds 0-17 it found one withheld dot (13/11) and changed nothing else; at
    /// the fourth power it also took a tuft on a laser-off photo (3/15) and a wrong dot (5/06).
    ///
    /// Its look counts only up to the `chosen` blob's: the doubt is that the chosen blob is
    /// one of the look-alike's kind that slipped through the tests, and such a one would
    /// have the chosen blob's signal, not the look-alike's. Counted whole, a tuft of SNR 176
    /// beside a dot of SNR 27 withheld it, though the dot lay 0.14 sigmas off its unit's
    /// colour and the tuft 5.2 (target-less 1000116/04). On the tuning and looked-at
    /// target-less sets (1100 photos, 782 visible dots) right 630 -> 639, on the sets
    /// 1000224-247 (480 photos, 327 visible) 265 -> 269, wrong unchanged on both. Letting
    /// every look-alike count with the chosen blob's look, however faint, found one fewer:
    /// it withheld a dot of SNR 244 beside two look-alikes a fortieth and a thousandth of
    /// its weight (1000206/16).
    fn lookalike_weight(&self, chosen: &LineCandidate) -> f64 {
        let beyond = self.colour_sigmas.map_or(1.0, |z| (OFF_COLOUR_SIGMAS / z).min(1.0));
        self.look_weight().min(chosen.look_weight()) * beyond * beyond
    }

    /// A blob the line's image passes through (its centre nearer the line than its radius)
    /// refused only as off the line or too large, of a colour the gate lets through: a dot
    /// merged with a tuft or glint beside it measures as one such blob, centred off the dot
    /// and too wide for it, so the dot may lie inside.
    ///
    /// It casts doubt on the `chosen` blob only when of its kind (clipped or not) and at
    /// least [`HIDING_PEAK_RATIO`] times its peak: a speck that faint beside it is likelier
    /// noise than the dot.
    fn may_hide(&self, chosen: &LineCandidate) -> bool {
        let refused_for_place_or_size = !self.gate.explained() || self.misfit == Some(Refusal::TooLarge);
        refused_for_place_or_size
            && self.gate.offset_px.abs() < self.candidate.radius_px
            && !self.colour_sigmas.is_some_and(|z| z > OFF_COLOUR_SIGMAS)
            && self.candidate.saturated_core == chosen.candidate.saturated_core
            && self.candidate.peak_green >= HIDING_PEAK_RATIO * chosen.candidate.peak_green
    }

    /// What a blob that may hide the dot ([`Self::may_hide`]) counts against the
    /// chosen one: a dot inside it would lie on the line, so its look is weighed as if on the
    /// line's centre, and (as a look-alike's) only up to the `chosen` blob's look.
    fn hiding_weight(&self, chosen: &LineCandidate) -> f64 {
        self.signal_weight().min(chosen.look_weight())
    }

    /// Its centre in pixels, as the reports and sentences give it.
    pub fn pixel_px(&self) -> [f64; 2] {
        [self.candidate.pixel.x, self.candidate.pixel.y]
    }

    /// Why it cannot be the dot; `None` when plausible.
    pub fn refusal(&self) -> Option<Refusal> {
        if !self.gate.explained() {
            Some(Refusal::OffLine)
        } else {
            self.misfit
        }
    }
}

/// A normal's likelihood at `z` sigmas, relative to its peak; 1 without a measure.
fn normal_likelihood(z: Option<f64>) -> f64 {
    z.map_or(1.0, |z| (-0.5 * z * z).exp())
}

/// Why a blob in the band cannot be the laser's dot.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Refusal {
    /// Its offset from the line's image is beyond what the covariance and centring explain.
    OffLine,
    /// Larger at half its peak than any dot at the distance its place on the line implies.
    TooLarge,
    /// Smaller than the narrowest beam makes a dot at that distance.
    TooSmall,
    /// Fainter than a dot that near.
    TooFaint,
    /// Its place on the line implies a depth outside the searched range.
    OutOfRange,
    /// Its chroma is further from the unit's learned laser colour than the colour's spread
    /// and the blob's own measurement noise explain: a pigment (algae, a fin, tape), not
    /// the laser's light.
    OffColour,
    /// Its half-peak outline is lobed or ragged beyond [`MAX_OUTLINE_ROUGHNESS`], or its
    /// middle is dim (a bubble's rim): a beam's footprint is an ellipse, brightest at its
    /// centre.
    Ragged,
}

impl Refusal {
    /// Why, in the words a report shows.
    pub fn describe(self) -> &'static str {
        match self {
            Refusal::OffLine => "off the calibrated line",
            Refusal::TooLarge => "too large for its distance",
            Refusal::TooSmall => "too small for its distance",
            Refusal::TooFaint => "too faint for its distance",
            Refusal::OutOfRange => "beyond the searched depths",
            Refusal::OffColour => "not the laser's colour",
            Refusal::Ragged => "ragged outline: no beam's footprint",
        }
    }
}

/// The dot found near the laser's image.
#[derive(Clone, Debug, PartialEq)]
pub struct LineDot {
    /// Sub-pixel centre (pixel-centre convention).
    pub pixel: Vec2,
    /// Matched-filter signal-to-noise of the chosen blob (the detector's score).
    pub snr: f64,
    /// Perpendicular distance from the laser's image, pixels.
    pub offset_px: f64,
    /// The chosen candidate as the detector returned it.
    pub candidate: DotCandidate,
    /// The line's gate of the chosen candidate.
    pub gate: LineGate,
    /// Share of the plausible candidates' likelihood the chosen one carries (0-1).
    pub confidence: f64,
    /// Other dot-like blobs in the band, plausible or not.
    pub rivals: usize,
}

#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum DotOnLineError {
    #[error("the calibrated laser's image does not cross this {width}x{height} photo between {near_m} and {far_m} m (wrong calibration for this camera?)")]
    LineOutsideImage { width: usize, height: usize, near_m: f64, far_m: f64 },
    #[error("{}{}; give the dot by hand", ambiguity(candidates_px, *lookalikes), hiding_words(hiding_px))]
    Ambiguous {
        candidates_px: Vec<[f64; 2]>,
        /// Blobs on the line refused only for their colour or outline, which made the
        /// plausible ones doubtful.
        lookalikes: usize,
        /// Centres of brighter blobs the line passes through, refused as off it or too
        /// large, that may hide the dot ([`LineCandidate::may_hide`]).
        hiding_px: Vec<[f64; 2]>,
    },
    #[error("no laser dot on the calibrated laser's image (laser off, dot off the subject, or the laser has moved: `fslcal check` on several photos tells){}", refused_words(refused))]
    NoDot {
        half_width_px: f64,
        /// Blobs on the line (within what the calibration explains) refused for their look,
        /// size or distance: one may be the dot, for the user to give by hand.
        refused: Vec<RefusedOnLine>,
    },
}

/// A blob on the calibrated line that was refused, and why.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RefusedOnLine {
    pub pixel_px: [f64; 2],
    pub why: Refusal,
}

/// Blobs named in a no-dot sentence at most; the report lists them all.
const REFUSED_NAMED: usize = 3;

/// The blobs on the line refused, in words for a no-dot sentence ("" when none).
fn refused_words(refused: &[RefusedOnLine]) -> String {
    let named: Vec<String> = refused
        .iter()
        .take(REFUSED_NAMED)
        .map(|r| format!("{}, {}", pixel_words(r.pixel_px), r.why.describe()))
        .collect();
    let more = refused.len().saturating_sub(REFUSED_NAMED);
    match (refused.len(), more) {
        (0, _) => String::new(),
        (1, _) => format!("; refused on it: a blob at {} (give the dot by hand if it is the dot)", named[0]),
        (n, 0) => {
            format!("; refused on it: {n} blobs, at {} (give the dot by hand if one is the dot)", named.join("; "))
        }
        (n, m) => format!(
            "; refused on it: {n} blobs, at {} and {m} more (give the dot by hand if one is the dot)",
            named.join("; ")
        ),
    }
}

/// A pixel in a sentence, to the whole pixel: "(1234, 567)".
pub fn pixel_words(p: [f64; 2]) -> String {
    format!("({:.0}, {:.0})", p[0], p[1])
}

pub fn pixel_list(px: &[[f64; 2]]) -> String {
    px.iter().map(|&p| pixel_words(p)).collect::<Vec<_>>().join(", ")
}

/// The brighter blobs that may hide the dot, in words for an ambiguity ("" when none).
fn hiding_words(hiding_px: &[[f64; 2]]) -> String {
    match hiding_px {
        [] => String::new(),
        [one] => {
            format!(" (the line runs through a brighter blob at {}, which may hide the dot)", pixel_words(*one))
        }
        many => format!(" (the line runs through brighter blobs at {}, which may hide the dot)", pixel_list(many)),
    }
}

/// Why a photo's plausible blobs left no clear dot, in words.
fn ambiguity(candidates_px: &[[f64; 2]], lookalikes: usize) -> String {
    let beside = match lookalikes {
        0 => String::new(),
        1 => " beside a blob like it refused for its colour or outline".into(),
        n => format!(" beside {n} blobs like it refused for their colour or outline"),
    };
    match candidates_px {
        [one] => {
            format!(
                "a dot-like blob on the calibrated laser's image at {}{beside}, not clearly the dot",
                pixel_words(*one)
            )
        }
        many => format!(
            "{} dot-like blobs on the calibrated laser's image and none clearly the dot, at {}{beside}",
            many.len(),
            pixel_list(many)
        ),
    }
}

/// The laser's image as a polyline over `depths_m`, the points inside the image only.
pub fn laser_image_polyline(camera: &CameraModel, laser: &LaserLine, depths_m: (f64, f64)) -> Vec<Vec2> {
    // Log-spaced: near depths move the dot fast, far depths crowd toward the vanishing point.
    let n = 96;
    let (a, b) = (depths_m.0.ln(), depths_m.1.ln());
    (0..=n)
        .filter_map(|i| laser.pixel_at_depth(camera, (a + (b - a) * i as f64 / n as f64).exp()))
        .filter(|p| camera.contains(*p))
        .collect()
}

/// Finds the laser dot in `img` (the full-resolution photo the `camera` describes) along the
/// image of `laser`: [`line_candidates`], then [`choose`].
pub fn find_dot_on_laser_line(
    img: &ColourView,
    camera: &CameraModel,
    laser: &LaserLine,
    search: &LineSearch,
) -> Result<LineDot, DotOnLineError> {
    let candidates = line_candidates(img, camera, laser, search)?;
    choose(&candidates, search.band_half_width_px)
}

/// Every dot-like blob in the band around the laser's image, each with its gate, strongest
/// first. A second, more sensitive look close to the line runs when the first finds nothing
/// plausible: far dots in murky water are faint, and a blob the first look refused may be
/// a dot measured against too wide a background ([`take_second_measure`]).
pub fn line_candidates(
    img: &ColourView,
    camera: &CameraModel,
    laser: &LaserLine,
    search: &LineSearch,
) -> Result<Vec<LineCandidate>, DotOnLineError> {
    let line = laser_image_polyline(camera, laser, search.depths_m);
    if line.len() < 2 {
        return Err(DotOnLineError::LineOutsideImage {
            width: img.width,
            height: img.height,
            near_m: search.depths_m.0,
            far_m: search.depths_m.1,
        });
    }
    let hw = search.band_half_width_px;
    let pad = hw + search.detector.background_radius_px as f64;
    let pieces = band_pieces(&line, (4.0 * hw).max(200.0));
    let judge = |c: DotCandidate, sensitive: bool| judge_candidate(camera, laser, search, c, sensitive);
    let mut found: Vec<LineCandidate> = search_pieces(img, &line, &pieces, hw, pad, &search.detector)
        .into_iter()
        .filter_map(|c| judge(c, false))
        .collect();
    if !found.iter().any(LineCandidate::plausible) {
        // In small pieces with a small background window, so the noise is measured where
        // the dot is: over a board's squares or a reef's texture a band-wide noise estimate
        // buries a far dot on a dark patch.
        let near = hw.min(SENSITIVE_HALF_WIDTH_PX);
        let detector =
            DotDetectorParams { background_radius_px: SENSITIVE_BACKGROUND_PX, ..search.detector.sensitive() };
        let small = band_pieces(&line, 2.0 * near);
        for c in search_pieces(img, &line, &small, near, near + SENSITIVE_BACKGROUND_PX as f64, &detector) {
            let same = |f: &LineCandidate| (f.candidate.pixel - c.pixel).norm() < 2.0 * c.radius_px.max(2.0);
            // A spot split from a larger blob is that blob's part: the whole one found in
            // the second look is the better measure of it.
            found.retain(|f| !(f.candidate.split_from_blob && !f.plausible() && same(f)));
            match found.iter().position(same) {
                None => found.extend(judge(c, true)),
                Some(k) => {
                    if let Some(again) = judge(c, true) {
                        take_second_measure(&mut found[k], again);
                    }
                }
            }
        }
    }
    found.sort_by(|a, b| b.candidate.snr.total_cmp(&a.candidate.snr));
    Ok(found)
}

/// Largest share of the first look's radius at which the second look's measure of a blob
/// the first refused as too large replaces it. A dot in its own glow on a bright fish
/// (target-less 1000164/15: 34 px against the first look's 40 px background, 7 px
/// against the second's 12 px) or its halo over dark water (1000181/14: 12 -> 7.6 px) shrinks
/// to its core; a lit surface stays nearly as large (a laser-off photo's 21 px blob read
/// 17.5 px, tuning 1000157/05; an occluded dot's 13 px blob 10 px, 1000104/13), and was
/// taken for the dot when any plausible second measure replaced the first.
const REMEASURED_TOO_LARGE_SHARE: f64 = 2.0 / 3.0;

/// Keeps the second look's measure of a blob the first look measured as `first`, when the
/// first was refused and the second is plausible. The second look's 12 px background is the
/// dot's own surroundings, where the first's 40 px took in a fish's sheen or the water beside
/// it: on 38 tuning target-less sets, 9 dots first refused as too large (3), ragged (3),
/// off-colour (2) or off the line (1) were found, and no other answer changed. A blob
/// refused as too large is a surface unless the second look sees it much smaller
/// ([`REMEASURED_TOO_LARGE_SHARE`]).
fn take_second_measure(first: &mut LineCandidate, again: LineCandidate) {
    let shrunk = again.candidate.radius_px < REMEASURED_TOO_LARGE_SHARE * first.candidate.radius_px;
    if !first.plausible() && again.plausible() && (first.refusal() != Some(Refusal::TooLarge) || shrunk) {
        *first = again;
    }
}

/// The line split into pieces about `piece_px` long, each running near to far, nearest
/// first: the detector's region of interest is the bounding box of its polygon, and a
/// diagonal line's box is mostly empty. The cuts are measured from the far end, where every
/// search's line ends: a search reaching nearer adds pieces at the near end and moves no
/// cut, and a blob near a cut (measured against its piece's background and noise) is
/// measured alike. A near remainder shorter than half a piece joins the piece beside it: its
/// own box, padded all round, cost nearly as much as a whole piece's.
fn band_pieces(line: &[Vec2], piece_px: f64) -> Vec<Vec<Vec2>> {
    let Some(&far) = line.last() else { return Vec::new() };
    // Walked from the far end; reversed at the end.
    let mut pieces: Vec<Vec<Vec2>> = vec![vec![far]];
    let mut run = 0.0;
    for w in line.windows(2).rev() {
        let (mut from, to) = (w[1], w[0]);
        while run + (to - from).norm() > piece_px {
            let cut = from + (to - from).normalize() * (piece_px - run);
            pieces.last_mut().expect("starts with one piece").push(cut);
            pieces.push(vec![cut]);
            (from, run) = (cut, 0.0);
        }
        run += (to - from).norm();
        pieces.last_mut().expect("starts with one piece").push(to);
    }
    if pieces.len() > 1 && run < 0.5 * piece_px {
        let rest = pieces.pop().expect("more than one piece");
        pieces.last_mut().expect("more than one piece").extend_from_slice(&rest[1..]);
    }
    pieces.reverse();
    pieces.iter_mut().for_each(|p| p.reverse());
    pieces
}

/// A candidate's gate against `laser` and size test; `None` when its pixel gives no distance
/// on the line. The drift check judges the same blobs again against a turned laser.
pub fn judge_candidate(
    camera: &CameraModel,
    laser: &LaserLine,
    search: &LineSearch,
    candidate: DotCandidate,
    sensitive: bool,
) -> Option<LineCandidate> {
    let centring = detected_sigma_px(&candidate).max(CENTRING_FLOOR_PX);
    let gate = laser.gate(camera, &search.laser_covariance, candidate.pixel, centring)?;
    // The band reaches past the line's ends: a blob there implies a depth outside the search.
    let (near, far) = search.depths_m;
    let near = if candidate.saturated_core { near.min(CLIPPED_NEAR_M) } else { near };
    let colour_sigmas = candidate.colour_sigmas(&search.detector.colour);
    let off_colour = beyond_colour_gate(colour_sigmas);
    let misfit = if gate.depth_m < near || gate.depth_m > far {
        Some(Refusal::OutOfRange)
    } else {
        misfit(camera, &candidate, gate.depth_m).or_else(|| off_colour.then_some(Refusal::OffColour))
    };
    Some(LineCandidate { candidate, gate, misfit, sensitive, colour_sigmas, photo_scale: photo_scale(camera) })
}

/// Nearest depth a blob clipped at its centre is taken at, metres, however far the
/// calibration's own near end: 10% inside the 0.5 m the diver's manual works from. A dot
/// nearer than the calibration's nearest photo is still the laser's, and a blob clipped at
/// its centre that fits a near dot's size is rare in scenery; a calibration whose nearest
/// photo was at 0.65 m refused dots at 0.50-0.52 m on fish (tuning seeds 0 and 4), while the
/// algae the wider search took when it admitted every blob there (7 -> 10 wrong dots) are
/// not clipped at their centres.
const CLIPPED_NEAR_M: f64 = 0.45;

/// The photo's width over the 4000 px at which this module's pixel sizes and signal-to-noise
/// figures were measured. A matched filter's SNR grows with a blob's linear size at a given
/// level, as blur and halo widths in pixels do.
fn photo_scale(camera: &CameraModel) -> f64 {
    camera.width_px as f64 / 4000.0
}

/// Why a blob's size or signal cannot be a dot's at depth `z_m`; `None` when they can. A
/// clipped core is bright enough for any distance; it blooms, but only so far
/// ([`BLOOM_FACTOR`]).
pub(crate) fn misfit(camera: &CameraModel, c: &DotCandidate, z_m: f64) -> Option<Refusal> {
    let smallest = 0.5 * camera.fx_px * BEAM_MIN_RADIUS_M / z_m.max(0.05);
    if c.radius_px < smallest {
        Some(Refusal::TooSmall)
    } else if too_large(camera, c, z_m) {
        Some(Refusal::TooLarge)
    } else if c.snr < MIN_SNR_AT_1M * photo_scale(camera) / z_m.max(0.05) {
        Some(Refusal::TooFaint)
    } else if c.outline_roughness.is_some_and(|r| r > MAX_OUTLINE_ROUGHNESS) {
        Some(Refusal::Ragged)
    } else {
        None
    }
}

/// Whether a blob's core is larger than a laser dot's can be at depth `z_m`: an unclipped
/// core wider than the widest beam there (plus blur), or a clipped one blooming past
/// [`BLOOM_FACTOR`] times the largest unclipped dot. A sun fleck or a lamp's glint is large
/// wherever it lies; a dot is small at its own distance. A spot standing in for the blob it
/// was found in ([`DotCandidate::enclosed_by`]) is too large when that blob is.
pub fn too_large(camera: &CameraModel, c: &DotCandidate, z_m: f64) -> bool {
    if c.enclosed_by.as_deref().is_some_and(|e| too_large(camera, e, z_m)) {
        true
    } else if c.saturated_core {
        let (clipped, largest) = (clipped_radius_px(c), largest_radius_px(camera, z_m));
        let glowing = (c.lit_clipped_px as f64 / core::f64::consts::PI).sqrt() - clipped >= largest;
        clipped > if glowing { FLARE_FACTOR } else { BLOOM_FACTOR } * largest
    } else {
        c.core_radius_px > largest_core_radius_px(camera, z_m)
    }
}

/// The size a clipped core is judged by, pixels: its white part's equivalent radius (where
/// all three channels clip) when it has one, else its core's. A near dot's glow clips the
/// laser's own channel 36-45 px out on a bright square (tuning calibration seeds 17, 22
/// and 23, dots of 700-2 300 levels at 0.6-0.9 m, refused as too large), while only its
/// centre is white; a glint or a sun fleck is white throughout.
fn clipped_radius_px(c: &DotCandidate) -> f64 {
    if c.white_px > 0 {
        (c.white_px as f64 / core::f64::consts::PI).sqrt()
    } else {
        c.core_radius_px
    }
}

/// Largest equivalent radius of an unclipped dot at depth `z_m`, pixels: the widest beam
/// spread by the largest divergence, plus blur and halo. (A clipped core blooms without
/// bound and is judged by its halo's colour instead.)
pub fn largest_radius_px(camera: &CameraModel, z_m: f64) -> f64 {
    widest_beam_px(camera, z_m) + (HALO_PX * photo_scale(camera)).max(HALO_FLOOR_PX)
}

/// Largest half-peak radius of an unclipped dot at depth `z_m`, pixels: the widest beam
/// spread by the largest divergence, plus blur ([`CORE_BLUR_PX`]).
pub fn largest_core_radius_px(camera: &CameraModel, z_m: f64) -> f64 {
    widest_beam_px(camera, z_m) + (CORE_BLUR_PX * photo_scale(camera)).max(HALO_FLOOR_PX)
}

/// Radius of the widest beam spread by the largest divergence at depth `z_m`, pixels.
fn widest_beam_px(camera: &CameraModel, z_m: f64) -> f64 {
    camera.fx_px * (BEAM_RADIUS_M + BEAM_HALF_DIVERGENCE_RAD * z_m) / z_m.max(0.05)
}

/// The dot among `candidates`: the plausible one carrying at least [`CLEAR_CONFIDENCE`] of
/// the plausible candidates' likelihood ([`CLEAR_CONFIDENCE_OF_LASER_COLOUR`] when of the
/// laser's colour); several without a clear one are ambiguous, none is
/// no dot.
pub fn choose(candidates: &[LineCandidate], band_half_width_px: f64) -> Result<LineDot, DotOnLineError> {
    let plausible: Vec<&LineCandidate> = candidates.iter().filter(|c| c.plausible()).collect();
    let Some(best) = plausible.iter().max_by(|a, b| a.weight().total_cmp(&b.weight())) else {
        let refused = candidates
            .iter()
            .filter(|c| c.gate.explained())
            .filter_map(|c| c.misfit.map(|why| RefusedOnLine { pixel_px: c.pixel_px(), why }))
            .collect();
        return Err(DotOnLineError::NoDot { half_width_px: band_half_width_px, refused });
    };
    // Blobs on the line refused only for their look (colour, outline) say the scene makes
    // dot-like things here: one of their kind that slipped through those tests is as likely.
    // Their weight counts against the chosen one's confidence. Kind: a blob clipped at its
    // centre (a near or bright dot, a glint) and one that is not (a tuft, a fin) differ in
    // what made them. A dot of 270 levels clipped at 0.70 m was withheld beside an unclipped
    // tuft whose outline had been refused (tuning target-less seed 3); no tuning answer went
    // wrong for counting only its kind.
    let lookalikes: Vec<&LineCandidate> = candidates
        .iter()
        .filter(|c| c.gate.explained() && matches!(c.misfit, Some(Refusal::Ragged | Refusal::OffColour)))
        .filter(|c| c.candidate.saturated_core == best.candidate.saturated_core && !c.unlike_colour())
        .collect();
    let hiding: Vec<&LineCandidate> = candidates.iter().filter(|c| c.may_hide(best)).collect();
    let total: f64 = plausible.iter().map(|c| c.weight()).sum::<f64>()
        // A look-alike of the chosen one's look and outline, of any colour within the gate
        // (`impostor_colour_likelihood`): the chosen one's outline likelihood scales both
        // sides, and its colour counts for it only as far as it is nearer the laser's than
        // an impostor's is likely to be (tuning 1/08 and 7/11 were withheld when the dot's
        // colour term was set against the tuft's bare look).
        + LOOKALIKE_SHARE
            * best.impostor_colour_likelihood()
            * best.outline_likelihood()
            * lookalikes.iter().map(|c| c.lookalike_weight(best)).sum::<f64>()
        + best.colour_likelihood() * best.outline_likelihood() * hiding.iter().map(|c| c.hiding_weight(best)).sum::<f64>()
        + NO_DOT_SNR.powf(SNR_POWER);
    let confidence = best.weight() / total;
    let clear = if best.colour_sigmas.is_some_and(|z| z <= LOOKALIKE_COLOUR_SIGMAS) {
        CLEAR_CONFIDENCE_OF_LASER_COLOUR
    } else {
        CLEAR_CONFIDENCE
    };
    if confidence < clear {
        let candidates_px = plausible.iter().map(|c| c.pixel_px()).collect();
        let hiding_px = hiding.iter().map(|c| c.pixel_px()).collect();
        return Err(DotOnLineError::Ambiguous { candidates_px, lookalikes: lookalikes.len(), hiding_px });
    }
    Ok(LineDot {
        pixel: best.candidate.pixel,
        snr: best.candidate.snr,
        offset_px: best.gate.offset_px.abs(),
        candidate: best.candidate.clone(),
        gate: best.gate,
        confidence,
        rivals: candidates.len() - 1,
    })
}

/// Candidates in every piece of the band, one per blob, best first.
fn search_pieces(
    img: &ColourView,
    line: &[Vec2],
    pieces: &[Vec<Vec2>],
    hw: f64,
    pad: f64,
    params: &DotDetectorParams,
) -> Vec<DotCandidate> {
    let mut found: Vec<DotCandidate> = Vec::new();
    for piece in pieces.iter().filter(|p| p.len() >= 2) {
        let (a, b) = (piece[0], piece[piece.len() - 1]);
        let along = (b - a).try_normalize(1e-9).unwrap_or(Vec2::new(1.0, 0.0));
        let across = Vec2::new(-along.y, along.x);
        // The piece may bow a little under distortion: widen by its largest sag.
        let sag = piece.iter().map(|p| ((p - a).dot(&across)).abs()).fold(0.0, f64::max);
        let (s, t) = (along * pad, across * (pad + sag));
        let polygon = vec![a - s - t, b + s - t, b + s + t, a - s + t];
        let region =
            SearchRegion { polygon, band: Some((line.to_vec(), hw)), squares: Vec::new(), overlapping_pieces: true };
        for c in find_dot_candidates(img, &region, params, PIECE_CANDIDATES) {
            keep_stronger(&mut found, c);
        }
    }
    found.sort_by(|a, b| b.snr.total_cmp(&a.snr));
    found
}

/// Adds `c` to `found` unless it is a blob already there, measured again by an overlapping
/// piece: one blob, one candidate, the one of the higher SNR. Pieces measure a blob against
/// their own background and noise, so one may see a dot and a tuft beside it as one ragged
/// blob and the next as two; keeping the first measure made the answer hang on the order
/// of the pieces, and a dot 13 px from a tuft it merged with in the first piece was lost in
/// every later one (held-out target-less 1000103/01). A spot split from a blob lies inside
/// its parent's blob, so near a whole blob it is the same spot only when that blob is
/// centred on it (another piece's edge cut the larger blob away there).
///
/// Two measures not centred alike (apart by twice the smaller's radius) are one piece's
/// merged blob and another's finer part of it: the finer stands for the place when it
/// carries at least [`FINER_PART_SNR_SHARE`] of the merged blob's SNR, the rest being a
/// faint neighbour the merge took in (tuning target-less 3000/17: a dot of SNR 35 and a tuft
/// beside it measured as one blob of SNR 37 centred 11 px off the dot, which won and was
/// withheld). A fragment of a much stronger blob is not that blob: preferred whatever its
/// SNR, a tuft's 4.5 px piece (SNR 66) stood for the 13 px tuft (SNR 377) refused as too
/// large, and was taken as the dot (tuning 3007/02).
fn keep_stronger(found: &mut Vec<DotCandidate>, c: DotCandidate) {
    let same = |f: &DotCandidate| {
        if f.split_from_blob == c.split_from_blob {
            (f.pixel - c.pixel).norm() < 2.0 * f.radius_px.max(c.radius_px).max(2.0)
        } else {
            centred_alike(f, &c)
        }
    };
    let Some(k) = found.iter().position(same) else {
        found.push(c);
        return;
    };
    let f = &found[k];
    let (finer, merged) = if c.radius_px < f.radius_px { (&c, f) } else { (f, &c) };
    let keep_new = if !centred_alike(f, &c) && finer.snr >= FINER_PART_SNR_SHARE * merged.snr {
        c.radius_px < f.radius_px
    } else {
        c.snr > f.snr
    };
    if keep_new {
        found[k] = c;
    }
}

/// Whether two measures of a place are centred alike: nearer than twice the smaller's
/// radius (at least 2 px), as two measures of one blob are.
fn centred_alike(a: &DotCandidate, b: &DotCandidate) -> bool {
    (a.pixel - b.pixel).norm() < 2.0 * a.radius_px.min(b.radius_px).max(2.0)
}

/// Least share of a merged blob's SNR that a finer measure of part of it must carry to
/// stand for it ([`keep_stronger`]). On the tuning target-less seeds 3000-3009 any share from
/// 0.3 to 0.7 gave the same answers (one dot more, 3000/17); without the rule 0 (every
/// finer part preferred) took a tuft's fragment there (3007/02).
const FINER_PART_SNR_SHARE: f64 = 0.5;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dot::candidates::ChannelOrder;
    use calib_targets::rig::{fsl_laser, tg6_camera};
    use calib_targets::scene::{laser_scene_set, render, Water};

    fn view(img: &image::RgbImage) -> ColourView<'_> {
        ColourView {
            width: img.width() as usize,
            height: img.height() as usize,
            stride: img.width() as usize * 3,
            order: ChannelOrder::Rgb,
            data: img.as_raw(),
            tone: None,
        }
    }

    /// A blob's measure at (`x`, `y`) of radius `radius_px` and SNR `snr`, for
    /// [`keep_stronger`].
    fn measure_at(x: f64, y: f64, radius_px: f64, snr: f64) -> DotCandidate {
        DotCandidate { radius_px, snr, ..crate::dot::on_target::hand_candidate(Vec2::new(x, y)) }
    }

    /// Two pieces' measures of one place: a dot (SNR 500) and, 13 px away, the ragged blob
    /// it merged into with a tuft (SNR 300, 15 px); a third, far blob. Whichever piece is
    /// searched first, the dot's measure is kept and the far blob too.
    #[test]
    fn of_two_measures_of_one_blob_the_stronger_is_kept_whatever_the_order() {
        let (dot, merged, far) = (
            measure_at(100.0, 100.0, 4.0, 500.0),
            measure_at(100.0, 113.0, 15.0, 300.0),
            measure_at(300.0, 100.0, 5.0, 50.0),
        );
        for order in [[&merged, &dot, &far], [&dot, &merged, &far], [&far, &merged, &dot]] {
            let mut found = Vec::new();
            for c in order {
                keep_stronger(&mut found, c.clone());
            }
            found.sort_by(|a, b| b.snr.total_cmp(&a.snr));
            assert_eq!(found, vec![dot.clone(), far.clone()]);
        }
    }

    /// A dot (SNR 35, 4.8 px) beside a tuft: one piece measures them as one blob centred
    /// 11 px off the dot (SNR 37, 6 px), the next sees the dot alone. The dot's measure
    /// stands for the place in either order. A tuft's small fragment (SNR 66) beside its
    /// whole (SNR 377, 13 px) does not.
    #[test]
    fn a_finer_measure_carrying_most_of_a_merged_blobs_signal_stands_for_it() {
        let kept = |order: [&DotCandidate; 2]| {
            let mut found = Vec::new();
            for c in order {
                keep_stronger(&mut found, c.clone());
            }
            found
        };
        let (dot, merged) = (measure_at(137.7, 122.8, 4.8, 35.0), measure_at(127.0, 121.4, 6.0, 37.0));
        let (fragment, tuft) = (measure_at(114.0, 77.0, 4.55, 66.0), measure_at(93.0, 84.0, 13.2, 377.0));
        for (a, b) in [(&dot, &merged), (&merged, &dot)] {
            assert_eq!(kept([a, b]), vec![dot.clone()]);
        }
        for (a, b) in [(&fragment, &tuft), (&tuft, &fragment)] {
            assert_eq!(kept([a, b]), vec![tuft.clone()]);
        }
    }

    #[test]
    fn band_pieces_are_cut_from_the_far_end_and_a_short_near_rest_joins_its_neighbour() {
        // A straight line 1 000 px long, sampled unevenly as the log-spaced line is.
        let line = |from: f64| -> Vec<Vec2> {
            let mut xs: Vec<f64> = (0..=40).map(|i| 1000.0 - 1000.0 * (i as f64 / 40.0).powi(2)).collect();
            xs.retain(|&x| x >= from);
            xs.reverse();
            xs.into_iter().map(|x| Vec2::new(x, 0.5 * x)).collect()
        };
        let ends = |l: &[Vec2]| -> Vec<(f64, f64)> {
            band_pieces(l, 250.0).iter().map(|p| (p[0].x, p[p.len() - 1].x)).collect()
        };
        let len = 1000.0 * 1.25f64.sqrt();
        // 1 118 px: three pieces of 250 px from the far end, and the near 368 px as one.
        let whole = ends(&line(0.0));
        assert_eq!(whole.len(), 4, "{whole:?}");
        let step = 250.0 / 1.25f64.sqrt();
        for (k, &(a, b)) in whole.iter().rev().enumerate() {
            assert!((b - (1000.0 - k as f64 * step)).abs() < 1e-9, "{k}: {whole:?}");
            if k < 3 {
                assert!((a - (1000.0 - (k + 1) as f64 * step)).abs() < 1e-9, "{k}: {whole:?}");
            }
        }
        assert!(whole[0].0 == 0.0, "{whole:?}");
        // Begun at its sample x = 437.5, 629 px from the far end, the line keeps its far
        // cuts: two pieces of 250 px and a near one of 129 px, over half a piece.
        let short = ends(&line(400.0));
        assert_eq!(short.len(), 3, "{short:?}");
        for (s, w) in short.iter().rev().zip(whole.iter().rev()).take(2) {
            assert!((s.0 - w.0).abs() < 1e-9 && (s.1 - w.1).abs() < 1e-9, "{short:?} {whole:?}");
        }
        // Every piece runs near to far, and together they cover the line once.
        let pieces = band_pieces(&line(0.0), 250.0);
        let total: f64 = pieces.iter().flat_map(|p| p.windows(2).map(|w| (w[1] - w[0]).norm())).sum();
        assert!((total - len).abs() < 1e-6, "{total} {len}");
        assert!(pieces.iter().all(|p| p.windows(2).all(|w| w[1].x >= w[0].x)));
    }

    /// The size rules at 1 m and 4 m: an unclipped dot is judged by its half-peak core
    /// against the widest beam there, a clipped one may bloom to 1.85x the widest unclipped
    /// blob, and to 3.5x when its own channel clips a dot's width beyond its white core,
    /// never further; a wide blob at the threshold with a narrow core is a dot.
    #[test]
    fn a_dots_core_must_fit_its_distance_and_a_clipped_one_blooms_only_so_far() {
        let camera = tg6_camera();
        for z in [1.0, 4.0] {
            let core = largest_core_radius_px(&camera, z);
            let widest = largest_radius_px(&camera, z);
            assert!(core < widest, "{core} {widest}");
            let blob = |radius_px: f64, core_radius_px: f64, saturated_core: bool| DotCandidate {
                radius_px,
                core_radius_px,
                saturated_core,
                snr: 1e4,
                ..crate::dot::on_target::hand_candidate(Vec2::zeros())
            };
            assert_eq!(
                misfit(&camera, &blob(2.0 * widest, 0.9 * core, false), z),
                None,
                "z {z}: halo wide, core narrow"
            );
            assert_eq!(misfit(&camera, &blob(core * 1.2, 1.1 * core, false), z), Some(Refusal::TooLarge), "z {z}");
            // A dot-sized spot standing in for the blob it was found in, centred on it: a
            // tuft's middle is no dot when the tuft is too large for one.
            let inside = |outer: DotCandidate| DotCandidate {
                enclosed_by: Some(Box::new(outer)),
                ..blob(0.5 * core, 0.5 * core, false)
            };
            assert_eq!(misfit(&camera, &inside(blob(1.2 * core, 0.8 * core, false)), z), None, "z {z}");
            assert_eq!(
                misfit(&camera, &inside(blob(1.5 * core, 1.3 * core, false)), z),
                Some(Refusal::TooLarge),
                "z {z}: a tuft's middle"
            );
            assert_eq!(misfit(&camera, &blob(1.5 * widest, 1.4 * widest, true), z), None, "z {z}: bloom");
            assert_eq!(misfit(&camera, &blob(2.2 * widest, 1.9 * widest, true), z), Some(Refusal::TooLarge), "z {z}");
            // The same clipped blob judged by its white part: a dot's glow clips only the
            // laser's channel, a glint is white throughout.
            let area = |radius_px: f64| (std::f64::consts::PI * radius_px * radius_px).round() as usize;
            let glow = DotCandidate { white_px: area(0.5 * widest), ..blob(2.2 * widest, 1.9 * widest, true) };
            assert_eq!(misfit(&camera, &glow, z), None, "z {z}: a white centre in a clipped glow");
            let glint = DotCandidate { white_px: area(1.9 * widest), ..blob(2.2 * widest, 1.9 * widest, true) };
            assert_eq!(misfit(&camera, &glint, z), Some(Refusal::TooLarge), "z {z}: white throughout");
            // A near dot bright enough to bloom white over 1.82 of the widest unclipped dot.
            let bloom = DotCandidate { white_px: area(1.82 * widest), ..blob(2.2 * widest, 1.82 * widest, true) };
            assert_eq!(misfit(&camera, &bloom, z), None, "z {z}: a blooming dot");
            // A dot so bright its white core is 2.8 times the widest: passed only when its own
            // channel clips a dot's width beyond the white, and never past 3.5 times.
            let flare = |white: f64, lit: f64| DotCandidate {
                white_px: area(white * widest),
                lit_clipped_px: area(lit * widest),
                ..blob(white * widest, white * widest, true)
            };
            assert_eq!(misfit(&camera, &flare(2.8, 3.9), z), None, "z {z}: a flaring dot");
            assert_eq!(misfit(&camera, &flare(2.8, 3.7), z), Some(Refusal::TooLarge), "z {z}: a thin ring");
            assert_eq!(misfit(&camera, &flare(3.6, 5.0), z), Some(Refusal::TooLarge), "z {z}: past 3.5");
        }
    }

    /// A search from 0.55 m (a calibration whose nearest photo was at 0.65 m): a blob on the
    /// line at 0.50 m clipped at its centre is judged as a near dot, the same blob unclipped
    /// is beyond the searched depths, and below 0.45 m even a clipped one is.
    #[test]
    fn a_clipped_dot_nearer_than_the_calibrated_range_is_still_judged() {
        let (camera, laser) = (tg6_camera(), fsl_laser());
        let search = LineSearch { depths_m: (0.55, 5.0), ..LineSearch::default() };
        let at = |z: f64, saturated_core: bool| {
            let p = laser.point_at_depth(z);
            let pixel = camera.project(&p).expect("in front of the camera");
            let c = DotCandidate {
                radius_px: 14.0,
                core_radius_px: 12.0,
                saturated_core,
                snr: 800.0,
                colour_score: 300.0,
                ..crate::dot::on_target::hand_candidate(pixel)
            };
            judge_candidate(&camera, &laser, &search, c, false).expect("on the line").misfit
        };
        assert_eq!(at(0.50, true), None);
        assert_eq!(at(0.50, false), Some(Refusal::OutOfRange));
        assert_eq!(at(0.42, true), Some(Refusal::OutOfRange));
    }

    /// A blob of signal-to-noise 50 at (x, 100) judged on a line whose gate explains an
    /// offset of 1 sigma per pixel, under the prior colour.
    fn blob(x: f64, misfit: Option<Refusal>, offset_px: f64) -> LineCandidate {
        let gate = LineGate {
            depth_m: 2.0,
            along_laser_m: 2.0,
            offset_px,
            line_sigma_px: 0.5,
            sigma_px: 1.0,
            chi2: offset_px * offset_px,
            implied_turn_rad: 0.0,
        };
        LineCandidate {
            candidate: DotCandidate { snr: 50.0, ..crate::dot::on_target::hand_candidate(Vec2::new(x, 100.0)) },
            gate,
            misfit,
            sensitive: false,
            colour_sigmas: None,
            photo_scale: 1.0,
        }
    }

    /// `c` with signal-to-noise `snr`.
    fn with_snr(c: LineCandidate, snr: f64) -> LineCandidate {
        LineCandidate { candidate: DotCandidate { snr, ..c.candidate }, ..c }
    }

    /// `c` clipped at its centre.
    fn clipped(c: LineCandidate) -> LineCandidate {
        LineCandidate { candidate: DotCandidate { saturated_core: true, ..c.candidate }, ..c }
    }

    /// The second look's measure replaces a refused first one when it is plausible; a blob
    /// first refused as too large only when the second look sees it under two-thirds its
    /// size. A plausible first measure, or a second one refused, changes nothing.
    #[test]
    fn the_second_look_measures_again_a_blob_the_first_refused() {
        let sized = |c: LineCandidate, radius_px: f64| LineCandidate {
            candidate: DotCandidate { radius_px, ..c.candidate },
            ..c
        };
        let again = |radius_px: f64| sized(with_snr(blob(100.0, None, 0.3), 40.0), radius_px);
        let second = |first: &LineCandidate, again: LineCandidate| {
            let mut kept = first.clone();
            take_second_measure(&mut kept, again);
            kept
        };
        for refusal in [Refusal::Ragged, Refusal::OffColour, Refusal::TooFaint] {
            let first = sized(blob(100.0, Some(refusal), 0.3), 5.0);
            assert_eq!(second(&first, again(5.0)), again(5.0), "{refusal:?}");
        }
        let off_line = sized(blob(100.0, None, 8.0), 5.0);
        assert_eq!(off_line.refusal(), Some(Refusal::OffLine));
        assert_eq!(second(&off_line, again(4.0)), again(4.0));
        // Too large at 21 px: 13.9 px is a dot in its glow, 14.1 px the same surface.
        let large = sized(blob(100.0, Some(Refusal::TooLarge), 0.3), 21.0);
        assert_eq!(second(&large, again(13.9)), again(13.9));
        assert_eq!(second(&large, again(14.1)), large);
        let plausible = sized(blob(100.0, None, 0.3), 5.0);
        assert_eq!(second(&plausible, again(3.0)), plausible);
        let refused_again = sized(blob(100.0, Some(Refusal::Ragged), 0.3), 3.0);
        let ragged = sized(blob(100.0, Some(Refusal::Ragged), 0.3), 5.0);
        assert_eq!(second(&ragged, refused_again), ragged);
    }

    /// One plausible blob alone is the dot; beside a look-alike refused for its outline that
    /// is stronger, it is withheld as ambiguous (a scene that makes dot-like algae on the
    /// line makes the survivor doubtful); a blob refused for being off the line does not
    /// count.
    #[test]
    fn look_alikes_refused_for_their_look_lower_the_confidence() {
        let dot = blob(100.0, None, 0.2);
        let alone = choose(std::slice::from_ref(&dot), 80.0).expect("one plausible blob");
        let weight = 2500.0 * (-0.02f64).exp();
        assert!((alone.confidence - weight / (weight + 25.0)).abs() < 1e-12, "{}", alone.confidence);
        // A tuft half again as strong as the dot, refused for its outline.
        let ragged = with_snr(blob(300.0, Some(Refusal::Ragged), 0.2), 75.0);
        let e = choose(&[dot.clone(), ragged.clone()], 80.0).unwrap_err();
        assert!(
            matches!(e, DotOnLineError::Ambiguous { ref candidates_px, lookalikes: 1, .. } if candidates_px.len() == 1),
            "{e}"
        );
        assert_eq!(
            e.to_string(),
            "a dot-like blob on the calibrated laser's image at (100, 100) beside a blob like it refused for its colour or outline, not clearly the dot; give the dot by hand"
        );
        // Far off the line, the same blob says nothing about this line's neighbourhood.
        let off_line = blob(300.0, Some(Refusal::Ragged), 10.0);
        assert!(choose(&[dot.clone(), off_line], 80.0).is_ok());
        // A look-alike much fainter than the dot leaves it clear.
        let faint = with_snr(ragged.clone(), 5.0);
        let found = choose(&[dot.clone(), faint], 80.0).expect("clear of a faint look-alike");
        assert!(found.confidence > CLEAR_CONFIDENCE, "{}", found.confidence);
        // A dot clipped at its centre is no kin of an unclipped tuft, however ragged: the tuft
        // still counts against an unclipped dot, not against a clipped one.
        let clipped_dot = clipped(dot);
        let found =
            choose(&[clipped_dot.clone(), ragged.clone()], 80.0).expect("a clipped dot beside an unclipped tuft");
        assert_eq!(found.pixel, clipped_dot.candidate.pixel);
        let clipped_tuft = clipped(ragged);
        assert!(
            choose(&[clipped_dot, clipped_tuft], 80.0).is_err(),
            "a clipped look-alike counts against a clipped dot"
        );
    }

    /// With nothing plausible on the line, the no-dot sentence names the blobs the line
    /// explains that were refused and why (the dot may be among them, for the user to give
    /// by hand), at most three by place; a blob off the line is not named.
    #[test]
    fn a_no_dot_sentence_names_the_blobs_refused_on_the_line() {
        let none = choose(&[blob(300.0, None, 10.0)], 80.0).unwrap_err();
        assert!(matches!(none, DotOnLineError::NoDot { ref refused, .. } if refused.is_empty()), "{none}");
        assert!(!none.to_string().contains("refused on it"), "{none}");
        let one = choose(&[blob(120.0, Some(Refusal::OffColour), 0.4), blob(300.0, None, 10.0)], 80.0).unwrap_err();
        assert!(
            one.to_string().ends_with(
                "; refused on it: a blob at (120, 100), not the laser's colour (give the dot by hand if it is the dot)"
            ),
            "{one}"
        );
        let why = [Refusal::TooLarge, Refusal::Ragged, Refusal::TooFaint, Refusal::TooSmall, Refusal::OffColour];
        let many: Vec<LineCandidate> =
            why.iter().enumerate().map(|(i, &r)| blob(100.0 + 50.0 * i as f64, Some(r), 0.4)).collect();
        let e = choose(&many, 80.0).unwrap_err();
        assert!(matches!(e, DotOnLineError::NoDot { ref refused, .. } if refused.len() == 5), "{e}");
        assert!(
            e.to_string().ends_with(
                "; refused on it: 5 blobs, at (100, 100), too large for its distance; (150, 100), ragged outline: no beam's footprint; (200, 100), too faint for its distance and 2 more (give the dot by hand if one is the dot)"
            ),
            "{e}"
        );
    }

    /// A faint blob on the line beside a much brighter one the line runs through, refused
    /// as off it or too large (a dot merged with a tuft), is withheld: the dot may be inside
    /// the bright one. Under three times its peak, of the other kind (clipped or not), off
    /// the laser's colour, with the line outside it or refused for another reason, the
    /// bright blob casts no doubt.
    #[test]
    fn a_brighter_blob_the_line_runs_through_may_hide_the_dot() {
        let speck = with_snr(blob(100.0, None, 0.1), 30.0);
        let speck = LineCandidate { candidate: DotCandidate { peak_green: 5.0, ..speck.candidate }, ..speck };
        let merged = |peak_green: f64, offset_px: f64, misfit: Option<Refusal>| {
            let c = with_snr(blob(300.0, misfit, offset_px), 500.0);
            LineCandidate { candidate: DotCandidate { peak_green, radius_px: 15.0, ..c.candidate }, ..c }
        };
        assert!(choose(std::slice::from_ref(&speck), 80.0).is_ok(), "alone the speck is the dot");
        let e = choose(&[speck.clone(), merged(73.0, 10.0, None)], 80.0).unwrap_err();
        assert!(matches!(e, DotOnLineError::Ambiguous { ref hiding_px, .. } if hiding_px == &[[300.0, 100.0]]), "{e}");
        assert!(
            e.to_string().contains("(the line runs through a brighter blob at (300, 100), which may hide the dot)"),
            "{e}"
        );
        let too_large = merged(73.0, 0.5, Some(Refusal::TooLarge));
        assert!(choose(&[speck.clone(), too_large], 80.0).is_err(), "too large on the line");
        for (why, rival) in [
            ("under 3 times the peak", merged(14.0, 10.0, None)),
            ("the line outside it", merged(73.0, 16.0, None)),
            ("on the line, refused as too faint", merged(73.0, 0.5, Some(Refusal::TooFaint))),
            ("clipped", clipped(merged(73.0, 10.0, None))),
            ("off the laser's colour", LineCandidate { colour_sigmas: Some(3.5), ..merged(73.0, 10.0, None) }),
        ] {
            let found = choose(&[speck.clone(), rival], 80.0);
            assert!(found.is_ok(), "{why}: {found:?}");
        }
    }

    /// Under a learned colour, a blob nearer the laser's colour is likelier the dot: a dot
    /// 0.3 sigmas off is clear of a stronger tuft 2.8 sigmas off that the prior could not
    /// tell from it. Against a look-alike, the dot's colour counts as far as it is likelier
    /// the laser's than an impostor's (flat, as the laser's at 2 sigmas): a dot 0.2 sigmas
    /// off is clear of a ragged tuft half again as strong, which withholds it under the
    /// prior and withholds a dot 2.5 sigmas off.
    #[test]
    fn the_lasers_colour_weighs_in_the_choice() {
        let dot = blob(100.0, None, 0.2);
        let tuft = with_snr(blob(300.0, None, 0.2), 75.0);
        assert!(choose(&[dot.clone(), tuft.clone()], 80.0).is_err(), "the prior tells no green from another");
        let coloured = |c: &LineCandidate, z: f64| LineCandidate { colour_sigmas: Some(z), ..c.clone() };
        let found = choose(&[coloured(&dot, 0.3), coloured(&tuft, 2.8)], 80.0).expect("the laser's colour chooses");
        assert_eq!(found.pixel, dot.candidate.pixel);
        assert!(found.confidence > CLEAR_CONFIDENCE, "{}", found.confidence);
        // The look-alike's look counts up to the dot's, 0.12 * min(75^2, 50^2) = 300: under
        // the prior against the dot's 2500, 0.885. With a learned colour, at an impostor's
        // colour likelihood exp(-2): 41 against the dot's 2500 * exp(-0.02), 0.97; against
        // a dot 2.5 sigmas off, 2500 * exp(-3.125) = 110, 0.62 (25 for none of them the dot
        // throughout, all but the none scaled by the offset's exp(-0.02)).
        let ragged = with_snr(blob(300.0, Some(Refusal::Ragged), 0.2), 75.0);
        assert!(matches!(
            choose(&[dot.clone(), ragged.clone()], 80.0),
            Err(DotOnLineError::Ambiguous { lookalikes: 1, .. })
        ));
        let offset = (-0.02f64).exp();
        let confidence = |z: f64| {
            let own = 2500.0 * offset * (-0.5 * z * z).exp();
            own / (own + 300.0 * offset * (-2.0f64).exp() + 25.0)
        };
        let found = choose(&[coloured(&dot, 0.2), coloured(&ragged, 2.0)], 80.0).expect("clear of the look-alike");
        assert!((found.confidence - confidence(0.2)).abs() < 1e-9, "{} {}", found.confidence, confidence(0.2));
        assert!(found.confidence > 0.95, "{}", found.confidence);
        assert!(matches!(
            choose(&[coloured(&dot, 2.5), coloured(&ragged, 2.0)], 80.0),
            Err(DotOnLineError::Ambiguous { lookalikes: 1, .. })
        ));
        assert!((confidence(2.5) - 0.62).abs() < 0.01, "{}", confidence(2.5));
    }

    /// A blob clipped at its centre is likelier the dot than one that is not: an unclipped dot
    /// of SNR 50 beside a plausible tuft of SNR 30 is withheld (2500 against 900 and 25 for
    /// neither: 0.73); clipped, it carries 4 x 2500 against them and is taken (0.92).
    #[test]
    fn a_blob_clipped_at_its_centre_is_likelier_the_dot() {
        let dot = blob(100.0, None, 0.0);
        let tuft = with_snr(blob(300.0, None, 0.0), 30.0);
        assert!(matches!(choose(&[dot.clone(), tuft.clone()], 80.0), Err(DotOnLineError::Ambiguous { .. })));
        let clipped_dot = clipped(dot);
        let found = choose(&[clipped_dot.clone(), tuft], 80.0).expect("a clipped dot beside an unclipped tuft");
        assert_eq!(found.pixel, clipped_dot.candidate.pixel);
        assert!((found.confidence - 10_000.0 / 10_925.0).abs() < 1e-9, "{}", found.confidence);
    }

    /// A look-alike counts less the further its chroma lies beyond the off-colour gate: a
    /// tuft 3 sigmas off the laser's colour, stronger than a dot of SNR 100 2.2 sigmas off,
    /// withholds it (0.12 of the dot's 100^2, the most a look-alike's look counts, at an
    /// impostor's colour likelihood exp(-2): 162 against 10 000 * exp(-2.42) = 889, 0.83
    /// with 25 for none of them the dot); the same tuft 6 sigmas off counts a quarter of
    /// that (0.93).
    #[test]
    fn a_look_alike_counts_less_the_further_off_the_lasers_colour() {
        let dot = LineCandidate { colour_sigmas: Some(2.2), ..with_snr(blob(100.0, None, 0.0), 100.0) };
        let tuft = |z: f64| LineCandidate {
            colour_sigmas: Some(z),
            ..with_snr(blob(300.0, Some(Refusal::OffColour), 0.0), 150.0)
        };
        assert!(matches!(
            choose(&[dot.clone(), tuft(OFF_COLOUR_SIGMAS)], 80.0),
            Err(DotOnLineError::Ambiguous { lookalikes: 1, .. })
        ));
        let found = choose(&[dot.clone(), tuft(2.0 * OFF_COLOUR_SIGMAS)], 80.0).expect("clear of a far-off tuft");
        assert_eq!(found.pixel, dot.candidate.pixel);
        let own = 10_000.0 * (-2.42f64).exp();
        let expected = own / (own + 1200.0 * (-2.0f64).exp() / 4.0 + 25.0);
        assert!((found.confidence - expected).abs() < 1e-9, "{} {expected}", found.confidence);
        assert!((found.confidence - 0.93).abs() < 0.005, "{}", found.confidence);
    }

    /// A lone plausible blob is the dot only when it is clearly likelier than none of the
    /// candidates being the dot (a laser-off photo with a look-alike on the line): at SNR 16
    /// on the line's centre of a 4000 px photo it carries 256 against 25 (0.91) and is taken;
    /// at SNR 14, 196 against 25 (0.89), it is withheld with its pixel named.
    #[test]
    fn a_lone_blob_too_weak_to_tell_from_no_dot_is_withheld() {
        let found = choose(&[with_snr(blob(100.0, None, 0.0), 16.0)], 80.0).expect("strong enough alone");
        assert!((found.confidence - 256.0 / 281.0).abs() < 1e-9, "{}", found.confidence);
        let weak = with_snr(blob(100.0, None, 0.0), 14.0);
        let e = choose(std::slice::from_ref(&weak), 80.0).unwrap_err();
        assert_eq!(
            e.to_string(),
            "a dot-like blob on the calibrated laser's image at (100, 100), not clearly the dot; give the dot by hand"
        );
        // In a photo 1000 px wide the same scene's blobs have a quarter of the SNR: 14 there
        // is 56 at 4000 px, 3136 against 25.
        let small = choose(&[LineCandidate { photo_scale: 0.25, ..weak }], 80.0).expect("a 1000 px photo");
        assert!((small.confidence - 3136.0 / 3161.0).abs() < 1e-9, "{}", small.confidence);
    }

    /// A lone blob of the laser's colour is taken at a lower share than one whose colour
    /// says nothing: at SNR 12, 1.5 sigmas off the learned colour, it carries 144 * exp(-1.125)
    /// = 47 against 25 (0.65) and is withheld; at SNR 16, 83 (0.77) withheld; at SNR 20, 130
    /// (0.84) taken; 2.5 sigmas off (within the 3 sigmas' colour gate) at SNR 60, 158 (0.86),
    /// withheld, as is a blob under the prior at SNR 14 (196, 0.89).
    #[test]
    fn a_blob_of_the_lasers_colour_is_the_dot_at_a_lower_share() {
        let coloured =
            |snr: f64, z: f64| LineCandidate { colour_sigmas: Some(z), ..with_snr(blob(100.0, None, 0.0), snr) };
        let share = |snr: f64, z: f64| {
            let own = snr * snr * (-0.5 * z * z).exp();
            own / (own + 25.0)
        };
        for snr in [12.0, 16.0] {
            assert!(choose(&[coloured(snr, 1.5)], 80.0).is_err(), "SNR {snr}: {}", share(snr, 1.5));
        }
        let found = choose(&[coloured(20.0, 1.5)], 80.0).expect("of the laser's colour");
        assert!((found.confidence - share(20.0, 1.5)).abs() < 1e-9, "{}", found.confidence);
        assert!(found.confidence < CLEAR_CONFIDENCE, "{}", found.confidence);
        assert!(choose(&[coloured(60.0, 2.5)], 80.0).is_err(), "{}", share(60.0, 2.5));
        assert!(choose(&[with_snr(blob(100.0, None, 0.0), 14.0)], 80.0).is_err());
    }

    /// A rough outline under the gate's limit still tells against a blob: a tuft of SNR 60
    /// whose outline departs 0.09 of its radius from an ellipse weighs 3600 * exp(-3.3) = 132
    /// against a smooth dot of SNR 50 (2500) and 25 for neither, and the dot is taken (0.94);
    /// beside a tuft of roughness 0.06 (828) it is withheld (0.75).
    #[test]
    fn a_rougher_outline_is_less_likely_a_beams_footprint() {
        let outline = |c: LineCandidate, r: f64| LineCandidate {
            candidate: DotCandidate { outline_roughness: Some(r), ..c.candidate },
            ..c
        };
        let dot = outline(blob(100.0, None, 0.0), 0.0);
        let tuft = |r: f64| outline(with_snr(blob(300.0, None, 0.0), 60.0), r);
        let found = choose(&[dot.clone(), tuft(0.09)], 80.0).expect("clear of a rough tuft");
        assert_eq!(found.pixel, dot.candidate.pixel);
        let rough = 3600.0 * (-0.5 * (0.09f64 / OUTLINE_ROUGHNESS_SIGMA).powi(2)).exp();
        assert!((found.confidence - 2500.0 / (2525.0 + rough)).abs() < 1e-9, "{}", found.confidence);
        assert!(choose(&[dot, tuft(0.06)], 80.0).is_err(), "a smoother tuft withholds the dot");
    }

    /// An unclipped blob that implies a near dot is less likely the dot, as the square of
    /// its distance over 1.5 m: alone at SNR 20 it is taken at 2 m (400 against 25: 0.94) and
    /// withheld at 0.5 m (44 against 25: 0.64); clipped there, it is taken (1600: 0.98).
    #[test]
    fn an_unclipped_blob_near_the_camera_is_less_likely_the_dot() {
        let at = |depth_m: f64| {
            let c = with_snr(blob(100.0, None, 0.0), 20.0);
            LineCandidate { gate: LineGate { depth_m, ..c.gate }, ..c }
        };
        let far = choose(&[at(2.0)], 80.0).expect("a far unclipped blob");
        assert!((far.confidence - 400.0 / 425.0).abs() < 1e-9, "{}", far.confidence);
        assert!(choose(&[at(0.5)], 80.0).is_err());
        let near = choose(&[clipped(at(0.5))], 80.0).expect("a near clipped blob");
        assert!((near.confidence - 1600.0 / 1625.0).abs() < 1e-9, "{}", near.confidence);
    }

    /// Under a learned colour of 4 degrees' spread, a blob refused 20 degrees off the laser's
    /// colour is a look-alike and withholds a weaker dot 10 degrees off (2.5 sigmas) beside
    /// it; one 40 degrees off (over [`UNLIKE_COLOUR_RATIO`] times the 12-degree limit) is no
    /// kin of the dot and does not. Neither withholds a dot 2 degrees off, though the kin's
    /// signal is seven times its own.
    /// A blob of the laser's chroma whose white part falls 25 degrees short is refused too.
    #[test]
    fn a_blob_far_off_the_lasers_colour_is_no_look_alike() {
        let (camera, laser) = (tg6_camera(), fsl_laser());
        let unit = crate::dot::colour::linear_unit_colour([0.25, 0.9, 0.36], 4f32.to_radians(), 6);
        let colour = crate::dot::colour::LaserColourModel::from_unit(&unit).expect("a green laser");
        let detector = DotDetectorParams { colour, ..DotDetectorParams::default() };
        let search = LineSearch { detector, ..LineSearch::default() };
        let with_white = |z: f64, angle_deg: f64, white_deficit_deg: f64, snr: f64| {
            let pixel = camera.project(&laser.point_at_depth(z)).expect("in front of the camera");
            let c = DotCandidate {
                radius_px: 4.0,
                core_radius_px: 3.0,
                snr,
                colour_score: snr,
                colour_angle_rad: angle_deg.to_radians(),
                colour_angle_sigma_rad: 0.5f64.to_radians(),
                white_deficit_rad: white_deficit_deg.to_radians(),
                ..crate::dot::on_target::hand_candidate(pixel)
            };
            judge_candidate(&camera, &laser, &search, c, false).expect("on the line")
        };
        let at = |z: f64, angle_deg: f64, snr: f64| with_white(z, angle_deg, 0.0, snr);
        let dot = at(2.0, 10.0, 100.0);
        assert!(dot.plausible() && !dot.unlike_colour(), "{dot:?}");
        let kin = at(1.2, 20.0, 200.0);
        assert_eq!((kin.misfit, kin.unlike_colour()), (Some(Refusal::OffColour), false));
        assert!(matches!(
            choose(&[dot.clone(), kin.clone()], 80.0),
            Err(DotOnLineError::Ambiguous { lookalikes: 1, .. })
        ));
        // The kin's look counts only up to the dot's: 0.12 * exp(-2) * 30^2 * (3 / 4.96)^2 = 5
        // against 30^2 * exp(-0.12) = 796 (counted whole, 25 600 for the kin, unclipped
        // nearer than 1.5 m: 152, 0.82).
        let true_colour = at(2.0, 2.0, 30.0);
        let found = choose(&[true_colour.clone(), kin], 80.0).expect("a dot of the laser's colour");
        assert_eq!(found.pixel, true_colour.candidate.pixel);
        assert!(found.confidence > 0.95, "{}", found.confidence);
        let unlike = at(1.2, 40.0, 200.0);
        assert_eq!((unlike.misfit, unlike.unlike_colour()), (Some(Refusal::OffColour), true));
        let found = choose(&[dot.clone(), unlike], 80.0).expect("a pigment far off the laser's colour");
        assert_eq!(found.pixel, dot.candidate.pixel);
        assert!(with_white(1.2, 2.0, 10.0, 200.0).plausible(), "10 degrees short: within 3 sigmas");
        let darkening = with_white(1.2, 2.0, 25.0, 200.0);
        assert_eq!(darkening.misfit, Some(Refusal::OffColour));
    }

    /// Rendered 4000x3000 scenes near and far, with glints and a green reflection elsewhere:
    /// the dot is found on the line without the board, within a pixel of the truth.
    #[test]
    fn finds_the_dot_along_the_line_without_a_target() {
        let murky = laser_scene_set(8, 5, Water::Murky, 3);
        let clear = laser_scene_set(8, 5, Water::Clear, 3);
        let (camera, laser) = (tg6_camera(), fsl_laser());
        for (i, spec) in [(0usize, &murky[0]), (1, &murky[1]), (4, &murky[4]), (7, &murky[7]), (6, &clear[6])] {
            let scene = render(spec);
            let truth = scene.truth.dot.clone().expect("dot on the board");
            let found = find_dot_on_laser_line(&view(&scene.image), &camera, &laser, &LineSearch::default());
            // A 4.5 m dot on a black square is at the noise floor: it may be refused, never
            // taken from a wrong blob.
            if i == 7 {
                if let Err(e) = &found {
                    eprintln!(
                        "photo {i} ({:?}, {:.2} m, on black: {}): refused: {e}",
                        spec.water, truth.depth_m, truth.on_black_square
                    );
                    continue;
                }
            }
            let dot = found.unwrap_or_else(|e| panic!("photo {i} at {:.2} m: {e}", truth.depth_m));
            let err = (dot.pixel - Vec2::new(truth.pixel[0], truth.pixel[1])).norm();
            eprintln!(
                "photo {i}: depth {:.2} m, dot {err:.2} px from truth, offset {:.2} px, snr {:.0}, rivals {}",
                truth.depth_m, dot.offset_px, dot.snr, dot.rivals
            );
            assert!(err < 1.0, "photo {i}: {err:.2} px from the truth");
            assert!(dot.offset_px < 1.0, "photo {i}: the true laser's dot is {:.2} px off its line", dot.offset_px);
        }
    }

    #[test]
    fn a_photo_with_the_laser_off_has_no_dot_and_a_foreign_line_misses_the_image() {
        let mut spec = laser_scene_set(3, 6, Water::Clear, 2).remove(1);
        spec.laser = None;
        let scene = render(&spec);
        let (camera, laser) = (tg6_camera(), fsl_laser());
        let e = find_dot_on_laser_line(&view(&scene.image), &camera, &laser, &LineSearch::default()).unwrap_err();
        assert!(matches!(e, DotOnLineError::NoDot { .. }), "{e}");
        // A line pointing out of the frame sideways.
        let away = LaserLine::from_point_direction(
            fslcal_core::Vec3::new(2.0, 0.0, 0.0),
            fslcal_core::Vec3::new(1.0, 0.0, 0.3),
        )
        .unwrap();
        let e = find_dot_on_laser_line(&view(&scene.image), &camera, &away, &LineSearch::default()).unwrap_err();
        assert!(matches!(e, DotOnLineError::LineOutsideImage { .. }), "{e}");
    }
}
