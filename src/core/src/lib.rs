//! fslcal's core: the camera model, the laser geometry, and the signed calibration file
//! format (`unit_file`), shared by the `fslcal` CLI and the `firmware-sim` camera companion.
//!
//! Built `#![no_std]` when the default `std` feature is off, and never depends on OpenCV,
//! `image` or `rawler`: CI checks both.
//!
//! # Conventions (the full text is `docs/conventions.md`)
//! - Frames: the camera frame has x right, y down, z forward along the optical axis, origin
//!   at the optical centre. A transform named `T_a_b` maps points from frame `b` into `a`
//!   (`p_a = T_a_b * p_b`); `T_cam_target` puts target points in the camera frame.
//! - Units: lengths in metres (`_m`), image positions in pixels (`_px`), angles in radians
//!   unless a name says `_deg`. Directions are unit vectors without a unit suffix.
//! - Pixels: OpenCV's convention. The centre of the top-left pixel is `(0, 0)`; the image
//!   spans `[-0.5, w - 0.5] x [-0.5, h - 0.5]`. `u` is the column, `v` the row.
//! - Distance: "distance" to a dot or fish is its depth `z` in the camera frame, the `D` of
//!   the thesis's `L = D n w / f`, not the range along the ray.
#![cfg_attr(not(feature = "std"), no_std)]
#![forbid(unsafe_code)]

pub mod camera;
pub mod laser;
pub mod unit_file;

pub use camera::{CameraModel, Distortion};
pub use laser::{covariance_known, DotFix, LaserLine, LineGate, Plane, DOT_CENTRING_FLOOR_PX, LINE_GATE_CHI2};

/// 3-vector in metres (or unitless for directions), camera frame unless named otherwise.
pub type Vec3 = nalgebra::Vector3<f64>;
/// 2-vector: a pixel position or normalised image coordinates.
pub type Vec2 = nalgebra::Vector2<f64>;
