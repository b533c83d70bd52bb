//! The camera companion shows the same distance as the CLI for the same dot and file: the
//! firmware (`firmware-sim`, no_std) and `fslcal::calibration::load` both read the signed
//! unit file through fslcal-core and both take the distance from `LaserLine::fix_from_pixel`.

use firmware_sim::{screens, Button, Calibration, Config, Event, Firmware, TrustedKey};
use fslcal_core::unit_file::{self, EXAMPLE_SECRET_KEY, MAX_FILE_BYTES};
use fslcal_core::Vec2;
use std::sync::OnceLock;

fn trusted() -> &'static [TrustedKey] {
    static KEYS: OnceLock<[TrustedKey; 1]> = OnceLock::new();
    KEYS.get_or_init(|| [TrustedKey { name: "example-key", public_key: unit_file::public_key(&EXAMPLE_SECRET_KEY) }])
}

#[test]
fn firmware_distance_equals_the_cli_library_within_1_mm() {
    let mut buf = [0u8; MAX_FILE_BYTES];
    let n = unit_file::example().sign(&EXAMPLE_SECRET_KEY, &mut buf).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("fsl03.fslcal");
    std::fs::write(&path, &buf[..n]).unwrap();

    let cli = fslcal::calibration::load(&path).unwrap();
    let mut fw = Box::new(Firmware::new(Config { unit: "FSL-03", trusted_keys: trusted() }));
    fw.handle(Event::LoadFile(&std::fs::read(&path).unwrap()));
    fw.handle(Event::Press(Button::Next));
    let Calibration::Valid(fw_cal) = *fw.calibration() else { panic!("{:?}", fw.calibration()) };

    // Dots on the beam from 0.4 to 8 m, and beside it by a few pixels (a knocked laser, a
    // noisy detection), with seeded jitter.
    let mut seed = 0x2545_f491_4f6c_dd1du64;
    let mut jitter = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    let (mut worst_exact_m, mut worst_shown_m, mut worst_sigma_rel, mut count) = (0.0f64, 0.0f64, 0.0f64, 0);
    for i in 0..200 {
        let z = 0.4 * (20.0f64).powf(i as f64 / 199.0);
        let on = cli.laser.pixel_at_depth(&cli.camera, z).unwrap();
        let off = if i % 2 == 0 { 0.0 } else { 6.0 };
        let px = Vec2::new(on.x + off * jitter() + 0.3 * jitter(), on.y + off * jitter() + 0.3 * jitter());
        let want = cli.laser.fix_from_pixel(&cli.camera, px).unwrap().depth_m;

        fw.handle(Event::Dot { u_px: px.x, v_px: px.y });
        let fix = fw.reading().unwrap().fix.unwrap();
        let (shown, _) = screens::live_lines(&fw, &fw_cal);
        let shown_m: f64 = shown.as_str().trim_end_matches(" m").parse().unwrap();

        worst_exact_m = worst_exact_m.max((fix.distance_m - want).abs());
        worst_shown_m = worst_shown_m.max((shown_m - want).abs());
        if off == 0.0 {
            // The CLI's distance sigma (at the depth) and the firmware's (at the pixel) are
            // the one core function too.
            let s_cli = cli.distance_sigma_m(z).unwrap();
            let s_fw = fw_cal.laser.depth_sigma_at_depth(&fw_cal.camera, &fw_cal.laser_covariance, z).unwrap();
            worst_sigma_rel = worst_sigma_rel.max((s_cli - s_fw).abs() / s_cli);
        }
        count += 1;
    }
    println!(
        "{count} dots 0.4-8 m: firmware vs CLI distance worst {:.2e} m computed, {:.2} mm as shown (3 decimals); sigma worst relative {:.1e}",
        worst_exact_m,
        1e3 * worst_shown_m,
        worst_sigma_rel
    );
    assert!(worst_exact_m < 1e-9, "{worst_exact_m}");
    // The screen rounds to the millimetre, so what the diver reads is within 0.5 mm.
    assert!(worst_shown_m <= 0.5e-3 + 1e-9, "{worst_shown_m}");
    assert!(worst_sigma_rel < 1e-12, "{worst_sigma_rel}");
}
