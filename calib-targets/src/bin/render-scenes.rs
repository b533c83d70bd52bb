//! `render-scenes laser|camera --out DIR [--count N] [--seed S] [--water clear|murky]
//! [--glints N] [--no-board K]`: writes synthetic calibration photos with their truth.
//!
//! `render-scenes variety --kind calibration|slate|targetless --out DIR [--seed S]
//! [--count N] [--size WxH]`: writes one randomised set (`calib_targets::variety`,
//! docs/scene-variety.md). Seeds from 1000000 up are held out: do not tune on them.

use calib_targets::scene::{camera_scene_set, laser_scene_set, render, Water};
use calib_targets::variety::{Kind, VarietySet};
use calib_targets::{write_camera_yaml, write_scene};
use rayon::prelude::*;
use std::path::PathBuf;
use std::process::ExitCode;

const USAGE: &str = "usage: render-scenes laser|camera --out DIR [--count N] [--seed S] [--water clear|murky] [--glints N] [--no-board K]
       render-scenes variety --kind calibration|slate|targetless --out DIR [--seed S] [--count N] [--size WxH]";

struct VarietyArgs {
    kind: Kind,
    out: PathBuf,
    seed: u64,
    count: Option<usize>,
    width_px: u32,
}

/// `WxH` with a 4:3 aspect, e.g. `4000x3000` or `1000x750`.
fn parse_size(v: &str) -> Result<u32, String> {
    let bad = || format!("--size: `{v}` is not WxH in pixels with a 4:3 aspect, e.g. 4000x3000 or 1000x750");
    let (w, h) = v.split_once('x').ok_or_else(bad)?;
    let (w, h): (u32, u32) = (w.parse().map_err(|_| bad())?, h.parse().map_err(|_| bad())?);
    if w % 4 != 0 || h != w / 4 * 3 {
        return Err(bad());
    }
    Ok(w)
}

fn parse_variety(mut it: impl Iterator<Item = String>) -> Result<VarietyArgs, String> {
    let mut a =
        VarietyArgs { kind: Kind::Calibration, out: PathBuf::new(), seed: 1_000_000, count: None, width_px: 4000 };
    let mut kind = None;
    while let Some(flag) = it.next() {
        let value = it.next().ok_or_else(|| format!("{flag} needs a value"))?;
        let number = |v: &str| v.parse::<u64>().map_err(|_| format!("{flag}: `{v}` is not a whole number"));
        match flag.as_str() {
            "--kind" => kind = Some(value.parse::<Kind>()?),
            "--out" => a.out = PathBuf::from(value),
            "--seed" => a.seed = number(&value)?,
            "--count" => a.count = Some(number(&value)? as usize),
            "--size" => a.width_px = parse_size(&value)?,
            _ => return Err(format!("unknown option {flag}")),
        }
    }
    a.kind = kind.ok_or("--kind calibration|slate|targetless is required")?;
    if a.out.as_os_str().is_empty() {
        return Err("--out DIR is required".into());
    }
    Ok(a)
}

fn run_variety(args: VarietyArgs) -> ExitCode {
    let set = match VarietySet::plan(args.kind, args.seed, args.count, args.width_px) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("render-scenes: {e}");
            return ExitCode::from(2);
        }
    };
    match set.write(&args.out, &mut |p| println!("{}", p.display())) {
        Ok(_) => {
            for f in ["camera.yml", "cal.json", "set.json"] {
                println!("{}", args.out.join(f).display());
            }
            if set.slate.is_some() {
                println!("{}", args.out.join("slate.toml").display());
            }
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("render-scenes: {e}");
            ExitCode::FAILURE
        }
    }
}

struct Args {
    kind: String,
    out: PathBuf,
    count: usize,
    seed: u64,
    water: Water,
    glints: u32,
    no_board: usize,
}

fn parse() -> Result<Args, String> {
    let mut it = std::env::args().skip(1);
    let kind = it.next().ok_or("missing the set kind")?;
    if kind != "laser" && kind != "camera" {
        return Err(format!("unknown set `{kind}`"));
    }
    let mut a = Args { kind, out: PathBuf::new(), count: 16, seed: 1, water: Water::Clear, glints: 0, no_board: 0 };
    while let Some(flag) = it.next() {
        let value = it.next().ok_or_else(|| format!("{flag} needs a value"))?;
        let number = |v: &str| v.parse::<u64>().map_err(|_| format!("{flag}: `{v}` is not a whole number"));
        match flag.as_str() {
            "--out" => a.out = PathBuf::from(value),
            "--count" => a.count = number(&value)? as usize,
            "--seed" => a.seed = number(&value)?,
            "--water" => a.water = value.parse()?,
            "--glints" => a.glints = number(&value)? as u32,
            "--no-board" => a.no_board = number(&value)? as usize,
            _ => return Err(format!("unknown option {flag}")),
        }
    }
    if a.out.as_os_str().is_empty() {
        return Err("--out DIR is required".into());
    }
    Ok(a)
}

fn main() -> ExitCode {
    if std::env::args().nth(1).as_deref() == Some("variety") {
        return match parse_variety(std::env::args().skip(2)) {
            Ok(a) => run_variety(a),
            Err(e) => {
                eprintln!("render-scenes: {e}\n{USAGE}");
                ExitCode::from(2)
            }
        };
    }
    let args = match parse() {
        Ok(a) => a,
        Err(e) => {
            eprintln!("render-scenes: {e}\n{USAGE}");
            return ExitCode::from(2);
        }
    };
    let mut specs = match args.kind.as_str() {
        "laser" => laser_scene_set(args.count, args.seed, args.water, args.glints),
        _ => camera_scene_set(args.count, args.seed, args.water),
    };
    let template = laser_scene_set(1, args.seed ^ 0xB0A2D, args.water, 0);
    for k in 0..args.no_board {
        let mut s = template[0].clone();
        s.board = None;
        s.seed = s.seed.wrapping_add(k as u64 + 1);
        specs.push(s);
    }
    if let Err(e) = std::fs::create_dir_all(&args.out) {
        eprintln!("render-scenes: {}: cannot create the folder: {e}", args.out.display());
        return ExitCode::FAILURE;
    }
    let results: Vec<Result<String, String>> = specs
        .par_iter()
        .enumerate()
        .map(|(i, spec)| {
            let name = format!("photo_{i:02}");
            let scene = render(spec);
            write_scene(&args.out, &name, &scene).map_err(|e| format!("{}: {e}", args.out.join(&name).display()))?;
            Ok(format!("{}", args.out.join(format!("{name}.jpg")).display()))
        })
        .collect();
    let mut failed = false;
    for r in results {
        match r {
            Ok(path) => println!("{path}"),
            Err(e) => {
                eprintln!("render-scenes: cannot write {e}");
                failed = true;
            }
        }
    }
    let camera = args.out.join("camera.yml");
    if let Err(e) = write_camera_yaml(&camera, &specs[0].camera) {
        eprintln!("render-scenes: {}: cannot write: {e}", camera.display());
        return ExitCode::FAILURE;
    }
    println!("{}", camera.display());
    if failed {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    }
}
