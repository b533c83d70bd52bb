//! Everything that touches OpenCV: decoding photos, finding and refining checkerboard
//! corners, and solving a target's pose. Nothing outside this module names `opencv`.

mod board;
mod buffers;
mod decoded;
mod intrinsics;
mod pose;
mod slate;

pub use board::{
    find_checkerboard, local_square_px, refine_corners, search_plan, BoardSearch, CropDetector, CropImage, SearchStep,
};
pub use decoded::Photo;
pub use intrinsics::{calibrate_intrinsics, IntrinsicsSolve, SolveOptions};
pub use pose::{solve_pose, TargetPose};
pub use slate::{find_slate, Features, SlateDetection, SlateMiss, SlateModel, MIN_INLIERS};

use crate::photo::counter::{count, Event};
use crate::photo::exif::PhotoExif;
use crate::photo::raw::develop::{binned_grey, for_each_row, write_row, GreyWorld, Order, ToneCurve};
use crate::photo::raw::{is_orf, RawError, RawFrame};
use crate::photo::thumbnails;
use opencv::core::{Mat, Scalar, Vector, CV_8UC1, CV_8UC3};
use opencv::imgcodecs;
use opencv::prelude::*;
use std::path::Path;

#[derive(Debug, thiserror::Error)]
pub enum VisionError {
    /// The cause is in the message, not a `source`, or `{:#}` would say it twice.
    #[error("{path}: cannot read: {cause}")]
    Io { path: String, cause: std::io::Error },
    #[error("{path}: not a readable image (corrupt, truncated, or not a JPEG, PNG or Olympus ORF raw)")]
    Undecodable { path: String },
    #[error("{path}: a TIFF image, which fslcal does not read; it reads JPEG, PNG and Olympus ORF raw: convert the photo to PNG")]
    Tiff { path: String },
    #[error("{path}: truncated JPEG (no end-of-image marker); copy the file from the card again")]
    Truncated { path: String },
    #[error("{path}: OpenCV failed: {message}")]
    OpenCv { path: String, message: String },
    #[error(transparent)]
    Raw(#[from] RawError),
}

impl VisionError {
    fn cv(path: &Path, e: opencv::Error) -> Self {
        VisionError::OpenCv { path: path.display().to_string(), message: e.message }
    }
}

/// A photo read but not yet decoded, so it can be decoded small first and in full only when
/// it holds a target: a JPEG's or PNG's bytes, or a raw's sensor samples.
pub struct EncodedPhoto<'p> {
    pub path: &'p Path,
    source: Source,
    exif: Option<PhotoExif>,
}

enum Source {
    Encoded(Vector<u8>),
    Raw { frame: RawFrame, balance: GreyWorld },
}

impl<'p> EncodedPhoto<'p> {
    pub fn read(path: &'p Path) -> Result<Self, VisionError> {
        count(Event::FileRead);
        let bytes = std::fs::read(path).map_err(|cause| VisionError::Io { path: path.display().to_string(), cause })?;
        if bytes.is_empty() {
            return Err(VisionError::Undecodable { path: path.display().to_string() });
        }
        let exif = PhotoExif::from_bytes(&bytes);
        if is_orf(&bytes) {
            let frame = RawFrame::decode(bytes, path)?;
            let balance = GreyWorld::of(&frame);
            return Ok(EncodedPhoto { path, source: Source::Raw { frame, balance }, exif });
        }
        // Named as a raw but not one: a raw's own message, not the JPEG reader's.
        if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("orf")) {
            return Err(RawError::NotOrf { path: path.display().to_string() }.into());
        }
        if bytes.starts_with(b"II*\0") || bytes.starts_with(b"MM\0*") {
            return Err(VisionError::Tiff { path: path.display().to_string() });
        }
        // libjpeg fills a truncated JPEG's missing rows with grey and calls it a photo; a
        // half-copied file must say so instead of "no board found".
        let is_jpeg = bytes.starts_with(&[0xFF, 0xD8]);
        let tail = &bytes[bytes.len().saturating_sub(64)..];
        if is_jpeg && !tail.windows(2).any(|w| w == [0xFF, 0xD9]) {
            return Err(VisionError::Truncated { path: path.display().to_string() });
        }
        Ok(EncodedPhoto { path, source: Source::Encoded(Vector::from_slice(&bytes)), exif })
    }

    /// The photo's EXIF (make, model, serial, time, focal length, depth), when it has one.
    pub fn exif(&self) -> Option<&PhotoExif> {
        self.exif.as_ref()
    }

    /// Width and height from the file's header, without decoding pixels.
    pub fn dimensions(&self) -> Result<(u32, u32), VisionError> {
        let undecodable = || VisionError::Undecodable { path: self.path.display().to_string() };
        let buf = match &self.source {
            Source::Encoded(buf) => buf,
            Source::Raw { frame, .. } => return Ok((frame.width as u32, frame.height as u32)),
        };
        image::ImageReader::new(std::io::Cursor::new(buf.as_slice()))
            .with_guessed_format()
            .map_err(|_| undecodable())?
            .into_dimensions()
            .map_err(|_| undecodable())
    }

    /// Greyscale at 1/2, 1/4 or 1/8 size by libjpeg's DCT scaling, for a caller that needs
    /// nothing at full resolution (a raw is binned from its sensor sites, as fast). A photo
    /// that may need full resolution is [`decode`](Self::decode)d once instead, and its
    /// reduced images come from that.
    pub fn decode_reduced_grey(&self, factor: u32) -> Result<Mat, VisionError> {
        if let Source::Raw { frame, balance } = &self.source {
            let (grey, w, h) = binned_grey(frame, balance, factor.max(2) as usize);
            return self.mat_from(&grey, w, h, CV_8UC1);
        }
        let flags = match factor {
            2 => imgcodecs::IMREAD_REDUCED_GRAYSCALE_2,
            4 => imgcodecs::IMREAD_REDUCED_GRAYSCALE_4,
            _ => imgcodecs::IMREAD_REDUCED_GRAYSCALE_8,
        };
        let Source::Encoded(buf) = &self.source else { unreachable!("raws returned above") };
        count(Event::ReducedDecode);
        let m = imgcodecs::imdecode(buf, flags).map_err(|e| VisionError::cv(self.path, e))?;
        if m.empty() {
            return Err(VisionError::Undecodable { path: self.path.display().to_string() });
        }
        Ok(m)
    }

    /// The photo's one decode, at full resolution: the colour pixels in the decoder's own
    /// layout (BGR), written into a buffer this thread has used before; the grey and
    /// reduced images and the report's thumbnail all come from it.
    pub fn decode(&self) -> Result<Photo, VisionError> {
        let cv = |e| VisionError::cv(self.path, e);
        let photo = match &self.source {
            Source::Encoded(buf) => {
                // A size the header does not give (or gives before EXIF rotation) only costs
                // a fresh buffer.
                let (w, h) = self.dimensions().unwrap_or((0, 0));
                let mut bgr = buffers::take(h as i32, w as i32, CV_8UC3);
                count(Event::FullDecode);
                imgcodecs::imdecode_to(buf, imgcodecs::IMREAD_COLOR, &mut bgr).map_err(cv)?;
                if bgr.empty() {
                    return Err(VisionError::Undecodable { path: self.path.display().to_string() });
                }
                Photo::new(bgr, None)
            }
            Source::Raw { frame, balance } => {
                let (bgr, linear) = self.develop(frame, balance)?;
                Photo::new(bgr, Some(linear))
            }
        };
        if let Some(width_px) = thumbnails::wanted_width_px() {
            let kept = photo.thumbnail(width_px).map_err(cv)?;
            thumbnails::keep(self.path, kept);
        }
        Ok(photo)
    }

    /// Developed (balanced sRGB) and linear BGR images of a raw, in one demosaic pass.
    fn develop(&self, frame: &RawFrame, balance: &GreyWorld) -> Result<(Mat, Mat), VisionError> {
        let cv = |e| VisionError::cv(self.path, e);
        let (w, h) = (frame.width as i32, frame.height as i32);
        let mut bgr = buffers::take(h, w, CV_8UC3);
        if bgr.empty() {
            bgr = Mat::new_rows_cols_with_default(h, w, CV_8UC3, Scalar::all(0.0)).map_err(cv)?;
        }
        let mut linear = buffers::take(h, w, CV_8UC3);
        if linear.empty() {
            linear = Mat::new_rows_cols_with_default(h, w, CV_8UC3, Scalar::all(0.0)).map_err(cv)?;
        }
        {
            let (srgb, straight) = (ToneCurve::srgb(255), ToneCurve::linear(255));
            // The camera's own white balance, green unscaled: the board's white squares come
            // out near neutral (the detector's green excess must not see the whole board as
            // green), and a green channel at 255 is one the sensor clipped.
            let wb = frame.camera_wb;
            let out = bgr.data_bytes_mut().map_err(cv)?;
            let lin = linear.data_bytes_mut().map_err(cv)?;
            let stride = frame.width * 3;
            for_each_row(frame, |y, row| {
                let span = y * stride..(y + 1) * stride;
                write_row(row, balance.gains, &srgb, Order::Bgr, &mut out[span.clone()], |v| v as u8);
                write_row(row, wb, &straight, Order::Bgr, &mut lin[span], |v| v as u8);
            });
        }
        Ok((bgr, linear))
    }

    fn mat_from(&self, pixels: &[u8], w: usize, h: usize, typ: i32) -> Result<Mat, VisionError> {
        let cv = |e| VisionError::cv(self.path, e);
        let mut m = Mat::new_rows_cols_with_default(h as i32, w as i32, typ, Scalar::all(0.0)).map_err(cv)?;
        m.data_bytes_mut().map_err(cv)?.copy_from_slice(pixels);
        Ok(m)
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
