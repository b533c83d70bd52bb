//! `cargo bench --bench slate_detection`: finding the example slate and its pose in
//! rendered 4000x3000 JPEGs (0.45-2.2 m, murky water), from the file on disk to
//! `T_cam_target` with the full-resolution photo decoded for the dot search. Prints, per
//! feature type (ORB, the default; SIFT; AKAZE): photos found, fewest inliers, pose errors
//! against the truth, and wall time per photo, single-threaded and with all threads over the
//! photos. The target is 0.5 s per photo on 2 cores. Asserts nothing about time.

#[path = "../tests/common/mod.rs"]
mod common;

use calib_targets::rig::{fsl_laser, tg6_camera};
use calib_targets::scene::Water;
use fslcal::vision::{find_slate, EncodedPhoto, Features, SlateModel};
use fslcal_core::Vec3;
use rayon::prelude::*;
use std::time::Instant;

fn main() {
    let full = std::env::args().any(|a| a == "--bench");
    let count = if full { 8 } else { 2 };
    eprintln!("rendering {count} slate photos (not timed)...");
    let set = common::slate_set("bench-slate", fsl_laser(), (0.45, 2.2), count, 17, Water::Murky, 2);
    let camera = tg6_camera();
    fslcal::vision::use_single_threaded_opencv();
    let threads = rayon::current_num_threads();
    let kinds: &[Features] = if full { &[Features::Orb, Features::Sift, Features::Akaze] } else { &[Features::Orb] };
    for &kind in kinds {
        let model = SlateModel::new(common::example_slate(), kind).expect("scan features");
        let one = |i: usize| {
            let enc = EncodedPhoto::read(&set.photos[i]).expect("photo");
            find_slate(&model, &enc, &camera)
        };
        // Single-threaded: the cost of one photo.
        let t = Instant::now();
        let results: Vec<_> = (0..count).map(one).collect();
        let single = t.elapsed().as_secs_f64() / count as f64;
        // All threads over the photos: what a run of many photos costs per photo.
        let t = Instant::now();
        let _: Vec<_> = (0..count).into_par_iter().map(one).collect();
        let parallel = t.elapsed().as_secs_f64() / count as f64;
        let centre = Vec3::new(0.15, 0.11, 0.0);
        let (mut found, mut fewest, mut worst_mm_per_m, mut worst_deg) = (0, usize::MAX, 0.0f64, 0.0f64);
        for (r, truth) in results.iter().zip(&set.truths) {
            if let Ok(d) = r {
                let pose = truth.t_cam_target.expect("pose");
                let truth_c = pose.apply(&centre);
                found += 1;
                fewest = fewest.min(d.inliers);
                worst_mm_per_m = worst_mm_per_m.max((d.pose.to_camera(&centre) - truth_c).norm() * 1e3 / truth_c.z);
                worst_deg = worst_deg.max(d.pose.rotation.column(2).angle(&pose.normal()).to_degrees());
            }
        }
        println!(
            "slate {kind:?}: found {found} of {count}, fewest inliers {fewest}, worst centre error {worst_mm_per_m:.2} mm per m, worst normal {worst_deg:.2} deg; {single:.3} s per photo on 1 thread, {parallel:.3} s per photo on {threads} threads (target 0.5 s on 2 cores)"
        );
    }
}
