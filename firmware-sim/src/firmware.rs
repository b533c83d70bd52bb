//! The firmware's state machine: events in, one current screen out. Everything lives in
//! fixed fields of [`Firmware`]; nothing allocates.

use crate::drift::DriftMonitor;
use crate::unit_file::{self, Rejection, TrustedKey, UnitCalibration};
use fslcal_core::unit_file::MAX_FILE_BYTES;
use fslcal_core::Vec2;

/// What a firmware build is configured with.
#[derive(Clone, Copy, Debug)]
pub struct Config {
    /// This unit's name; a calibration for any other unit is refused.
    pub unit: &'static str,
    /// Public keys whose signatures the firmware accepts (at most
    /// [`unit_file::MAX_TRUSTED_KEYS`]).
    pub trusted_keys: &'static [TrustedKey],
}

/// The companion's two buttons.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Button {
    /// Cycles self-check -> live -> validation.
    Next,
    /// Acknowledges a drift warning (and re-runs the self-check on the self-check screen).
    Ok,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Event<'a> {
    /// A calibration file arrived (over USB or from the SD card): its bytes.
    LoadFile(&'a [u8]),
    /// The real-time clock was set, seconds since 1970-01-01 UTC.
    SetClock {
        unix_s: i64,
    },
    Press(Button),
    /// The camera found the laser dot at this pixel of a photo.
    Dot {
        u_px: f64,
        v_px: f64,
    },
    /// A slate-length validation result (from `fslcal validate` or the camera): the length
    /// measured through this calibration and the slate's true length.
    Validation {
        measured_mm: f64,
        true_mm: f64,
    },
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Screen {
    NoCalibration,
    SelfCheck,
    Invalid,
    Live,
    Validation,
    DriftWarning,
}

/// The calibration's state.
// No heap to box the large variant into, and the state is one fixed value anyway.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Calibration {
    None,
    Valid(UnitCalibration),
    Invalid(Rejection),
}

/// The live readout for the last dot.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reading {
    pub dot_px: [f64; 2],
    pub fix: Option<Fix>,
}

/// Distance of a dot through the calibration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fix {
    /// Depth of the dot, the `D` of `L = D n w / f`.
    pub distance_m: f64,
    /// 1-sigma of `distance_m` from the laser's covariance.
    pub sigma_m: Option<f64>,
    /// Gap between the dot's camera ray and the calibrated laser line, metres and as pixels
    /// at the dot's depth. Near zero while the laser sits where it was calibrated.
    pub miss_m: f64,
    pub miss_px: f64,
    /// The dot's offset from the calibrated line's image is explained by the calibration's
    /// covariance and the dot's centring (`fslcal_core::LaserLine::gate`, the rule `fslcal
    /// check` and `measure` use): only then is the distance shown.
    pub explained: bool,
}

/// Depths searched for the beam's image when a dot gives no fix: the housing's front to
/// beyond any visibility.
const BEAM_NEAR_M: f64 = 0.1;
const BEAM_FAR_M: f64 = 50.0;

/// Slate validations pass within this error, as `fslcal validate`'s default tolerance.
pub const VALIDATION_TOLERANCE_PCT: f64 = 3.0;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ValidationResult {
    pub measured_mm: f64,
    pub true_mm: f64,
    pub error_pct: f64,
    pub pass: bool,
}

/// The whole firmware state: the raw file, what was decoded from it, and the screens' data.
pub struct Firmware {
    config: Config,
    /// The calibration file as received. Kept so the self-check can verify it again.
    file: [u8; MAX_FILE_BYTES],
    file_len: usize,
    calibration: Calibration,
    clock_unix_s: Option<i64>,
    screen: Screen,
    reading: Option<Reading>,
    dots_seen: u32,
    drift: DriftMonitor,
    validation: Option<ValidationResult>,
}

impl Firmware {
    pub const fn new(config: Config) -> Self {
        Firmware {
            config,
            file: [0; MAX_FILE_BYTES],
            file_len: 0,
            calibration: Calibration::None,
            clock_unix_s: None,
            screen: Screen::NoCalibration,
            reading: None,
            dots_seen: 0,
            drift: DriftMonitor::new(),
            validation: None,
        }
    }

    pub fn handle(&mut self, event: Event) {
        match event {
            Event::LoadFile(bytes) => self.load(bytes),
            Event::SetClock { unix_s } => self.clock_unix_s = Some(unix_s),
            Event::Press(button) => self.press(button),
            Event::Dot { u_px, v_px } => self.dot(u_px, v_px),
            Event::Validation { measured_mm, true_mm } => self.validate(measured_mm, true_mm),
        }
    }

    fn load(&mut self, bytes: &[u8]) {
        self.reading = None;
        self.dots_seen = 0;
        self.drift = DriftMonitor::new();
        self.validation = None;
        if bytes.len() > self.file.len() {
            // Larger than any calibration: nothing worth keeping.
            self.file_len = 0;
            self.calibration = Calibration::Invalid(Rejection::NotACalibration);
            self.screen = Screen::Invalid;
            return;
        }
        self.file[..bytes.len()].copy_from_slice(bytes);
        self.file_len = bytes.len();
        self.self_check();
    }

    /// Verifies the stored file again and shows the result.
    fn self_check(&mut self) {
        self.calibration =
            match unit_file::open(&self.file[..self.file_len], self.config.unit, self.config.trusted_keys) {
                Ok(cal) => Calibration::Valid(cal),
                Err(why) => Calibration::Invalid(why),
            };
        self.screen = match self.calibration {
            Calibration::Valid(_) => Screen::SelfCheck,
            _ => Screen::Invalid,
        };
    }

    fn press(&mut self, button: Button) {
        if !matches!(self.calibration, Calibration::Valid(_)) {
            // Nothing to measure with: the warning stays up.
            return;
        }
        self.screen = match (self.screen, button) {
            (Screen::SelfCheck, Button::Next) => Screen::Live,
            (Screen::Live, Button::Next) => Screen::Validation,
            (Screen::Validation, Button::Next) => {
                self.self_check();
                self.screen
            }
            (Screen::SelfCheck, Button::Ok) => {
                self.self_check();
                self.screen
            }
            (Screen::DriftWarning, Button::Ok) => {
                self.drift.acknowledge();
                Screen::Live
            }
            (Screen::DriftWarning, Button::Next) => Screen::Live,
            (screen, _) => screen,
        };
    }

    fn dot(&mut self, u_px: f64, v_px: f64) {
        let Calibration::Valid(cal) = &self.calibration else { return };
        let px = Vec2::new(u_px, v_px);
        let fix = if cal.camera.contains(px) {
            cal.laser.fix_from_pixel(&cal.camera, px).map(|f| Fix {
                distance_m: f.depth_m,
                sigma_m: cal.laser.depth_sigma_at_pixel(&cal.camera, &cal.laser_covariance, px),
                miss_m: f.miss_m,
                miss_px: f.miss_m * cal.camera.fx_px / f.depth_m,
                explained: cal
                    .laser
                    .gate(&cal.camera, &cal.laser_covariance, px, fslcal_core::DOT_CENTRING_FLOOR_PX)
                    .is_some_and(|g| g.explained()),
            })
        } else {
            None
        };
        self.dots_seen = self.dots_seen.saturating_add(1);
        self.reading = Some(Reading { dot_px: [u_px, v_px], fix });
        // A dot in the image that gives no fix (its ray passes the beam on the far side of
        // the camera) is as far off the line as its pixel is from the beam's image.
        let miss_px = match fix {
            Some(f) => Some(f.miss_px),
            None if cal.camera.contains(px) => {
                Some(cal.laser.pixel_offset(&cal.camera, px, BEAM_NEAR_M, BEAM_FAR_M).unwrap_or(f64::INFINITY))
            }
            None => None,
        };
        if let Some(m) = miss_px {
            self.drift.push(m);
        }
        self.screen = if self.drift.warning() { Screen::DriftWarning } else { Screen::Live };
    }

    fn validate(&mut self, measured_mm: f64, true_mm: f64) {
        if !matches!(self.calibration, Calibration::Valid(_))
            || !true_mm.is_finite()
            || true_mm <= 0.0
            || !measured_mm.is_finite()
        {
            return;
        }
        let error_pct = 100.0 * (measured_mm - true_mm) / true_mm;
        self.validation = Some(ValidationResult {
            measured_mm,
            true_mm,
            error_pct,
            pass: error_pct.abs() <= VALIDATION_TOLERANCE_PCT,
        });
        self.screen = Screen::Validation;
    }

    pub fn screen(&self) -> Screen {
        self.screen
    }

    pub fn calibration(&self) -> &Calibration {
        &self.calibration
    }

    pub fn config(&self) -> &Config {
        &self.config
    }

    pub fn reading(&self) -> Option<&Reading> {
        self.reading.as_ref()
    }

    pub fn dots_seen(&self) -> u32 {
        self.dots_seen
    }

    pub fn drift(&self) -> &DriftMonitor {
        &self.drift
    }

    pub fn validation(&self) -> Option<&ValidationResult> {
        self.validation.as_ref()
    }

    /// Whole days since the calibration was made, by the real-time clock. `None` before the
    /// clock is set or when it reads earlier than the calibration.
    pub fn calibration_age_days(&self) -> Option<i64> {
        let (Calibration::Valid(cal), Some(now)) = (&self.calibration, self.clock_unix_s) else { return None };
        (now >= cal.made_unix_s).then(|| (now - cal.made_unix_s) / 86_400)
    }

    pub fn clock_unix_s(&self) -> Option<i64> {
        self.clock_unix_s
    }
}
