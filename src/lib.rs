//! fslcal: field calibration for FishSense Lite (a TG-6 in a housing with a laser pointer).
//!
//! The geometry and the calibration file live in `fslcal-core` (no_std, shared with the
//! camera companion). This crate adds what needs std, grouped along the chain a calibration
//! follows, photo → target pose → dot → laser fit → signed file → use:
//!
//! - [`photo`]: what a photo says before any target is found (EXIF, body identity, raw).
//! - [`vision`]: everything that touches OpenCV (decoding, boards, slates, poses, intrinsics).
//! - [`dot`]: finding the laser dot and deciding which blob it is.
//! - [`laser`]: the laser chain over photos, the fit and its gates.
//! - [`camera`]: camera intrinsics, their residuals and the OpenCV YAML file.
//! - [`units`]: keys, signed unit files on disk, the registry, the lab's `.pkg`.
//! - [`calibration`]: using a calibration: loading it, comparing two, validate and drift.
//! - [`fish`]: measuring fish with a calibration.
//! - [`report`]: the HTML reports; [`documents`]: the JSON documents; [`cli`]: the commands.
//! - [`reason`]: a decision (why a photo was skipped) carried with its sentence.

pub mod atomic_file;
pub mod calibration;
pub mod camera;
pub mod cli;
pub mod documents;
pub mod dot;
pub mod fish;
pub mod laser;
pub mod photo;
pub mod reason;
pub mod report;
pub mod units;
pub mod utc_time;
#[cfg(feature = "vision")]
pub mod vision;

pub use fslcal_core as geometry;
