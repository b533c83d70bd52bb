//! Camera raw files (Olympus ORF, the TG-6 first), decoded with rawler.
//!
//! The thesis works from raw files because the camera's JPEG engine corrects distortion
//! behind the user's back (§2.4.1): calibration and measurement must see the sensor's
//! pixels. [`RawFrame`] is the sensor's active area with its black and white levels and CFA
//! layout; [`develop`] turns it into pictures (grey-world balanced sRGB, a linear view for
//! the dot detector, a binned grey for the board search). Nothing here touches OpenCV.

pub mod develop;

use crate::photo::exif::strips_end;
use std::path::Path;
use std::sync::Arc;

#[derive(Debug, thiserror::Error)]
pub enum RawError {
    /// The cause is in the message, not a `source`, or `{:#}` would say it twice.
    #[error("{path}: cannot read: {cause}")]
    Io { path: String, cause: std::io::Error },
    #[error("{path}: truncated raw file ({have} of {need} bytes); copy the file from the card again")]
    Truncated { path: String, have: u64, need: u64 },
    #[error("{path}: not an Olympus ORF raw file (no ORF header); fslcal reads ORF, JPEG and PNG")]
    NotOrf { path: String },
    #[error("{path}: raw files from {make} {model} are not supported (rawler has no definition for it); use the camera's JPEG or a TG-6 ORF")]
    Unsupported { path: String, make: String, model: String },
    #[error("{path}: corrupt raw file ({why}); copy the file from the card again")]
    Corrupt { path: String, why: String },
}

/// rawler turns its own panics on malformed files into errors (`catch_unwind`), but the
/// panic hook has printed a multi-line backtrace to stderr by then. The error is reported
/// as one line; the hook stays quiet for panics raised inside rawler's code, wherever the
/// thread (rawler decodes rows on rayon's workers), and keeps every other panic loud.
fn silence_rawler_panics() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if info.location().is_some_and(|l| l.file().contains("/rawler-")) {
                return;
            }
            previous(info)
        }));
    });
}

/// Whether `bytes` start like an ORF: a TIFF whose magic is Olympus's `RO`/`RS` (or
/// `OR`/`SR` big-endian) instead of 42.
pub fn is_orf(bytes: &[u8]) -> bool {
    matches!(bytes.get(..4), Some(b"IIRO" | b"IIRS" | b"MMOR" | b"MMSR"))
}

/// The sensor's active area as decoded: raw samples (12-bit scale) with their levels.
pub struct RawFrame {
    /// The whole sensor, row-major; only the crop is a picture.
    samples: Vec<u16>,
    sensor_width: usize,
    sensor_height: usize,
    /// Top-left of the picture on the sensor.
    x0: usize,
    y0: usize,
    pub width: usize,
    pub height: usize,
    /// Colour (0 R, 1 G, 2 B) of each site of the 2x2 pattern at the picture's origin,
    /// row-major.
    pattern: [u8; 4],
    /// Black level of each site of the same 2x2 pattern.
    black: [f32; 4],
    white: f32,
    /// The camera's as-shot white balance (R, G, B multipliers, G = 1), from the maker note.
    pub camera_wb: [f32; 3],
    pub make: String,
    pub model: String,
}

impl RawFrame {
    /// Decodes an ORF held in `bytes` (`path` names it in errors). Takes the bytes so that
    /// rawler reads them in place; they are freed once the samples are out.
    pub fn decode(bytes: Vec<u8>, path: &Path) -> Result<RawFrame, RawError> {
        let name = path.display().to_string();
        if !is_orf(&bytes) {
            return Err(RawError::NotOrf { path: name });
        }
        // rawler pads a short strip with zeros; a half-copied file must say so instead.
        match strips_end(&bytes) {
            Some(need) if need > bytes.len() as u64 => {
                return Err(RawError::Truncated { path: name, have: bytes.len() as u64, need });
            }
            Some(_) => {}
            None => return Err(RawError::Corrupt { path: name, why: "no image strips in its first IFD".into() }),
        }
        silence_rawler_panics();
        let source = rawler::rawsource::RawSource::new_from_shared_vec(Arc::new(bytes)).with_path(path);
        let image = rawler::decode(&source, &rawler::decoders::RawDecodeParams::default()).map_err(|e| match e {
            rawler::RawlerError::Unsupported { make, model, .. } => {
                RawError::Unsupported { path: name.clone(), make, model }
            }
            rawler::RawlerError::DecoderFailed(why) if why.contains("Caught a panic") => {
                RawError::Corrupt { path: name.clone(), why: "the decoder could not make sense of its contents".into() }
            }
            rawler::RawlerError::DecoderFailed(why) => RawError::Corrupt {
                path: name.clone(),
                why: why.lines().next().unwrap_or("decoder failed").trim().to_string(),
            },
        })?;
        drop(source);
        Self::from_rawler(image, &name)
    }

    fn from_rawler(image: rawler::RawImage, name: &str) -> Result<RawFrame, RawError> {
        let corrupt = |why: &str| RawError::Corrupt { path: name.to_string(), why: why.to_string() };
        if image.cpp != 1 {
            return Err(corrupt("not a colour-filter-array raw"));
        }
        let rawler::rawimage::RawPhotometricInterpretation::Cfa(config) = &image.photometric else {
            return Err(corrupt("not a colour-filter-array raw"));
        };
        let (sw, sh) = (image.width, image.height);
        let crop = image.crop_area.or(image.active_area);
        let (x0, y0, width, height) = match crop {
            Some(r) => (r.p.x, r.p.y, r.d.w, r.d.h),
            None => (0, 0, sw, sh),
        };
        if width < 4 || height < 4 || x0 + width > sw || y0 + height > sh {
            return Err(corrupt("its crop lies outside the sensor"));
        }
        let mut pattern = [0u8; 4];
        for (i, p) in pattern.iter_mut().enumerate() {
            let c = config.cfa.color_at(y0 + i / 2, x0 + i % 2);
            // Some CFAs name their second green 3; a colour above that is not RGB Bayer.
            *p = match c {
                0..=2 => c as u8,
                3 => 1,
                _ => return Err(corrupt("its colour filter is not RGB Bayer")),
            };
        }
        let levels = image.blacklevel.as_bayer_array();
        let bw = image.blacklevel.width.max(1);
        let bh = image.blacklevel.height.max(1);
        let mut black = [0f32; 4];
        for (i, b) in black.iter_mut().enumerate() {
            let (y, x) = ((y0 + i / 2) % bh, (x0 + i % 2) % bw);
            *b = levels[(y * bw + x).min(3)];
        }
        let white = image.whitelevel.as_bayer_array()[0];
        let floor = black.iter().cloned().fold(0.0, f32::max) + 16.0;
        // Written so that a NaN white level is refused too.
        if white.is_nan() || white <= floor {
            return Err(corrupt("its white level is not above its black level"));
        }
        let wb = image.wb_coeffs;
        let camera_wb = if wb[..3].iter().all(|v| v.is_finite() && *v > 0.0) {
            [wb[0] / wb[1], 1.0, wb[2] / wb[1]]
        } else {
            [1.0; 3]
        };
        let samples = match image.data {
            rawler::RawImageData::Integer(v) => v,
            rawler::RawImageData::Float(_) => return Err(corrupt("floating-point samples")),
        };
        if samples.len() != sw * sh {
            return Err(corrupt("sample count does not match its size"));
        }
        Ok(RawFrame {
            samples,
            sensor_width: sw,
            sensor_height: sh,
            x0,
            y0,
            width,
            height,
            pattern,
            black,
            white,
            camera_wb,
            make: image.clean_make,
            model: image.clean_model,
        })
    }

    /// Reads and decodes an ORF file.
    pub fn read(path: &Path) -> Result<RawFrame, RawError> {
        crate::photo::counter::count(crate::photo::counter::Event::FileRead);
        let bytes = std::fs::read(path).map_err(|cause| RawError::Io { path: path.display().to_string(), cause })?;
        Self::decode(bytes, path)
    }

    /// Colour (0 R, 1 G, 2 B) of picture pixel (x, y); negative and past-the-edge positions
    /// follow the same 2x2 pattern.
    #[inline]
    pub fn colour_at(&self, x: isize, y: isize) -> usize {
        self.pattern[((y & 1) * 2 + (x & 1)) as usize] as usize
    }

    /// Linear level of picture pixel (x, y): black subtracted, 1.0 at the white level. The
    /// sensor's border outside the picture is used where it exists (so interpolation at
    /// the picture's edge sees real neighbours); past the sensor's edge, the nearest sample
    /// of the same colour.
    #[inline]
    pub fn linear_at(&self, x: isize, y: isize) -> f32 {
        let same_site_clamp = |p: isize, len: usize| -> usize {
            let len = len as isize;
            if p < 0 {
                p.rem_euclid(2) as usize
            } else if p >= len {
                (len - 2 + (p - len).rem_euclid(2)) as usize
            } else {
                p as usize
            }
        };
        let sx = same_site_clamp(self.x0 as isize + x, self.sensor_width);
        let sy = same_site_clamp(self.y0 as isize + y, self.sensor_height);
        let black = self.black[((y & 1) * 2 + (x & 1)) as usize];
        ((self.samples[sy * self.sensor_width + sx] as f32 - black) / (self.white - black)).max(0.0)
    }

    /// Row `y` of the picture's raw samples (12-bit scale, black not subtracted).
    #[inline]
    fn picture_row(&self, y: usize) -> &[u16] {
        let start = (self.y0 + y) * self.sensor_width + self.x0;
        &self.samples[start..start + self.width]
    }

    /// Bytes held, for memory accounting.
    pub fn heap_bytes(&self) -> usize {
        self.samples.len() * 2
    }
}
