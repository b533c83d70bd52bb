//! The camera chain on rendered underwater scenes with known intrinsics (the TG-6 behind its
//! corrective port, 4000x3000, strong barrel distortion; boards at 0.5-1.6 m, tilted up to
//! 35 degrees, spread over the frame).

mod common;

use calib_targets::scene::{camera_scene_set, Water};
use calib_targets::Checkerboard;
use common::{camera_figures, render_set};
use fslcal::camera::calibrate::{calibrate, CameraJob};
use fslcal::camera::opencv_yaml;

#[test]
fn rendered_scenes_recover_the_true_intrinsics() {
    let set = render_set("camera-clear", &camera_scene_set(10, 5, Water::Clear));
    let (truth, _) = opencv_yaml::read(&set.camera_file).unwrap();
    let cal =
        calibrate(&CameraJob::new(Checkerboard::fishsense()), &set.photos, &|| {}).unwrap_or_else(|e| panic!("{e}"));
    let c = &cal.camera;
    let fx_err = (c.fx_px / truth.fx_px - 1.0) * 100.0;
    let fy_err = (c.fy_px / truth.fy_px - 1.0) * 100.0;
    let pp_err = ((c.cx_px - truth.cx_px).powi(2) + (c.cy_px - truth.cy_px).powi(2)).sqrt();
    eprintln!("rendered camera scenes: {}", camera_figures(&cal));
    eprintln!(
        "fx {:.2} (truth {:.2}, {fx_err:+.3}%, 1-sigma {:.2}), fy {:.2} (truth {:.2}, {fy_err:+.3}%, 1-sigma {:.2}), cx {:.2} cy {:.2} (truth {:.2} {:.2}, {pp_err:.2} px off; 1-sigma {:.2} {:.2})",
        c.fx_px, truth.fx_px, cal.sigma[0], c.fy_px, truth.fy_px, cal.sigma[1], c.cx_px, c.cy_px, truth.cx_px, truth.cy_px, cal.sigma[2], cal.sigma[3]
    );
    eprintln!("distortion {:?} (truth {:?})", c.distortion.to_opencv(), truth.distortion.to_opencv());
    assert!(fx_err.abs() < 0.3 && fy_err.abs() < 0.3, "fx {fx_err}% fy {fy_err}%");
    assert!(pp_err < 3.0, "principal point {pp_err} px off");
    assert!(cal.used_photos() >= 9, "{} used", cal.used_photos());
    // Honest uncertainty: the truth within 4 sigma of the estimate.
    for (k, (est, tru)) in
        [(c.fx_px, truth.fx_px), (c.fy_px, truth.fy_px), (c.cx_px, truth.cx_px), (c.cy_px, truth.cy_px)]
            .iter()
            .enumerate()
    {
        assert!((est - tru).abs() < 4.0 * cal.sigma[k] + 0.5, "parameter {k}: {est} vs {tru}, sigma {}", cal.sigma[k]);
    }
}
