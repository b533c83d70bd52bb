//! What the laser chain says about each photo and about the fit: a photo's status and why it
//! was skipped, where its dot came from, and the gates a fit must pass.
//!
//! These are the per-photo lines and gates of `fslcal laser --json` as well (see
//! `documents::laser`), so they build without the `vision` feature: a calibration is read
//! back by commands that need no OpenCV.

use crate::reason::{named_status, Reason};
use fslcal_core::{Plane, Vec2};
use serde::{Deserialize, Serialize};
use std::fmt;

/// Largest RMS reprojection error of a checkerboard's corners from its solved pose, pixels:
/// beyond it the camera file is wrong or the board is bent.
pub const MAX_BOARD_RMS_PX: f64 = 2.0;

/// Where a photo's dot came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum DotSource {
    Detected,
    /// Found by the second, more sensitive search near the first fit's prediction.
    DetectedNearPrediction,
    Hand,
}

impl DotSource {
    /// The name as the JSON and the tables write it.
    pub fn as_str(self) -> &'static str {
        match self {
            DotSource::Detected => "detected",
            DotSource::DetectedNearPrediction => "detected-near-prediction",
            DotSource::Hand => "hand",
        }
    }
}

/// Whether a photo's dot went into the fit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PhotoStatus {
    Used,
    /// Left out, with a [`SkipReason`].
    Skipped,
}
named_status!(PhotoStatus { Used => "used", Skipped => "skipped" });

/// Why a photo's target cannot be used: the photo or the target is not there, or its pose
/// cannot be trusted. Shared by `fslcal laser` and `fslcal validate`.
#[derive(Clone, Debug, PartialEq)]
pub enum TargetMiss {
    /// The photo cannot be read or decoded; `detail` is the reader's message without the path.
    Unreadable { detail: String },
    /// OpenCV or the decoder failed on a photo that was read; its message without the path.
    Vision { detail: String },
    /// No checkerboard of this many inner corners.
    NoCheckerboard { cols: u32, rows: u32 },
    /// The slate's features did not match (too few or too weak); the matcher's words.
    NoSlate { detail: String },
    /// The slate matched, but its pose is not believable; the matcher's words.
    SlatePose { detail: String },
    /// OpenCV's sub-pixel corner refinement failed; its message.
    CornerRefinement { detail: String },
    /// No pose puts the board in front of the camera.
    PoseUnsolved,
    /// The board's corners reproject this far from its pose (over [`MAX_BOARD_RMS_PX`]).
    CornersReproject { rms_px: f64 },
}

impl fmt::Display for TargetMiss {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            TargetMiss::Unreadable { detail } => write!(f, "unreadable: {detail}"),
            TargetMiss::Vision { detail } | TargetMiss::NoSlate { detail } | TargetMiss::SlatePose { detail } => {
                f.write_str(detail)
            }
            TargetMiss::NoCheckerboard { cols, rows } => {
                write!(f, "no {cols}x{rows} checkerboard found (the whole board must be in the frame)")
            }
            TargetMiss::CornerRefinement { detail } => write!(f, "corner refinement failed: {detail}"),
            TargetMiss::PoseUnsolved => f.write_str("the board's pose could not be solved (check the camera file)"),
            TargetMiss::CornersReproject { rms_px } => write!(
                f,
                "the board's corners reproject {rms_px:.1} px RMS from their pose (limit {MAX_BOARD_RMS_PX} px): wrong camera file or a bent board"
            ),
        }
    }
}

/// Why the robust fit left a photo's dot out.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Outlier {
    /// The dot lies this far from the fitted line's image, beyond the gate.
    OffLine { residual_px: f64, gate_px: f64 },
}

impl fmt::Display for Outlier {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Outlier::OffLine { residual_px, gate_px } => write!(
                f,
                "dot {residual_px:.1} px off the fitted laser line (gate {gate_px:.1} px): a reflection, a glint or a mislabelled dot"
            ),
        }
    }
}

impl Serialize for Outlier {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(self)
    }
}

/// Why a photo's dot is not in the fit.
#[derive(Clone, Debug, PartialEq)]
pub enum SkipReason {
    /// No usable target in the photo.
    Target(TargetMiss),
    /// The target was found, but no dot-like blob on it.
    NoDotOnTarget,
    /// Blobs were found, but the fit could use none of them.
    NoUsableDot,
    /// Two blobs lie on the laser's image, too close to the line to tell which is the dot:
    /// withheld rather than guessed.
    AmbiguousDot { candidates: usize },
    /// The fit was refused, so no photo was fitted.
    NotFitted,
    /// The robust fit left the dot out.
    Outlier(Outlier),
}

impl fmt::Display for SkipReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SkipReason::Target(miss) => miss.fmt(f),
            SkipReason::NoDotOnTarget => f.write_str("no laser dot found on the target"),
            SkipReason::NoUsableDot => f.write_str("no usable dot"),
            SkipReason::AmbiguousDot { candidates } => write!(
                f,
                "ambiguous: {candidates} dot-like blobs on the laser's image, none clearly the dot (give it by hand)"
            ),
            SkipReason::NotFitted => f.write_str("not fitted (the fit was refused)"),
            SkipReason::Outlier(why) => write!(f, "outlier: {why}"),
        }
    }
}

/// Where a photo's target was seen: what the HTML report draws on the thumbnail.
#[derive(Clone, Debug)]
pub struct BoardInImage {
    /// The physical target's outline from its pose, padded as the dot search is, pixels.
    pub outline_px: Vec<Vec2>,
    /// A checkerboard's inner corners as refined (a slate has none), pixels.
    pub corners_px: Vec<Vec2>,
    /// The target's plane from its pose, camera frame.
    pub plane: Plane,
}

/// One photo's line of the result (`photos` in `fslcal laser --json`).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct PhotoReport {
    pub file: String,
    pub status: PhotoStatus,
    /// Why a skipped photo was skipped (`None` when used).
    pub reason: Option<Reason<SkipReason>>,
    /// The dot, pixels.
    pub dot_px: Option<[f64; 2]>,
    pub dot_source: Option<DotSource>,
    /// Depth of the dot on the board, metres.
    pub distance_m: Option<f64>,
    /// Dot's offset from the fitted line's image, pixels.
    pub residual_px: Option<f64>,
    /// RMS reprojection error of the board's corners for this photo's pose, pixels.
    pub board_rms_px: Option<f64>,
    /// The board as detected, when it was; kept for the HTML report, not the JSON.
    #[serde(skip)]
    pub board: Option<BoardInImage>,
    /// Feature inliers of a slate's match (checkerboards: none).
    pub target_inliers: Option<usize>,
    /// Every dot-like blob the search found on the target, and what the consensus over
    /// photos made of it (absent in files written before; empty for a hand-given dot).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub candidates: Vec<CandidateReport>,
}

/// What the consensus over photos made of one candidate.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CandidateRole {
    /// On the line most photos agree on: the photo's dot.
    Chosen,
    /// Off that line, but so strong a dot that the fit judges it (an outlier if the laser
    /// has not moved).
    StrongOffLine,
    /// On the line's image with another blob as close: the photo is withheld.
    Ambiguous,
    /// Off the line: a glint, a reflection, tape or texture.
    OffLine,
    /// No consensus line was found (the fit decided alone).
    Undecided,
}

/// One candidate as the report lists it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CandidateReport {
    pub px: [f64; 2],
    /// Contrast along the laser's colour over the local background less its off-colour
    /// part, noise sigmas.
    pub colour_score: f64,
    /// Angle between its chroma and the laser's, degrees.
    pub colour_angle_deg: f64,
    /// Matched-filter SNR, peak contrast (8-bit levels) and equivalent radius (px).
    pub snr: f64,
    pub peak_levels: f64,
    pub radius_px: f64,
    /// Pixels of its core with the laser's channel clipped.
    pub saturated_px: usize,
    /// Distance from the consensus line's image on this photo's target, pixels.
    pub line_offset_px: Option<f64>,
    pub role: CandidateRole,
}

impl PhotoReport {
    /// A photo's line with nothing measured yet: skipped when there is a reason to, used
    /// otherwise.
    pub fn new(file: String, skip: Option<Reason<SkipReason>>) -> Self {
        PhotoReport {
            file,
            status: if skip.is_some() { PhotoStatus::Skipped } else { PhotoStatus::Used },
            reason: skip,
            dot_px: None,
            dot_source: None,
            distance_m: None,
            residual_px: None,
            board_rms_px: None,
            board: None,
            target_inliers: None,
            candidates: Vec::new(),
        }
    }

    /// The status as the tables show it: a used photo with where its dot came from, a
    /// skipped one with its reason.
    pub fn status_text(&self) -> String {
        match (&self.reason, self.dot_source) {
            (Some(r), _) => format!("{}: {r}", self.status),
            (None, Some(src)) => format!("{} ({})", self.status, src.as_str()),
            (None, None) => self.status.to_string(),
        }
    }
}

/// The gates a careful lab applies to a laser fit before trusting it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Gate {
    #[serde(rename = "photos used")]
    PhotosUsed,
    #[serde(rename = "dot span along the laser")]
    DotSpan,
    #[serde(rename = "camera-to-laser baseline")]
    Baseline,
    #[serde(rename = "worst used dot off the line")]
    WorstDotOffset,
    #[serde(rename = "outlier photos")]
    OutlierPhotos,
}

impl Gate {
    /// The gate's name as the summary, the report and the JSON write it.
    pub fn as_str(self) -> &'static str {
        match self {
            Gate::PhotosUsed => "photos used",
            Gate::DotSpan => "dot span along the laser",
            Gate::Baseline => "camera-to-laser baseline",
            Gate::WorstDotOffset => "worst used dot off the line",
            Gate::OutlierPhotos => "outlier photos",
        }
    }
}

impl fmt::Display for Gate {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.pad(self.as_str())
    }
}

/// One gate with its figure and limit, as people read them ("3.86 m", ">= 0.60 m").
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GateResult {
    pub name: Gate,
    pub figure: String,
    pub limit: String,
    pub pass: bool,
}

impl GateResult {
    /// A failed gate in one phrase: "camera-to-laser baseline 112.3 mm (limit 50.0-60.0 mm)".
    pub fn failure_text(&self) -> String {
        format!("{} {} (limit {})", self.name, self.figure, self.limit)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_what_the_json_always_said() {
        for g in [Gate::PhotosUsed, Gate::DotSpan, Gate::Baseline, Gate::WorstDotOffset, Gate::OutlierPhotos] {
            assert_eq!(serde_json::to_value(g).unwrap(), g.as_str());
            assert_eq!(serde_json::from_value::<Gate>(g.as_str().into()).unwrap(), g);
        }
        for d in [DotSource::Detected, DotSource::DetectedNearPrediction, DotSource::Hand] {
            assert_eq!(serde_json::to_value(d).unwrap(), d.as_str());
        }
        let outlier = SkipReason::Outlier(Outlier::OffLine { residual_px: 537.31, gate_px: 4.0 });
        assert_eq!(
            outlier.to_string(),
            "outlier: dot 537.3 px off the fitted laser line (gate 4.0 px): a reflection, a glint or a mislabelled dot"
        );
        let miss = SkipReason::Target(TargetMiss::CornersReproject { rms_px: 2.345 });
        assert_eq!(
            miss.to_string(),
            "the board's corners reproject 2.3 px RMS from their pose (limit 2 px): wrong camera file or a bent board"
        );
    }

    #[test]
    fn a_photo_line_reads_back_what_it_wrote() {
        let why = SkipReason::Target(TargetMiss::NoCheckerboard { cols: 14, rows: 10 });
        let p = PhotoReport::new("a.jpg".into(), Some(why.into()));
        let v = serde_json::to_value(&p).unwrap();
        assert_eq!(v["status"], "skipped");
        assert_eq!(v["reason"], "no 14x10 checkerboard found (the whole board must be in the frame)");
        let back: PhotoReport = serde_json::from_value(v.clone()).unwrap();
        assert_eq!(serde_json::to_value(&back).unwrap(), v);
        assert_eq!(p.status_text(), "skipped: no 14x10 checkerboard found (the whole board must be in the frame)");
    }
}
