//! Any bytes into the unit file decoder and verifier: no panic, and nothing but the
//! signer's own bytes verifies.
#![no_main]

use fslcal_core::unit_file::{self, SignedUnitFile, MAX_FILE_BYTES};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let trusted = [unit_file::public_key(&unit_file::EXAMPLE_SECRET_KEY)];
    if let Ok(file) = SignedUnitFile::decode(data) {
        assert!(data.len() <= MAX_FILE_BYTES);
        let _ = file.key_id();
        if file.check_signature().is_ok() && file.signer == trusted[0] {
            // Only the example key's own signature verifies: re-signing the decoded contents
            // must give back exactly these bytes (ed25519 and postcard are deterministic).
            let mut buf = [0u8; MAX_FILE_BYTES];
            let n = file.contents.sign(&unit_file::EXAMPLE_SECRET_KEY, &mut buf).expect("a decoded file re-signs");
            assert_eq!(&buf[..n], data);
        }
    }
    let _ = unit_file::verify(data, &trusted);
});
