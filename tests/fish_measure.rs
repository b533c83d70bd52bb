//! `fslcal measure` end to end on rendered fish with exact snout, fork and fork length
//! (calib-targets' fish), at known distances with the laser dot on them: length error by
//! distance from masks and from labels, a Label Studio export round trip, and the flags that
//! withhold a number.

mod common;

use calib_targets::fish::FishTruth;
use common::{fish_set, FishSet};
use serde_json::{json, Value};
use std::path::Path;
use std::process::{Command, Output};
use std::sync::OnceLock;

fn set() -> &'static FishSet {
    static SET: OnceLock<FishSet> = OnceLock::new();
    SET.get_or_init(|| fish_set("fish-measure", 10, 21))
}

fn fslcal(args: &[String]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_fslcal")).args(args).output().expect("run fslcal")
}

fn s(p: &Path) -> String {
    p.display().to_string()
}

fn run_json(args: &[String]) -> Value {
    let o = fslcal(args);
    assert!(o.status.success(), "fslcal {args:?}: {}", String::from_utf8_lossy(&o.stderr));
    serde_json::from_slice(&o.stdout).expect("stdout is one JSON object")
}

/// The straight snout-to-fork length at the fish's depth: what labels at the true snout and
/// fork measure (equal to the fork length for a straight fish).
fn chord_m(t: &FishTruth) -> f64 {
    let p = |a: [f64; 2]| fslcal_core::Vec2::new(a[0], a[1]);
    t.spec.camera.length_at_depth(p(t.snout_px), p(t.fork_px), t.spec.pose.depth_m).unwrap()
}

#[test]
fn length_error_by_distance_from_masks() {
    let set = set();
    let mut args = vec![
        "measure".into(),
        "--cal".into(),
        s(&set.cal),
        "--masks".into(),
        s(&set.dir.join("masks")),
        "--dots".into(),
        s(&set.dots),
        "--json".into(),
    ];
    args.extend(set.photos.iter().map(|p| s(p)));
    let v = run_json(&args);
    let fish = v["fish"].as_array().unwrap();
    assert_eq!(fish.len(), set.truths.len());
    eprintln!("distance m   fork length mm   measured mm (1-sigma)   error     shape");
    let (mut worst_straight, mut worst_bent): (f64, f64) = (0.0, 0.0);
    for (f, t) in fish.iter().zip(&set.truths) {
        let got = f["length_m"].as_f64().unwrap_or_else(|| panic!("{}: withheld {}", f["photo"], f["flags"]));
        let err = 100.0 * (got / t.fork_length_m - 1.0);
        eprintln!(
            "{:10.2}   {:14.1}   {:11.1} ({:4.1})   {err:+6.2}%   {}{}",
            t.spec.pose.depth_m,
            t.fork_length_m * 1e3,
            got * 1e3,
            f["length_sigma_m"].as_f64().unwrap() * 1e3,
            if t.spec.shape.bend_rad > 0.0 {
                format!("bent {:.0} deg", t.spec.shape.bend_rad.to_degrees())
            } else {
                "straight".into()
            },
            if t.spec.shape.fork_depth > 0.0 { ", forked" } else { ", square tail" },
        );
        assert!((f["distance_m"].as_f64().unwrap() - t.spec.pose.depth_m).abs() < 0.01 * t.spec.pose.depth_m, "{f}");
        let worst = if t.spec.shape.bend_rad > 0.0 { &mut worst_bent } else { &mut worst_straight };
        *worst = worst.max(err.abs());
    }
    eprintln!("worst length error from masks: straight fish {worst_straight:.2}%, C-bent fish {worst_bent:.2}%");
    assert!(worst_straight < 1.0, "straight fish: worst {worst_straight:.2}%");
    assert!(worst_bent < 8.0, "bent fish: worst {worst_bent:.2}%");
}

#[test]
fn labels_at_the_true_ends_give_the_straight_length() {
    let set = set();
    let labels = set.dir.join("labels.csv");
    let mut csv = String::from("photo,head_x,head_y,tail_x,tail_y,species\n");
    for (i, (p, t)) in set.photos.iter().zip(&set.truths).enumerate() {
        csv += &format!(
            "{},{},{},{},{},{}\n",
            p.file_name().unwrap().to_string_lossy(),
            t.snout_px[0],
            t.snout_px[1],
            t.fork_px[0],
            t.fork_px[1],
            if i % 2 == 0 { "snapper" } else { "grouper" }
        );
    }
    std::fs::write(&labels, csv).unwrap();
    let (out, summary) = (set.dir.join("lengths.csv"), set.dir.join("summary.csv"));
    let mut args = vec![
        "measure".into(),
        "--cal".into(),
        s(&set.cal),
        "--labels".into(),
        s(&labels),
        "--dots".into(),
        s(&set.dots),
        "--out".into(),
        s(&out),
        "--summary-out".into(),
        s(&summary),
        "--json".into(),
    ];
    args.extend(set.photos.iter().map(|p| s(p)));
    let v = run_json(&args);
    let mut worst: f64 = 0.0;
    for (f, t) in v["fish"].as_array().unwrap().iter().zip(&set.truths) {
        let err = 100.0 * (f["length_m"].as_f64().unwrap() / chord_m(t) - 1.0);
        worst = worst.max(err.abs());
    }
    eprintln!("labels at the true snout and fork: worst error {worst:.3}% against the straight length");
    assert!(worst < 0.5, "{worst}");
    assert_eq!(v["measured"], 10);
    assert_eq!(v["summary"]["species"]["snapper"]["n"], 5);
    assert!(v["summary"]["all"]["percentiles_m"]["p50"].as_f64().unwrap() > 0.1);
    let rows = std::fs::read_to_string(&out).unwrap();
    assert_eq!(rows.lines().count(), 11);
    let sum = std::fs::read_to_string(&summary).unwrap();
    assert!(sum.contains("grouper,p50_m,,,") && sum.contains("all,count,"), "{sum}");
}

/// A Label Studio export (keypoints in percent of the image, `(0, 0)` at its top-left edge)
/// for two photos, with the upload hash prefix Label Studio puts on file names.
#[test]
fn label_studio_export_round_trip() {
    let set = set();
    let kp = |id: &str, label: &str, p: [f64; 2], t: &FishTruth| {
        let (w, h) = (t.spec.camera.width_px as f64, t.spec.camera.height_px as f64);
        json!({
            "id": id, "type": "keypointlabels", "from_name": "kp", "to_name": "image",
            "original_width": w, "original_height": h, "image_rotation": 0,
            "value": {"x": (p[0] + 0.5) / w * 100.0, "y": (p[1] + 0.5) / h * 100.0, "width": 0.4, "keypointlabels": [label]},
        })
    };
    let tasks: Vec<Value> = [0usize, 2]
        .iter()
        .map(|&i| {
            let t = &set.truths[i];
            let d = t.dot.as_ref().unwrap().pixel;
            json!({
                "id": 100 + i,
                "data": {"image": format!("/data/upload/7/1a2b3c4d-{}", set.photos[i].file_name().unwrap().to_string_lossy())},
                "annotations": [{"id": 1, "was_cancelled": false, "result": [
                    kp("a", "Snout", t.snout_px, t), kp("b", "Fork", t.fork_px, t), kp("c", "Laser", d, t),
                    {"type": "choices", "from_name": "species", "to_name": "image", "value": {"choices": ["Lutjanus"]}},
                ]}],
            })
        })
        .collect();
    let export = set.dir.join("label-studio.json");
    std::fs::write(&export, serde_json::to_vec_pretty(&tasks).unwrap()).unwrap();
    let v = run_json(&[
        "measure".into(),
        "--cal".into(),
        s(&set.cal),
        "--labels".into(),
        s(&export),
        "--json".into(),
        s(&set.photos[0]),
        s(&set.photos[1]),
        s(&set.photos[2]),
    ]);
    let fish = v["fish"].as_array().unwrap();
    assert_eq!(fish.len(), 2, "{v}");
    assert_eq!(v["photos_without_fish"].as_array().unwrap().len(), 1);
    for (f, i) in fish.iter().zip([0usize, 2]) {
        let t = &set.truths[i];
        let head = [f["head_px"][0].as_f64().unwrap(), f["head_px"][1].as_f64().unwrap()];
        assert!(
            (head[0] - t.snout_px[0]).abs() < 1e-6 && (head[1] - t.snout_px[1]).abs() < 1e-6,
            "percent to pixels: {head:?} vs {:?}",
            t.snout_px
        );
        let err = 100.0 * (f["length_m"].as_f64().unwrap() / chord_m(t) - 1.0);
        eprintln!(
            "Label Studio round trip: {} measured {:.1} mm, truth {:.1} mm ({err:+.3}%), species {}",
            f["photo"],
            f["length_m"].as_f64().unwrap() * 1e3,
            chord_m(t) * 1e3,
            f["species"]
        );
        assert!(err.abs() < 0.5);
        assert_eq!(f["species"], "Lutjanus");
    }
}

#[test]
fn flags_withhold_wrong_numbers() {
    let set = set();
    let (t, photo) = (&set.truths[1], &set.photos[1]);
    let d = t.dot.as_ref().unwrap().pixel;
    let name = photo.file_name().unwrap().to_string_lossy().into_owned();
    // Same fish four times: a good dot, a dot 25 px off the laser line, no dot in the label
    // (searched for and found), ends at the frame edge.
    let labels = set.dir.join("flags.csv");
    let (h, f) = (t.snout_px, t.fork_px);
    std::fs::write(
        &labels,
        format!(
            "photo,head_x,head_y,tail_x,tail_y,dot_x,dot_y\n{name},{},{},{},{},{},{}\n{name},{},{},{},{},{},{}\n{name},{},{},{},{},,\n{name},0.5,{},{},{},{},{}\n",
            h[0], h[1], f[0], f[1], d[0], d[1],
            h[0], h[1], f[0], f[1], d[0] + 25.0, d[1],
            h[0], h[1], f[0], f[1],
            h[1], f[0], f[1], d[0], d[1],
        ),
    )
    .unwrap();
    let v = run_json(&[
        "measure".into(),
        "--cal".into(),
        s(&set.cal),
        "--labels".into(),
        s(&labels),
        "--json".into(),
        s(photo),
    ]);
    let flags: Vec<String> = v["fish"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| {
            f["flags"]
                .as_array()
                .unwrap()
                .iter()
                .map(|x| x["flag"].as_str().unwrap().to_string())
                .collect::<Vec<_>>()
                .join("+")
        })
        .collect();
    assert_eq!(flags, ["", "dot_off_laser_line", "", "cut_by_edge"], "{v}");
    assert!(v["fish"][1]["length_m"].is_null());
    let (a, b) = (v["fish"][0]["length_m"].as_f64().unwrap(), v["fish"][2]["length_m"].as_f64().unwrap());
    assert!((a / b - 1.0).abs() < 0.003, "labelled dot {a}, searched dot {b}");

    // The same photo with the dot painted out (the water around it copied over it).
    let mut img = image::open(photo).unwrap().to_rgb8();
    let (cx, cy) = (d[0].round() as i64, d[1].round() as i64);
    for y in cy - 40..=cy + 40 {
        for x in cx - 40..=cx + 40 {
            let from = *img.get_pixel((x + 120) as u32, y as u32);
            img.put_pixel(x as u32, y as u32, from);
        }
    }
    let painted = set.dir.join("painted").join(&name);
    std::fs::create_dir_all(painted.parent().unwrap()).unwrap();
    img.save(&painted).unwrap();
    let v = run_json(&[
        "measure".into(),
        "--cal".into(),
        s(&set.cal),
        "--labels".into(),
        s(&labels),
        "--json".into(),
        s(&painted),
    ]);
    // Either nothing dot-like is left, or what is found is off the laser's line: withheld.
    let flag = v["fish"][2]["flags"][0]["flag"].as_str().unwrap_or("").to_string();
    assert!(v["fish"][2]["length_m"].is_null() && (flag == "no_dot" || flag == "dot_off_laser_line"), "{v}");

    // A calibration whose dots only covered 0.5-1.0 m: a fish at 1.03 m is extrapolation.
    let mut cal: Value = serde_json::from_slice(&std::fs::read(&set.cal).unwrap()).unwrap();
    cal["depth_range_m"] = json!([0.5, 0.8]);
    let narrow = set.dir.join("narrow-cal.json");
    std::fs::write(&narrow, serde_json::to_vec(&cal).unwrap()).unwrap();
    let v = run_json(&[
        "measure".into(),
        "--cal".into(),
        s(&narrow),
        "--labels".into(),
        s(&labels),
        "--json".into(),
        s(photo),
    ]);
    assert_eq!(v["fish"][0]["flags"][0]["flag"], "outside_calibrated_range", "{v}");

    // A photo of another size cannot come from the calibrated camera.
    let small = set.dir.join("small").join(&name);
    std::fs::create_dir_all(small.parent().unwrap()).unwrap();
    image::open(photo).unwrap().thumbnail(800, 600).save(&small).unwrap();
    let v = run_json(&[
        "measure".into(),
        "--cal".into(),
        s(&set.cal),
        "--labels".into(),
        s(&labels),
        "--json".into(),
        s(&small),
    ]);
    assert_eq!(v["fish"][0]["flags"][0]["flag"], "other_camera_body", "{v}");
}

#[test]
fn one_fish_on_the_command_line_and_a_mask_alone() {
    let set = set();
    let t = &set.truths[0];
    let d = t.dot.as_ref().unwrap().pixel;
    let xy = |p: [f64; 2]| format!("{},{}", p[0], p[1]);
    let v = run_json(&[
        "measure".into(),
        "--cal".into(),
        s(&set.cal),
        s(&set.photos[0]),
        "--head".into(),
        xy(t.snout_px),
        "--tail".into(),
        xy(t.fork_px),
        "--dot".into(),
        xy(d),
        "--json".into(),
    ]);
    let err = v["length_m"].as_f64().unwrap() / chord_m(t) - 1.0;
    assert!(err.abs() < 0.005, "{v}");
    assert!((v["distance_m"].as_f64().unwrap() - t.spec.pose.depth_m).abs() < 0.01);
    let sigma = v["length_sigma_m"].as_f64().unwrap();
    assert!(sigma > 0.0 && sigma < 0.01 * v["length_m"].as_f64().unwrap(), "{v}");

    let m = run_json(&["measure".into(), "--mask".into(), s(&set.dir.join("masks/fish_00.png")), "--json".into()]);
    let keys: Vec<&str> = m.as_object().unwrap().keys().map(String::as_str).collect();
    for k in ["head_px", "tail_px", "length_px"] {
        assert!(keys.contains(&k), "{keys:?}");
    }

    // Without --dot the dot is searched for along the laser's image.
    let v = run_json(&[
        "measure".into(),
        "--cal".into(),
        s(&set.cal),
        s(&set.photos[0]),
        "--head".into(),
        xy(t.snout_px),
        "--tail".into(),
        xy(t.fork_px),
        "--json".into(),
    ]);
    let found = [v["dot_px"][0].as_f64().unwrap(), v["dot_px"][1].as_f64().unwrap()];
    eprintln!(
        "dot searched: {:.2} px from the truth; length {:+.3}%",
        ((found[0] - d[0]).powi(2) + (found[1] - d[1]).powi(2)).sqrt(),
        100.0 * (v["length_m"].as_f64().unwrap() / chord_m(t) - 1.0)
    );
    assert!(((found[0] - d[0]).powi(2) + (found[1] - d[1]).powi(2)).sqrt() < 1.0, "{v}");
    assert!((v["length_m"].as_f64().unwrap() / chord_m(t) - 1.0).abs() < 0.005);
    // A file that is not a calibration.
    let o =
        fslcal(&["measure".into(), "--cal".into(), s(&set.dots), "--labels".into(), s(&set.dots), s(&set.photos[0])]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.lines().count() == 1 && err.contains("dots.csv"), "{err}");
}
