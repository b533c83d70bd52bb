//! The laser result: what `fslcal laser --json` prints and `--out FILE.json` writes, and
//! what `--cal FILE.json` reads back.
//!
//! Reading needs only `camera` and `laser`'s `origin_m`, `direction` and `covariance`: a
//! calibration written before `schema_version` existed (version 1), or put together by
//! hand from another tool's numbers, is still a calibration. The fit's report (method,
//! outliers, gates, photos, EXIF) reads as absent where it does not parse: its vocabulary
//! (gate names, statuses) may grow, and an old file is a user's calibration all the same.

use super::{report_part, schema_version_1, CameraJson, XOfN};
use crate::laser::fit::Method;
use crate::laser::outcome::{GateResult, PhotoReport};
use crate::photo::exif::PhotoExif;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// The order of the rows and columns of `laser.covariance`.
pub const COVARIANCE_PARAMETERS: [&str; 4] = ["origin_x_m", "origin_y_m", "direction_x_over_z", "direction_y_over_z"];

/// The fitted laser line, camera frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LaserLineJson {
    /// Where the line crosses the camera's z = 0 plane, metres.
    pub origin_m: [f64; 3],
    /// Unit direction, pointing away from the camera (z > 0).
    pub direction: [f64; 3],
    /// Distance of the origin from the optical axis, metres.
    pub baseline_m: Option<f64>,
    pub angle_to_optical_axis_deg: Option<f64>,
    /// Covariance of [`COVARIANCE_PARAMETERS`]: metres and unitless slopes.
    pub covariance: [[f64; 4]; 4],
    /// The names of the covariance's rows and columns, in order.
    #[serde(default)]
    pub covariance_parameters: Vec<String>,
}

/// The laser's colour as the laser result records it (the signed unit file's
/// `laser_colour`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct LaserColourJson {
    pub rgb: [f64; 3],
    pub spread_rad: f64,
    pub dots: u16,
    /// The camera's tone curve the colour was measured through (`ToneCurve`); 1 (linear)
    /// in results written before it was learned.
    #[serde(default = "linear_tone")]
    pub tone_gamma: f64,
    /// Why the photos were read through `tone_gamma` rather than as linear, when `fslcal
    /// laser` learned it (absent when read as linear, and in older results).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tone_retry: Option<ToneRetryJson>,
}

/// Why a calibration read as linear was read again through camera tone curves.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "why")]
pub enum ToneRetryJson {
    /// The linear reading's fit was refused.
    LinearRefused,
    /// The linear reading's dots spread this much in colour, radians.
    LinearScattered { spread_rad: f64 },
}

fn linear_tone() -> f64 {
    1.0
}

/// `fslcal laser`'s result. The fit's figures are optional when read (see the module
/// documentation); the command always writes them.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct LaserDocument {
    #[serde(default = "schema_version_1")]
    pub schema_version: u32,
    /// The camera file as given on the command line.
    pub camera_file: Option<String>,
    /// The intrinsics themselves, so that the result alone is a usable `--cal`.
    pub camera: CameraJson,
    /// The target as given (`checkerboard:14x10@42.17mm`, `slate:PATH.toml`).
    pub target: Option<String>,
    #[serde(default, deserialize_with = "report_part")]
    pub method: Option<Method>,
    pub laser: LaserLineJson,
    /// The used dots' offsets from the fitted line's image: RMS and worst, pixels.
    pub residual_rms_px: Option<f64>,
    pub residual_worst_px: Option<f64>,
    /// The same offsets on the target, millimetres.
    pub residual_rms_mm: Option<f64>,
    pub residual_worst_mm: Option<f64>,
    /// Extent of the used dots along the laser, metres.
    pub span_m: Option<f64>,
    /// Depths of the used dots, metres: distances outside are extrapolation.
    pub depth_range_m: Option<(f64, f64)>,
    /// Predicted 1-sigma distance error from the calibration alone, metres, by depth in
    /// metres (`"1"`, `"3"`, `"5"`).
    #[serde(default)]
    pub predicted_distance_sigma_m: BTreeMap<String, f64>,
    /// Photos whose dot disagreed with the line, of the photos with a dot.
    #[serde(default, deserialize_with = "report_part")]
    pub outliers: Option<XOfN>,
    #[serde(default, deserialize_with = "report_part")]
    pub gates: Vec<GateResult>,
    /// Every gate passed.
    pub accepted: Option<bool>,
    #[serde(default, deserialize_with = "report_part")]
    pub photos: Vec<PhotoReport>,
    /// The camera body serial the photos agree on (EXIF), so `--cal` users can refuse
    /// another body's photos.
    pub camera_serial: Option<String>,
    /// The focal length the photos agree on (EXIF), millimetres: another means the zoom.
    pub focal_length_mm: Option<f64>,
    /// Each photo's EXIF, in the order of `photos`; `null` for a photo without EXIF.
    #[serde(default, deserialize_with = "report_part")]
    pub photo_exif: Vec<Option<PhotoExif>>,
    /// The laser's colour learned from the used dots: unit (R, G, B) of a dot's excess over
    /// its background, the 1-sigma spread of the dots' chroma around it, and how many dots
    /// (absent when fewer than three detected dots were used, and in older files).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub laser_colour: Option<LaserColourJson>,
    /// `FSL-NN`: never written by `fslcal laser`, read when a hand-made file names its unit.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub unit: Option<String>,
    /// The `--dots` file, as read (written only when one was given).
    #[serde(default, skip_serializing_if = "Option::is_none", deserialize_with = "report_part")]
    pub dots_file: Option<DotsFileJson>,
    /// The lab's own `fsl calibrate-laser` fit on the same dots, beside fslcal's.
    #[serde(default, skip_serializing_if = "Option::is_none", deserialize_with = "report_part")]
    pub lab_equivalent: Option<LabEquivalentJson>,
}

/// What a `--dots` file gave: how it was read and mapped into the camera's pixels.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DotsFileJson {
    /// The file as given.
    pub file: String,
    /// `csv` or `label-studio`.
    pub format: String,
    /// Label Studio: tasks in the export; CSV: dot rows.
    pub entries: usize,
    /// Dots read (one per photo).
    pub dots: usize,
    /// Of those, the ones that name a photo of the run (used instead of detection).
    pub matched: usize,
    /// Photos named by a dot but not given.
    pub unmatched: Vec<String>,
    /// Label Studio: the keypoint label taken for the dot.
    pub label: Option<String>,
    /// The frames the dots were clicked in, each with its dot count and the shift into the
    /// camera's pixels.
    pub frames: Vec<DotsFrameJson>,
    /// `as-shot`, or `undistorted` (clicked on images undistorted with the camera's lens,
    /// distorted back before use).
    pub image: String,
    /// Photos with several annotations of which the newest was used.
    pub newest_of_several: Vec<String>,
    /// Label Studio tasks that gave no dot, and why.
    pub skipped: Vec<SkippedTaskJson>,
}

/// One frame dots were clicked in.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DotsFrameJson {
    /// `WxH`, pixels.
    pub size: String,
    pub dots: usize,
    /// Added to each dot to put it in the camera's pixels, `[x, y]`.
    pub shift_px: [f64; 2],
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SkippedTaskJson {
    /// `task 138992 (P2100001.JPG)`.
    pub task: String,
    pub why: String,
}

/// The lab's `fsl calibrate-laser` fit (the averaging fit on every dot, none left out) on
/// the dots fslcal used, and how far it lies from fslcal's.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LabEquivalentJson {
    /// Always `average`: the thesis's averaging fit the lab's tool runs.
    pub method: String,
    /// Dots it was fitted on (every photo with a dot on its target).
    pub dots: usize,
    /// Of those, the ones fslcal left out as outliers.
    pub left_out_by_fslcal: usize,
    pub origin_m: [f64; 3],
    pub direction: [f64; 3],
    pub baseline_m: f64,
    /// Angle between its direction and fslcal's, degrees.
    pub angle_deg: f64,
    /// Distance between the two origins, millimetres.
    pub origin_difference_mm: f64,
    /// For a dot fslcal puts at depth 1, 3, 5 m (`"1"`, `"3"`, `"5"`): the lab's depth for
    /// the same pixel minus fslcal's, metres (null where it has none).
    pub distance_difference_m: BTreeMap<String, Option<f64>>,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A laser result as fslcal wrote them before `schema_version` (trimmed to two photos).
    const BEFORE_SCHEMA_VERSION: &str = r#"{
  "accepted": true,
  "camera": {"cx": 2004.5, "cy": 1497.0, "dist": [-0.18, 0.09, 0.0006, -0.0004, -0.02], "fx": 2950.0, "fy": 2948.0, "image_size": [4000, 3000]},
  "camera_file": "camera.yml",
  "camera_serial": null,
  "depth_range_m": [0.5999907568192774, 4.457698369901542],
  "focal_length_mm": null,
  "gates": [{"figure": "15", "limit": ">= 3", "name": "photos used", "pass": true}],
  "laser": {
    "angle_to_optical_axis_deg": 1.3951, "baseline_m": 0.1123,
    "covariance": [[1e-9, 0.0, 0.0, 0.0], [0.0, 1e-9, 0.0, 0.0], [0.0, 0.0, 1e-10, 0.0], [0.0, 0.0, 0.0, 1e-10]],
    "covariance_parameters": ["origin_x_m", "origin_y_m", "direction_x_over_z", "direction_y_over_z"],
    "direction": [0.01048, 0.02196, 0.9997], "origin_m": [-0.04, -0.105, 0.0]
  },
  "method": "reprojection",
  "outliers": "0 of 15",
  "photo_exif": [null, null],
  "photos": [
    {"board_rms_px": 0.05, "distance_m": 0.6, "dot_px": [1839.5, 1048.2], "dot_source": "detected", "file": "photo_00.jpg", "reason": null, "residual_px": 0.07, "status": "used", "target_inliers": null},
    {"board_rms_px": null, "distance_m": null, "dot_px": null, "dot_source": null, "file": "photo_16.jpg", "reason": "no 14x10 checkerboard found (the whole board must be in the frame)", "residual_px": null, "status": "skipped", "target_inliers": null}
  ],
  "predicted_distance_sigma_m": {"1": 0.0001, "3": 0.0012, "5": 0.004},
  "residual_rms_mm": 0.26, "residual_rms_px": 0.22, "residual_worst_mm": 0.61, "residual_worst_px": 0.46,
  "span_m": 3.86,
  "target": "checkerboard:14x10@42.17mm"
}"#;

    #[test]
    fn a_result_from_before_schema_version_reads_as_version_1_and_writes_back_the_same() {
        let doc: LaserDocument = serde_json::from_str(BEFORE_SCHEMA_VERSION).unwrap();
        assert_eq!(doc.schema_version, 1);
        assert_eq!(doc.outliers, Some(XOfN(0, 15)));
        assert_eq!(doc.photos[1].status, "skipped");
        assert_eq!(doc.gates[0].name.as_str(), "photos used");
        let mut again = serde_json::to_value(&doc).unwrap();
        assert_eq!(again["schema_version"], 1);
        again.as_object_mut().unwrap().remove("schema_version");
        let before: serde_json::Value = serde_json::from_str(BEFORE_SCHEMA_VERSION).unwrap();
        assert_eq!(again, before);
    }

    #[test]
    fn a_report_in_words_this_build_does_not_know_still_reads_as_a_calibration() {
        let mut v: serde_json::Value = serde_json::from_str(BEFORE_SCHEMA_VERSION).unwrap();
        v["gates"][0]["name"] = "a gate of a later version".into();
        v["photos"][0]["status"] = "maybe".into();
        v["method"] = "a later method".into();
        let doc: LaserDocument = serde_json::from_value(v).unwrap();
        assert!(doc.gates.is_empty() && doc.photos.is_empty() && doc.method.is_none());
        assert_eq!(doc.laser.origin_m, [-0.04, -0.105, 0.0]);
        assert_eq!(doc.outliers, Some(XOfN(0, 15)));
    }

    #[test]
    fn why_a_tone_curve_was_read_is_tagged_and_absent_when_read_as_linear() {
        let colour = |tone_retry| LaserColourJson {
            rgb: [0.6, 0.8, 0.0],
            spread_rad: 0.07,
            dots: 7,
            tone_gamma: 1.8,
            tone_retry,
        };
        let scattered =
            serde_json::to_value(colour(Some(ToneRetryJson::LinearScattered { spread_rad: 0.12 }))).unwrap();
        assert_eq!(scattered["tone_retry"], serde_json::json!({"why": "linear_scattered", "spread_rad": 0.12}));
        let refused = serde_json::to_value(colour(Some(ToneRetryJson::LinearRefused))).unwrap();
        assert_eq!(refused["tone_retry"], serde_json::json!({"why": "linear_refused"}));
        let linear = serde_json::to_value(colour(None)).unwrap();
        assert!(linear.get("tone_retry").is_none(), "{linear}");
        let back: LaserColourJson = serde_json::from_value(scattered).unwrap();
        assert_eq!(back.tone_retry, Some(ToneRetryJson::LinearScattered { spread_rad: 0.12 }));
    }
}
