//! What `fslcal validate` and `fslcal check` say about each photo: measured and within the
//! tolerance or not, on the calibrated line or flagged, or why the photo could not be used.
//!
//! These are the per-photo lines of their JSON documents too (`documents::validation`,
//! `documents::check`), so they build without the `vision` feature: the registry reads a
//! validation report without OpenCV.

use crate::dot::on_line::{DotOnLineError, Refusal};
use crate::laser::outcome::TargetMiss;
use crate::reason::Reason;
use fslcal_core::Vec2;
use serde::{Deserialize, Serialize};
use std::fmt;

/// How the two end points of a validation's known length are put into 3D.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum LengthRule {
    /// The plane through the dot's 3D point with the target's detected orientation
    /// (orientation only, no distance): judges the calibration, not the photo's tilt.
    TiltedPlane,
    /// The thesis's rule: both ends at the dot's depth, as for a fish.
    FrontoParallel,
}

impl LengthRule {
    /// The rule's name as the option and the JSON spell it.
    pub fn as_str(self) -> &'static str {
        match self {
            LengthRule::TiltedPlane => "tilted-plane",
            LengthRule::FrontoParallel => "fronto-parallel",
        }
    }
}

/// Why a photo could not be measured by `fslcal validate`.
#[derive(Clone, Debug, PartialEq)]
pub enum ValidationSkip {
    /// No usable target in the photo.
    Target(TargetMiss),
    /// No dot-like blob on the target near the calibrated laser's image.
    NoDot,
    /// Several blobs on the target could be the dot and none clearly is; their pixels.
    Ambiguous { candidates_px: Vec<[f64; 2]> },
    /// The best blob's distance by the laser disagrees with the target's plane there,
    /// metres: not the dot, or a badly wrong calibration.
    NotTheDot { by_laser_m: f64, on_target_m: f64 },
    /// The known length's end points project behind the camera.
    EndsBehindCamera,
    /// The end points' rays do not meet the plane.
    EndsOffPlane,
}

impl fmt::Display for ValidationSkip {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ValidationSkip::Target(miss) => miss.fmt(f),
            ValidationSkip::NoDot => f.write_str("no laser dot found on the target near the calibrated laser's image"),
            ValidationSkip::Ambiguous { candidates_px } => write!(
                f,
                "{} dot-like blobs on the target along the calibrated laser's image and none clearly the dot, at {}",
                candidates_px.len(),
                crate::dot::on_line::pixel_list(candidates_px)
            ),
            ValidationSkip::NotTheDot { by_laser_m, on_target_m } => write!(
                f,
                "the best dot-like blob gives {by_laser_m:.2} m by the laser but lies on the target at {on_target_m:.2} m: not the dot, or a badly wrong calibration"
            ),
            ValidationSkip::EndsBehindCamera => f.write_str("the length's end points are behind the camera"),
            ValidationSkip::EndsOffPlane => f.write_str("the length's end points could not be put on the plane"),
        }
    }
}

/// What became of one photo in a validation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ValidationOutcome<'a> {
    Pass,
    Fail,
    Skipped(&'a Reason<ValidationSkip>),
    /// Neither measured nor given a reason: a line read from a document missing both.
    Unknown,
}

/// One photo's line of a validation (`photos` in `fslcal validate --json`).
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct PhotoValidation {
    pub file: String,
    /// The known length as measured, millimetres.
    pub measured_mm: Option<f64>,
    pub true_mm: f64,
    /// (measured - true) / true, percent.
    pub error_pct: Option<f64>,
    /// Within the tolerance; `None` for a skipped photo.
    pub pass: Option<bool>,
    /// Depth of the dot by the calibration, metres.
    pub distance_m: Option<f64>,
    pub dot_px: Option<[f64; 2]>,
    /// Feature inliers of a slate's match (checkerboards: none).
    pub target_inliers: Option<usize>,
    /// Why a skipped photo was skipped.
    pub reason: Option<Reason<ValidationSkip>>,
    /// The target's outline and the length's end points in the image, pixels; kept for the
    /// HTML report, not the JSON.
    #[serde(skip)]
    pub target_outline_px: Vec<Vec2>,
    #[serde(skip)]
    pub ends_px: Option<[Vec2; 2]>,
}

impl PhotoValidation {
    pub fn outcome(&self) -> ValidationOutcome<'_> {
        match (self.pass, &self.reason) {
            (Some(true), _) => ValidationOutcome::Pass,
            (Some(false), _) => ValidationOutcome::Fail,
            (None, Some(why)) => ValidationOutcome::Skipped(why),
            (None, None) => ValidationOutcome::Unknown,
        }
    }
}

/// Why a photo could not be checked by `fslcal check`.
#[derive(Clone, Debug, PartialEq)]
pub enum CheckSkip {
    /// The photo cannot be read or decoded; the reader's message without the path.
    Unreadable { detail: String },
    /// No clear dot along the calibrated laser's image.
    NoDot(DotOnLineError),
    /// A dot was found this far from the line's image, but the calibration gives it no
    /// distance (its ray passes the beam behind the camera), so it cannot be judged.
    NoDistance { offset_px: f64 },
}

impl fmt::Display for CheckSkip {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CheckSkip::Unreadable { detail } => f.write_str(detail),
            CheckSkip::NoDot(e) => e.fmt(f),
            CheckSkip::NoDistance { offset_px } => write!(
                f,
                "the dot found lies {offset_px:.1} px from the calibrated line, where the calibration gives no distance: it cannot be judged (a reflection, or the laser moved far)"
            ),
        }
    }
}

/// What became of one photo in a drift check.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CheckOutcome<'a> {
    /// The dot is as near the calibrated line as the uncertainties explain.
    Within,
    /// The dot is off the line beyond `FLAG_SIGMAS`.
    Flagged,
    Skipped(&'a Reason<CheckSkip>),
}

/// One dot-like blob in the band around the calibrated line's image, as the drift check
/// judged it (`candidates` of a photo in `fslcal check --json`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CandidateCheck {
    /// Its centre, pixels.
    pub pixel: [f64; 2],
    /// The detector's matched-filter signal-to-noise.
    pub snr: f64,
    /// Its contrast along the laser's colour over its background, noise sigmas, and the
    /// angle between its colour and the laser's, degrees.
    #[serde(default)]
    pub colour_sigmas: f64,
    #[serde(default)]
    pub colour_angle_deg: f64,
    /// 1 sigma of that angle from the blob's noise, degrees.
    #[serde(default)]
    pub colour_angle_sigma_deg: f64,
    /// 1 sigma of that angle from the texture of the surface around it, degrees: judged
    /// with, beside `colour_angle_sigma_deg`.
    #[serde(default)]
    pub colour_texture_sigma_deg: f64,
    /// How far the white part of its excess falls short of the laser's, degrees: a
    /// pigment darkens a channel the laser's light would lift.
    #[serde(default)]
    pub white_deficit_deg: f64,
    /// Its mean excess (R, G, B) over a background ring beyond its halo, 8-bit levels: what
    /// its contrast is scored on.
    #[serde(default)]
    pub excess_rgb_levels: [f64; 3],
    /// Equivalent radius, pixels, and whether its core is clipped.
    pub radius_px: f64,
    pub saturated: bool,
    /// Equivalent radius of its part at or above half its peak, pixels, and that peak
    /// (excess along the laser's colour, 8-bit levels).
    #[serde(default)]
    pub core_radius_px: f64,
    #[serde(default)]
    pub peak_levels: f64,
    /// For a spot found inside a larger blob and centred on it, which stands in for it:
    /// that blob's `core_radius_px`. A stand-in is `too-large` when the blob it stands in
    /// for is too large for a dot at its distance, however small its own core. Null for a
    /// blob measured whole.
    #[serde(default)]
    pub enclosing_core_radius_px: Option<f64>,
    /// How far its half-peak outline departs from an ellipse, share of its radius; null
    /// when not measured (clipped, small or faint).
    #[serde(default)]
    pub outline_roughness: Option<f64>,
    /// Signed offset across the calibrated line's image, pixels (positive: the side a beam
    /// turned out of the camera-beam plane by a positive angle moves to).
    pub offset_px: f64,
    /// 1 sigma of that offset explained by the calibration and the centring, pixels.
    pub sigma_px: f64,
    /// Depth its place on the line implies, metres.
    pub distance_m: f64,
    /// Why it cannot be the dot under the laser the check believes; `None`: plausible.
    pub refused: Option<Refusal>,
    /// How far its colour lies from the unit's learned laser colour (chroma angle and white
    /// part), in sigmas of the colour's spread and the blob's noise; null under the prior.
    #[serde(default)]
    pub colour_off_sigmas: Option<f64>,
    /// Pixels of the blob with a clipped channel.
    #[serde(default)]
    pub saturated_px: usize,
    /// Pixels of the blob with all three channels clipped.
    #[serde(default)]
    pub white_px: usize,
    /// Pixels clipped in the laser's own channels around its white part.
    #[serde(default)]
    pub lit_clipped_px: usize,
    /// Found by the second, more sensitive look close to the line.
    #[serde(default)]
    pub sensitive: bool,
    /// A spot of its own split from a larger blob.
    #[serde(default)]
    pub split_from_blob: bool,
}

impl CandidateCheck {
    /// A line candidate against the calibrated laser, refused or not under the believed one.
    pub fn of(c: &crate::dot::on_line::LineCandidate, refused: Option<Refusal>) -> Self {
        CandidateCheck {
            pixel: c.pixel_px(),
            snr: c.candidate.snr,
            colour_sigmas: c.candidate.colour_score,
            colour_angle_deg: c.candidate.colour_angle_rad.to_degrees(),
            colour_angle_sigma_deg: c.candidate.colour_angle_sigma_rad.to_degrees(),
            colour_texture_sigma_deg: c.candidate.colour_texture_sigma_rad.to_degrees(),
            white_deficit_deg: c.candidate.white_deficit_rad.to_degrees(),
            excess_rgb_levels: c.candidate.excess_rgb,
            radius_px: c.candidate.radius_px,
            saturated: c.candidate.saturated_core,
            core_radius_px: c.candidate.core_radius_px,
            peak_levels: c.candidate.peak_green,
            enclosing_core_radius_px: c.candidate.enclosed_by.as_ref().map(|e| e.core_radius_px),
            outline_roughness: c.candidate.outline_roughness,
            offset_px: c.gate.offset_px,
            sigma_px: c.gate.sigma_px,
            distance_m: c.gate.depth_m,
            refused,
            colour_off_sigmas: c.colour_sigmas,
            saturated_px: c.candidate.saturated_px,
            white_px: c.candidate.white_px,
            lit_clipped_px: c.candidate.lit_clipped_px,
            sensitive: c.sensitive,
            split_from_blob: c.candidate.split_from_blob,
        }
    }
}

/// One photo's line of a drift check (`photos` in `fslcal check --json`).
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct PhotoCheck {
    pub file: String,
    pub dot_px: Option<[f64; 2]>,
    /// Perpendicular distance of the dot from the calibrated line's image, pixels.
    pub offset_px: Option<f64>,
    /// What the calibration and the dot's localisation explain, 1 sigma, pixels.
    pub explained_sigma_px: Option<f64>,
    pub flag: bool,
    /// Depth of the dot by the calibration, metres.
    pub distance_m: Option<f64>,
    /// Angle at the laser's origin between the calibrated beam and the dot, degrees; the
    /// median over the photos is the document's `implied_direction_change_deg`.
    #[serde(skip)]
    pub direction_change_deg: Option<f64>,
    /// Share of the plausible candidates' likelihood the chosen dot carries (0-1).
    #[serde(default)]
    pub confidence: Option<f64>,
    /// Every dot-like blob in the band, strongest first.
    #[serde(default)]
    pub candidates: Vec<CandidateCheck>,
    /// Why the photo could not be checked.
    pub reason: Option<Reason<CheckSkip>>,
}

impl PhotoCheck {
    pub fn outcome(&self) -> CheckOutcome<'_> {
        match (&self.reason, self.flag) {
            (Some(why), _) => CheckOutcome::Skipped(why),
            (None, true) => CheckOutcome::Flagged,
            (None, false) => CheckOutcome::Within,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_read_back_what_they_wrote_and_keep_the_sentences() {
        let p = PhotoValidation {
            file: "a.jpg".into(),
            true_mm: 548.2,
            reason: Some(ValidationSkip::NotTheDot { by_laser_m: 1.234, on_target_m: 2.0 }.into()),
            ..PhotoValidation::default()
        };
        let v = serde_json::to_value(&p).unwrap();
        assert_eq!(
            v["reason"],
            "the best dot-like blob gives 1.23 m by the laser but lies on the target at 2.00 m: not the dot, or a badly wrong calibration"
        );
        assert!(v["pass"].is_null() && v.get("ends_px").is_none());
        let back: PhotoValidation = serde_json::from_value(v.clone()).unwrap();
        assert_eq!(serde_json::to_value(&back).unwrap(), v);
        assert!(matches!(back.outcome(), ValidationOutcome::Skipped(_)));

        let c = PhotoCheck {
            file: "b.jpg".into(),
            reason: Some(
                CheckSkip::NoDot(DotOnLineError::Ambiguous {
                    candidates_px: vec![[10.0, 20.0], [30.4, 40.6]],
                    lookalikes: 0,
                    hiding_px: Vec::new(),
                })
                .into(),
            ),
            ..PhotoCheck::default()
        };
        let v = serde_json::to_value(&c).unwrap();
        assert_eq!(v["reason"], "2 dot-like blobs on the calibrated laser's image and none clearly the dot, at (10, 20), (30, 41); give the dot by hand");
        assert!(v.get("direction_change_deg").is_none());
        let back: PhotoCheck = serde_json::from_value(v.clone()).unwrap();
        assert_eq!(serde_json::to_value(&back).unwrap(), v);
        assert_eq!(serde_json::to_value(LengthRule::FrontoParallel).unwrap(), LengthRule::FrontoParallel.as_str());
    }

    /// A spot standing in for the blob it was found in names that blob's core beside its
    /// own: the size its `too-large` refusal judged. A blob measured whole names none.
    #[test]
    fn a_stand_in_spot_names_the_core_of_the_blob_it_stands_in_for() {
        use crate::dot::candidates::DotCandidate;
        use crate::dot::on_line::LineCandidate;
        use crate::dot::on_target::hand_candidate;
        let at = Vec2::new(100.0, 100.0);
        let fin = DotCandidate { core_radius_px: 18.8, ..hand_candidate(at) };
        let spot = DotCandidate { core_radius_px: 4.0, enclosed_by: Some(Box::new(fin)), ..hand_candidate(at) };
        let gate = fslcal_core::LineGate {
            depth_m: 2.0,
            along_laser_m: 2.0,
            offset_px: 0.0,
            line_sigma_px: 0.5,
            sigma_px: 1.0,
            chi2: 0.0,
            implied_turn_rad: 0.0,
        };
        let stand_in = LineCandidate {
            candidate: spot,
            gate,
            misfit: Some(Refusal::TooLarge),
            sensitive: false,
            colour_sigmas: None,
            photo_scale: 1.0,
        };
        let v = serde_json::to_value(CandidateCheck::of(&stand_in, stand_in.misfit)).unwrap();
        assert_eq!((v["core_radius_px"].as_f64(), v["enclosing_core_radius_px"].as_f64()), (Some(4.0), Some(18.8)));
        assert_eq!(v["refused"], "too-large");
        let whole =
            LineCandidate { candidate: DotCandidate { enclosed_by: None, ..stand_in.candidate.clone() }, ..stand_in };
        assert!(serde_json::to_value(CandidateCheck::of(&whole, None)).unwrap()["enclosing_core_radius_px"].is_null());
    }
}
