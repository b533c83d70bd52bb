//! `cargo bench --bench laser_pipeline`: the laser chain's wall time on 16 rendered 4000x3000
//! JPEGs (0.6-4.5 m, clean water), end to end from files on disk to the fitted line, and the
//! time to reject a photo with no board. Targets on a 2-core machine: about 1.2 s for the 16,
//! under 150 ms for the no-board photo. Prints figures; asserts nothing about time.

#[path = "../tests/common/mod.rs"]
mod common;

use calib_targets::scene::Water;
use fslcal::laser::fit::Method;
use fslcal::laser::pipeline::{calibrate, examine_photo};
use std::time::{Duration, Instant};

fn median(mut v: Vec<Duration>) -> Duration {
    v.sort();
    v[v.len() / 2]
}

fn main() {
    // `cargo test --benches` runs this too; keep that quick.
    let runs = if std::env::args().any(|a| a == "--bench") { 5 } else { 1 };
    eprintln!("rendering scenes (not timed)...");
    let set = common::laser_set("bench-laser", 16, 11, Water::Clear, 0);
    let no_board = common::render_set("bench-no-board", &[common::no_board_spec(7)]);
    let job = common::board_job(&set.camera_file, Method::Reprojection);
    let threads = rayon::current_num_threads();

    let mut chain = Vec::new();
    for _ in 0..runs {
        let t = Instant::now();
        let cal = calibrate(&job, &set.photos, &|| {}).expect("calibration");
        chain.push(t.elapsed());
        assert_eq!(cal.photos.len(), 16);
    }
    let mut reject = Vec::new();
    fslcal::vision::use_single_threaded_opencv();
    for _ in 0..runs.max(3) {
        let t = Instant::now();
        let r = examine_photo(&job, &no_board.photos[0]).expect("examine");
        reject.push(t.elapsed());
        assert!(r.is_err(), "the no-board photo must be rejected");
    }
    println!("laser chain, 16 photos 4000x3000 JPEG, {threads} threads: median {:.3} s over {runs} run(s) (target ~1.2 s on 2 cores)", median(chain).as_secs_f64());
    println!(
        "no-board photo rejected: median {:.1} ms over {} run(s) (target < 150 ms)",
        median(reject).as_secs_f64() * 1e3,
        runs.max(3)
    );
}
