//! `fslcal units`: the coordinator's registry of every unit's calibrations.

use crate::calibration;
use crate::calibration::change::{self, REFERENCE_FISH_M};
use crate::units::registry::{Filed, Registry};
use crate::utc_time;
use anyhow::Context;
use fslcal_core::unit_file::{FormatError, Provenance};
use serde_json::json;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// The registry of units: file verified calibrations and validation reports, list each
/// unit's current state, compare two calibrations.
#[derive(clap::Args, Debug)]
pub struct UnitsArgs {
    /// The registry folder. Its `trusted/` subfolder holds the .pub keys it accepts.
    #[arg(long, value_name = "DIR", default_value = "units", global = true)]
    registry: PathBuf,

    /// Print one JSON object instead of the summary.
    #[arg(long, global = true)]
    json: bool,

    #[command(subcommand)]
    action: UnitsAction,
}

#[derive(clap::Subcommand, Debug)]
enum UnitsAction {
    /// File a unit file (.fslcal) under its unit after verifying it, or a validation report
    /// (the JSON of `fslcal validate --json`) as the unit's latest validation.
    Add {
        /// A .fslcal, or a validation report (.json).
        #[arg(value_name = "FILE")]
        file: PathBuf,
        /// Trust these keys (a .pub or a folder) instead of the registry's `trusted/`.
        #[arg(long, value_name = "PUBKEY_OR_DIR")]
        trust: Option<PathBuf>,
        /// The unit a validation report is for, when the report does not say.
        #[arg(long, value_name = "FSL-NN")]
        unit: Option<String>,
    },
    /// Trust a signer: copy their public key (KEY.pub, from `fslcal keygen`) into the
    /// registry's `trusted/` folder, created if missing.
    Trust {
        #[arg(value_name = "KEY.pub")]
        key: PathBuf,
    },
    /// Each unit's current calibration, its age and signer, and the last validation result.
    List {
        /// Judge signers against these keys instead of the registry's `trusted/`.
        #[arg(long, value_name = "PUBKEY_OR_DIR")]
        trust: Option<PathBuf>,
    },
    /// What changed from calibration OLD to NEW, and the distance and length errors OLD
    /// causes if still used after the change (NEW taken as the truth).
    Diff {
        /// The earlier calibration (.fslcal or `fslcal laser` JSON).
        #[arg(value_name = "OLD")]
        old: PathBuf,
        /// The later calibration.
        #[arg(value_name = "NEW")]
        new: PathBuf,
    },
}

pub fn run(args: UnitsArgs) -> anyhow::Result<ExitCode> {
    let registry = Registry::new(&args.registry);
    match args.action {
        UnitsAction::Add { file, trust, unit } => add(&registry, &file, trust.as_deref(), unit.as_deref(), args.json),
        UnitsAction::Trust { key } => trust(&registry, &key, args.json),
        UnitsAction::List { trust } => list(&registry, trust.as_deref(), args.json),
        UnitsAction::Diff { old, new } => diff(&old, &new, args.json),
    }
}

fn is_json(path: &Path) -> bool {
    std::fs::File::open(path)
        .and_then(|mut f| {
            let mut first = [0u8; 64];
            let n = std::io::Read::read(&mut f, &mut first)?;
            Ok(first[..n].iter().find(|b| !b.is_ascii_whitespace()) == Some(&b'{'))
        })
        .unwrap_or(false)
}

fn add(
    registry: &Registry,
    file: &Path,
    trust: Option<&Path>,
    unit: Option<&str>,
    as_json: bool,
) -> anyhow::Result<ExitCode> {
    if is_json(file) {
        let (filed, unit, pass) = registry.add_validation(file, unit)?;
        let (dest, new) = (filed.path().display().to_string(), matches!(filed, Filed::New(_)));
        let verdict = if pass { "pass" } else { "FAIL" };
        if as_json {
            println!("{}", json!({ "unit": unit, "validation": dest, "pass": pass, "new": new }));
        } else if new {
            println!("{unit}: validation {verdict} filed as {dest}");
        } else {
            println!("{unit}: validation {verdict} already filed as {dest}");
        }
        return Ok(ExitCode::SUCCESS);
    }
    let trusted = registry.trusted(trust)?;
    let (filed, unit) = registry.add_calibration(file, &trusted)?;
    let (dest, new) = match filed {
        Filed::New(p) => (p, true),
        Filed::AlreadyThere(p) => (p, false),
    };
    if as_json {
        println!("{}", json!({ "unit": unit, "calibration": dest.display().to_string(), "new": new }));
    } else if new {
        println!("{unit}: filed {}", dest.display());
    } else {
        println!("{unit}: already filed as {}", dest.display());
    }
    Ok(ExitCode::SUCCESS)
}

fn trust(registry: &Registry, key: &Path, as_json: bool) -> anyhow::Result<ExitCode> {
    let filed = registry.trust(key)?;
    let (dest, new) = (filed.path().display().to_string(), matches!(filed, Filed::New(_)));
    let id = fslcal_core::unit_file::KeyId::of(&crate::units::keys::read_public(key)?).to_string();
    if as_json {
        println!("{}", json!({ "trusted": dest, "key_id": id, "new": new }));
    } else if new {
        println!("trusted key {id}: {dest}");
    } else {
        println!("key {id} is already trusted: {dest}");
    }
    Ok(ExitCode::SUCCESS)
}

fn age(now: i64, then: i64) -> String {
    let days = (now - then) as f64 / 86_400.0;
    if days < 1.0 {
        format!("{:.0} h", (days * 24.0).max(0.0))
    } else {
        format!("{days:.0} d")
    }
}

/// A filed calibration's status as the list shows it: `valid`, or why not.
fn status_text(status: &Result<(), FormatError>) -> String {
    match status {
        Ok(()) => "valid".into(),
        Err(e) => e.to_string(),
    }
}

fn list(registry: &Registry, trust: Option<&Path>, as_json: bool) -> anyhow::Result<ExitCode> {
    let trusted = registry.trusted(trust)?;
    let units = registry.list(&trusted)?;
    let now = utc_time::now_s();
    if as_json {
        let rows: Vec<_> = units
            .iter()
            .map(|u| {
                json!({
                    "unit": u.unit,
                    "calibrations": u.calibrations,
                    "current": u.current.as_ref().map(|c| json!({
                        "file": c.file.display().to_string(),
                        "made_utc": utc_time::format_iso(c.made_utc_s),
                        "age_days": (now - c.made_utc_s) as f64 / 86_400.0,
                        "signer": c.signer.to_string(),
                        "provenance": c.provenance.name(),
                        "status": status_text(&c.status),
                        "sha256": c.sha256,
                    })),
                    "last_validation": u.last_validation.as_ref().map(|v| json!({
                        "file": v.file.display().to_string(),
                        "validated_utc": utc_time::format_iso(v.validated_utc_s),
                        "filed_utc": utc_time::format_iso(v.filed_utc_s),
                        "pass": v.pass,
                    })),
                })
            })
            .collect();
        println!(
            "{}",
            serde_json::to_string_pretty(&json!({ "registry": registry.root.display().to_string(), "units": rows }))?
        );
        return Ok(ExitCode::SUCCESS);
    }
    if units.is_empty() {
        println!("{}: no units yet; file calibrations with `fslcal units add FILE.fslcal`", registry.root.display());
        return Ok(ExitCode::SUCCESS);
    }
    println!(
        "{:8} {:>4}  {:20} {:>6}  {:16}  {:16}  status",
        "unit", "cals", "current (made)", "age", "signer", "validation"
    );
    for u in &units {
        let (made, age, signer, status) = match &u.current {
            Some(c) => (
                utc_time::format_iso(c.made_utc_s),
                age(now, c.made_utc_s),
                c.signer.to_string(),
                // An imported calibration has no fit behind it: say so where its status is read.
                match c.provenance {
                    Provenance::Fitted => status_text(&c.status),
                    p => format!("{} ({})", status_text(&c.status), p.name()),
                },
            ),
            None => ("-".into(), "-".into(), "-".into(), "no readable calibration".into()),
        };
        let validation = u.last_validation.as_ref().map_or("-".to_string(), |v| {
            format!("{} {}", if v.pass { "pass" } else { "FAIL" }, &utc_time::format_iso(v.validated_utc_s)[..10])
        });
        println!("{:8} {:>4}  {made:20} {age:>6}  {signer:16}  {validation:16}  {status}", u.unit, u.calibrations);
    }
    Ok(ExitCode::SUCCESS)
}

fn diff(old: &Path, new: &Path, as_json: bool) -> anyhow::Result<ExitCode> {
    let a = calibration::load(old)?;
    let b = calibration::load(new)?;
    let change = change::compare(&a, &b);
    let units = (a.unit.as_deref().unwrap_or("-"), b.unit.as_deref().unwrap_or("-"));
    if as_json {
        let mut v = serde_json::to_value(&change).context("cannot describe the change")?;
        v["old"] = json!({ "file": old.display().to_string(), "unit": a.unit });
        v["new"] = json!({ "file": new.display().to_string(), "unit": b.unit });
        v["reference_fish_m"] = json!(REFERENCE_FISH_M);
        println!("{}", serde_json::to_string_pretty(&v)?);
        return Ok(ExitCode::SUCCESS);
    }
    println!("old {} (unit {}) -> new {} (unit {})", old.display(), units.0, new.display(), units.1);
    if units.0 != units.1 {
        println!("note: different units; the errors below are what swapping their files would cause");
    }
    println!(
        "laser direction changed {:.3} deg, origin moved {:.1} mm",
        change.direction_change_deg, change.origin_change_mm
    );
    println!("using the old file after the change (a {:.0} mm fish square to the camera):", REFERENCE_FISH_M * 1e3);
    for e in &change.errors {
        let d =
            e.distance_error_m.map_or("-".into(), |d| format!("{:+.1} mm ({:+.2}%)", d * 1e3, 100.0 * d / e.depth_m));
        let l = e
            .length_error_pct
            .map_or("-".into(), |p| format!("{:+.1} mm ({p:+.2}%)", p / 100.0 * REFERENCE_FISH_M * 1e3));
        println!("  at {:.0} m: distance {d}, length {l}", e.depth_m);
    }
    Ok(ExitCode::SUCCESS)
}
