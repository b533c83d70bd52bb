//! The laser dot: finding candidate blobs, centring them, and the search policies (on a
//! target's image, near a first fit's prediction, along a calibrated laser's image).

pub mod candidates;
mod centre;
pub mod colour;
pub mod near_prediction;
pub mod on_line;
pub mod on_target;
mod outline;
