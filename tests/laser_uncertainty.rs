//! The laser fit's reported 1-sigma, checked the way mrcal checks its uncertainty: many fits
//! of one calibration session, each with fresh seeded pixel noise of a known sigma, and the
//! observed spread of the fitted direction, origin and predicted distances compared with
//! what each fit reports (its covariance and `distance_sigma_m`).
//!
//! The session is a real calibration's geometry: the board poses `laser_scene_set` places
//! for the rendered laser tests (the TG-6 model, its laser, 0.6-4.5 m, tilted up to 35
//! degrees). The dots are rendered geometrically, not as images: the true dot is where the
//! true laser line meets the board's plane, projected through the camera model (distortion
//! included), plus Gaussian noise on each pixel axis. Rendering 4000x3000 photos for
//! hundreds of fits would take far too long, and the image stage has its own tests (the dot
//! within a pixel of the truth); what is checked here is the fit's claim about what pixel
//! noise does to the laser. The board planes are exact, as the covariance assumes.
//!
//! See the table with `cargo test --release --test laser_uncertainty -- --nocapture`.

use calib_targets::rig::{fsl_laser, tg6_camera};
use calib_targets::scene::{laser_scene_set, Water};
use fslcal::laser::fit::{fit, DotObservation, Gates, LaserFit, Method};
use fslcal_core::{CameraModel, LaserLine, Plane, Vec2, Vec3};

/// Fits per check: the observed sigma of 1000 Gaussian samples is within 2.2% (1-sigma) of
/// the true one, so the ±25% bound is eleven of its own sigmas wide: a miss is the fit's,
/// not the sampling's. (A fit takes about 0.2 ms in release.)
const TRIALS: usize = 1000;
/// Photos in the session, as the rendered laser tests and a diver's session have.
const PHOTOS: usize = 16;
/// Depths at which the fit reports its distance sigma, metres.
const DEPTHS_M: [f64; 3] = [1.0, 3.0, 5.0];
/// How far the observed sigma may be from the reported one, as a fraction.
const TOLERANCE: f64 = 0.25;

/// A seeded xorshift64* with Box-Muller normals: the test owns its noise.
struct Noise(u64);

impl Noise {
    fn unit(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        ((self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }

    fn gaussian(&mut self) -> f64 {
        let (a, b) = (self.unit(), self.unit());
        (-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos()
    }
}

/// One calibration session: the camera, the true laser, each photo's board plane and the
/// dot's true pixel on it.
struct Session {
    camera: CameraModel,
    laser: LaserLine,
    planes: Vec<Plane>,
    true_dots_px: Vec<Vec2>,
}

fn session(seed: u64) -> Session {
    let (camera, laser) = (tg6_camera(), fsl_laser());
    let planes: Vec<Plane> = laser_scene_set(PHOTOS, seed, Water::Clear, 0)
        .iter()
        .map(|s| s.board.as_ref().expect("a board").1.plane())
        .collect();
    let true_dots_px = planes
        .iter()
        .map(|p| camera.project(&laser.hit(p).expect("the laser meets the board")).expect("the dot is in front"))
        .collect();
    Session { camera, laser, planes, true_dots_px }
}

/// What one fit gives: its parameters (origin x, y in metres; slopes x/z, y/z), its unit
/// direction, the depth it reads from the true line's dot at each of [`DEPTHS_M`], and what
/// it reports about itself.
struct Trial {
    params: [f64; 4],
    direction: Vec3,
    depths_m: [f64; 3],
    reported: LaserFit,
}

fn trial(s: &Session, noise_px: f64, stated_sigma_px: f64, noise: &mut Noise) -> Trial {
    let obs: Vec<Option<DotObservation>> = s
        .planes
        .iter()
        .zip(&s.true_dots_px)
        .map(|(plane, px)| {
            let seen = px + Vec2::new(noise_px * noise.gaussian(), noise_px * noise.gaussian());
            Some(DotObservation { plane: *plane, candidates: vec![seen], sigma_px: stated_sigma_px })
        })
        .collect();
    let f = fit(&s.camera, &obs, Method::Reprojection, &Gates::default()).expect("every noisy session fits");
    assert_eq!(f.used, PHOTOS, "no dot of Gaussian noise is an outlier");
    let depths_m = DEPTHS_M.map(|z| {
        let px = s.laser.pixel_at_depth(&s.camera, z).expect("the true dot is in the image");
        f.laser.fix_from_pixel(&s.camera, px).expect("the fitted line gives a depth").depth_m
    });
    Trial { params: f.laser.to_params(), direction: f.laser.dir(), depths_m, reported: f }
}

/// Standard deviation about the mean.
fn std(xs: impl Iterator<Item = f64> + Clone) -> f64 {
    let n = xs.clone().count() as f64;
    let mean = xs.clone().sum::<f64>() / n;
    (xs.map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt()
}

/// Root mean square: the 1-sigma that a set of per-fit reported sigmas amounts to.
fn rms(xs: impl Iterator<Item = f64>) -> f64 {
    let (n, sum) = xs.fold((0.0, 0.0), |(n, s), x| (n + 1.0, s + x * x));
    (sum / n).sqrt()
}

/// A row of the table: a quantity, the reported and the observed 1-sigma, and the mean
/// error against the truth (printed, in units of the observed sigma: the fit's bias).
struct Row {
    name: String,
    reported: f64,
    observed: f64,
    bias_sigmas: f64,
}

fn mean(xs: impl Iterator<Item = f64>) -> f64 {
    let (n, sum) = xs.fold((0.0, 0.0), |(n, s), x| (n + 1.0, s + x));
    sum / n
}

fn rows(s: &Session, trials: &[Trial]) -> Vec<Row> {
    let truth = s.laser.to_params();
    let cov = |a: usize, b: usize| trials.iter().map(move |t| t.reported.covariance[a][b]);
    let mut rows = Vec::new();
    // The direction's total angle, as `direction_text` prints it: atan(sqrt(var x/z + var y/z)).
    let mean_dir = trials.iter().fold(Vec3::zeros(), |a, t| a + t.direction).normalize();
    let angles_deg = trials.iter().map(|t| t.direction.dot(&mean_dir).clamp(-1.0, 1.0).acos().to_degrees());
    let observed = rms(angles_deg);
    rows.push(Row {
        name: "direction angle (deg)".into(),
        reported: rms(cov(2, 2).zip(cov(3, 3)).map(|(a, b)| (a + b).sqrt().atan().to_degrees())),
        observed,
        bias_sigmas: mean_dir.dot(&s.laser.dir()).clamp(-1.0, 1.0).acos().to_degrees() / observed,
    });
    for (i, name, scale) in [
        (2, "direction slope x/z (mrad)", 1e3),
        (3, "direction slope y/z (mrad)", 1e3),
        (0, "origin x (mm)", 1e3),
        (1, "origin y (mm)", 1e3),
    ] {
        let observed = std(trials.iter().map(|t| t.params[i]));
        rows.push(Row {
            name: name.into(),
            reported: scale * rms(cov(i, i).map(f64::sqrt)),
            observed: scale * observed,
            bias_sigmas: (mean(trials.iter().map(|t| t.params[i])) - truth[i]) / observed,
        });
    }
    for (k, z) in DEPTHS_M.iter().enumerate() {
        let observed = std(trials.iter().map(|t| t.depths_m[k]));
        rows.push(Row {
            name: format!("distance at {z:.0} m (mm)"),
            reported: 1e3 * rms(trials.iter().map(|t| t.reported.distance_sigma_m[k].1)),
            observed: 1e3 * observed,
            bias_sigmas: (mean(trials.iter().map(|t| t.depths_m[k])) - z) / observed,
        });
    }
    rows
}

/// Runs the fits of session `session_seed` with noise `seed` and prints the table.
fn table(label: &str, noise_px: f64, stated_sigma_px: f64, session_seed: u64, seed: u64) -> Vec<Row> {
    let s = session(session_seed);
    let mut noise = Noise(seed);
    let trials: Vec<Trial> = (0..TRIALS).map(|_| trial(&s, noise_px, stated_sigma_px, &mut noise)).collect();
    let rows = rows(&s, &trials);
    println!(
        "{label}: {TRIALS} fits of {PHOTOS} dots (0.6-4.5 m), pixel noise {noise_px} px, stated {stated_sigma_px} px"
    );
    println!("  {:<28} {:>12} {:>12} {:>8} {:>8}", "quantity", "reported 1σ", "observed 1σ", "obs/rep", "bias/σ");
    for r in &rows {
        println!(
            "  {:<28} {:>12.4} {:>12.4} {:>8.3} {:>+8.2}",
            r.name,
            r.reported,
            r.observed,
            r.observed / r.reported,
            r.bias_sigmas
        );
    }
    rows
}

/// Asserts every observed sigma within `expected` ±25% of the reported one.
fn assert_ratios(label: &str, rows: &[Row], expected: f64) {
    for r in rows {
        let ratio = r.observed / r.reported;
        assert!(
            (expected * (1.0 - TOLERANCE)..=expected * (1.0 + TOLERANCE)).contains(&ratio),
            "{label}: {}: observed 1-sigma {:.4} vs reported {:.4} (ratio {ratio:.3}, expected {expected} ±{:.0}%)",
            r.name,
            r.observed,
            r.reported,
            100.0 * TOLERANCE
        );
    }
}

/// Measured: the spread is about 5% under what is reported, because the fit never lets the
/// residuals shrink its sigma (`max(1, chi²/dof)` averages about 1.1 at 28 degrees of
/// freedom, which is 5% in sigma).
#[test]
fn reported_sigma_matches_the_spread_when_the_dot_noise_is_stated_right() {
    let rows = table("stated right", 0.5, 0.5, 11, 0x5eed_0001);
    assert_ratios("stated right", &rows, 1.0);
}

/// A detector that claims more precision than it has: the fit must notice from its residuals
/// and widen what it reports, never print the claimed precision. Measured: the spread is
/// 5-10% over what is reported, as the Huber loss (at 1.5 *stated* sigmas) then down-weights
/// good dots and loses some efficiency.
#[test]
fn reported_sigma_matches_the_spread_when_the_dot_noise_is_understated() {
    let rows = table("understated 2x", 0.8, 0.4, 23, 0x5eed_0002);
    assert_ratios("understated 2x", &rows, 1.0);
}

/// A detector that claims less precision than it has: the fit keeps the stated sigma (a
/// lucky session is not a precise one), so it reports twice the spread it shows, by design.
#[test]
fn reported_sigma_stays_conservative_when_the_dot_noise_is_overstated() {
    let rows = table("overstated 2x", 0.3, 0.6, 31, 0x5eed_0003);
    assert_ratios("overstated 2x", &rows, 0.5);
}
