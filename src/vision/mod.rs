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

use crate::dot::candidates::{ChannelOrder, ColourView};
use crate::photo::counter::{count, Event};
use crate::photo::exif::PhotoExif;
use crate::photo::raw::develop::{binned_grey, for_each_row, write_row, GreyWorld, Order, ToneCurve};
use crate::photo::raw::{is_orf, RawError, RawFrame};
use opencv::core::{Mat, Scalar, Vector, CV_8UC1, CV_8UC3};
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

/// A decoded full-resolution colour photo (BGR, 8 bit).
pub struct Photo {
    /// What people see: the JPEG's pixels, or a raw developed with the grey-world balance.
    bgr: Mat,
    grey: Mat,
    /// For a raw, its linear levels under the camera's white balance (green 255 = the sensor
    /// clipped), where the dot's saturation and colour are true; the dot detector reads this.
    linear: Option<Mat>,
}

impl<'p> EncodedPhoto<'p> {
    pub fn read(path: &'p Path) -> Result<Self, VisionError> {
        count(Event::FileRead);
        let bytes =
            std::fs::read(path).map_err(|source| VisionError::Io { path: path.display().to_string(), source })?;
        if bytes.is_empty() {
            return Err(VisionError::Undecodable { path: path.display().to_string() });
        }
        let exif = PhotoExif::from_bytes(&bytes);
        if is_orf(&bytes) {
            let frame = RawFrame::decode(bytes, path)?;
            let balance = GreyWorld::of(&frame);
            return Ok(EncodedPhoto { path, source: Source::Raw { frame, balance }, exif });
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

    fn decode(&self, flags: i32) -> Result<Mat, VisionError> {
        let Source::Encoded(buf) = &self.source else {
            unreachable!("raw photos are developed, not decoded by OpenCV");
        };
        let reduced = matches!(
            flags,
            imgcodecs::IMREAD_REDUCED_GRAYSCALE_2 | imgcodecs::IMREAD_REDUCED_GRAYSCALE_4 | imgcodecs::IMREAD_REDUCED_GRAYSCALE_8
        );
        count(if reduced { Event::ReducedDecode } else { Event::FullDecode });
        let m = imgcodecs::imdecode(buf, flags).map_err(|e| VisionError::cv(self.path, e))?;
        if m.empty() {
            return Err(VisionError::Undecodable { path: self.path.display().to_string() });
        }
        Ok(m)
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

    /// Greyscale at 1/4 (JPEG decodes this fast by DCT scaling) or 1/2 size.
    /// A raw is binned from its sensor sites (no demosaic), which is as fast.
    pub fn decode_reduced_grey(&self, factor: u32) -> Result<Mat, VisionError> {
        if let Source::Raw { frame, balance } = &self.source {
            if factor >= 2 {
                let (grey, w, h) = binned_grey(frame, balance, factor as usize);
                return self.mat_from(&grey, w, h, CV_8UC1);
            }
            return self.decode_full().map(|p| p.grey);
        }
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
        let (bgr, linear) = match &self.source {
            Source::Encoded(_) => (self.decode(imgcodecs::IMREAD_COLOR)?, None),
            Source::Raw { frame, balance } => {
                let (bgr, linear) = self.develop(frame, balance)?;
                (bgr, Some(linear))
            }
        };
        let mut grey = Mat::default();
        imgproc::cvt_color(&bgr, &mut grey, imgproc::COLOR_BGR2GRAY, 0).map_err(|e| VisionError::cv(self.path, e))?;
        Ok(Photo { bgr, grey, linear })
    }

    /// Developed (balanced sRGB) and linear BGR images of a raw, in one demosaic pass.
    fn develop(&self, frame: &RawFrame, balance: &GreyWorld) -> Result<(Mat, Mat), VisionError> {
        let cv = |e| VisionError::cv(self.path, e);
        let (w, h) = (frame.width as i32, frame.height as i32);
        let mut bgr = Mat::new_rows_cols_with_default(h, w, CV_8UC3, Scalar::all(0.0)).map_err(cv)?;
        let mut linear = Mat::new_rows_cols_with_default(h, w, CV_8UC3, Scalar::all(0.0)).map_err(cv)?;
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

impl Photo {
    pub fn width(&self) -> u32 {
        self.bgr.cols() as u32
    }

    pub fn height(&self) -> u32 {
        self.bgr.rows() as u32
    }

    /// The colour pixels for the dot detector: a raw's linear levels, else the photo's.
    pub fn colour(&self) -> ColourView<'_> {
        let m = self.linear.as_ref().unwrap_or(&self.bgr);
        let data = m.data_bytes().unwrap_or(&[]);
        ColourView {
            width: m.cols() as usize,
            height: m.rows() as usize,
            stride: m.cols() as usize * 3,
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
