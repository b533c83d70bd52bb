//! Calibration files for the firmware tests, all signed by the core's own `sign` so the
//! tests exercise the exact bytes the CLI writes.
#![allow(dead_code)]

use firmware_sim::{Config, Firmware, TrustedKey};
use fslcal_core::unit_file::{self, UnitFile, EXAMPLE_SECRET_KEY, MAX_FILE_BYTES};
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// A key nobody told the firmware about.
pub const STRANGER_SECRET_KEY: [u8; 32] = *b"a stranger's key, never trusted.";

pub fn sign(contents: &UnitFile, secret: &[u8; 32]) -> Vec<u8> {
    let mut buf = [0u8; MAX_FILE_BYTES];
    let n = contents.sign(secret, &mut buf).expect("the example signs");
    buf[..n].to_vec()
}

pub fn good_file() -> Vec<u8> {
    sign(&unit_file::example(), &EXAMPLE_SECRET_KEY)
}

/// The good file with the lowest mantissa byte of fx changed: still a plausible camera, so
/// only the signature can tell.
pub fn tampered_file() -> Vec<u8> {
    let mut f = good_file();
    let fx = unit_file::example().camera.fx_px.to_le_bytes();
    let at = f.windows(8).position(|w| w == fx).expect("fx is stored as little-endian f64");
    f[at] ^= 0x01;
    f
}

pub fn other_unit_file() -> Vec<u8> {
    let mut c = unit_file::example();
    c.unit = "FSL-05";
    sign(&c, &EXAMPLE_SECRET_KEY)
}

pub fn unknown_signer_file() -> Vec<u8> {
    sign(&unit_file::example(), &STRANGER_SECRET_KEY)
}

pub fn truncated_file() -> Vec<u8> {
    good_file()[..300].to_vec()
}

/// Version byte raised past the newest: what a future fslcal would write.
pub fn newer_format_file() -> Vec<u8> {
    let mut f = good_file();
    f[4] = unit_file::VERSION + 1;
    f
}

/// The files the example dive loads, by name.
pub fn example_files() -> Vec<(&'static str, Vec<u8>)> {
    vec![
        ("fsl03.fslcal", good_file()),
        ("fsl03-tampered.fslcal", tampered_file()),
        ("fsl05.fslcal", other_unit_file()),
        ("fsl03-unknown-signer.fslcal", unknown_signer_file()),
        ("fsl03-truncated.fslcal", truncated_file()),
        ("fsl03-newer.fslcal", newer_format_file()),
    ]
}

pub fn trusted() -> &'static [TrustedKey] {
    static KEYS: OnceLock<[TrustedKey; 1]> = OnceLock::new();
    KEYS.get_or_init(|| [TrustedKey { name: "example-key", public_key: unit_file::public_key(&EXAMPLE_SECRET_KEY) }])
}

/// A firmware built for FSL-03 that trusts the example key, on the heap as a real build
/// would keep it in a static.
pub fn firmware() -> Box<Firmware> {
    Box::new(Firmware::new(Config { unit: "FSL-03", trusted_keys: trusted() }))
}

pub fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap().to_path_buf()
}

/// Set `FSLCAL_BLESS=1` to rewrite golden files after an intended change of the screens.
pub fn bless() -> bool {
    std::env::var_os("FSLCAL_BLESS").is_some()
}
