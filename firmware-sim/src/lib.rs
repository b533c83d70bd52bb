//! The FishSense Lite camera companion's firmware logic: a small board on the rig with a
//! 128x64 monochrome display that holds the unit's signed calibration, tells the diver
//! whether it can be trusted, and turns laser-dot pixels into distances.
//!
//! `#![no_std]` without an allocator: the whole state is one [`Firmware`] value of fixed
//! size. The calibration file is decoded and verified by `fslcal_core::unit_file` and the
//! distance comes from `fslcal_core::LaserLine::fix_from_pixel`, the same code as the CLI's.
//! Inputs are [`Event`]s; [`screens::draw`] renders the current screen onto any
//! embedded-graphics `DrawTarget`. The `firmware-sim` binary (feature `sim`) runs a
//! scripted dive on a desktop and writes every screen as a PNG.
#![no_std]
#![forbid(unsafe_code)]

pub mod drift;
pub mod firmware;
pub mod screens;
pub mod script;
pub mod text;
pub mod unit_file;

pub use firmware::{Button, Calibration, Config, Event, Firmware, Screen};
pub use unit_file::{Rejection, TrustedKey};
