//! The laser chain: photos of a target with the dot on it, through the dots' 3D points, to
//! a fitted laser line with its covariance and quality gates.

pub mod consensus;
pub mod fit;
#[cfg(feature = "vision")]
pub mod gates;
pub mod lab_equivalent;
pub mod outcome;
#[cfg(feature = "vision")]
pub mod pipeline;
#[cfg(feature = "vision")]
pub mod target;
