//! The camera result: what `fslcal camera --json` prints.

use super::{schema_version_1, CameraJson, XOfN};
use crate::camera::outcome::CameraPhotoReport;
use serde::{Deserialize, Serialize};

/// How the standard deviations are meant (written into the document beside them).
pub const SIGMA_CONVENTION: &str = "1-sigma: sqrt(diag((JtJ)^-1) * s2) with s2 the noise variance per residual coordinate (sum of squares / (2N - P)); OpenCV 4.6's stdDeviationsIntrinsics divide by N - P (N points) and are larger by sqrt((2N - P)/(N - P)), about 1.41";

/// 1-sigma of each intrinsic: pixels for the focal lengths and the principal point,
/// unitless for the distortion coefficients.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct IntrinsicsSigma {
    pub fx: f64,
    pub fy: f64,
    pub cx: f64,
    pub cy: f64,
    pub k1: f64,
    pub k2: f64,
    pub p1: f64,
    pub p2: f64,
    pub k3: f64,
}

impl From<[f64; 9]> for IntrinsicsSigma {
    /// From fx, fy, cx, cy, k1, k2, p1, p2, k3 (OpenCV's order).
    fn from(s: [f64; 9]) -> Self {
        IntrinsicsSigma { fx: s[0], fy: s[1], cx: s[2], cy: s[3], k1: s[4], k2: s[5], p1: s[6], p2: s[7], k3: s[8] }
    }
}

/// Corners and photos left out of the final solve.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CameraOutliers {
    /// Outlier corners of the used photos' corners.
    pub corners: XOfN,
    /// Rejected photos of the photos with a board.
    pub photos: XOfN,
    /// A corner was an outlier beyond this many of its photo's robust sigmas.
    pub corner_k_sigma: f64,
}

/// How much of the frame the used boards cover.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CoverageJson {
    /// Share of the image area inside at least one used board's outline, 0 to 1.
    pub share: f64,
    /// Frame corners ("top-left", ...) with no detected corner near them.
    pub uncovered_frame_corners: Vec<String>,
}

/// `fslcal camera`'s result.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct CameraDocument {
    #[serde(default = "schema_version_1")]
    pub schema_version: u32,
    /// The board as given (`checkerboard:14x10@42.17mm`).
    pub board: String,
    pub camera: CameraJson,
    /// RMS reprojection error per point over the corners in the solve, pixels.
    pub rms_px: f64,
    /// The worst corner in the solve, pixels, and its photo.
    pub worst_px: f64,
    pub worst_file: String,
    pub sigma: IntrinsicsSigma,
    pub sigma_convention: String,
    /// OpenCV 4.6's `stdDeviationsIntrinsics` as returned (fx, fy, cx, cy, k1, k2, p1, p2, k3).
    pub opencv_std_deviations_intrinsics: [f64; 9],
    /// Corners in the final solve, and the solve's free parameters.
    pub points: usize,
    pub free_parameters: usize,
    pub outliers: CameraOutliers,
    pub coverage: CoverageJson,
    /// Solves run (1 when nothing was culled).
    pub solves: usize,
    pub photos: Vec<CameraPhotoReport>,
}

#[cfg(feature = "vision")]
impl CameraDocument {
    /// The document of a calibration with `board` as given.
    pub fn new(board: String, cal: &crate::camera::calibrate::CameraCalibration) -> Self {
        CameraDocument {
            schema_version: super::SCHEMA_VERSION,
            board,
            camera: CameraJson::from(&cal.camera),
            rms_px: cal.rms_px,
            worst_px: cal.worst_px,
            worst_file: cal.photos[cal.worst_photo].file.clone(),
            sigma: cal.sigma.into(),
            sigma_convention: SIGMA_CONVENTION.into(),
            opencv_std_deviations_intrinsics: cal.opencv_std_dev,
            points: cal.points,
            free_parameters: cal.free_parameters,
            outliers: CameraOutliers {
                corners: cal.corner_outliers.into(),
                photos: cal.photo_outliers.into(),
                corner_k_sigma: cal.k_corner,
            },
            coverage: CoverageJson {
                share: cal.coverage.share,
                uncovered_frame_corners: cal.coverage.uncovered_frame_corners.iter().map(|c| c.to_string()).collect(),
            },
            solves: cal.solves,
            photos: cal.photos.clone(),
        }
    }
}
