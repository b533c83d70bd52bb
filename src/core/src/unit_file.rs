//! The signed per-unit calibration file (`.fslcal`), the one implementation used by the CLI
//! and by the camera companion. The wire format is specified in `docs/calib-format.md`; a
//! golden test holds this code to the worked example there byte for byte.
//!
//! ```text
//! "FSLC"  version:u8  total_len:u16le  postcard(payload)  ed25519 signature (64 bytes)
//! └──────────────────── signed ─────────────────────────┘
//! ```
//!
//! Decoding borrows every string from the input and never allocates, so a `no_std` target
//! without a heap can decode and verify. Nothing in here panics on any input: the decoder is
//! fuzzed (`src/core/fuzz/`) and mutation-tested (`tests/unit_file_robustness.rs`).

use crate::{CameraModel, Distortion, LaserLine};
use ed25519_dalek::{Signature, Signer, SigningKey, VerifyingKey};
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

/// The first four bytes of every calibration file.
pub const MAGIC: [u8; 4] = *b"FSLC";
/// The newest format version this build writes and reads; it reads every older one too.
pub const VERSION: u8 = 3;
/// Magic, version and the total length, in every version.
pub const HEADER_BYTES: usize = 7;
pub const SIGNATURE_BYTES: usize = 64;
/// A complete file never exceeds this: it must fit a camera companion's fixed buffer.
pub const MAX_FILE_BYTES: usize = 512;
/// Longest unit id, camera make, model or serial, and target description, in bytes.
pub const MAX_TEXT_BYTES: usize = 64;

/// What can be wrong with a calibration file (or with one about to be signed).
///
/// The messages name no file: the caller prefixes the path.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum FormatError {
    #[error("truncated: the file ends early ({found} of {expected} bytes); copy it again from the original")]
    Truncated { found: usize, expected: usize },
    #[error("not a calibration file (it does not start with the FSLC magic)")]
    NotACalibrationFile,
    #[error(
        "written by a newer fslcal (format version {found}; this build reads versions 1 to {supported}); update fslcal"
    )]
    NewerVersion { found: u8, supported: u8 },
    #[error("corrupt ({0}); the file was damaged or altered, copy it again from the original")]
    Corrupt(&'static str),
    #[error("tampered: the signature does not match the contents; the file was altered after signing")]
    BadSignature,
    #[error("signed by unknown key {0}; trust that key's .pub only if you know who holds it")]
    UnknownSigner(KeyId),
    #[error("cannot sign: {0}")]
    Unsignable(&'static str),
}

/// Short name of a signing key: the first 8 bytes of SHA-256 of its 32-byte public key,
/// printed as 16 hex digits.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct KeyId(pub [u8; 8]);

impl KeyId {
    pub fn of(public_key: &[u8; 32]) -> Self {
        let digest = Sha256::digest(public_key);
        let mut id = [0u8; 8];
        id.copy_from_slice(&digest[..8]);
        KeyId(id)
    }
}

impl core::fmt::Display for KeyId {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        self.0.iter().try_for_each(|b| write!(f, "{b:02x}"))
    }
}

/// The ed25519 public key of a 32-byte secret key (seed).
pub fn public_key(secret_key: &[u8; 32]) -> [u8; 32] {
    SigningKey::from_bytes(secret_key).verifying_key().to_bytes()
}

/// Which camera body the intrinsics belong to.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CameraIdentity<'a> {
    pub make: &'a str,
    pub model: &'a str,
    /// Body serial number, where the photos' metadata carried it.
    #[serde(borrow)]
    pub serial: Option<&'a str>,
}

/// Intrinsics on the wire, fixed here so that a change to [`CameraModel`] cannot silently
/// change the format.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
struct IntrinsicsWire {
    width_px: u32,
    height_px: u32,
    fx_px: f64,
    fy_px: f64,
    cx_px: f64,
    cy_px: f64,
    /// OpenCV's order: k1, k2, p1, p2, k3.
    distortion: [f64; 5],
}

/// The laser on the wire: origin x, y (z is 0 by construction), unit direction, and the
/// upper triangle of the 4x4 covariance, row by row.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
struct LaserWire {
    origin_m: [f64; 2],
    direction: [f64; 3],
    covariance_upper: [f64; 10],
}

/// How the laser line was fitted.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum FitMethod {
    Reprojection,
    GaussNewton,
    Average,
    /// Taken from another tool's files (the FishSense lab's `.pkg`), not fitted by fslcal.
    Imported,
}

impl FitMethod {
    /// The name `fslcal laser --method` and the JSON outputs use.
    pub fn name(self) -> &'static str {
        match self {
            FitMethod::Reprojection => "reprojection",
            FitMethod::GaussNewton => "gauss-newton",
            FitMethod::Average => "average",
            FitMethod::Imported => "imported",
        }
    }
}

/// Where a calibration came from: fitted by fslcal from photos, or imported from the
/// FishSense lab's own files. Version 1 files record only "imported" (`FitMethod`), which
/// could then only mean a `.pkg`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Provenance {
    /// Fitted by fslcal from calibration photos.
    Fitted,
    /// Imported from the lab's `.pkg` archives (lens and laser calibration).
    LabPkg,
    /// Imported from the lab's API JSON (`CameraIntrinsics`, `LaserExtrinsics`).
    LabApi,
}

impl Provenance {
    /// The name the JSON outputs and `fslcal inspect` use.
    pub fn name(self) -> &'static str {
        match self {
            Provenance::Fitted => "fitted",
            Provenance::LabPkg => "imported-pkg",
            Provenance::LabApi => "imported-api",
        }
    }
}

/// The laser dot's colour as this unit's camera sees it, learned from the calibration's
/// accepted dots: the dot detector scores candidates by their contrast along it.
///
/// A laser's spectrum is fixed, so the colour it adds to a surface has a fixed direction in
/// the camera's RGB space whatever the surface and the water; only its length (brightness)
/// varies. Clipped pixels carry no colour and are left out when learning it.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct LaserColour {
    /// Unit vector (R, G, B) of the dot's excess over its local background, in the decoded
    /// photo's 8-bit RGB.
    pub rgb: [f32; 3],
    /// 1-sigma angle between an accepted dot's direction and `rgb`, radians.
    pub spread_rad: f32,
    /// Accepted dots it was learned from.
    pub dots: u16,
    /// The camera's tone curve the colour was measured through (version 3): a photo's 8-bit
    /// level `v` is read as `255 (v / 255)^tone_gamma` before the dot is scored, so light the
    /// laser adds counts alike over dark and light surfaces. 1 for a linear camera, and for
    /// every colour a version 2 file holds.
    pub tone_gamma: f32,
}

/// Version 2's laser colour, as released: [`LaserColour`] without its tone curve.
#[derive(Clone, Copy, Serialize, Deserialize)]
struct LaserColourV2 {
    rgb: [f32; 3],
    spread_rad: f32,
    dots: u16,
}

/// Tone curves a calibration may state: from linear to past sRGB's (about 2.2).
pub const TONE_GAMMA_RANGE: [f32; 2] = [1.0, 3.0];

/// The laser fit's own quality figures, as `fslcal laser` reports them.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct FitQuality {
    pub photos_used: u16,
    pub photos_total: u16,
    pub outliers: u16,
    pub residual_rms_px: f32,
    pub residual_worst_px: f32,
    pub residual_rms_mm: f32,
    pub residual_worst_mm: f32,
    /// Length of laser the dots covered, metres.
    pub span_m: f32,
}

/// Everything a calibration file says about its unit: what the signer vouches for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UnitFile<'a> {
    /// `FSL-NN`.
    pub unit: &'a str,
    pub camera_identity: CameraIdentity<'a>,
    pub camera: CameraModel,
    pub laser: LaserLine,
    /// Covariance of (origin x m, origin y m, direction x/z, direction y/z), as
    /// `laser::fit::LaserFit::covariance`. Symmetric; the file stores the upper triangle.
    pub laser_covariance: [[f64; 4]; 4],
    /// When the calibration was made, seconds since 1970-01-01 UTC.
    pub made_utc_s: i64,
    /// Water depth of the calibration photos, where they carried it.
    pub water_depth_m: Option<f32>,
    /// Depths the calibration's dots covered: distances outside are extrapolation.
    pub depth_range_m: Option<[f32; 2]>,
    /// `None` for imported calibrations, which come without fit figures.
    pub fit: Option<FitQuality>,
    pub method: FitMethod,
    /// The target in the calibration photos, e.g. `checkerboard:14x10@42.17mm`.
    pub target: Option<&'a str>,
    /// Fitted here or imported, and from what (version 2; version 1 files: from `method`).
    pub provenance: Provenance,
    /// The laser dot's learned colour (version 2; `None` when unknown: imported, or a
    /// version 1 file).
    pub laser_colour: Option<LaserColour>,
}

/// Version 3's payload, in wire order: version 2's, its laser colour with the camera's tone
/// curve. Field order is the format: never reorder.
#[derive(Serialize, Deserialize)]
struct PayloadV3<'a> {
    unit: &'a str,
    #[serde(borrow)]
    camera_identity: CameraIdentity<'a>,
    intrinsics: IntrinsicsWire,
    laser: LaserWire,
    made_utc_s: i64,
    water_depth_m: Option<f32>,
    depth_range_m: Option<[f32; 2]>,
    method: FitMethod,
    fit: Option<FitQuality>,
    #[serde(borrow)]
    target: Option<&'a str>,
    provenance: Provenance,
    laser_colour: Option<LaserColour>,
    signer: [u8; 32],
}

/// Version 2's payload, in wire order, as released: version 1's fields, then where the
/// calibration came from and the laser's colour, then the signer. Read, never written.
#[derive(Serialize, Deserialize)]
struct PayloadV2<'a> {
    unit: &'a str,
    #[serde(borrow)]
    camera_identity: CameraIdentity<'a>,
    intrinsics: IntrinsicsWire,
    laser: LaserWire,
    made_utc_s: i64,
    water_depth_m: Option<f32>,
    depth_range_m: Option<[f32; 2]>,
    method: FitMethod,
    fit: Option<FitQuality>,
    #[serde(borrow)]
    target: Option<&'a str>,
    provenance: Provenance,
    laser_colour: Option<LaserColourV2>,
    signer: [u8; 32],
}

/// Version 1's payload, in wire order, as released: read, never written.
#[derive(Serialize, Deserialize)]
struct PayloadV1<'a> {
    unit: &'a str,
    #[serde(borrow)]
    camera_identity: CameraIdentity<'a>,
    intrinsics: IntrinsicsWire,
    laser: LaserWire,
    made_utc_s: i64,
    water_depth_m: Option<f32>,
    depth_range_m: Option<[f32; 2]>,
    method: FitMethod,
    fit: Option<FitQuality>,
    #[serde(borrow)]
    target: Option<&'a str>,
    signer: [u8; 32],
}

const UPPER: [(usize, usize); 10] = [(0, 0), (0, 1), (0, 2), (0, 3), (1, 1), (1, 2), (1, 3), (2, 2), (2, 3), (3, 3)];

impl<'a> UnitFile<'a> {
    fn to_wire(self, signer: [u8; 32]) -> PayloadV3<'a> {
        let c = &self.camera;
        PayloadV3 {
            unit: self.unit,
            camera_identity: self.camera_identity,
            intrinsics: IntrinsicsWire {
                width_px: c.width_px,
                height_px: c.height_px,
                fx_px: c.fx_px,
                fy_px: c.fy_px,
                cx_px: c.cx_px,
                cy_px: c.cy_px,
                distortion: c.distortion.to_opencv(),
            },
            laser: LaserWire {
                origin_m: [self.laser.origin_m[0], self.laser.origin_m[1]],
                direction: self.laser.direction,
                covariance_upper: UPPER.map(|(r, c)| self.laser_covariance[r][c]),
            },
            made_utc_s: self.made_utc_s,
            water_depth_m: self.water_depth_m,
            depth_range_m: self.depth_range_m,
            method: self.method,
            fit: self.fit,
            target: self.target,
            provenance: self.provenance,
            laser_colour: self.laser_colour,
            signer,
        }
    }

    fn from_wire(p: &PayloadV3<'a>) -> Self {
        let i = &p.intrinsics;
        let mut cov = [[0.0; 4]; 4];
        for (&(r, c), &v) in UPPER.iter().zip(&p.laser.covariance_upper) {
            cov[r][c] = v;
            cov[c][r] = v;
        }
        UnitFile {
            unit: p.unit,
            camera_identity: p.camera_identity,
            camera: CameraModel {
                width_px: i.width_px,
                height_px: i.height_px,
                fx_px: i.fx_px,
                fy_px: i.fy_px,
                cx_px: i.cx_px,
                cy_px: i.cy_px,
                distortion: Distortion::from_opencv(i.distortion),
            },
            laser: LaserLine {
                origin_m: [p.laser.origin_m[0], p.laser.origin_m[1], 0.0],
                direction: p.laser.direction,
            },
            laser_covariance: cov,
            made_utc_s: p.made_utc_s,
            water_depth_m: p.water_depth_m,
            depth_range_m: p.depth_range_m,
            fit: p.fit,
            method: p.method,
            target: p.target,
            provenance: p.provenance,
            laser_colour: p.laser_colour,
        }
    }

    /// Why these contents cannot be a calibration, if they cannot: the same rules hold when
    /// signing and when decoding, so a signed file always decodes.
    pub fn check(&self) -> Result<(), &'static str> {
        let texts = [
            Some(self.unit),
            Some(self.camera_identity.make),
            Some(self.camera_identity.model),
            self.camera_identity.serial,
            self.target,
        ];
        if self.unit.is_empty() {
            return Err("empty unit id");
        }
        if texts.iter().flatten().any(|t| t.len() > MAX_TEXT_BYTES || t.chars().any(char::is_control)) {
            return Err("a text field is over 64 bytes or holds control characters");
        }
        if !self.camera.is_plausible() {
            return Err("camera intrinsics out of range");
        }
        let d = self.laser.dir();
        let o = &self.laser.origin_m;
        if !o[0].is_finite() || !o[1].is_finite() || o[2] != 0.0 || !d.iter().all(|v| v.is_finite()) {
            return Err("laser origin or direction not finite");
        }
        if (d.norm() - 1.0).abs() > 1e-9 || d.z <= 0.0 {
            return Err("laser direction not a forward unit vector");
        }
        if let Some(c) = &self.laser_colour {
            // Squared, as no_std has no sqrt: |n - 1| <= 1e-3 is about |n² - 1| <= 2e-3.
            let norm_sq = c.rgb.iter().map(|v| v * v).sum::<f32>();
            if !c.rgb.iter().all(|v| v.is_finite())
                || (norm_sq - 1.0).abs() > 2e-3
                || !c.spread_rad.is_finite()
                || c.spread_rad < 0.0
            {
                return Err("laser colour not a unit vector with a spread");
            }
            if !(TONE_GAMMA_RANGE[0]..=TONE_GAMMA_RANGE[1]).contains(&c.tone_gamma) {
                return Err("tone curve gamma outside 1-3");
            }
        }
        if (self.method == FitMethod::Imported) != (self.provenance != Provenance::Fitted) {
            return Err("method and provenance disagree on whether the calibration was imported");
        }
        if self.laser_covariance.iter().flatten().any(|v| !v.is_finite()) {
            return Err("laser covariance not finite");
        }
        if UPPER.iter().any(|&(r, c)| self.laser_covariance[r][c] != self.laser_covariance[c][r]) {
            return Err("laser covariance not symmetric");
        }
        let finite = |v: &f32| v.is_finite();
        if self.water_depth_m.is_some_and(|w| !w.is_finite())
            || self.depth_range_m.is_some_and(|r| !r.iter().all(finite))
            || self.fit.is_some_and(|f| {
                ![f.residual_rms_px, f.residual_worst_px, f.residual_rms_mm, f.residual_worst_mm, f.span_m]
                    .iter()
                    .all(finite)
            })
        {
            return Err("a quality figure is not finite");
        }
        Ok(())
    }

    /// Writes the signed file into `out` and returns its length. Deterministic: the same
    /// contents and key give the same bytes (ed25519 signatures are).
    pub fn sign(&self, secret_key: &[u8; 32], out: &mut [u8; MAX_FILE_BYTES]) -> Result<usize, FormatError> {
        self.check().map_err(FormatError::Unsignable)?;
        let key = SigningKey::from_bytes(secret_key);
        let payload = self.to_wire(key.verifying_key().to_bytes());
        let room = MAX_FILE_BYTES - SIGNATURE_BYTES;
        let written = postcard::to_slice(&payload, &mut out[HEADER_BYTES..room])
            .map_err(|_| FormatError::Unsignable("the contents do not fit in 512 bytes; shorten the text fields"))?
            .len();
        let signed_len = HEADER_BYTES + written;
        let total = signed_len + SIGNATURE_BYTES;
        out[..4].copy_from_slice(&MAGIC);
        out[4] = VERSION;
        // `total` <= 512 by the slice bound above.
        out[5..7].copy_from_slice(&(total as u16).to_le_bytes());
        let signature = key.sign(&out[..signed_len]);
        out[signed_len..total].copy_from_slice(&signature.to_bytes());
        Ok(total)
    }
}

/// One version's payload from the bytes between the header and the signature, which it
/// must fill exactly.
fn take_payload<'a, P: Deserialize<'a>>(body: &'a [u8]) -> Result<P, FormatError> {
    match postcard::take_from_bytes(body) {
        Ok((p, [])) => Ok(p),
        Ok(_) => Err(FormatError::Corrupt("bytes between the payload and the signature")),
        Err(postcard::Error::DeserializeUnexpectedEnd) => {
            Err(FormatError::Corrupt("the payload runs into the signature"))
        }
        Err(_) => Err(FormatError::Corrupt("undecodable payload")),
    }
}

impl<'a> PayloadV2<'a> {
    /// Version 2 read every photo as linear.
    fn into_v3(self) -> PayloadV3<'a> {
        let colour =
            |c: LaserColourV2| LaserColour { rgb: c.rgb, spread_rad: c.spread_rad, dots: c.dots, tone_gamma: 1.0 };
        PayloadV3 {
            unit: self.unit,
            camera_identity: self.camera_identity,
            intrinsics: self.intrinsics,
            laser: self.laser,
            made_utc_s: self.made_utc_s,
            water_depth_m: self.water_depth_m,
            depth_range_m: self.depth_range_m,
            method: self.method,
            fit: self.fit,
            target: self.target,
            provenance: self.provenance,
            laser_colour: self.laser_colour.map(colour),
            signer: self.signer,
        }
    }
}

impl<'a> PayloadV1<'a> {
    /// Version 1 knew one import, the lab's `.pkg`, and no laser colour.
    fn into_v3(self) -> PayloadV3<'a> {
        let provenance = if self.method == FitMethod::Imported { Provenance::LabPkg } else { Provenance::Fitted };
        PayloadV3 {
            unit: self.unit,
            camera_identity: self.camera_identity,
            intrinsics: self.intrinsics,
            laser: self.laser,
            made_utc_s: self.made_utc_s,
            water_depth_m: self.water_depth_m,
            depth_range_m: self.depth_range_m,
            method: self.method,
            fit: self.fit,
            target: self.target,
            provenance,
            laser_colour: None,
            signer: self.signer,
        }
    }
}

/// A decoded file: its contents, who signed it, and the signature, not yet checked.
#[derive(Clone, Copy, Debug)]
pub struct SignedUnitFile<'a> {
    pub version: u8,
    pub contents: UnitFile<'a>,
    /// The signer's ed25519 public key, as the file states it (signed along with the rest).
    pub signer: [u8; 32],
    pub signature: [u8; SIGNATURE_BYTES],
    signed: &'a [u8],
}

impl<'a> SignedUnitFile<'a> {
    /// Parses a file without checking its signature (for `inspect`; use [`verify`] to trust
    /// one). Borrows the strings from `bytes`; never allocates, never panics.
    pub fn decode(bytes: &'a [u8]) -> Result<Self, FormatError> {
        let magic_seen = bytes.len().min(4);
        if bytes[..magic_seen] != MAGIC[..magic_seen] {
            return Err(FormatError::NotACalibrationFile);
        }
        let truncated = |expected| FormatError::Truncated { found: bytes.len(), expected };
        if bytes.len() < 5 {
            return Err(truncated(HEADER_BYTES));
        }
        let version = bytes[4];
        if version == 0 {
            return Err(FormatError::Corrupt("format version 0"));
        }
        if version > VERSION {
            return Err(FormatError::NewerVersion { found: version, supported: VERSION });
        }
        if bytes.len() < HEADER_BYTES {
            return Err(truncated(HEADER_BYTES));
        }
        let total = u16::from_le_bytes([bytes[5], bytes[6]]) as usize;
        if !(HEADER_BYTES + SIGNATURE_BYTES..=MAX_FILE_BYTES).contains(&total) {
            return Err(FormatError::Corrupt("impossible length in the header"));
        }
        if bytes.len() < total {
            return Err(truncated(total));
        }
        if bytes.len() > total {
            return Err(FormatError::Corrupt("bytes after the signature"));
        }
        let signed_len = total - SIGNATURE_BYTES;
        let (signed, sig) = bytes.split_at(signed_len);
        let mut signature = [0u8; SIGNATURE_BYTES];
        signature.copy_from_slice(sig);
        // Each released version keeps its arm; older payloads become version 3's.
        let body = &signed[HEADER_BYTES..];
        let payload = match version {
            1 => take_payload::<PayloadV1<'a>>(body)?.into_v3(),
            2 => take_payload::<PayloadV2<'a>>(body)?.into_v3(),
            _ => take_payload::<PayloadV3<'a>>(body)?,
        };
        let contents = UnitFile::from_wire(&payload);
        contents.check().map_err(FormatError::Corrupt)?;
        Ok(SignedUnitFile { version, contents, signer: payload.signer, signature, signed })
    }

    pub fn key_id(&self) -> KeyId {
        KeyId::of(&self.signer)
    }

    /// Whether the signature matches the contents and the key the file names. Says nothing
    /// about whether that key is trusted.
    pub fn check_signature(&self) -> Result<(), FormatError> {
        let key = VerifyingKey::from_bytes(&self.signer).map_err(|_| FormatError::BadSignature)?;
        key.verify_strict(self.signed, &Signature::from_bytes(&self.signature)).map_err(|_| FormatError::BadSignature)
    }
}

/// Decodes `bytes` and accepts it only if intact and signed by one of `trusted` (ed25519
/// public keys). The one check a consumer of calibrations needs.
pub fn verify<'a>(bytes: &'a [u8], trusted: &[[u8; 32]]) -> Result<SignedUnitFile<'a>, FormatError> {
    let file = SignedUnitFile::decode(bytes)?;
    file.check_signature()?;
    if !trusted.contains(&file.signer) {
        return Err(FormatError::UnknownSigner(file.key_id()));
    }
    Ok(file)
}

/// The secret key of the worked example in `docs/calib-format.md`: never trust its public
/// key for real calibrations.
pub const EXAMPLE_SECRET_KEY: [u8; 32] = *b"fslcal example key, not a secret";

/// The worked example of `docs/calib-format.md`: a TG-6 calibration of unit FSL-03.
pub fn example() -> UnitFile<'static> {
    UnitFile {
        unit: "FSL-03",
        camera_identity: CameraIdentity { make: "OLYMPUS CORPORATION", model: "TG-6", serial: Some("BJ7654321") },
        camera: CameraModel {
            width_px: 4000,
            height_px: 3000,
            fx_px: 2912.5,
            fy_px: 2913.25,
            cx_px: 2004.75,
            cy_px: 1497.5,
            distortion: Distortion::from_opencv([-0.125, 0.0625, 0.0009765625, -0.00048828125, -0.015625]),
        },
        // (40, 81, 4080) / 4081 is a unit vector exactly: a Pythagorean quadruple.
        laser: LaserLine {
            origin_m: [-0.0405, -0.1055, 0.0],
            direction: [40.0 / 4081.0, 81.0 / 4081.0, 4080.0 / 4081.0],
        },
        laser_covariance: [
            [4.0e-8, 1.0e-9, 0.0, 0.0],
            [1.0e-9, 9.0e-8, 0.0, 0.0],
            [0.0, 0.0, 2.5e-9, 0.0],
            [0.0, 0.0, 0.0, 2.5e-9],
        ],
        // 2026-06-01 09:30:00 UTC
        made_utc_s: 1_780_306_200,
        water_depth_m: Some(4.5),
        depth_range_m: Some([0.75, 4.5]),
        fit: Some(FitQuality {
            photos_used: 14,
            photos_total: 16,
            outliers: 1,
            residual_rms_px: 0.75,
            residual_worst_px: 2.25,
            residual_rms_mm: 0.5,
            residual_worst_mm: 1.5,
            span_m: 3.75,
        }),
        method: FitMethod::Reprojection,
        target: Some("checkerboard:14x10@42.17mm"),
        provenance: Provenance::Fitted,
        // A green dot with a little red in it, as a TG-6 renders a 532 nm laser:
        // 0.28² + 0.96² = 1, a unit vector to f32 rounding.
        // Read through a tone curve of gamma 2.25, near sRGB's, as a TG-6 JPEG is.
        laser_colour: Some(LaserColour { rgb: [0.28, 0.96, 0.0], spread_rad: 0.0625, dots: 14, tone_gamma: 2.25 }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn contents() -> UnitFile<'static> {
        example()
    }

    #[test]
    fn round_trips_and_verifies() {
        let mut buf = [0u8; MAX_FILE_BYTES];
        let n = contents().sign(&EXAMPLE_SECRET_KEY, &mut buf).unwrap();
        assert!(n <= MAX_FILE_BYTES);
        eprintln!("example file: {n} bytes");
        let pk = public_key(&EXAMPLE_SECRET_KEY);
        let f = verify(&buf[..n], &[pk]).unwrap();
        assert_eq!(f.contents, contents());
        assert_eq!(f.version, VERSION);
        assert_eq!(verify(&buf[..n], &[[7u8; 32]]).unwrap_err(), FormatError::UnknownSigner(KeyId::of(&pk)));
    }

    #[test]
    fn names_each_failure() {
        let mut buf = [0u8; MAX_FILE_BYTES];
        let n = contents().sign(&EXAMPLE_SECRET_KEY, &mut buf).unwrap();
        let pk = [public_key(&EXAMPLE_SECRET_KEY)];
        let file = &buf[..n];
        assert!(matches!(verify(&file[..n - 1], &pk), Err(FormatError::Truncated { .. })));
        assert!(matches!(verify(&file[..3], &pk), Err(FormatError::Truncated { .. })));
        assert_eq!(verify(b"{\"camera\": 1}", &pk).unwrap_err(), FormatError::NotACalibrationFile);
        let mut newer = buf;
        newer[4] = VERSION + 1;
        assert_eq!(
            verify(&newer[..n], &pk).unwrap_err(),
            FormatError::NewerVersion { found: VERSION + 1, supported: VERSION }
        );
        let mut tampered = buf;
        tampered[n - SIGNATURE_BYTES - 40] ^= 0x01; // inside the signed payload
        assert_eq!(verify(&tampered[..n], &pk).unwrap_err(), FormatError::BadSignature);
    }

    #[test]
    fn refuses_to_sign_what_it_would_not_read() {
        let mut buf = [0u8; MAX_FILE_BYTES];
        let mut c = contents();
        c.laser.direction = [0.0, 0.0, -1.0];
        assert!(matches!(c.sign(&EXAMPLE_SECRET_KEY, &mut buf), Err(FormatError::Unsignable(_))));
        let long = "x".repeat(MAX_TEXT_BYTES);
        let mut c = contents();
        c.camera_identity.make = &long;
        c.camera_identity.model = &long;
        c.camera_identity.serial = Some(&long);
        c.target = Some(&long);
        assert!(matches!(c.sign(&EXAMPLE_SECRET_KEY, &mut buf), Err(FormatError::Unsignable(_))));
        let mut c = contents();
        c.laser_colour.as_mut().unwrap().tone_gamma = 0.5;
        assert!(matches!(c.sign(&EXAMPLE_SECRET_KEY, &mut buf), Err(FormatError::Unsignable(_))));
    }
}
