//! Signed unit files on disk: reading one (bounded, with the path in every error), signing
//! and writing one atomically, and the unit id rule. The format itself is
//! `fslcal_core::unit_file`.

use crate::atomic_file::write_atomically;
use crate::units::keys::{self, KeyError};
use fslcal_core::unit_file::{FormatError, UnitFile, MAX_FILE_BYTES};
use std::io::Read;
use std::path::Path;

#[derive(Debug, thiserror::Error)]
pub enum UnitFileError {
    #[error("{path}: cannot read: {cause}")]
    Io { path: String, cause: std::io::Error },
    #[error("{path}: {cause}")]
    Format { path: String, cause: FormatError },
    #[error(transparent)]
    Key(#[from] KeyError),
    #[error("{path}: cannot write: {cause}")]
    Write { path: String, cause: std::io::Error },
    #[error("unit `{0}` is not a FishSense Lite unit id; expected FSL-NN, e.g. FSL-03 (optionally with the optic letter, FSL-03D)")]
    BadUnitId(String),
}

impl UnitFileError {
    /// Names `path` in a format error.
    pub fn at(path: &Path) -> impl Fn(FormatError) -> UnitFileError + '_ {
        move |cause| UnitFileError::Format { path: path.display().to_string(), cause }
    }
}

/// Reads at most one byte more than a calibration file can hold, so that pointing the tool
/// at a video by mistake costs nothing (the decoder then calls it what it is).
pub fn read_bytes(path: &Path) -> Result<Vec<u8>, UnitFileError> {
    let io = |cause| UnitFileError::Io { path: path.display().to_string(), cause };
    let mut bytes = Vec::with_capacity(MAX_FILE_BYTES + 1);
    std::fs::File::open(path).map_err(io)?.take(MAX_FILE_BYTES as u64 + 1).read_to_end(&mut bytes).map_err(io)?;
    Ok(bytes)
}

/// The canonical unit id, `FSL-` and two digits, with the lab's optic letter (`D` with the
/// corrective optic, `F` without) when given: `fsl-3` is refused rather than guessed.
pub fn unit_id(text: &str) -> Result<String, UnitFileError> {
    let up = text.trim().to_ascii_uppercase();
    let ok = up.strip_prefix("FSL-").is_some_and(|rest| {
        let b = rest.as_bytes();
        (b.len() == 2 || (b.len() == 3 && b[2].is_ascii_uppercase())) && b[..2].iter().all(u8::is_ascii_digit)
    });
    if ok {
        Ok(up)
    } else {
        Err(UnitFileError::BadUnitId(text.to_string()))
    }
}

/// Signs `contents` with the secret key at `key_path` and writes the file atomically.
/// Returns the file's length in bytes.
pub fn sign_to_file(contents: &UnitFile<'_>, key_path: &Path, out: &Path) -> Result<usize, UnitFileError> {
    let secret = keys::read_secret(key_path)?;
    // Every signature goes through here: the one place to warn, as ssh does.
    if let Some(w) = keys::exposure_warning(key_path) {
        eprintln!("fslcal: warning: {w}");
    }
    let mut buf = [0u8; MAX_FILE_BYTES];
    let n = contents.sign(&secret, &mut buf).map_err(UnitFileError::at(out))?;
    write_atomically(out, &buf[..n])
        .map_err(|cause| UnitFileError::Write { path: out.display().to_string(), cause })?;
    Ok(n)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unit_ids() {
        assert_eq!(unit_id("fsl-03").unwrap(), "FSL-03");
        assert_eq!(unit_id("FSL-01D").unwrap(), "FSL-01D");
        for bad in ["FSL-3", "FSL-003", "unit 3", "FSL-0x", "FSL-01d1"] {
            assert!(unit_id(bad).is_err(), "{bad}");
        }
    }
}
