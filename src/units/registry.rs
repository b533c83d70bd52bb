//! The coordinator's registry of units: a plain folder anyone can back up or read by hand.
//!
//! ```text
//! units/
//!   trusted/*.pub                          keys whose files `units add` accepts
//!   FSL-03/
//!     20260601T093000Z-1a2b3c4d5e6f7a8b-0f1e2d3c4b5a6978.fslcal
//!         every accepted calibration: when it was made, its signer's key id, and the
//!         first 16 hex digits of its SHA-256
//!     validation-20260602T101500Z-9a8b7c6d5e4f3a2b.json
//!         validation reports: when the validation ran, and the report's SHA-256
//! ```
//! Names are unique by content: two different calibrations made in the same second by the
//! same signer (a corrected re-import of the lab's files) are filed side by side, and the
//! same file filed twice is recognised. Every file is created with `O_EXCL` semantics
//! (written aside, then renamed without replacing), so two `units add` racing for one name
//! never lose one: one files it, the other finds it there. Nothing is ever overwritten or
//! deleted, so the folder is the unit's history.
//!
//! A unit's current calibration is the one made last (ties, such as a re-import of the same
//! lab date, go to the one filed last). A validation report names the SHA-256 of the
//! calibration it validated and is shown only beside that calibration: a pass of last
//! month's file says nothing about today's.

use crate::atomic_file::write_new_atomically;
use crate::documents::validation::ValidationDocument;
use crate::documents::{check_schema, NewerSchema};
use crate::units::keys::{self, KeyError, TrustedKey};
use crate::units::signed_file::{self, unit_id, UnitFileError};
use crate::utc_time;
use fslcal_core::unit_file::{self, FormatError, KeyId, Provenance, SignedUnitFile};
use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};
use std::time::SystemTime;

#[derive(Debug, thiserror::Error)]
pub enum RegistryError {
    #[error(transparent)]
    UnitFile(#[from] UnitFileError),
    #[error(transparent)]
    Key(#[from] KeyError),
    #[error("{path}: cannot {what}: {cause}")]
    Io { path: String, what: &'static str, cause: std::io::Error },
    #[error("{path}: a different file is already filed under this name (a SHA-256 prefix collision); nothing written")]
    Conflict { path: String },
    #[error("{path}: not a validation report (expected the JSON of `fslcal validate --json`, with a boolean `pass`)")]
    NotAReport { path: String },
    #[error("{path}: {cause}")]
    NewerReport { path: String, cause: NewerSchema },
    #[error("{path}: the report names no unit; give it with --unit FSL-NN")]
    ReportWithoutUnit { path: String },
    #[error("{path}: the report is of {report}'s calibration, not {given}'s; leave out --unit or give {report}")]
    ReportOfAnotherUnit { path: String, report: String, given: String },
    #[error("{path}: the report does not name the calibration it validated (a report from before fslcal recorded it); run `fslcal validate --json` again to file it")]
    ReportWithoutCalibration { path: String },
    #[error("{path}: the calibration it validated (SHA-256 {sha256}) is not filed under {unit}; file that calibration first with `fslcal units add CAL.fslcal`")]
    CalibrationNotFiled { path: String, unit: String, sha256: String },
    #[error("{path}: another key is already trusted under this name; rename the .pub file you are adding")]
    TrustConflict { path: String },
    #[error("{path}: no such folder; the registry trusts the .pub keys in it: add one with `fslcal units trust KEY.pub` (or create the folder and copy the .pub files into it), or give --trust KEY.pub")]
    NoTrustedFolder { path: String },
}

/// The SHA-256 of `bytes`, lower-case hex: how the registry and a validation report name a
/// calibration file.
pub fn sha256_hex(bytes: &[u8]) -> String {
    keys::hex(&Sha256::digest(bytes))
}

/// What `add` did with a file.
#[derive(Debug, PartialEq)]
pub enum Filed {
    New(PathBuf),
    AlreadyThere(PathBuf),
}

impl Filed {
    pub fn path(&self) -> &Path {
        match self {
            Filed::New(p) | Filed::AlreadyThere(p) => p,
        }
    }
}

pub struct Registry {
    pub root: PathBuf,
}

/// One unit's state, as `units list` shows it.
#[derive(Debug)]
pub struct UnitSummary {
    pub unit: String,
    pub calibrations: usize,
    /// The calibration made last, and how it reads now (a file edited in the registry after
    /// filing shows here as invalid).
    pub current: Option<CurrentCalibration>,
    /// The last validation of the current calibration (never of another one).
    pub last_validation: Option<ValidationRecord>,
}

#[derive(Debug)]
pub struct CurrentCalibration {
    pub file: PathBuf,
    pub made_utc_s: i64,
    pub signer: KeyId,
    /// Fitted by fslcal, or imported from the lab's files.
    pub provenance: Provenance,
    /// `Ok` when intact and signed by a trusted key; why not otherwise.
    pub status: Result<(), FormatError>,
    /// SHA-256 of the file, hex.
    pub sha256: String,
    /// When it was filed (the file's modification time): orders calibrations made in the
    /// same second.
    filed: SystemTime,
}

#[derive(Debug)]
pub struct ValidationRecord {
    pub file: PathBuf,
    /// When the validation ran (the report's `validated_utc`), else when it was filed.
    pub validated_utc_s: i64,
    /// When the report was filed (the file's modification time), seconds since 1970.
    pub filed_utc_s: i64,
    pub pass: bool,
    filed: SystemTime,
}

/// The first 16 hex digits of a SHA-256: enough to tell a unit's files apart by name.
fn short(sha256: &str) -> &str {
    &sha256[..16]
}

impl Registry {
    pub fn new(root: &Path) -> Self {
        Registry { root: root.to_path_buf() }
    }

    fn io<'p>(path: &'p Path, what: &'static str) -> impl FnOnce(std::io::Error) -> RegistryError + 'p {
        move |cause| RegistryError::Io { path: path.display().to_string(), what, cause }
    }

    /// The registry's `trusted/` folder.
    pub fn trusted_dir(&self) -> PathBuf {
        self.root.join("trusted")
    }

    /// The registry's trusted keys, or those at `trust` when given.
    pub fn trusted(&self, trust: Option<&Path>) -> Result<Vec<TrustedKey>, RegistryError> {
        let dir = self.trusted_dir();
        if trust.is_none() && !dir.exists() {
            return Err(RegistryError::NoTrustedFolder { path: dir.display().to_string() });
        }
        Ok(keys::read_trusted(trust.unwrap_or(&dir))?)
    }

    /// Trusts the signer whose public key is `public` (a `.pub` file, checked first): copies
    /// it into `trusted/`, created if missing. A key already trusted under that name is
    /// "already there"; another key under it is refused, never replaced.
    pub fn trust(&self, public: &Path) -> Result<Filed, RegistryError> {
        let key = keys::read_public(public)?;
        let bytes = std::fs::read(public).map_err(Self::io(public, "read"))?;
        let dir = self.trusted_dir();
        std::fs::create_dir_all(&dir).map_err(Self::io(&dir, "create the folder"))?;
        let name = match public.file_name() {
            Some(n) if public.extension().is_some_and(|e| e == "pub") => n.to_os_string(),
            _ => format!("{}.pub", KeyId::of(&key)).into(),
        };
        let dest = dir.join(name);
        match file_new(&dest, &bytes) {
            Err(RegistryError::Conflict { path }) if keys::read_public(&dest).ok() != Some(key) => {
                Err(RegistryError::TrustConflict { path })
            }
            // The same key, written with another comment: trusted already.
            Err(RegistryError::Conflict { .. }) => Ok(Filed::AlreadyThere(dest)),
            other => other,
        }
    }

    /// Files a calibration that verifies against `trusted` under its unit.
    pub fn add_calibration(&self, file: &Path, trusted: &[TrustedKey]) -> Result<(Filed, String), RegistryError> {
        let bytes = signed_file::read_bytes(file)?;
        let keys: Vec<[u8; 32]> = trusted.iter().map(|t| t.key).collect();
        let f = unit_file::verify(&bytes, &keys).map_err(UnitFileError::at(file))?;
        let unit = unit_id(f.contents.unit)?;
        let dir = self.root.join(&unit);
        std::fs::create_dir_all(&dir).map_err(Self::io(&dir, "create the unit's folder"))?;
        // Filed before, perhaps under an older naming.
        let same = |p: &PathBuf| std::fs::read(p).is_ok_and(|b| b == bytes);
        if let Some(there) = files_with_ext(&dir, "fslcal").into_iter().find(same) {
            return Ok((Filed::AlreadyThere(there), unit));
        }
        let sha = sha256_hex(&bytes);
        let made = utc_time::format_compact(f.contents.made_utc_s);
        let name = format!("{made}-{}-{}.fslcal", f.key_id(), short(&sha));
        Ok((file_new(&dir.join(name), &bytes)?, unit))
    }

    /// Files a validation report (the JSON `fslcal validate --json` prints) under the unit it
    /// names (or `unit`), beside the filed calibration it validated. Returns what was filed,
    /// the unit and the verdict.
    pub fn add_validation(&self, report: &Path, unit: Option<&str>) -> Result<(Filed, String, bool), RegistryError> {
        let name = report.display().to_string();
        let text = std::fs::read(report).map_err(Self::io(report, "read"))?;
        let doc = read_report(&text, &name)?;
        let unit = report_unit(&doc, unit, &name)?;
        let Some(cal_sha) = doc.calibration_sha256.as_deref() else {
            return Err(RegistryError::ReportWithoutCalibration { path: name });
        };
        let dir = self.root.join(&unit);
        let validated = |p: &PathBuf| std::fs::read(p).is_ok_and(|b| sha256_hex(&b).eq_ignore_ascii_case(cal_sha));
        if !files_with_ext(&dir, "fslcal").iter().any(validated) {
            return Err(RegistryError::CalibrationNotFiled { path: name, unit, sha256: cal_sha.to_string() });
        }
        let when = doc.validated_utc.as_deref().and_then(utc_time::parse_iso).unwrap_or_else(utc_time::now_s);
        let dest =
            dir.join(format!("validation-{}-{}.json", utc_time::format_compact(when), short(&sha256_hex(&text))));
        Ok((file_new(&dest, &text)?, unit, doc.pass))
    }

    /// Every unit with its current calibration and last validation, by unit id.
    pub fn list(&self, trusted: &[TrustedKey]) -> Result<Vec<UnitSummary>, RegistryError> {
        let entries = std::fs::read_dir(&self.root).map_err(Self::io(&self.root, "read the registry"))?;
        let mut units: Vec<(String, PathBuf)> = entries
            .filter_map(|e| e.ok())
            .filter(|e| e.path().is_dir())
            .filter_map(|e| Some((unit_id(e.file_name().to_str()?).ok()?, e.path())))
            .collect();
        units.sort();
        units.into_iter().map(|(unit, dir)| self.summarise(unit, &dir, trusted)).collect()
    }

    fn summarise(&self, unit: String, dir: &Path, trusted: &[TrustedKey]) -> Result<UnitSummary, RegistryError> {
        std::fs::read_dir(dir).map_err(Self::io(dir, "read"))?;
        let cals = files_with_ext(dir, "fslcal");
        let current = cals
            .iter()
            .filter_map(|p| read_current(p, trusted))
            .max_by(|a, b| (a.made_utc_s, a.filed, &a.file).cmp(&(b.made_utc_s, b.filed, &b.file)));
        let last_validation = current.as_ref().and_then(|c| {
            files_with_ext(dir, "json")
                .iter()
                .filter(|p| p.file_name().is_some_and(|n| n.to_string_lossy().starts_with("validation-")))
                .filter_map(|p| read_validation(p, &c.sha256))
                .max_by(|a, b| (a.validated_utc_s, a.filed, &a.file).cmp(&(b.validated_utc_s, b.filed, &b.file)))
        });
        Ok(UnitSummary { unit, calibrations: cals.len(), current, last_validation })
    }
}

/// The unit a report is filed under: the one it names, which `given` may repeat but not
/// contradict, or `given` when it names none.
fn report_unit(doc: &ValidationDocument, given: Option<&str>, name: &str) -> Result<String, RegistryError> {
    let named = doc.unit.as_deref().map(unit_id).transpose()?;
    let given = given.map(unit_id).transpose()?;
    match (named, given) {
        (Some(r), Some(g)) if r != g => {
            Err(RegistryError::ReportOfAnotherUnit { path: name.to_string(), report: r, given: g })
        }
        (Some(u), _) | (None, Some(u)) => Ok(u),
        (None, None) => Err(RegistryError::ReportWithoutUnit { path: name.to_string() }),
    }
}

/// Writes `bytes` at `dest` unless something is there: the same bytes are "already filed",
/// other bytes a conflict (never replaced).
fn file_new(dest: &Path, bytes: &[u8]) -> Result<Filed, RegistryError> {
    match write_new_atomically(dest, bytes) {
        Ok(()) => Ok(Filed::New(dest.to_path_buf())),
        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
            let there = std::fs::read(dest).map_err(Registry::io(dest, "read"))?;
            if there == bytes {
                Ok(Filed::AlreadyThere(dest.to_path_buf()))
            } else {
                Err(RegistryError::Conflict { path: dest.display().to_string() })
            }
        }
        Err(e) => Err(Registry::io(dest, "write")(e)),
    }
}

/// The files in `dir` ending in `.ext`, by name (none when `dir` cannot be read).
fn files_with_ext(dir: &Path, ext: &str) -> Vec<PathBuf> {
    let Ok(entries) = std::fs::read_dir(dir) else { return Vec::new() };
    let mut files: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == ext) && p.is_file())
        .collect();
    files.sort();
    files
}

fn modified(path: &Path) -> SystemTime {
    std::fs::metadata(path).and_then(|m| m.modified()).unwrap_or(SystemTime::UNIX_EPOCH)
}

fn read_current(path: &Path, trusted: &[TrustedKey]) -> Option<CurrentCalibration> {
    let bytes = signed_file::read_bytes(path).ok()?;
    let f = SignedUnitFile::decode(&bytes).ok()?;
    let keys: Vec<[u8; 32]> = trusted.iter().map(|t| t.key).collect();
    let status = match f.check_signature() {
        Err(e) => Err(e),
        Ok(()) if !keys.contains(&f.signer) => Err(FormatError::UnknownSigner(f.key_id())),
        Ok(()) => Ok(()),
    };
    Some(CurrentCalibration {
        file: path.to_path_buf(),
        made_utc_s: f.contents.made_utc_s,
        signer: f.key_id(),
        provenance: f.contents.provenance,
        status,
        sha256: sha256_hex(&bytes),
        filed: modified(path),
    })
}

/// A filed report, when it is a report of the calibration whose SHA-256 is `cal_sha256`.
fn read_validation(path: &Path, cal_sha256: &str) -> Option<ValidationRecord> {
    let doc = read_report(&std::fs::read(path).ok()?, "").ok()?;
    if !doc.calibration_sha256.as_deref().is_some_and(|s| s.eq_ignore_ascii_case(cal_sha256)) {
        return None;
    }
    let filed = modified(path);
    let filed_utc_s = filed.duration_since(SystemTime::UNIX_EPOCH).map_or(0, |d| d.as_secs() as i64);
    let validated_utc_s = doc.validated_utc.as_deref().and_then(utc_time::parse_iso).unwrap_or(filed_utc_s);
    Some(ValidationRecord { file: path.to_path_buf(), validated_utc_s, filed_utc_s, pass: doc.pass, filed })
}

/// A validation report (the file `name`) of a schema this build reads.
fn read_report(bytes: &[u8], name: &str) -> Result<ValidationDocument, RegistryError> {
    let doc: ValidationDocument =
        serde_json::from_slice(bytes).map_err(|_| RegistryError::NotAReport { path: name.to_string() })?;
    check_schema(doc.schema_version).map_err(|cause| RegistryError::NewerReport { path: name.to_string(), cause })?;
    Ok(doc)
}
