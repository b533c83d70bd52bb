//! `cargo bench --bench dot_search [-- DIR...]`: the dot search's time per photo on one core,
//! and how the colour score, the chroma angle and the white part separate true dots from each
//! impostor kind (issue 14).
//!
//! For every `photo_NN.jpg` with its `photo_NN.truth.json` in the given set folders (default:
//! the held-out sets in /work/cache/heldout, docs/scene-variety.md), the whole frame is
//! searched with the default detector and timed (the worst case: the calibration search
//! covers only the target's image, the target-less search a band along the laser), then
//! searched again without the colour floor so that every blob is scored. Each blob is
//! labelled by the truth: the dot (within 2 px), the impostor it lies on, or texture. Prints the median and worst search time and a
//! histogram of colour scores and of outline roughness per label (and, against a unit's learned
//! colour, of chroma angle and white-part deficit); then the time of the search `check` and `measure`
//! run, along the set's calibrated line. Asserts nothing about time.

use fslcal::dot::candidates::{find_dot_candidates, ChannelOrder, ColourView, DotDetectorParams, SearchRegion};
use fslcal::dot::colour::ColourSource;
use fslcal::dot::on_line::find_dot_on_laser_line;
use serde_json::Value;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Colour score bin edges, sigmas.
const EDGES: [f64; 8] = [f64::NEG_INFINITY, 0.0, 4.0, 10.0, 30.0, 100.0, 300.0, f64::INFINITY];

fn photos(dirs: &[PathBuf]) -> Vec<PathBuf> {
    let mut v = Vec::new();
    for d in dirs {
        let Ok(rd) = std::fs::read_dir(d) else { continue };
        let mut here: Vec<PathBuf> =
            rd.flatten().map(|e| e.path()).filter(|p| p.extension().is_some_and(|x| x == "jpg")).collect();
        here.sort();
        v.extend(here);
    }
    v
}

/// The truth's label for a blob at `px`: "dot", the impostor kind it lies on, or "texture".
fn label(truth: &Value, px: [f64; 2]) -> String {
    if let Some(p) = truth["dot"]["pixel"].as_array() {
        let (x, y) = (p[0].as_f64().unwrap_or(f64::NAN), p[1].as_f64().unwrap_or(f64::NAN));
        if (x - px[0]).hypot(y - px[1]) <= 2.0 {
            return "dot".into();
        }
        let r = truth["dot"]["radius_px"].as_f64().unwrap_or(0.0);
        if (x - px[0]).hypot(y - px[1]) <= r + 3.0 {
            return "dot (off by > 2 px)".into();
        }
    }
    for imp in truth["impostors"].as_array().into_iter().flatten() {
        let p = &imp["pixel"];
        let (x, y) = (p[0].as_f64().unwrap_or(f64::NAN), p[1].as_f64().unwrap_or(f64::NAN));
        let r = imp["radius_px"].as_f64().unwrap_or(0.0);
        if (x - px[0]).hypot(y - px[1]) <= r + 3.0 {
            return imp["kind"].as_str().unwrap_or("impostor").to_string();
        }
    }
    "texture".into()
}

/// Upper edges of the outline roughness bins (`check` refuses above 0.10); the first bin is
/// "not measured".
const ROUGH_EDGES: [f64; 6] = [f64::NAN, 0.03, 0.06, 0.10, 0.2, f64::INFINITY];

fn rough_bin(r: Option<f64>) -> usize {
    r.map_or(0, |r| 1 + ROUGH_EDGES[1..].iter().position(|&e| r < e).unwrap_or(ROUGH_EDGES.len() - 2))
}

/// How the half-peak outline's roughness separates true dots from each impostor kind.
fn outline_histogram(hist: &BTreeMap<String, [usize; ROUGH_EDGES.len()]>) {
    table(
        "outline roughness (share of the radius off the best ellipse; `check` refuses above 0.10) of every blob the search returns, by what the truth says it is",
        &["not measured", "< 0.03", "0.03-0.06", "0.06-0.10", "0.10-0.2", ">= 0.2"],
        hist,
    );
}

/// Upper edges of the colour angle bins, degrees; the first bin is exactly 0.
const ANGLE_EDGES_DEG: [f64; 8] = [0.0, 5.0, 10.0, 20.0, 30.0, 45.0, 90.0, f64::INFINITY];
const ANGLE_HEADS: [&str; 8] = ["0", "0-5", "5-10", "10-20", "20-30", "30-45", "45-90", ">= 90"];

fn angle_bin(deg: f64) -> usize {
    ANGLE_EDGES_DEG.iter().position(|&e| deg <= e).unwrap_or(ANGLE_EDGES_DEG.len() - 1)
}

/// A histogram per truth label, one row each, as a Markdown table under `title`.
fn table<const N: usize>(title: &str, heads: &[&str], hist: &BTreeMap<String, [usize; N]>) {
    if hist.is_empty() {
        return;
    }
    println!("\n{title}");
    println!("| blob | {} |", heads.join(" | "));
    println!("|---|{}", "---|".repeat(heads.len()));
    for (k, counts) in hist {
        println!("| {k} | {} |", counts.iter().map(|c| c.to_string()).collect::<Vec<_>>().join(" | "));
    }
}

fn bin(score: f64) -> usize {
    EDGES.windows(2).position(|w| score >= w[0] && score < w[1]).unwrap_or(EDGES.len() - 2)
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).filter(|a| !a.starts_with("--")).collect();
    let full = std::env::args().any(|a| a == "--bench");
    let dirs: Vec<PathBuf> = if args.is_empty() {
        std::fs::read_dir("/work/cache/heldout").map_or_else(
            |_| Vec::new(),
            |rd| {
                let mut v: Vec<PathBuf> = rd.flatten().map(|e| e.path()).collect();
                v.sort();
                v
            },
        )
    } else {
        args.iter().map(PathBuf::from).collect()
    };
    let mut list = photos(&dirs);
    if !full {
        list.truncate(1);
    }
    if list.is_empty() {
        println!("dot_search: no photos in {dirs:?}; render a set (docs/scene-variety.md) and name its folder");
        return;
    }
    let params = DotDetectorParams { min_colour_sigmas: f64::NEG_INFINITY, ..DotDetectorParams::default() };
    let mut times_ms = Vec::new();
    let mut line_ms = Vec::new();
    let mut hist: BTreeMap<String, [usize; EDGES.len() - 1]> = BTreeMap::new();
    let mut hist_learned = hist.clone();
    let mut outlines: BTreeMap<String, [usize; ROUGH_EDGES.len()]> = BTreeMap::new();
    // Against a learned colour only: the prior judges no blob's colour.
    let mut chroma_angles: BTreeMap<String, [usize; ANGLE_EDGES_DEG.len()]> = BTreeMap::new();
    let mut white_deficits = chroma_angles.clone();
    for path in &list {
        let Ok(img) = image::open(path) else { continue };
        let img = img.to_rgb8();
        let view = ColourView {
            width: img.width() as usize,
            height: img.height() as usize,
            stride: img.width() as usize * 3,
            order: ChannelOrder::Rgb,
            data: img.as_raw(),
            tone: None,
        };
        let t = Instant::now();
        let _ = find_dot_candidates(&view, &SearchRegion::default(), &DotDetectorParams::default(), 64);
        times_ms.push((t.elapsed().as_secs_f64() * 1e3, img.width(), img.height()));
        // The search as `check` and `measure` run it: along the set's calibrated line (its
        // own `calibration/fitted.json` when the dot evaluation made one, else the truth).
        let dir = path.parent().unwrap_or(Path::new("."));
        let cal = [dir.join("calibration/fitted.json"), dir.join("cal.json")].into_iter().find(|p| p.is_file());
        let cal = cal.and_then(|c| fslcal::calibration::load(&c).ok());
        if let Some(cal) = &cal {
            let t = Instant::now();
            let _ = find_dot_on_laser_line(&view, &cal.camera, &cal.laser, &cal.line_search());
            line_ms.push((t.elapsed().as_secs_f64() * 1e3, path.clone()));
        }
        // Scores along the colour the unit's calibration learned, where it has one.
        let colour = cal.map_or(params.colour, |c| c.dot_detector().colour);
        let scored = if colour.source == ColourSource::Prior { &mut hist } else { &mut hist_learned };
        let found =
            find_dot_candidates(&view, &SearchRegion::default(), &DotDetectorParams { colour, ..params.clone() }, 64);
        let truth: Value = std::fs::read_to_string(path.with_extension("truth.json"))
            .ok()
            .and_then(|s| serde_json::from_str(&s).ok())
            .unwrap_or(Value::Null);
        for c in &found {
            let kind = label(&truth, [c.pixel.x, c.pixel.y]);
            outlines.entry(kind.clone()).or_insert([0; ROUGH_EDGES.len()])[rough_bin(c.outline_roughness)] += 1;
            if colour.source != ColourSource::Prior {
                chroma_angles.entry(kind.clone()).or_insert([0; ANGLE_EDGES_DEG.len()])
                    [angle_bin(c.colour_angle_rad.to_degrees())] += 1;
                white_deficits.entry(kind.clone()).or_insert([0; ANGLE_EDGES_DEG.len()])
                    [angle_bin(c.white_deficit_rad.to_degrees())] += 1;
            }
            scored.entry(kind).or_insert([0; EDGES.len() - 1])[bin(c.colour_score)] += 1;
        }
    }
    report(&list, &times_ms, &hist, "the green prior (sets without a learned colour)");
    if !hist_learned.is_empty() {
        histogram(&hist_learned, "the laser colour the unit's own calibration learned");
    }
    outline_histogram(&outlines);
    table(
        "chroma angle from the learned laser colour (degrees; `check` refuses beyond 3 sigmas of its spread and the blob's noise) of every blob the search returns, by what the truth says it is",
        &ANGLE_HEADS,
        &chroma_angles,
    );
    table(
        "white part short of the learned laser colour's (degrees; judged with the chroma angle at 1.67 times the spread) of every blob the search returns, by what the truth says it is",
        &ANGLE_HEADS,
        &white_deficits,
    );
    line_ms.sort_by(|a, b| a.0.total_cmp(&b.0));
    if let Some((worst_ms, worst)) = line_ms.last() {
        println!(
            "\ndot search along the calibrated line (as check and measure run it), one thread, {} photos: median {:.1} ms, worst {worst_ms:.1} ms ({}) (target < 40 ms)",
            line_ms.len(),
            line_ms[line_ms.len() / 2].0,
            worst.display()
        );
    }
}

fn report(list: &[PathBuf], times_ms: &[(f64, u32, u32)], hist: &Histogram, colour: &str) {
    let mut t: Vec<f64> = times_ms.iter().map(|x| x.0).collect();
    t.sort_by(f64::total_cmp);
    let sizes: Vec<String> = times_ms
        .iter()
        .map(|x| format!("{}x{}", x.1, x.2))
        .collect::<std::collections::BTreeSet<_>>()
        .into_iter()
        .collect();
    println!(
        "dot search, whole frame, one thread, {} photos ({}) from {}: median {:.1} ms, worst {:.1} ms (target < 40 ms)",
        t.len(),
        sizes.join(", "),
        list.first()
            .and_then(|p| p.parent())
            .and_then(Path::parent)
            .map_or_else(String::new, |p| p.display().to_string()),
        t[t.len() / 2],
        t[t.len() - 1],
    );
    histogram(hist, colour);
}

type Histogram = BTreeMap<String, [usize; EDGES.len() - 1]>;

fn histogram(hist: &Histogram, colour: &str) {
    let heads: Vec<String> = EDGES
        .windows(2)
        .map(|w| match (w[0].is_finite(), w[1].is_finite()) {
            (false, _) => format!("< {}", w[1]),
            (_, false) => format!(">= {}", w[0]),
            _ => format!("{}-{}", w[0], w[1]),
        })
        .collect();
    let heads: Vec<&str> = heads.iter().map(String::as_str).collect();
    table(
        &format!("colour score (sigmas) along {colour} of every blob the search returns, by what the truth says it is"),
        &heads,
        hist,
    );
}
