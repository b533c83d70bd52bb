//! Fish: end points from a mask, hand labels, and lengths from a calibration.

pub mod ends;
pub mod labels;
pub mod mask;
pub mod measure;

pub use ends::{fish_ends, principal_axis_ends, FishEnds, HeadCall, TailPoint};
pub use mask::Mask;

#[derive(Debug, thiserror::Error)]
pub enum FishError {
    #[error("{path}: cannot use the mask: {why}")]
    Mask { path: String, why: String },
    #[error("{path}: cannot use the labels: {why}")]
    Labels { path: String, why: String },
    #[error("the fish mask has only {pixels} pixels in its largest piece: too small to find its ends")]
    TooSmall { pixels: usize },
}
