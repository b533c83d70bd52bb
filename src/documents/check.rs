//! The drift check's result: what `fslcal check --json` prints.

use super::schema_version_1;
use crate::calibration::outcome::PhotoCheck;
use serde::{Deserialize, Serialize};

/// `fslcal check`'s result.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct CheckDocument {
    #[serde(default = "schema_version_1")]
    pub schema_version: u32,
    pub photos: Vec<PhotoCheck>,
    /// At least half the sure dots are flagged: the laser has moved.
    pub drifted: bool,
    /// Photos with a dot the check is sure of; drift is judged from these only.
    #[serde(default)]
    pub sure_dots: usize,
    /// Median over the sure dots of the implied change of the beam's direction, degrees.
    pub implied_direction_change_deg: Option<f64>,
}

#[cfg(feature = "vision")]
impl From<&crate::calibration::drift::DriftCheck> for CheckDocument {
    fn from(r: &crate::calibration::drift::DriftCheck) -> Self {
        CheckDocument {
            schema_version: super::SCHEMA_VERSION,
            photos: r.photos.clone(),
            drifted: r.drifted,
            sure_dots: r.sure_dots,
            implied_direction_change_deg: r.implied_direction_change_deg,
        }
    }
}
