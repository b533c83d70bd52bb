//! The options every command that signs a unit file shares (`laser`, `import`).

// Only the commands that find targets (vision feature) use all of this.
#![cfg_attr(not(feature = "vision"), allow(dead_code))]

use crate::photo::identity::ExpectedCamera;
use crate::units::signed_file::{self, UnitFileError};
use fslcal_core::unit_file::{self, CameraIdentity, UnitFile};
use fslcal_core::CameraModel;
use std::path::PathBuf;

/// Who the calibration is for and who signs it.
#[derive(clap::Args, Debug, Clone)]
pub struct SigningArgs {
    /// The unit the calibration is for, `FSL-NN` (needed to write a signed .fslcal).
    #[arg(long, value_name = "FSL-NN")]
    pub unit: Option<String>,

    /// Secret key to sign with (from `fslcal keygen`).
    #[arg(long, value_name = "KEY")]
    pub key: Option<PathBuf>,

    /// Camera maker, as its EXIF `Make` says.
    #[arg(long, value_name = "MAKE", default_value = "OLYMPUS CORPORATION")]
    pub camera_make: String,

    /// Camera model, as its EXIF `Model` says.
    #[arg(long, value_name = "MODEL", default_value = "TG-6")]
    pub camera_model: String,

    /// Camera body serial number (EXIF `BodySerialNumber`), when known.
    #[arg(long, value_name = "SERIAL")]
    pub camera_serial: Option<String>,

    /// Water depth where the calibration photos were taken, metres.
    #[arg(long, value_name = "M", value_parser = super::parse::water_depth_m, allow_negative_numbers = true)]
    pub water_depth_m: Option<f32>,

    /// Replace a signed unit file already at --out; without it an existing .fslcal is never
    /// overwritten.
    #[arg(long)]
    pub force: bool,
}

impl SigningArgs {
    pub fn identity(&self) -> CameraIdentity<'_> {
        CameraIdentity { make: &self.camera_make, model: &self.camera_model, serial: self.camera_serial.as_deref() }
    }

    /// The canonical unit id and the key, both required to sign.
    pub fn unit_and_key(&self, out: &std::path::Path) -> anyhow::Result<(String, PathBuf)> {
        let (Some(unit), Some(key)) = (&self.unit, &self.key) else {
            anyhow::bail!(
                "{}: a signed unit file needs --unit FSL-NN and --key KEY (make one with `fslcal keygen`)",
                out.display()
            );
        };
        Ok((signed_file::unit_id(unit).map_err(|e: UnitFileError| anyhow::anyhow!(e))?, key.clone()))
    }
}

/// A camera given as a previous unit file: its unit and identity carry over.
#[derive(Debug, Clone)]
pub struct PriorUnit {
    pub unit: String,
    pub make: String,
    pub model: String,
    pub serial: Option<String>,
}

/// Reads `--camera`: an OpenCV camera file, or a previous signed unit file of the same unit
/// (told apart by its magic), which must be intact and, when --unit is given, that unit's.
/// Also returns the body (and zoom) the photos must come from, where the file records them.
pub fn read_camera(
    path: &std::path::Path,
    signing: &SigningArgs,
) -> anyhow::Result<(CameraModel, Option<PriorUnit>, ExpectedCamera)> {
    let bytes = signed_file::read_bytes(path)?;
    if !bytes.starts_with(&unit_file::MAGIC) {
        let (camera, extras) = crate::camera::opencv_yaml::read(path)?;
        let expected = ExpectedCamera { serial: extras.camera_serial, focal_length_mm: extras.focal_length_mm };
        return Ok((camera, None, expected));
    }
    let err = UnitFileError::at(path);
    let file = unit_file::SignedUnitFile::decode(&bytes).map_err(&err)?;
    file.check_signature().map_err(err)?;
    let c = &file.contents;
    let theirs = signed_file::unit_id(c.unit)?;
    if let Some(ours) = &signing.unit {
        let ours = signed_file::unit_id(ours)?;
        if ours != theirs {
            anyhow::bail!("{}: this is {theirs}'s calibration, not {ours}'s; give --camera the camera file or a unit file of {ours}", path.display());
        }
    }
    let id = &c.camera_identity;
    let prior =
        PriorUnit { unit: theirs, make: id.make.into(), model: id.model.into(), serial: id.serial.map(str::to_string) };
    let expected = ExpectedCamera { serial: prior.serial.clone(), focal_length_mm: None };
    Ok((c.camera, Some(prior), expected))
}

/// True when `out` names a signed unit file rather than a JSON result.
pub fn is_unit_file_path(out: &std::path::Path) -> bool {
    out.extension().is_some_and(|e| e == "fslcal")
}

/// Signs `contents` (its unit and identity filled here from the options, or from the prior
/// unit file the camera came from) into `out`; returns the file's size.
pub fn sign_unit_file(
    out: &std::path::Path,
    signing: &SigningArgs,
    prior: Option<&PriorUnit>,
    contents: UnitFile<'_>,
) -> anyhow::Result<usize> {
    let mut signing = signing.clone();
    if let Some(p) = prior {
        signing.unit.get_or_insert_with(|| p.unit.clone());
        // The identity recorded with the camera's own calibration wins over the defaults.
        signing.camera_make = p.make.clone();
        signing.camera_model = p.model.clone();
        signing.camera_serial = signing.camera_serial.or_else(|| p.serial.clone());
    }
    let (unit, key) = signing.unit_and_key(out)?;
    let contents =
        UnitFile { unit: &unit, camera_identity: signing.identity(), water_depth_m: signing.water_depth_m, ..contents };
    Ok(signed_file::sign_to_file(&contents, &key, out)?)
}
