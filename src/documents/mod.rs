//! The JSON documents fslcal writes and reads: one serde type per document, used in both
//! directions, each with a `schema_version` (docs/json-output.md describes every field).
//!
//! | document | written by | read by | type |
//! |---|---|---|---|
//! | laser result | `fslcal laser --json`, `--out FILE.json` | `--cal` of validate, check, measure, units diff | [`laser::LaserDocument`] |
//! | camera result | `fslcal camera --json` | (other tools) | [`camera::CameraDocument`] |
//! | validation report | `fslcal validate --json` | `fslcal units add-validation` | [`validation::ValidationDocument`] |
//! | check result | `fslcal check --json` | (other tools) | [`check::CheckDocument`] |
//! | lengths | `fslcal measure --json` (a dive, one fish, a mask's ends) | (other tools) | [`lengths`] |
//! | refused run | `laser`, `check`, `validate --json` when no photo gave a result | (other tools) | [`refused::RefusedDocument`] |
//!
//! The documents live together, apart from the types the chains compute with, because they
//! are a contract with users' files and scripts: a field renamed in a chain must not
//! silently rename a key in a calibration someone keeps. Each document is assembled from
//! its chain's result by the command that prints it; the per-photo lines are the chains'
//! own outcome types (`laser::outcome`, `camera::outcome`, `calibration::outcome`), which
//! say what each key means.

pub mod camera;
pub mod check;
pub mod laser;
pub mod lengths;
pub mod refused;
pub mod validation;

use fslcal_core::{CameraModel, Distortion};
use serde::{Deserialize, Deserializer, Serialize, Serializer};
use std::fmt;

/// The schema version this build writes and the highest it reads.
pub const SCHEMA_VERSION: u32 = 1;

/// Documents written before `schema_version` existed are version 1.
fn schema_version_1() -> u32 {
    1
}

/// A part of a document that only reports (a fit's photos and gates, a validation's
/// photos), as read: what it says, or absent when it does not parse. Reading a document is
/// for its verdict or its calibration; a report in words this build does not know (a gate
/// or a status added later) must not make a user's file unreadable.
fn report_part<'de, D: Deserializer<'de>, T: serde::de::DeserializeOwned + Default>(d: D) -> Result<T, D::Error> {
    let value = serde_json::Value::deserialize(d)?;
    Ok(serde_json::from_value(value).unwrap_or_default())
}

/// A document written by a newer fslcal than this one.
#[derive(Debug, PartialEq, thiserror::Error)]
#[error("written by a newer fslcal (schema_version {found}; this build reads up to {SCHEMA_VERSION}); update fslcal")]
pub struct NewerSchema {
    pub found: u32,
}

/// Refuses a document whose `schema_version` this build does not know.
pub fn check_schema(found: u32) -> Result<(), NewerSchema> {
    if found > SCHEMA_VERSION {
        return Err(NewerSchema { found });
    }
    Ok(())
}

/// A document as text: pretty-printed with its keys sorted, as fslcal has always printed
/// them, so that diffs of two runs line up.
pub fn to_text<T: Serialize>(document: &T) -> serde_json::Result<String> {
    // Through a `Value`, whose maps are sorted, rather than in the structs' field order.
    serde_json::to_string_pretty(&serde_json::to_value(document)?)
}

/// The `camera` object of every document: `image_size` [width, height] and `fx`, `fy`,
/// `cx`, `cy` in pixels, `dist` as OpenCV's `[k1, k2, p1, p2, k3]`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CameraJson {
    pub image_size: [u32; 2],
    pub fx: f64,
    pub fy: f64,
    pub cx: f64,
    pub cy: f64,
    pub dist: [f64; 5],
}

impl From<&CameraModel> for CameraJson {
    fn from(c: &CameraModel) -> Self {
        CameraJson {
            image_size: [c.width_px, c.height_px],
            fx: c.fx_px,
            fy: c.fy_px,
            cx: c.cx_px,
            cy: c.cy_px,
            dist: c.distortion.to_opencv(),
        }
    }
}

impl From<&CameraJson> for CameraModel {
    fn from(c: &CameraJson) -> Self {
        CameraModel {
            width_px: c.image_size[0],
            height_px: c.image_size[1],
            fx_px: c.fx,
            fy_px: c.fy,
            cx_px: c.cx,
            cy_px: c.cy,
            distortion: Distortion::from_opencv(c.dist),
        }
    }
}

/// A count out of a total, written `"x of n"` ("2 of 15 photos were outliers").
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct XOfN(pub usize, pub usize);

impl From<(usize, usize)> for XOfN {
    fn from((x, n): (usize, usize)) -> Self {
        XOfN(x, n)
    }
}

impl fmt::Display for XOfN {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} of {}", self.0, self.1)
    }
}

impl Serialize for XOfN {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(self)
    }
}

impl<'de> Deserialize<'de> for XOfN {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let text = String::deserialize(d)?;
        let parsed =
            text.split_once(" of ").and_then(|(x, n)| Some(XOfN(x.trim().parse().ok()?, n.trim().parse().ok()?)));
        parsed.ok_or_else(|| serde::de::Error::custom(format!("expected \"X of N\", found \"{text}\"")))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn x_of_n_and_the_camera_read_back_what_they_wrote() {
        let v = serde_json::to_value(XOfN(2, 15)).unwrap();
        assert_eq!(v, "2 of 15");
        assert_eq!(serde_json::from_value::<XOfN>(v).unwrap(), XOfN(2, 15));
        assert!(serde_json::from_value::<XOfN>("two of 15".into()).is_err());
        let c = CameraModel {
            width_px: 4000,
            height_px: 3000,
            fx_px: 2900.0,
            fy_px: 2901.0,
            cx_px: 1999.5,
            cy_px: 1499.5,
            distortion: Distortion::from_opencv([-0.1, 0.03, 0.001, -0.002, 0.0]),
        };
        let text = to_text(&CameraJson::from(&c)).unwrap();
        let back: CameraJson = serde_json::from_str(&text).unwrap();
        assert_eq!(CameraModel::from(&back), c);
        assert!(text.find("\"cx\"").unwrap() < text.find("\"image_size\"").unwrap(), "keys sorted: {text}");
    }

    #[test]
    fn a_newer_schema_is_refused_by_name() {
        assert!(check_schema(1).is_ok());
        let e = check_schema(2).unwrap_err().to_string();
        assert!(e.contains("schema_version 2") && e.contains("update fslcal"), "{e}");
    }
}
