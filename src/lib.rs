//! fslcal: field calibration for FishSense Lite (a TG-6 in a housing with a laser pointer).
//!
//! The geometry and the calibration file live in `fslcal-core` (no_std, shared with the
//! camera companion). This crate adds what needs std: finding dots, fitting the laser,
//! reading camera files, the OpenCV-backed vision module, and the CLI.

pub mod atomic_file;
pub mod calibration;
pub mod calibration_change;
#[cfg(feature = "vision")]
pub mod camera_calibration;
pub mod camera_file;
pub mod camera_fit;
pub mod cli;
pub mod dot;
pub mod exif;
pub mod fishsense_pkg;
pub mod keys;
pub mod dot_on_line;
pub mod fish;
#[cfg(feature = "vision")]
pub mod laser_calibration;
pub mod laser_fit;
pub mod photo_identity;
pub mod raw;
pub mod report;
pub mod unit_files;
pub mod unit_registry;
pub mod utc_time;
#[cfg(feature = "vision")]
pub mod validation;
#[cfg(feature = "vision")]
pub mod drift_check;
#[cfg(feature = "vision")]
pub mod vision;

pub use fslcal_core as geometry;
