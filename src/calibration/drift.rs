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
    #[error("no photo has a laser dot near the calibrated line; see the reasons above")]
    NoDots,
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
        return Err(CheckError::NoDots);
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
    if let Some(fix) = cal.laser.fix_from_pixel(cam, dot.pixel) {
        out.distance_m = Some(fix.depth_m);
        out.direction_change_deg = Some(fix.miss_m.atan2(fix.along_laser_m.max(1e-9)).to_degrees());
        let dot_sigma = detected_sigma_px(&dot.candidate).max(DOT_SIGMA_FLOOR_PX);
        let line_sigma = line_sigma_px(cam, &cal.laser, cov, fix.depth_m).unwrap_or(0.0);
        let sigma = dot_sigma.hypot(line_sigma);
        out.explained_sigma_px = Some(sigma);
        out.flag = dot.offset_px > FLAG_SIGMAS * sigma;
    }
}
