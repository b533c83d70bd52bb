//! Thumbnails made from each photo's one decode and kept until a report draws on them, so
//! `--report` never reads or decodes a photo a second time. A command that writes a
//! report holds a [`Keeping`] over its run; while one is held, every photo decoded to full
//! resolution leaves its thumbnail here, and the report takes it back out by the photo's
//! path. The first 8 MB of them wait as pixels; the rest as JPEG (about 25 kB at 320 px
//! wide, a tenth of the pixels), so a 300-photo report holds a few MB of them, not 70.

use image::RgbImage;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// A photo scaled down, with the full size it was scaled from.
pub struct Kept {
    pub image: RgbImage,
    pub full_width_px: u32,
    pub full_height_px: u32,
}

/// A thumbnail waiting for its report: as made while the run's unpacked ones fit in
/// [`UNPACKED_BYTES`], as JPEG after.
enum Packed {
    Pixels(Kept),
    Jpeg { jpeg: Vec<u8>, full_width_px: u32, full_height_px: u32 },
}

/// What a run's thumbnails may hold unpacked, bytes: a dive's 10-40 photos (230 kB each at
/// 320 px wide) wait as pixels, since packing one and unpacking it costs 2-3 ms, a tenth of
/// what a report adds to a 16-photo `laser` run; a 300-photo run's later ones are packed.
const UNPACKED_BYTES: usize = 8 << 20;

/// Quality of the waiting JPEG: the report encodes the thumbnail again at 82, so this
/// loses nothing that shows.
const PACKED_QUALITY: u8 = 95;

struct Store {
    width_px: u32,
    holders: usize,
    kept: HashMap<PathBuf, Packed>,
    /// Bytes of the thumbnails kept as pixels.
    unpacked_bytes: usize,
}

static STORE: Mutex<Option<Store>> = Mutex::new(None);

fn store() -> std::sync::MutexGuard<'static, Option<Store>> {
    STORE.lock().unwrap_or_else(|e| e.into_inner())
}

/// While held, photos decoded in this process keep a thumbnail `width_px` wide. Dropping
/// the last holder forgets the thumbnails not taken.
pub struct Keeping(());

impl Keeping {
    pub fn start(width_px: u32) -> Keeping {
        let mut s = store();
        match s.as_mut() {
            Some(s) => {
                s.holders += 1;
                s.width_px = s.width_px.max(width_px);
            }
            None => *s = Some(Store { width_px, holders: 1, kept: HashMap::new(), unpacked_bytes: 0 }),
        }
        Keeping(())
    }
}

impl Drop for Keeping {
    fn drop(&mut self) {
        let mut s = store();
        if let Some(st) = s.as_mut() {
            st.holders -= 1;
            if st.holders == 0 {
                *s = None;
            }
        }
    }
}

/// The width thumbnails are wanted at, when a report is being made.
pub fn wanted_width_px() -> Option<u32> {
    store().as_ref().map(|s| s.width_px)
}

/// The thumbnail's size for a `width` x `height` photo shown `width_px` wide.
pub fn size_px(width: u32, height: u32, width_px: u32) -> (u32, u32) {
    let tw = width_px.min(width).max(1);
    let th = ((height as f64 * tw as f64 / width.max(1) as f64).round() as u32).max(1);
    (tw, th)
}

/// Keeps `photo`'s thumbnail, if a report is being made.
pub fn keep(photo: &Path, kept: Kept) {
    let bytes = kept.image.as_raw().len();
    let kept = {
        let mut s = store();
        // No report is being made.
        let Some(s) = s.as_mut() else { return };
        if s.unpacked_bytes + bytes <= UNPACKED_BYTES {
            s.unpacked_bytes += bytes;
            s.kept.insert(photo.to_path_buf(), Packed::Pixels(kept));
            return;
        }
        kept
    };
    // Encoded on the caller's (pool) thread, outside the lock. A thumbnail that fails to
    // encode is only one the report reads again.
    let mut jpeg = Vec::new();
    let mut encoder = image::codecs::jpeg::JpegEncoder::new_with_quality(&mut jpeg, PACKED_QUALITY);
    if encoder.encode_image(&kept.image).is_err() {
        return;
    }
    let packed = Packed::Jpeg { jpeg, full_width_px: kept.full_width_px, full_height_px: kept.full_height_px };
    if let Some(s) = store().as_mut() {
        s.kept.insert(photo.to_path_buf(), packed);
    }
}

/// The thumbnail kept for `photo`, taken out of the store.
pub fn take(photo: &Path) -> Option<Kept> {
    let packed = store().as_mut()?.kept.remove(photo)?;
    match packed {
        Packed::Pixels(kept) => Some(kept),
        Packed::Jpeg { jpeg, full_width_px, full_height_px } => {
            let image = image::load_from_memory_with_format(&jpeg, image::ImageFormat::Jpeg).ok()?.to_rgb8();
            Some(Kept { image, full_width_px, full_height_px })
        }
    }
}
