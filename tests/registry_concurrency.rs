//! Two coordinators filing at once lose nothing (issue 16, item 2): rounds of two `fslcal
//! units add` started together, of different calibrations made in the same second by the
//! same signer, then of two validation reports of the current calibration; after each
//! round both are filed, with their bytes, and `units list` shows the right current
//! calibration and last validation.
//!
//! `FSLCAL_STRESS_ROUNDS` sets the number of rounds: 25 by default, which CI runs in about
//! half a minute; the closing note's figures are from `FSLCAL_STRESS_ROUNDS=100`.

use fslcal_core::unit_file::{self, UnitFile, MAX_FILE_BYTES};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::Instant;

fn fslcal(args: &[&str]) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_fslcal"));
    c.args(args).stdout(Stdio::piped()).stderr(Stdio::piped());
    c
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn rounds() -> usize {
    std::env::var("FSLCAL_STRESS_ROUNDS").ok().and_then(|v| v.parse().ok()).unwrap_or(25)
}

/// Starts two commands together and waits for both.
fn together(a: &mut Command, b: &mut Command) -> (Output, Output) {
    let (x, y): (Child, Child) = (a.spawn().unwrap(), b.spawn().unwrap());
    (x.wait_with_output().unwrap(), y.wait_with_output().unwrap())
}

fn ok_json(o: &Output) -> Value {
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    serde_json::from_slice(&o.stdout).expect("one JSON object")
}

/// The example calibration of FSL-07 with its laser turned by `tilt` (a distinct file),
/// made at `made_utc_s`, signed with `secret`.
fn calibration(dir: &Path, name: &str, tilt: f64, made_utc_s: i64, secret: &[u8; 32]) -> PathBuf {
    let mut c: UnitFile = unit_file::example();
    c.unit = "FSL-07";
    c.made_utc_s = made_utc_s;
    let d = c.laser.direction;
    let n = (d[0] * d[0] + (d[1] + tilt).powi(2) + d[2] * d[2]).sqrt();
    c.laser.direction = [d[0] / n, (d[1] + tilt) / n, d[2] / n];
    let mut buf = [0u8; MAX_FILE_BYTES];
    let len = c.sign(secret, &mut buf).unwrap();
    let path = dir.join(name);
    std::fs::write(&path, &buf[..len]).unwrap();
    path
}

fn report(dir: &Path, name: &str, cal_sha256: &str, pass: bool, validated_utc: &str) -> PathBuf {
    let v = serde_json::json!({
        "schema_version": 1, "unit": "FSL-07", "photos": [], "pass": pass,
        "calibration_sha256": cal_sha256, "validated_utc": validated_utc,
    });
    let path = dir.join(name);
    std::fs::write(&path, serde_json::to_vec(&v).unwrap()).unwrap();
    path
}

fn entries(dir: &Path, prefix: &str, ext: &str) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| {
            let n = p.file_name().unwrap().to_string_lossy();
            n.starts_with(prefix) && n.ends_with(ext)
        })
        .collect();
    v.sort();
    v
}

#[test]
fn two_units_add_started_together_lose_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let key = d.join("lead");
    assert!(fslcal(&["keygen", "--out", s(&key)]).output().unwrap().status.success());
    let secret = fslcal::units::keys::read_secret(&key).unwrap();
    let reg = d.join("units");
    let trust = fslcal(&["units", "--registry", s(&reg), "trust", s(&d.join("lead.pub"))]).output().unwrap();
    assert!(trust.status.success());
    // Every calibration made in the same second by the same signer: one name each, by
    // content alone.
    let made = 1_780_306_200;
    let (n, started) = (rounds(), Instant::now());
    let mut reports_filed = 0;
    for r in 0..n {
        let (a, b) = (
            calibration(d, &format!("a{r}.fslcal"), 1e-4 * (2 * r + 1) as f64, made, &secret),
            calibration(d, &format!("b{r}.fslcal"), 1e-4 * (2 * r + 2) as f64, made, &secret),
        );
        let add = |f: &Path| fslcal(&["units", "--registry", s(&reg), "add", s(f), "--json"]);
        let (x, y) = together(&mut add(&a), &mut add(&b));
        let (x, y) = (ok_json(&x), ok_json(&y));
        assert_eq!((x["new"].as_bool(), y["new"].as_bool()), (Some(true), Some(true)), "round {r}: {x} {y}");
        for (v, f) in [(&x, &a), (&y, &b)] {
            let filed = PathBuf::from(v["calibration"].as_str().unwrap());
            assert_eq!(std::fs::read(&filed).unwrap(), std::fs::read(f).unwrap(), "round {r}: filed bytes");
        }
        let cals = entries(&reg.join("FSL-07"), "", ".fslcal");
        assert_eq!(cals.len(), 2 * (r + 1), "round {r}: a calibration was lost");
        let list = |reg: &Path| ok_json(&fslcal(&["units", "--registry", s(reg), "list", "--json"]).output().unwrap());
        let unit = list(&reg)["units"][0].clone();
        assert_eq!(unit["calibrations"], 2 * (r + 1));
        // The current one is this round's (filed last; made in the same second as all).
        let current = unit["current"]["file"].as_str().unwrap().to_string();
        assert!(current == x["calibration"] || current == y["calibration"], "round {r}: current {current}");
        let sha = unit["current"]["sha256"].as_str().unwrap().to_string();

        // Two reports of it at once: an older FAIL and a newer PASS (which one is newer
        // alternates), validated in the same minute.
        let newer_passes = r % 2 == 0;
        let (t0, t1) = (format!("2026-06-02T10:{:02}:00Z", r % 60), format!("2026-06-02T10:{:02}:01Z", r % 60));
        let (p, f) = (
            report(d, &format!("pass{r}.json"), &sha, true, if newer_passes { &t1 } else { &t0 }),
            report(d, &format!("fail{r}.json"), &sha, false, if newer_passes { &t0 } else { &t1 }),
        );
        let (x, y) = together(&mut add(&p), &mut add(&f));
        let (x, y) = (ok_json(&x), ok_json(&y));
        assert_eq!((x["new"].as_bool(), y["new"].as_bool()), (Some(true), Some(true)), "round {r}: {x} {y}");
        reports_filed += 2;
        let reports = entries(&reg.join("FSL-07"), "validation-", ".json");
        assert_eq!(reports.len(), reports_filed, "round {r}: a report was lost");
        let last = list(&reg)["units"][0]["last_validation"].clone();
        assert_eq!(last["pass"].as_bool(), Some(newer_passes), "round {r}: {last}");
    }
    eprintln!(
        "{n} rounds in {:.1} s: {} calibrations and {reports_filed} validation reports filed by pairs of `units add` started together, none lost; `units list` right every round",
        started.elapsed().as_secs_f64(),
        2 * n
    );
}
