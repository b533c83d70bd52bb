//! The FishSense lab's calibration files (`.pkg`): gzip-compressed tar archives holding a
//! `metadata.json` with `calibrated_date` and NumPy `.npy` arrays.
//!
//! - lens:  `_calibration_matrix.npy` (3x3), `_distortion_coefficients.npy` (OpenCV's order)
//! - laser: `laser_pos.npy` ([x, y, 0], metres), `laser_axis.npy` (unit vector)
//!
//! `.npy` is read and written here by hand: a magic, a version, a Python-literal header
//! (`descr`, `fortran_order`, `shape`) padded to 64 bytes, then the raw array.
//!
//! Kept by hand rather than `npyz` or `ndarray-npy`: both write headers NumPy reads but does
//! not write (`'shape': (2, 2, ), }` from one, a dict without NumPy's trailing `, ` from the
//! other), where `write_npy` gives NumPy's own bytes (golden-tested below), so an exported
//! `.pkg` is byte for byte what the lab's `np.save` makes; and both parse the header with
//! `py_literal` (a pest grammar, big integers) for a dict of three keys, which `read_npy`
//! reads in a few lines tested against every truncation.

use crate::utc_time;
use flate2::read::GzDecoder;
use flate2::write::GzEncoder;
use std::collections::BTreeMap;
use std::io::Read;

#[derive(Debug, thiserror::Error, PartialEq)]
pub enum PkgError {
    #[error("not a gzip-compressed tar archive ({0}); expected a FishSense .pkg")]
    NotAnArchive(String),
    #[error("the archive has no `{0}`; expected a FishSense {1} calibration .pkg")]
    Missing(&'static str, &'static str),
    #[error("`{name}` is not a NumPy array file: {why}")]
    Npy { name: String, why: String },
    #[error("`{name}` has shape {shape:?}, expected {expected}")]
    Shape { name: String, shape: Vec<usize>, expected: &'static str },
    #[error("`metadata.json` has no readable `calibrated_date`")]
    Date,
    #[error("`metadata.json`'s calibrated_date: {0}")]
    PlaceDate(#[from] utc_time::PlaceTimeError),
}

/// A float array read from `.npy`, in C (row-major) order whatever the file's order.
#[derive(Clone, Debug, PartialEq)]
pub struct NpyArray {
    pub shape: Vec<usize>,
    pub data: Vec<f64>,
}

const NPY_MAGIC: &[u8] = b"\x93NUMPY";

/// `.npy` version 1.0 of a little-endian float64 array in C order.
pub fn write_npy(shape: &[usize], data: &[f64]) -> Vec<u8> {
    let dims: Vec<String> = shape.iter().map(|d| d.to_string()).collect();
    let shape_text = if dims.len() == 1 { format!("({},)", dims[0]) } else { format!("({})", dims.join(", ")) };
    let mut header = format!("{{'descr': '<f8', 'fortran_order': False, 'shape': {shape_text}, }}");
    // NumPy pads the header with spaces and a newline so the data starts on a 64-byte boundary.
    let unpadded = NPY_MAGIC.len() + 4 + header.len() + 1;
    header.push_str(&" ".repeat((64 - unpadded % 64) % 64));
    header.push('\n');
    let mut out = Vec::with_capacity(NPY_MAGIC.len() + 4 + header.len() + 8 * data.len());
    out.extend_from_slice(NPY_MAGIC);
    out.extend_from_slice(&[1, 0]);
    out.extend_from_slice(&(header.len() as u16).to_le_bytes());
    out.extend_from_slice(header.as_bytes());
    for v in data {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out
}

/// The value of `'key': ...` in a `.npy` header dict, up to the next top-level comma.
fn header_value<'a>(header: &'a str, key: &str) -> Option<&'a str> {
    let at = header.find(&format!("'{key}'")).or_else(|| header.find(&format!("\"{key}\"")))?;
    let rest = header[at + key.len() + 2..].trim_start().strip_prefix(':')?.trim_start();
    let end = if rest.starts_with('(') { rest.find(')')? + 1 } else { rest.find([',', '}'])? };
    Some(rest[..end].trim())
}

/// Reads a `.npy` holding a float32 or float64 array (either byte order, C or Fortran order).
pub fn read_npy(name: &str, bytes: &[u8]) -> Result<NpyArray, PkgError> {
    let bad = |why: &str| PkgError::Npy { name: name.to_string(), why: why.to_string() };
    if !bytes.starts_with(NPY_MAGIC) || bytes.len() < 10 {
        return Err(bad("no \\x93NUMPY magic"));
    }
    let (header_len, header_at) = match bytes[6] {
        1 => (u16::from_le_bytes([bytes[8], bytes[9]]) as usize, 10),
        2 | 3 if bytes.len() >= 12 => (u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize, 12),
        _ => return Err(bad("unknown .npy version")),
    };
    let header = bytes.get(header_at..header_at + header_len).ok_or_else(|| bad("header cut short"))?;
    let header = std::str::from_utf8(header).map_err(|_| bad("header not text"))?;
    let descr = header_value(header, "descr").ok_or_else(|| bad("no descr"))?.trim_matches(['\'', '"']);
    let fortran = match header_value(header, "fortran_order") {
        Some("True") => true,
        Some("False") => false,
        _ => return Err(bad("no fortran_order")),
    };
    let shape_text = header_value(header, "shape").ok_or_else(|| bad("no shape"))?;
    let shape: Vec<usize> = shape_text
        .trim_matches(['(', ')'])
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|s| s.parse().map_err(|_| bad("shape not whole numbers")))
        .collect::<Result<_, _>>()?;
    let count = shape.iter().try_fold(1usize, |a, &d| a.checked_mul(d)).ok_or_else(|| bad("shape too large"))?;
    let (size, little, float64) = match descr {
        "<f8" => (8, true, true),
        ">f8" => (8, false, true),
        "<f4" => (4, true, false),
        ">f4" => (4, false, false),
        other => return Err(bad(&format!("dtype {other}, expected float32 or float64"))),
    };
    let body = &bytes[header_at + header_len..];
    if count.checked_mul(size) != Some(body.len()) {
        return Err(bad(&format!("{} data bytes for {count} values of {size} bytes", body.len())));
    }
    let values: Vec<f64> = body
        .chunks_exact(size)
        .map(|c| match (float64, little) {
            (true, true) => f64::from_le_bytes(c.try_into().unwrap_or([0; 8])),
            (true, false) => f64::from_be_bytes(c.try_into().unwrap_or([0; 8])),
            (false, true) => f32::from_le_bytes(c.try_into().unwrap_or([0; 4])) as f64,
            (false, false) => f32::from_be_bytes(c.try_into().unwrap_or([0; 4])) as f64,
        })
        .collect();
    let data = if fortran && shape.len() == 2 {
        let (r, c) = (shape[0], shape[1]);
        (0..r * c).map(|i| values[(i % c) * r + i / c]).collect()
    } else if fortran && shape.iter().filter(|&&d| d > 1).count() > 1 {
        return Err(bad("Fortran-ordered arrays of more than 2 dimensions"));
    } else {
        values
    };
    Ok(NpyArray { shape, data })
}

/// Builds a `.pkg`: `metadata.json` then the arrays, every entry stamped with `made_utc_s`
/// so the archive depends on its contents only.
pub fn write_pkg(made_utc_s: i64, arrays: &[(&str, &[usize], &[f64])]) -> std::io::Result<Vec<u8>> {
    let metadata =
        serde_json::to_vec_pretty(&serde_json::json!({ "calibrated_date": utc_time::format_python(made_utc_s) }))?;
    let mut tar = tar::Builder::new(GzEncoder::new(Vec::new(), flate2::Compression::default()));
    let mut add = |name: &str, bytes: &[u8]| {
        let mut h = tar::Header::new_gnu();
        h.set_size(bytes.len() as u64);
        h.set_mode(0o644);
        h.set_mtime(made_utc_s.max(0) as u64);
        h.set_entry_type(tar::EntryType::Regular);
        tar.append_data(&mut h, name, bytes)
    };
    add("metadata.json", &metadata)?;
    for (name, shape, data) in arrays {
        add(name, &write_npy(shape, data))?;
    }
    tar.into_inner()?.finish()
}

/// Every regular file in a `.pkg`, by name, with the time from its `metadata.json`.
pub struct Pkg {
    pub files: BTreeMap<String, Vec<u8>>,
}

/// No entry of a calibration archive is anywhere near this; a bigger one is not ours.
const MAX_ENTRY_BYTES: u64 = 1 << 20;

impl Pkg {
    pub fn read(bytes: &[u8]) -> Result<Self, PkgError> {
        let not = |e: std::io::Error| PkgError::NotAnArchive(e.to_string());
        let mut archive = tar::Archive::new(GzDecoder::new(bytes));
        let mut files = BTreeMap::new();
        for entry in archive.entries().map_err(not)? {
            let entry = entry.map_err(not)?;
            if entry.header().entry_type() != tar::EntryType::Regular {
                continue;
            }
            let name = entry.path().map_err(not)?.to_string_lossy().trim_start_matches("./").to_string();
            let mut data = Vec::new();
            entry.take(MAX_ENTRY_BYTES).read_to_end(&mut data).map_err(not)?;
            files.insert(name, data);
        }
        if files.is_empty() {
            return Err(PkgError::NotAnArchive("no files in it".into()));
        }
        Ok(Pkg { files })
    }

    pub fn array(&self, name: &'static str, kind: &'static str) -> Result<NpyArray, PkgError> {
        read_npy(name, self.files.get(name).ok_or(PkgError::Missing(name, kind))?)
    }

    /// `calibrated_date` as seconds since 1970 UTC; a date without a zone is refused.
    pub fn calibrated_utc_s(&self, kind: &'static str) -> Result<i64, PkgError> {
        Ok(self.metadata(kind, None)?.calibrated_utc_s)
    }

    /// `metadata.json`: when (a date without a zone placed in `zone`, refused without one)
    /// and, where the lab's 2023 lens tool wrote it, the camera's serial number.
    pub fn metadata(&self, kind: &'static str, zone: Option<&jiff::tz::TimeZone>) -> Result<PkgMetadata, PkgError> {
        let text = self.files.get("metadata.json").ok_or(PkgError::Missing("metadata.json", kind))?;
        let json: serde_json::Value = serde_json::from_slice(text).map_err(|_| PkgError::Date)?;
        let date = json.get("calibrated_date").and_then(|d| d.as_str()).ok_or(PkgError::Date)?;
        let serial_number = json
            .get("serial_number")
            .and_then(|s| s.as_str())
            .map(str::trim)
            .filter(|s| !s.is_empty())
            .map(str::to_string);
        Ok(PkgMetadata {
            calibrated_utc_s: utc_time::parse_iso_in(date, zone)?,
            calibrated_date: date.to_string(),
            serial_number,
        })
    }
}

/// What a `.pkg`'s `metadata.json` says besides the arrays.
#[derive(Clone, Debug, PartialEq)]
pub struct PkgMetadata {
    pub calibrated_utc_s: i64,
    /// As written (`2025-02-10 18:32:05.123456+00:00`, or the 2023 tools' local time).
    pub calibrated_date: String,
    /// The camera's serial number (the 2023 lens metadata has it; later files do not).
    pub serial_number: Option<String>,
}

/// A lens calibration: camera matrix (row-major 3x3) and distortion coefficients.
#[derive(Clone, Debug, PartialEq)]
pub struct LensPkg {
    pub camera_matrix: [f64; 9],
    pub distortion: Vec<f64>,
    pub calibrated_utc_s: i64,
}

/// A laser calibration: where the beam leaves the camera's xy-plane and its direction.
#[derive(Clone, Debug, PartialEq)]
pub struct LaserPkg {
    pub position_m: [f64; 3],
    pub axis: [f64; 3],
    pub calibrated_utc_s: i64,
}

fn vector3(a: NpyArray, name: &str) -> Result<[f64; 3], PkgError> {
    <[f64; 3]>::try_from(a.data.as_slice()).map_err(|_| PkgError::Shape {
        name: name.to_string(),
        shape: a.shape,
        expected: "3 values",
    })
}

pub const LENS_MATRIX: &str = "_calibration_matrix.npy";
pub const LENS_DISTORTION: &str = "_distortion_coefficients.npy";
pub const LASER_POSITION: &str = "laser_pos.npy";
pub const LASER_AXIS: &str = "laser_axis.npy";

impl LensPkg {
    pub fn read(bytes: &[u8]) -> Result<Self, PkgError> {
        Ok(Self::read_with_metadata(bytes, None)?.0)
    }

    /// The lens and its metadata, a date without a zone placed in `zone`.
    pub fn read_with_metadata(
        bytes: &[u8],
        zone: Option<&jiff::tz::TimeZone>,
    ) -> Result<(Self, PkgMetadata), PkgError> {
        let pkg = Pkg::read(bytes)?;
        let k = pkg.array(LENS_MATRIX, "lens")?;
        let camera_matrix = <[f64; 9]>::try_from(k.data.as_slice())
            .ok()
            .filter(|_| k.shape == [3, 3])
            .ok_or(PkgError::Shape { name: LENS_MATRIX.into(), shape: k.shape.clone(), expected: "3x3" })?;
        let d = pkg.array(LENS_DISTORTION, "lens")?;
        let meta = pkg.metadata("lens", zone)?;
        Ok((LensPkg { camera_matrix, distortion: d.data, calibrated_utc_s: meta.calibrated_utc_s }, meta))
    }

    /// The archive, with the distortion as OpenCV returns it: shape (1, N).
    pub fn write(&self) -> std::io::Result<Vec<u8>> {
        write_pkg(
            self.calibrated_utc_s,
            &[
                (LENS_MATRIX, &[3, 3], &self.camera_matrix),
                (LENS_DISTORTION, &[1, self.distortion.len()], &self.distortion),
            ],
        )
    }
}

impl LaserPkg {
    pub fn read(bytes: &[u8]) -> Result<Self, PkgError> {
        Ok(Self::read_with_metadata(bytes, None)?.0)
    }

    /// The laser and its metadata, a date without a zone placed in `zone`.
    pub fn read_with_metadata(
        bytes: &[u8],
        zone: Option<&jiff::tz::TimeZone>,
    ) -> Result<(Self, PkgMetadata), PkgError> {
        let pkg = Pkg::read(bytes)?;
        let meta = pkg.metadata("laser", zone)?;
        let laser = LaserPkg {
            position_m: vector3(pkg.array(LASER_POSITION, "laser")?, LASER_POSITION)?,
            axis: vector3(pkg.array(LASER_AXIS, "laser")?, LASER_AXIS)?,
            calibrated_utc_s: meta.calibrated_utc_s,
        };
        Ok((laser, meta))
    }

    pub fn write(&self) -> std::io::Result<Vec<u8>> {
        write_pkg(self.calibrated_utc_s, &[(LASER_AXIS, &[3], &self.axis), (LASER_POSITION, &[3], &self.position_m)])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// What `np.save(f, np.array([[1.5, -2.0], [0.25, 3.0]]))` wrote with NumPy 1.24, as hex.
    const GOLDEN_2X2_HEX: &str = concat!(
        "934e554d5059010076007b276465736372273a20273c6638272c2027666f7274",
        "72616e5f6f72646572273a2046616c73652c20277368617065273a2028322c20",
        "32292c207d202020202020202020202020202020202020202020202020202020",
        "202020202020202020202020202020202020202020202020202020202020200a",
        "000000000000f83f00000000000000c0000000000000d03f0000000000000840",
    );

    fn unhex(s: &str) -> Vec<u8> {
        (0..s.len()).step_by(2).map(|i| u8::from_str_radix(&s[i..i + 2], 16).unwrap()).collect()
    }

    #[test]
    fn npy_matches_numpys_bytes() {
        let golden = unhex(GOLDEN_2X2_HEX);
        assert_eq!(write_npy(&[2, 2], &[1.5, -2.0, 0.25, 3.0]), golden);
        let a = read_npy("x", &golden).unwrap();
        assert_eq!(a, NpyArray { shape: vec![2, 2], data: vec![1.5, -2.0, 0.25, 3.0] });
    }

    #[test]
    fn reads_fortran_order_and_float32() {
        // A 2x3 array [[1, 2, 3], [4, 5, 6]] stored column by column, big-endian float32.
        let mut b = b"\x93NUMPY\x01\x00".to_vec();
        let header = "{'descr': '>f4', 'fortran_order': True, 'shape': (2, 3), }\n";
        b.extend_from_slice(&(header.len() as u16).to_le_bytes());
        b.extend_from_slice(header.as_bytes());
        for v in [1.0f32, 4.0, 2.0, 5.0, 3.0, 6.0] {
            b.extend_from_slice(&v.to_be_bytes());
        }
        let a = read_npy("f", &b).unwrap();
        assert_eq!(a.data, vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
        // Cut short: an error, not a panic.
        for n in 0..b.len() {
            assert!(read_npy("f", &b[..n]).is_err(), "{n}");
        }
    }

    #[test]
    fn pkgs_round_trip() {
        let lens = LensPkg {
            camera_matrix: [2900.5, 0.0, 2004.25, 0.0, 2901.0, 1499.5, 0.0, 0.0, 1.0],
            distortion: vec![-0.1, 0.03, 0.001, -0.002, 0.0004],
            calibrated_utc_s: 1_780_306_200,
        };
        let bytes = lens.write().unwrap();
        assert_eq!(LensPkg::read(&bytes).unwrap(), lens);
        // Deterministic: the same calibration gives the same archive.
        assert_eq!(lens.write().unwrap(), bytes);
        let laser =
            LaserPkg { position_m: [-0.04, -0.105, 0.0], axis: [0.01, 0.02, 0.99975], calibrated_utc_s: 1_780_306_200 };
        assert_eq!(LaserPkg::read(&laser.write().unwrap()).unwrap(), laser);
        assert_eq!(LaserPkg::read(&bytes).unwrap_err(), PkgError::Missing(LASER_POSITION, "laser"));
        assert!(matches!(LensPkg::read(b"not gzip"), Err(PkgError::NotAnArchive(_))));
    }

    /// The 2023 lens tool's metadata: name, maker, model, serial and a local time without a
    /// zone (`str(datetime.now())`).
    fn pkg_2023(date: &str) -> Vec<u8> {
        let meta = format!(
            r#"{{"name": "tg6", "manufacturer": "Olympus", "model": "TG-6", "serial_number": " BHV204411 ", "calibrated_date": "{date}"}}"#
        );
        let mut tar = tar::Builder::new(GzEncoder::new(Vec::new(), flate2::Compression::default()));
        for (name, bytes) in [
            ("metadata.json", meta.into_bytes()),
            (LENS_MATRIX, write_npy(&[3, 3], &[2900.0, 0.0, 2020.0, 0.0, 2900.0, 1508.0, 0.0, 0.0, 1.0])),
            (LENS_DISTORTION, write_npy(&[1, 5], &[-0.1, 0.05, 0.0, 0.0, 0.0])),
        ] {
            let mut h = tar::Header::new_gnu();
            h.set_size(bytes.len() as u64);
            h.set_mode(0o644);
            h.set_entry_type(tar::EntryType::Regular);
            tar.append_data(&mut h, name, bytes.as_slice()).unwrap();
        }
        tar.into_inner().unwrap().finish().unwrap()
    }

    #[test]
    fn the_2023_metadata_needs_a_zone_and_gives_its_serial() {
        let bytes = pkg_2023("2023-07-14 10:31:07.517211");
        let e = LensPkg::read(&bytes).unwrap_err();
        assert!(e.to_string().contains("has no time zone") && e.to_string().contains("--timezone"), "{e}");
        let la = utc_time::parse_zone("America/Los_Angeles").unwrap();
        let (lens, meta) = LensPkg::read_with_metadata(&bytes, Some(&la)).unwrap();
        // 10:31:07 PDT is 17:31:07 UTC.
        assert_eq!(utc_time::format_iso(lens.calibrated_utc_s), "2023-07-14T17:31:07Z");
        assert_eq!(meta.serial_number.as_deref(), Some("BHV204411"));
        assert_eq!(meta.calibrated_date, "2023-07-14 10:31:07.517211");
    }
}
