//! The README demo's photos (`render-scenes laser --count 16 --seed 1 --water clear
//! --glints 2`, 4000x3000): `check`, `validate` and `measure` search the dot along the
//! calibrated line (or on the board near it) with no help from `laser`, and must find the
//! dot `laser` used in every photo it used, within 2 px. Before issue 14 `check` missed
//! three of them and took a speck 354 px away on another, and `validate` skipped seven.
//!
//! Met (asserted since stop 25): all 16 photos in each command, never a wrong dot. (photo_13, a
//! 3.96 m dot on a black square between light ones, was missed by the along-line search
//! for several stops; photo_05's blooming dot, 33 px at the detection threshold, was
//! refused as too large until a dot's size was judged at half its peak.)

mod common;

use calib_targets::scene::Water;
use serde_json::Value;
use std::collections::BTreeMap;
use std::path::Path;
use std::process::Command;

fn fslcal(args: &[String]) -> Value {
    let o = Command::new(env!("CARGO_BIN_EXE_fslcal")).args(args).output().expect("fslcal runs");
    serde_json::from_slice(&o.stdout)
        .unwrap_or_else(|e| panic!("{args:?}: {e}; stderr {}", String::from_utf8_lossy(&o.stderr)))
}

fn name(p: &Value) -> String {
    let f = p.as_str().expect("a file name");
    Path::new(f).file_name().unwrap().to_string_lossy().into_owned()
}

/// Dots per photo file name from a document's rows.
fn dots(rows: &Value, file_key: &str) -> BTreeMap<String, Option<[f64; 2]>> {
    rows.as_array()
        .expect("rows")
        .iter()
        .map(|r| (name(&r[file_key]), r["dot_px"].as_array().map(|d| [d[0].as_f64().unwrap(), d[1].as_f64().unwrap()])))
        .collect()
}

#[test]
fn check_validate_and_measure_find_the_dots_laser_used_on_the_demo_photos() {
    let set = common::laser_set("demo-dots", 16, 1, Water::Clear, 2);
    let dir = set.dir.display().to_string();
    let photos: Vec<String> = set.photos.iter().map(|p| p.display().to_string()).collect();
    let cal = format!("{dir}/laser.json");
    let mut args: Vec<String> =
        ["laser", "--camera", &format!("{dir}/camera.yml"), "--target"].iter().map(|s| s.to_string()).collect();
    args.extend(["checkerboard:14x10@42.17mm".into(), "--out".into(), cal.clone(), "--json".into()]);
    args.extend(photos.iter().cloned());
    let laser = fslcal(&args);
    let used: BTreeMap<String, [f64; 2]> = dots(&laser["photos"], "file")
        .into_iter()
        .zip(laser["photos"].as_array().unwrap())
        .filter(|(_, p)| p["status"] == "used")
        .map(|((f, d), _)| (f, d.expect("a used photo has its dot")))
        .collect();
    assert!(used.len() >= 12, "laser used only {} photos", used.len());

    let mut check = vec!["check".to_string(), "--cal".into(), cal.clone(), "--json".into()];
    check.extend(photos.iter().cloned());
    let mut validate = vec!["validate".to_string(), "--cal".into(), cal.clone(), "--json".into()];
    validate.extend(["--target".into(), "checkerboard:14x10@42.17mm".into()]);
    validate.extend(photos.iter().cloned());
    let labels = format!("{dir}/labels.csv");
    let rows: String = used.keys().map(|f| format!("{f},100,100,600,100\n")).collect();
    std::fs::write(&labels, format!("photo,head_x,head_y,tail_x,tail_y\n{rows}")).unwrap();
    let mut measure = vec!["measure".to_string(), "--cal".into(), cal, "--json".into(), "--labels".into(), labels];
    measure.extend(photos.iter().cloned());

    let found = [
        ("check", dots(&fslcal(&check)["photos"], "file")),
        ("validate", dots(&fslcal(&validate)["photos"], "file")),
        ("measure", dots(&fslcal(&measure)["fish"], "photo")),
    ];
    let (mut wrong, mut missed) = (Vec::new(), Vec::new());
    for (command, got) in &found {
        let mut right = 0;
        for (file, want) in &used {
            match got.get(file).copied().flatten() {
                Some(d) if (d[0] - want[0]).hypot(d[1] - want[1]) <= 2.0 => right += 1,
                Some(d) => {
                    wrong.push(format!("{command} {file}: {:.1} px off", (d[0] - want[0]).hypot(d[1] - want[1])))
                }
                None => missed.push(format!("{command} {file}: no dot")),
            }
        }
        eprintln!("{command}: the dot laser used in {right} of {} photos", used.len());
        assert_eq!(right, used.len(), "{command}: only {right} of {}; missed {missed:#?}", used.len());
    }
    eprintln!("missed: {missed:?}");
    assert!(wrong.is_empty(), "a wrong dot: {wrong:#?}");
}
