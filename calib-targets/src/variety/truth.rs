//! What a randomised photo shows, exactly: written beside it as `NAME.truth.json`.

use super::look::{CameraEffects, LightLook, WaterLook};
use super::materials::{BoardLook, FishLook, ReefLook};
use super::unit::Unit;
use super::{Kind, SeedSplit};
use crate::scene::Pose;
use crate::Checkerboard;
use serde::{Deserialize, Serialize};

/// What the laser dot landed on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SurfaceKind {
    Board,
    Slate,
    Fish,
    Reef,
}

/// Why a photo has no laser dot.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum NoDot {
    LaserOff,
    /// The beam meets something whose image is outside the frame (a subject too close).
    OffFrame,
    /// Something nearer hides the dot from the camera (the laser sits beside the lens).
    Occluded,
    /// The beam runs into open water.
    NoSurface,
}

/// A thing that may be taken for the dot.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ImpostorKind {
    /// A small white specular highlight.
    Glint,
    /// The laser's own reflection: a fainter dot of the laser's colour elsewhere.
    Reflection,
    Bubble,
    /// Sunlight focused by the waves: a soft bright patch.
    SunFleck,
    /// A tuft of bright green algae on the reef.
    Algae,
    /// A yellow-green fin.
    Fin,
    /// Yellow-green tape on a board's margin or backing, or on a slate.
    Tape,
    /// A laminated board's broad specular sheen.
    Sheen,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Impostor {
    pub kind: ImpostorKind,
    /// Centre, pixels (OpenCV pixel-centre convention).
    pub pixel: [f64; 2],
    pub radius_px: f64,
}

/// The laser dot as rendered.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DotTruth {
    /// Centre, pixels (pixel-centre convention): the dot is radially symmetric about it,
    /// and every blur is centred.
    pub pixel: [f64; 2],
    /// Where the beam meets the surface, camera frame, metres.
    pub point_m: [f64; 3],
    pub depth_m: f64,
    /// From the laser's exit to the surface, metres.
    pub range_m: f64,
    pub surface: SurfaceKind,
    /// Radius of the beam's footprint, pixels.
    pub radius_px: f64,
    /// The core's level in the green channel before clipping, 8-bit levels (over 255:
    /// clipped).
    pub radiance_levels: f64,
    /// What the core adds to the green channel at the centre after blur, levels (before
    /// clipping): below a few noise sigmas the dot cannot be seen.
    pub peak_levels: f64,
    /// All three channels at or above 250 at the centre of the written photo.
    pub saturated: bool,
}

/// A fish in the photo.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FishTruth {
    pub snout_px: [f64; 2],
    pub fork_px: [f64; 2],
    pub fork_length_m: f64,
    pub depth_m: f64,
    /// The whole fish is inside the frame.
    pub in_frame: bool,
    pub look: FishLook,
}

/// The calibration target in the photo.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase", tag = "kind")]
pub enum TargetTruth {
    Board {
        board: Checkerboard,
        #[serde(rename = "T_cam_target")]
        t_cam_target: Pose,
        look: Box<BoardLook>,
        /// Projected inner corners in `Checkerboard::object_points` order, pixels.
        corners_px: Vec<[f64; 2]>,
    },
    Slate {
        width_m: f64,
        height_m: f64,
        #[serde(rename = "T_cam_target")]
        t_cam_target: Pose,
    },
}

/// Everything about one photo.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PhotoTruth {
    pub kind: Kind,
    pub set_seed: u64,
    pub split: SeedSplit,
    pub index: usize,
    pub image_size: [u32; 2],
    /// The set's camera and laser, exactly.
    pub unit: Unit,
    pub laser_on: bool,
    /// This photo's laser power over the unit's.
    pub power_factor: f64,
    pub dot: Option<DotTruth>,
    /// Why there is no dot, when there is none.
    pub no_dot: Option<NoDot>,
    pub water: WaterLook,
    pub light: LightLook,
    pub effects: CameraEffects,
    pub impostors: Vec<Impostor>,
    pub target: Option<TargetTruth>,
    pub fish: Vec<FishTruth>,
    pub reef: Option<ReefLook>,
}

/// A dot whose peak is under this many noise sigmas (at mid-grey) cannot be seen.
pub const VISIBLE_SIGMAS: f64 = 3.0;

impl PhotoTruth {
    /// The dot, if it is there and stands out of the noise by [`VISIBLE_SIGMAS`].
    pub fn visible_dot(&self) -> Option<&DotTruth> {
        let e = &self.effects;
        let sigma = (e.noise_read_levels.powi(2) + e.noise_shot_gain * 128.0).sqrt();
        self.dot.as_ref().filter(|d| d.peak_levels >= VISIBLE_SIGMAS * sigma)
    }
}
