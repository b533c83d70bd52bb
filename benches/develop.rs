//! `cargo bench --bench develop`: decode + develop time per TG-6 raw (4000x3000) and the
//! peak memory of a 100-raw batch through `fslcal develop`'s own code path.
//!
//! Writes 100 synthetic TG-6 ORFs (24 MB each) to a temporary folder, develops them with
//! one worker per core into 8-bit PNGs, and prints seconds per photo and the process's peak
//! resident memory (VmHWM) before and after the batch.

use calib_targets::orf::{tg6_orf, OrfMeta};
use calib_targets::scene::{laser_scene_set, render, Water};
use fslcal::cli::develop_one;
use rayon::prelude::*;
use std::time::Instant;

fn vm_hwm_mb() -> f64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmHWM:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<f64>().ok())
        .map_or(f64::NAN, |kb| kb / 1024.0)
}

fn main() {
    // The renderer's memory would mask the batch's peak: the batch runs in a child process.
    if let Some(dir) = std::env::var_os("DEVELOP_BENCH_BATCH") {
        return batch(std::path::Path::new(&dir));
    }
    let count: usize = std::env::var("DEVELOP_BENCH_COUNT").ok().and_then(|v| v.parse().ok()).unwrap_or(100);
    let dir = tempfile::tempdir().expect("temp dir");
    let raws: Vec<std::path::PathBuf> = {
        let spec = &laser_scene_set(1, 7, Water::Clear, 1)[0];
        let scene = render(spec);
        let orf = tg6_orf(&scene.image, &OrfMeta::default());
        (0..count)
            .map(|i| {
                let p = dir.path().join(format!("P{i:07}.ORF"));
                std::fs::write(&p, &orf).unwrap();
                p
            })
            .collect()
    };
    drop(raws);
    let status = std::process::Command::new(std::env::current_exe().unwrap())
        .env("DEVELOP_BENCH_BATCH", dir.path())
        .status()
        .expect("run the batch");
    assert!(status.success());
}

fn batch(dir: &std::path::Path) {
    let mut raws: Vec<std::path::PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "ORF"))
        .collect();
    raws.sort();
    let count = raws.len();
    let out = dir.join("png");
    std::fs::create_dir_all(&out).unwrap();
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let before = vm_hwm_mb();
    let pool = rayon::ThreadPoolBuilder::new().num_threads(cores).build().unwrap();
    let t = Instant::now();
    let ok = pool.install(|| raws.par_iter().with_max_len(1).filter(|r| develop_one(r, &out, false).is_ok()).count());
    let secs = t.elapsed().as_secs_f64();
    let one = Instant::now();
    develop_one(&raws[0], &out, false).unwrap();
    let single = one.elapsed().as_secs_f64();
    println!("develop: {ok} of {count} TG-6 raws (4000x3000, 24 MB ORF) -> 8-bit PNG on {cores} cores");
    println!("  wall time per photo (batch, {cores} in flight): {:.3} s", secs / count as f64);
    println!("  one photo alone (decode + grey world + demosaic + PNG + atomic write): {single:.3} s");
    println!("  peak RSS (VmHWM): {before:.0} MB before the batch, {:.0} MB after {count} photos", vm_hwm_mb());
}
