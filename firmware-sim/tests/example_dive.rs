//! The scripted dive under docs/firmware-example/: its calibration files are what the core
//! signs, and running `firmware-sim run` on it reproduces the committed PNGs pixel for pixel.

mod common;

use common::*;
use std::path::Path;
use std::process::Command;

fn example_dir() -> std::path::PathBuf {
    repo_root().join("docs/firmware-example")
}

#[test]
fn committed_calibration_files_are_what_the_core_signs() {
    for (name, bytes) in example_files() {
        let path = example_dir().join(name);
        if bless() {
            std::fs::write(&path, &bytes).unwrap();
            continue;
        }
        let committed = std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert!(committed == bytes, "{name} differs from what fslcal-core signs today (FSLCAL_BLESS=1 rewrites it)");
    }
}

fn pngs(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".png"))
        .collect();
    names.sort();
    names
}

#[test]
fn scripted_dive_reproduces_the_committed_screens() {
    let out = tempfile::tempdir().unwrap();
    let run = Command::new(env!("CARGO_BIN_EXE_firmware-sim"))
        .args(["run", "--json", "--out"])
        .arg(out.path())
        .arg(example_dir().join("dive.txt"))
        .output()
        .unwrap();
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let report: serde_json::Value = serde_json::from_slice(&run.stdout).unwrap();
    let screens: Vec<&str> =
        report["steps"].as_array().unwrap().iter().map(|s| s["screen"].as_str().unwrap()).collect();
    // The story the script tells, screen by screen.
    assert_eq!(
        screens,
        [
            "NoCalibration",
            "Invalid",
            "Invalid",
            "Invalid",
            "Invalid",
            "Invalid",
            "Invalid",
            "SelfCheck",
            "Live",
            "Live",
            "Live",
            "Live",
            "Live",
            "Validation",
            "Validation",
            "Validation",
            "SelfCheck",
            "Live",
            "Live",
            "Live",
            "Live",
            "DriftWarning",
            "Live",
            "Live",
        ]
    );
    let summary = |i: usize| report["steps"][i]["summary"].as_str().unwrap().to_string();
    assert!(summary(1).starts_with("NOT A CALIBRATION"), "{}", summary(1));
    assert!(summary(2).starts_with("OTHER UNIT"), "{}", summary(2));
    assert!(summary(3).starts_with("UNKNOWN SIGNER"), "{}", summary(3));
    assert!(summary(4).starts_with("TAMPERED"), "{}", summary(4));
    assert!(summary(5).starts_with("TRUNCATED"), "{}", summary(5));
    assert!(summary(6).starts_with("NEWER FORMAT"), "{}", summary(6));

    let committed = example_dir().join("screens");
    if bless() {
        let _ = std::fs::remove_dir_all(&committed);
        std::fs::create_dir_all(&committed).unwrap();
        for n in pngs(out.path()) {
            std::fs::copy(out.path().join(&n), committed.join(&n)).unwrap();
        }
        std::fs::write(example_dir().join("run.txt"), plain_report(out.path())).unwrap();
    }
    assert_eq!(pngs(out.path()), pngs(&committed));
    for n in pngs(&committed) {
        let got = image::open(out.path().join(&n)).unwrap().to_rgb8();
        let want = image::open(committed.join(&n)).unwrap().to_rgb8();
        assert_eq!(got.dimensions(), (511, 255), "{n}");
        assert!(got == want, "{n}: differs from the committed screen (FSLCAL_BLESS=1 rewrites)");
    }
}

/// The human table `firmware-sim run` prints, committed beside the PNGs for the README.
fn plain_report(out: &Path) -> String {
    let run = Command::new(env!("CARGO_BIN_EXE_firmware-sim"))
        .current_dir(repo_root())
        .args(["run", "docs/firmware-example/dive.txt", "--out"])
        .arg(out)
        .output()
        .unwrap();
    String::from_utf8(run.stdout).unwrap().replace(&out.display().to_string(), "DIR")
}

#[test]
fn a_bad_script_line_names_the_file_and_line_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let script = dir.path().join("bad.txt");
    std::fs::write(&script, "clock 2026-11-25T07:30:00Z\npress next\ndot 12\n").unwrap();
    let out = dir.path().join("out");
    let run = Command::new(env!("CARGO_BIN_EXE_firmware-sim"))
        .arg("run")
        .arg(&script)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(!run.status.success());
    let err = String::from_utf8_lossy(&run.stderr);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains("bad.txt:3: usage: dot U_PX V_PX"), "{err}");
    assert!(!out.exists(), "nothing written for a bad script");
}
