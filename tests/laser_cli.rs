//! `fslcal laser` as a diver runs it: JSON keys, hand-given dots, gates that refuse, and
//! errors that are one line and leave no file behind.

mod common;

use calib_targets::scene::Water;
use common::{laser_set, SceneSet};
use std::process::{Command, Output};
use std::sync::OnceLock;

fn set() -> &'static SceneSet {
    static SET: OnceLock<SceneSet> = OnceLock::new();
    SET.get_or_init(|| laser_set("laser-cli", 6, 31, Water::Clear, 1))
}

fn fslcal(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_fslcal")).args(args).output().expect("run fslcal")
}

fn base_args(set: &SceneSet) -> Vec<String> {
    let mut a = vec![
        "laser".to_string(),
        "--camera".into(),
        set.camera_file.display().to_string(),
        "--target".into(),
        "checkerboard:14x10@42.17mm".into(),
    ];
    a.extend(set.photos.iter().map(|p| p.display().to_string()));
    a
}

fn stderr_line(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).lines().last().unwrap_or("").to_string()
}

#[test]
fn json_has_the_documented_keys_and_out_is_written() {
    let set = set();
    let out = set.path().join("fit.json");
    let mut args = base_args(set);
    args.extend(["--json".into(), "--out".into(), out.display().to_string()]);
    let o = fslcal(&args.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("stdout is one JSON object");
    let origin = v["laser"]["origin_m"].as_array().expect("laser.origin_m");
    assert_eq!(origin.len(), 3);
    assert_eq!(origin[2].as_f64(), Some(0.0));
    let d: Vec<f64> = v["laser"]["direction"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
    assert!((d.iter().map(|x| x * x).sum::<f64>() - 1.0).abs() < 1e-9 && d[2] > 0.0);
    let truth = set.truths[0].laser.unwrap();
    assert!((origin[0].as_f64().unwrap() - truth.origin_m[0]).abs() < 0.002);
    assert!(v["residual_rms_px"].as_f64().unwrap() < 1.0);
    for k in ["1", "3", "5"] {
        assert!(v["predicted_distance_sigma_m"][k].as_f64().unwrap() > 0.0, "sigma at {k} m");
    }
    let photos = v["photos"].as_array().unwrap();
    assert_eq!(photos.len(), 6);
    for p in photos {
        assert!(p["file"].is_string());
        match p["status"].as_str().unwrap() {
            "used" => {
                assert!(p["dot_px"].as_array().unwrap().len() == 2 && p["distance_m"].as_f64().unwrap() > 0.5);
                assert!(p["reason"].is_null());
            }
            "skipped" => assert!(p["reason"].is_string()),
            s => panic!("status {s}"),
        }
    }
    let written: serde_json::Value = serde_json::from_slice(&std::fs::read(&out).unwrap()).unwrap();
    assert_eq!(written["laser"], v["laser"]);
    // The written result is itself a calibration the measuring commands take as `--cal`.
    let cal = fslcal::calibration::load(&out).expect("--out is a usable --cal");
    assert_eq!(cal.camera.width_px, 4000);
    assert!((cal.laser.origin_m[0] - truth.origin_m[0]).abs() < 0.002);
    assert!(cal.distance_sigma_m(3.0).unwrap() > 0.0);
}

#[test]
fn hand_given_dots_override_detection() {
    let set = set();
    let t = set.truths[2].dot.as_ref().unwrap();
    let csv = set.path().join("dots.csv");
    let name = set.photos[3].file_name().unwrap().to_string_lossy().to_string();
    let t3 = set.truths[3].dot.as_ref().unwrap();
    std::fs::write(&csv, format!("file,x,y\n{name},{},{}\n", t3.pixel[0] + 0.5, t3.pixel[1])).unwrap();
    let mut args = base_args(set);
    let dot = format!("{}={},{}", set.photos[2].display(), t.pixel[0] + 1.0, t.pixel[1] - 1.0);
    args.extend(["--json".into(), "--dot".into(), dot, "--dots".into(), csv.display().to_string()]);
    let o = fslcal(&args.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let p2 = &v["photos"][2];
    assert_eq!(p2["dot_source"], "hand");
    assert!((p2["dot_px"][0].as_f64().unwrap() - (t.pixel[0] + 1.0)).abs() < 1e-9);
    assert_eq!(v["photos"][3]["dot_source"], "hand");
}

#[test]
fn a_failed_gate_exits_1_and_writes_nothing() {
    let set = set();
    let out = set.path().join("rejected.json");
    let mut args = base_args(set);
    let report = set.path().join("rejected-report");
    args.extend(["--baseline-range-mm".into(), "50,60".into(), "--out".into(), out.display().to_string()]);
    args.extend(["--report".into(), report.display().to_string()]);
    let o = fslcal(&args.iter().map(String::as_str).collect::<Vec<_>>());
    assert_eq!(o.status.code(), Some(1));
    let line = stderr_line(&o);
    assert!(line.contains("rejected") && line.contains("baseline"), "{line}");
    assert!(String::from_utf8_lossy(&o.stdout).contains("FAIL  camera-to-laser baseline"));
    assert!(!out.exists(), "a rejected calibration must not be written");
    // The report is written all the same: a rejection is when it is read.
    let html = std::fs::read_to_string(report.join("index.html")).expect("report of a rejected run");
    assert!(html.contains("REJECTED: camera-to-laser baseline 112."), "verdict names the failed gate");
    assert!(html.contains("<td class=\"bad\">FAIL</td>"));
    assert_eq!(html.matches("<img src=\"thumbs/").count(), 6);
}

#[test]
fn a_refused_fit_still_writes_its_report() {
    let set = set();
    let report = set.path().join("refused-report");
    let mut args = base_args(set);
    args.truncate(5 + 2);
    args.extend(["--report".into(), report.display().to_string()]);
    let o = fslcal(&args.iter().map(String::as_str).collect::<Vec<_>>());
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr_line(&o).contains("cannot fit the laser: only 2 photo(s)"), "{}", stderr_line(&o));
    let html = std::fs::read_to_string(report.join("index.html")).expect("report of a refused fit");
    assert!(html.contains("NOT FITTED: only 2 photo(s) with both a target and a dot"));
    assert_eq!(html.matches("<img src=\"thumbs/").count(), 2);
    assert_eq!(html.matches("<img src=\"plots/").count(), 0, "no fit, no plots of one");
}

#[test]
fn bad_inputs_give_one_line_errors() {
    let set = set();
    let bad_camera = set.path().join("bad.yml");
    std::fs::write(&bad_camera, "%YAML:1.0\n---\nimage_width: 4000\n").unwrap();
    let photo = set.photos[0].display().to_string();
    let cases: Vec<(Vec<String>, &str)> = vec![
        (
            vec!["laser", "--camera", &bad_camera.display().to_string(), "--target", "14x10@42.17mm", &photo]
                .into_iter()
                .map(String::from)
                .collect(),
            "missing `image_height`",
        ),
        (
            vec![
                "laser",
                "--camera",
                &set.camera_file.display().to_string(),
                "--target",
                "14x10@42.17mm",
                "/no/such.jpg",
            ]
            .into_iter()
            .map(String::from)
            .collect(),
            "/no/such.jpg: no such photo",
        ),
        (
            vec!["laser", "--camera", &set.camera_file.display().to_string(), "--target", "14x10", &photo]
                .into_iter()
                .map(String::from)
                .collect(),
            "expected checkerboard:COLSxROWS@SQUAREmm",
        ),
    ];
    for (args, expect) in cases {
        let o = fslcal(&args.iter().map(String::as_str).collect::<Vec<_>>());
        assert!(!o.status.success());
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains(expect), "expected `{expect}` in: {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
}

#[test]
fn duplicate_photos_are_used_once_and_do_not_shrink_the_sigma() {
    let set = set();
    let once = fslcal(
        &{
            let mut a = base_args(set);
            a.push("--json".into());
            a
        }
        .iter()
        .map(String::as_str)
        .collect::<Vec<_>>(),
    );
    assert!(once.status.success(), "{}", String::from_utf8_lossy(&once.stderr));
    // Each photo three times: as given, a copy, and a symlink to it.
    let dups = set.path().join("dups");
    let _ = std::fs::remove_dir_all(&dups);
    std::fs::create_dir_all(&dups).unwrap();
    let mut args = base_args(set);
    for (i, p) in set.photos.iter().enumerate() {
        let copy = dups.join(format!("copy_{i:02}.jpg"));
        std::fs::copy(p, &copy).unwrap();
        let link = dups.join(format!("link_{i:02}.jpg"));
        std::os::unix::fs::symlink(p, &link).unwrap();
        args.extend([copy.display().to_string(), link.display().to_string()]);
    }
    args.push("--json".into());
    let thrice = fslcal(&args.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(thrice.status.success(), "{}", String::from_utf8_lossy(&thrice.stderr));
    let err = String::from_utf8_lossy(&thrice.stderr);
    assert!(err.contains("copy_00.jpg is the same photo as") && err.contains("used once"), "{err}");
    assert!(err.contains("7 more photos repeat earlier ones; 6 distinct photos used of 18 given"), "{err}");
    let (a, b): (serde_json::Value, serde_json::Value) =
        (serde_json::from_slice(&once.stdout).unwrap(), serde_json::from_slice(&thrice.stdout).unwrap());
    assert_eq!(b["photos"].as_array().unwrap().len(), 6);
    // The same fit: the same covariance and predicted sigma, not a third of it.
    assert_eq!(a["laser"], b["laser"]);
    assert_eq!(a["predicted_distance_sigma_m"], b["predicted_distance_sigma_m"]);
}
