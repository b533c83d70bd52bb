//! The FishSense lab's HTTP API bodies for a unit's calibration: `CameraIntrinsics` (one per
//! camera) and `LaserExtrinsics` (one per dive), field for field as the lab's API models
//! take and return them (UCSD-E4E/fishsense-api, `models/camera_intrinsics.py` and
//! `models/laser_extrinsics.py`; the SDK's `_CameraIntrinsics` has the same fields).
//!
//! - `CameraIntrinsics`: `id` (int or null), `camera_matrix` (3x3 list of lists, row by
//!   row, pixels), `distortion_coefficients` (list, OpenCV's order), `camera_id` (int).
//! - `LaserExtrinsics`: `id` (int or null), `laser_position` (3 numbers, metres),
//!   `laser_axis` (3 numbers, unit), `created_at` (ISO 8601 with a zone, or null),
//!   `dive_id` (int or null), `camera_id` (int).
//!
//! Numbers go through serde_json with `float_roundtrip`: read exactly, written in the
//! shortest form that reads back to the same bits, as Python's `json` writes floats. The
//! ids are the database's; fslcal's signed file does not keep them, so `fslcal export`
//! takes them as options and writes `id: null` (a new row).

use serde::{Deserialize, Serialize};

/// The field names of the lab's `CameraIntrinsics` model, in its order.
pub const CAMERA_INTRINSICS_FIELDS: [&str; 4] = ["id", "camera_matrix", "distortion_coefficients", "camera_id"];
/// The field names of the lab's `LaserExtrinsics` model, in its order.
pub const LASER_EXTRINSICS_FIELDS: [&str; 6] =
    ["id", "laser_position", "laser_axis", "created_at", "dive_id", "camera_id"];

/// A camera's intrinsics as the lab's API keeps them.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraIntrinsics {
    #[serde(default)]
    pub id: Option<i64>,
    /// Row-major 3x3: `[[fx, 0, cx], [0, fy, cy], [0, 0, 1]]`, pixels.
    pub camera_matrix: [[f64; 3]; 3],
    /// OpenCV's `[k1, k2, p1, p2, k3, ...]`.
    pub distortion_coefficients: Vec<f64>,
    #[serde(default)]
    pub camera_id: Option<i64>,
}

/// A dive's laser calibration as the lab's API keeps it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LaserExtrinsics {
    #[serde(default)]
    pub id: Option<i64>,
    /// Where the beam crosses the camera's z = 0 plane, metres.
    pub laser_position: [f64; 3],
    /// Unit direction of the beam, camera frame.
    pub laser_axis: [f64; 3],
    /// When it was made: ISO 8601 with a zone (`2025-02-10T18:32:05+00:00`).
    #[serde(default)]
    pub created_at: Option<String>,
    #[serde(default)]
    pub dive_id: Option<i64>,
    #[serde(default)]
    pub camera_id: Option<i64>,
}

/// Which of the two bodies a JSON file holds.
#[derive(Clone, Debug, PartialEq)]
pub enum ApiBody {
    Intrinsics(CameraIntrinsics),
    Extrinsics(LaserExtrinsics),
}

#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ApiError {
    #[error("not JSON ({0})")]
    Json(String),
    #[error("a JSON object with neither `camera_matrix` (the lab's CameraIntrinsics) nor `laser_position` (its LaserExtrinsics)")]
    Neither,
    #[error("not the lab's {model} body: {why} (its fields are {fields})")]
    Fields { model: &'static str, why: String, fields: String },
}

impl ApiBody {
    /// Reads one body, telling the two apart by their fields. Unknown fields are refused:
    /// a body fslcal would read only in part is not the model it claims to be.
    pub fn parse(text: &str) -> Result<ApiBody, ApiError> {
        let v: serde_json::Value = serde_json::from_str(text).map_err(|e| ApiError::Json(e.to_string()))?;
        let has = |k: &str| v.get(k).is_some();
        fn fields(model: &'static str, names: &'static [&'static str]) -> impl Fn(serde_json::Error) -> ApiError {
            move |e| ApiError::Fields { model, why: e.to_string(), fields: names.join(", ") }
        }
        if has("camera_matrix") {
            serde_json::from_value(v)
                .map(ApiBody::Intrinsics)
                .map_err(fields("CameraIntrinsics", &CAMERA_INTRINSICS_FIELDS))
        } else if has("laser_position") || has("laser_axis") {
            serde_json::from_value(v)
                .map(ApiBody::Extrinsics)
                .map_err(fields("LaserExtrinsics", &LASER_EXTRINSICS_FIELDS))
        } else {
            Err(ApiError::Neither)
        }
    }
}

impl CameraIntrinsics {
    /// The camera matrix row-major, as `.pkg` files and `camera_from_opencv` take it.
    pub fn matrix_row_major(&self) -> [f64; 9] {
        let k = &self.camera_matrix;
        [k[0][0], k[0][1], k[0][2], k[1][0], k[1][1], k[1][2], k[2][0], k[2][1], k[2][2]]
    }
}

/// Whether `text` holds a JSON object (an API body) rather than a `.pkg` archive.
pub fn looks_like_json_object(bytes: &[u8]) -> bool {
    bytes.iter().find(|b| !b.is_ascii_whitespace()) == Some(&b'{')
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_both_bodies_and_writes_them_back_with_the_same_numbers_and_fields() {
        let ci = r#"{"id": 12, "camera_matrix": [[2911.75123456789, 0.0, 2019.125], [0.0, 2912.5, 1509.0625], [0.0, 0.0, 1.0]],
                     "distortion_coefficients": [-0.11750000000000001, 0.0512, 0.00091, -0.00042, -0.0139], "camera_id": 4}"#;
        let ApiBody::Intrinsics(i) = ApiBody::parse(ci).unwrap() else { panic!() };
        assert_eq!(i.camera_matrix[0][0].to_bits(), 2911.75123456789f64.to_bits());
        assert_eq!(i.distortion_coefficients[0], -0.11750000000000001);
        let back: serde_json::Value = serde_json::to_value(&i).unwrap();
        let keys: Vec<&str> = back.as_object().unwrap().keys().map(String::as_str).collect();
        let mut want = CAMERA_INTRINSICS_FIELDS.to_vec();
        want.sort();
        assert_eq!(keys, want);
        assert_eq!(back, serde_json::from_str::<serde_json::Value>(ci).unwrap());

        let le = r#"{"id": null, "laser_position": [-0.0412, -0.1067, 0.0], "laser_axis": [0.0098, 0.0199, 0.9997538],
                     "created_at": "2025-02-10T18:32:05+00:00", "dive_id": 31, "camera_id": 4}"#;
        let ApiBody::Extrinsics(e) = ApiBody::parse(le).unwrap() else { panic!() };
        assert_eq!(e.dive_id, Some(31));
        assert_eq!(serde_json::to_value(&e).unwrap(), serde_json::from_str::<serde_json::Value>(le).unwrap());
    }

    #[test]
    fn refuses_other_json_naming_the_model_and_its_fields() {
        assert_eq!(ApiBody::parse(r#"{"camera": {}}"#).unwrap_err(), ApiError::Neither);
        let e = ApiBody::parse(r#"{"camera_matrix": [[1, 0, 0], [0, 1, 0]], "distortion_coefficients": []}"#)
            .unwrap_err()
            .to_string();
        assert!(e.contains("CameraIntrinsics") && e.contains("camera_matrix, distortion_coefficients"), "{e}");
        let e = ApiBody::parse(r#"{"laser_position": [0, 0, 0], "laser_axis": [0, 0, 1], "laser_pos_cm": 3}"#)
            .unwrap_err()
            .to_string();
        assert!(e.contains("unknown field `laser_pos_cm`"), "{e}");
        assert!(looks_like_json_object(b"  {\"id\"") && !looks_like_json_object(b"\x1f\x8b"));
    }
}
