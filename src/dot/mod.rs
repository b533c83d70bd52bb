//! The laser dot: finding candidate blobs, centring them, and the search policies (on a
//! target's image, along a calibrated laser's image).

pub mod candidates;
pub mod on_line;
