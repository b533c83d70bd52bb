//! `fslcal verify`: the gate before a unit file goes onto a camera or into the registry.

use crate::units::keys::{self, TrustedKey};
use crate::units::signed_file::{self, UnitFileError};
use fslcal_core::unit_file::{self as format, SignedUnitFile};
use serde_json::json;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// Check that a unit file is intact and signed by a key you trust; exit 0 only then.
///
/// Otherwise prints one line saying why (truncated, not a calibration file, newer format
/// version, tampered, unknown signer) and exits 1.
#[derive(clap::Args, Debug)]
pub struct VerifyArgs {
    /// The unit file (.fslcal).
    #[arg(value_name = "FILE")]
    file: PathBuf,

    /// A trusted public key (KEY.pub), or a folder whose .pub files are all trusted.
    #[arg(long, value_name = "PUBKEY_OR_DIR")]
    trust: PathBuf,

    /// Print one JSON object (`valid`, `reason` or the unit and signer) instead of a line.
    #[arg(long)]
    json: bool,
}

/// Verifies `bytes` (read from `path`) against `trusted`, returning the decoded file and the
/// trusted key that signed it.
pub(super) fn verify_bytes<'a>(
    path: &Path,
    bytes: &'a [u8],
    trusted: &'a [TrustedKey],
) -> Result<(SignedUnitFile<'a>, &'a TrustedKey), UnitFileError> {
    let keys: Vec<[u8; 32]> = trusted.iter().map(|t| t.key).collect();
    let file = format::verify(bytes, &keys).map_err(UnitFileError::at(path))?;
    // `verify` accepted the signer, so it is among `trusted`.
    let by = trusted.iter().find(|t| t.key == file.signer).unwrap_or(&trusted[0]);
    Ok((file, by))
}

pub fn run(args: VerifyArgs) -> anyhow::Result<ExitCode> {
    let trusted = keys::read_trusted(&args.trust)?;
    let bytes = signed_file::read_bytes(&args.file)?;
    match verify_bytes(&args.file, &bytes, &trusted) {
        Ok((file, by)) => {
            let line = format!(
                "{}: valid: unit {}, signed by {} (trusted via {})",
                args.file.display(),
                file.contents.unit,
                file.key_id(),
                by.file.display()
            );
            if args.json {
                let report = json!({
                    "file": args.file.display().to_string(),
                    "valid": true,
                    "unit": file.contents.unit,
                    "signer": file.key_id().to_string(),
                    "trusted_key_file": by.file.display().to_string(),
                });
                println!("{report}");
            } else {
                println!("{line}");
            }
            Ok(ExitCode::SUCCESS)
        }
        Err(e) if args.json => {
            println!("{}", json!({ "file": args.file.display().to_string(), "valid": false, "reason": e.to_string() }));
            Ok(ExitCode::FAILURE)
        }
        Err(e) => Err(e.into()),
    }
}
