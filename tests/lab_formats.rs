//! The FishSense lab's own files in and out of fslcal: its real Label Studio export of
//! laser dots, its 4040x3016 frame (labels and lens) against fslcal's 4000x3000 picture,
//! its API's JSON bodies round-tripped bit for bit, and the import's sanity gates.

mod common;

use calib_targets::scene::Water;
use common::{laser_set, SceneSet};
use fslcal::photo::dot_labels::{self, DotsFormat};
use fslcal::photo::frame::Frame;
use fslcal::units::lab_api::{CAMERA_INTRINSICS_FIELDS, LASER_EXTRINSICS_FIELDS};
use fslcal::units::lab_pkg::{LaserPkg, LensPkg};
use fslcal_core::{CameraModel, LaserLine, Vec2, Vec3};
use serde_json::{json, Value};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::OnceLock;

fn fslcal(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_fslcal")).args(args).output().expect("run fslcal")
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn ok(o: &Output) -> &Output {
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    o
}

fn json_out(o: &Output) -> Value {
    serde_json::from_slice(&ok(o).stdout).expect("stdout is one JSON object")
}

/// The one line a refused command prints.
fn refusal(o: &Output) -> String {
    assert_eq!(o.status.code(), Some(1), "expected a refusal: {}", String::from_utf8_lossy(&o.stdout));
    let err = String::from_utf8_lossy(&o.stderr).trim_end().to_string();
    assert_eq!(err.lines().count(), 1, "one line: {err}");
    err
}

fn real_export() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/fishsense-lab-laser-labels/fsl-11d.json")
}

/// RMS and worst distance of points from a total-least-squares line, and from a quadratic
/// along it (its principal axis), pixels.
fn curve_fits(pts: &[Vec2]) -> ((f64, f64), (f64, f64)) {
    let n = pts.len() as f64;
    let c = pts.iter().fold(Vec2::zeros(), |a, p| a + p) / n;
    let m = pts.iter().fold(nalgebra::Matrix2::zeros(), |m, p| m + (p - c) * (p - c).transpose());
    let eig = nalgebra::SymmetricEigen::new(m);
    let along = eig.eigenvectors.column(eig.eigenvalues.imax()).into_owned();
    let across = Vec2::new(-along.y, along.x);
    let (t, r): (Vec<f64>, Vec<f64>) = pts.iter().map(|p| ((p - c).dot(&along), (p - c).dot(&across))).unzip();
    let stats = |res: &[f64]| {
        ((res.iter().map(|e| e * e).sum::<f64>() / n).sqrt(), res.iter().fold(0.0f64, |a, e| a.max(e.abs())))
    };
    // r = a + b t + c t², least squares by the normal equations.
    let a = nalgebra::DMatrix::from_fn(pts.len(), 3, |i, j| t[i].powi(j as i32));
    let coef = (a.transpose() * &a).try_inverse().unwrap() * a.transpose() * nalgebra::DVector::from_vec(r.clone());
    let quad: Vec<f64> = (0..pts.len()).map(|i| r[i] - (coef[0] + coef[1] * t[i] + coef[2] * t[i] * t[i])).collect();
    (stats(&r), stats(&quad))
}

/// The lab's real export (FSL-11D, 2025-02-12): every task read, one dot per photo, all in
/// the lab's 4040x3016 frame, matched by stem to the ORFs they were developed from; the
/// dots' spread off one smooth curve is the lab's labelling noise.
#[test]
fn the_labs_real_export_is_read_and_its_dots_lie_on_one_curve() {
    let f = dot_labels::read(&real_export(), "Green Laser").unwrap();
    assert_eq!(f.format, DotsFormat::LabelStudio);
    assert_eq!((f.entries, f.dots.len()), (76, 76));
    assert!(f.skipped.is_empty() && f.newest_of_several.is_empty());
    assert_eq!(f.labels.iter().collect::<Vec<_>>(), [(&"Green Laser".to_string(), &76)]);
    assert!(f.dots.iter().all(|d| d.frame == Some(Frame::of_size(4040, 3016))));
    let orfs: Vec<PathBuf> = (1..=76).map(|i| PathBuf::from(format!("dive/P21{i:05}.ORF"))).collect();
    let (matched, unmatched) = dot_labels::match_photos(&f, &orfs).unwrap();
    assert_eq!((matched.len(), unmatched.len()), (76, 0));
    let distinct: std::collections::BTreeSet<&PathBuf> = matched.iter().map(|(p, _)| p).collect();
    assert_eq!(distinct.len(), 76, "one dot per photo");

    let pts: Vec<Vec2> = f.dots.iter().map(|d| d.pixel).collect();
    let (lo, hi) =
        pts.iter().fold((Vec2::repeat(f64::MAX), Vec2::repeat(f64::MIN)), |(lo, hi), p| (lo.inf(p), hi.sup(p)));
    let ((line_rms, line_worst), (quad_rms, quad_worst)) = curve_fits(&pts);
    eprintln!(
        "FSL-11D export: 76 tasks, 76 `Green Laser` keypoints on 4040x3016 images, one per photo; \
         dots span x {:.1}-{:.1}, y {:.1}-{:.1} px",
        lo.x, hi.x, lo.y, hi.y
    );
    eprintln!(
        "off one straight line (the image of a 3D line on the lab's undistorted images): RMS {line_rms:.2} px, worst {line_worst:.2} px; \
         off a quadratic along it: RMS {quad_rms:.2} px, worst {quad_worst:.2} px"
    );
    // The figures PROVENANCE.md states for this file, and the line a little worse.
    assert!((quad_rms - 1.40).abs() < 0.01 && (quad_worst - 6.50).abs() < 0.01, "{quad_rms} {quad_worst}");
    assert!(line_rms > quad_rms && line_rms < 2.0 && line_worst < 9.0, "{line_rms} {line_worst}");
}

fn scene_set() -> &'static SceneSet {
    static SET: OnceLock<SceneSet> = OnceLock::new();
    SET.get_or_init(|| laser_set("lab-frames", 8, 41, Water::Clear, 0))
}

/// The lab's 4040x3016 readout frame: fslcal's picture starts at (8, 8) in it.
const CROP: f64 = 8.0;

fn laser_args(set: &SceneSet, camera: &Path, dots: &Path, extra: &[&str]) -> Vec<String> {
    let mut a: Vec<String> =
        ["laser", "--camera", s(camera), "--target", "checkerboard:14x10@42.17mm", "--dots", s(dots)]
            .iter()
            .map(|x| x.to_string())
            .collect();
    a.extend(extra.iter().map(|x| x.to_string()));
    a.push("--json".into());
    a.extend(set.photos.iter().map(|p| s(p).to_string()));
    a
}

fn run_laser(args: &[String]) -> Value {
    json_out(&fslcal(&args.iter().map(String::as_str).collect::<Vec<_>>()))
}

fn line_of(v: &Value) -> LaserLine {
    let a = |k: &str| -> [f64; 3] { std::array::from_fn(|i| v["laser"][k][i].as_f64().unwrap()) };
    LaserLine { origin_m: a("origin_m"), direction: a("direction") }
}

/// Origin difference (mm), angle (deg), and the largest depth difference (mm) for a dot `a`
/// puts at 1, 3 and 5 m.
fn apart(camera: &CameraModel, a: &LaserLine, b: &LaserLine) -> (f64, f64, f64) {
    let depth_mm = [1.0, 3.0, 5.0]
        .iter()
        .map(|&z| (b.fix_from_pixel(camera, a.pixel_at_depth(camera, z).unwrap()).unwrap().depth_m - z).abs() * 1e3)
        .fold(0.0, f64::max);
    ((a.origin() - b.origin()).norm() * 1e3, fslcal::laser::fit::angle_deg(&a.direction, &b.direction), depth_mm)
}

/// A Label Studio task as the lab's export has it, for `photo`'s dot at `px` on a 4040x3016
/// image.
fn task(id: usize, photo: &Path, px: Vec2) -> Value {
    let name = photo.file_stem().unwrap().to_string_lossy();
    json!({
        "id": 1000 + id,
        "data": {"img": format!("https://e4e-nas.ucsd.edu:6021/label_studio/x/processed_lasers/{name}.JPG")},
        "annotations": [{"id": 5000 + id, "was_cancelled": false, "created_at": "2025-02-12T02:46:47.060779Z",
            "result": [{"type": "keypointlabels", "origin": "manual", "image_rotation": 0,
                "original_width": 4040, "original_height": 3016,
                "value": {"x": (px.x + 0.5) / 4040.0 * 100.0, "y": (px.y + 0.5) / 3016.0 * 100.0, "width": 0.12,
                          "keypointlabels": ["Green Laser"]}}]}],
    })
}

/// The true dots of the scenes whose dot is on the board, by photo.
fn true_dots(set: &SceneSet) -> Vec<(PathBuf, Vec2)> {
    set.photos
        .iter()
        .zip(&set.truths)
        .filter_map(|(p, t)| t.dot.as_ref().map(|d| (p.clone(), Vec2::new(d.pixel[0], d.pixel[1]))))
        .collect()
}

/// A `file,x,y` CSV of `dots` moved by `shift` px.
fn write_csv(dir: &Path, name: &str, dots: &[(PathBuf, Vec2)], shift: f64) -> PathBuf {
    let p = dir.join(name);
    let rows: String = dots.iter().map(|(f, d)| format!("{},{},{}\n", s(f), d.x + shift, d.y + shift)).collect();
    std::fs::write(&p, format!("file,x,y\n{rows}")).unwrap();
    p
}

/// A Label Studio export of `dots`, each placed on the 4040x3016 image by `to_raw`.
fn write_export(dir: &Path, name: &str, dots: &[(PathBuf, Vec2)], to_raw: &dyn Fn(Vec2) -> Vec2) -> PathBuf {
    let tasks: Vec<Value> = dots.iter().enumerate().map(|(i, (p, d))| task(i, p, to_raw(*d))).collect();
    let p = dir.join(name);
    std::fs::write(&p, serde_json::to_vec(&tasks).unwrap()).unwrap();
    p
}

/// The lab's lens `.pkg` of `camera`: the same lens in the 4040x3016 readout frame.
fn write_lab_lens(dir: &Path, camera: &CameraModel) -> (PathBuf, CameraModel) {
    let raw = CameraModel {
        width_px: 4040,
        height_px: 3016,
        cx_px: camera.cx_px + CROP,
        cy_px: camera.cy_px + CROP,
        ..*camera
    };
    let lens = LensPkg {
        camera_matrix: [raw.fx_px, 0.0, raw.cx_px, 0.0, raw.fy_px, raw.cy_px, 0.0, 0.0, 1.0],
        distortion: raw.distortion.to_opencv().to_vec(),
        calibrated_utc_s: 1_739_212_325,
    };
    let path = dir.join("fsl-xx-lens-raw.pkg");
    std::fs::write(&path, lens.write().unwrap()).unwrap();
    (path, raw)
}

/// How far `other` puts a dot `base` puts at 1, 3 and 5 m.
fn depth_errors(camera: &CameraModel, base: &LaserLine, other: &LaserLine) -> String {
    let at: Vec<String> = [1.0, 3.0, 5.0]
        .iter()
        .map(|&d| {
            let fix = other.fix_from_pixel(camera, base.pixel_at_depth(camera, d).unwrap()).unwrap();
            format!("{:+.0} mm at {d} m", (fix.depth_m - d) * 1e3)
        })
        .collect();
    at.join(", ")
}

/// A calibration and labels made in the lab's 4040x3016 frame give the laser the same scene
/// gives in fslcal's own 4000x3000 frame: the lens `.pkg` with its principal point 8 px on,
/// the dots 8 px on (as clicked on as-shot images, and as the lab clicks them, on images
/// undistorted with that lens). The same dots given in the raw frame without saying so are
/// the error this prevents.
#[test]
fn the_labs_4040x3016_frame_gives_the_same_laser_as_fslcals_own() {
    let set = scene_set();
    let (dir, truth_cam, truth) = (set.path(), set.truths[0].camera, set.truths[0].laser.unwrap());
    let dots = true_dots(set);
    assert!(dots.len() >= 6, "{} dots on boards", dots.len());
    let own = run_laser(&laser_args(set, &set.camera_file, &write_csv(dir, "own.csv", &dots, 0.0), &[]));
    let (lens_path, raw_cam) = write_lab_lens(dir, &truth_cam);
    let shifted = |d: Vec2| d + Vec2::repeat(CROP);
    // As the lab clicks: on the readout image undistorted with its lens (OpenCV's
    // undistort keeps the camera matrix).
    let undistorted = |d: Vec2| {
        let x = raw_cam.undistort(shifted(d)).unwrap();
        Vec2::new(raw_cam.fx_px * x.x + raw_cam.cx_px, raw_cam.fy_px * x.y + raw_cam.cy_px)
    };
    let as_shot_json = write_export(dir, "as-shot.json", &dots, &shifted);
    let as_shot = run_laser(&laser_args(set, &lens_path, &as_shot_json, &["--dots-image", "as-shot"]));
    let lab_style = run_laser(&laser_args(set, &lens_path, &write_export(dir, "lab.json", &dots, &undistorted), &[]));
    let raw_csv = write_csv(dir, "raw.csv", &dots, CROP);
    let csv_said = run_laser(&laser_args(set, &set.camera_file, &raw_csv, &["--dots-frame", "4040x3016"]));
    let csv_unsaid = run_laser(&laser_args(set, &set.camera_file, &raw_csv, &[]));

    let base = line_of(&own);
    let (o, a, z) = apart(&truth_cam, &base, &truth);
    eprintln!("fslcal frame vs truth: origin {o:.4} mm, direction {a:.5} deg, depth at 1/3/5 m within {z:.3} mm");
    assert_eq!(own["dots_file"]["matched"], dots.len());
    for (name, v) in [
        ("lens+labels in 4040x3016, as-shot", &as_shot),
        ("lens+labels as the lab makes them (undistorted 4040x3016)", &lab_style),
        ("CSV in 4040x3016 with --dots-frame", &csv_said),
    ] {
        let (o, a, z) = apart(&truth_cam, &base, &line_of(v));
        eprintln!(
            "{name} vs fslcal frame: origin {o:.2e} mm, direction {a:.2e} deg, depth at 1/3/5 m within {z:.2e} mm"
        );
        // The undistortion is iterative: the round trip keeps each dot to about 1e-9 px, which
        // the fit turns into up to about 1e-6 deg of direction (8.5e-7 seen), depending on the
        // boards' poses. A frame mixed up is 8 px per dot, degrees of direction.
        assert!(o < 1e-6 && a < 1e-5 && z < 1e-6, "{name}: {o} mm {a} deg {z} mm");
        assert_eq!(v["camera"], own["camera"], "{name}: the lens lands on fslcal's picture");
        assert_eq!(v["dots_file"]["matched"], dots.len());
    }
    assert_eq!(lab_style["dots_file"]["image"], "undistorted");
    assert_eq!(lab_style["dots_file"]["frames"][0]["shift_px"], json!([-8.0, -8.0]));
    let wrong = line_of(&csv_unsaid);
    let (o, a, z) = apart(&truth_cam, &base, &wrong);
    let errors = depth_errors(&truth_cam, &base, &wrong);
    eprintln!(
        "the same 4040x3016 dots taken as fslcal's pixels: origin {o:.2} mm, direction {a:.4} deg, depth {errors}"
    );
    assert!(z > 5.0, "an 8 px offset must show: {z} mm");
    lab_equivalent_rides_along(&own, dots.len());
}

/// The lab's equivalent of its own tool in the laser JSON: on clean dots, within a hair of
/// fslcal's fit.
fn lab_equivalent_rides_along(own: &Value, dots: usize) {
    let lab = &own["lab_equivalent"];
    assert_eq!(lab["method"], "average");
    assert_eq!(lab["dots"], dots);
    eprintln!(
        "lab equivalent on the true dots: {:.4} deg, origins {:.3} mm apart, depth at 1/3/5 m {} m",
        lab["angle_deg"].as_f64().unwrap(),
        lab["origin_difference_mm"].as_f64().unwrap(),
        lab["distance_difference_m"]
    );
    assert!(lab["angle_deg"].as_f64().unwrap() < 0.05 && lab["origin_difference_mm"].as_f64().unwrap() < 1.0);
}

/// The summary says where the lens and the dots came from, and the lab's fit beside ours.
#[test]
fn the_summary_names_the_frames_and_the_labs_own_fit() {
    let set = scene_set();
    let dir = set.path();
    let t = &set.truths;
    let rows: String = set
        .photos
        .iter()
        .zip(t)
        .filter_map(|(p, t)| t.dot.as_ref().map(|d| (p, d)))
        .enumerate()
        .map(|(i, (p, d))| task(i, p, Vec2::new(d.pixel[0] + CROP, d.pixel[1] + CROP)))
        .map(|v| v.to_string())
        .collect::<Vec<_>>()
        .join(",");
    // A second, newer annotation of the first photo, and a cancelled-only task.
    let mut tasks: Vec<Value> = serde_json::from_str(&format!("[{rows}]")).unwrap();
    let mut newer = tasks[0]["annotations"][0].clone();
    newer["updated_at"] = "2025-02-13T00:00:00Z".into();
    tasks[0]["annotations"].as_array_mut().unwrap().push(newer);
    tasks.push(json!({"id": 9, "data": {"img": "https://x/P9999999.JPG"}, "annotations": [{"was_cancelled": true, "result": []}]}));
    let export = dir.join("summary.json");
    std::fs::write(&export, serde_json::to_vec(&tasks).unwrap()).unwrap();
    let mut args = laser_args(set, &set.camera_file, &export, &["--dots-image", "as-shot"]);
    args.retain(|a| a != "--json");
    let o = fslcal(&args.iter().map(String::as_str).collect::<Vec<_>>());
    let text = String::from_utf8_lossy(&ok(&o).stdout).to_string();
    for want in [
        "a Label Studio export: ",
        "dots labelled \"Green Laser\"",
        "clicked on 4040x3016 images (as-shot), moved by (-8, -8) px into the camera's pixels",
        "several annotations of photo_00.JPG: the newest used",
        "skipped task 9 (P9999999.JPG): no annotation that is not cancelled",
        "the lab's fsl calibrate-laser on these dots (averaging fit on all",
        "a dot fslcal puts at 1 m it puts",
    ] {
        assert!(text.contains(want), "missing `{want}` in:\n{text}");
    }
}

/// A `--dots` file that is not what it should be is refused with the reason before any
/// photo is read (issue 16 item 14: a JSON export used to be silently ignored).
#[test]
fn a_dots_file_fslcal_cannot_read_is_refused_with_the_reason() {
    let set = scene_set();
    let dir = set.path();
    let cases = [
        ("foreign.json", r#"{"camera": {"fx": 1}}"#, "not a Label Studio export fslcal reads"),
        (
            "red.json",
            r#"[{"data": {"img": "photo_00.JPG"}, "annotations": [{"result": [{"value": {"x": 50, "y": 50, "keypointlabels": ["Red Laser"]}, "original_width": 4000, "original_height": 3000}]}]}]"#,
            "no keypoint labelled `Green Laser`",
        ),
        ("words.txt", "the dots are in the other file", "line 1: expected `file,x,y`"),
        ("header-only.csv", "file,x,y\n", "no dots in it"),
    ];
    for (name, text, why) in cases {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        let err = refusal(&fslcal(
            &laser_args(set, &set.camera_file, &p, &[]).iter().map(String::as_str).collect::<Vec<_>>(),
        ));
        assert!(err.contains(name) && err.contains(why), "{name}: {err}");
    }
    // Pixels of a size fslcal cannot place are refused with both sizes named.
    let p = dir.join("odd-frame.csv");
    std::fs::write(&p, format!("{},10,20\n", s(&set.photos[0]))).unwrap();
    let err = refusal(&fslcal(
        &laser_args(set, &set.camera_file, &p, &["--dots-frame", "2000x1500"])
            .iter()
            .map(String::as_str)
            .collect::<Vec<_>>(),
    ));
    assert!(err.contains("2000x1500") && err.contains("4000x3000") && err.contains("cannot be placed"), "{err}");
}

fn keygen(dir: &Path) -> PathBuf {
    let key = dir.join("lead");
    ok(&fslcal(&["keygen", "--out", s(&key), "--comment", "test"]));
    key
}

/// Awkward numbers, as a lab's calibration has them: none is short in decimal.
const K: [[f64; 3]; 3] =
    [[2911.7531249876543, 0.0, 2027.3359375000002], [0.0, 2912.4687500000005, 1509.0625000001], [0.0, 0.0, 1.0]];
const DIST: [f64; 5] =
    [-0.11750000000000001, 0.051234567890123456, 0.0009100000000000001, -0.00042, -0.013900000000000003];
const POSITION_M: [f64; 3] = [-0.041234567890123, -0.10671428571428572, 0.0];

fn axis() -> [f64; 3] {
    let d = Vec3::new(0.0098123456789, 0.0199987654321, 1.0).normalize();
    [d.x, d.y, d.z]
}

/// Every number in `v`, depth first, as its bits.
fn bits(v: &Value) -> Vec<u64> {
    match v {
        Value::Number(n) => vec![n.as_f64().unwrap().to_bits()],
        Value::Array(a) => a.iter().flat_map(bits).collect(),
        _ => Vec::new(),
    }
}

fn keys(v: &Value) -> Vec<String> {
    v.as_object().unwrap().keys().cloned().collect()
}

fn sorted(fields: &[&str]) -> Vec<String> {
    let mut v: Vec<String> = fields.iter().map(|s| s.to_string()).collect();
    v.sort();
    v
}

/// The lab's API bodies as its database returns them.
fn lab_bodies(d: &Path) -> (Value, PathBuf, Value, PathBuf) {
    let intrinsics = json!({"id": 17, "camera_matrix": K, "distortion_coefficients": DIST, "camera_id": 4});
    let extrinsics = json!({"id": 230, "laser_position": POSITION_M, "laser_axis": axis(),
                            "created_at": "2025-02-10T18:32:05+00:00", "dive_id": 31, "camera_id": 4});
    let (ci, le) = (d.join("intrinsics.json"), d.join("extrinsics.json"));
    std::fs::write(&ci, serde_json::to_vec_pretty(&intrinsics).unwrap()).unwrap();
    std::fs::write(&le, serde_json::to_vec_pretty(&extrinsics).unwrap()).unwrap();
    (intrinsics, ci, extrinsics, le)
}

/// Python's `json` reads the same numbers from both files of each pair, and
/// `datetime.fromisoformat` reads `created_at` as a zoned time at `epoch_s`.
fn python_reads_the_same(extrinsics: [&str; 2], intrinsics: [&str; 2], epoch_s: f64) {
    let script = r#"
import json, sys
from datetime import datetime
a, b = json.load(open(sys.argv[1])), json.load(open(sys.argv[2]))
ia, ib = json.load(open(sys.argv[3])), json.load(open(sys.argv[4]))
same = all(a[k] == b[k] for k in ["laser_position", "laser_axis", "dive_id", "camera_id"]) and \
       all(ia[k] == ib[k] for k in ["camera_matrix", "distortion_coefficients", "camera_id"])
t = datetime.fromisoformat(b["created_at"])
print(json.dumps({"same": same, "zoned": t.tzinfo is not None, "epoch": t.timestamp()}))
"#;
    let [le, le_out] = extrinsics;
    let [ci, ci_out] = intrinsics;
    let py = Command::new("python3").args(["-c", script, le, le_out, ci, ci_out]).output();
    let py = py.expect("this test needs python3 (the lab's tools read these bodies with Python's json and datetime)");
    let p: Value = serde_json::from_slice(&ok(&py).stdout).unwrap();
    assert_eq!(p, json!({"same": true, "zoned": true, "epoch": epoch_s}), "Python reads the same numbers");
}

/// The lab's API bodies → `fslcal import` → signed file → `fslcal export --format
/// fishsense-api` → the same bodies: every number bit for bit, the fields exactly the lab's
/// models', the time ISO 8601 with its zone (Python's `datetime.fromisoformat` reads it).
#[test]
fn api_bodies_round_trip_bit_exact_through_a_signed_file() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let key = keygen(d);
    let (intrinsics, ci, extrinsics, le) = lab_bodies(d);
    let file = d.join("fsl-11d.fslcal");
    // Either order: told apart by content.
    let import = ["import", s(&le), s(&ci), "--unit", "FSL-11", "--key", s(&key), "--out", s(&file), "--json"];
    assert_eq!(json_out(&fslcal(&import))["provenance"], "imported-api");
    let i = json_out(&fslcal(&["inspect", s(&file), "--json"]));
    assert_eq!(i["provenance"], "imported-api");
    assert_eq!(i["camera"]["image_size"], json!([4000, 3000]));
    assert_eq!(i["camera"]["cx"].as_f64(), Some(K[0][2] - 8.0), "moved into fslcal's picture");
    assert_eq!(i["made_utc"], "2025-02-10T18:32:05Z");
    let text = String::from_utf8_lossy(&ok(&fslcal(&["inspect", s(&file)])).stdout).to_string();
    assert!(text.contains("source    imported from the lab's API JSON"), "{text}");

    let out = d.join("api");
    let e = json_out(&fslcal(&[
        "export",
        s(&file),
        "--format",
        "fishsense-api",
        "--out",
        s(&out),
        "--camera-id",
        "4",
        "--dive-id",
        "31",
        "--json",
    ]));
    let read = |k: &str| -> Value { serde_json::from_slice(&std::fs::read(e[k].as_str().unwrap()).unwrap()).unwrap() };
    let (ci2, le2) = (read("camera_intrinsics"), read("laser_extrinsics"));
    assert_eq!(keys(&ci2), sorted(&CAMERA_INTRINSICS_FIELDS), "the lab's CameraIntrinsics fields");
    assert_eq!(keys(&le2), sorted(&LASER_EXTRINSICS_FIELDS), "the lab's LaserExtrinsics fields");
    let mut count = 0;
    for (a, b, fields) in [
        (&intrinsics, &ci2, &["camera_matrix", "distortion_coefficients", "camera_id"][..]),
        (&extrinsics, &le2, &["laser_position", "laser_axis", "dive_id", "camera_id"][..]),
    ] {
        for f in fields {
            assert_eq!(bits(&a[*f]), bits(&b[*f]), "{f}: {} vs {}", a[*f], b[*f]);
            count += bits(&a[*f]).len();
        }
    }
    assert_eq!(le2["created_at"], extrinsics["created_at"]);
    // A new row: the database gives the id.
    assert!(ci2["id"].is_null() && le2["id"].is_null());
    eprintln!(
        "API round trip: {count} numbers (9 camera matrix, 5 distortion, 3 position, 3 axis, 3 ids) bit-exact; \
         fields {:?} and {:?}; created_at {}",
        CAMERA_INTRINSICS_FIELDS, LASER_EXTRINSICS_FIELDS, le2["created_at"]
    );
    let (le_out, ci_out) = (e["laser_extrinsics"].as_str().unwrap(), e["camera_intrinsics"].as_str().unwrap());
    python_reads_the_same([s(&le), le_out], [s(&ci), ci_out], 1_739_212_325.0);
}

/// The lab's `.pkg` archives in, its API bodies and its archives out: the same numbers.
#[test]
fn pkg_files_come_out_as_api_bodies_and_pkgs_with_the_same_numbers() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let key = keygen(d);
    let lens = LensPkg {
        camera_matrix: std::array::from_fn(|i| K[i / 3][i % 3]),
        distortion: DIST.to_vec(),
        calibrated_utc_s: 1_739_212_325,
    };
    let laser = LaserPkg { position_m: POSITION_M, axis: axis(), calibrated_utc_s: 1_739_212_325 };
    let (lp, xp) = (d.join("lens.pkg"), d.join("laser.pkg"));
    std::fs::write(&lp, lens.write().unwrap()).unwrap();
    std::fs::write(&xp, laser.write().unwrap()).unwrap();
    let file = d.join("from-pkg.fslcal");
    let v = json_out(&fslcal(&[
        "import",
        s(&lp),
        s(&xp),
        "--unit",
        "FSL-11",
        "--key",
        s(&key),
        "--out",
        s(&file),
        "--json",
    ]));
    assert_eq!(v["provenance"], "imported-pkg");
    let e = json_out(&fslcal(&["export", s(&file), "--format", "fishsense-api", "--out", s(&d.join("api")), "--json"]));
    let ci: Value = serde_json::from_slice(&std::fs::read(e["camera_intrinsics"].as_str().unwrap()).unwrap()).unwrap();
    assert_eq!(bits(&ci["camera_matrix"]), bits(&json!(K)));
    assert_eq!(bits(&ci["distortion_coefficients"]), bits(&json!(DIST)));
    assert!(ci["camera_id"].is_null(), "no --camera-id: null, as the API's PUT fills it from its path");
    let back =
        json_out(&fslcal(&["export", s(&file), "--format", "fishsense-pkg", "--out", s(&d.join("pkg")), "--json"]));
    assert_eq!(LensPkg::read(&std::fs::read(back["lens"].as_str().unwrap()).unwrap()).unwrap(), lens);
    assert_eq!(LaserPkg::read(&std::fs::read(back["laser"].as_str().unwrap()).unwrap()).unwrap(), laser);
}

fn pkg_with_metadata(path: &Path, metadata: &str, arrays: &[(&str, &[usize], &[f64])]) {
    use flate2::write::GzEncoder;
    let mut tar = tar::Builder::new(GzEncoder::new(Vec::new(), flate2::Compression::default()));
    let mut add = |name: &str, bytes: Vec<u8>| {
        let mut h = tar::Header::new_gnu();
        h.set_size(bytes.len() as u64);
        h.set_mode(0o644);
        h.set_entry_type(tar::EntryType::Regular);
        tar.append_data(&mut h, name, bytes.as_slice()).unwrap();
    };
    add("metadata.json", metadata.as_bytes().to_vec());
    for (name, shape, data) in arrays {
        add(name, fslcal::units::lab_pkg::write_npy(shape, data));
    }
    std::fs::write(path, tar.into_inner().unwrap().finish().unwrap()).unwrap();
}

/// Issue 16 item 11: what the lab's own `.pkg` writers have produced is checked on import.
#[test]
fn import_refuses_wrong_units_and_naive_times_and_says_what_it_changed() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let key = keygen(d);
    let k: Vec<f64> = K.iter().flatten().copied().collect();
    let lens_2023 = d.join("lens-2023.pkg");
    // The 2023 lens tool: a local time without a zone, and the camera's serial.
    let meta_2023 = r#"{"name": "tg6", "manufacturer": "Olympus", "model": "TG-6", "serial_number": "BHV204411", "calibrated_date": "2023-07-14 10:31:07.517211"}"#;
    pkg_with_metadata(
        &lens_2023,
        meta_2023,
        &[("_calibration_matrix.npy", &[3, 3], &k), ("_distortion_coefficients.npy", &[1, 5], &DIST)],
    );
    let laser_at = |name: &str, pos: [f64; 3], axis: [f64; 3]| {
        let p = d.join(name);
        pkg_with_metadata(
            &p,
            r#"{"calibrated_date": "2023-07-14 11:02:00"}"#,
            &[("laser_axis.npy", &[3], &axis), ("laser_pos.npy", &[3], &pos)],
        );
        p
    };
    let good = laser_at("laser.pkg", POSITION_M, axis());
    let import = |laser: &Path, extra: &[&str]| {
        let out = d.join(format!("{}.fslcal", laser.file_stem().unwrap().to_string_lossy()));
        let mut a = vec!["import", s(&lens_2023), s(laser), "--unit", "FSL-03", "--key", s(&key), "--out", s(&out)];
        a.extend_from_slice(extra);
        (fslcal(&a), out)
    };
    // A time without a zone: refused, then placed where it was written.
    let err = refusal(&import(&good, &[]).0);
    assert!(err.contains("2023-07-14 10:31:07.517211") && err.contains("--timezone"), "{err}");
    let (o, out) = import(&good, &["--timezone", "America/Los_Angeles"]);
    ok(&o);
    let i = json_out(&fslcal(&["inspect", s(&out), "--json"]));
    // The later of the two, 11:02 PDT: 18:02 UTC, not 11:02 UTC.
    assert_eq!(i["made_utc"], "2023-07-14T18:02:00Z");
    assert_eq!(i["camera_identity"]["serial"], "BHV204411", "the 2023 metadata's serial_number is carried");
    assert_eq!(i["provenance"], "imported-pkg");
    // --camera-serial still wins over the file.
    // The same output again: replacing a signed file takes --force.
    let (o, out) = import(&good, &["--timezone", "-07:00", "--camera-serial", "BHX000001", "--force"]);
    ok(&o);
    assert_eq!(json_out(&fslcal(&["inspect", s(&out), "--json"]))["camera_identity"]["serial"], "BHX000001");

    // Centimetres and millimetres: refused by the laser's own baseline gates, unless forced.
    let cm = laser_at("laser-cm.pkg", POSITION_M.map(|v| v * 100.0), axis());
    let err = refusal(&import(&cm, &["--timezone", "UTC"]).0);
    assert!(
        err.contains("11.4") && err.contains("78-145 mm") && err.contains("centimetres") && err.contains("--force"),
        "{err}"
    );
    let mm = laser_at("laser-mm.pkg", POSITION_M.map(|v| v * 1000.0), axis());
    assert!(refusal(&import(&mm, &["--timezone", "UTC"]).0).contains("millimetres"));
    let (o, _) = import(&cm, &["--timezone", "UTC", "--force"]);
    assert!(String::from_utf8_lossy(&ok(&o).stderr).contains("signed anyway (--force)"));

    // A non-unit axis pointing backwards is turned round and normalised, and it is said.
    let a = axis();
    let flipped = laser_at("laser-flipped.pkg", POSITION_M, [-2.0 * a[0], -2.0 * a[1], -2.0 * a[2]]);
    let (o, out) = import(&flipped, &["--timezone", "UTC"]);
    let warnings = String::from_utf8_lossy(&ok(&o).stderr).to_string();
    assert!(warnings.contains("has length 2.000000000, not 1: normalised"), "{warnings}");
    assert!(warnings.contains("flipped to point forward"), "{warnings}");
    let i = json_out(&fslcal(&["inspect", s(&out), "--json"]));
    let got: Vec<f64> = i["laser"]["direction"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
    assert!(got.iter().zip(a).all(|(g, w)| (g - w).abs() < 1e-15), "{got:?}");
    // A unit axis that is already right says nothing (a fresh output: nothing replaced).
    let (o, _) = import(&laser_at("laser-again.pkg", POSITION_M, axis()), &["--timezone", "UTC"]);
    assert!(String::from_utf8_lossy(&ok(&o).stderr).trim().is_empty());
}

/// Fish labelled on the lab's 4040x3016 images measure as the same fish labelled in the
/// photo's own 4000x3000 pixels; labels of a size that cannot be placed are withheld with
/// the reason.
#[test]
fn fish_labels_on_the_labs_frame_measure_the_same_fish() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let camera = calib_targets::rig::tg6_camera();
    let laser = calib_targets::rig::fsl_laser();
    let cal = d.join("cal.json");
    let cal_json = json!({
        "camera": fslcal::calibration::camera_json(&camera),
        "laser": {"origin_m": laser.origin_m, "direction": laser.direction,
                  "covariance": [[1e-8, 0.0, 0.0, 0.0], [0.0, 1e-8, 0.0, 0.0], [0.0, 0.0, 1e-9, 0.0], [0.0, 0.0, 0.0, 1e-9]]},
        "depth_range_m": [0.5, 4.6],
    });
    std::fs::write(&cal, serde_json::to_vec(&cal_json).unwrap()).unwrap();
    let photo = d.join("P7010042.JPG");
    image::RgbImage::from_pixel(4000, 3000, image::Rgb([40, 90, 110])).save(&photo).unwrap();
    // A fish at 2 m with the dot on it, in the photo's pixels.
    let dot = laser.pixel_at_depth(&camera, 2.0).unwrap();
    let (head, tail) = (dot + Vec2::new(-400.0, 30.0), dot + Vec2::new(380.0, -20.0));
    let csv = d.join("labels.csv");
    let row = |p: Vec2| format!("{},{}", p.x, p.y);
    std::fs::write(&csv, format!("P7010042.JPG,{},{},{}\n", row(head), row(tail), row(dot))).unwrap();
    let export = |name: &str, w: u32, h: u32, shift: f64| {
        let kp = |label: &str, p: Vec2| {
            json!({"type": "keypointlabels", "original_width": w, "original_height": h, "image_rotation": 0,
                   "value": {"x": (p.x + shift + 0.5) / w as f64 * 100.0, "y": (p.y + shift + 0.5) / h as f64 * 100.0, "keypointlabels": [label]}})
        };
        let tasks = json!([{"id": 1, "data": {"image": "/data/upload/3/9c1e-P7010042.JPG"},
            "annotations": [{"result": [kp("Snout", head), kp("Fork", tail), kp("Green Laser", dot)]}]}]);
        let p = d.join(name);
        std::fs::write(&p, tasks.to_string()).unwrap();
        p
    };
    let measure = |labels: &Path| {
        json_out(&fslcal(&["measure", "--cal", s(&cal), "--labels", s(labels), "--json", s(&photo)]))["fish"][0].clone()
    };
    let own = measure(&csv);
    let lab = measure(&export("lab-frame.json", 4040, 3016, CROP));
    let length = |v: &Value| v["length_m"].as_f64().unwrap();
    eprintln!(
        "fish at 2 m: CSV in the photo's pixels {:.4} mm, Label Studio on 4040x3016 {:.4} mm",
        length(&own) * 1e3,
        length(&lab) * 1e3
    );
    assert!((length(&own) - length(&lab)).abs() < 1e-9, "{own} vs {lab}");
    assert!((lab["head_px"][0].as_f64().unwrap() - head.x).abs() < 1e-9);
    let odd = measure(&export("odd-frame.json", 2000, 1500, 0.0));
    let flags = odd["flags"].to_string();
    assert!(odd["length_m"].is_null() && flags.contains("2000x1500") && flags.contains("4000x3000"), "{odd}");
}
