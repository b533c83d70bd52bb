//! What a photo says about itself: camera make, model and body serial, capture time, focal
//! length, and the TG-6's water depth, pressure and temperature.
//!
//! One small TIFF reader serves both JPEG (EXIF in APP1) and ORF (a TIFF itself), because
//! the tags fslcal needs are the same in both and rawler's EXIF summary has neither the
//! EXIF 2.31 underwater tags nor the Olympus body serial, which Olympus keeps in its maker
//! note's Equipment IFD rather than in EXIF's `BodySerialNumber`. Every read is
//! bounds-checked: a damaged EXIF block yields fewer fields, never a panic.

use serde::{Deserialize, Serialize};

/// The fields fslcal uses. Absent tags stay `None`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PhotoExif {
    pub make: Option<String>,
    pub model: Option<String>,
    /// Camera body serial (EXIF `BodySerialNumber`, else the Olympus maker note's).
    pub serial: Option<String>,
    /// `DateTimeOriginal` as written, `YYYY:MM:DD HH:MM:SS` (camera's local time).
    pub date_time: Option<String>,
    pub focal_length_mm: Option<f64>,
    /// EXIF 2.31 `WaterDepth`, metres (negative above the surface).
    pub water_depth_m: Option<f64>,
    /// EXIF 2.31 `Pressure`, hectopascals.
    pub pressure_hpa: Option<f64>,
    /// EXIF 2.31 `Temperature` (ambient), degrees Celsius.
    pub temperature_c: Option<f64>,
}

impl PhotoExif {
    /// Reads the EXIF of a JPEG or a TIFF-based raw (ORF). `None`: the file carries none.
    pub fn from_bytes(bytes: &[u8]) -> Option<PhotoExif> {
        if bytes.starts_with(&[0xFF, 0xD8]) {
            return jpeg_exif_tiff(bytes).and_then(read_tiff);
        }
        read_tiff(bytes)
    }

    /// Reads the EXIF at the start of a photo file (the first MiB holds it in JPEGs and in
    /// ORFs, whose pixels follow their tags). `None` also when the file cannot be read: the
    /// photo's own reader reports that.
    pub fn read_file(path: &std::path::Path) -> Option<PhotoExif> {
        use std::io::Read;
        let mut head = Vec::new();
        crate::photo::counter::count(crate::photo::counter::Event::HeaderRead);
        std::fs::File::open(path).ok()?.take(1 << 20).read_to_end(&mut head).ok()?;
        PhotoExif::from_bytes(&head)
    }

    /// "OLYMPUS CORPORATION TG-6 #BHR201234", as much of it as is known.
    pub fn camera_label(&self) -> String {
        let mut parts: Vec<String> = [&self.make, &self.model].into_iter().flatten().cloned().collect();
        if let Some(s) = &self.serial {
            parts.push(format!("serial {s}"));
        }
        if parts.is_empty() {
            "unknown camera".into()
        } else {
            parts.join(" ")
        }
    }
}

/// The TIFF block inside a JPEG's `Exif\0\0` APP1 segment.
fn jpeg_exif_tiff(bytes: &[u8]) -> Option<&[u8]> {
    let mut i = 2;
    while i + 4 <= bytes.len() {
        if bytes[i] != 0xFF {
            return None;
        }
        let marker = bytes[i + 1];
        // Start of scan: the header segments are over.
        if marker == 0xDA || marker == 0xD9 {
            return None;
        }
        let len = u16::from_be_bytes([bytes[i + 2], bytes[i + 3]]) as usize;
        let seg = bytes.get(i + 4..i + 2 + len)?;
        if marker == 0xE1 && seg.starts_with(b"Exif\0\0") {
            return Some(&seg[6..]);
        }
        i += 2 + len;
    }
    None
}

#[derive(Clone, Copy)]
struct Tiff<'a> {
    /// Offsets in the file are relative to this slice's start.
    data: &'a [u8],
    little: bool,
}

/// One IFD entry: its type, count, and where its value bytes start in `data`.
#[derive(Clone, Copy)]
struct Entry {
    kind: u16,
    count: u32,
    value_at: usize,
}

const TAG_MAKE: u16 = 0x010F;
const TAG_MODEL: u16 = 0x0110;
const TAG_STRIP_OFFSETS: u16 = 0x0111;
const TAG_STRIP_BYTE_COUNTS: u16 = 0x0117;
const TAG_EXIF_IFD: u16 = 0x8769;
const TAG_DATE_TIME_ORIGINAL: u16 = 0x9003;
const TAG_FOCAL_LENGTH: u16 = 0x920A;
const TAG_MAKER_NOTE: u16 = 0x927C;
const TAG_TEMPERATURE: u16 = 0x9400;
const TAG_PRESSURE: u16 = 0x9402;
const TAG_WATER_DEPTH: u16 = 0x9403;
const TAG_BODY_SERIAL: u16 = 0xA431;
const OLYMPUS_EQUIPMENT_IFD: u16 = 0x2010;
const OLYMPUS_SERIAL: u16 = 0x0101;

impl<'a> Tiff<'a> {
    fn u16_at(&self, at: usize) -> Option<u16> {
        let b = self.data.get(at..at + 2)?;
        Some(if self.little { u16::from_le_bytes([b[0], b[1]]) } else { u16::from_be_bytes([b[0], b[1]]) })
    }

    fn u32_at(&self, at: usize) -> Option<u32> {
        let b: [u8; 4] = self.data.get(at..at + 4)?.try_into().ok()?;
        Some(if self.little { u32::from_le_bytes(b) } else { u32::from_be_bytes(b) })
    }

    /// The entries of the IFD at `at`, with value offsets taken relative to `base`.
    fn ifd(&self, at: usize, base: usize) -> Option<Vec<(u16, Entry)>> {
        let n = self.u16_at(at)? as usize;
        // A real IFD has at most a few hundred entries; more is garbage.
        if n > 1000 {
            return None;
        }
        let mut out = Vec::with_capacity(n);
        for k in 0..n {
            let e = at + 2 + 12 * k;
            let (tag, kind, count) = (self.u16_at(e)?, self.u16_at(e + 2)?, self.u32_at(e + 4)?);
            let size = type_size(kind).checked_mul(count as usize)?;
            let value_at = if size <= 4 { e + 8 } else { base.checked_add(self.u32_at(e + 8)? as usize)? };
            if value_at.checked_add(size)? > self.data.len() {
                continue;
            }
            out.push((tag, Entry { kind, count, value_at }));
        }
        Some(out)
    }

    fn ascii(&self, e: &Entry) -> Option<String> {
        if e.kind != 2 && e.kind != 7 {
            return None;
        }
        let raw = self.data.get(e.value_at..e.value_at + e.count as usize)?;
        let text = raw.split(|&b| b == 0).next().unwrap_or(&[]);
        let s = String::from_utf8_lossy(text).trim().to_string();
        (!s.is_empty()).then_some(s)
    }

    fn number(&self, e: &Entry) -> Option<f64> {
        let v = match e.kind {
            3 => self.u16_at(e.value_at)? as f64,
            4 => self.u32_at(e.value_at)? as f64,
            5 => self.u32_at(e.value_at)? as f64 / self.u32_at(e.value_at + 4)? as f64,
            10 => self.u32_at(e.value_at)? as i32 as f64 / self.u32_at(e.value_at + 4)? as i32 as f64,
            _ => return None,
        };
        // EXIF writes 0xFFFFFFFF/1 or x/0 for "unknown".
        (v.is_finite() && v.abs() < 1e6).then_some(v)
    }
}

fn type_size(kind: u16) -> usize {
    match kind {
        1 | 2 | 6 | 7 => 1,
        3 | 8 => 2,
        4 | 9 | 11 | 13 => 4,
        5 | 10 | 12 => 8,
        _ => 1,
    }
}

fn find(entries: &[(u16, Entry)], tag: u16) -> Option<&Entry> {
    entries.iter().find(|(t, _)| *t == tag).map(|(_, e)| e)
}

/// A TIFF's byte order and its first IFD.
fn open_tiff(data: &[u8]) -> Option<(Tiff<'_>, Vec<(u16, Entry)>)> {
    let little = match data.get(..2)? {
        b"II" => true,
        b"MM" => false,
        _ => return None,
    };
    let t = Tiff { data, little };
    let ifd0 = t.ifd(t.u32_at(4)? as usize, 0)?;
    Some((t, ifd0))
}

fn read_tiff(data: &[u8]) -> Option<PhotoExif> {
    let (t, ifd0) = open_tiff(data)?;
    let mut exif = PhotoExif {
        make: find(&ifd0, TAG_MAKE).and_then(|e| t.ascii(e)),
        model: find(&ifd0, TAG_MODEL).and_then(|e| t.ascii(e)),
        ..PhotoExif::default()
    };
    let Some(sub) = find(&ifd0, TAG_EXIF_IFD).and_then(|e| t.u32_at(e.value_at)).and_then(|at| t.ifd(at as usize, 0))
    else {
        return Some(exif);
    };
    let num = |tag| find(&sub, tag).and_then(|e| t.number(e));
    exif.date_time = find(&sub, TAG_DATE_TIME_ORIGINAL).and_then(|e| t.ascii(e));
    exif.focal_length_mm = num(TAG_FOCAL_LENGTH);
    exif.temperature_c = num(TAG_TEMPERATURE);
    exif.pressure_hpa = num(TAG_PRESSURE);
    exif.water_depth_m = num(TAG_WATER_DEPTH);
    exif.serial = find(&sub, TAG_BODY_SERIAL)
        .and_then(|e| t.ascii(e))
        .or_else(|| find(&sub, TAG_MAKER_NOTE).and_then(|e| olympus_serial(&t, e)));
    Some(exif)
}

/// Where the first IFD's image strips end, bytes from the file's start: a raw file shorter
/// than this was cut off while copying. `None`: not a TIFF, or no strips.
pub fn strips_end(data: &[u8]) -> Option<u64> {
    let (t, ifd0) = open_tiff(data)?;
    let (offsets, counts) = (find(&ifd0, TAG_STRIP_OFFSETS)?, find(&ifd0, TAG_STRIP_BYTE_COUNTS)?);
    let nth = |e: &Entry, i: usize| -> Option<u64> {
        match e.kind {
            3 => t.u16_at(e.value_at + 2 * i).map(u64::from),
            4 => t.u32_at(e.value_at + 4 * i).map(u64::from),
            _ => None,
        }
    };
    (0..offsets.count.min(counts.count) as usize)
        .map(|i| Some(nth(offsets, i)? + nth(counts, i)?))
        .try_fold(0u64, |m, e| e.map(|e| m.max(e)))
}

/// The body serial from an Olympus maker note's Equipment IFD.
fn olympus_serial(t: &Tiff, note: &Entry) -> Option<String> {
    let start = note.value_at;
    let head = t.data.get(start..start + 16)?;
    // New-style notes ("OLYMPUS\0II", "OM SYSTEM\0...II") count offsets from the note's
    // first byte; the old style ("OLYMP\0") from the TIFF header.
    let (ifd_at, base) = if head.starts_with(b"OLYMPUS\0") {
        (start + 12, start)
    } else if head.starts_with(b"OM SYSTEM\0") {
        (start + 16, start)
    } else if head.starts_with(b"OLYMP\0") {
        (start + 8, 0)
    } else {
        return None;
    };
    let main = t.ifd(ifd_at, base)?;
    let equipment = find(&main, OLYMPUS_EQUIPMENT_IFD)?;
    let at = t.u32_at(equipment.value_at)? as usize;
    let eq = t.ifd(base.checked_add(at)?, base)?;
    find(&eq, OLYMPUS_SERIAL).and_then(|e| t.ascii(e))
}

#[cfg(test)]
mod tests {
    use super::*;
    use calib_targets::orf::{exif_app1, tg6_orf, OrfMeta};

    #[test]
    fn reads_every_field_from_a_tg6_orf_and_a_jpeg() {
        let meta = OrfMeta { serial: "BHX123".into(), water_depth_m: Some(-0.5), ..OrfMeta::default() };
        let img = image::RgbImage::from_pixel(16, 12, image::Rgb([90, 120, 60]));
        let orf = tg6_orf(&img, &meta);
        let mut jpeg = Vec::new();
        image::codecs::jpeg::JpegEncoder::new(&mut jpeg).encode_image(&img).unwrap();
        let jpeg = calib_targets::orf::jpeg_with_exif(&jpeg, &meta);
        assert!(exif_app1(&meta).len() > 100);
        for bytes in [&orf, &jpeg] {
            let e = PhotoExif::from_bytes(bytes).unwrap();
            assert_eq!(e.make.as_deref(), Some("OLYMPUS CORPORATION"));
            assert_eq!(e.model.as_deref(), Some("TG-6"));
            assert_eq!(e.serial.as_deref(), Some("BHX123"));
            assert_eq!(e.date_time.as_deref(), Some("2024:07:14 10:31:07"));
            assert_eq!(e.focal_length_mm, Some(4.5));
            assert_eq!(e.water_depth_m, Some(-0.5));
            assert_eq!(e.pressure_hpa, Some(1651.0));
            assert_eq!(e.temperature_c, Some(24.0));
        }
        // The decoded JPEG is still a JPEG.
        assert_eq!(image::load_from_memory(&jpeg).unwrap().width(), 16);
    }

    #[test]
    fn damaged_exif_gives_fewer_fields_not_a_panic() {
        let meta = OrfMeta::default();
        let img = image::RgbImage::from_pixel(16, 12, image::Rgb([90, 120, 60]));
        let orf = tg6_orf(&img, &meta);
        for cut in [0, 1, 3, 7, 9, 40, 200, 600, 1000] {
            let _ = PhotoExif::from_bytes(&orf[..cut.min(orf.len())]);
        }
        let mut flipped = orf.clone();
        for b in flipped.iter_mut().skip(8).step_by(7).take(200) {
            *b ^= 0xA5;
        }
        let _ = PhotoExif::from_bytes(&flipped);
        assert_eq!(PhotoExif::from_bytes(b"not a photo"), None);
    }
}
