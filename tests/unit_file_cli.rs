//! The signed unit file's life through the CLI: keys, signing from a laser fit and from the
//! lab's .pkg files, inspect, verify with each failure named, the registry, and export back
//! to .pkg files that NumPy reads with the same numbers.

mod common;

use calib_targets::scene::Water;
use fslcal::units::lab_pkg::{LaserPkg, LensPkg};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn fslcal(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_fslcal")).args(args).output().expect("run fslcal")
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// The one line a failing command prints, asserting it is one line naming `file`.
fn one_line_error(o: &Output, file: &str) -> String {
    assert!(!o.status.success(), "expected failure, got: {}", String::from_utf8_lossy(&o.stdout));
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr).trim_end().to_string();
    assert_eq!(err.lines().count(), 1, "one line: {err}");
    assert!(err.contains(file), "names {file}: {err}");
    err
}

fn json(o: &Output) -> Value {
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    serde_json::from_slice(&o.stdout).expect("stdout is one JSON object")
}

const LENS_K: [f64; 9] = [2911.75, 0.0, 2003.125, 0.0, 2912.5, 1501.0625, 0.0, 0.0, 1.0];
const LENS_DIST: [f64; 5] = [-0.1175, 0.0512, 0.00091, -0.00042, -0.0139];
const LASER_POS: [f64; 3] = [-0.0412, -0.1067, 0.0];

fn unit_axis(tilt_deg: f64) -> [f64; 3] {
    let d = [0.0098, 0.0199 + tilt_deg.to_radians(), 1.0];
    let n = d.iter().map(|v| v * v).sum::<f64>().sqrt();
    d.map(|v| v / n)
}

/// The lab's lens and laser .pkg files, as their tools write them; `tilt_deg` turns the laser.
fn lab_pkgs(dir: &Path, tag: &str, tilt_deg: f64, date_s: i64) -> (PathBuf, PathBuf) {
    let lens = LensPkg { camera_matrix: LENS_K, distortion: LENS_DIST.to_vec(), calibrated_utc_s: date_s };
    let laser = LaserPkg { position_m: LASER_POS, axis: unit_axis(tilt_deg), calibrated_utc_s: date_s };
    let (a, b) = (dir.join(format!("{tag}-lens.pkg")), dir.join(format!("{tag}-laser.pkg")));
    std::fs::write(&a, lens.write().unwrap()).unwrap();
    std::fs::write(&b, laser.write().unwrap()).unwrap();
    (a, b)
}

fn keygen(dir: &Path, name: &str) -> PathBuf {
    let key = dir.join(name);
    let o = fslcal(&["keygen", "--out", s(&key), "--comment", "test"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    key
}

fn import(dir: &Path, key: &Path, unit: &str, tag: &str, tilt_deg: f64, date_s: i64) -> PathBuf {
    let (lens, laser) = lab_pkgs(dir, tag, tilt_deg, date_s);
    let out = dir.join(format!("{tag}.fslcal"));
    let o = fslcal(&[
        "import",
        s(&lens),
        s(&laser),
        "--unit",
        unit,
        "--key",
        s(key),
        "--camera-serial",
        "BHV204411",
        "--out",
        s(&out),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    out
}

#[test]
fn keygen_writes_a_private_secret_and_refuses_to_overwrite() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    let key = dir.path().join("lead");
    let v = json(&fslcal(&["keygen", "--out", s(&key), "--json"]));
    assert_eq!(std::fs::metadata(&key).unwrap().permissions().mode() & 0o777, 0o600);
    let public = std::fs::read_to_string(dir.path().join("lead.pub")).unwrap();
    assert!(public.starts_with(&format!(
        "fslcal-ed25519 {} {}",
        v["public_key"].as_str().unwrap(),
        v["key_id"].as_str().unwrap()
    )));
    let err = one_line_error(&fslcal(&["keygen", "--out", s(&key)]), "lead");
    assert!(err.contains("already exists"), "{err}");
}

#[test]
fn imported_file_inspects_and_verifies_and_every_failure_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let key = keygen(d, "lead");
    let file = import(d, &key, "fsl-02", "a", 0.0, 1_780_306_200);
    let bytes = std::fs::read(&file).unwrap();
    assert!(bytes.len() <= 512, "{} bytes", bytes.len());

    let v = json(&fslcal(&["inspect", s(&file), "--json"]));
    assert_eq!(v["unit"], "FSL-02");
    assert_eq!(v["signature"], "valid");
    assert_eq!(v["camera"]["image_size"], serde_json::json!([4000, 3000]));
    assert_eq!(v["camera"]["fx"].as_f64(), Some(LENS_K[0]));
    // The lab's lenses are made in the TG-6's 4040x3016 readout; fslcal's picture starts
    // 8 px in (docs/conventions.md).
    assert_eq!(v["camera"]["cx"].as_f64(), Some(LENS_K[2] - 8.0));
    assert_eq!(v["camera"]["cy"].as_f64(), Some(LENS_K[5] - 8.0));
    let dist: Vec<f64> = v["camera"]["dist"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
    assert_eq!(dist, LENS_DIST);
    assert_eq!(v["laser"]["origin_m"], serde_json::json!(LASER_POS));
    assert_eq!(v["laser"]["direction"], serde_json::json!(unit_axis(0.0)));
    assert_eq!(v["camera_identity"]["serial"], "BHV204411");
    assert_eq!(v["made_utc"], "2026-06-01T09:30:00Z");
    assert_eq!(v["method"], "imported");
    assert_eq!(v["provenance"], "imported-pkg");
    assert_eq!(v["size_bytes"].as_u64(), Some(bytes.len() as u64));
    let signer = v["signer"].as_str().unwrap().to_string();
    assert_eq!(signer.len(), 16);

    // Trusted as a key file and as a folder of keys.
    let public = d.join("lead.pub");
    for trust in [public.as_path(), d] {
        let o = fslcal(&["verify", s(&file), "--trust", s(trust)]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        assert!(String::from_utf8_lossy(&o.stdout).contains(&format!("valid: unit FSL-02, signed by {signer}")));
    }

    // The failures, each one line naming the file and the reason, exit 1.
    let other = tempfile::tempdir().unwrap();
    let stranger = keygen(other.path(), "stranger");
    let err = one_line_error(&fslcal(&["verify", s(&file), "--trust", &format!("{}.pub", s(&stranger))]), "a.fslcal");
    assert!(err.contains(&format!("signed by unknown key {signer}")), "{err}");
    let case = |name: &str, content: &[u8], reason: &str| {
        let p = d.join(name);
        std::fs::write(&p, content).unwrap();
        let err = one_line_error(&fslcal(&["verify", s(&p), "--trust", s(&public)]), name);
        assert!(err.contains(reason), "{name}: {err}");
        let v = json_failure(&fslcal(&["verify", s(&p), "--trust", s(&public), "--json"]));
        assert!(v["reason"].as_str().unwrap().contains(reason));
    };
    let mut tampered = bytes.clone();
    tampered[60] ^= 0x04; // inside fx
    case("tampered.fslcal", &tampered, "tampered");
    case("cut.fslcal", &bytes[..bytes.len() - 10], "truncated");
    case("laser.json", br#"{"camera": {}}"#, "not a calibration file");
    let mut newer = bytes.clone();
    newer[4] = 9;
    case("newer.fslcal", &newer, "newer fslcal (format version 9");

    // Inspect still shows a tampered file, says so, and exits 1.
    let o = fslcal(&["inspect", s(&d.join("tampered.fslcal")), "--json"]);
    assert_eq!(o.status.code(), Some(1));
    let v: Value = serde_json::from_slice(&o.stdout).expect("the contents, as found");
    assert_eq!(v["signature"], "invalid");
    // Measuring commands refuse it through the shared --cal loader.
    let err = fslcal::calibration::load(&d.join("tampered.fslcal")).unwrap_err().to_string();
    assert!(err.contains("tampered"), "{err}");
}

fn json_failure(o: &Output) -> Value {
    assert_eq!(o.status.code(), Some(1));
    let v: Value = serde_json::from_slice(&o.stdout).expect("one JSON object");
    assert_eq!(v["valid"], false);
    v
}

/// A Python with NumPy: `python3` on the PATH, or Debian's (which `.ci/setup` installs it for).
fn python_with_numpy() -> Option<&'static str> {
    ["python3", "/usr/bin/python3"]
        .into_iter()
        .find(|py| Command::new(py).args(["-c", "import numpy"]).output().is_ok_and(|o| o.status.success()))
}

#[test]
fn export_writes_pkgs_numpy_reads_with_the_same_numbers() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let key = keygen(d, "lead");
    let file = import(d, &key, "FSL-04", "orig", 0.0, 1_780_306_200);
    let out = d.join("export");
    let v = json(&fslcal(&["export", s(&file), "--format", "fishsense-pkg", "--out", s(&out), "--json"]));
    let (lens_path, laser_path) = (out.join("FSL-04-lens.pkg"), out.join("FSL-04-laser.pkg"));
    assert_eq!(v["lens"].as_str(), Some(s(&lens_path)));
    // Our own reader: exactly the numbers imported.
    let lens = LensPkg::read(&std::fs::read(&lens_path).unwrap()).unwrap();
    assert_eq!(lens.camera_matrix, LENS_K);
    assert_eq!(lens.distortion, LENS_DIST);
    assert_eq!(lens.calibrated_utc_s, 1_780_306_200);
    let laser = LaserPkg::read(&std::fs::read(&laser_path).unwrap()).unwrap();
    assert_eq!(laser.position_m, LASER_POS);
    assert_eq!(laser.axis, unit_axis(0.0));

    // NumPy, as the lab's tools read them (tarfile + np.load).
    // Without NumPy this test would check our reader against our writer: fail instead.
    let py = python_with_numpy().expect(
        "this test needs python3 with NumPy, which reads the exported .pkg as the lab does: \
         run `bash .ci/setup` (or `apt-get install python3-numpy`, or `pip install numpy`)",
    );
    let script = r#"
import json, sys, tarfile, io
import numpy as np
out = {}
for path in sys.argv[1:]:
    with tarfile.open(path, "r:gz") as t:
        for m in t.getmembers():
            data = t.extractfile(m).read()
            if m.name.endswith(".npy"):
                a = np.load(io.BytesIO(data))
                resaved = io.BytesIO()
                np.save(resaved, a)
                out[m.name] = {"shape": list(a.shape), "dtype": str(a.dtype), "values": a.ravel().tolist(),
                               "same_bytes_as_np_save": resaved.getvalue() == data}
            else:
                out[m.name] = json.loads(data)
print(json.dumps(out))
"#;
    let o = Command::new(py).args(["-c", script, s(&lens_path), s(&laser_path)]).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: Value = serde_json::from_slice(&o.stdout).unwrap();
    let values = |name: &str| -> Vec<f64> {
        v[name]["values"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect()
    };
    assert_eq!(v["_calibration_matrix.npy"]["shape"], serde_json::json!([3, 3]));
    assert_eq!(v["_calibration_matrix.npy"]["dtype"], "float64");
    assert_eq!(values("_calibration_matrix.npy"), LENS_K);
    assert_eq!(values("_distortion_coefficients.npy"), LENS_DIST);
    assert_eq!(values("laser_pos.npy"), LASER_POS);
    assert_eq!(values("laser_axis.npy"), unit_axis(0.0));
    assert_eq!(v["metadata.json"]["calibrated_date"], "2026-06-01 09:30:00+00:00");
    // The files are what the lab's own `np.save` writes, byte for byte.
    for name in ["_calibration_matrix.npy", "_distortion_coefficients.npy", "laser_pos.npy", "laser_axis.npy"] {
        assert_eq!(v[name]["same_bytes_as_np_save"], true, "{name}: not the bytes np.save writes");
    }
    eprintln!("{py} with NumPy read all four arrays with identical numbers, in np.save's own bytes");
}

#[test]
fn registry_files_lists_and_diffs() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let registry = d.join("units");
    std::fs::create_dir_all(registry.join("trusted")).unwrap();
    let key = keygen(d, "lead");
    std::fs::copy(d.join("lead.pub"), registry.join("trusted/lead.pub")).unwrap();
    let old = import(d, &key, "FSL-07", "old", 0.0, 1_780_306_200);
    // A month later the laser was knocked 0.3 deg.
    let new = import(d, &key, "FSL-07", "new", 0.3, 1_780_306_200 + 30 * 86_400);
    let reg = s(&registry);
    for f in [&old, &new] {
        let v = json(&fslcal(&["units", "--registry", reg, "add", s(f), "--json"]));
        assert_eq!(v["unit"], "FSL-07");
        assert_eq!(v["new"], true);
    }
    let again = json(&fslcal(&["units", "--registry", reg, "add", s(&new), "--json"]));
    assert_eq!(again["new"], false);
    // A file from a key the registry does not trust is refused, and nothing is filed.
    let other = tempfile::tempdir().unwrap();
    let stranger = keygen(other.path(), "stranger");
    let foreign = import(other.path(), &stranger, "FSL-01", "foreign", 0.0, 1_780_306_200);
    let err = one_line_error(&fslcal(&["units", "--registry", reg, "add", s(&foreign)]), "foreign.fslcal");
    assert!(err.contains("unknown key"), "{err}");
    assert!(!registry.join("FSL-01").exists());
    // A validation report of the new calibration.
    let report = d.join("validate.json");
    let sha = fslcal::units::registry::sha256_hex(&std::fs::read(&new).unwrap());
    std::fs::write(&report, format!(r#"{{"photos": [], "pass": true, "calibration_sha256": "{sha}"}}"#)).unwrap();
    let v = json(&fslcal(&["units", "--registry", reg, "add", s(&report), "--unit", "FSL-07", "--json"]));
    assert_eq!(v["pass"], true);

    let v = json(&fslcal(&["units", "--registry", reg, "list", "--json"]));
    let units = v["units"].as_array().unwrap();
    assert_eq!(units.len(), 1);
    let u = &units[0];
    assert_eq!(u["unit"], "FSL-07");
    assert_eq!(u["calibrations"], 2);
    assert_eq!(u["current"]["made_utc"], "2026-07-01T09:30:00Z");
    assert_eq!(u["current"]["status"], "valid");
    assert_eq!(u["last_validation"]["pass"], true);
    let text = fslcal(&["units", "--registry", reg, "list"]);
    let text = String::from_utf8_lossy(&text.stdout);
    assert!(text.contains("FSL-07") && text.contains("2026-07-01T09:30:00Z") && text.contains("pass"), "{text}");

    let v = json(&fslcal(&["units", "diff", s(&old), s(&new), "--json"]));
    let turned = v["direction_change_deg"].as_f64().unwrap();
    assert!((turned - 0.3).abs() < 0.01, "{turned}");
    assert_eq!(v["origin_change_mm"].as_f64(), Some(0.0));
    let errors = v["errors"].as_array().unwrap();
    let at: Vec<f64> = errors.iter().map(|e| e["distance_error_m"].as_f64().unwrap().abs()).collect();
    assert_eq!(errors.iter().map(|e| e["depth_m"].as_f64().unwrap()).collect::<Vec<_>>(), [1.0, 3.0, 5.0]);
    // Triangulation: a direction error's distance error grows about as depth squared.
    assert!(at[0] > 0.005 && at[2] > 10.0 * at[0], "{at:?}");
    assert!(errors[2]["length_error_pct"].as_f64().unwrap().abs() > 1.0);
}

#[test]
fn laser_signs_a_unit_file_and_takes_one_as_its_camera() {
    let set = common::laser_set("unit-file-cli", 6, 31, Water::Clear, 1);
    let d = set.path();
    let key = keygen(d, "diver");
    let target = "checkerboard:14x10@42.17mm";
    let photos: Vec<&str> = set.photos.iter().map(|p| s(p)).collect();
    let laser = |camera: &Path, extra: &[&str]| {
        let mut args = vec!["laser", "--camera", s(camera), "--target", target];
        args.extend_from_slice(extra);
        args.extend(photos.iter().copied());
        fslcal(&args)
    };
    // Without a key nothing is fitted or written.
    let first = d.join("FSL-05.fslcal");
    let err = one_line_error(&laser(&set.camera_file, &["--unit", "FSL-05", "--out", s(&first)]), "FSL-05.fslcal");
    assert!(err.contains("--key"), "{err}");
    assert!(!first.exists());

    let o = laser(
        &set.camera_file,
        &[
            "--unit",
            "FSL-05",
            "--key",
            s(&key),
            "--camera-serial",
            "BHV11",
            "--water-depth-m",
            "3.5",
            "--out",
            s(&first),
        ],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let size = std::fs::metadata(&first).unwrap().len();
    eprintln!("a real unit file from `fslcal laser`: {size} bytes");
    assert!(size <= 512);
    let ok = fslcal(&["verify", s(&first), "--trust", &format!("{}.pub", s(&key))]);
    assert!(ok.status.success(), "{}", String::from_utf8_lossy(&ok.stderr));
    let v = json(&fslcal(&["inspect", s(&first), "--json"]));
    assert_eq!(v["unit"], "FSL-05");
    assert_eq!(v["target"], target);
    assert_eq!(v["method"], "reprojection");
    assert_eq!(v["water_depth_m"].as_f64(), Some(3.5));
    assert!(v["fit"]["residual_rms_px"].as_f64().unwrap() < 1.0);
    let truth = set.truths[0].laser.unwrap();
    let origin = v["laser"]["origin_m"].as_array().unwrap();
    assert!((origin[0].as_f64().unwrap() - truth.origin_m[0]).abs() < 0.002);
    // The same fit through the shared --cal loader.
    let cal = fslcal::calibration::load(&first).unwrap();
    assert_eq!(cal.unit.as_deref(), Some("FSL-05"));
    assert_eq!(cal.camera_serial.as_deref(), Some("BHV11"));
    assert!(cal.distance_sigma_m(3.0).unwrap() > 0.0);

    // The unit file as the next calibration's camera: same unit only.
    let err = one_line_error(
        &laser(&first, &["--unit", "FSL-06", "--key", s(&key), "--out", s(&d.join("x.fslcal"))]),
        "FSL-05.fslcal",
    );
    assert!(err.contains("FSL-05's calibration, not FSL-06's"), "{err}");
    let second = d.join("FSL-05-b.fslcal");
    let o = laser(&first, &["--key", s(&key), "--out", s(&second)]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v2 = json(&fslcal(&["inspect", s(&second), "--json"]));
    assert_eq!(v2["unit"], "FSL-05");
    assert_eq!(v2["camera_identity"]["serial"], "BHV11");
    assert_eq!(v2["camera"], v["camera"]);
}
