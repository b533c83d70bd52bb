//! What the firmware keeps of a unit's signed `.fslcal` file, and why it refuses one.
//!
//! Decoding and signature checking are `fslcal_core`'s (the same code as the CLI's
//! `fslcal verify`); this module only adds the firmware's own rules (the file must be for
//! this unit) and copies the few fields the screens need out of the borrowed decode.

use crate::text::TextBuf;
use fslcal_core::unit_file::{self, FormatError, KeyId};
use fslcal_core::{CameraModel, LaserLine};

/// A unit name such as `FSL-03`.
pub type UnitName = TextBuf<12>;

/// A public key the firmware trusts, built in at compile time.
#[derive(Clone, Copy, Debug)]
pub struct TrustedKey {
    /// Who holds the secret key, shown on the self-check screen (at most 12 characters).
    pub name: &'static str,
    pub public_key: [u8; 32],
}

/// A verified calibration for this unit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UnitCalibration {
    pub unit: UnitName,
    pub camera: CameraModel,
    pub laser: LaserLine,
    /// Covariance of [`LaserLine::to_params`], row-major.
    pub laser_covariance: [[f64; 4]; 4],
    /// When the calibration was made, seconds since 1970-01-01 UTC.
    pub made_unix_s: i64,
    /// Name of the trusted key that signed it.
    pub signer: &'static str,
    pub format_version: u16,
    pub file_len: usize,
}

/// Why a file is refused. Each has its own short reason on the "calibration invalid" screen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Rejection {
    /// Intact structure, but the signature does not match the contents.
    Tampered,
    /// A field that no signer would have written (the file was damaged or edited).
    Damaged(&'static str),
    /// Intact and correctly signed, by a key the firmware does not trust.
    UnknownSigner(KeyId),
    /// A good file for another unit.
    OtherUnit { file_unit: UnitName },
    /// Written by a newer fslcal than this firmware reads.
    NewerFormat { found: u8, supported: u8 },
    /// Ends early: a half-copied file.
    Truncated { found: usize, expected: usize },
    /// Not a calibration file at all (wrong magic, or larger than any calibration).
    NotACalibration,
}

impl From<FormatError> for Rejection {
    fn from(e: FormatError) -> Self {
        match e {
            FormatError::BadSignature => Rejection::Tampered,
            FormatError::Corrupt(why) => Rejection::Damaged(why),
            FormatError::UnknownSigner(id) => Rejection::UnknownSigner(id),
            FormatError::NewerVersion { found, supported } => Rejection::NewerFormat { found, supported },
            FormatError::Truncated { found, expected } => Rejection::Truncated { found, expected },
            FormatError::NotACalibrationFile | FormatError::Unsignable(_) => Rejection::NotACalibration,
        }
    }
}

/// Most keys a firmware build trusts (the lab's current and next key, with room to spare).
pub const MAX_TRUSTED_KEYS: usize = 4;

/// Decodes and verifies `bytes` against the trusted keys (`fslcal_core::unit_file::verify`,
/// the same check as `fslcal verify`), then checks the file is for `own_unit`.
pub fn open(bytes: &[u8], own_unit: &str, trusted: &'static [TrustedKey]) -> Result<UnitCalibration, Rejection> {
    if bytes.len() > unit_file::MAX_FILE_BYTES {
        return Err(Rejection::NotACalibration);
    }
    let mut keys = [[0u8; 32]; MAX_TRUSTED_KEYS];
    let n = trusted.len().min(MAX_TRUSTED_KEYS);
    for (k, t) in keys.iter_mut().zip(trusted) {
        *k = t.public_key;
    }
    let file = unit_file::verify(bytes, &keys[..n])?;
    let c = &file.contents;
    if c.unit != own_unit {
        return Err(Rejection::OtherUnit { file_unit: crate::text!(12, "{}", c.unit) });
    }
    let signer = trusted.iter().find(|t| t.public_key == file.signer).map_or("?", |t| t.name);
    Ok(UnitCalibration {
        unit: crate::text!(12, "{}", c.unit),
        camera: c.camera,
        laser: c.laser,
        laser_covariance: c.laser_covariance,
        made_unix_s: c.made_utc_s,
        signer,
        format_version: file.version as u16,
        file_len: bytes.len(),
    })
}
