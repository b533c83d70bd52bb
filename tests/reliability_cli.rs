//! Nothing the user has is lost or overwritten, and every refusal says why (issue 16): the
//! command-line cases that need no rendered photos. Each test is named after what it
//! guards.

use fslcal::units::lab_pkg::{LaserPkg, LensPkg};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn fslcal(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_fslcal")).args(args).output().expect("run fslcal")
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// The one line a refused command prints, asserting it failed with one line containing
/// `expect` and no panic.
fn refused(o: &Output, expect: &str) -> String {
    assert_eq!(o.status.code(), Some(1), "expected a refusal; stdout: {}", String::from_utf8_lossy(&o.stdout));
    let err = stderr(o).trim_end().to_string();
    assert_eq!(err.lines().count(), 1, "one line: {err}");
    assert!(err.contains(expect), "expected `{expect}` in: {err}");
    assert!(!err.contains("panicked"), "{err}");
    err
}

fn keygen(dir: &Path, name: &str) -> PathBuf {
    let key = dir.join(name);
    let o = fslcal(&["keygen", "--out", s(&key)]);
    assert!(o.status.success(), "{}", stderr(&o));
    key
}

/// The lab's lens and laser .pkg files for a TG-6 at 4000x3000.
fn lab_pkgs(dir: &Path, tag: &str, tilt_deg: f64, date_s: i64) -> (PathBuf, PathBuf) {
    let lens = LensPkg {
        camera_matrix: [2911.75, 0.0, 2003.125, 0.0, 2912.5, 1501.0625, 0.0, 0.0, 1.0],
        distortion: vec![-0.1175, 0.0512, 0.00091, -0.00042, -0.0139],
        calibrated_utc_s: date_s,
    };
    let d = [0.0098, 0.0199 + tilt_deg.to_radians(), 1.0];
    let n = d.iter().map(|v| v * v).sum::<f64>().sqrt();
    let laser = LaserPkg { position_m: [-0.0412, -0.1067, 0.0], axis: d.map(|v| v / n), calibrated_utc_s: date_s };
    let (a, b) = (dir.join(format!("{tag}-lens.pkg")), dir.join(format!("{tag}-laser.pkg")));
    std::fs::write(&a, lens.write().unwrap()).unwrap();
    std::fs::write(&b, laser.write().unwrap()).unwrap();
    (a, b)
}

fn import_args<'a>(lens: &'a Path, laser: &'a Path, key: &'a Path, out: &'a Path) -> Vec<&'a str> {
    vec!["import", s(lens), s(laser), "--unit", "FSL-03", "--key", s(key), "--out", s(out)]
}

#[test]
fn outputs_that_are_inputs_are_refused_and_the_inputs_kept() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let photos: Vec<PathBuf> = (0..2).map(|i| d.join(format!("photo_{i:02}.jpg"))).collect();
    for p in &photos {
        std::fs::write(p, b"\xff\xd8 a photo").unwrap();
    }
    let camera = d.join("camera.yml");
    std::fs::write(&camera, "%YAML:1.0\n").unwrap();
    let link = d.join("link.jpg");
    std::os::unix::fs::symlink(&photos[1], &link).unwrap();
    let labels = d.join("labels.csv");
    std::fs::write(&labels, "photo,head_x,head_y,tail_x,tail_y\n").unwrap();
    let key = keygen(d, "lead");
    let (lens, laser) = lab_pkgs(d, "lab", 0.0, 1_780_306_200);
    let board = "checkerboard:14x10@42.17mm";
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (
            vec![
                "laser",
                "--camera",
                s(&camera),
                "--target",
                board,
                "--out",
                s(&photos[0]),
                s(&photos[0]),
                s(&photos[1]),
            ],
            "(photo ",
        ),
        (vec!["laser", "--camera", s(&camera), "--target", board, "--out", s(&camera), s(&photos[0])], "(--camera "),
        (vec!["laser", "--camera", s(&camera), "--target", board, "--out", s(&link), s(&photos[1])], "(photo "),
        (vec!["camera", "--board", "14x10@42.17mm", "--out", s(&photos[0]), s(&photos[0]), s(&photos[1])], "(photo "),
        (
            vec!["measure", "--cal", s(&camera), "--labels", s(&labels), "--out", s(&labels), s(&photos[0])],
            "(--labels ",
        ),
        (import_args(&lens, &laser, &key, &lens), "(LENS.pkg "),
        (import_args(&lens, &laser, &key, &key), "(--key "),
    ];
    let before: Vec<Vec<u8>> =
        [&photos[0], &photos[1], &camera, &labels, &lens, &key].iter().map(|p| std::fs::read(p).unwrap()).collect();
    for (args, what) in cases {
        let err = refused(&fslcal(&args), "would overwrite an input of this run");
        assert!(err.contains(what), "{err}");
    }
    let after: Vec<Vec<u8>> =
        [&photos[0], &photos[1], &camera, &labels, &lens, &key].iter().map(|p| std::fs::read(p).unwrap()).collect();
    assert!(before == after, "an input was changed");
    // Two outputs naming one file, and a report folder that is the photos' folder.
    let out = d.join("lengths.csv");
    let same = format!("{}/./lengths.csv", d.display());
    refused(
        &fslcal(&[
            "measure",
            "--cal",
            s(&camera),
            "--labels",
            s(&labels),
            "--out",
            s(&out),
            "--summary-out",
            &same,
            s(&photos[0]),
        ]),
        "--out and --summary-out name the same file",
    );
    refused(
        &fslcal(&["check", "--cal", s(&camera), "--report", s(d), s(&photos[0])]),
        "--report is a folder that is not an fslcal report",
    );
    assert!(photos.iter().all(|p| p.is_file()));
}

#[test]
fn an_existing_signed_file_is_replaced_only_with_force_and_said() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let key = keygen(d, "lead");
    let (lens, laser) = lab_pkgs(d, "a", 0.0, 1_780_306_200);
    let out = d.join("FSL-03.fslcal");
    let o = fslcal(&import_args(&lens, &laser, &key, &out));
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stderr(&o).contains("replacing"), "nothing was there: {}", stderr(&o));
    let first = std::fs::read(&out).unwrap();
    let (lens2, laser2) = lab_pkgs(d, "b", 0.2, 1_780_306_200);
    refused(&fslcal(&import_args(&lens2, &laser2, &key, &out)), "a signed unit file is already there; give --force");
    assert_eq!(std::fs::read(&out).unwrap(), first, "the signed file is untouched");
    let mut forced = import_args(&lens2, &laser2, &key, &out);
    forced.push("--force");
    let o = fslcal(&forced);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains(&format!("note: replacing {}", out.display())), "{}", stderr(&o));
    assert_ne!(std::fs::read(&out).unwrap(), first);
}

fn json(o: &Output) -> serde_json::Value {
    assert!(o.status.success(), "{}", stderr(o));
    serde_json::from_slice(&o.stdout).expect("stdout is one JSON object")
}

/// A registry folder trusting a fresh key, and the key.
fn registry(d: &Path) -> (PathBuf, PathBuf) {
    let key = keygen(d, "lead");
    let reg = d.join("units");
    let o = fslcal(&["units", "--registry", s(&reg), "trust", s(&d.join("lead.pub"))]);
    assert!(o.status.success(), "{}", stderr(&o));
    (reg, key)
}

fn import(d: &Path, key: &Path, tag: &str, tilt_deg: f64, date_s: i64) -> PathBuf {
    let (lens, laser) = lab_pkgs(d, tag, tilt_deg, date_s);
    let out = d.join(format!("{tag}.fslcal"));
    let o = fslcal(&["import", s(&lens), s(&laser), "--unit", "FSL-07", "--key", s(key), "--out", s(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));
    out
}

fn report(d: &Path, name: &str, cal: Option<&Path>, pass: bool, validated: &str) -> PathBuf {
    let mut v = serde_json::json!({"schema_version": 1, "unit": "FSL-07", "photos": [], "pass": pass, "validated_utc": validated});
    if let Some(cal) = cal {
        v["calibration_sha256"] = fslcal::units::registry::sha256_hex(&std::fs::read(cal).unwrap()).into();
    }
    let p = d.join(name);
    std::fs::write(&p, serde_json::to_vec(&v).unwrap()).unwrap();
    p
}

#[test]
fn a_validation_is_filed_and_shown_only_beside_the_calibration_it_validated() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (reg, key) = registry(d);
    let add = |f: &Path, extra: &[&str]| {
        let mut a = vec!["units", "--registry", s(&reg), "add", s(f)];
        a.extend_from_slice(extra);
        fslcal(&a)
    };
    let june = import(d, &key, "june", 0.0, 1_780_306_200);
    // FSL-07 has no calibration yet: a pass for it would be a pass of nothing.
    let early = report(d, "early.json", Some(&june), true, "2026-06-02T10:00:00Z");
    refused(&add(&early, &["--unit", "FSL-07"]), "is not filed under FSL-07; file that calibration first");
    assert!(!reg.join("FSL-07").exists());
    assert!(add(&june, &[]).status.success());
    let v = json(&add(&early, &["--json"]));
    assert_eq!((v["pass"].as_bool(), v["new"].as_bool()), (Some(true), Some(true)));
    refused(
        &add(&report(d, "bare.json", None, true, "2026-06-02T11:00:00Z"), &[]),
        "does not name the calibration it validated",
    );
    refused(&add(&early, &["--unit", "FSL-03"]), "the report is of FSL-07's calibration, not FSL-03's");
    let list = |reg: &Path| json(&fslcal(&["units", "--registry", s(reg), "list", "--json"]))["units"][0].clone();
    let u = list(&reg);
    assert_eq!(u["last_validation"]["pass"], true);
    assert_eq!(u["last_validation"]["validated_utc"], "2026-06-02T10:00:00Z");
    // A calibration made after it: the June pass says nothing about it.
    let july = import(d, &key, "july", 0.3, 1_780_306_200 + 30 * 86_400);
    assert!(add(&july, &[]).status.success());
    let u = list(&reg);
    assert_eq!(u["current"]["made_utc"], "2026-07-01T09:30:00Z");
    assert!(u["last_validation"].is_null(), "{u}");
    let text = String::from_utf8_lossy(&fslcal(&["units", "--registry", s(&reg), "list"]).stdout).into_owned();
    assert!(!text.contains("pass"), "{text}");
}

#[test]
fn reports_filed_in_one_second_are_ordered_by_when_they_ran() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (reg, key) = registry(d);
    let cal = import(d, &key, "cal", 0.0, 1_780_306_200);
    assert!(fslcal(&["units", "--registry", s(&reg), "add", s(&cal)]).status.success());
    // The later validation passes; it is filed first, the older FAIL after it.
    let pass = report(d, "pass.json", Some(&cal), true, "2026-06-02T10:00:01Z");
    let fail = report(d, "fail.json", Some(&cal), false, "2026-06-02T10:00:00Z");
    for r in [&pass, &fail] {
        assert!(fslcal(&["units", "--registry", s(&reg), "add", s(r)]).status.success());
    }
    let v = json(&fslcal(&["units", "--registry", s(&reg), "list", "--json"]));
    assert_eq!(v["units"][0]["last_validation"]["pass"], true, "{v}");
    // Filing the same report again is recognised, not filed twice.
    let again = json(&fslcal(&["units", "--registry", s(&reg), "add", s(&pass), "--json"]));
    assert_eq!(again["new"], false);
    let reports = std::fs::read_dir(reg.join("FSL-07"))
        .unwrap()
        .filter(|e| e.as_ref().unwrap().file_name().to_string_lossy().starts_with("validation-"))
        .count();
    assert_eq!(reports, 2);
}

#[test]
fn a_corrected_reimport_is_filed_beside_the_old_one() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (reg, key) = registry(d);
    // The lab's same files, the laser axis corrected: same date, same signer.
    let first = import(d, &key, "first", 0.0, 1_780_306_200);
    let corrected = import(d, &key, "corrected", 0.05, 1_780_306_200);
    let mut filed = Vec::new();
    for f in [&first, &corrected] {
        let v = json(&fslcal(&["units", "--registry", s(&reg), "add", s(f), "--json"]));
        assert_eq!(v["new"], true, "{v}");
        filed.push(v["calibration"].as_str().unwrap().to_string());
    }
    assert_ne!(filed[0], filed[1]);
    let u = json(&fslcal(&["units", "--registry", s(&reg), "list", "--json"]))["units"][0].clone();
    assert_eq!(u["calibrations"], 2);
    assert_eq!(u["current"]["file"].as_str(), Some(filed[1].as_str()), "the one filed last is current");
    for (f, there) in [(&first, &filed[0]), (&corrected, &filed[1])] {
        assert_eq!(std::fs::read(f).unwrap(), std::fs::read(there).unwrap());
    }
}

#[test]
fn units_add_on_a_fresh_folder_says_what_to_do() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let key = keygen(d, "lead");
    let cal = import(d, &key, "cal", 0.0, 1_780_306_200);
    let reg = d.join("units");
    let err = refused(&fslcal(&["units", "--registry", s(&reg), "add", s(&cal)]), "units/trusted: no such folder");
    assert!(err.contains("`fslcal units trust KEY.pub`"), "{err}");
    let v = json(&fslcal(&["units", "--registry", s(&reg), "trust", s(&d.join("lead.pub")), "--json"]));
    assert_eq!(v["new"], true);
    let again = json(&fslcal(&["units", "--registry", s(&reg), "trust", s(&d.join("lead.pub")), "--json"]));
    assert_eq!(again["new"], false);
    assert!(fslcal(&["units", "--registry", s(&reg), "add", s(&cal)]).status.success());
}

#[test]
fn an_edited_key_id_in_a_pub_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let key = keygen(d, "lead");
    let cal = import(d, &key, "cal", 0.0, 1_780_306_200);
    let public = std::fs::read_to_string(d.join("lead.pub")).unwrap();
    let words: Vec<&str> = public.split_whitespace().collect();
    let edited = d.join("edited.pub");
    std::fs::write(&edited, format!("{} {} 0123456789abcdef coordinator\n", words[0], words[1])).unwrap();
    let err = refused(
        &fslcal(&["verify", s(&cal), "--trust", s(&edited)]),
        "edited.pub: the key id written in it (0123456789abcdef) is not its key's",
    );
    assert!(err.contains(words[2]), "{err}");
    assert!(fslcal(&["verify", s(&cal), "--trust", s(&d.join("lead.pub"))]).status.success());
}

#[test]
fn a_secret_key_readable_by_others_is_warned_about() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let key = keygen(d, "lead");
    let (lens, laser) = lab_pkgs(d, "a", 0.0, 1_780_306_200);
    let o = fslcal(&import_args(&lens, &laser, &key, &d.join("a.fslcal")));
    assert!(o.status.success() && !stderr(&o).contains("warning"), "{}", stderr(&o));
    std::fs::set_permissions(&key, std::fs::Permissions::from_mode(0o644)).unwrap();
    let o = fslcal(&import_args(&lens, &laser, &key, &d.join("b.fslcal")));
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(err.contains("the secret key is readable by others (mode 0644)") && err.contains("chmod 600"), "{err}");
}

#[test]
fn keygen_creates_a_missing_folder_owner_only() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    let home = dir.path().join(".fslcal");
    let o = fslcal(&["keygen", "--out", s(&home.join("lead"))]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(std::fs::metadata(&home).unwrap().permissions().mode() & 0o777, 0o700);
    assert!(home.join("lead.pub").is_file());
}

#[test]
fn inspect_of_a_tampered_file_shows_it_and_exits_1() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let key = keygen(d, "lead");
    let cal = import(d, &key, "cal", 0.0, 1_780_306_200);
    let mut bytes = std::fs::read(&cal).unwrap();
    bytes[60] ^= 0x04;
    std::fs::write(&cal, &bytes).unwrap();
    let o = fslcal(&["inspect", s(&cal)]);
    assert_eq!(o.status.code(), Some(1));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("unit FSL-07") && out.contains("signature INVALID"), "{out}");
    assert!(stderr(&o).contains("cal.fslcal: tampered"), "{}", stderr(&o));
}

/// `fslcal inspect --json FILE` into a pipe whose reader has already left: fslcal
/// ends as a Unix filter does (SIGPIPE), not with a panic and a backtrace.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
#[test]
#[allow(unsafe_code)]
fn a_reader_that_left_ends_fslcal_quietly() {
    use std::os::fd::{FromRawFd, OwnedFd};
    use std::os::unix::process::ExitStatusExt;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let key = keygen(d, "lead");
    let cal = import(d, &key, "cal", 0.0, 1_780_306_200);
    let mut fds = [0; 2];
    // SAFETY: `pipe` fills both descriptors, each then owned by one OwnedFd.
    let (read, write) = unsafe {
        assert_eq!(libc::pipe(fds.as_mut_ptr()), 0);
        (OwnedFd::from_raw_fd(fds[0]), OwnedFd::from_raw_fd(fds[1]))
    };
    // The reader leaves before fslcal starts: its first write meets a closed pipe.
    drop(read);
    let o = Command::new(env!("CARGO_BIN_EXE_fslcal"))
        .args(["inspect", "--json", s(&cal)])
        .stdout(std::process::Stdio::from(write))
        .output()
        .expect("run fslcal");
    let err = stderr(&o);
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(o.status.signal(), Some(libc::SIGPIPE), "ended by SIGPIPE: {:?} {err}", o.status);
}

/// A small camera, a calibration of it (JSON), and photos of nothing: grey JPEGs of its
/// size, plus one file that is not a photo at all.
struct Blank {
    _dir: tempfile::TempDir,
    camera_file: PathBuf,
    cal: PathBuf,
    photos: Vec<PathBuf>,
}

fn blank_photos() -> Blank {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let camera = fslcal_core::CameraModel {
        width_px: 800,
        height_px: 600,
        fx_px: 580.0,
        fy_px: 580.0,
        cx_px: 400.0,
        cy_px: 300.0,
        distortion: fslcal_core::Distortion::from_opencv([0.0; 5]),
    };
    let camera_file = d.join("camera.yml");
    std::fs::write(&camera_file, calib_targets::camera_yaml(&camera)).unwrap();
    let cal = d.join("cal.json");
    let doc = serde_json::json!({
        "camera": fslcal::calibration::camera_json(&camera),
        "laser": {"origin_m": [-0.04, -0.105, 0.0], "direction": [0.0105, 0.022, 0.9997],
                  "covariance": [[1e-8, 0.0, 0.0, 0.0], [0.0, 1e-8, 0.0, 0.0], [0.0, 0.0, 1e-9, 0.0], [0.0, 0.0, 0.0, 1e-9]]},
    });
    std::fs::write(&cal, serde_json::to_vec(&doc).unwrap()).unwrap();
    let mut photos = Vec::new();
    for (i, level) in [90u8, 140, 200].into_iter().enumerate() {
        let p = d.join(format!("grey_{i}.jpg"));
        image::RgbImage::from_pixel(800, 600, image::Rgb([level, level, level])).save(&p).unwrap();
        photos.push(p);
    }
    let junk = d.join("junk.jpg");
    std::fs::write(&junk, b"not a photo at all").unwrap();
    photos.push(junk);
    Blank { _dir: dir, camera_file, cal, photos }
}

/// Every photo of `b` has its line in `photos` (JSON), each with a reason.
fn every_photo_has_a_reason(v: &serde_json::Value, b: &Blank) {
    let photos = v["photos"].as_array().unwrap_or_else(|| panic!("no photos in {v}"));
    assert_eq!(photos.len(), b.photos.len(), "{v}");
    for (p, want) in photos.iter().zip(&b.photos) {
        assert_eq!(p["file"].as_str(), Some(s(want)));
        assert!(p["reason"].as_str().is_some_and(|r| !r.is_empty()), "{p}");
    }
    assert!(
        photos[3]["reason"].as_str().unwrap().contains("unreadable")
            || photos[3]["reason"].as_str().unwrap().contains("not a readable image"),
        "{}",
        photos[3]
    );
}

/// The text run lists every photo by name with a reason, then the verdict, and the report
/// has every photo.
fn text_and_report_say_why(o: &Output, report: &Path, b: &Blank, verdict: &str) {
    assert_eq!(o.status.code(), Some(1));
    let text = format!("{}{}", String::from_utf8_lossy(&o.stdout), stderr(o));
    for p in &b.photos {
        let name = p.file_name().unwrap().to_str().unwrap();
        let line = text.lines().find(|l| l.contains(name)).unwrap_or_else(|| panic!("{name} not listed: {text}"));
        assert!(line.contains("skipped") || line.contains("unreadable") || line.contains("no "), "{line}");
    }
    assert!(text.contains(verdict), "{text}");
    let html = std::fs::read_to_string(report.join("index.html")).expect("the report is written");
    for p in &b.photos {
        assert!(html.contains(p.file_name().unwrap().to_str().unwrap()), "report lacks {}", p.display());
    }
}

#[test]
fn check_with_no_usable_photo_says_why_per_photo_in_text_json_and_report() {
    let b = blank_photos();
    let report = b._dir.path().join("check-report");
    let mut args = vec!["check", "--cal", s(&b.cal), "--report", s(&report)];
    args.extend(b.photos.iter().map(|p| s(p)));
    let o = fslcal(&args);
    text_and_report_say_why(&o, &report, &b, "verdict: NOT JUDGED");
    assert!(std::fs::read_to_string(report.join("index.html")).unwrap().contains("NOT JUDGED"));
    args.push("--json");
    let o = fslcal(&args);
    assert_eq!(o.status.code(), Some(1));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("one JSON object even when nothing is judged");
    assert!(v["error"].as_str().unwrap().contains("no photo has a laser dot"), "{v}");
    every_photo_has_a_reason(&v, &b);
}

#[test]
fn validate_with_nothing_measured_says_why_per_photo_in_text_json_and_report() {
    let b = blank_photos();
    let report = b._dir.path().join("validate-report");
    let mut args = vec!["validate", "--cal", s(&b.cal), "--target", "checkerboard:9x6@25mm", "--report", s(&report)];
    args.extend(b.photos.iter().map(|p| s(p)));
    let o = fslcal(&args);
    text_and_report_say_why(&o, &report, &b, "verdict: NOT JUDGED");
    assert!(std::fs::read_to_string(report.join("index.html")).unwrap().contains("NOT JUDGED"));
    args.push("--json");
    let o = fslcal(&args);
    let v: serde_json::Value =
        serde_json::from_slice(&o.stdout).expect("one JSON object even when nothing is measured");
    assert!(v["error"].as_str().unwrap().contains("no photo could be measured"), "{v}");
    every_photo_has_a_reason(&v, &b);
}

#[test]
fn laser_json_that_cannot_fit_lists_every_photo_with_its_reason() {
    let b = blank_photos();
    let mut args = vec!["laser", "--camera", s(&b.camera_file), "--target", "checkerboard:9x6@25mm", "--json"];
    args.extend(b.photos.iter().map(|p| s(p)));
    let o = fslcal(&args);
    assert_eq!(o.status.code(), Some(1));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("one JSON object when the fit is refused");
    assert!(v["error"].as_str().unwrap().starts_with("cannot fit the laser: "), "{v}");
    every_photo_has_a_reason(&v, &b);
    assert!(v["photos"][0]["reason"].as_str().unwrap().contains("no 9x6 checkerboard found"), "{v}");
}

#[test]
fn an_unknown_covariance_reads_unknown_and_never_shrinks_a_length_sigma() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let key = keygen(d, "lead");
    let (lens, laser) = lab_pkgs(d, "lab", 0.0, 1_780_306_200);
    let cal = d.join("imported.fslcal");
    assert!(fslcal(&import_args(&lens, &laser, &key, &cal)).status.success());
    let c = fslcal::calibration::load(&cal).unwrap();
    assert_eq!(c.distance_sigma_m(2.0), None, "no sigma from an all-zero covariance");
    let dot = c.laser.pixel_at_depth(&c.camera, 2.0).unwrap();
    let photo = d.join("fish.jpg");
    image::RgbImage::from_pixel(4000, 3000, image::Rgb([40, 80, 90])).save(&photo).unwrap();
    let dot_arg = format!("{},{}", dot.x, dot.y);
    let args =
        ["measure", "--cal", s(&cal), s(&photo), "--head", "1500,1400", "--tail", "2100,1420", "--dot", &dot_arg];
    let o = fslcal(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("± unknown (1-sigma)") && text.contains("calibration unknown"), "{text}");
    assert!(text.contains("covariance is unknown"), "{text}");
    let mut json_args = args.to_vec();
    json_args.push("--json");
    let v = json(&fslcal(&json_args));
    let l = &v;
    assert!(l["length_m"].as_f64().unwrap() > 0.1, "{v}");
    assert!(l["length_sigma_m"].is_null() && l["distance_sigma_m"].is_null(), "{v}");
    assert!(l["distance_sigma_calibration_m"].is_null() && l["distance_sigma_dot_m"].as_f64().unwrap() > 0.0, "{v}");
    // inspect: "unknown", and JSON null, never zeros.
    let text = String::from_utf8_lossy(&fslcal(&["inspect", s(&cal)]).stdout).into_owned();
    assert!(text.contains("mm ± unknown, direction") && text.contains("covariance unknown"), "{text}");
    assert!(json(&fslcal(&["inspect", s(&cal), "--json"]))["laser"]["covariance"].is_null());
}

/// A value refused when the command line is parsed: clap's exit status 2, the cause in the
/// message, and no number printed as hundreds of digits.
fn refused_at_parse(args: &[&str], expect: &str) {
    let o = fslcal(args);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
    assert!(err.contains(expect), "{args:?}: expected `{expect}` in: {err}");
    assert!(err.len() < 600 && !err.contains("panicked"), "{err}");
}

#[test]
fn options_are_refused_at_parse_time_with_their_true_cause() {
    let laser = |opt: &str, value: &str| {
        let mut a = vec!["laser", "--camera", "c.yml", "x.jpg"];
        if opt != "--target" {
            a.extend(["--target", "checkerboard:14x10@42.17mm"]);
        }
        a.extend([opt, value]);
        a.into_iter().map(String::from).collect::<Vec<_>>()
    };
    let cases: Vec<(Vec<String>, &str)> = vec![
        (vec!["camera".into(), "--board".into(), "2x2@40mm".into(), "x.jpg".into()], "3x3 inner corners or more"),
        (
            laser("--target", "checkerboard:14x10@42.17cm"),
            "the square size is in cm; fslcal takes mm or m: write `421.7mm`",
        ),
        (laser("--target", "checkerboard:14x10@1e308mm"), "a 1.000e308 mm square is not plausible"),
        (laser("--max-dot-offset-px", "0"), "expected a number of pixels above 0"),
        (laser("--max-dot-offset-px", "-3"), "expected a number of pixels above 0"),
        (laser("--max-dot-offset-px", "NaN"), "not a finite number"),
        (laser("--water-depth-m", "-5"), "metres below the surface, 0 or more"),
        (laser("--water-depth-m", "inf"), "not a finite number"),
        (laser("--baseline-range-mm", "78,inf"), "not a finite number"),
        (
            vec![
                "import".into(),
                "a".into(),
                "b".into(),
                "--out".into(),
                "o.fslcal".into(),
                "--water-depth-m".into(),
                "NaN".into(),
            ],
            "not a finite number",
        ),
        (
            vec![
                "import".into(),
                "a".into(),
                "b".into(),
                "--out".into(),
                "o.fslcal".into(),
                "--image-size".into(),
                "99999999x99999999".into(),
            ],
            "each side must be 1 to 30000 pixels",
        ),
        (
            vec![
                "validate".into(),
                "--cal".into(),
                "c".into(),
                "--target".into(),
                "9x6@25mm".into(),
                "--tolerance".into(),
                "1e308".into(),
                "x.jpg".into(),
            ],
            "expected a percentage between 0 and 100",
        ),
        (
            vec!["develop".into(), "--out".into(), "d".into(), "--jobs".into(), "99999".into(), "x.orf".into()],
            "from 1 to 64",
        ),
    ];
    for (args, expect) in cases {
        refused_at_parse(&args.iter().map(String::as_str).collect::<Vec<_>>(), expect);
    }
}

#[test]
fn a_zero_length_fish_a_stray_dot_and_conflicting_dot_rows_are_refused() {
    let b = blank_photos();
    let d = b._dir.path();
    refused(
        &fslcal(&["measure", "--cal", s(&b.cal), s(&b.photos[0]), "--head", "100,200", "--tail", "100,200"]),
        "--head 100,200 and --tail 100,200 are the same point",
    );
    let laser = |extra: &[&str]| {
        let mut a = vec!["laser", "--camera", s(&b.camera_file), "--target", "checkerboard:9x6@25mm"];
        a.extend_from_slice(extra);
        a.extend(b.photos[..3].iter().map(|p| s(p)));
        fslcal(&a)
    };
    refused(&laser(&["--dot", "grey_9.jpg=10,20"]), "grey_9.jpg is not one of this run's photos");
    refused(&laser(&["--dot", "grey_0.jpg=10,20", "--dot", "grey_0.jpg=11,20"]), "a second --dot for grey_0.jpg");
    let csv = d.join("dots.csv");
    std::fs::write(&csv, "file,x,y\ngrey_0.jpg,10,20\ngrey_1.jpg,30,40\ngrey_0.jpg,12,20\n").unwrap();
    refused(
        &laser(&["--dots", s(&csv)]),
        "dots.csv: line 4: a second, different dot for grey_0.jpg (line 2 gives another)",
    );
}

#[test]
fn a_tiff_a_fake_orf_a_folder_and_a_file_as_masks_get_true_messages() {
    let b = blank_photos();
    let d = b._dir.path();
    let tiff = d.join("scan.tif");
    std::fs::write(&tiff, b"II*\0\x08\0\0\0 a little-endian TIFF").unwrap();
    let orf = d.join("P1010001.ORF");
    std::fs::write(&orf, vec![0x5a; 4096]).unwrap();
    let mut args = vec!["check", "--cal", s(&b.cal), "--json", s(&b.photos[0]), s(&tiff), s(&orf)];
    let v: serde_json::Value = serde_json::from_slice(&fslcal(&args).stdout).unwrap();
    let reason = |i: usize| v["photos"][i]["reason"].as_str().unwrap().to_string();
    assert!(
        reason(1).contains("a TIFF image, which fslcal does not read; it reads JPEG, PNG and Olympus ORF raw"),
        "{v}"
    );
    assert!(reason(2).contains("not an Olympus ORF raw file (no ORF header)"), "{v}");
    assert!(!reason(2).contains("JPEG/PNG"), "{v}");
    args.push(s(d));
    refused(&fslcal(&args), "a folder, not a photo; give the photos in it");
    refused(
        &fslcal(&["measure", "--cal", s(&b.cal), "--masks", s(&b.photos[0]), s(&b.photos[1])]),
        "a file, not a folder of masks",
    );
    for command in ["camera", "measure", "laser"] {
        let help = String::from_utf8_lossy(&fslcal(&[command, "--help"]).stdout).into_owned();
        assert!(help.contains("Olympus ORF raw"), "{command} --help: {help}");
        assert!(!help.contains("TIFF"), "{command} --help names TIFF: {help}");
    }
}

#[test]
fn a_non_utf8_file_name_keeps_its_thumbnail() {
    use std::os::unix::ffi::OsStrExt;
    let b = blank_photos();
    let d = b._dir.path();
    let odd = d.join(std::ffi::OsStr::from_bytes(b"dive\xff3.jpg"));
    std::fs::copy(&b.photos[0], &odd).unwrap();
    let report = d.join("report");
    let o = Command::new(env!("CARGO_BIN_EXE_fslcal"))
        .args(["check", "--cal", s(&b.cal), "--report", s(&report), s(&b.photos[1])])
        .arg(&odd)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1), "no dot in a grey photo: {}", stderr(&o));
    let html = std::fs::read_to_string(report.join("index.html")).unwrap();
    assert_eq!(html.matches("<img src=\"thumbs/").count(), 2, "both photos have their thumbnail: {html}");
    assert!(!html.contains("no thumbnail"), "{html}");
}

#[test]
fn a_missing_file_says_its_cause_once() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("x.jpg"), b"\xff\xd8").unwrap();
    let cases: Vec<Vec<String>> = vec![
        vec!["develop".into(), "--out".into(), s(&d.join("png")).into(), s(&d.join("nope.orf")).into()],
        vec![
            "laser".into(),
            "--camera".into(),
            s(&d.join("nope.yml")).into(),
            "--target".into(),
            "9x6@25mm".into(),
            s(&d.join("x.jpg")).into(),
        ],
        vec!["inspect".into(), s(&d.join("nope.fslcal")).into()],
    ];
    for args in cases {
        let o = fslcal(&args.iter().map(String::as_str).collect::<Vec<_>>());
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{err}");
        assert_eq!(err.matches("No such file or directory").count(), 1, "{args:?}: {err}");
    }
}
