//! The camera companion's firmware logic (no_std). Screens and simulator come with issue 7.
#![no_std]
pub use fslcal_core as core_geometry;
