//! The companion's live distance shows a dot's distance only when the dot's offset from the
//! calibrated line's image is explained by the calibration's covariance and a dot's
//! centring: the same `fslcal_core::LaserLine::gate` that `fslcal check` and `measure` use
//! to pick the dot, so a reflection or glint clicked beside the line never becomes a
//! distance on the screen.

mod common;

use common::*;
use firmware_sim::screens;
use firmware_sim::{Button, Calibration, Event, Firmware};
use fslcal_core::unit_file;
use fslcal_core::{Vec2, DOT_CENTRING_FLOOR_PX, LINE_GATE_CHI2};

/// 2026-11-25 07:30 UTC: 176 days after the example calibration (2026-06-01 09:30).
const DIVE_DAY: i64 = 1_795_591_800;

fn live() -> Box<Firmware> {
    let mut fw = firmware();
    fw.handle(Event::SetClock { unix_s: DIVE_DAY });
    fw.handle(Event::LoadFile(&good_file()));
    fw.handle(Event::Press(Button::Next));
    fw
}

#[test]
fn the_live_distance_is_shown_only_for_dots_the_calibration_explains() {
    let ex = unit_file::example();
    let mut fw = live();
    let Calibration::Valid(cal) = *fw.calibration() else { panic!("the example file loads") };
    // Across the line's image at each depth, stepping out from the line: the firmware's
    // decision is the core gate's, and the gate's edge is at sqrt(LINE_GATE_CHI2) sigma.
    for z in [0.7, 1.5, 3.0, 4.5] {
        let on = ex.laser.pixel_at_depth(&ex.camera, z).unwrap();
        let next = ex.laser.pixel_at_depth(&ex.camera, z * 1.01).unwrap();
        let t = (next - on).normalize();
        let normal = Vec2::new(-t.y, t.x);
        let sigma = ex.laser.gate(&ex.camera, &ex.laser_covariance, on, DOT_CENTRING_FLOOR_PX).unwrap().sigma_px;
        assert!((DOT_CENTRING_FLOOR_PX..3.0).contains(&sigma), "z {z}: sigma {sigma:.3} px");
        let edge = LINE_GATE_CHI2.sqrt() * sigma;
        for k in 0..=12 {
            let off_px = 0.5 * k as f64;
            let px = on + normal * off_px;
            fw.handle(Event::Dot { u_px: px.x, v_px: px.y });
            let f = fw.reading().unwrap().fix.expect("a fix near the line");
            let (big, lines) = screens::live_lines(&fw, &cal);
            if off_px < 0.95 * edge {
                assert!(f.explained, "z {z}: {off_px} px off (edge {edge:.2}) not explained");
                assert!((f.distance_m - z).abs() < 0.05 * z, "z {z}: {}", f.distance_m);
                assert!(big.as_str().ends_with(" m") && !big.as_str().starts_with('-'), "{}", big.as_str());
            } else if off_px > 1.05 * edge {
                assert!(!f.explained, "z {z}: {off_px} px off (edge {edge:.2}) explained");
                assert_eq!(big.as_str(), "-.--- m");
                assert_eq!(lines[0].as_str(), "off the line: no dist.");
            }
        }
    }
}
