//! What a photo says before any target is found: its EXIF (body, time, depth, focal
//! length), whether it comes from the calibrated body, and raw (ORF) decoding.

pub mod counter;
pub mod exif;
pub mod identity;
pub mod raw;
pub mod thumbnails;
