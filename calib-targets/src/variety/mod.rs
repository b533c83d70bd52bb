//! Randomised underwater photo sets with exact truth, for measuring a laser-dot detector on
//! scenes it was not tuned on (issue 14, `docs/scene-variety.md`).
//!
//! Every photo draws, independently of the others: the water (blue ocean, green coastal,
//! brown harbour, each varying continuously in colour and turbidity), the daylight (level,
//! gradient, vignetting, caustics), what the target is made of (paper white, cream, grey or
//! laminated with a sheen; slate plastics and tapes), fish skins and fins, the reef, the
//! camera's blur, motion streak, noise and JPEG quality (75-95), and impostors: specular
//! glints, yellow-green tape, green fins and algae, the laser's own reflection, bubbles, sun
//! flecks, the laser switched off. A *set* is one unit (one camera, one laser with its own
//! colour, power and beam, and the camera's tone curve, [`unit`]) and its photos:
//!
//! - [`Kind::Calibration`]: 12-16 photos of the FishSense checkerboard at 0.55-5 m, the dot
//!   on it, for `fslcal laser --target checkerboard:14x10@42.17mm`;
//! - [`Kind::Slate`]: 12-16 photos of the set's own taped slate at 0.5-2.5 m (its scan and
//!   definition are written with the set), for `fslcal laser --target slate:...`;
//! - [`Kind::Targetless`]: 20 photos of fish and reef with the dot on a fish or the reef,
//!   hidden, off the frame or switched off, for `fslcal check` and `fslcal measure` with the
//!   unit's true calibration.
//!
//! # Seeds: tuning and held out
//!
//! A set is named by its kind and a seed. Seeds below [`HELD_OUT_FIRST_SEED`] (1 000 000)
//! are for tuning: look at them, fit thresholds to them. Seeds from 1 000 000 up are held
//! out: a detector is *reported* on them and nobody looks at them while tuning. The
//! evaluation (`benches/dot_generalisation.rs`) runs on held-out seeds unless told
//! otherwise. The same seed of different kinds gives unrelated sets.
//!
//! Photos are 4000x3000 like the TG-6's; a smaller width (a multiple of 4, 4:3) renders the
//! same camera scaled down, with every pixel size (blur, streaks, glints) scaled with it.

mod impostors;
mod kinds;
pub mod look;
pub mod materials;
mod render;
pub mod truth;
pub mod unit;

pub use kinds::{BOARD_DEPTHS_M, SLATE_DEPTHS_M};
pub use truth::{DotTruth, FishTruth, Impostor, ImpostorKind, NoDot, PhotoTruth, SurfaceKind, TargetTruth};
pub use unit::{calibration_json, Unit};

use crate::random::SplitMix;
use crate::scene::SlateTexture;
use crate::slate::{slate_toml, taped_slate_scan_with};
use crate::Checkerboard;
use fslcal_core::Vec3;
use image::RgbImage;
use render::{Body, PhotoPlan};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::str::FromStr;
use std::sync::Arc;

/// The first held-out seed: seeds below it are for tuning, seeds from it up are reported on.
pub const HELD_OUT_FIRST_SEED: u64 = 1_000_000;

/// Which side of the tuning / held-out partition a seed is on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SeedSplit {
    Tuning,
    HeldOut,
}

impl SeedSplit {
    pub fn of(seed: u64) -> SeedSplit {
        if seed < HELD_OUT_FIRST_SEED {
            SeedSplit::Tuning
        } else {
            SeedSplit::HeldOut
        }
    }
}

/// The kind of set.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Kind {
    Calibration,
    Slate,
    Targetless,
}

impl Kind {
    pub const ALL: [Kind; 3] = [Kind::Calibration, Kind::Slate, Kind::Targetless];

    pub fn name(self) -> &'static str {
        match self {
            Kind::Calibration => "calibration",
            Kind::Slate => "slate",
            Kind::Targetless => "targetless",
        }
    }

    fn salt(self) -> u64 {
        match self {
            Kind::Calibration => 0xCA1B,
            Kind::Slate => 0x51A7,
            Kind::Targetless => 0xF15B,
        }
    }
}

impl FromStr for Kind {
    type Err = String;
    fn from_str(s: &str) -> Result<Kind, String> {
        Kind::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| format!("unknown kind `{s}`: expected calibration, slate or targetless"))
    }
}

#[derive(Debug, thiserror::Error)]
pub enum VarietyError {
    #[error("photo width {0} px: expected a multiple of 4 from 400 to 4000 (photos are 4:3)")]
    Width(u32),
    #[error("{count} photos: a set has 1 to 200")]
    Count { count: usize },
    #[error("{path}: cannot write: {source}")]
    Write { path: String, source: std::io::Error },
}

/// A set's taped slate: its scan, size and known lengths (scan millimetres).
pub struct SetSlate {
    pub scan: RgbImage,
    pub width_mm: f64,
    pub height_mm: f64,
    pub lengths: Vec<(&'static str, [f64; 2], [f64; 2])>,
    texture: Arc<SlateTexture>,
    /// Yellow-green tapes' centres, slate metres.
    green_tapes_m: Vec<[f64; 2]>,
}

/// A set planned: its unit and every photo's plan, rendered on demand (a 4000x3000 photo
/// takes about 150 MB while it is rendered).
pub struct VarietySet {
    pub kind: Kind,
    pub seed: u64,
    pub unit: Unit,
    pub slate: Option<SetSlate>,
    plans: Vec<PhotoPlan>,
}

/// A rendered photo and its truth.
pub struct VarietyPhoto {
    pub image: RgbImage,
    pub truth: PhotoTruth,
}

fn draw_slate(rng: &mut SplitMix) -> SetSlate {
    let width_mm = rng.range(220.0, 320.0).round();
    let height_mm = (width_mm * rng.range(0.65, 0.8)).round();
    let look = materials::draw_slate_look(rng, width_mm, height_mm);
    let scan = taped_slate_scan_with(rng.next_u64(), width_mm, height_mm, 2.0, &look);
    let texture = Arc::new(SlateTexture::new(&scan, width_mm * 1e-3, height_mm * 1e-3));
    let green_tapes_m = look.extra_tapes.iter().map(|t| t.centre.map(|c| c * 1e-3)).collect();
    let (m, w, h) = (15.0, width_mm, height_mm);
    let lengths = vec![("diagonal", [m, m], [w - m, h - m]), ("across", [m, 0.5 * h], [w - m, 0.5 * h])];
    SetSlate { scan, width_mm, height_mm, lengths, texture, green_tapes_m }
}

impl VarietySet {
    /// Plans set `seed` of `kind` with photos `width_px` wide; `count` photos, or as many as
    /// the seed draws (12-16 of a target, 20 without).
    pub fn plan(kind: Kind, seed: u64, count: Option<usize>, width_px: u32) -> Result<VarietySet, VarietyError> {
        if !(400..=4000).contains(&width_px) || width_px % 4 != 0 {
            return Err(VarietyError::Width(width_px));
        }
        let key = SplitMix::derive(seed, kind.salt()).next_u64();
        let mut rng = SplitMix::derive(key, 1);
        let count = count.unwrap_or(match kind {
            Kind::Targetless => 20,
            _ => 12 + rng.below(5) as usize,
        });
        if !(1..=200).contains(&count) {
            return Err(VarietyError::Count { count });
        }
        let unit = unit::draw_unit(key, width_px);
        let slate = (kind == Kind::Slate).then(|| draw_slate(&mut rng));
        let plans = (0..count)
            .map(|i| match (kind, &slate) {
                (Kind::Calibration, _) => kinds::calibration_photo(&unit, key, i, count),
                (Kind::Slate, Some(s)) => kinds::slate_photo(&unit, &s.texture, &s.green_tapes_m, key, i, count),
                _ => kinds::targetless_photo(&unit, key, i),
            })
            .collect();
        Ok(VarietySet { kind, seed, unit, slate, plans })
    }

    /// The same set through another camera tone curve (1: linear), every other draw as it
    /// was: for a test whose photos were chosen for what they show without a curve.
    pub fn with_tone_gamma(mut self, gamma: f64) -> VarietySet {
        self.unit.tone_gamma = gamma;
        for p in &mut self.plans {
            p.tone_gamma = gamma;
        }
        self
    }

    pub fn len(&self) -> usize {
        self.plans.len()
    }

    pub fn is_empty(&self) -> bool {
        self.plans.is_empty()
    }

    /// The calibration a diver would have made of this set's unit before taking its photos:
    /// `count` checkerboard photos of the same camera and laser (new scenes, water and
    /// looks), under the same seed. `check` and `measure` are then run with what `fslcal
    /// laser` made of them (its fit and the laser colour it learned), not with the truth.
    pub fn companion_calibration(&self, count: usize) -> Result<VarietySet, VarietyError> {
        if !(2..=200).contains(&count) {
            return Err(VarietyError::Count { count });
        }
        let key = SplitMix::derive(self.seed, Kind::Calibration.salt() ^ self.kind.salt() ^ 0xC0).next_u64();
        let plans = (0..count).map(|i| kinds::calibration_photo(&self.unit, key, i, count)).collect();
        Ok(VarietySet { kind: Kind::Calibration, seed: self.seed, unit: self.unit.clone(), slate: None, plans })
    }

    /// Renders photo `index`.
    pub fn render(&self, index: usize) -> VarietyPhoto {
        let plan = &self.plans[index];
        let r = render::render(plan);
        let truth = PhotoTruth {
            kind: self.kind,
            set_seed: self.seed,
            split: SeedSplit::of(self.seed),
            index,
            image_size: [plan.camera.width_px, plan.camera.height_px],
            unit: self.unit.clone(),
            laser_on: plan.laser.is_some(),
            power_factor: plan.power_factor,
            dot: r.dot.as_ref().ok().cloned(),
            no_dot: r.dot.as_ref().err().copied(),
            water: plan.water.clone(),
            light: plan.light.clone(),
            effects: plan.effects.clone(),
            impostors: r.impostors,
            target: target_truth(plan),
            fish: fish_truths(plan),
            reef: plan.objects.iter().find_map(|o| match &o.body {
                Body::Reef { look } => Some(look.clone()),
                _ => None,
            }),
        };
        VarietyPhoto { image: r.image, truth }
    }

    /// Writes the set into `dir`: `photo_NN.jpg` with `photo_NN.truth.json`, `camera.yml`,
    /// `cal.json` (the unit's truth as a `--cal` file), `set.json`, and for a slate set
    /// `slate.toml` with `slate_scan.png`. Photos are rendered one after the other (each
    /// uses every core); `on_photo` is called with each photo written. Returns the photos.
    pub fn write(&self, dir: &Path, on_photo: &mut dyn FnMut(&Path)) -> Result<Vec<PathBuf>, VarietyError> {
        let err = |path: &Path| {
            let path = path.display().to_string();
            move |source| VarietyError::Write { path, source }
        };
        std::fs::create_dir_all(dir).map_err(err(dir))?;
        let camera = dir.join("camera.yml");
        crate::write_camera_yaml(&camera, &self.unit.camera).map_err(err(&camera))?;
        let cal = dir.join("cal.json");
        let cal_json = calibration_json(&self.unit, (0.5, 5.0));
        crate::output::write_json(&cal, &cal_json).map_err(err(&cal))?;
        let set = dir.join("set.json");
        crate::output::write_json(&set, &self.summary()).map_err(err(&set))?;
        if let Some(s) = &self.slate {
            let scan = dir.join("slate_scan.png");
            crate::output::write_png(&scan, &s.scan).map_err(err(&scan))?;
            let toml = dir.join("slate.toml");
            std::fs::write(&toml, slate_toml("slate_scan.png", s.width_mm, s.height_mm, &s.lengths))
                .map_err(err(&toml))?;
        }
        let mut photos = Vec::new();
        for i in 0..self.len() {
            let photo = self.render(i);
            let name = format!("photo_{i:02}");
            let q = photo.truth.effects.jpeg_quality;
            crate::output::write_photo(dir, &name, &photo.image, q, &photo.truth).map_err(err(&dir.join(&name)))?;
            let path = dir.join(format!("{name}.jpg"));
            on_photo(&path);
            photos.push(path);
        }
        Ok(photos)
    }

    /// A digest of every photo's plan (scene, looks, effects): two sets with the same
    /// digest render the same photos with the same renderer code, so a folder written by an
    /// older plan is not taken for this set.
    pub fn plan_digest(&self) -> String {
        use std::hash::Hasher;
        struct Digest(std::collections::hash_map::DefaultHasher);
        impl std::fmt::Write for Digest {
            fn write_str(&mut self, s: &str) -> std::fmt::Result {
                self.0.write(s.as_bytes());
                Ok(())
            }
        }
        let mut d = Digest(std::collections::hash_map::DefaultHasher::new());
        let _ = std::fmt::Write::write_fmt(&mut d, format_args!("{:?}", self.plans));
        format!("{:016x}", d.0.finish())
    }

    /// What `set.json` says: kind, seed, split, the unit, the photo count, the target, the
    /// plans' digest.
    pub fn summary(&self) -> serde_json::Value {
        serde_json::json!({
            "kind": self.kind,
            "seed": self.seed,
            "split": SeedSplit::of(self.seed),
            "photos": self.len(),
            "plan_digest": self.plan_digest(),
            "unit": self.unit,
            "target": match (self.kind, &self.slate) {
                (Kind::Calibration, _) => Some(Checkerboard::fishsense().to_string()),
                (Kind::Slate, Some(_)) => Some("slate:slate.toml".to_string()),
                _ => None,
            },
        })
    }
}

fn target_truth(plan: &PhotoPlan) -> Option<TargetTruth> {
    plan.objects.iter().find_map(|o| match &o.body {
        Body::Board { board, look } => Some(TargetTruth::Board {
            board: *board,
            t_cam_target: o.pose,
            look: Box::new(look.clone()),
            corners_px: board
                .object_points()
                .iter()
                .filter_map(|p| plan.camera.project(&o.pose.apply(&Vec3::from(*p))))
                .map(|p| [p.x, p.y])
                .collect(),
        }),
        Body::Slate { texture, .. } => {
            Some(TargetTruth::Slate { width_m: texture.width_m, height_m: texture.height_m, t_cam_target: o.pose })
        }
        _ => None,
    })
}

fn fish_truths(plan: &PhotoPlan) -> Vec<FishTruth> {
    let project = |pose: &crate::fish::FishPose, q| plan.camera.project(&pose.camera_point(q)).map(|p| [p.x, p.y]);
    plan.objects
        .iter()
        .filter_map(|o| match &o.body {
            Body::Fish { shape, look, pose } => Some(FishTruth {
                snout_px: project(pose, shape.spine_point(0.0))?,
                fork_px: project(pose, shape.spine_point(shape.fork_length_m))?,
                fork_length_m: shape.fork_length_m,
                depth_m: pose.depth_m,
                in_frame: crate::fish::fish_in_frame(&plan.camera, shape, pose, 0.0),
                look: look.clone(),
            }),
            _ => None,
        })
        .collect()
}

#[cfg(test)]
mod tests;
