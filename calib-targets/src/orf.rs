//! Synthetic Olympus ORF files laid out as the TG-6 writes them, for testing the raw path
//! without shipping a real raw (none may be shipped).
//!
//! What is copied from the real TG-6 file: little-endian TIFF with the ORF magic `IIRO`;
//! IFD0 with make `OLYMPUS CORPORATION`, model `TG-6`, a 4040x3016 sensor of 16-bit samples
//! in uncompressed strips (12-bit values left-aligned, as the camera stores them); an EXIF
//! IFD with the capture time, focal length, the EXIF 2.31 water depth, pressure and
//! temperature the TG-6 records, and an Olympus maker note (`OLYMPUS\0II\x03\0`, offsets
//! relative to the note) whose Equipment IFD holds the body serial and whose
//! ImageProcessing IFD holds the per-site black levels (257/256/257/257), the white-balance
//! multipliers and the 4000x3000 crop at (8, 8). The CFA pattern is GRBG.
//!
//! The scene's 8-bit sRGB pixels are linearised and scaled by per-channel sensor responses
//! before mosaicking, so that a decoder's linear output has known channel means.

use image::RgbImage;

/// TG-6 sensor: photo size plus its masked and padding border.
pub const TG6_SENSOR: (u32, u32) = (4040, 3016);
/// Top-left of the 4000x3000 crop on the sensor.
pub const TG6_CROP_ORIGIN: (u32, u32) = (8, 8);
/// Black level per 2x2 site (row-major from the sensor's origin), as real TG-6 files carry.
pub const TG6_BLACK: [u16; 4] = [257, 256, 257, 257];
/// White level (rawler's TG-6 camera definition).
pub const TG6_WHITE: u16 = 4000;

/// What a synthetic raw records besides its pixels.
#[derive(Clone, Debug, PartialEq)]
pub struct OrfMeta {
    pub make: String,
    pub model: String,
    /// Body serial, in the maker note's Equipment IFD (where Olympus keeps it).
    pub serial: String,
    /// EXIF `DateTimeOriginal`, `YYYY:MM:DD HH:MM:SS`.
    pub date_time: String,
    pub focal_length_mm: f64,
    pub water_depth_m: Option<f64>,
    pub pressure_hpa: Option<f64>,
    pub temperature_c: Option<f64>,
    /// Linear response of the sensor's R, G, B sites to the scene's linear R, G, B: the
    /// water's and the sensor's colour cast a grey-world balance must undo.
    pub response: [f64; 3],
}

impl Default for OrfMeta {
    fn default() -> Self {
        OrfMeta {
            make: "OLYMPUS CORPORATION".into(),
            model: "TG-6".into(),
            serial: "BHR201234".into(),
            date_time: "2024:07:14 10:31:07".into(),
            focal_length_mm: 4.5,
            water_depth_m: Some(6.4),
            pressure_hpa: Some(1651.0),
            temperature_c: Some(24.0),
            response: [0.35, 0.9, 0.6],
        }
    }
}

/// sRGB-encoded 8-bit level to linear light in [0, 1].
pub fn srgb_to_linear(v: u8) -> f64 {
    let c = v as f64 / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Colour (0 R, 1 G, 2 B) of a GRBG sensor site.
pub fn grbg_colour(x: u32, y: u32) -> usize {
    match (y % 2, x % 2) {
        (0, 0) | (1, 1) => 1,
        (0, 1) => 0,
        _ => 2,
    }
}

/// The raw value (12-bit scale, before left-alignment) of sensor site (x, y) for a scene
/// pixel: black plus the linear, response-scaled level, clipped at white as a sensor clips.
/// A channel the render clipped (255: a laser dot's core, a glint) was beyond the sensor's
/// range too, and clips at white whatever the response.
pub fn raw_level(rgb: [u8; 3], colour: usize, black: u16, response: [f64; 3]) -> u16 {
    if rgb[colour] == 255 {
        return TG6_WHITE;
    }
    let lin = srgb_to_linear(rgb[colour]) * response[colour];
    let v = black as f64 + lin * (TG6_WHITE - black) as f64;
    v.round().clamp(0.0, TG6_WHITE as f64) as u16
}

/// A TG-6 ORF of `image` (4000x3000 for a real-sized file; any even size works, the sensor
/// keeps the TG-6's 40x16 border).
pub fn tg6_orf(image: &RgbImage, meta: &OrfMeta) -> Vec<u8> {
    let (cw, ch) = image.dimensions();
    let (sw, sh) = (cw + TG6_SENSOR.0 - 4000, ch + TG6_SENSOR.1 - 3000);
    let (ox, oy) = TG6_CROP_ORIGIN;
    let mut strips = Vec::with_capacity(sw as usize * sh as usize * 2);
    for y in 0..sh {
        for x in 0..sw {
            // The border outside the crop sees the edge of the scene, as a real sensor's
            // unused margin sees light.
            let px = image.get_pixel(x.saturating_sub(ox).min(cw - 1), y.saturating_sub(oy).min(ch - 1)).0;
            let black = TG6_BLACK[((y % 2) * 2 + x % 2) as usize];
            let v = raw_level(px, grbg_colour(x, y), black, meta.response);
            strips.extend_from_slice(&(v << 4).to_le_bytes());
        }
    }
    orf_file(sw, sh, (cw, ch), meta, strips)
}

/// An EXIF APP1 segment (as a JPEG carries it) with the same tags and maker note as the ORF.
pub fn exif_app1(meta: &OrfMeta) -> Vec<u8> {
    let mut tiff = Tiff::new(*b"II*\0");
    let exif_at = {
        let ifd0 = ifd0_entries(meta, None);
        tiff.ifd_size(&ifd0) + 8
    };
    let ifd0 = ifd0_entries(meta, Some(exif_at));
    tiff.write_ifd(&ifd0, 0);
    let exif = exif_entries(meta);
    tiff.write_ifd(&exif, 0);
    let body = tiff.finish();
    let mut seg = vec![0xFF, 0xE1];
    seg.extend_from_slice(&((body.len() + 8) as u16).to_be_bytes());
    seg.extend_from_slice(b"Exif\0\0");
    seg.extend_from_slice(&body);
    seg
}

/// `jpeg` with an EXIF segment right after its start-of-image marker.
pub fn jpeg_with_exif(jpeg: &[u8], meta: &OrfMeta) -> Vec<u8> {
    let mut out = jpeg[..2].to_vec();
    out.extend_from_slice(&exif_app1(meta));
    out.extend_from_slice(&jpeg[2..]);
    out
}

fn orf_file(sw: u32, sh: u32, crop: (u32, u32), meta: &OrfMeta, strips: Vec<u8>) -> Vec<u8> {
    let mut tiff = Tiff::new(*b"IIRO");
    // Sizes first (offsets depend on them), then the real write.
    let rows_per_strip = sh.div_ceil(8);
    let strip_count = sh.div_ceil(rows_per_strip);
    let placeholder = raw_ifd_entries(meta, sw, sh, rows_per_strip, strip_count, 0, 0);
    let ifd0_size = tiff.ifd_size(&placeholder);
    let exif_at = 8 + ifd0_size;
    let exif_size = tiff.ifd_size(&exif_entries_with_crop(meta, crop));
    let strips_at = exif_at + exif_size;
    let ifd0 = raw_ifd_entries(meta, sw, sh, rows_per_strip, strip_count, exif_at, strips_at);
    tiff.write_ifd(&ifd0, 0);
    tiff.write_ifd(&exif_entries_with_crop(meta, crop), 0);
    debug_assert_eq!(tiff.bytes.len() as u32, strips_at);
    let mut bytes = tiff.finish();
    bytes.extend_from_slice(&strips);
    bytes
}

fn ifd0_entries(meta: &OrfMeta, exif_at: Option<u32>) -> Vec<Entry> {
    let mut e = vec![
        Entry::ascii(0x010F, &meta.make),
        Entry::ascii(0x0110, &meta.model),
        Entry::short(0x0112, &[1]),
        Entry::ascii(0x0131, "Version 1.0"),
        Entry::ascii(0x0132, &meta.date_time),
    ];
    e.push(Entry::long(0x8769, &[exif_at.unwrap_or(0)]));
    e
}

fn raw_ifd_entries(
    meta: &OrfMeta,
    sw: u32,
    sh: u32,
    rows_per_strip: u32,
    strip_count: u32,
    exif_at: u32,
    strips_at: u32,
) -> Vec<Entry> {
    let row_bytes = sw * 2;
    let offsets: Vec<u32> = (0..strip_count).map(|i| strips_at + i * rows_per_strip * row_bytes).collect();
    let counts: Vec<u32> =
        (0..strip_count).map(|i| (sh - i * rows_per_strip).min(rows_per_strip) * row_bytes).collect();
    let mut e = vec![
        Entry::long(0x00FE, &[0]),
        Entry::long(0x0100, &[sw]),
        Entry::long(0x0101, &[sh]),
        Entry::short(0x0102, &[16]),
        Entry::short(0x0103, &[1]),
        Entry::short(0x0106, &[32803]),
        Entry::long(0x0111, &offsets),
        Entry::short(0x0115, &[1]),
        Entry::long(0x0116, &[rows_per_strip]),
        Entry::long(0x0117, &counts),
        Entry::short(0x011C, &[1]),
    ];
    e.extend(ifd0_entries(meta, Some(exif_at)));
    e.sort_by_key(|x| x.tag);
    e
}

fn exif_entries(meta: &OrfMeta) -> Vec<Entry> {
    exif_entries_with_crop(meta, (4000, 3000))
}

fn exif_entries_with_crop(meta: &OrfMeta, crop: (u32, u32)) -> Vec<Entry> {
    let rational = |v: f64| ((v * 1000.0).round() as u32, 1000);
    let srational = |v: f64| ((v * 1000.0).round() as i32, 1000);
    let mut e = vec![
        Entry::rational(0x829A, &[(1, 200)]),
        Entry::rational(0x829D, &[(28, 10)]),
        Entry::short(0x8827, &[100]),
        Entry::ascii(0x9003, &meta.date_time),
        Entry::rational(0x920A, &[rational(meta.focal_length_mm)]),
    ];
    if let Some(t) = meta.temperature_c {
        e.push(Entry::srational(0x9400, &[srational(t)]));
    }
    if let Some(p) = meta.pressure_hpa {
        e.push(Entry::rational(0x9402, &[rational(p)]));
    }
    if let Some(d) = meta.water_depth_m {
        e.push(Entry::srational(0x9403, &[srational(d)]));
    }
    // Every offset inside the note is relative to the note itself, so it can sit anywhere.
    e.push(Entry::undefined(0x927C, maker_note(meta, crop)));
    e.sort_by_key(|x| x.tag);
    e
}

/// The Olympus maker note: header, a main IFD pointing at the Equipment and
/// ImageProcessing IFDs, every offset relative to the note's first byte.
fn maker_note(meta: &OrfMeta, crop: (u32, u32)) -> Vec<u8> {
    let mut note = Tiff::new_note();
    let main_probe = vec![Entry::undefined(0x0000, b"0100".to_vec()), Entry::ifd(0x2010, 0), Entry::ifd(0x2040, 0)];
    let equipment_at = 12 + note.ifd_size(&main_probe);
    let equipment = vec![
        Entry::undefined(0x0000, b"0100".to_vec()),
        Entry::ascii(0x0100, "D4591"),
        Entry::ascii(0x0101, &meta.serial),
        Entry::ascii(0x0102, "4109101001180000"),
    ];
    let processing_at = equipment_at + note.ifd_size(&equipment);
    let (ox, oy) = TG6_CROP_ORIGIN;
    let processing = vec![
        Entry::undefined(0x0000, b"0112".to_vec()),
        // The as-shot white balance undoes the sensor's response to daylight (real TG-6
        // files carry about 1.9 and 1.7).
        Entry::short(0x0100, &[wb_level(meta.response, 0), wb_level(meta.response, 2)]),
        Entry::short(0x0600, &TG6_BLACK),
        Entry::short(0x0612, &[ox as u16]),
        Entry::short(0x0613, &[oy as u16]),
        Entry::short(0x0614, &[crop.0 as u16]),
        Entry::short(0x0615, &[crop.1 as u16]),
    ];
    let main = vec![
        Entry::undefined(0x0000, b"0100".to_vec()),
        Entry::ifd(0x2010, equipment_at),
        Entry::ifd(0x2040, processing_at),
    ];
    note.write_ifd(&main, 0);
    note.write_ifd(&equipment, 0);
    note.write_ifd(&processing, 0);
    note.bytes
}

/// Maker-note white-balance level (256 = 1.0) of R (0) or B (2) for a sensor response.
fn wb_level(response: [f64; 3], colour: usize) -> u16 {
    (256.0 * response[1] / response[colour]).round().clamp(1.0, 65535.0) as u16
}

/// One IFD entry: tag, TIFF type, count, value bytes (little-endian).
#[derive(Clone, Debug)]
struct Entry {
    tag: u16,
    kind: u16,
    count: u32,
    data: Vec<u8>,
}

impl Entry {
    fn ascii(tag: u16, s: &str) -> Entry {
        let mut data = s.as_bytes().to_vec();
        data.push(0);
        Entry { tag, kind: 2, count: data.len() as u32, data }
    }
    fn short(tag: u16, v: &[u16]) -> Entry {
        Entry { tag, kind: 3, count: v.len() as u32, data: v.iter().flat_map(|x| x.to_le_bytes()).collect() }
    }
    fn long(tag: u16, v: &[u32]) -> Entry {
        Entry { tag, kind: 4, count: v.len() as u32, data: v.iter().flat_map(|x| x.to_le_bytes()).collect() }
    }
    fn rational(tag: u16, v: &[(u32, u32)]) -> Entry {
        let data = v.iter().flat_map(|(n, d)| n.to_le_bytes().into_iter().chain(d.to_le_bytes())).collect();
        Entry { tag, kind: 5, count: v.len() as u32, data }
    }
    fn srational(tag: u16, v: &[(i32, i32)]) -> Entry {
        let data = v.iter().flat_map(|(n, d)| n.to_le_bytes().into_iter().chain(d.to_le_bytes())).collect();
        Entry { tag, kind: 10, count: v.len() as u32, data }
    }
    fn undefined(tag: u16, data: Vec<u8>) -> Entry {
        Entry { tag, kind: 7, count: data.len() as u32, data }
    }
    /// A sub-IFD pointer as Olympus writes it (type 13, "IFD").
    fn ifd(tag: u16, offset: u32) -> Entry {
        Entry { tag, kind: 13, count: 1, data: offset.to_le_bytes().to_vec() }
    }
}

/// A little-endian TIFF (or maker note) being laid out: IFDs in order, each followed by its
/// out-of-line values.
struct Tiff {
    bytes: Vec<u8>,
}

impl Tiff {
    fn new(magic: [u8; 4]) -> Tiff {
        let mut bytes = magic.to_vec();
        bytes.extend_from_slice(&8u32.to_le_bytes());
        Tiff { bytes }
    }

    fn new_note() -> Tiff {
        Tiff { bytes: b"OLYMPUS\0II\x03\0".to_vec() }
    }

    fn ifd_size(&self, entries: &[Entry]) -> u32 {
        let out_of_line: usize =
            entries.iter().filter(|e| e.data.len() > 4).map(|e| e.data.len().next_multiple_of(2)).sum();
        (2 + 12 * entries.len() + 4 + out_of_line) as u32
    }

    fn write_ifd(&mut self, entries: &[Entry], next: u32) {
        let start = self.bytes.len();
        let mut data_at = start + 2 + 12 * entries.len() + 4;
        let mut table = Vec::new();
        let mut values = Vec::new();
        table.extend_from_slice(&(entries.len() as u16).to_le_bytes());
        for e in entries {
            table.extend_from_slice(&e.tag.to_le_bytes());
            table.extend_from_slice(&e.kind.to_le_bytes());
            table.extend_from_slice(&e.count.to_le_bytes());
            if e.data.len() <= 4 {
                let mut inline = e.data.clone();
                inline.resize(4, 0);
                table.extend_from_slice(&inline);
            } else {
                table.extend_from_slice(&(data_at as u32).to_le_bytes());
                values.extend_from_slice(&e.data);
                if e.data.len() % 2 == 1 {
                    values.push(0);
                }
                data_at = start + 2 + 12 * entries.len() + 4 + values.len();
            }
        }
        table.extend_from_slice(&next.to_le_bytes());
        self.bytes.extend_from_slice(&table);
        self.bytes.extend_from_slice(&values);
    }

    fn finish(self) -> Vec<u8> {
        self.bytes
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layout_has_the_orf_magic_and_the_strips_at_the_end() {
        let img = RgbImage::from_pixel(40, 30, image::Rgb([128, 128, 128]));
        let orf = tg6_orf(&img, &OrfMeta::default());
        assert_eq!(&orf[..4], b"IIRO");
        let (sw, sh) = (80usize, 46usize);
        let header = orf.len() - sw * sh * 2;
        // The first sample is a G site of mid grey: black + 0.216 * 0.9 * (4000 - 257), left-aligned.
        let first = u16::from_le_bytes([orf[header], orf[header + 1]]) >> 4;
        assert_eq!(first, raw_level([128; 3], 1, 257, OrfMeta::default().response));
        assert!((first as f64 - (257.0 + srgb_to_linear(128) * 0.9 * 3743.0)).abs() < 1.0);
        let note = orf.windows(12).position(|w| w == b"OLYMPUS\0II\x03\0");
        assert!(note.is_some_and(|n| n < header));
    }
}
