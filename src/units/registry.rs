//! The coordinator's registry of units: a plain folder anyone can back up or read by hand.
//!
//! ```text
//! units/
//!   trusted/*.pub                          keys whose files `units add` accepts
//!   FSL-03/
//!     20260601T093000Z-1a2b3c4d5e6f7a8b.fslcal   every accepted calibration, named by when
//!                                                it was made and its signer's key id
//!     validation-20260602T101500Z.json           validation reports, named by when filed
//! ```
//! A unit's current calibration is the one made last. Nothing is ever overwritten or
//! deleted, so the folder is the unit's history.

use crate::atomic_file::write_atomically;
use crate::documents::validation::ValidationDocument;
use crate::documents::{check_schema, NewerSchema};
use crate::units::keys::{self, KeyError, TrustedKey};
use crate::units::signed_file::{self, unit_id, UnitFileError};
use crate::utc_time;
use fslcal_core::unit_file::{self, FormatError, KeyId, Provenance, SignedUnitFile};
use std::path::{Path, PathBuf};

#[derive(Debug, thiserror::Error)]
pub enum RegistryError {
    #[error(transparent)]
    UnitFile(#[from] UnitFileError),
    #[error(transparent)]
    Key(#[from] KeyError),
    #[error("{path}: cannot {what}: {cause}")]
    Io { path: String, what: &'static str, cause: std::io::Error },
    #[error("{path}: a different calibration is already filed under this name; nothing written")]
    Conflict { path: String },
    #[error("{path}: not a validation report (expected the JSON of `fslcal validate --json`, with a boolean `pass`)")]
    NotAReport { path: String },
    #[error("{path}: {cause}")]
    NewerReport { path: String, cause: NewerSchema },
    #[error("{path}: the report names no unit; give it with --unit FSL-NN")]
    ReportWithoutUnit { path: String },
}

/// What `add` did with a calibration.
#[derive(Debug, PartialEq)]
pub enum Filed {
    New(PathBuf),
    AlreadyThere(PathBuf),
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
}

#[derive(Debug)]
pub struct ValidationRecord {
    pub file: PathBuf,
    pub filed_utc_s: i64,
    pub pass: bool,
}

impl Registry {
    pub fn new(root: &Path) -> Self {
        Registry { root: root.to_path_buf() }
    }

    fn io<'p>(path: &'p Path, what: &'static str) -> impl FnOnce(std::io::Error) -> RegistryError + 'p {
        move |cause| RegistryError::Io { path: path.display().to_string(), what, cause }
    }

    /// The registry's trusted keys, or those at `trust` when given.
    pub fn trusted(&self, trust: Option<&Path>) -> Result<Vec<TrustedKey>, RegistryError> {
        let dir = self.root.join("trusted");
        Ok(keys::read_trusted(trust.unwrap_or(&dir))?)
    }

    /// Files a calibration that verifies against `trusted` under its unit.
    pub fn add_calibration(&self, file: &Path, trusted: &[TrustedKey]) -> Result<(Filed, String), RegistryError> {
        let bytes = signed_file::read_bytes(file)?;
        let keys: Vec<[u8; 32]> = trusted.iter().map(|t| t.key).collect();
        let f = unit_file::verify(&bytes, &keys).map_err(UnitFileError::at(file))?;
        let unit = unit_id(f.contents.unit)?;
        let dir = self.root.join(&unit);
        std::fs::create_dir_all(&dir).map_err(Self::io(&dir, "create the unit's folder"))?;
        let dest = dir.join(format!("{}-{}.fslcal", utc_time::format_compact(f.contents.made_utc_s), f.key_id()));
        if dest.exists() {
            let there = std::fs::read(&dest).map_err(Self::io(&dest, "read"))?;
            return if there == bytes {
                Ok((Filed::AlreadyThere(dest), unit))
            } else {
                Err(RegistryError::Conflict { path: dest.display().to_string() })
            };
        }
        write_atomically(&dest, &bytes).map_err(Self::io(&dest, "write"))?;
        Ok((Filed::New(dest), unit))
    }

    /// Files a validation report (the JSON `fslcal validate --json` prints) under `unit`, or
    /// under the unit the report names.
    pub fn add_validation(&self, report: &Path, unit: Option<&str>) -> Result<(PathBuf, String, bool), RegistryError> {
        let name = report.display().to_string();
        let text = std::fs::read(report).map_err(Self::io(report, "read"))?;
        let doc = read_report(&text, &name)?;
        let pass = doc.pass;
        let unit = match unit.or(doc.unit.as_deref()) {
            Some(u) => unit_id(u)?,
            None => return Err(RegistryError::ReportWithoutUnit { path: name }),
        };
        let dir = self.root.join(&unit);
        std::fs::create_dir_all(&dir).map_err(Self::io(&dir, "create the unit's folder"))?;
        let now = utc_time::now_s();
        let mut dest = dir.join(format!("validation-{}.json", utc_time::format_compact(now)));
        // Two reports filed within a second keep both.
        let mut n = 1;
        while dest.exists() {
            n += 1;
            dest = dir.join(format!("validation-{}-{n}.json", utc_time::format_compact(now)));
        }
        write_atomically(&dest, &text).map_err(Self::io(&dest, "write"))?;
        Ok((dest, unit, pass))
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
        let mut names: Vec<PathBuf> =
            std::fs::read_dir(dir).map_err(Self::io(dir, "read"))?.filter_map(|e| e.ok().map(|e| e.path())).collect();
        names.sort();
        let ext = |p: &Path, e: &str| p.extension().is_some_and(|x| x == e);
        let cals: Vec<&PathBuf> = names.iter().filter(|p| ext(p, "fslcal")).collect();
        let current = cals.iter().filter_map(|p| read_current(p, trusted)).max_by_key(|c| c.made_utc_s);
        let last_validation = names
            .iter()
            .filter(|p| ext(p, "json") && p.file_name().is_some_and(|n| n.to_string_lossy().starts_with("validation-")))
            .filter_map(|p| read_validation(p))
            .max_by_key(|v| v.filed_utc_s);
        Ok(UnitSummary { unit, calibrations: cals.len(), current, last_validation })
    }
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
    })
}

fn read_validation(path: &Path) -> Option<ValidationRecord> {
    let stem = path.file_stem()?.to_str()?.strip_prefix("validation-")?;
    let compact = stem.get(..16).filter(|c| c.is_ascii())?;
    // 20260602T101500Z -> 2026-06-02T10:15:00Z
    let iso = format!(
        "{}-{}-{}T{}:{}:{}Z",
        &compact[..4],
        &compact[4..6],
        &compact[6..8],
        &compact[9..11],
        &compact[11..13],
        &compact[13..15]
    );
    let filed_utc_s = utc_time::parse_iso(&iso)?;
    let doc = read_report(&std::fs::read(path).ok()?, "").ok()?;
    Some(ValidationRecord { file: path.to_path_buf(), filed_utc_s, pass: doc.pass })
}

/// A validation report (the file `name`) of a schema this build reads.
fn read_report(bytes: &[u8], name: &str) -> Result<ValidationDocument, RegistryError> {
    let doc: ValidationDocument =
        serde_json::from_slice(bytes).map_err(|_| RegistryError::NotAReport { path: name.to_string() })?;
    check_schema(doc.schema_version).map_err(|cause| RegistryError::NewerReport { path: name.to_string(), cause })?;
    Ok(doc)
}
