//! The camera companion's live distance against the renderer's truth. Photos of the board
//! with the laser dot at 0.6-4.5 m are rendered with their ground truth (`DotTruth`: the
//! dot's pixel and its true depth); the firmware (`firmware-sim`, no_std) holds a signed unit
//! file of a calibration fitted from a noisy session, is given each dot, and the distance it
//! computes and the one it shows are compared with the depth at which the renderer put the
//! dot.
//!
//! The scenes are the TG-6 model at a quarter of its resolution (1000x750: the same field of
//! view and lens; a 12 Mpx render takes some 15 s, this one under 1 s). The camera model in
//! the file is the renderer's: intrinsics error is the camera tests' business.
//!
//! Error budget. With the true pixel, the firmware is off by the calibration's own error,
//! which its reported 1-sigma bounds at 3 sigma (the Monte-Carlo test `laser_uncertainty`
//! checks that sigma against the spread it claims). With a live dot carrying Gaussian pixel
//! noise of sigma `DOT_NOISE_PX`, that noise moves the depth by at most `g` times as much,
//! `g` the largest depth change per pixel around the dot, and the two add in quadrature: the
//! error stays within 4 combined sigmas. The screen rounds to the millimetre.

use calib_targets::rig::{fsl_laser, tg6_camera};
use calib_targets::scene::{laser_scene_set, render, SceneSpec, Water};
use firmware_sim::{screens, Button, Calibration, Config, Event, Firmware, TrustedKey};
use fslcal::laser::fit::{fit, DotObservation, Gates, LaserFit, Method};
use fslcal_core::unit_file::{self, UnitFile, EXAMPLE_SECRET_KEY, MAX_FILE_BYTES};
use fslcal_core::{CameraModel, LaserLine, Vec2};
use rayon::prelude::*;
use std::sync::OnceLock;

/// Pixel noise of the calibration session's dots and of the live dots, pixels of the
/// quarter-resolution frame: 0.5 px at full resolution, as in `laser_uncertainty`.
const SESSION_NOISE_PX: f64 = 0.125;
const DOT_NOISE_PX: f64 = 0.125;
/// Noisy live dots per rendered photo.
const DRAWS: usize = 25;

fn trusted() -> &'static [TrustedKey] {
    static KEYS: OnceLock<[TrustedKey; 1]> = OnceLock::new();
    KEYS.get_or_init(|| [TrustedKey { name: "example-key", public_key: unit_file::public_key(&EXAMPLE_SECRET_KEY) }])
}

/// The TG-6 model at a quarter of its resolution, pixel centres mapped exactly.
fn quarter_tg6() -> CameraModel {
    let c = tg6_camera();
    CameraModel {
        width_px: c.width_px / 4,
        height_px: c.height_px / 4,
        fx_px: c.fx_px / 4.0,
        fy_px: c.fy_px / 4.0,
        cx_px: (c.cx_px + 0.5) / 4.0 - 0.5,
        cy_px: (c.cy_px + 0.5) / 4.0 - 0.5,
        distortion: c.distortion,
    }
}

/// A seeded xorshift64 with Box-Muller normals.
struct Noise(u64);

impl Noise {
    fn unit(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        ((self.0 >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }

    fn gaussian(&mut self) -> f64 {
        let (a, b) = (self.unit(), self.unit());
        (-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos()
    }

    fn pixel(&mut self, sigma_px: f64) -> Vec2 {
        Vec2::new(sigma_px * self.gaussian(), sigma_px * self.gaussian())
    }
}

/// The rig's laser-calibration photos (board poses from `laser_scene_set`) seen by `camera`.
fn scenes(count: usize, seed: u64, camera: CameraModel) -> Vec<SceneSpec> {
    laser_scene_set(count, seed, Water::Clear, 0).into_iter().map(|s| SceneSpec { camera, ..s }).collect()
}

/// A diver's calibration of the rig: 16 board photos at 0.6-4.5 m whose dots carry seeded
/// Gaussian pixel noise, fitted with the default method. Its laser is off the truth by a
/// realistic amount, and its covariance says by how much.
fn session_fit(camera: &CameraModel, laser: &LaserLine) -> LaserFit {
    let mut noise = Noise(0x2545_f491_4f6c_dd1d);
    let obs: Vec<Option<DotObservation>> = scenes(16, 3, *camera)
        .iter()
        .map(|spec| {
            let plane = spec.board.as_ref().expect("a board").1.plane();
            let px = camera.project(&laser.hit(&plane).expect("dot on the board")).expect("in front");
            let seen = px + noise.pixel(SESSION_NOISE_PX);
            Some(DotObservation { plane, candidates: vec![seen], sigma_px: SESSION_NOISE_PX })
        })
        .collect();
    fit(camera, &obs, Method::Reprojection, &Gates::default()).expect("the session fits")
}

/// The firmware with the signed file of `contents` loaded and its live screen up.
fn firmware_with(contents: &UnitFile) -> Box<Firmware> {
    let mut buf = [0u8; MAX_FILE_BYTES];
    let n = contents.sign(&EXAMPLE_SECRET_KEY, &mut buf).expect("signs");
    let mut fw = Box::new(Firmware::new(Config { unit: "FSL-03", trusted_keys: trusted() }));
    fw.handle(Event::LoadFile(&buf[..n]));
    fw.handle(Event::Press(Button::Next));
    assert!(matches!(fw.calibration(), Calibration::Valid(_)), "{:?}", fw.calibration());
    fw
}

/// The largest depth change a one-pixel step in any direction from `px` makes, metres.
fn depth_per_px(camera: &CameraModel, laser: &LaserLine, px: Vec2) -> f64 {
    let z = laser.fix_from_pixel(camera, px).expect("a fix").depth_m;
    (0..32)
        .map(|k| {
            let a = std::f64::consts::TAU * k as f64 / 32.0;
            let q = px + Vec2::new(a.cos(), a.sin());
            (laser.fix_from_pixel(camera, q).expect("a fix").depth_m - z).abs()
        })
        .fold(0.0, f64::max)
}

/// What the firmware computes and shows for a dot at `px`: (distance, its sigma, shown).
fn reading(fw: &mut Firmware, px: Vec2) -> (f64, f64, f64) {
    fw.handle(Event::Dot { u_px: px.x, v_px: px.y });
    let fix = fw.reading().expect("a reading").fix.expect("a dot on the beam gives a fix");
    let Calibration::Valid(cal) = *fw.calibration() else { unreachable!("checked on load") };
    let (shown, _) = screens::live_lines(fw, &cal);
    let shown_m: f64 = shown.as_str().trim_end_matches(" m").parse().expect("the screen shows metres");
    (fix.distance_m, fix.sigma_m.expect("a fitted calibration has a sigma"), shown_m)
}

#[test]
fn firmware_live_distance_matches_the_renderers_true_depth() {
    let camera = quarter_tg6();
    let cal = session_fit(&camera, &fsl_laser());
    let contents = UnitFile {
        camera,
        laser: cal.laser,
        // As `fslcal laser` signs it: the file keeps the upper triangle, so the fit's rounding
        // asymmetry is averaged away.
        laser_covariance: std::array::from_fn(|r| {
            std::array::from_fn(|c| 0.5 * (cal.covariance[r][c] + cal.covariance[c][r]))
        }),
        depth_range_m: Some([cal.depth_range_m.0 as f32, cal.depth_range_m.1 as f32]),
        ..unit_file::example()
    };
    let mut fw = firmware_with(&contents);
    let truths: Vec<_> =
        scenes(8, 41, camera).par_iter().map(|s| render(s).truth.dot.expect("the dot is on the board")).collect();

    let mut noise = Noise(0x9e37_79b9_7f4a_7c15);
    let (mut worst_true, mut worst_live, mut sum_sq, mut count) = (0.0f64, 0.0f64, 0.0, 0);
    for truth in &truths {
        let true_px = Vec2::new(truth.pixel[0], truth.pixel[1]);
        // The true pixel: only the calibration's error is left.
        let (z, sigma_cal_m, shown) = reading(&mut fw, true_px);
        let e = z - truth.depth_m;
        assert!(e.abs() <= 3.0 * sigma_cal_m, "true dot at {:.2} m: {:.2} mm off", truth.depth_m, 1e3 * e);
        assert!((shown - z).abs() <= 0.5e-3 + 1e-9, "shown {shown} for {z}");
        worst_true = worst_true.max(e.abs() / sigma_cal_m);
        // Live dots with pixel noise.
        let g = depth_per_px(&camera, &cal.laser, true_px);
        let sigma_m = sigma_cal_m.hypot(g * DOT_NOISE_PX);
        let mut worst_here = 0.0f64;
        for _ in 0..DRAWS {
            let (z, _, shown) = reading(&mut fw, true_px + noise.pixel(DOT_NOISE_PX));
            let e = z - truth.depth_m;
            assert!(e.abs() <= 4.0 * sigma_m, "live dot at {:.2} m: {:.2} mm off", truth.depth_m, 1e3 * e);
            // What the diver reads: the same, plus the screen's rounding to the millimetre.
            assert!((shown - truth.depth_m).abs() <= 4.0 * sigma_m + 0.5e-3 + 1e-9, "shown {shown}");
            worst_here = worst_here.max(e.abs());
            sum_sq += (e / sigma_m).powi(2);
            count += 1;
        }
        worst_live = worst_live.max(worst_here / sigma_m);
        println!(
            "true {:.3} m: true pixel {:+.2} mm (calibration 1σ {:.2} mm); {DRAWS} live dots worst {:.2} mm (1σ {:.2} mm = calibration + {:.1} mm/px x {DOT_NOISE_PX} px)",
            truth.depth_m,
            1e3 * e,
            1e3 * sigma_cal_m,
            1e3 * worst_here,
            1e3 * sigma_m,
            1e3 * g
        );
    }
    println!(
        "worst: true pixel {worst_true:.2} calibration sigmas, live {worst_live:.2} combined sigmas; rms {:.2} sigmas over {count} live dots",
        (sum_sq / count as f64).sqrt()
    );
}
