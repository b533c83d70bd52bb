//! Slate detection on rendered 4000x3000 photos of the example taped slate, 0.45-2.2 m,
//! against the exact pose.

mod common;

use calib_targets::rig::{fsl_laser, tg6_camera};
use calib_targets::scene::Water;
use common::{example_slate, slate_set, SceneSet};
use fslcal::vision::{find_slate, EncodedPhoto, Features, SlateModel};
use fslcal_core::Vec3;
use std::sync::OnceLock;
use std::time::Instant;

fn murky() -> &'static SceneSet {
    static SET: OnceLock<SceneSet> = OnceLock::new();
    SET.get_or_init(|| slate_set("slate-detect-murky", fsl_laser(), (0.45, 2.2), 6, 3, Water::Murky, 3))
}

#[test]
fn compare_features() {
    let set = murky();
    fslcal::vision::use_single_threaded_opencv();
    for kind in [Features::Orb, Features::Sift] {
        let model = SlateModel::new(example_slate(), kind).unwrap();
        for (p, truth) in set.photos.iter().zip(&set.truths) {
            let t = Instant::now();
            let enc = EncodedPhoto::read(p).unwrap();
            let r = find_slate(&model, &enc, &tg6_camera());
            let dt = t.elapsed().as_secs_f64();
            let pose = truth.t_cam_target.unwrap();
            match r {
                Ok(d) => {
                    let c = Vec3::new(0.15, 0.11, 0.0);
                    let err = (d.pose.to_camera(&c) - pose.apply(&c)).norm() * 1e3;
                    let n_err = d.pose.rotation.column(2).angle(&pose.normal()).to_degrees();
                    eprintln!("{kind:?} {:.2} m: {dt:.3} s, {} inl of {}, f {} {}, centre err {err:.2} mm, normal err {n_err:.3} deg, rms {:.2}", pose.translation_m[2], d.inliers, d.matches, d.found_at_factor, d.fine_factor, d.pose.rms_px);
                }
                Err(e) => eprintln!("{kind:?} {:.2} m: {dt:.3} s, {e}", pose.translation_m[2]),
            }
        }
    }
}
