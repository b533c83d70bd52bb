//! `fslcal camera` as a diver runs it, on OpenCV's sample photos: JSON keys, a camera file
//! that OpenCV itself and `fslcal laser` read, and one-line errors that leave no file.

use fslcal::camera::opencv_yaml;
use opencv::core::{FileStorage, FileStorage_Mode, Mat};
use opencv::prelude::*;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn fslcal(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_fslcal")).args(args).output().expect("run fslcal")
}

fn samples() -> Vec<String> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/opencv-samples");
    let mut p: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "jpg"))
        .map(|p| p.display().to_string())
        .collect();
    p.sort();
    p
}

fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("camera-cli").join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn camera_cmd<'a>(board: &'a str, out: &'a str, photos: &'a [String]) -> Vec<&'a str> {
    let mut a = vec!["camera", "--board", board, "--out", out];
    a.extend(photos.iter().map(String::as_str));
    a
}

#[test]
fn json_keys_and_a_camera_file_opencv_and_laser_read() {
    let dir = scratch("good");
    let out = dir.join("camera.yml");
    let photos = samples();
    let mut args = camera_cmd("9x6@25mm", out.to_str().unwrap(), &photos);
    args.push("--json");
    let o = fslcal(&args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("stdout is one JSON object");
    let cam = &v["camera"];
    assert_eq!(cam["image_size"], serde_json::json!([640, 480]));
    let f = |x: &serde_json::Value| x.as_f64().unwrap();
    let (fx, fy, cx, cy) = (f(&cam["fx"]), f(&cam["fy"]), f(&cam["cx"]), f(&cam["cy"]));
    let dist: Vec<f64> = cam["dist"].as_array().unwrap().iter().map(f).collect();
    assert_eq!(dist.len(), 5);
    assert!((fx - 532.8).abs() < 1.5);
    assert!(f(&v["rms_px"]) < 0.25 && f(&v["worst_px"]) >= f(&v["rms_px"]));
    for k in ["fx", "fy", "cx", "cy", "k1", "k2", "k3", "p1", "p2"] {
        let s = f(&v["sigma"][k]);
        assert!(s > 0.0 && s.is_finite(), "sigma.{k}");
    }
    assert!(f(&v["sigma"]["fx"]) < 1.0);
    assert!(v["sigma_convention"].as_str().unwrap().contains("1-sigma"));
    assert_eq!(v["outliers"]["photos"], "0 of 13");
    assert!(v["outliers"]["corners"].as_str().unwrap().ends_with("of 702"));
    let share = f(&v["coverage"]["share"]);
    assert!(share > 0.2 && share < 1.0);
    assert!(v["coverage"]["uncovered_frame_corners"].is_array());
    let list = v["photos"].as_array().unwrap();
    assert_eq!(list.len(), 13);
    for p in list {
        assert!(p["file"].as_str().unwrap().ends_with(".jpg"));
        assert_eq!(p["status"], "used");
        assert!(f(&p["rms_px"]) < 0.3);
    }

    // OpenCV's own FileStorage reads what was written, to the last digit.
    let fs = FileStorage::new(out.to_str().unwrap(), FileStorage_Mode::READ as i32, "").unwrap();
    assert!(fs.is_opened().unwrap());
    assert_eq!(fs.get("image_width").unwrap().to_i32().unwrap(), 640);
    assert_eq!(fs.get("image_height").unwrap().to_i32().unwrap(), 480);
    let k: Mat = fs.get("camera_matrix").unwrap().mat().unwrap();
    let d: Mat = fs.get("distortion_coefficients").unwrap().mat().unwrap();
    let at = |r, c| *k.at_2d::<f64>(r, c).unwrap();
    eprintln!(
        "OpenCV FileStorage read back: fx {} fy {} cx {} cy {} dist {:?}",
        at(0, 0),
        at(1, 1),
        at(0, 2),
        at(1, 2),
        d.data_typed::<f64>().unwrap()
    );
    assert_eq!((at(0, 0), at(1, 1), at(0, 2), at(1, 2)), (fx, fy, cx, cy));
    assert_eq!((at(0, 1), at(1, 0), at(2, 0), at(2, 1), at(2, 2)), (0.0, 0.0, 0.0, 0.0, 1.0));
    assert_eq!(d.data_typed::<f64>().unwrap(), dist.as_slice());
    let e = fs.get("avg_reprojection_error").unwrap().real().unwrap();
    assert!((e - f(&v["rms_px"])).abs() < 1e-15);

    // fslcal's reader (what `laser --camera` uses) gives the same camera ...
    let (c, _) = opencv_yaml::read(&out).unwrap();
    assert_eq!((c.fx_px, c.fy_px, c.cx_px, c.cy_px), (fx, fy, cx, cy));
    assert_eq!(c.distortion.to_opencv().as_slice(), dist.as_slice());
    // ... and `fslcal laser --camera` gets past the camera file to the photos (these have no
    // laser dot, so it stops there).
    let l = fslcal(&[
        "laser",
        "--camera",
        out.to_str().unwrap(),
        "--target",
        "checkerboard:9x6@25mm",
        &photos[0],
        &photos[1],
    ]);
    let err = String::from_utf8_lossy(&l.stderr);
    assert!(!l.status.success());
    assert!(!err.contains("camera.yml") && !err.contains("panicked"), "{err}");
}

#[test]
fn human_summary_says_rms_outliers_sigma_and_coverage() {
    let dir = scratch("summary");
    let out = dir.join("camera.yml");
    let photos = samples();
    let o = fslcal(&camera_cmd("9x6@25mm", out.to_str().unwrap(), &photos));
    assert!(o.status.success());
    let text = String::from_utf8_lossy(&o.stdout);
    eprintln!("{text}");
    for needle in [
        "RMS",
        "px per point",
        "worst",
        "outlier corners",
        "of 702",
        "outlier photos 0 of 13",
        "1-sigma",
        "coverage:",
        "left02.jpg",
    ] {
        assert!(text.contains(needle), "summary lacks `{needle}`");
    }
    assert!(out.is_file());
}

/// Runs a failing command; checks one line on stderr naming `needle`, exit 1, no output file.
fn refuses(name: &str, board: &str, photos: &[String], needle: &str) {
    let dir = scratch(name);
    let out = dir.join("camera.yml");
    let o = fslcal(&camera_cmd(board, out.to_str().unwrap(), photos));
    let err = String::from_utf8_lossy(&o.stderr);
    eprintln!("{name}: {}", err.trim());
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(err.starts_with("fslcal: error:") && err.contains(needle), "{err}");
    assert_eq!(err.matches(needle).count(), 1, "said once: {err}");
    assert!(!out.exists(), "nothing may be written");
}

#[test]
fn bad_input_is_one_line_and_writes_nothing() {
    let photos = samples();
    let dir = scratch("inputs");
    // A file that is not a photo.
    let junk = dir.join("junk.jpg");
    std::fs::write(&junk, b"\xFF\xD8 not really a jpeg \xFF\xD9").unwrap();
    let mut with_junk = photos.clone();
    with_junk.push(junk.display().to_string());
    refuses("unreadable", "9x6@25mm", &with_junk, "junk.jpg");
    // A photo from another camera mode.
    let small = dir.join("small.png");
    image::GrayImage::from_pixel(320, 240, image::Luma([128])).save(&small).unwrap();
    let mut mixed = photos.clone();
    mixed.push(small.display().to_string());
    refuses("mixed", "9x6@25mm", &mixed, "320x240, but");
    // No photo shows a board of this size.
    let blanks: Vec<String> = (0..4)
        .map(|i| {
            let p = dir.join(format!("blank{i}.png"));
            image::GrayImage::from_fn(640, 480, |x, y| image::Luma([((x * 7 + y * 3 + i) % 200) as u8]))
                .save(&p)
                .unwrap();
            p.display().to_string()
        })
        .collect();
    refuses("no-board", "9x6@25mm", &blanks, "no 9x6 checkerboard found in any of the 4 photos");
    // Too few views.
    refuses("few", "9x6@25mm", &photos[..3], "found in only 3 of 3 photos; at least 4");
    // A missing photo and a bad board.
    refuses("missing", "9x6@25mm", &["nowhere.jpg".to_string()], "nowhere.jpg: no such photo");
    let o = fslcal(&["camera", "--board", "9x6", &photos[0]]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("COLSxROWS@SQUAREmm"));
}
