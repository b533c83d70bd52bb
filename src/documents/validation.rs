//! The validation report: what `fslcal validate --json` prints and `fslcal units
//! add-validation` files.
//!
//! Filing needs `pass`, `calibration_sha256` (the registry files a report only beside the
//! calibration it validated) and `unit`, unless `--unit` names it: the registry keeps the
//! report's bytes as they are and reads its verdict.

use super::{report_part, schema_version_1};
use crate::calibration::outcome::{LengthRule, PhotoValidation};
use serde::{Deserialize, Serialize};

/// `fslcal validate`'s result. Everything but `pass` is optional when read (see the module
/// documentation); the command always writes it.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ValidationDocument {
    #[serde(default = "schema_version_1")]
    pub schema_version: u32,
    /// The calibration's unit (`FSL-NN`), when the calibration names one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub unit: Option<String>,
    /// The calibration file validated, as given to `--cal`.
    #[serde(default)]
    pub calibration_file: Option<String>,
    /// SHA-256 of the calibration file's bytes, lower-case hex: which calibration this
    /// report is about (a registry shows it only beside that file).
    #[serde(default)]
    pub calibration_sha256: Option<String>,
    /// When the validation ran, ISO 8601 UTC (`2026-06-02T10:15:00Z`).
    #[serde(default)]
    pub validated_utc: Option<String>,
    /// The known length's name.
    pub length: Option<String>,
    /// The known length, millimetres.
    pub true_mm: Option<f64>,
    pub rule: Option<LengthRule>,
    /// A photo passes within ±this, percent.
    pub tolerance_pct: Option<f64>,
    #[serde(default, deserialize_with = "report_part")]
    pub photos: Vec<PhotoValidation>,
    /// Slope of the length error against distance and its 1-sigma, percent per metre;
    /// null when the photos do not span enough distance (3 photos over 0.5 m).
    pub error_slope_pct_per_m: Option<f64>,
    pub error_slope_sigma_pct_per_m: Option<f64>,
    /// The slope is real and large enough to fail the calibration.
    pub trend_fails: Option<bool>,
    /// The verdict: every measured photo within the tolerance and no failing trend.
    pub pass: bool,
}

/// The calibration a validation used, as its report names it.
#[derive(Clone, Debug)]
pub struct CalibrationUsed {
    /// `FSL-NN`, when the calibration names its unit.
    pub unit: Option<String>,
    pub file: String,
    /// SHA-256 of the file's bytes, hex.
    pub sha256: String,
    /// When the validation ran, seconds since 1970 UTC.
    pub validated_utc_s: i64,
}

#[cfg(feature = "vision")]
impl ValidationDocument {
    /// The document of a validation of the calibration `used`.
    pub fn new(v: &crate::calibration::validate::Validation, used: CalibrationUsed) -> Self {
        ValidationDocument {
            schema_version: super::SCHEMA_VERSION,
            unit: used.unit,
            calibration_file: Some(used.file),
            calibration_sha256: Some(used.sha256),
            validated_utc: Some(crate::utc_time::format_iso(used.validated_utc_s)),
            length: Some(v.length_name.clone()),
            true_mm: Some(v.true_mm),
            rule: Some(v.rule),
            tolerance_pct: Some(v.tolerance_pct),
            photos: v.photos.clone(),
            error_slope_pct_per_m: v.slope_pct_per_m.map(|s| s.0),
            error_slope_sigma_pct_per_m: v.slope_pct_per_m.map(|s| s.1),
            trend_fails: Some(v.trend_fails),
            pass: v.pass,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_bare_verdict_is_a_report_and_a_verdictless_one_is_not() {
        let d: ValidationDocument = serde_json::from_str(r#"{"photos": [], "pass": true}"#).unwrap();
        assert!(d.pass && d.schema_version == 1 && d.unit.is_none());
        assert!(serde_json::from_str::<ValidationDocument>(r#"{"photos": []}"#).is_err());
        let odd: ValidationDocument = serde_json::from_str(r#"{"photos": [{"file": 3}], "pass": false}"#).unwrap();
        assert!(!odd.pass && odd.photos.is_empty());
    }
}
