//! The camera-body check every command that takes a calibration runs on its photos.

// Only the commands that find targets (vision feature) use all of this.
#![cfg_attr(not(feature = "vision"), allow(dead_code))]

use crate::photo::identity::{check_photos, ExpectedCamera};
use std::path::PathBuf;

/// Whether photos from another camera body may be used.
#[derive(clap::Args, Debug, Clone, Copy)]
pub struct BodyCheckArgs {
    /// Accept photos from another camera body than the calibration's (EXIF serial); without
    /// it they are refused.
    #[arg(long)]
    pub allow_other_body: bool,
}

impl BodyCheckArgs {
    /// Refuses the first photo from another body (unless allowed) and prints the warnings
    /// (zoom used, no serial to check, allowed other body) on stderr.
    pub fn check(&self, expected: &ExpectedCamera, photos: &[PathBuf]) -> anyhow::Result<()> {
        for w in check_photos(expected, photos, self.allow_other_body)? {
            eprintln!("fslcal: warning: {w}");
        }
        Ok(())
    }
}
