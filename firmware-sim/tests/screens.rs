//! Every screen against golden PNGs (pixel for pixel), the title and text layout against a
//! MockDisplay pattern, and each kind of bad file reaching its own "calibration invalid"
//! reason.

mod common;

use common::*;
use embedded_graphics::mock_display::MockDisplay;
use embedded_graphics::pixelcolor::BinaryColor;
use embedded_graphics::prelude::*;
use embedded_graphics_simulator::{OutputSettingsBuilder, SimulatorDisplay};
use firmware_sim::screens::{self, rejection_lines};
use firmware_sim::{Button, Calibration, Event, Firmware, Rejection, Screen};
use fslcal_core::unit_file::{self, KeyId, EXAMPLE_SECRET_KEY, VERSION};

/// 2026-11-25 07:30 UTC: 176 days after the example calibration (2026-06-01 09:30).
const DIVE_DAY: i64 = 1_795_591_800;

fn loaded(file: &[u8]) -> Box<Firmware> {
    let mut fw = firmware();
    fw.handle(Event::SetClock { unix_s: DIVE_DAY });
    fw.handle(Event::LoadFile(file));
    fw
}

fn dot_at_depth(z_m: f64) -> Event<'static> {
    let ex = unit_file::example();
    let p = ex.laser.pixel_at_depth(&ex.camera, z_m).unwrap();
    Event::Dot { u_px: p.x, v_px: p.y }
}

#[test]
fn each_bad_file_reaches_its_own_reason() {
    let stranger = KeyId::of(&unit_file::public_key(&STRANGER_SECRET_KEY));
    let cases: [(&str, Vec<u8>, Rejection, [&str; 3]); 6] = [
        ("tampered", tampered_file(), Rejection::Tampered, ["TAMPERED", "signature does not", "match the contents"]),
        (
            "other unit",
            other_unit_file(),
            Rejection::OtherUnit { file_unit: firmware_sim::text!(12, "FSL-05") },
            ["OTHER UNIT", "file is for FSL-05", "this unit is FSL-03"],
        ),
        (
            "unknown signer",
            unknown_signer_file(),
            Rejection::UnknownSigner(stranger),
            ["UNKNOWN SIGNER", &format!("key {stranger}"), "is not trusted here"],
        ),
        (
            "newer format",
            newer_format_file(),
            Rejection::NewerFormat { found: VERSION + 1, supported: VERSION },
            ["NEWER FORMAT", &format!("file v{}, reads v{VERSION}", VERSION + 1), "update the firmware"],
        ),
        (
            "truncated",
            truncated_file(),
            Rejection::Truncated { found: 300, expected: good_file().len() },
            ["TRUNCATED", &format!("300 of {} bytes", good_file().len()), "copy the file again"],
        ),
        (
            "not a calibration",
            b"Dive log, site B".to_vec(),
            Rejection::NotACalibration,
            ["NOT A CALIBRATION", "not an .fslcal file", ""],
        ),
    ];
    for (name, file, want, lines) in cases {
        let mut fw = loaded(&file);
        assert_eq!(fw.screen(), Screen::Invalid, "{name}");
        assert_eq!(*fw.calibration(), Calibration::Invalid(want), "{name}");
        let got = rejection_lines("FSL-03", &want).map(|l| l.as_str().to_string());
        assert_eq!(got, lines, "{name}");
        // Nothing gets past the warning: no measuring with a refused file.
        fw.handle(Event::Press(Button::Next));
        fw.handle(dot_at_depth(2.0));
        fw.handle(Event::Validation { measured_mm: 400.0, true_mm: 400.0 });
        assert_eq!(fw.screen(), Screen::Invalid, "{name}");
        assert!(fw.reading().is_none() && fw.validation().is_none(), "{name}");
    }
    // And the good file passes, with the facts the self-check screen shows.
    let fw = loaded(&good_file());
    assert_eq!(fw.screen(), Screen::SelfCheck);
    assert_eq!(fw.calibration_age_days(), Some(176));
    let Calibration::Valid(cal) = fw.calibration() else { panic!() };
    let lines = screens::self_check_lines(&fw, cal).map(|l| l.as_str().to_string());
    assert_eq!(lines[0], "unit   FSL-03");
    assert_eq!(lines[1], "cal 2026-06-01 176 d");
    assert_eq!(lines[2], "signer example-key");
    assert_eq!(lines[4], format!("file v{} {} B", VERSION, good_file().len()));
}

#[test]
fn a_stored_file_is_verified_again_by_the_self_check() {
    // The firmware keeps the raw bytes; OK on the self-check screen re-verifies them.
    let mut fw = loaded(&good_file());
    fw.handle(Event::Press(Button::Ok));
    assert_eq!(fw.screen(), Screen::SelfCheck);
    // A file signed by the right key but for this unit under a different name is still
    // another unit's: the unit comparison is exact.
    let mut c = unit_file::example();
    c.unit = "FSL-3";
    let fw = loaded(&sign(&c, &EXAMPLE_SECRET_KEY));
    assert!(matches!(fw.calibration(), Calibration::Invalid(Rejection::OtherUnit { .. })));
}

#[test]
fn an_empty_or_oversized_file_is_refused_not_ignored() {
    let fw = loaded(&[]);
    assert_eq!(*fw.calibration(), Calibration::Invalid(Rejection::Truncated { found: 0, expected: 7 }));
    let fw = loaded(&vec![0u8; 4096]);
    assert_eq!(*fw.calibration(), Calibration::Invalid(Rejection::NotACalibration));
    // A bad file after a good one replaces it: the diver never measures with a stale file.
    let mut fw = loaded(&good_file());
    fw.handle(Event::LoadFile(&tampered_file()));
    assert_eq!(fw.screen(), Screen::Invalid);
}

#[test]
fn drift_warning_needs_most_recent_dots_off_the_line_and_clears_on_ok() {
    let mut fw = loaded(&good_file());
    fw.handle(Event::Press(Button::Next));
    let ex = unit_file::example();
    let off = |z: f64| {
        let p = ex.laser.pixel_at_depth(&ex.camera, z).unwrap();
        Event::Dot { u_px: p.x + 8.0, v_px: p.y }
    };
    for z in [1.0, 2.0, 3.0] {
        fw.handle(dot_at_depth(z));
        assert_eq!(fw.screen(), Screen::Live);
    }
    for (i, z) in [1.0, 1.5, 2.0, 2.5, 3.0].into_iter().enumerate() {
        fw.handle(off(z));
        let f = fw.reading().unwrap().fix.unwrap();
        assert!(f.miss_px > 7.0 && f.miss_px < 8.0, "{}", f.miss_px);
        assert_eq!(fw.screen(), if i < 4 { Screen::Live } else { Screen::DriftWarning }, "dot {i}");
    }
    fw.handle(Event::Press(Button::Ok));
    assert_eq!(fw.screen(), Screen::Live);
    fw.handle(dot_at_depth(2.0));
    assert_eq!(fw.screen(), Screen::Live);
}

#[test]
fn validation_passes_within_three_percent() {
    let mut fw = loaded(&good_file());
    fw.handle(Event::Validation { measured_mm: 411.9, true_mm: 400.0 });
    let v = *fw.validation().unwrap();
    assert!(v.pass && (v.error_pct - 2.975).abs() < 1e-9);
    fw.handle(Event::Validation { measured_mm: 387.9, true_mm: 400.0 });
    assert!(!fw.validation().unwrap().pass);
    assert_eq!(fw.screen(), Screen::Validation);
}

/// The example calibration as an import of the lab's files writes it: no covariance (all
/// zero, which means unknown).
fn imported_file() -> Vec<u8> {
    let mut c = unit_file::example();
    c.laser_covariance = [[0.0; 4]; 4];
    c.fit = None;
    c.method = unit_file::FitMethod::Imported;
    c.provenance = unit_file::Provenance::LabPkg;
    sign(&c, &EXAMPLE_SECRET_KEY)
}

#[test]
fn an_imported_calibrations_unknown_sigma_reads_unknown_never_zero() {
    let mut fw = loaded(&imported_file());
    let Calibration::Valid(cal) = *fw.calibration() else { panic!("the imported file loads") };
    fw.handle(Event::Press(Button::Next));
    fw.handle(dot_at_depth(2.5));
    let fix = fw.reading().unwrap().fix.unwrap();
    assert!((fix.distance_m - 2.5).abs() < 1e-6 && fix.sigma_m.is_none(), "{fix:?}");
    let (_, lines) = screens::live_lines(&fw, &cal);
    assert_eq!(lines[0].as_str(), "± unknown (1σ)");
    // The same dot through the signed example (a real covariance) has a figure.
    let mut known = loaded(&good_file());
    known.handle(Event::Press(Button::Next));
    known.handle(dot_at_depth(2.5));
    assert!(known.reading().unwrap().fix.unwrap().sigma_m.is_some_and(|s| s > 0.0));
}

/// The firmware states each golden screen is drawn from.
fn golden_states() -> Vec<(&'static str, Box<Firmware>)> {
    let after = |file: &[u8], events: &[Event]| {
        let mut fw = loaded(file);
        for e in events {
            fw.handle(*e);
        }
        fw
    };
    let good = good_file();
    let next = Event::Press(Button::Next);
    let ex = unit_file::example();
    let mut drift = vec![next];
    for z in [1.0, 1.5, 2.0, 2.5, 3.0] {
        let p = ex.laser.pixel_at_depth(&ex.camera, z).unwrap();
        drift.push(Event::Dot { u_px: p.x + 8.0, v_px: p.y });
    }
    vec![
        ("no-calibration", firmware()),
        ("self-check", after(&good, &[])),
        ("invalid-tampered", after(&tampered_file(), &[])),
        ("invalid-other-unit", after(&other_unit_file(), &[])),
        ("invalid-unknown-signer", after(&unknown_signer_file(), &[])),
        ("invalid-newer-format", after(&newer_format_file(), &[])),
        ("invalid-truncated", after(&truncated_file(), &[])),
        ("invalid-not-a-calibration", after(b"Dive log", &[])),
        ("live-waiting", after(&good, &[next])),
        ("live-2.5m", after(&good, &[next, dot_at_depth(2.5)])),
        ("live-outside-image", after(&good, &[next, Event::Dot { u_px: 4100.0, v_px: 10.0 }])),
        ("live-imported-2.5m", after(&imported_file(), &[next, dot_at_depth(2.5)])),
        ("validation-none", after(&good, &[next, next])),
        ("validation-pass", after(&good, &[Event::Validation { measured_mm: 404.2, true_mm: 400.0 }])),
        ("validation-fail", after(&good, &[Event::Validation { measured_mm: 386.5, true_mm: 400.0 }])),
        ("drift-warning", after(&good, &drift)),
    ]
}

fn render(fw: &Firmware) -> image::RgbImage {
    let mut display = SimulatorDisplay::<BinaryColor>::new(Size::new(screens::WIDTH, screens::HEIGHT));
    screens::draw(fw, &mut display).unwrap();
    let out = display.to_rgb_output_image(&OutputSettingsBuilder::new().build());
    let b = out.as_image_buffer();
    image::RgbImage::from_raw(b.width(), b.height(), b.as_raw().to_vec()).unwrap()
}

#[test]
fn every_screen_matches_its_golden_png_pixel_for_pixel() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/golden");
    let mut failures = Vec::new();
    for (name, fw) in golden_states() {
        let got = render(&fw);
        let path = dir.join(format!("{name}.png"));
        if bless() {
            std::fs::create_dir_all(&dir).unwrap();
            got.save(&path).unwrap();
            continue;
        }
        let want = image::open(&path)
            .unwrap_or_else(|e| panic!("{}: {e} (FSLCAL_BLESS=1 writes it)", path.display()))
            .to_rgb8();
        assert_eq!(want.dimensions(), (128, 64), "{name}");
        let differing = got.pixels().zip(want.pixels()).filter(|(a, b)| a != b).count();
        let lit = got.pixels().filter(|p| p.0 != [0, 0, 0]).count();
        // A blank or all-lit screen would be a drawing bug even if blessed.
        assert!(lit > 150 && lit < 128 * 64 / 2, "{name}: {lit} lit pixels");
        if differing > 0 {
            let actual = std::env::temp_dir().join(format!("firmware-sim-{name}.png"));
            got.save(&actual).unwrap();
            failures.push(format!("{name}: {differing} pixels differ (actual in {})", actual.display()));
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

/// The left half of the tampered file's screen: the inverted title bar, the headline and
/// the first detail line, as MockDisplay patterns (`#` lit, `.` dark). The display is 128
/// wide; MockDisplay holds 64x64, so the right half is clipped away.
#[test]
fn invalid_screen_layout_matches_the_pattern() {
    let fw = loaded(&tampered_file());
    let mut d = MockDisplay::<BinaryColor>::new();
    d.set_allow_out_of_bounds_drawing(true);
    d.set_allow_overdraw(true);
    screens::draw(&fw, &mut d).unwrap();
    let rows: Vec<String> = (0..33)
        .map(|y| {
            (0..64).map(|x| if d.get_pixel(Point::new(x, y)) == Some(BinaryColor::On) { '#' } else { '.' }).collect()
        })
        .collect();
    let expected = PATTERN_TAMPERED_TOP_LEFT;
    if rows.join("\n") != expected.join("\n") {
        panic!("pattern differs; got:\n{}", rows.join("\n"));
    }
    // The title bar spans the whole width: lit right edge on every bar row, dark below it.
    let mut right = MockDisplay::<BinaryColor>::new();
    right.set_allow_out_of_bounds_drawing(true);
    right.set_allow_overdraw(true);
    screens::draw(&fw, &mut right.translated(Point::new(-64, 0))).unwrap();
    for y in 0..64 {
        let want = if y < screens::TITLE_ROWS as i32 { BinaryColor::On } else { BinaryColor::Off };
        assert_eq!(right.get_pixel(Point::new(63, y)), Some(want), "row {y}");
    }
}

const PATTERN_TAMPERED_TOP_LEFT: &[&str] = &[
    "################################################################",
    "################################################################",
    "##...####.###.######...##....##....####.###.....##...###...##.##",
    "#.###.##.#.##.#######.####.##.#.###.##.#.####.#####.###.###.#.##",
    "#.#####.###.#.#######.####.##.#.###.#.###.###.#####.###.###.#..#",
    "#.#####.###.#.#######.####...##....##.###.###.#####.###.###.#.#.",
    "#.#####.....#.#######.####.##.#.#.###.....###.#####.###.###.#.##",
    "#.###.#.###.#.#######.####.##.#.##.##.###.###.#####.###.###.#.##",
    "##...##.###.#.....##...##....##.###.#.###.###.####...###...##.##",
    "################################################################",
    "################################################################",
    "................................................................",
    "................................................................",
    "................................................................",
    ".#####...#...#...#.####..#####.####..#####.####.................",
    "...#....#.#..#...#.#...#.#.....#...#.#......#..#................",
    "...#...#...#.##.##.#...#.#.....#...#.#......#..#................",
    "...#...#...#.#.#.#.####..####..####..####...#..#................",
    "...#...#####.#...#.#.....#.....#.#...#......#..#................",
    "...#...#...#.#...#.#.....#.....#..#..#......#..#................",
    "...#...#...#.#...#.#.....#####.#...#.#####.####.................",
    "................................................................",
    "................................................................",
    "................................................................",
    ".........#......................#...............................",
    "................................#...............................",
    "..###...##....####.#.##...###..####..#...#.#.##...###.........##",
    ".#.......#...#...#.##..#.....#..#....#...#.##..#.#...#.......#..",
    "..###....#...#...#.#...#..####..#....#...#.#.....#####.......#..",
    ".....#...#....####.#...#.#...#..#..#.#..##.#.....#...........#..",
    ".####...###......#.#...#..####...##...##.#.#......###.........##",
    ".............#...#..............................................",
    "..............###...............................................",
];
