//! A photo decoded once at full resolution, and everything made from that one decode: its
//! grey image, the reduced images the board and slate searches run on, and the report's
//! thumbnail. Each is made when first asked for, into a buffer its thread has used before.

use super::buffers::{self, Buffer};
use crate::dot::candidates::{ChannelOrder, ColourView};
use crate::dot::colour::ToneCurve;
use crate::photo::thumbnails::{self, Kept};
use opencv::core::{Mat, Rect, Size, CV_8UC1, CV_8UC3};
use opencv::imgproc;
use opencv::prelude::*;
use std::cell::OnceCell;

/// A decoded full-resolution colour photo (BGR, 8 bit).
pub struct Photo {
    /// What people see: the JPEG's pixels, or a raw developed with the grey-world balance.
    bgr: Buffer,
    /// For a raw, its linear levels under the camera's white balance (green 255 = the sensor
    /// clipped), where the dot's saturation and colour are true; the dot detector reads this.
    linear: Option<Buffer>,
    grey: OnceCell<Buffer>,
    /// Grey at 1/2, 1/4 and 1/8 size.
    reduced: [OnceCell<Buffer>; 3],
}

/// `cell`'s value, made by `make` the first time.
fn get_or_make(cell: &OnceCell<Buffer>, make: impl FnOnce() -> opencv::Result<Mat>) -> opencv::Result<&Mat> {
    if let Some(m) = cell.get() {
        return Ok(m);
    }
    let m = Buffer::new(make()?);
    Ok(cell.get_or_init(|| m))
}

/// `src` halved by averaging 2x2 blocks (its last row or column dropped when odd), so
/// pixel `i` covers source pixels `2i` and `2i + 1`: the centre convention of a JPEG
/// decoded at half size, kept through every halving.
fn halve(src: &Mat, typ: i32) -> opencv::Result<Mat> {
    let size = Size::new(src.cols() / 2, src.rows() / 2);
    let even = Mat::roi(src, Rect::new(0, 0, size.width * 2, size.height * 2))?;
    let mut dst = buffers::take(size.height, size.width, typ);
    imgproc::resize(&even, &mut dst, size, 0.0, 0.0, imgproc::INTER_AREA)?;
    Ok(dst)
}

impl Photo {
    pub(super) fn new(bgr: Mat, linear: Option<Mat>) -> Photo {
        Photo {
            bgr: Buffer::new(bgr),
            linear: linear.map(Buffer::new),
            grey: OnceCell::new(),
            reduced: Default::default(),
        }
    }

    pub fn width(&self) -> u32 {
        self.bgr.cols() as u32
    }

    pub fn height(&self) -> u32 {
        self.bgr.rows() as u32
    }

    /// The colour pixels for the dot detector: a raw's linear levels, else the photo's read
    /// through `tone` (the camera's curve, learned by the unit's calibration).
    pub fn colour<'a>(&'a self, tone: &'a ToneCurve) -> ColourView<'a> {
        let m: &Mat = self.linear.as_ref().unwrap_or(&self.bgr);
        let data = m.data_bytes().unwrap_or(&[]);
        let view = ColourView {
            width: m.cols() as usize,
            height: m.rows() as usize,
            stride: m.cols() as usize * 3,
            order: ChannelOrder::Bgr,
            data,
            tone: None,
        };
        // A raw's levels are linear already.
        if self.linear.is_some() {
            view
        } else {
            view.through(tone)
        }
    }

    /// The full-resolution grey image.
    pub(crate) fn grey(&self) -> opencv::Result<&Mat> {
        get_or_make(&self.grey, || {
            let mut grey = buffers::take(self.bgr.rows(), self.bgr.cols(), CV_8UC1);
            imgproc::cvt_color(&*self.bgr, &mut grey, imgproc::COLOR_BGR2GRAY, 0)?;
            Ok(grey)
        })
    }

    /// Grey at 1/`factor` size (1, 2, 4 or 8; others round down to one of them): pixel `i`
    /// averages full-resolution pixels `factor i` to `factor i + factor - 1`, centred at
    /// `factor i + (factor - 1) / 2` (`docs/conventions.md`).
    pub fn reduced_grey(&self, factor: u32) -> opencv::Result<&Mat> {
        match factor {
            0 | 1 => self.grey(),
            2 | 3 => get_or_make(&self.reduced[0], || halve(self.grey()?, CV_8UC1)),
            4..=7 => get_or_make(&self.reduced[1], || halve(self.reduced_grey(2)?, CV_8UC1)),
            _ => get_or_make(&self.reduced[2], || halve(self.reduced_grey(4)?, CV_8UC1)),
        }
    }

    /// Colour channel `channel` (0 red, 1 green, 2 blue) of the region `crop` of the photo at
    /// 1/`factor` size (a power of two), in that size's pixels: the same pixels as
    /// [`Photo::reduced_grey`]'s over `crop`, in one channel.
    pub fn channel_crop(&self, crop: Rect, factor: u32, channel: u8) -> opencv::Result<Mat> {
        let f = factor.max(1) as i32;
        let full = Rect::new(crop.x * f, crop.y * f, crop.width * f, crop.height * f);
        let mut plane = Mat::default();
        // BGR order: red is the last plane.
        opencv::core::extract_channel(&Mat::roi(&*self.bgr, full)?, &mut plane, 2 - channel.min(2) as i32)?;
        let mut f = f;
        while f > 1 {
            plane = halve(&plane, CV_8UC1)?;
            f /= 2;
        }
        Ok(plane)
    }

    /// The photo scaled to `width_px` wide (at most its own width), RGB, for a report.
    pub fn thumbnail(&self, width_px: u32) -> opencv::Result<Kept> {
        let (w, h) = (self.width(), self.height());
        let (tw, th) = thumbnails::size_px(w, h, width_px);
        // Halvings first (OpenCV's fast exact 2x2 path), then one area resize: a single
        // area resize by a non-integer factor from full size costs five times as much.
        let mut small: Option<Mat> = None;
        loop {
            let src = small.as_ref().unwrap_or(&*self.bgr);
            if src.cols() < 2 * tw as i32 || src.rows() < 2 * th as i32 {
                break;
            }
            small = Some(halve(src, CV_8UC3)?);
        }
        let src = small.as_ref().unwrap_or(&*self.bgr);
        let mut sized = Mat::default();
        imgproc::resize(src, &mut sized, Size::new(tw as i32, th as i32), 0.0, 0.0, imgproc::INTER_AREA)?;
        let mut rgb = Mat::default();
        imgproc::cvt_color(&sized, &mut rgb, imgproc::COLOR_BGR2RGB, 0)?;
        let image = image::RgbImage::from_raw(tw, th, rgb.data_bytes()?.to_vec())
            .ok_or_else(|| opencv::Error::new(opencv::core::StsError, "thumbnail size mismatch"))?;
        Ok(Kept { image, full_width_px: w, full_height_px: h })
    }
}
