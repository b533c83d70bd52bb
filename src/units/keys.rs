//! Signing keys as files: a secret key (`KEY`, owner-only) and its public half (`KEY.pub`),
//! each one line of text so that a coordinator can paste a public key into an email.
//!
//! ```text
//! KEY      fslcal-ed25519-secret <64 hex digits: the 32-byte seed>
//! KEY.pub  fslcal-ed25519 <64 hex digits: the public key> <key id> [comment]
//! ```

use crate::atomic_file::{write_atomically, write_atomically_private};
use fslcal_core::unit_file::{self, KeyId};
use std::io::Read;
use std::path::{Path, PathBuf};

const SECRET_TAG: &str = "fslcal-ed25519-secret";
const PUBLIC_TAG: &str = "fslcal-ed25519";

#[derive(Debug, thiserror::Error)]
pub enum KeyError {
    #[error("{path}: cannot read: {cause}")]
    Io { path: String, cause: std::io::Error },
    #[error("{path}: not an fslcal {what} (expected one line `{tag} <64 hex digits>`, as `fslcal keygen` writes)")]
    Malformed { path: String, what: &'static str, tag: &'static str },
    #[error("{path}: no .pub files in this folder; put the trusted signers' public keys there")]
    NoTrustedKeys { path: String },
    #[error(
        "{path}: already exists; a new key would orphan every file the old one signed (remove it first if you mean to)"
    )]
    Exists { path: String },
    #[error("{path}: cannot write: {cause}")]
    Write { path: String, cause: std::io::Error },
    #[error("cannot read random bytes for a new key: {0}")]
    Random(std::io::Error),
    #[error("{path}: the key id written in it ({written}) is not its key's ({actual}): the file was edited or mixed up; get the .pub again from its owner")]
    IdMismatch { path: String, written: String, actual: String },
    #[error("{path}: cannot create the folder: {cause}")]
    Folder { path: String, cause: std::io::Error },
}

/// Lower-case hex of `bytes`.
pub fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

fn unhex32(s: &str) -> Option<[u8; 32]> {
    if s.len() != 64 || !s.is_ascii() {
        return None;
    }
    let mut out = [0u8; 32];
    for (i, b) in out.iter_mut().enumerate() {
        *b = u8::from_str_radix(&s[2 * i..2 * i + 2], 16).ok()?;
    }
    Some(out)
}

fn read_text(path: &Path) -> Result<String, KeyError> {
    let bytes = std::fs::read(path).map_err(|cause| KeyError::Io { path: path.display().to_string(), cause })?;
    Ok(String::from_utf8_lossy(&bytes).into_owned())
}

/// `KEY` -> `KEY.pub`.
pub fn public_path(secret_path: &Path) -> PathBuf {
    let mut p = secret_path.as_os_str().to_owned();
    p.push(".pub");
    PathBuf::from(p)
}

/// The text of a public key file.
pub fn public_key_text(public_key: &[u8; 32], comment: &str) -> String {
    format!("{PUBLIC_TAG} {} {} {comment}\n", hex(public_key), KeyId::of(public_key)).replace(" \n", "\n")
}

/// Makes a new key pair from the operating system's randomness and writes `path` (0600) and
/// `path.pub`. Refuses to replace an existing key.
pub fn generate(path: &Path, comment: &str) -> Result<[u8; 32], KeyError> {
    let name = path.display().to_string();
    for p in [path.to_path_buf(), public_path(path)] {
        if p.exists() {
            return Err(KeyError::Exists { path: p.display().to_string() });
        }
    }
    create_key_folder(path)?;
    let mut seed = [0u8; 32];
    std::fs::File::open("/dev/urandom").and_then(|mut f| f.read_exact(&mut seed)).map_err(KeyError::Random)?;
    write_atomically_private(path, format!("{SECRET_TAG} {}\n", hex(&seed)).as_bytes())
        .map_err(|cause| KeyError::Write { path: name, cause })?;
    let public = unit_file::public_key(&seed);
    let pub_path = public_path(path);
    write_atomically(&pub_path, public_key_text(&public, comment).as_bytes())
        .map_err(|cause| KeyError::Write { path: pub_path.display().to_string(), cause })?;
    Ok(public)
}

/// The 32 bytes on a key file's line `TAG <64 hex digits> ...`.
fn read_key_line(path: &Path, tag: &'static str, what: &'static str) -> Result<[u8; 32], KeyError> {
    let text = read_text(path)?;
    let mut words = text.split_whitespace();
    match (words.next(), words.next().and_then(unhex32)) {
        (Some(t), Some(key)) if t == tag => Ok(key),
        _ => Err(KeyError::Malformed { path: path.display().to_string(), what, tag }),
    }
}

/// Reads a secret key file.
pub fn read_secret(path: &Path) -> Result<[u8; 32], KeyError> {
    read_key_line(path, SECRET_TAG, "secret key")
}

/// Reads a public key file, whose key id (when written) must be its key's: a trusted file
/// whose id was edited would otherwise show one signer's id and trust another's key.
pub fn read_public(path: &Path) -> Result<[u8; 32], KeyError> {
    let key = read_key_line(path, PUBLIC_TAG, "public key")?;
    let text = read_text(path)?;
    if let Some(written) = text.split_whitespace().nth(2) {
        let actual = KeyId::of(&key).to_string();
        if !written.eq_ignore_ascii_case(&actual) {
            return Err(KeyError::IdMismatch { path: path.display().to_string(), written: written.into(), actual });
        }
    }
    Ok(key)
}

/// A warning when the secret key at `path` can be read by others than its owner (as ssh
/// warns of an unprotected private key): anyone who can read it can sign calibrations.
#[cfg(unix)]
pub fn exposure_warning(path: &Path) -> Option<String> {
    use std::os::unix::fs::PermissionsExt;
    let mode = std::fs::metadata(path).ok()?.permissions().mode() & 0o777;
    (mode & 0o077 != 0).then(|| {
        format!(
            "{}: the secret key is readable by others (mode {mode:04o}): anyone who can read it can sign calibrations; `chmod 600 {}`",
            path.display(),
            path.display()
        )
    })
}

#[cfg(not(unix))]
pub fn exposure_warning(_path: &Path) -> Option<String> {
    None
}

/// Creates the folders a new key goes into, owner-only (0700) as `~/.ssh` is: the first
/// `fslcal keygen --out ~/.fslcal/lead` needs `~/.fslcal`. Folders already there are left
/// as they are.
fn create_key_folder(path: &Path) -> Result<(), KeyError> {
    let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty() && !d.exists()) else { return Ok(()) };
    let mut builder = std::fs::DirBuilder::new();
    builder.recursive(true);
    #[cfg(unix)]
    std::os::unix::fs::DirBuilderExt::mode(&mut builder, 0o700);
    builder.create(dir).map_err(|cause| KeyError::Folder { path: dir.display().to_string(), cause })
}

/// A key someone chose to trust, and the file it came from.
#[derive(Clone, Debug)]
pub struct TrustedKey {
    pub key: [u8; 32],
    pub file: PathBuf,
}

/// The trusted keys named by `path`: one `.pub` file, or every `.pub` file in a folder.
pub fn read_trusted(path: &Path) -> Result<Vec<TrustedKey>, KeyError> {
    if !path.is_dir() {
        return Ok(vec![TrustedKey { key: read_public(path)?, file: path.to_path_buf() }]);
    }
    let entries = std::fs::read_dir(path).map_err(|cause| KeyError::Io { path: path.display().to_string(), cause })?;
    let mut files: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "pub"))
        .collect();
    files.sort();
    if files.is_empty() {
        return Err(KeyError::NoTrustedKeys { path: path.display().to_string() });
    }
    files.into_iter().map(|f| Ok(TrustedKey { key: read_public(&f)?, file: f })).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn generated_keys_read_back_and_match() {
        let dir = tempfile::tempdir().unwrap();
        let key = dir.path().join("coordinator");
        let public = generate(&key, "lab").unwrap();
        let secret = read_secret(&key).unwrap();
        assert_eq!(unit_file::public_key(&secret), public);
        assert_eq!(read_public(&public_path(&key)).unwrap(), public);
        let trusted = read_trusted(dir.path()).unwrap();
        assert_eq!(trusted.len(), 1);
        assert_eq!(trusted[0].key, public);
        // Two keys from the OS's randomness differ.
        let other = generate(&dir.path().join("second"), "").unwrap();
        assert_ne!(other, public);
        assert!(matches!(generate(&key, ""), Err(KeyError::Exists { .. })));
    }

    #[test]
    fn a_public_key_is_not_a_secret_key() {
        let dir = tempfile::tempdir().unwrap();
        let key = dir.path().join("k");
        generate(&key, "").unwrap();
        let msg = read_secret(&public_path(&key)).unwrap_err().to_string();
        assert!(msg.contains("k.pub: not an fslcal secret key"), "{msg}");
        let empty = tempfile::tempdir().unwrap();
        assert!(matches!(read_trusted(empty.path()), Err(KeyError::NoTrustedKeys { .. })));
    }
}
