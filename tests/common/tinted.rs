//! Small, low-contrast checkerboards in green and brown water: the photos a reduced search
//! misses and an open-ended search stalls on. The renderer has clear and murky water only,
//! so these are its murky scenes seen through more water, as water does it per channel:
//! `I = J t + B (1 - t)`, with `t` the transmission and `B` the water's own colour.

use super::SceneSet;
use calib_targets::scene::{render, Pose, SceneSpec, Water};
use calib_targets::{camera_yaml, write_scene, Checkerboard};
use image::RgbImage;
use rayon::prelude::*;
use std::path::Path;

/// The colour of the water's veil.
#[derive(Clone, Copy, Debug)]
pub enum Tint {
    /// Plankton-rich coastal water.
    Green,
    /// Tannin or silt.
    Brown,
}

impl Tint {
    /// Background radiance of a deep column of this water, 8-bit sRGB.
    pub fn veil(self) -> [f64; 3] {
        match self {
            Tint::Green => [35.0, 120.0, 75.0],
            Tint::Brown => [105.0, 85.0, 45.0],
        }
    }
}

/// Sees `image` through more water: each channel `J` becomes `J t + B (1 - t)`.
pub fn tint(image: &mut RgbImage, tint: Tint, transmission: f64) {
    let veil = tint.veil();
    for p in image.pixels_mut() {
        for (c, b) in p.0.iter_mut().zip(veil) {
            *c = (*c as f64 * transmission + b * (1.0 - transmission)).round().clamp(0.0, 255.0) as u8;
        }
    }
}

/// One small-board photo: a 13x9 board of `square_m` squares at `depth_m`, turned `yaw_rad`
/// about the vertical, its first corner at `(x, y)` times the depth (metres, camera frame),
/// or no board at all.
#[derive(Clone, Copy, Debug)]
pub struct SmallBoard {
    pub board: Option<Checkerboard>,
    pub depth_m: f64,
    pub yaw_rad: f64,
    pub at: (f64, f64),
    pub tint: Tint,
    pub transmission: f64,
    pub seed: u64,
}

/// The 13x9 board of the stalled run, with 30 mm squares.
pub fn board_13x9() -> Checkerboard {
    Checkerboard { inner_cols: 13, inner_rows: 9, square_m: 0.03 }
}

impl SmallBoard {
    pub fn spec(&self) -> SceneSpec {
        let (s, c) = self.yaw_rad.sin_cos();
        let pose = Pose {
            rotation: [[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]],
            translation_m: [self.at.0 * self.depth_m, self.at.1 * self.depth_m, self.depth_m],
        };
        SceneSpec {
            camera: calib_targets::rig::tg6_camera(),
            laser: Some(calib_targets::rig::fsl_laser()),
            board: self.board.map(|b| (b, pose)),
            water: Water::Murky,
            glints: 0,
            impostor: false,
            seed: self.seed,
        }
    }
}

/// Renders `scenes` as `photo_NN.jpg` (with truth and `camera.yml`) into a fresh folder
/// `name` under cargo's per-target scratch folder.
pub fn small_board_set(name: &str, scenes: &[SmallBoard]) -> SceneSet {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("scratch folder");
    let written: Vec<_> = scenes
        .par_iter()
        .enumerate()
        .map(|(i, s)| {
            let mut scene = render(&s.spec());
            tint(&mut scene.image, s.tint, s.transmission);
            let name = format!("photo_{i:02}");
            write_scene(&dir, &name, &scene).expect("write scene");
            (dir.join(format!("{name}.jpg")), scene.truth)
        })
        .collect();
    let camera_file = dir.join("camera.yml");
    std::fs::write(&camera_file, camera_yaml(&calib_targets::rig::tg6_camera())).expect("write camera file");
    let (photos, truths) = written.into_iter().unzip();
    SceneSet { dir, photos, truths, camera_file }
}
