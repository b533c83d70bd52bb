//! Everything that touches OpenCV: decoding photos, finding and refining checkerboard
//! corners, and solving a target's pose. Nothing outside this module names `opencv`.

mod board;
mod intrinsics;
mod pose;
mod slate;

pub use board::{find_checkerboard, local_square_px, refine_corners, BoardSearch};
pub use intrinsics::{calibrate_intrinsics, IntrinsicsSolve, SolveOptions};
pub use pose::{solve_pose, TargetPose};
pub use slate::{find_slate, Features, SlateDetection, SlateMiss, SlateModel, MIN_INLIERS};

use crate::dot::{ChannelOrder, ColourView};
use opencv::core::{Mat, Vector};
use opencv::prelude::*;
use opencv::{imgcodecs, imgproc};
use std::path::Path;

#[derive(Debug, thiserror::Error)]
pub enum VisionError {
    #[error("{path}: cannot read: {source}")]
    Io { path: String, source: std::io::Error },
    #[error("{path}: not a readable image (corrupt, truncated, or not JPEG/PNG/TIFF)")]
    Undecodable { path: String },
    #[error("{path}: truncated JPEG (no end-of-image marker); copy the file from the card again")]
    Truncated { path: String },
    #[error("{path}: OpenCV failed: {message}")]
    OpenCv { path: String, message: String },
}

impl VisionError {
    fn cv(path: &Path, e: opencv::Error) -> Self {
        VisionError::OpenCv { path: path.display().to_string(), message: e.message }
    }
}

/// Encoded photo bytes, kept so the photo can be decoded small first and in full only when
/// it holds a target.
pub struct EncodedPhoto<'p> {
    pub path: &'p Path,
    buf: Vector<u8>,
}

/// A decoded full-resolution colour photo (BGR, 8 bit).
pub struct Photo {
    bgr: Mat,
    grey: Mat,
}

impl<'p> EncodedPhoto<'p> {
    pub fn read(path: &'p Path) -> Result<Self, VisionError> {
        let bytes = std::fs::read(path).map_err(|source| VisionError::Io { path: path.display().to_string(), source })?;
        if bytes.is_empty() {
            return Err(VisionError::Undecodable { path: path.display().to_string() });
        }
        // libjpeg fills a truncated JPEG's missing rows with grey and calls it a photo; a
        // half-copied file must say so instead of "no board found".
        let is_jpeg = bytes.starts_with(&[0xFF, 0xD8]);
        let tail = &bytes[bytes.len().saturating_sub(64)..];
        if is_jpeg && !tail.windows(2).any(|w| w == [0xFF, 0xD9]) {
            return Err(VisionError::Truncated { path: path.display().to_string() });
        }
        Ok(EncodedPhoto { path, buf: Vector::from_slice(&bytes) })
    }

    fn decode(&self, flags: i32) -> Result<Mat, VisionError> {
        let m = imgcodecs::imdecode(&self.buf, flags).map_err(|e| VisionError::cv(self.path, e))?;
        if m.empty() {
            return Err(VisionError::Undecodable { path: self.path.display().to_string() });
        }
        Ok(m)
    }

    /// Width and height from the file's header, without decoding pixels.
    pub fn dimensions(&self) -> Result<(u32, u32), VisionError> {
        let undecodable = || VisionError::Undecodable { path: self.path.display().to_string() };
        image::ImageReader::new(std::io::Cursor::new(self.buf.as_slice()))
            .with_guessed_format()
            .map_err(|_| undecodable())?
            .into_dimensions()
            .map_err(|_| undecodable())
    }

    /// Greyscale at 1/4 (JPEG decodes this fast by DCT scaling) or 1/2 size.
    pub fn decode_reduced_grey(&self, factor: u32) -> Result<Mat, VisionError> {
        let flags = match factor {
            2 => imgcodecs::IMREAD_REDUCED_GRAYSCALE_2,
            4 => imgcodecs::IMREAD_REDUCED_GRAYSCALE_4,
            8 => imgcodecs::IMREAD_REDUCED_GRAYSCALE_8,
            _ => imgcodecs::IMREAD_GRAYSCALE,
        };
        self.decode(flags)
    }

    /// Full-resolution colour.
    pub fn decode_full(&self) -> Result<Photo, VisionError> {
        let bgr = self.decode(imgcodecs::IMREAD_COLOR)?;
        let mut grey = Mat::default();
        imgproc::cvt_color(&bgr, &mut grey, imgproc::COLOR_BGR2GRAY, 0).map_err(|e| VisionError::cv(self.path, e))?;
        Ok(Photo { bgr, grey })
    }
}

impl Photo {
    pub fn width(&self) -> u32 {
        self.bgr.cols() as u32
    }

    pub fn height(&self) -> u32 {
        self.bgr.rows() as u32
    }

    /// The colour pixels for the dot detector.
    pub fn colour(&self) -> ColourView<'_> {
        let data = self.bgr.data_bytes().unwrap_or(&[]);
        ColourView {
            width: self.bgr.cols() as usize,
            height: self.bgr.rows() as usize,
            stride: self.bgr.cols() as usize * 3,
            order: ChannelOrder::Bgr,
            data,
        }
    }

    pub(crate) fn grey(&self) -> &Mat {
        &self.grey
    }
}

/// Size of an image file without decoding its pixels fully (decodes at 1/8 for JPEG).
pub fn mat_size(m: &Mat) -> (u32, u32) {
    (m.cols() as u32, m.rows() as u32)
}

/// Keeps OpenCV from starting its own thread pool under rayon's: photos are already
/// processed in parallel, and two pools on two cores only fight.
pub fn use_single_threaded_opencv() {
    let _ = opencv::core::set_num_threads(1);
}
