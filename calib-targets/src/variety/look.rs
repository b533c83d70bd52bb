//! The look of one photo, drawn at random: its water, its light, how the camera spoils it
//! (blur, noise, JPEG), and the look of a unit's laser dot.

use crate::random::SplitMix;
use crate::scene::WaterOptics;
use serde::{Deserialize, Serialize};

/// The kind of water, each with continuous variation within it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum WaterType {
    /// Blue open ocean: blue travels furthest, the veil is blue.
    Ocean,
    /// Green coastal water: phytoplankton, a green veil.
    Coastal,
    /// Brown-green harbour water: dissolved organic matter eats blue, a murky yellow-brown veil.
    Harbour,
}

impl WaterType {
    pub const ALL: [WaterType; 3] = [WaterType::Ocean, WaterType::Coastal, WaterType::Harbour];

    pub fn name(self) -> &'static str {
        match self {
            WaterType::Ocean => "ocean",
            WaterType::Coastal => "coastal",
            WaterType::Harbour => "harbour",
        }
    }
}

/// The water of one photo, as drawn.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct WaterLook {
    #[serde(rename = "type")]
    pub kind: WaterType,
    /// 0 (clearest of its kind) to 1 (murkiest); scales attenuation, veil, blur and scatter.
    pub turbidity: f64,
    /// Attenuation per channel (R, G, B), 1/m, turbidity included.
    pub attenuation_per_m: [f64; 3],
    /// Backscatter veil at infinite range per channel, 8-bit levels.
    pub veil: [f64; 3],
    /// Colour of the daylight that reaches the scene (its own path from the surface).
    pub light_colour: [f64; 3],
    /// Gaussian blur of the whole photo (forward scatter and optics), pixels at this size.
    pub blur_sigma_px: f64,
    /// Forward scatter around the dot: halo width over the dot's and its strength.
    pub halo_width: f64,
    pub halo_strength: f64,
}

/// Ranges per water type: attenuation (R, G, B) 1/m, veil levels, light colour.
struct WaterRanges {
    attenuation: [(f64, f64); 3],
    veil: [(f64, f64); 3],
    light: [(f64, f64); 3],
}

fn ranges(kind: WaterType) -> WaterRanges {
    match kind {
        WaterType::Ocean => WaterRanges {
            attenuation: [(0.30, 0.55), (0.05, 0.10), (0.03, 0.07)],
            veil: [(4.0, 14.0), (35.0, 65.0), (60.0, 105.0)],
            light: [(0.55, 0.75), (0.85, 0.95), (1.0, 1.0)],
        },
        WaterType::Coastal => WaterRanges {
            attenuation: [(0.40, 0.65), (0.10, 0.20), (0.18, 0.35)],
            veil: [(8.0, 22.0), (58.0, 95.0), (30.0, 56.0)],
            light: [(0.60, 0.80), (1.0, 1.0), (0.70, 0.85)],
        },
        WaterType::Harbour => WaterRanges {
            attenuation: [(0.55, 0.90), (0.35, 0.60), (0.60, 1.10)],
            veil: [(30.0, 58.0), (45.0, 72.0), (18.0, 38.0)],
            light: [(0.90, 1.0), (0.95, 1.0), (0.50, 0.70)],
        },
    }
}

impl WaterLook {
    /// Ocean 40%, coastal 35%, harbour 25%; `scale` is the photo's width over 4000 px.
    pub(crate) fn draw(rng: &mut SplitMix, scale: f64) -> WaterLook {
        let u = rng.unit();
        let kind = if u < 0.40 {
            WaterType::Ocean
        } else if u < 0.75 {
            WaterType::Coastal
        } else {
            WaterType::Harbour
        };
        let r = ranges(kind);
        let turbidity = rng.unit();
        let mut draw3 = |rr: [(f64, f64); 3]| rr.map(|(a, b)| rng.range(a, b));
        let attenuation = draw3(r.attenuation).map(|a| a * (1.0 + 1.2 * turbidity));
        let veil = draw3(r.veil).map(|v| v * (0.8 + 0.5 * turbidity));
        let light_colour = draw3(r.light);
        WaterLook {
            kind,
            turbidity,
            attenuation_per_m: attenuation,
            veil,
            light_colour,
            blur_sigma_px: (0.5 + 1.5 * turbidity) * scale,
            halo_width: 1.0 + 1.5 * turbidity,
            halo_strength: 0.04 + 0.12 * turbidity,
        }
    }

    /// As the fixed-water renderer describes water (its noise is drawn separately here).
    pub(crate) fn optics(&self) -> WaterOptics {
        WaterOptics {
            attenuation_per_m: self.attenuation_per_m,
            veil: self.veil,
            blur_sigma_px: self.blur_sigma_px,
            noise_levels: 0.0,
            halo_width: self.halo_width,
            halo_strength: self.halo_strength,
        }
    }
}

/// Daylight on the scene: its level, a gradient across the frame (brighter toward the
/// surface), vignetting, and caustics (sunlight focused by surface waves).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LightLook {
    /// Multiplies the renderer's illumination (a perfect white at zero range, 265 levels).
    pub level: f64,
    /// Direction the light increases toward, image angle in degrees (-90: up).
    pub gradient_angle_deg: f64,
    /// Relative change across the frame's diagonal.
    pub gradient_strength: f64,
    /// Darkening in the frame's corners, share.
    pub vignette: f64,
    /// Caustic network strength (share of the light) and its cell size in the scene, metres.
    pub caustic_strength: f64,
    pub caustic_cell_m: f64,
    pub caustic_seed: u64,
}

impl LightLook {
    pub(crate) fn draw(rng: &mut SplitMix, water: WaterType) -> LightLook {
        let caustics = match water {
            WaterType::Harbour => 0.15,
            _ => 0.55,
        };
        LightLook {
            level: rng.range(0.6, 1.3),
            gradient_angle_deg: -90.0 + rng.range(-50.0, 50.0),
            gradient_strength: rng.range(0.0, 0.45),
            vignette: rng.range(0.0, 0.35),
            caustic_strength: if rng.unit() < 0.5 { rng.range(0.0, caustics) } else { 0.0 },
            caustic_cell_m: rng.range(0.08, 0.35),
            caustic_seed: rng.next_u64(),
        }
    }
}

/// How the camera spoils the photo.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CameraEffects {
    pub jpeg_quality: u8,
    /// Read noise, 8-bit levels, 1 sigma.
    pub noise_read_levels: f64,
    /// Shot noise: variance per level of signal.
    pub noise_shot_gain: f64,
    /// Length of a straight motion streak, pixels at this size (0: none), and its angle.
    pub motion_blur_px: f64,
    pub motion_blur_angle_deg: f64,
}

impl CameraEffects {
    pub(crate) fn draw(rng: &mut SplitMix, scale: f64) -> CameraEffects {
        let u = rng.unit();
        // Most photos are steady; some shake a little, a few a lot.
        let streak = if u < 0.6 {
            rng.range(0.0, 1.5)
        } else if u < 0.9 {
            rng.range(1.5, 5.0)
        } else {
            rng.range(5.0, 12.0)
        };
        CameraEffects {
            jpeg_quality: 75 + rng.below(21) as u8,
            // In-camera JPEGs are denoised: 1.5-5.5 levels at a bright 200, as a TG-6 from ISO
            // 100 in sunlit water to ISO 1600 in a murky harbour.
            noise_read_levels: rng.range(0.8, 3.0),
            noise_shot_gain: rng.range(0.01, 0.15),
            motion_blur_px: streak * scale,
            motion_blur_angle_deg: rng.range(0.0, 180.0),
        }
    }
}

/// A unit's laser as its dots look: fixed per unit (one pointer, one sensor).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LaserLook {
    /// 515-532 nm is pure green (DPSS 532 nm, diode 520 nm); up to 560 nm yellow-green.
    pub wavelength_nm: f64,
    /// How the wavelength lands in the camera's R, G, B (colour filter cross-talk), G = 1.
    pub chroma: [f64; 3],
    /// Power relative to the renderer's reference pointer.
    pub power: f64,
    pub beam_diameter_m: f64,
    /// Full divergence, radians.
    pub divergence_rad: f64,
    /// Share of the missing channels a very bright dot picks up (sensor cross-talk), so that
    /// near dots clip to white in all three channels.
    pub crosstalk: f64,
    /// Blooming around bright dots: strength (share of the core) and width over the dot's.
    pub bloom_strength: f64,
    pub bloom_width: f64,
}

/// Camera response to a monochromatic source (R, G, B with G = 1), by wavelength.
fn chroma_of(wavelength_nm: f64) -> [f64; 3] {
    const TABLE: [(f64, [f64; 3]); 4] = [
        (515.0, [0.05, 1.0, 0.55]),
        (532.0, [0.25, 1.0, 0.30]),
        (545.0, [0.45, 1.0, 0.15]),
        (560.0, [0.75, 1.0, 0.08]),
    ];
    let l = wavelength_nm.clamp(TABLE[0].0, TABLE[3].0);
    let k = TABLE.windows(2).position(|w| l <= w[1].0).unwrap_or(2);
    let ((a, ca), (b, cb)) = (TABLE[k], TABLE[k + 1]);
    let t = (l - a) / (b - a);
    [0, 1, 2].map(|i| ca[i] + (cb[i] - ca[i]) * t)
}

impl LaserLook {
    pub(crate) fn draw(rng: &mut SplitMix) -> LaserLook {
        // Two thirds pure green, a third toward yellow-green.
        let wavelength_nm = if rng.unit() < 0.67 { rng.range(515.0, 533.0) } else { rng.range(533.0, 560.0) };
        let base = chroma_of(wavelength_nm);
        let chroma = [(base[0] + rng.range(-0.04, 0.04)).max(0.0), 1.0, (base[2] + rng.range(-0.04, 0.04)).max(0.0)];
        LaserLook {
            wavelength_nm,
            chroma,
            // Pointers from 1 mW to tens of mW: near dots of most clip all three channels.
            power: (rng.range(0.5f64.ln(), 8.0f64.ln())).exp(),
            beam_diameter_m: rng.range(0.0015, 0.005),
            divergence_rad: rng.range(0.0005, 0.0015),
            crosstalk: rng.range(0.1, 0.4),
            bloom_strength: rng.range(0.01, 0.08),
            bloom_width: rng.range(2.0, 5.0),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chroma_runs_from_green_to_yellow_green() {
        let green = chroma_of(520.0);
        let yellow = chroma_of(560.0);
        assert!(green[0] < 0.15 && green[2] > 0.4, "{green:?}");
        assert!(yellow[0] > 0.7 && yellow[2] < 0.1, "{yellow:?}");
        assert_eq!(chroma_of(532.0), [0.25, 1.0, 0.30]);
    }

    #[test]
    fn water_types_differ_as_named() {
        let mut rng = SplitMix::new(4);
        let mut seen = std::collections::BTreeMap::new();
        for _ in 0..300 {
            let w = WaterLook::draw(&mut rng, 1.0);
            let [r, g, b] = w.veil;
            match w.kind {
                WaterType::Ocean => assert!(b > g && g > r, "{w:?}"),
                WaterType::Coastal => assert!(g > b && g > r, "{w:?}"),
                WaterType::Harbour => assert!(w.attenuation_per_m[2] > w.attenuation_per_m[1] && b < g, "{w:?}"),
            }
            *seen.entry(w.kind).or_insert(0) += 1;
        }
        assert_eq!(seen.len(), 3, "{seen:?}");
    }
}
