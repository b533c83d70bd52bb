//! `render-scenes laser|camera --out DIR [--count N] [--seed S] [--water clear|murky]
//! [--glints N] [--no-board K]`: writes synthetic calibration photos with their truth.

use calib_targets::scene::{camera_scene_set, laser_scene_set, render, Water};
use calib_targets::{write_camera_yaml, write_scene};
use rayon::prelude::*;
use std::path::PathBuf;
use std::process::ExitCode;

const USAGE: &str = "usage: render-scenes laser|camera --out DIR [--count N] [--seed S] [--water clear|murky] [--glints N] [--no-board K]";

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
