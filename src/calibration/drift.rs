//! `fslcal check`: has the laser moved since it was calibrated?
//!
//! Every photo with a dot is a check, fish photos included, since no target is needed: a
//! rigid laser's dot lies on the image of the calibrated line. Each dot's perpendicular
//! offset from that image is compared with what the calibration's covariance and the dot's
//! own localisation explain; a photo is flagged beyond [`FLAG_SIGMAS`] of that, and the
//! calibration is called drifted when at least half the photos are flagged (one dot taken
//! from a reflection must not condemn a calibration).
//!
//! A laser turned *within* the plane of the camera centre and the beam moves its dot along
//! the line's image, which no dot can show: that error changes the scale with range and is
//! what `fslcal validate`'s trend test catches.

use crate::calibration::Calibration;
use crate::dot::on_line::{find_dot_on_laser_line, LineSearch};
use crate::dot::on_target::detected_sigma_px;
use crate::laser::target::strip_path;
use crate::vision::{EncodedPhoto, Photo};
use fslcal_core::{CameraModel, LaserLine, Vec2, Vec3};
use nalgebra::{Matrix4, Vector4};
use rayon::prelude::*;
use std::path::{Path, PathBuf};

pub use super::outcome::{CheckOutcome, CheckSkip, PhotoCheck};

/// A photo is flagged when its offset exceeds this many sigmas of what is explained.
pub const FLAG_SIGMAS: f64 = 5.0;
/// Floor of a dot's localisation sigma, pixels: JPEG blocks and the dot model's own limits.
const DOT_SIGMA_FLOOR_PX: f64 = 0.3;

#[derive(Clone, Debug)]
pub struct DriftCheck {
    pub photos: Vec<PhotoCheck>,
    pub drifted: bool,
    /// Median over the photos with a dot of the implied change of the beam's direction.
    pub implied_direction_change_deg: Option<f64>,
}

#[derive(Debug, thiserror::Error)]
pub enum CheckError {
    #[error("{file}: the photo is {photo_w}x{photo_h} but the calibration's camera is {camera_w}x{camera_h}; use the calibration made for this camera (resized photos cannot be used)")]
    ImageSize { file: String, photo_w: u32, photo_h: u32, camera_w: u32, camera_h: u32 },
    /// Nothing to judge; every photo's line says why.
    #[error("no photo has a laser dot the calibration can judge (each photo's reason is listed)")]
    NoDots { photos: Vec<PhotoCheck> },
}

fn params(l: &LaserLine) -> Vector4<f64> {
    Vector4::new(l.origin_m[0], l.origin_m[1], l.direction[0] / l.direction[2], l.direction[1] / l.direction[2])
}

fn line_of(p: &Vector4<f64>) -> LaserLine {
    LaserLine::from_point_direction(Vec3::new(p[0], p[1], 0.0), Vec3::new(p[2], p[3], 1.0)).expect("forward direction")
}

/// 1-sigma of the line image's perpendicular position at depth `z_m`, pixels, from the
/// laser's covariance (first-order propagation).
pub fn line_sigma_px(camera: &CameraModel, laser: &LaserLine, cov: &Matrix4<f64>, z_m: f64) -> Option<f64> {
    let at = |l: &LaserLine, z: f64| l.pixel_at_depth(camera, z);
    let tangent = (at(laser, z_m * 1.01)? - at(laser, z_m * 0.99)?).try_normalize(1e-12)?;
    let normal = Vec2::new(-tangent.y, tangent.x);
    let p = params(laser);
    let mut j = Vector4::zeros();
    for k in 0..4 {
        let h = 1e-7;
        let (mut a, mut b) = (p, p);
        a[k] += h;
        b[k] -= h;
        j[k] = normal.dot(&(at(&line_of(&a), z_m)? - at(&line_of(&b), z_m)?)) / (2.0 * h);
    }
    Some((j.transpose() * cov * j)[0].max(0.0).sqrt())
}

/// Checks every photo against the calibration.
pub fn check(cal: &Calibration, photos: &[PathBuf], progress: &(dyn Fn() + Sync)) -> Result<DriftCheck, CheckError> {
    let cov = Matrix4::from(cal.laser_covariance).transpose();
    let search = LineSearch::default();
    let results: Vec<PhotoCheck> = photos
        .par_iter()
        .map(|path| -> Result<PhotoCheck, CheckError> {
            let photo = decode(path, cal);
            progress();
            let mut out = PhotoCheck { file: path.display().to_string(), ..PhotoCheck::default() };
            match photo? {
                Ok(photo) => check_photo(cal, &cov, &search, &photo, &mut out),
                Err(why) => out.reason = Some(why.into()),
            }
            Ok(out)
        })
        .collect::<Result<_, _>>()?;
    let with_dot: Vec<&PhotoCheck> = results.iter().filter(|p| p.explained_sigma_px.is_some()).collect();
    if with_dot.is_empty() {
        return Err(CheckError::NoDots { photos: results });
    }
    let flagged = with_dot.iter().filter(|p| p.flag).count();
    let mut changes: Vec<f64> = with_dot.iter().filter_map(|p| p.direction_change_deg).collect();
    changes.sort_by(f64::total_cmp);
    let implied = (!changes.is_empty()).then(|| changes[changes.len() / 2]);
    Ok(DriftCheck {
        drifted: flagged > 0 && 2 * flagged >= with_dot.len(),
        photos: results,
        implied_direction_change_deg: implied,
    })
}

/// The photo at `path`, decoded; `Ok(Err)` when it cannot be read, `Err` when it is not the
/// calibrated camera's size.
fn decode(path: &Path, cal: &Calibration) -> Result<Result<Photo, CheckSkip>, CheckError> {
    let file = path.display().to_string();
    let photo = EncodedPhoto::read(path).and_then(|e| Ok((e.dimensions()?, e.decode()?)));
    let ((w, h), photo) = match photo {
        Ok(p) => p,
        Err(e) => return Ok(Err(CheckSkip::Unreadable { detail: strip_path(&e.to_string(), &file) })),
    };
    let cam = &cal.camera;
    if (w, h) != (cam.width_px, cam.height_px) {
        return Err(CheckError::ImageSize {
            file,
            photo_w: w,
            photo_h: h,
            camera_w: cam.width_px,
            camera_h: cam.height_px,
        });
    }
    Ok(Ok(photo))
}

/// Finds the dot along the calibrated line's image and compares its offset with what the
/// calibration and the dot's localisation explain.
fn check_photo(cal: &Calibration, cov: &Matrix4<f64>, search: &LineSearch, photo: &Photo, out: &mut PhotoCheck) {
    let cam = &cal.camera;
    let dot = match find_dot_on_laser_line(&photo.colour(), cam, &cal.laser, search) {
        Ok(d) => d,
        Err(e) => {
            out.reason = Some(CheckSkip::NoDot(e).into());
            return;
        }
    };
    out.dot_px = Some([dot.pixel.x, dot.pixel.y]);
    out.offset_px = Some(dot.offset_px);
    let dot_sigma_px = detected_sigma_px(&dot.candidate).max(DOT_SIGMA_FLOOR_PX);
    judge_dot(cal, cov, dot.pixel, dot.offset_px, dot_sigma_px, out);
}

/// Judges a dot found at `pixel`, `offset_px` off the calibrated line's image: within what
/// the calibration and the dot's localisation explain, or flagged. A dot the calibration
/// gives no distance (its ray passes the beam behind the camera) cannot be judged, and is
/// said so: never "within" for want of a threshold.
fn judge_dot(
    cal: &Calibration,
    cov: &Matrix4<f64>,
    pixel: Vec2,
    offset_px: f64,
    dot_sigma_px: f64,
    out: &mut PhotoCheck,
) {
    let Some(fix) = cal.laser.fix_from_pixel(&cal.camera, pixel) else {
        out.reason = Some(CheckSkip::NoDistance { offset_px }.into());
        return;
    };
    out.distance_m = Some(fix.depth_m);
    out.direction_change_deg = Some(fix.miss_m.atan2(fix.along_laser_m.max(1e-9)).to_degrees());
    let line_sigma = line_sigma_px(&cal.camera, &cal.laser, cov, fix.depth_m).unwrap_or(0.0);
    let sigma = dot_sigma_px.hypot(line_sigma);
    out.explained_sigma_px = Some(sigma);
    out.flag = offset_px > FLAG_SIGMAS * sigma;
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The FishSense rig at 800x600, with a small covariance.
    fn calibration() -> Calibration {
        let camera = CameraModel {
            width_px: 800,
            height_px: 600,
            fx_px: 580.0,
            fy_px: 580.0,
            cx_px: 400.0,
            cy_px: 300.0,
            distortion: fslcal_core::Distortion::from_opencv([0.0; 5]),
        };
        let laser =
            LaserLine::from_point_direction(Vec3::new(-0.04, -0.105, 0.0), Vec3::new(0.0105, 0.022, 1.0)).unwrap();
        let (o, d) = (1e-8, 1e-9);
        Calibration {
            camera,
            laser,
            laser_covariance: [[o, 0.0, 0.0, 0.0], [0.0, o, 0.0, 0.0], [0.0, 0.0, d, 0.0], [0.0, 0.0, 0.0, d]],
            depth_range_m: Some((0.5, 5.0)),
            unit: None,
            camera_serial: None,
            focal_length_mm: None,
            source: "test".into(),
        }
    }

    #[test]
    fn a_dot_without_a_distance_is_not_judged_never_ok() {
        let cal = calibration();
        let cov = Matrix4::from(cal.laser_covariance).transpose();
        let (cam, laser) = (&cal.camera, &cal.laser);
        // Past the beam's vanishing point, on the far side from its near image: a blob on
        // the line's image extended, whose ray meets the beam only behind the camera.
        let vanishing = cam.project(&laser.dir()).unwrap();
        let near = laser.pixel_at_depth(cam, 0.5).unwrap();
        let beyond = vanishing + (vanishing - near).normalize() * 40.0;
        assert!(cam.contains(beyond) && laser.fix_from_pixel(cam, beyond).is_none(), "{beyond:?}");
        let mut out = PhotoCheck::default();
        judge_dot(&cal, &cov, beyond, 48.0, 0.5, &mut out);
        assert!(matches!(out.outcome(), CheckOutcome::Skipped(_)), "{:?}", out.outcome());
        assert!(out.reason.as_deref().unwrap().contains("48.0 px from the calibrated line"), "{:?}", out.reason);
        assert!(!out.flag && out.explained_sigma_px.is_none());
        // A dot on the line at 2 m is judged: within, and flagged once 48 px off it.
        let at_2m = laser.pixel_at_depth(cam, 2.0).unwrap();
        let mut out = PhotoCheck::default();
        judge_dot(&cal, &cov, at_2m, 0.4, 0.5, &mut out);
        assert_eq!(out.outcome(), CheckOutcome::Within);
        assert!((out.distance_m.unwrap() - 2.0).abs() < 1e-6);
        let mut out = PhotoCheck::default();
        judge_dot(&cal, &cov, at_2m, 48.0, 0.5, &mut out);
        assert_eq!(out.outcome(), CheckOutcome::Flagged);
    }

    /// The sweep (53 of 300 photos at 800x600 were "ok" though their dot had no
    /// distance): 300 seeded dots 48-77 px off the line's image, anywhere along it in the
    /// frame. Every dot without a distance is not judged; every dot with one is judged.
    #[test]
    fn a_sweep_of_dots_off_the_line_never_calls_one_without_a_distance_ok() {
        let cal = calibration();
        let cov = Matrix4::from(cal.laser_covariance).transpose();
        let (cam, laser) = (&cal.camera, &cal.laser);
        let near = laser.pixel_at_depth(cam, 0.5).unwrap();
        let along = (cam.project(&laser.dir()).unwrap() - near).normalize();
        let across = Vec2::new(-along.y, along.x);
        let mut state = 0x16_u64;
        let mut uniform = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let (mut dots, mut no_distance, mut not_judged, mut judged) = (0, 0, 0, 0);
        while dots < 300 {
            let offset_px = 48.0 + 29.0 * uniform();
            let side = if uniform() < 0.5 { -1.0 } else { 1.0 };
            let pixel = near + along * (1000.0 * (2.0 * uniform() - 1.0)) + across * (side * offset_px);
            if !cam.contains(pixel) {
                continue;
            }
            dots += 1;
            let mut out = PhotoCheck::default();
            judge_dot(&cal, &cov, pixel, offset_px, 0.5, &mut out);
            let has_distance = laser.fix_from_pixel(cam, pixel).is_some();
            no_distance += usize::from(!has_distance);
            match out.outcome() {
                CheckOutcome::Skipped(_) => {
                    assert!(!has_distance, "{pixel:?} has a distance yet was not judged");
                    not_judged += 1;
                }
                judged_as => {
                    assert!(has_distance, "{pixel:?} has no distance yet was judged {judged_as:?}");
                    judged += 1;
                }
            }
        }
        eprintln!("300 dots 48-77 px off the line at 800x600: {no_distance} without a distance, {not_judged} not judged, {judged} judged");
        // The sweep reaches the case it guards, and the rest are judged, not dropped.
        assert!(no_distance >= 30 && judged >= 30, "{no_distance} without a distance, {judged} judged");
        assert_eq!(not_judged, no_distance);
    }
}
