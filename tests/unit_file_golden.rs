//! The worked example in `docs/calib-format.md` is the format: this test rebuilds the example
//! file (fixed contents, fixed key, fixed time) and compares it with the spec's annotated hex
//! dump byte for byte, and checks that the dump's offsets and lengths add up. The spec's
//! version 1 and 2 dumps (as those versions wrote the example) must still decode and verify.

use fslcal_core::unit_file::{self, SignedUnitFile, EXAMPLE_SECRET_KEY, MAX_FILE_BYTES};

const SPEC: &str = include_str!("../docs/calib-format.md");

/// The bytes of the spec's ```hexdump block (the current version). Each line is
/// `OFFSET  HEX BYTES  [comment]`, the offset in hex; comments are separated from the bytes
/// by two or more spaces.
fn spec_bytes() -> Vec<u8> {
    dump_bytes("```hexdump\n")
}

/// The bytes of the block that starts with `fence`.
fn dump_bytes(fence: &str) -> Vec<u8> {
    let start = SPEC.find(fence).unwrap_or_else(|| panic!("the spec has a {fence} block")) + fence.len();
    let end = start + SPEC[start..].find("```").expect("the hexdump block ends");
    let mut bytes = Vec::new();
    for line in SPEC[start..end].lines().filter(|l| !l.trim().is_empty()) {
        let (offset, rest) = line.split_once("  ").unwrap_or_else(|| panic!("no offset in `{line}`"));
        let offset = usize::from_str_radix(offset.trim(), 16).unwrap_or_else(|_| panic!("bad offset in `{line}`"));
        assert_eq!(offset, bytes.len(), "offset of `{line}` does not follow on");
        let hex = rest.split("  ").next().unwrap();
        for b in hex.split_whitespace() {
            bytes.push(u8::from_str_radix(b, 16).unwrap_or_else(|_| panic!("bad byte `{b}` in `{line}`")));
        }
    }
    bytes
}

fn example_file() -> Vec<u8> {
    let mut buf = [0u8; MAX_FILE_BYTES];
    let n = unit_file::example().sign(&EXAMPLE_SECRET_KEY, &mut buf).unwrap();
    buf[..n].to_vec()
}

#[test]
fn the_spec_hex_dump_is_what_the_code_writes() {
    let ours = example_file();
    let hex: Vec<String> = ours.iter().map(|b| format!("{b:02x}")).collect();
    assert_eq!(spec_bytes(), ours, "the code writes (update the spec only with a version bump):\n{}", hex.join(" "));
}

#[test]
fn the_spec_example_decodes_to_the_example() {
    let bytes = spec_bytes();
    let f = unit_file::verify(&bytes, &[unit_file::public_key(&EXAMPLE_SECRET_KEY)]).unwrap();
    assert_eq!(f.contents, unit_file::example());
    assert_eq!(f.version, unit_file::VERSION);
    assert_eq!(f.key_id().to_string(), SignedUnitFile::decode(&bytes).unwrap().key_id().to_string());
    // The size the spec states.
    assert!(SPEC.contains(&format!("{} bytes", bytes.len())), "the spec should state the example's size");
}

/// The spec's dump of the example as format `version` wrote it (block ```hexdump-vN),
/// decoded and verified: its contents.
fn older_example(version: u8) -> unit_file::UnitFile<'static> {
    let bytes: &'static [u8] = Vec::leak(dump_bytes(&format!("```hexdump-v{version}\n")));
    assert_eq!(bytes[4], version, "the block is a version {version} file");
    assert!(
        SPEC.contains(&format!("{} bytes", bytes.len())),
        "the spec should state the version {version} example's size"
    );
    let f = unit_file::verify(bytes, &[unit_file::public_key(&EXAMPLE_SECRET_KEY)]).unwrap();
    assert_eq!(f.version, version);
    f.contents
}

#[test]
fn the_spec_version_2_example_still_decodes_and_verifies() {
    // Version 2 read every photo as linear.
    let mut expected = unit_file::example();
    expected.laser_colour.as_mut().expect("the example has a colour").tone_gamma = 1.0;
    assert_eq!(older_example(2), expected);
}

#[test]
fn the_spec_version_1_example_still_decodes_and_verifies() {
    // Version 1 knew neither field: a fitted calibration with no learned colour.
    let expected =
        unit_file::UnitFile { provenance: unit_file::Provenance::Fitted, laser_colour: None, ..unit_file::example() };
    assert_eq!(older_example(1), expected);
}
