//! What the camera chain says about each photo: used in the solve, rejected as an outlier,
//! or without the board; the lines of `fslcal camera --json` (see `documents::camera`).

use crate::reason::named_status;
use fslcal_core::Vec2;
use serde::{Deserialize, Serialize};

/// What became of a photo in the intrinsics solve.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CameraPhotoStatus {
    Used,
    /// An outlier photo: its corners disagree with the rest.
    Rejected,
    /// The board was not found in it.
    NoBoard,
}
named_status!(CameraPhotoStatus { Used => "used", Rejected => "rejected", NoBoard => "no board" });

impl CameraPhotoStatus {
    /// The status as the summary and the report explain it.
    pub fn explained(self) -> &'static str {
        match self {
            CameraPhotoStatus::Rejected => "rejected: an outlier photo (its corners disagree with the rest)",
            other => other.as_str(),
        }
    }
}

/// One photo's line in the report.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct CameraPhotoReport {
    pub file: String,
    pub status: CameraPhotoStatus,
    /// RMS over the corners in the solve (used) or over all its corners from its own pose
    /// under the final camera (rejected), pixels per point.
    pub rms_px: Option<f64>,
    pub worst_px: Option<f64>,
    pub corners_used: Option<usize>,
    pub corners_found: Option<usize>,
    /// Residual length beyond which this photo's corners were outliers, pixels.
    pub corner_limit_px: Option<f64>,
    /// The corners as detected, with their residuals; kept for the HTML report, not the JSON.
    #[serde(skip)]
    pub corners: Option<CornerResiduals>,
}

impl CameraPhotoReport {
    /// A photo in which the board was not found.
    pub fn no_board(file: String) -> Self {
        CameraPhotoReport {
            file,
            status: CameraPhotoStatus::NoBoard,
            rms_px: None,
            worst_px: None,
            corners_used: None,
            corners_found: None,
            corner_limit_px: None,
            corners: None,
        }
    }
}

/// One photo's detected corners (row by row) with their residuals under the final camera:
/// observed minus projected, pixels, from the solve's pose (used photos) or the photo's own
/// pose (rejected photos).
#[derive(Clone, Debug)]
pub struct CornerResiduals {
    pub corners_px: Vec<Vec2>,
    pub residuals_px: Vec<Vec2>,
    /// Whether each corner was in the final solve.
    pub inlier: Vec<bool>,
}
