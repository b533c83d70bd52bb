//! A unit's calibration as a signed artefact: signing keys, the signed `.fslcal` file on
//! disk, the coordinator's registry of units, and the FishSense lab's `.pkg` archives and API
//! bodies.

pub mod keys;
pub mod lab_api;
pub mod lab_pkg;
pub mod registry;
pub mod signed_file;
