//! Fish lengths: what `fslcal measure --json` prints. Three documents, by what was asked:
//! a dive's fish with their length distribution ([`LengthsDocument`], with `--labels` or
//! `--masks`), one fish ([`FishLengthDocument`], with `--head`/`--tail` or `--mask` and
//! `--cal`), and a mask's end points alone ([`FishEndsDocument`], `--mask` without `--cal`).
//!
//! Pixels follow docs/conventions.md (the centre of the top-left pixel is 0,0).

use super::schema_version_1;
use crate::fish::measure::{Distribution, Length, Withheld};
use crate::fish::{FishEnds, HeadCall, TailPoint};
use fslcal_core::Vec2;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// A pixel as the documents write it: `[x, y]`.
pub fn px(p: Vec2) -> [f64; 2] {
    [p.x, p.y]
}

/// A fish's end points as found in its mask.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FishEndsJson {
    /// Snout and fork (or tail tip), pixels.
    pub head_px: [f64; 2],
    pub tail_px: [f64; 2],
    /// Snout to fork along the spine for a bent fish, else straight, pixels.
    pub length_px: f64,
    /// Straight from head to tail, pixels.
    pub chord_px: f64,
    /// The spine bows clearly: `length_px` follows it.
    pub bent: bool,
    /// How head and tail were told apart.
    pub head_call: HeadCall,
    /// `head_call` is not `unknown`: head and tail are not swapped.
    pub head_known: bool,
    /// The fork (with its depth in pixels) or the tail tip.
    pub tail_point: TailPoint,
    /// The fish touches the frame edge and may be cut.
    pub cut_by_edge: bool,
}

impl From<&FishEnds> for FishEndsJson {
    fn from(e: &FishEnds) -> Self {
        FishEndsJson {
            head_px: px(e.head_px),
            tail_px: px(e.tail_px),
            length_px: e.length_px,
            chord_px: e.chord_px,
            bent: e.bent,
            head_call: e.head_call,
            head_known: e.head_call != HeadCall::Unknown,
            tail_point: e.tail_point,
            cut_by_edge: e.cut_by_edge,
        }
    }
}

/// `fslcal measure --mask MASK --json` without a calibration: the end points only.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FishEndsDocument {
    #[serde(default = "schema_version_1")]
    pub schema_version: u32,
    #[serde(flatten)]
    pub ends: FishEndsJson,
}

/// One fish measured: its end points, the dot, and the length with its 1-sigma.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FishLengthDocument {
    #[serde(default = "schema_version_1")]
    pub schema_version: u32,
    pub photo: String,
    pub head_px: [f64; 2],
    pub tail_px: [f64; 2],
    /// The laser dot used, pixels.
    pub dot_px: Option<[f64; 2]>,
    /// `length_m`, `distance_m` and their 1-sigma, the distance's 1-sigma from the
    /// calibration and from the dot alone, all metres (the 1-sigmas that need the
    /// calibration's covariance are null when it is unknown); `dot_offset_px`.
    #[serde(flatten)]
    pub length: Length,
    /// The end points as found in the mask, when they came from one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ends: Option<FishEndsJson>,
}

/// One fish of a dive: measured (its length, distance and their 1-sigma, metres) or
/// withheld (`length_m` null, `flags` say why).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FishRowJson {
    pub photo: String,
    /// The fish's number in its photo, from 1.
    pub fish: usize,
    pub species: Option<String>,
    pub head_px: Option<[f64; 2]>,
    pub tail_px: Option<[f64; 2]>,
    pub dot_px: Option<[f64; 2]>,
    pub head_call: Option<HeadCall>,
    pub length_m: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub distance_m: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub length_sigma_m: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub distance_sigma_m: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dot_offset_px: Option<f64>,
    /// Empty for a measured fish.
    pub flags: Vec<Withheld>,
}

/// One bin of a length histogram: lengths from `from_m` up to `to_m`, metres.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct HistogramBin {
    pub from_m: f64,
    pub to_m: f64,
    pub count: usize,
}

/// A length distribution, metres.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DistributionJson {
    pub n: usize,
    pub mean_m: f64,
    /// `p5`, `p25`, `p50`, `p75`, `p95`.
    pub percentiles_m: BTreeMap<String, f64>,
    pub bin_width_m: f64,
    /// From the first non-empty bin to the last.
    pub histogram: Vec<HistogramBin>,
}

impl From<&Distribution> for DistributionJson {
    fn from(d: &Distribution) -> Self {
        DistributionJson {
            n: d.n,
            mean_m: d.mean_m,
            percentiles_m: d.percentiles_m.iter().map(|(p, v)| (format!("p{p}"), *v)).collect(),
            bin_width_m: d.bin_width_m,
            histogram: d.histogram.iter().map(|&(from_m, to_m, count)| HistogramBin { from_m, to_m, count }).collect(),
        }
    }
}

/// A dive's length distribution: all measured fish, and each species with its own.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SummaryJson {
    pub all: Option<DistributionJson>,
    pub species: BTreeMap<String, DistributionJson>,
}

/// `fslcal measure --json` over a dive.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LengthsDocument {
    #[serde(default = "schema_version_1")]
    pub schema_version: u32,
    /// The calibration file used.
    pub calibration: String,
    pub fish: Vec<FishRowJson>,
    /// Photos given with no labelled fish in them.
    pub photos_without_fish: Vec<String>,
    /// Fish measured, of `total`.
    pub measured: usize,
    pub total: usize,
    /// Withheld fish by flag (a fish with two flags counts under both).
    pub withheld: BTreeMap<String, usize>,
    pub summary: SummaryJson,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fish::measure::distribution;

    #[test]
    fn a_dive_reads_back_what_it_wrote() {
        let d = distribution(&[0.21, 0.25, 0.33]).unwrap();
        let doc = LengthsDocument {
            schema_version: 1,
            calibration: "cal.json".into(),
            fish: vec![FishRowJson {
                photo: "a.jpg".into(),
                fish: 1,
                species: None,
                head_px: Some([1.0, 2.0]),
                tail_px: Some([3.0, 4.0]),
                dot_px: None,
                head_call: Some(HeadCall::Labelled),
                length_m: None,
                distance_m: None,
                length_sigma_m: None,
                distance_sigma_m: None,
                dot_offset_px: None,
                flags: vec![Withheld::CutByEdge],
            }],
            photos_without_fish: vec![],
            measured: 0,
            total: 1,
            withheld: [("cut_by_edge".to_string(), 1)].into(),
            summary: SummaryJson { all: Some((&d).into()), species: BTreeMap::new() },
        };
        let v = serde_json::to_value(&doc).unwrap();
        assert!(v["fish"][0]["length_m"].is_null() && v["fish"][0].get("distance_m").is_none());
        assert_eq!(v["summary"]["all"]["percentiles_m"]["p50"], 0.25);
        let back: LengthsDocument = serde_json::from_value(v).unwrap();
        assert_eq!(back, doc);
    }
}
