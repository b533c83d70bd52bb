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
