//! What a photo says before any target is found: its EXIF (body, time, depth, focal
//! length), whether it comes from the calibrated body, raw (ORF) decoding, the pixel frames
//! pixels are measured in, and the Label Studio labels clicked on photos.

pub mod counter;
pub mod dot_labels;
pub mod exif;
pub mod frame;
pub mod identity;
pub mod label_studio;
pub mod names;
pub mod raw;
pub mod thumbnails;
