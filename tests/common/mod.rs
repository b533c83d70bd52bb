//! Rendered scene sets (boards, fish) shared by the integration tests and the benchmarks:
//! rendered once per test binary into a temporary folder, with their ground truth.
#![allow(dead_code)]

pub mod tinted;

use calib_targets::fish::{fish_scene_set, render_fish, FishTruth};
use calib_targets::scene::{
    laser_scene_set, render, render_slate, slate_scene_set, RenderedScene, SceneSpec, SceneTruth, SlateSpec,
    SlateTexture, Water,
};
use calib_targets::variety::PhotoTruth;
use calib_targets::Checkerboard;
use calib_targets::Slate;
use calib_targets::{camera_yaml, write_fish, write_scene};
use fslcal::calibration::camera_json;
use fslcal::camera::opencv_yaml;
use fslcal::dot::candidates::DotDetectorParams;
use fslcal::laser::fit::{Gates, Method};
use fslcal::laser::pipeline::{HandDots, LaserJob, PhotoReport, PhotoStatus};
use fslcal_core::{CameraModel, LaserLine};
use rayon::prelude::*;
use serde_json::json;
use std::path::{Path, PathBuf};

pub struct SceneSet {
    pub dir: PathBuf,
    pub photos: Vec<PathBuf>,
    pub truths: Vec<SceneTruth>,
    pub camera_file: PathBuf,
}

impl SceneSet {
    pub fn path(&self) -> &Path {
        &self.dir
    }
}

/// Renders `specs` as `photo_NN.jpg` with truth and a `camera.yml` for the first spec's
/// camera, into a fresh folder `name` under cargo's per-target scratch folder (statics are
/// never dropped, so a `TempDir` would leak into /tmp).
pub fn render_set(name: &str, specs: &[SceneSpec]) -> SceneSet {
    render_with(name, specs.len(), &specs[0].camera, &|i| render(&specs[i]))
}

/// Renders `count` scenes with `render_one(i)` into a fresh folder `name` (see `render_set`).
fn render_with(
    name: &str,
    count: usize,
    camera: &CameraModel,
    render_one: &(dyn Fn(usize) -> RenderedScene + Sync),
) -> SceneSet {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("scratch folder");
    let written: Vec<(PathBuf, SceneTruth)> = (0..count)
        .into_par_iter()
        .map(|i| {
            let scene = render_one(i);
            let name = format!("photo_{i:02}");
            write_scene(&dir, &name, &scene).expect("write scene");
            (dir.join(format!("{name}.jpg")), scene.truth)
        })
        .collect();
    let camera_file = dir.join("camera.yml");
    std::fs::write(&camera_file, camera_yaml(camera)).expect("write camera file");
    let (photos, truths) = written.into_iter().unzip();
    SceneSet { dir, photos, truths, camera_file }
}

/// The example slate committed in `calib-targets/slates/example/`.
pub fn example_slate_path() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("calib-targets/slates/example/slate.toml")
}

pub fn example_slate() -> Slate {
    Slate::load(&example_slate_path()).expect("the example slate loads")
}

/// Photos of the example slate from `laser`, as `slate_scene_set` places them.
pub fn slate_set(
    name: &str,
    laser: LaserLine,
    depths_m: (f64, f64),
    count: usize,
    seed: u64,
    water: Water,
    glints: u32,
) -> SceneSet {
    let texture = SlateTexture::from_slate(&example_slate()).expect("the example scan");
    let specs: Vec<SlateSpec> = slate_scene_set(&texture, laser, depths_m, count, seed, water, glints);
    render_with(name, specs.len(), &specs[0].camera, &|i| render_slate(&texture, &specs[i]))
}

pub fn laser_set(name: &str, count: usize, seed: u64, water: Water, glints: u32) -> SceneSet {
    render_set(name, &laser_scene_set(count, seed, water, glints))
}

/// A photo of the same scenery with no board in it.
pub fn no_board_spec(seed: u64) -> SceneSpec {
    let mut spec = laser_scene_set(1, seed, Water::Clear, 0).remove(0);
    spec.board = None;
    spec
}

/// The figures a camera test prints for the closing note: photos, residuals, outliers,
/// coverage.
pub fn camera_figures(cal: &fslcal::camera::calibrate::CameraCalibration) -> String {
    format!(
        "{} of {} photos used, RMS {:.3} px per point, worst {:.3} px, outlier corners {} of {}, outlier photos {} of {}, coverage {:.0}% (uncovered frame corners {:?})",
        cal.used_photos(),
        cal.photos.len(),
        cal.rms_px,
        cal.worst_px,
        cal.corner_outliers.0,
        cal.corner_outliers.1,
        cal.photo_outliers.0,
        cal.photo_outliers.1,
        100.0 * cal.coverage.share,
        cal.coverage.uncovered_frame_corners
    )
}
pub struct FishSet {
    pub dir: PathBuf,
    pub photos: Vec<PathBuf>,
    pub truths: Vec<FishTruth>,
    pub cal: PathBuf,
    pub dots: PathBuf,
}

/// `count` fish from 0.6 to 4.5 m rendered into folder `name` (photos, `masks/`, truth),
/// with a calibration that is the rig's truth (a small covariance, depths 0.5-4.6 m) and
/// the true dots as a CSV.
pub fn fish_set(name: &str, count: usize, seed: u64) -> FishSet {
    {
        let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(dir.join("masks")).unwrap();
        let specs = fish_scene_set(count, seed, Water::Clear, 0.6, 4.5);
        let truths: Vec<FishTruth> = specs
            .par_iter()
            .enumerate()
            .map(|(i, spec)| {
                let fish = render_fish(spec);
                write_fish(&dir, &format!("fish_{i:02}"), &fish).unwrap();
                // Masks live in their own folder, as a segmenter's output would.
                std::fs::rename(
                    dir.join(format!("fish_{i:02}_mask.png")),
                    dir.join("masks").join(format!("fish_{i:02}.png")),
                )
                .unwrap();
                fish.truth
            })
            .collect();
        let photos: Vec<PathBuf> = (0..truths.len()).map(|i| dir.join(format!("fish_{i:02}.jpg"))).collect();
        let t = &truths[0];
        let laser = t.spec.laser.unwrap();
        let cal = dir.join("cal.json");
        let cal_json = json!({
            "camera": camera_json(&t.spec.camera),
            "laser": {
                "origin_m": laser.origin_m,
                "direction": laser.direction,
                "covariance": [[1e-8, 0.0, 0.0, 0.0], [0.0, 1e-8, 0.0, 0.0], [0.0, 0.0, 1e-9, 0.0], [0.0, 0.0, 0.0, 1e-9]],
            },
            "depth_range_m": [0.5, 4.6],
        });
        std::fs::write(&cal, serde_json::to_vec_pretty(&cal_json).unwrap()).unwrap();
        let dots = dir.join("dots.csv");
        let mut csv = String::from("file,x,y\n");
        for (p, t) in photos.iter().zip(&truths) {
            let d = t.dot.as_ref().expect("every fish has the dot on it");
            csv += &format!("{},{},{}\n", p.file_name().unwrap().to_string_lossy(), d.pixel[0], d.pixel[1]);
        }
        std::fs::write(&dots, csv).unwrap();
        FishSet { dir, photos, truths, cal, dots }
    }
}

/// A calibration of the TG-6 rig with `laser`, covering 0.45-2.2 m (the slate scenes'
/// depths), with independent variances for the origin's x and y (m²) and the direction's
/// slopes x/z and y/z.
pub fn tg6_calibration(laser: LaserLine, origin_var_m2: f64, slope_var: f64) -> fslcal::calibration::Calibration {
    let (o, d) = (origin_var_m2, slope_var);
    fslcal::calibration::Calibration {
        camera: calib_targets::rig::tg6_camera(),
        laser,
        laser_covariance: [[o, 0.0, 0.0, 0.0], [0.0, o, 0.0, 0.0], [0.0, 0.0, d, 0.0], [0.0, 0.0, 0.0, d]],
        depth_range_m: Some((0.45, 2.2)),
        unit: None,
        camera_serial: None,
        focal_length_mm: None,
        laser_colour: None,
        source: "test".into(),
    }
}

/// `from` copied to `to` with `copy` written after its end-of-image marker: decoders stop
/// at the marker, so the pixels are the same, but the bytes differ. fslcal uses a photo
/// given twice once (by its contents), so a dive of hard-linked copies would time a handful
/// of photos as a hundred.
pub fn distinct_copy(from: &Path, to: &Path, copy: usize) {
    let mut bytes = std::fs::read(from).unwrap();
    bytes.extend_from_slice(format!("fslcal bench copy {copy}").as_bytes());
    std::fs::write(to, bytes).unwrap();
}

/// `to` as a hard link to `from` (a copy where links are not possible).
pub fn link(from: &Path, to: &Path) {
    let _ = std::fs::remove_file(to);
    if std::fs::hard_link(from, to).is_err() {
        std::fs::copy(from, to).unwrap();
    }
}

/// The laser job a diver runs on photos of the FishSense board: the camera file
/// `camera_file` (OpenCV YAML), default gates and detector, no dot given by hand.
pub fn board_job(camera_file: &Path, method: Method) -> LaserJob {
    let (camera, _) = opencv_yaml::read(camera_file).expect("camera file");
    LaserJob {
        camera,
        target: Checkerboard::fishsense().into(),
        method,
        gates: Gates::default(),
        detector: DotDetectorParams::default(),
        hand_dots: HandDots::default(),
    }
}

/// The ground truth written beside a rendered variety photo.
pub fn variety_truth(photo: &Path) -> PhotoTruth {
    let text = std::fs::read_to_string(photo.with_extension("truth.json")).expect("truth file");
    serde_json::from_str(&text).expect("truth parses")
}

/// Panics when `report`'s photo is used with a dot over 2 px from the truth's, or with no
/// dot in the truth: a wrong dot in the fit.
pub fn assert_used_dot_is_right(report: &PhotoReport, truth: &PhotoTruth) {
    if report.status != PhotoStatus::Used {
        return;
    }
    let dot = report.dot_px.expect("a used photo has a dot");
    let t = truth.dot.as_ref().unwrap_or_else(|| panic!("{}: used, but no dot in the truth", report.file));
    let err = (dot[0] - t.pixel[0]).hypot(dot[1] - t.pixel[1]);
    assert!(err <= 2.0, "{}: a wrong dot used in the fit, {err:.1} px from the truth", report.file);
}
