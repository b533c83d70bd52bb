//! Camera files in OpenCV's FileStorage YAML, as written by OpenCV's calibration sample
//! (`image_width`, `image_height`, `camera_matrix`, `distortion_coefficients`).
//!
//! Read and written in plain Rust so that commands that never touch pixels (inspect,
//! verify, measure from given points) work without OpenCV. Only the subset OpenCV writes for
//! these keys is understood: scalars on one line, `!!opencv-matrix` maps with `rows`,
//! `cols`, `dt` and a `data: [ ... ]` list that may span lines.

use fslcal_core::{CameraModel, Distortion};
use std::path::Path;

#[derive(Debug, thiserror::Error)]
pub enum CameraFileError {
    /// The cause is in the message, not a `source`, or `{:#}` would say it twice.
    #[error("{path}: cannot read: {cause}")]
    Io { path: String, cause: std::io::Error },
    #[error("{path}: not an OpenCV camera file (no `%YAML` header); expected the YAML written by OpenCV's calibration sample or `fslcal camera --out`")]
    NotYaml { path: String },
    #[error("{path}: missing `{key}`; a camera file needs image_width, image_height, camera_matrix and distortion_coefficients")]
    Missing { path: String, key: &'static str },
    #[error("{path}: `{key}` is malformed: {why}")]
    Malformed { path: String, key: &'static str, why: String },
    #[error("{path}: the camera matrix is not plausible (focal lengths must be positive and the principal point inside the {w}x{h} image)")]
    Implausible { path: String, w: u32, h: u32 },
}

/// Extra figures OpenCV's sample writes beside the model.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CameraFileExtras {
    pub avg_reprojection_error: Option<f64>,
    /// Body serial of the camera the photos came from (EXIF), so photos from another body
    /// can be refused.
    pub camera_serial: Option<String>,
    /// Focal length of the calibration photos (EXIF), millimetres: another means zoom.
    pub focal_length_mm: Option<f64>,
}

fn scalar(text: &str, key: &str) -> Option<String> {
    text.lines().find_map(|l| {
        let l = l.trim_end();
        let rest = l.strip_prefix(key)?.strip_prefix(':')?;
        Some(rest.trim().to_string())
    })
}

fn matrix(text: &str, key: &'static str, path: &str) -> Result<Vec<f64>, CameraFileError> {
    let start = text
        .lines()
        .position(|l| l.starts_with(&format!("{key}:")))
        .ok_or_else(|| CameraFileError::Missing { path: path.into(), key })?;
    let body: String = text.lines().skip(start + 1).collect::<Vec<_>>().join("\n");
    let data_at = body.find("data:").ok_or_else(|| CameraFileError::Malformed {
        path: path.into(),
        key,
        why: "no `data:` list".into(),
    })?;
    let after = &body[data_at + 5..];
    let open =
        after.find('[').ok_or_else(|| CameraFileError::Malformed { path: path.into(), key, why: "no `[`".into() })?;
    let close = after.find(']').ok_or_else(|| CameraFileError::Malformed {
        path: path.into(),
        key,
        why: "no closing `]`".into(),
    })?;
    if close < open {
        return Err(CameraFileError::Malformed { path: path.into(), key, why: "`]` before `[`".into() });
    }
    after[open + 1..close]
        .split(',')
        .map(|s| s.trim())
        .filter(|s| !s.is_empty())
        .map(|s| {
            s.parse::<f64>().map_err(|_| CameraFileError::Malformed {
                path: path.into(),
                key,
                why: format!("`{s}` is not a number"),
            })
        })
        .collect()
}

/// Why an OpenCV camera matrix and distortion vector are not a camera fslcal can use.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum OpencvCameraProblem {
    /// This many coefficients, not representable in the 5-term model.
    Distortion(usize),
    /// Skew, a non-standard last row, or focal lengths or principal point out of range.
    Implausible,
}

/// The camera an OpenCV camera matrix (row-major 3x3) and distortion vector describe for a
/// `w` x `h` image. OpenCV may give 4, 5, 8, 12 or 14 coefficients; fslcal's model is the
/// 5-term one, so anything past k3 must be zero to be representable.
pub fn camera_from_opencv(w: u32, h: u32, k: &[f64; 9], d: &[f64]) -> Result<CameraModel, OpencvCameraProblem> {
    if d.len() < 4 || d.iter().skip(5).any(|&c| c != 0.0) {
        return Err(OpencvCameraProblem::Distortion(d.len()));
    }
    let mut c = [0.0; 5];
    c[..d.len().min(5)].copy_from_slice(&d[..d.len().min(5)]);
    let camera = CameraModel {
        width_px: w,
        height_px: h,
        fx_px: k[0],
        fy_px: k[4],
        cx_px: k[2],
        cy_px: k[5],
        distortion: Distortion::from_opencv(c),
    };
    if !camera.is_plausible() || k[1] != 0.0 || k[3] != 0.0 || k[6] != 0.0 || k[7] != 0.0 || k[8] != 1.0 {
        return Err(OpencvCameraProblem::Implausible);
    }
    Ok(camera)
}

/// Parses the text of an OpenCV camera file. `path` is only used in error messages.
pub fn parse(text: &str, path: &str) -> Result<(CameraModel, CameraFileExtras), CameraFileError> {
    if !text.trim_start().starts_with("%YAML") {
        return Err(CameraFileError::NotYaml { path: path.into() });
    }
    let int = |key: &'static str| -> Result<u32, CameraFileError> {
        let v = scalar(text, key).ok_or_else(|| CameraFileError::Missing { path: path.into(), key })?;
        v.parse::<u32>().map_err(|_| CameraFileError::Malformed {
            path: path.into(),
            key,
            why: format!("`{v}` is not a whole number"),
        })
    };
    let (w, h) = (int("image_width")?, int("image_height")?);
    let k = matrix(text, "camera_matrix", path)?;
    let k: [f64; 9] = k.as_slice().try_into().map_err(|_| CameraFileError::Malformed {
        path: path.into(),
        key: "camera_matrix",
        why: format!("{} values, expected 9", k.len()),
    })?;
    let d = matrix(text, "distortion_coefficients", path)?;
    let camera = camera_from_opencv(w, h, &k, &d).map_err(|problem| match problem {
        OpencvCameraProblem::Distortion(n) => CameraFileError::Malformed {
            path: path.into(),
            key: "distortion_coefficients",
            why: format!("{n} coefficients; fslcal uses OpenCV's 5-term model (k1, k2, p1, p2, k3)"),
        },
        OpencvCameraProblem::Implausible => CameraFileError::Implausible { path: path.into(), w, h },
    })?;
    let extras = CameraFileExtras {
        avg_reprojection_error: scalar(text, "avg_reprojection_error").and_then(|s| s.parse().ok()),
        camera_serial: scalar(text, "camera_serial").map(|s| s.trim_matches('"').to_string()).filter(|s| !s.is_empty()),
        focal_length_mm: scalar(text, "focal_length_mm").and_then(|s| s.parse().ok()),
    };
    Ok((camera, extras))
}

/// Reads an OpenCV camera file.
pub fn read(path: &Path) -> Result<(CameraModel, CameraFileExtras), CameraFileError> {
    let name = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|cause| CameraFileError::Io { path: name.clone(), cause })?;
    let text = String::from_utf8_lossy(&bytes);
    parse(&text, &name)
}

/// Renders a camera as OpenCV FileStorage YAML, in the layout of OpenCV's calibration sample.
pub fn to_yaml(camera: &CameraModel, extras: &CameraFileExtras) -> String {
    let d = camera.distortion.to_opencv();
    let mut s = String::from("%YAML:1.0\n---\n");
    s += &format!("image_width: {}\nimage_height: {}\n", camera.width_px, camera.height_px);
    s += "camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n";
    s += &format!(
        "   data: [ {:.17e}, 0., {:.17e}, 0., {:.17e}, {:.17e}, 0., 0., 1. ]\n",
        camera.fx_px, camera.cx_px, camera.fy_px, camera.cy_px
    );
    s += "distortion_coefficients: !!opencv-matrix\n   rows: 5\n   cols: 1\n   dt: d\n";
    s += &format!("   data: [ {:.17e}, {:.17e}, {:.17e}, {:.17e}, {:.17e} ]\n", d[0], d[1], d[2], d[3], d[4]);
    if let Some(e) = extras.avg_reprojection_error {
        s += &format!("avg_reprojection_error: {e:.17e}\n");
    }
    if let Some(serial) = &extras.camera_serial {
        s += &format!("camera_serial: \"{serial}\"\n");
    }
    if let Some(f) = extras.focal_length_mm {
        s += &format!("focal_length_mm: {f}\n");
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    const OPENCV_SAMPLE: &str = include_str!("../../tests/data/opencv-samples/left_intrinsics.yml");

    #[test]
    fn reads_opencvs_published_sample() {
        let (c, e) = parse(OPENCV_SAMPLE, "left_intrinsics.yml").unwrap();
        assert_eq!((c.width_px, c.height_px), (640, 480));
        assert!((c.fx_px - 535.915_733_961_632).abs() < 1e-9);
        assert!((c.cy_px - 235.570_829_097_881_73).abs() < 1e-9);
        assert!((c.distortion.k3 - 0.238_391_530_808_784_86).abs() < 1e-12);
        assert!((e.avg_reprojection_error.unwrap() - 0.392_590_989_755_813_64).abs() < 1e-12);
    }

    #[test]
    fn writes_what_it_reads() {
        let (c, e) = parse(OPENCV_SAMPLE, "x").unwrap();
        let (c2, e2) = parse(&to_yaml(&c, &e), "y").unwrap();
        assert_eq!(c, c2);
        assert_eq!(e, e2);
    }

    #[test]
    fn clear_errors() {
        let msg = |t: &str| parse(t, "cam.yml").unwrap_err().to_string();
        assert!(msg("hello").contains("not an OpenCV camera file"));
        assert!(msg("%YAML:1.0\nimage_width: 640\n").contains("missing `image_height`"));
        let cut = &OPENCV_SAMPLE[..OPENCV_SAMPLE.find("distortion_coefficients").unwrap()];
        assert!(msg(cut).contains("missing `distortion_coefficients`"));
        let bad = OPENCV_SAMPLE.replace("5.3591573396163199e+02, 0.,", "5.35x, 0.,");
        assert!(msg(&bad).contains("`5.35x` is not a number"), "{}", msg(&bad));
    }
}
