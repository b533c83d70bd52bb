//! The dive slate as a calibration target: a scan of the slate with pieces of duct tape on
//! it (thesis §3.5), its physical size, and lengths between marked points, read from a small
//! TOML file (`docs/slate.md`):
//!
//! ```toml
//! scan = "scan.png"          # relative to this file
//! width_mm = 300.0           # what the scan's full extent covers
//! height_mm = 220.0
//!
//! [[length]]
//! name = "tape-edge"
//! from_mm = [31.5, 40.0]     # scan millimetres: x right, y down from the scan's top-left edge
//! to_mm = [262.0, 40.0]
//! ```
//!
//! Target frame (`docs/conventions.md`): origin at the scan's top-left edge, x right, y down,
//! z into the slate, metres. Scan pixel `(i, j)` (pixel-centre convention) is at
//! `((i + 0.5) w / W, (j + 0.5) h / H)`.

use crate::random::SplitMix;
use crate::scene::value_noise;
use image::RgbImage;
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// A known length on the slate, between two points in the target frame.
#[derive(Clone, Debug, PartialEq)]
pub struct KnownLength {
    pub name: String,
    pub from_m: [f64; 2],
    pub to_m: [f64; 2],
}

impl KnownLength {
    pub fn length_m(&self) -> f64 {
        ((self.to_m[0] - self.from_m[0]).powi(2) + (self.to_m[1] - self.from_m[1]).powi(2)).sqrt()
    }
}

/// A slate definition with its scan's path resolved.
#[derive(Clone, Debug, PartialEq)]
pub struct Slate {
    /// The TOML file it was read from.
    pub definition: PathBuf,
    pub scan: PathBuf,
    pub width_m: f64,
    pub height_m: f64,
    pub lengths: Vec<KnownLength>,
}

#[derive(Debug, thiserror::Error)]
pub enum SlateError {
    #[error("{path}: cannot read the slate definition: {source}")]
    Io { path: String, source: std::io::Error },
    #[error("{path}: not a slate definition ({why}); see docs/slate.md")]
    Format { path: String, why: String },
    #[error("{path}: cannot read the slate's scan {scan}: {why}")]
    Scan { path: String, scan: String, why: String },
    #[error("{path}: the scan {scan} is {w}x{h} px but the slate is {width_mm}x{height_mm} mm: the aspect ratios differ by {diff_pct:.1}% (wrong size or unit? sizes are millimetres)")]
    Aspect { path: String, scan: String, w: u32, h: u32, width_mm: f64, height_mm: f64, diff_pct: f64 },
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SlateToml {
    scan: String,
    width_mm: f64,
    height_mm: f64,
    #[serde(default)]
    length: Vec<LengthToml>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct LengthToml {
    name: String,
    from_mm: [f64; 2],
    to_mm: [f64; 2],
}

impl Slate {
    /// Reads and checks a slate definition; the scan's size is checked against the physical
    /// size (its header only, not its pixels).
    pub fn load(path: &Path) -> Result<Slate, SlateError> {
        let name = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|source| SlateError::Io { path: name.clone(), source })?;
        let format = |why: String| SlateError::Format { path: name.clone(), why };
        let t: SlateToml = toml::from_str(&text).map_err(|e| format(e.message().to_string()))?;
        for (what, v) in [("width_mm", t.width_mm), ("height_mm", t.height_mm)] {
            if !(10.0..=2000.0).contains(&v) {
                return Err(format(format!("{what} = {v} is not a plausible slate size in millimetres (10-2000)")));
            }
        }
        let inside = |p: [f64; 2]| (0.0..=t.width_mm).contains(&p[0]) && (0.0..=t.height_mm).contains(&p[1]);
        let mut lengths = Vec::new();
        for l in &t.length {
            if !inside(l.from_mm) || !inside(l.to_mm) {
                return Err(format(format!(
                    "length `{}` has a point outside the {}x{} mm scan",
                    l.name, t.width_mm, t.height_mm
                )));
            }
            let k = KnownLength {
                name: l.name.clone(),
                from_m: l.from_mm.map(|v| v * 1e-3),
                to_m: l.to_mm.map(|v| v * 1e-3),
            };
            if k.length_m() < 0.01 {
                return Err(format(format!("length `{}` is shorter than 10 mm", l.name)));
            }
            if lengths.iter().any(|o: &KnownLength| o.name == l.name) {
                return Err(format(format!("two lengths are named `{}`", l.name)));
            }
            lengths.push(k);
        }
        let scan = path.parent().unwrap_or(Path::new(".")).join(&t.scan);
        let (w, h) = image::image_dimensions(&scan).map_err(|e| SlateError::Scan {
            path: name.clone(),
            scan: scan.display().to_string(),
            why: e.to_string(),
        })?;
        let diff_pct = 100.0 * ((w as f64 / h as f64) / (t.width_mm / t.height_mm) - 1.0).abs();
        if diff_pct > 2.0 {
            return Err(SlateError::Aspect {
                path: name,
                scan: scan.display().to_string(),
                w,
                h,
                width_mm: t.width_mm,
                height_mm: t.height_mm,
                diff_pct,
            });
        }
        Ok(Slate {
            definition: path.to_path_buf(),
            scan,
            width_m: t.width_mm * 1e-3,
            height_m: t.height_mm * 1e-3,
            lengths,
        })
    }

    /// The scan's pixels.
    pub fn read_scan(&self) -> Result<RgbImage, SlateError> {
        image::open(&self.scan).map(|i| i.to_rgb8()).map_err(|e| SlateError::Scan {
            path: self.definition.display().to_string(),
            scan: self.scan.display().to_string(),
            why: e.to_string(),
        })
    }

    /// The slate's corners in the target frame, metres, clockwise from the top-left.
    pub fn outline_m(&self) -> [[f64; 3]; 4] {
        let (w, h) = (self.width_m, self.height_m);
        [[0.0, 0.0, 0.0], [w, 0.0, 0.0], [w, h, 0.0], [0.0, h, 0.0]]
    }

    /// Target-frame point (metres) of a scan pixel `(i, j)` of a `scan_w x scan_h` scan.
    pub fn scan_px_to_m(&self, (scan_w, scan_h): (u32, u32), i: f64, j: f64) -> [f64; 3] {
        [(i + 0.5) * self.width_m / scan_w as f64, (j + 0.5) * self.height_m / scan_h as f64, 0.0]
    }

    /// The known length called `name`, or the first one when `name` is `None`.
    pub fn length(&self, name: Option<&str>) -> Option<&KnownLength> {
        match name {
            Some(n) => self.lengths.iter().find(|l| l.name == n),
            None => self.lengths.first(),
        }
    }
}

/// One piece of tape: a rotated strip with torn ends.
#[derive(Clone, Debug, PartialEq)]
pub struct Tape {
    /// Scan millimetres.
    pub centre: [f64; 2],
    /// Unit vector along the strip.
    pub along: [f64; 2],
    pub half_len: f64,
    pub half_width: f64,
    /// Albedo, 0-1.
    pub colour: [f64; 3],
    pub seed: u64,
}

/// What a taped slate is made of: the plastic, its rim, the tapes' colours, and tapes stuck
/// on last (on top of the others).
#[derive(Clone, Debug, PartialEq)]
pub struct SlateLook {
    pub plastic: [f64; 3],
    pub rim: [f64; 3],
    /// The first six tapes alternate between the first two colours, the other six draw.
    pub palette: Vec<[f64; 3]>,
    pub extra_tapes: Vec<Tape>,
}

impl SlateLook {
    /// The example slate's look: white plastic, grey rim, silver, black, red and blue tape.
    pub fn example() -> SlateLook {
        SlateLook {
            plastic: [0.88, 0.89, 0.87],
            rim: [0.45; 3],
            // No yellow or green tape: under water, where red is absorbed first, yellow turns
            // as green as the laser's dot (docs/slate.md).
            palette: vec![
                [0.62, 0.63, 0.64],
                [0.55, 0.56, 0.58],
                [0.12, 0.12, 0.13],
                [0.75, 0.18, 0.15],
                [0.15, 0.35, 0.70],
            ],
            extra_tapes: Vec::new(),
        }
    }
}

/// A synthetic taped dive slate as a scanner would see it, `px_per_mm` pixels per
/// millimetre: a white plastic slate with a grey rim, pencil scribbles, and a dozen pieces
/// of duct tape (silver, black, coloured) with woven texture and torn ends, overlapping. The
/// point is a surface as feature-rich, and as irregular, as a real taped slate.
pub fn taped_slate_scan(seed: u64, width_mm: f64, height_mm: f64, px_per_mm: f64) -> RgbImage {
    taped_slate_scan_with(seed, width_mm, height_mm, px_per_mm, &SlateLook::example())
}

/// [`taped_slate_scan`] in another look.
pub fn taped_slate_scan_with(seed: u64, width_mm: f64, height_mm: f64, px_per_mm: f64, look: &SlateLook) -> RgbImage {
    let (w, h) = ((width_mm * px_per_mm).round() as u32, (height_mm * px_per_mm).round() as u32);
    let mut rng = SplitMix::derive(seed, 0x51A7E);
    let palette = &look.palette;
    let mut tapes: Vec<Tape> = (0..12)
        .map(|k| {
            let angle = rng.range(0.0, std::f64::consts::PI);
            Tape {
                centre: [rng.range(0.12, 0.88) * width_mm, rng.range(0.12, 0.88) * height_mm],
                along: [angle.cos(), angle.sin()],
                half_len: rng.range(20.0, 60.0),
                half_width: rng.range(11.0, 25.0),
                colour: palette[if k < 6 { k % 2 } else { rng.below(palette.len() as u64) as usize }],
                seed: rng.next_u64(),
            }
        })
        .collect();
    tapes.extend(look.extra_tapes.iter().cloned());
    let strokes: Vec<([f64; 2], [f64; 2])> = (0..40)
        .map(|_| {
            let a = [rng.range(0.05, 0.95) * width_mm, rng.range(0.05, 0.95) * height_mm];
            let t = rng.range(0.0, std::f64::consts::TAU);
            let l = rng.range(5.0, 25.0);
            (a, [a[0] + l * t.cos(), a[1] + l * t.sin()])
        })
        .collect();
    RgbImage::from_fn(w, h, |i, j| {
        let (x, y) = ((i as f64 + 0.5) / px_per_mm, (j as f64 + 0.5) / px_per_mm);
        let c = slate_albedo(look, &tapes, &strokes, (width_mm, height_mm), seed, x, y);
        image::Rgb(c.map(|k| (k * 255.0).round().clamp(0.0, 255.0) as u8))
    })
}

/// The slate's albedo at scan millimetres `(x, y)`: plastic or rim, pencil, tapes in order.
fn slate_albedo(
    look: &SlateLook,
    tapes: &[Tape],
    strokes: &[([f64; 2], [f64; 2])],
    (width_mm, height_mm): (f64, f64),
    seed: u64,
    x: f64,
    y: f64,
) -> [f64; 3] {
    const RIM_MM: f64 = 5.0;
    let grain = 0.04 * (value_noise(seed, x, y, 1.5) - 0.5) + 0.06 * (value_noise(seed + 1, x, y, 9.0) - 0.5);
    let edge = x.min(y).min(width_mm - x).min(height_mm - y);
    let mut c = if edge < RIM_MM { look.rim.map(|k| k + grain) } else { look.plastic.map(|k| k + grain) };
    for (a, b) in strokes {
        let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
        let t = (((x - a[0]) * dx + (y - a[1]) * dy) / (dx * dx + dy * dy)).clamp(0.0, 1.0);
        let d = ((x - a[0] - t * dx).powi(2) + (y - a[1] - t * dy).powi(2)).sqrt();
        if d < 0.6 {
            c = [0.3, 0.3, 0.32];
        }
    }
    for tape in tapes {
        let (px, py) = (x - tape.centre[0], y - tape.centre[1]);
        let s = px * tape.along[0] + py * tape.along[1];
        let t = -px * tape.along[1] + py * tape.along[0];
        // Torn ends: the end line wanders by a few millimetres.
        let torn = 4.0 * (value_noise(tape.seed, t, s.signum() * 10.0, 2.5) - 0.5);
        if t.abs() > tape.half_width || s.abs() > tape.half_len + torn {
            continue;
        }
        // Woven fabric under the film: fine threads along and across, and creases.
        let weave = 0.05 * (value_noise(tape.seed ^ 1, s * 0.25, t * 3.0, 1.0) - 0.5)
            + 0.05 * (value_noise(tape.seed ^ 2, s * 3.0, t * 0.25, 1.0) - 0.5)
            + 0.10 * (value_noise(tape.seed ^ 3, s, t, 6.0) - 0.5);
        let shade = 1.0 + weave - if t.abs() > tape.half_width - 0.8 { 0.15 } else { 0.0 };
        c = tape.colour.map(|k| k * shade);
    }
    c
}

/// The TOML of a slate whose scan is `scan` (a file name beside it), with its lengths in
/// millimetres.
pub fn slate_toml(scan: &str, width_mm: f64, height_mm: f64, lengths: &[(&str, [f64; 2], [f64; 2])]) -> String {
    let mut s = format!("# A dive slate for fslcal (docs/slate.md).\nscan = \"{scan}\"\nwidth_mm = {width_mm:.1}\nheight_mm = {height_mm:.1}\n");
    for (name, a, b) in lengths {
        s += &format!(
            "\n[[length]]\nname = \"{name}\"\nfrom_mm = [{:.2}, {:.2}]\nto_mm = [{:.2}, {:.2}]\n",
            a[0], a[1], b[0], b[1]
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn example() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("slates/example/slate.toml")
    }

    #[test]
    fn the_example_slate_loads_with_its_lengths() {
        let s = Slate::load(&example()).unwrap();
        assert!((s.width_m - 0.3).abs() < 1e-12 && (s.height_m - 0.22).abs() < 1e-12);
        let l = s.length(None).unwrap();
        assert_eq!(l.name, "diagonal");
        assert!(l.length_m() > 0.25, "{}", l.length_m());
        assert!(s.length(Some("no-such")).is_none());
        let scan = s.read_scan().unwrap();
        assert_eq!(scan.dimensions(), (600, 440));
    }

    #[test]
    fn the_example_scan_is_seed_one_of_the_generator() {
        // The committed scan was made by `make-slate DIR 1`; the generator must still make it.
        let scan = Slate::load(&example()).unwrap().read_scan().unwrap();
        assert!(taped_slate_scan(1, 300.0, 220.0, 2.0) == scan, "taped_slate_scan no longer makes the example");
    }

    #[test]
    fn bad_definitions_say_what_is_wrong() {
        let dir = std::env::temp_dir().join(format!("slate-bad-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::copy(example().with_file_name("scan.png"), dir.join("scan.png")).unwrap();
        let cases = [
            ("scan = \"scan.png\"\nwidth_mm = 0.3\nheight_mm = 0.22\n", "not a plausible slate size"),
            ("scan = \"scan.png\"\nwidth_mm = 300\nheight_mm = 300\n", "aspect ratios differ"),
            ("scan = \"none.png\"\nwidth_mm = 300\nheight_mm = 220\n", "cannot read the slate's scan"),
            ("scan = \"scan.png\"\nwidth_mm = 300\nheight_mm = 220\n[[length]]\nname = \"a\"\nfrom_mm = [0, 0]\nto_mm = [400, 0]\n", "outside"),
            ("scan = \"scan.png\"\nwidth = 300\n", "not a slate definition"),
        ];
        for (text, want) in cases {
            let p = dir.join("s.toml");
            std::fs::write(&p, text).unwrap();
            let e = Slate::load(&p).unwrap_err().to_string();
            assert!(e.contains(want) && !e.contains('\n'), "{text}: {e}");
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
}
