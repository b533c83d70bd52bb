//! The targets the laser chain can use (a checkerboard or a taped slate): naming one on
//! the command line, finding it in a photo, solving its pose `T_cam_target`, and its outline
//! in the image, which bounds the dot's search.

use crate::dot::candidates::{ColourView, DotCandidate, DotDetectorParams, SearchRegion};
use crate::dot::on_target::{self, Surface};
use crate::reason::Reason;
use crate::vision::{self, EncodedPhoto, Photo, SlateMiss, SlateModel, TargetPose, VisionError};
use calib_targets::Checkerboard;
use fslcal_core::{CameraModel, Vec2, Vec3};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::outcome::{TargetMiss, MAX_BOARD_RMS_PX};
use super::pipeline::LaserError;

/// A target the chain can find and solve the pose of.
#[derive(Clone)]
pub enum Target {
    Checkerboard(Checkerboard),
    /// A taped slate with its scan's features, shared between threads.
    Slate(Arc<SlateModel>),
}

impl Target {
    /// What the dot search sees this target as.
    pub fn surface(&self) -> Surface {
        match self {
            Target::Checkerboard(_) => Surface::Checkerboard,
            Target::Slate(_) => Surface::Slate,
        }
    }

    /// Dot candidates on this target's image, best first (see [`on_target::find`]).
    pub fn find_dots(
        &self,
        img: &ColourView<'_>,
        region: &SearchRegion,
        params: &DotDetectorParams,
        max: usize,
    ) -> Vec<DotCandidate> {
        on_target::find(self.surface(), img, region, params, max)
    }
}

impl From<Checkerboard> for Target {
    fn from(b: Checkerboard) -> Self {
        Target::Checkerboard(b)
    }
}

impl std::fmt::Debug for Target {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{self}")
    }
}

impl std::fmt::Display for Target {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Target::Checkerboard(b) => write!(f, "{b}"),
            Target::Slate(m) => write!(f, "slate:{}", m.slate.definition.display()),
        }
    }
}

/// A target as named on the command line, before a slate's definition is read:
/// `checkerboard:COLSxROWS@SQUAREmm` or `slate:PATH.toml`.
#[derive(Clone, Debug, PartialEq)]
pub enum TargetArg {
    Checkerboard(Checkerboard),
    Slate(PathBuf),
}

impl std::str::FromStr for TargetArg {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.trim().split_once(':') {
            Some(("slate", path)) if !path.trim().is_empty() => Ok(TargetArg::Slate(PathBuf::from(path.trim()))),
            Some(("slate", _)) => Err("`slate:` needs the slate's definition, e.g. slate:my-slate/slate.toml".into()),
            _ => parse_checkerboard(s).map(TargetArg::Checkerboard).map_err(|e| format!("{e}, or slate:PATH.toml")),
        }
    }
}

/// Most inner corners along a side fslcal takes: a board of more is a typing slip.
const MAX_INNER_CORNERS: u32 = 100;

/// A checkerboard named on the command line, `[checkerboard:]COLSxROWS@SQUAREmm`, checked
/// beyond what the target's own parser knows: OpenCV's finder needs at least 3x3 inner
/// corners, a square measured in another unit (`42.17cm`) is told as such with the size in
/// millimetres, and an absurd size is printed readably.
pub fn parse_checkerboard(text: &str) -> Result<Checkerboard, String> {
    let body = text.trim();
    let body = body.strip_prefix("checkerboard:").unwrap_or(body);
    if let Some((_, square)) = body.split_once('@') {
        check_square(text, square.trim())?;
    }
    let board =
        body.parse::<Checkerboard>().map_err(|e| e.to_string().replace(&format!("`{body}`"), &format!("`{text}`")))?;
    let (cols, rows) = (board.inner_cols, board.inner_rows);
    if cols < 3 || rows < 3 {
        return Err(format!("`{text}`: OpenCV finds boards of 3x3 inner corners or more (count the corners where four squares meet, not the squares)"));
    }
    if cols > MAX_INNER_CORNERS || rows > MAX_INNER_CORNERS {
        return Err(format!(
            "`{text}`: {cols}x{rows} inner corners is not a board fslcal can find (at most {MAX_INNER_CORNERS} a side)"
        ));
    }
    Ok(board)
}

/// The square size `SIZEUNIT` of a board: in mm or m, plausible, or refused saying what
/// it would be in millimetres.
fn check_square(text: &str, square: &str) -> Result<(), String> {
    let unit_len =
        square.chars().rev().take_while(|c| c.is_alphabetic() || *c == '"').map(char::len_utf8).sum::<usize>();
    let (number, unit) = square.split_at(square.len() - unit_len);
    let Ok(value) = number.trim().parse::<f64>() else { return Ok(()) };
    let to_mm = match unit {
        "mm" => 1.0,
        "m" => 1e3,
        "cm" => 10.0,
        "in" | "inch" | "inches" | "\"" => 25.4,
        "um" | "µm" => 1e-3,
        "" => {
            return Err(format!(
                "`{text}`: the square size needs a unit: `{}mm` (millimetres) or `{}m`",
                number.trim(),
                number.trim()
            ))
        }
        _ => {
            return Err(format!(
                "`{text}`: `{unit}` is not a unit for the square size; give millimetres (e.g. 42.17mm) or metres"
            ))
        }
    };
    let mm = value * to_mm;
    if !(1.0..=500.0).contains(&mm) {
        return Err(format!("`{text}`: a {} mm square is not plausible (1-500 mm)", crate::cli::show_number(mm)));
    }
    if !matches!(unit, "mm" | "m") {
        return Err(format!(
            "`{text}`: the square size is in {unit}; fslcal takes mm or m: write `{}mm`",
            crate::cli::show_number(mm)
        ));
    }
    Ok(())
}

/// Why a slate named on the command line cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum TargetError {
    /// Its definition cannot be read.
    #[error(transparent)]
    Definition(#[from] calib_targets::SlateError),
    /// Its scan's features cannot be computed.
    #[error(transparent)]
    Scan(#[from] VisionError),
}

impl TargetArg {
    /// Reads a slate's definition and its scan's features; a checkerboard needs nothing.
    pub fn load(&self) -> Result<Target, TargetError> {
        match self {
            TargetArg::Checkerboard(b) => Ok(Target::Checkerboard(*b)),
            TargetArg::Slate(path) => {
                let slate = calib_targets::Slate::load(path)?;
                let model = SlateModel::new(slate, vision::Features::Orb)?;
                Ok(Target::Slate(Arc::new(model)))
            }
        }
    }
}

/// A target found in a photo: its pose, its outline in the image, and the decoded photo.
pub struct LocatedTarget {
    pub pose: TargetPose,
    /// The physical target's outline in the image (padded), pixels.
    pub outline_px: Vec<Vec2>,
    pub photo: Photo,
    /// Reduction factor the target was found at (4 = quarter size).
    pub found_at_factor: u32,
    /// Feature inliers of a slate's match (a checkerboard has none).
    pub inliers: Option<usize>,
    /// A checkerboard's inner corners as refined, row by row (a slate has none).
    pub corners_px: Vec<Vec2>,
}

/// Finds `target` in the photo at `path` and solves its pose. `Ok(Err(why))` when the
/// photo cannot be used (the reason omits the file name); `Err` for a photo of the wrong size.
pub fn locate_target(
    target: &Target,
    camera: &CameraModel,
    path: &Path,
) -> Result<Result<LocatedTarget, Reason<TargetMiss>>, LaserError> {
    let file = path.display().to_string();
    let encoded = match EncodedPhoto::read(path) {
        Ok(e) => e,
        Err(e) => return Ok(Err(unreadable(path, &e).into())),
    };
    let (w, h) = match encoded.dimensions() {
        Ok(d) => d,
        Err(e) => return Ok(Err(unreadable(path, &e).into())),
    };
    if (w, h) != (camera.width_px, camera.height_px) {
        return Err(LaserError::ImageSize {
            file,
            photo_w: w,
            photo_h: h,
            camera_w: camera.width_px,
            camera_h: camera.height_px,
        });
    }
    let located = match target {
        Target::Checkerboard(board) => locate_board(board, camera, &encoded, &file),
        Target::Slate(model) => locate_slate(model, camera, &encoded, &file),
    };
    Ok(located.map_err(Reason::from))
}

fn locate_slate(
    model: &SlateModel,
    camera: &CameraModel,
    encoded: &EncodedPhoto,
    file: &str,
) -> Result<LocatedTarget, TargetMiss> {
    let d = vision::find_slate(model, encoded, camera).map_err(|miss| {
        let detail = strip_path(&miss.to_string(), file);
        match miss {
            SlateMiss::NotFound { .. } | SlateMiss::Weak { .. } => TargetMiss::NoSlate { detail },
            SlateMiss::Implausible(_) => TargetMiss::SlatePose { detail },
            SlateMiss::Vision(_) => TargetMiss::Vision { detail },
        }
    })?;
    let slate = &model.slate;
    let outline = target_outline_px(camera, &slate.outline_m(), 0.02 * slate.width_m.max(slate.height_m), &d.pose);
    Ok(LocatedTarget {
        pose: d.pose,
        outline_px: outline,
        photo: d.photo,
        found_at_factor: d.found_at_factor,
        inliers: Some(d.inliers),
        corners_px: Vec::new(),
    })
}

fn locate_board(
    board: &Checkerboard,
    camera: &CameraModel,
    encoded: &EncodedPhoto,
    file: &str,
) -> Result<LocatedTarget, TargetMiss> {
    let (cols, rows) = (board.inner_cols, board.inner_rows);
    let failed = |e: VisionError| TargetMiss::Vision { detail: strip_path(&e.to_string(), file) };
    let photo = encoded.decode().map_err(failed)?;
    let search = match vision::find_checkerboard(&photo, encoded.path, cols, rows) {
        Ok(Some(s)) => s,
        Ok(None) => return Err(TargetMiss::NoCheckerboard { cols, rows }),
        Err(e) => return Err(failed(e)),
    };
    let mut corners = search.corners_px;
    if let Err(e) = vision::refine_corners(&photo, &mut corners, cols, rows) {
        return Err(TargetMiss::CornerRefinement { detail: e.message });
    }
    let object: Vec<Vec3> = board.object_points().iter().map(|p| Vec3::new(p[0], p[1], p[2])).collect();
    let solve = |corners: &[Vec2]| match vision::solve_pose(camera, &object, corners) {
        Ok(Some(p)) => Ok(p),
        Ok(None) | Err(_) => Err(TargetMiss::PoseUnsolved),
    };
    let mut pose = solve(&corners)?;
    // A board completed from part of its corners has some under whatever hid them, refined
    // onto it (a bubble's rim 10 px away): few enough to pass the gate, they tilt the pose.
    let partial = matches!(search.step, vision::SearchStep::Partial { .. });
    let most_strays = if partial { MAX_STRAY_CORNERS_PARTIAL } else { MAX_STRAY_CORNERS };
    if pose.rms_px > MAX_BOARD_RMS_PX || partial {
        if let Some(reseated) = reseat_stray_corners(camera, &object, &pose, &corners, most_strays) {
            corners = reseated;
            pose = solve(&corners)?;
        }
    }
    // A pose whose corners do not reproject is a wrong camera file or a misdetected board.
    if pose.rms_px > MAX_BOARD_RMS_PX {
        return Err(TargetMiss::CornersReproject { rms_px: pose.rms_px });
    }
    let outline = board_outline_px(camera, board, &pose);
    Ok(LocatedTarget {
        pose,
        outline_px: outline,
        photo,
        found_at_factor: search.found_at_factor,
        inliers: None,
        corners_px: corners,
    })
}

/// A corner this far from where the other corners' pose puts it was pulled off by something
/// on the board (the laser dot or a glint beside it), pixels.
const STRAY_CORNER_PX: f64 = 3.0;

/// At most this many stray corners are re-seated; more is a misdetected board or a wrong
/// camera file, which the reprojection gate must report.
const MAX_STRAY_CORNERS: usize = 3;

/// The same for a board completed from part of its corners ([`vision::SearchStep::Partial`]):
/// the corners its grid did not see may stray, as long as they are a tenth of the board's
/// at most (the grid held at least half).
const MAX_STRAY_CORNERS_PARTIAL: usize = 14;

/// The corners with the few strays put where the others' pose puts them. One corner refined
/// onto the laser dot 24 px away made a board's RMS 2.03 px and lost the photo (2 of 53
/// tuning calibration photos, seeds 8-11); the other 139 corners fix that corner's place to
/// a fraction of a pixel. `None` when no corner or too many corners stray.
fn reseat_stray_corners(
    camera: &CameraModel,
    object: &[Vec3],
    pose: &TargetPose,
    corners: &[Vec2],
    most: usize,
) -> Option<Vec<Vec2>> {
    let stray: Vec<bool> = object
        .iter()
        .zip(corners)
        .map(|(o, c)| camera.project(&pose.to_camera(o)).map(|q| (q - c).norm() > STRAY_CORNER_PX))
        .collect::<Option<_>>()?;
    let n = stray.iter().filter(|&&s| s).count();
    if n == 0 || n > most {
        return None;
    }
    // The pose again without the strays, which pulled it.
    let (kept_object, kept_corners): (Vec<Vec3>, Vec<Vec2>) =
        object.iter().zip(corners).zip(&stray).filter(|(_, &s)| !s).map(|((o, c), _)| (*o, *c)).unzip();
    let clean = vision::solve_pose(camera, &kept_object, &kept_corners).ok()??;
    object
        .iter()
        .zip(corners)
        .zip(&stray)
        .map(|((o, c), &s)| if s { camera.project(&clean.to_camera(o)) } else { Some(*c) })
        .collect()
}

/// The board's physical outline projected into the image, padded by half a square so a
/// dot on the board's edge is still searched.
fn board_outline_px(camera: &CameraModel, board: &Checkerboard, pose: &TargetPose) -> Vec<Vec2> {
    target_outline_px(camera, &board.outline_m(), 0.5 * board.square_m, pose)
}

/// A target's outline (target frame, metres) projected into the image, each corner pushed
/// `pad_m` outward from the centre.
fn target_outline_px(camera: &CameraModel, outline: &[[f64; 3]; 4], pad_m: f64, pose: &TargetPose) -> Vec<Vec2> {
    let centre = outline.iter().fold(Vec3::zeros(), |a, p| a + Vec3::new(p[0], p[1], p[2])) / 4.0;
    outline
        .iter()
        .filter_map(|p| {
            let p = Vec3::new(p[0], p[1], p[2]);
            let out = p + (p - centre).normalize() * pad_m;
            camera.project(&pose.to_camera(&out))
        })
        .collect()
}

/// The photo at `path` could not be read or decoded: the reader's message, without the path
/// the report already names.
pub(crate) fn unreadable(path: &Path, e: &VisionError) -> TargetMiss {
    TargetMiss::Unreadable { detail: strip_path(&e.to_string(), &path.display().to_string()) }
}

/// Error texts from the vision module start with the path; the report already names it.
pub(crate) fn strip_path(message: &str, file: &str) -> String {
    message
        .strip_prefix(file)
        .map(|m| m.trim_start_matches(':').trim().to_string())
        .unwrap_or_else(|| message.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Rotation3;

    /// A 14x10 board 0.6 m away, tilted, seen by a 4000x3000 camera: one corner pulled 24 px
    /// onto a dot is put back to within a tenth of a pixel; four pulled corners are left for
    /// the reprojection gate.
    #[test]
    fn one_stray_corner_is_reseated_and_many_are_not() {
        let camera = CameraModel {
            width_px: 4000,
            height_px: 3000,
            fx_px: 3000.0,
            fy_px: 3000.0,
            cx_px: 2000.0,
            cy_px: 1500.0,
            distortion: fslcal_core::Distortion::from_opencv([-0.14, 0.08, 0.0, 0.0, -0.03]),
        };
        let board = Checkerboard::fishsense();
        let object: Vec<Vec3> = board.object_points().iter().map(|p| Vec3::new(p[0], p[1], p[2])).collect();
        let rotation = *Rotation3::from_euler_angles(0.3, -0.2, 0.05).matrix();
        let truth = TargetPose { rotation, translation_m: Vec3::new(-0.3, -0.2, 0.6), rms_px: 0.0, worst_px: 0.0 };
        let exact: Vec<Vec2> = object.iter().map(|o| camera.project(&truth.to_camera(o)).unwrap()).collect();
        let pulled = |n: usize| -> Vec<Vec2> {
            let mut c = exact.clone();
            for k in 0..n {
                c[37 + 20 * k] += Vec2::new(19.0, -14.6);
            }
            c
        };
        let one = pulled(1);
        let pose = vision::solve_pose(&camera, &object, &one).unwrap().unwrap();
        assert!(pose.rms_px > MAX_BOARD_RMS_PX, "{}", pose.rms_px);
        let fixed = reseat_stray_corners(&camera, &object, &pose, &one, MAX_STRAY_CORNERS).expect("one stray");
        assert!((fixed[37] - exact[37]).norm() < 0.1, "{:?} vs {:?}", fixed[37], exact[37]);
        let four = pulled(4);
        let pose = vision::solve_pose(&camera, &object, &four).unwrap().unwrap();
        assert!(reseat_stray_corners(&camera, &object, &pose, &four, MAX_STRAY_CORNERS).is_none());
        let pose = vision::solve_pose(&camera, &object, &exact).unwrap().unwrap();
        assert!(reseat_stray_corners(&camera, &object, &pose, &exact, MAX_STRAY_CORNERS).is_none());
    }
}
