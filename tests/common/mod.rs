//! Rendered scene sets shared by the integration tests and the benchmark: rendered once per
//! test binary into a temporary folder, with their ground truth.
#![allow(dead_code)]

use calib_targets::scene::{laser_scene_set, render, render_slate, slate_scene_set, RenderedScene, SceneSpec, SceneTruth, SlateSpec, SlateTexture, Water};
use calib_targets::Slate;
use fslcal_core::{CameraModel, LaserLine};
use calib_targets::{camera_yaml, write_scene};
use rayon::prelude::*;
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
fn render_with(name: &str, count: usize, camera: &CameraModel, render_one: &(dyn Fn(usize) -> RenderedScene + Sync)) -> SceneSet {
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
pub fn slate_set(name: &str, laser: LaserLine, depths_m: (f64, f64), count: usize, seed: u64, water: Water, glints: u32) -> SceneSet {
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
pub fn camera_figures(cal: &fslcal::camera_calibration::CameraCalibration) -> String {
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
