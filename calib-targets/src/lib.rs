//! Calibration targets and synthetic underwater scenes with ground truth.
//!
//! [`Checkerboard`] defines the printed board (inner corners, measured square). [`scene`]
//! renders photos of it as the FishSense Lite rig would take them under water, with the
//! laser dot, glints and the exact truth, for tests, benchmarks and the demo; the
//! `render-scenes` binary writes sets of them to disk. [`orf`] wraps a rendered photo in a
//! synthetic Olympus TG-6 raw file. [`fish`] renders fish with exact snout, fork and fork
//! length in the same water, for measuring lengths. [`variety`] randomises everything a
//! laser-dot detector must not depend on (water, light, materials, the laser's look,
//! impostors), with seeds split into tuning and held-out ones.
//!
//! Conventions are fslcal's (`docs/conventions.md`): camera frame x right, y down, z
//! forward; `T_cam_target` maps target points into the camera frame; metres, pixels with the
//! centre of the top-left pixel at (0, 0).

pub mod fish;
pub mod orf;
mod output;
mod random;
pub mod rig;
pub mod scene;
pub mod slate;
mod target;
pub mod variety;

pub use output::{
    camera_yaml, write_camera_yaml, write_fish, write_json, write_photo, write_png, write_scene, JPEG_QUALITY,
};
pub use random::SplitMix;
pub use slate::{KnownLength, Slate, SlateError};
pub use target::{Checkerboard, TargetParseError, MARGIN_SQUARES};
