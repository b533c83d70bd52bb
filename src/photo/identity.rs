//! Is this photo from the camera the calibration was made for, at the same zoom?
//!
//! A calibration holds for one body and one focal length. A photo from another body (units
//! get swapped between housings on a boat) is refused unless the user says otherwise; a
//! different focal length means the zoom was used (thesis appendix C.4: "do not use the
//! zoom function") and gets a warning, since the intrinsics no longer hold.

use crate::calibration::Calibration;
use crate::photo::exif::PhotoExif;
use std::path::Path;

/// What the calibration says about its camera.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ExpectedCamera {
    pub serial: Option<String>,
    pub focal_length_mm: Option<f64>,
}

impl From<&Calibration> for ExpectedCamera {
    fn from(cal: &Calibration) -> Self {
        ExpectedCamera { serial: cal.camera_serial.clone(), focal_length_mm: cal.focal_length_mm }
    }
}

#[derive(Debug, thiserror::Error)]
#[error("{file}: taken with camera body {photo_serial}, but the calibration is for body {expected_serial}; use that unit's calibration, or pass --allow-other-body if the body was swapped on purpose")]
pub struct OtherBody {
    pub file: String,
    pub photo_serial: String,
    pub expected_serial: String,
}

/// Focal lengths closer than this are the same zoom setting (EXIF rounds to 0.1 mm).
const SAME_FOCAL_MM: f64 = 0.05;

/// Checks one photo's EXIF (`None`: the photo has none) against the calibration's camera.
/// `Ok` holds warnings to show; `Err` is a refusal, which `allow_other_body` turns into a
/// warning.
pub fn check_photo(
    expected: &ExpectedCamera,
    file: &Path,
    exif: Option<&PhotoExif>,
    allow_other_body: bool,
) -> Result<Vec<String>, OtherBody> {
    let name = file.display().to_string();
    let mut warnings = Vec::new();
    if let Some(want) = &expected.serial {
        match exif.and_then(|e| e.serial.as_ref()) {
            Some(got) if got != want => {
                let refusal =
                    OtherBody { file: name.clone(), photo_serial: got.clone(), expected_serial: want.clone() };
                if !allow_other_body {
                    return Err(refusal);
                }
                warnings.push(format!(
                    "{name}: camera body {got}, not the calibration's {want} (allowed by --allow-other-body)"
                ));
            }
            Some(_) => {}
            None => {
                warnings.push(format!("{name}: the photo records no camera serial; cannot check it is body {want}"))
            }
        }
    }
    if let (Some(want), Some(got)) = (expected.focal_length_mm, exif.and_then(|e| e.focal_length_mm)) {
        if (want - got).abs() > SAME_FOCAL_MM {
            warnings.push(format!(
                "{name}: focal length {got:.1} mm, the calibration's is {want:.1} mm: the zoom was used, and the calibration does not hold for it (thesis C.4)"
            ));
        }
    }
    Ok(warnings)
}

/// [`check_photo`] over photo files, reading each one's EXIF. Stops at the first refusal.
pub fn check_photos(
    expected: &ExpectedCamera,
    photos: &[impl AsRef<Path>],
    allow_other_body: bool,
) -> Result<Vec<String>, OtherBody> {
    let mut warnings = Vec::new();
    if expected.serial.is_none() && expected.focal_length_mm.is_none() {
        return Ok(warnings);
    }
    for p in photos {
        let exif = PhotoExif::read_file(p.as_ref());
        warnings.extend(check_photo(expected, p.as_ref(), exif.as_ref(), allow_other_body)?);
    }
    Ok(warnings)
}

/// Each photo's EXIF (`None` where it has none), and the body serial and focal length the
/// photos agree on.
pub type PhotosExif = (Vec<Option<PhotoExif>>, Option<String>, Option<f64>);

/// The photos' EXIF, and the body serial and focal length they agree on (what a later
/// `--cal` checks photos against).
pub fn photos_exif(photos: &[impl AsRef<Path>]) -> PhotosExif {
    let exif: Vec<Option<PhotoExif>> = photos.iter().map(|p| PhotoExif::read_file(p.as_ref())).collect();
    let agreed = |get: &dyn Fn(&PhotoExif) -> Option<String>| -> Option<String> {
        let mut values = exif.iter().map(|e| e.as_ref().and_then(get));
        let first = values.next()??;
        values.all(|v| v.as_ref() == Some(&first)).then_some(first)
    };
    let serial = agreed(&|e| e.serial.clone());
    let focal = agreed(&|e| e.focal_length_mm.map(|f| format!("{f}"))).and_then(|f| f.parse().ok());
    (exif, serial, focal)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn exif(serial: Option<&str>, focal: Option<f64>) -> PhotoExif {
        PhotoExif { serial: serial.map(String::from), focal_length_mm: focal, ..PhotoExif::default() }
    }

    #[test]
    fn refuses_another_body_unless_allowed_and_warns_on_zoom() {
        let want = ExpectedCamera { serial: Some("BHR1".into()), focal_length_mm: Some(4.5) };
        let p = Path::new("dive/P1.ORF");
        assert!(check_photo(&want, p, Some(&exif(Some("BHR1"), Some(4.5))), false).unwrap().is_empty());
        let err = check_photo(&want, p, Some(&exif(Some("BHR9"), Some(4.5))), false).unwrap_err().to_string();
        assert!(
            err.starts_with("dive/P1.ORF: taken with camera body BHR9") && err.contains("--allow-other-body"),
            "{err}"
        );
        assert!(!err.contains('\n'));
        let w = check_photo(&want, p, Some(&exif(Some("BHR9"), Some(4.5))), true).unwrap();
        assert_eq!(w.len(), 1);
        let w = check_photo(&want, p, Some(&exif(Some("BHR1"), Some(8.1))), false).unwrap();
        assert!(w.len() == 1 && w[0].contains("zoom"), "{w:?}");
        // No EXIF at all (a PNG): a warning, not a refusal.
        assert_eq!(check_photo(&want, p, None, false).unwrap().len(), 1);
        assert!(check_photo(&ExpectedCamera::default(), p, Some(&exif(Some("X"), Some(9.0))), false)
            .unwrap()
            .is_empty());
    }
}
