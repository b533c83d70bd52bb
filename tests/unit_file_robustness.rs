//! The unit file decoder against damage and hostile input: every single-byte change and
//! every truncation of the signed example fails verification, and a seeded stream of random
//! and mutated inputs never panics the decoder and never verifies. (The same property is
//! fuzzed without limit by `src/core/fuzz/`; this is the part CI runs.)

use fslcal_core::unit_file::{self, FormatError, SignedUnitFile, EXAMPLE_SECRET_KEY, MAX_FILE_BYTES};
use std::collections::BTreeMap;

fn signed_example() -> Vec<u8> {
    let mut buf = [0u8; MAX_FILE_BYTES];
    let n = unit_file::example().sign(&EXAMPLE_SECRET_KEY, &mut buf).unwrap();
    buf[..n].to_vec()
}

fn trusted() -> [[u8; 32]; 1] {
    [unit_file::public_key(&EXAMPLE_SECRET_KEY)]
}

fn kind(e: &FormatError) -> &'static str {
    match e {
        FormatError::Truncated { .. } => "truncated",
        FormatError::NotACalibrationFile => "not a calibration file",
        FormatError::NewerVersion { .. } => "newer version",
        FormatError::Corrupt(_) => "corrupt",
        FormatError::BadSignature => "tampered",
        FormatError::UnknownSigner(_) => "unknown signer",
        FormatError::Unsignable(_) => "unsignable",
    }
}

/// SplitMix64: a fixed, dependency-free random stream so every CI run tests the same inputs.
struct SplitMix(u64);

impl SplitMix {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
}

#[test]
fn every_single_byte_change_fails_verification() {
    let file = signed_example();
    assert!(unit_file::verify(&file, &trusted()).is_ok());
    let mut reasons: BTreeMap<&str, usize> = BTreeMap::new();
    let mut tried = 0;
    // Every position, with a low-bit flip, a high-bit flip and a whole-byte inversion.
    for i in 0..file.len() {
        for mask in [0x01u8, 0x80, 0xff] {
            let mut bad = file.clone();
            bad[i] ^= mask;
            let err = unit_file::verify(&bad, &trusted()).expect_err("a changed byte must not verify");
            *reasons.entry(kind(&err)).or_default() += 1;
            tried += 1;
        }
    }
    eprintln!("{} bytes x 3 changes = {tried} altered files, all refused: {reasons:?}", file.len());
    assert_eq!(tried, 3 * file.len());
    // The header's fields are told apart from tampering where the bytes allow it.
    let mut newer = file.clone();
    newer[4] = unit_file::VERSION + 1;
    assert_eq!(
        unit_file::verify(&newer, &trusted()).unwrap_err(),
        FormatError::NewerVersion { found: unit_file::VERSION + 1, supported: unit_file::VERSION }
    );
    let mut magic = file.clone();
    magic[0] ^= 0x01;
    assert_eq!(unit_file::verify(&magic, &trusted()).unwrap_err(), FormatError::NotACalibrationFile);
}

#[test]
fn every_truncation_fails_verification_as_truncated() {
    let file = signed_example();
    for len in 0..file.len() {
        let err = unit_file::verify(&file[..len], &trusted()).expect_err("a truncated file must not verify");
        assert!(matches!(err, FormatError::Truncated { found, .. } if found == len), "length {len}: {err:?}");
    }
    eprintln!("all {} truncations (0..{} bytes) refused as truncated", file.len(), file.len() - 1);
    // And an appended byte is not a valid file either.
    let mut longer = file.clone();
    longer.push(0);
    assert!(matches!(unit_file::verify(&longer, &trusted()), Err(FormatError::Corrupt(_))));
}

#[test]
fn random_and_mutated_inputs_never_panic_and_never_verify() {
    let file = signed_example();
    let mut rng = SplitMix(0x5eed_f51c);
    let mut decoded = 0usize;
    let mut reasons: BTreeMap<&str, usize> = BTreeMap::new();
    let mut check = |input: &[u8], reasons: &mut BTreeMap<&str, usize>| {
        // A panic anywhere in here fails the test.
        if SignedUnitFile::decode(input).is_ok() {
            decoded += 1;
        }
        match unit_file::verify(input, &trusted()) {
            Ok(_) => assert_eq!(input, &file[..], "only the signer's own bytes verify"),
            Err(e) => *reasons.entry(kind(&e)).or_default() += 1,
        }
    };
    let (mut random, mut mutated) = (0, 0);
    // Pure noise, with the magic and a plausible header half the time so the decoder gets
    // past its first checks.
    for _ in 0..20_000 {
        let len = rng.below(600);
        let mut input: Vec<u8> = (0..len).map(|_| rng.next() as u8).collect();
        if len >= 7 && rng.below(2) == 0 {
            input[..4].copy_from_slice(b"FSLC");
            input[4] = 1;
            input[5..7].copy_from_slice(&(len as u16).to_le_bytes());
        }
        check(&input, &mut reasons);
        random += 1;
    }
    // Mutations of the real file: overwritten, inserted and deleted bytes, and splices.
    for _ in 0..60_000 {
        let mut input = file.clone();
        for _ in 0..1 + rng.below(4) {
            match rng.below(4) {
                0 if !input.is_empty() => {
                    let i = rng.below(input.len());
                    input[i] = rng.next() as u8;
                }
                1 => {
                    let i = rng.below(input.len() + 1);
                    input.insert(i, rng.next() as u8);
                }
                2 if !input.is_empty() => {
                    let i = rng.below(input.len());
                    input.remove(i);
                }
                _ => {
                    let (a, b) = (rng.below(file.len()), rng.below(file.len()));
                    let (a, b) = (a.min(b), a.max(b));
                    let at = rng.below(input.len() + 1);
                    input.splice(at..at, file[a..b].iter().copied());
                }
            }
        }
        // Keep the header's length consistent half the time, to reach the payload decoder.
        if input.len() >= 7 && rng.below(2) == 0 {
            let len = input.len() as u16;
            input[5..7].copy_from_slice(&len.to_le_bytes());
        }
        check(&input, &mut reasons);
        mutated += 1;
    }
    eprintln!("{random} random + {mutated} mutated inputs: no panic; {decoded} decoded, none verified except the original; {reasons:?}");
    assert!(
        reasons.get("corrupt").copied().unwrap_or(0) > 1000,
        "the mutations reach the payload decoder: {reasons:?}"
    );
    assert!(reasons.get("tampered").copied().unwrap_or(0) > 100, "and the signature check: {reasons:?}");
}
