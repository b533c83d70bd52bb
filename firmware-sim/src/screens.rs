//! The screens of a 128x64 monochrome display, drawn from the firmware state onto any
//! embedded-graphics `DrawTarget` (the real panel, the simulator, a test's MockDisplay).
//!
//! Layout: an inverted title bar of 11 rows, then five text lines of the 6x10 font (21
//! characters each), or a large 10x20 figure with three lines below it. The fonts are
//! ISO 8859-7 so that `±`, `σ` and `°` exist.

use crate::firmware::{Calibration, Firmware, Screen, VALIDATION_TOLERANCE_PCT};
use crate::text;
use crate::text::TextBuf;
use crate::unit_file::{Rejection, UnitCalibration};
use embedded_graphics::mono_font::iso_8859_7::{FONT_10X20, FONT_6X10};
use embedded_graphics::mono_font::{MonoTextStyle, MonoTextStyleBuilder};
use embedded_graphics::pixelcolor::BinaryColor;
use embedded_graphics::prelude::*;
use embedded_graphics::primitives::{PrimitiveStyle, Rectangle};
use embedded_graphics::text::{Alignment, Baseline, Text, TextStyleBuilder};

pub const WIDTH: u32 = 128;
pub const HEIGHT: u32 = 64;
/// Rows of the title bar.
pub const TITLE_ROWS: u32 = 11;
/// Top rows of the five body lines under the title bar.
const BODY_TOP: [i32; 5] = [13, 23, 33, 43, 53];
/// Top rows of the three lines under a large figure.
const UNDER_LARGE_TOP: [i32; 3] = [34, 44, 54];

/// A screen's text, before drawing: testable without pixels.
type Line = TextBuf<24>;

/// Draws the firmware's current screen, clearing the display first.
pub fn draw<D: DrawTarget<Color = BinaryColor>>(fw: &Firmware, d: &mut D) -> Result<(), D::Error> {
    d.clear(BinaryColor::Off)?;
    let cal = match fw.calibration() {
        Calibration::None => {
            title(d, "NO CALIBRATION", "")?;
            return body(d, &["load this unit's", "signed .fslcal file", "", "do not measure"].map(line));
        }
        Calibration::Invalid(why) => return invalid(d, fw.config().unit, why),
        Calibration::Valid(cal) => cal,
    };
    match fw.screen() {
        Screen::Live => live(d, fw, cal),
        Screen::Validation => validation(d, fw),
        Screen::DriftWarning => drift_warning(d, fw),
        Screen::SelfCheck | Screen::NoCalibration | Screen::Invalid => self_check(d, fw, cal),
    }
}

fn line(s: &str) -> Line {
    text!(24, "{s}")
}

fn small(color: BinaryColor) -> MonoTextStyle<'static, BinaryColor> {
    MonoTextStyle::new(&FONT_6X10, color)
}

/// The inverted title bar, with `left` at the left and `right` right-aligned.
fn title<D: DrawTarget<Color = BinaryColor>>(d: &mut D, left: &str, right: &str) -> Result<(), D::Error> {
    Rectangle::new(Point::zero(), Size::new(WIDTH, TITLE_ROWS))
        .into_styled(PrimitiveStyle::with_fill(BinaryColor::On))
        .draw(d)?;
    let style = small(BinaryColor::Off);
    Text::with_baseline(left, Point::new(1, 1), style, Baseline::Top).draw(d)?;
    let right_style = TextStyleBuilder::new().alignment(Alignment::Right).baseline(Baseline::Top).build();
    Text::with_text_style(right, Point::new(WIDTH as i32 - 1, 1), style, right_style).draw(d)?;
    Ok(())
}

fn lines_at<D: DrawTarget<Color = BinaryColor>>(d: &mut D, tops: &[i32], lines: &[Line]) -> Result<(), D::Error> {
    for (top, l) in tops.iter().zip(lines) {
        Text::with_baseline(l.as_str(), Point::new(1, *top), small(BinaryColor::On), Baseline::Top).draw(d)?;
    }
    Ok(())
}

fn body<D: DrawTarget<Color = BinaryColor>>(d: &mut D, lines: &[Line]) -> Result<(), D::Error> {
    lines_at(d, &BODY_TOP, lines)
}

fn large<D: DrawTarget<Color = BinaryColor>>(d: &mut D, s: &str) -> Result<(), D::Error> {
    let style = MonoTextStyleBuilder::new().font(&FONT_10X20).text_color(BinaryColor::On).build();
    Text::with_baseline(s, Point::new(1, TITLE_ROWS as i32 + 2), style, Baseline::Top).draw(d)?;
    Ok(())
}

/// The reason lines of the "calibration invalid" screen: a short headline, two lines of
/// detail, all within 21 characters.
pub fn rejection_lines(own_unit: &str, why: &Rejection) -> [Line; 3] {
    match why {
        Rejection::Tampered => [line("TAMPERED"), line("signature does not"), line("match the contents")],
        Rejection::Damaged(what) => {
            let [a, b] = wrap2(what);
            [line("DAMAGED FILE"), a, b]
        }
        Rejection::UnknownSigner(id) => [line("UNKNOWN SIGNER"), text!(24, "key {id}"), line("is not trusted here")],
        Rejection::OtherUnit { file_unit } => {
            [line("OTHER UNIT"), text!(24, "file is for {}", file_unit.as_str()), text!(24, "this unit is {own_unit}")]
        }
        Rejection::NewerFormat { found, supported } => {
            [line("NEWER FORMAT"), text!(24, "file v{found}, reads v{supported}"), line("update the firmware")]
        }
        Rejection::Truncated { found, expected } => {
            [line("TRUNCATED"), text!(24, "{found} of {expected} bytes"), line("copy the file again")]
        }
        Rejection::NotACalibration => [line("NOT A CALIBRATION"), line("not an .fslcal file"), line("")],
    }
}

/// Splits `s` at a space into two lines of at most 21 characters (the rest is clipped: the
/// CLI's `fslcal verify` gives the whole reason).
fn wrap2(s: &str) -> [Line; 2] {
    const COLS: usize = 21;
    if s.chars().count() <= COLS {
        return [line(s), line("")];
    }
    let cut = s.char_indices().take(COLS + 1).filter(|&(_, c)| c == ' ').map(|(i, _)| i).last().unwrap_or(COLS);
    let rest = s[cut..].trim_start();
    let rest_end = rest.char_indices().nth(COLS).map_or(rest.len(), |(i, _)| i);
    [line(&s[..cut]), line(&rest[..rest_end])]
}

fn invalid<D: DrawTarget<Color = BinaryColor>>(d: &mut D, own_unit: &str, why: &Rejection) -> Result<(), D::Error> {
    title(d, "CALIBRATION INVALID", "")?;
    let [a, b, c] = rejection_lines(own_unit, why);
    body(d, &[a, b, c, line(""), line("do not measure")])
}

/// Year, month, day of a count of days since 1970-01-01 (proleptic Gregorian calendar).
pub fn civil_date(days: i64) -> (i64, u32, u32) {
    // Howard Hinnant's days-to-civil: 400-year eras starting in March.
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let month = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    (yoe + era * 400 + i64::from(month <= 2), month, day)
}

pub fn self_check_lines(fw: &Firmware, cal: &UnitCalibration) -> [Line; 5] {
    let (y, m, day) = civil_date(cal.made_unix_s.div_euclid(86_400));
    let age = match fw.calibration_age_days() {
        Some(days) => text!(24, "{days} d"),
        None if fw.clock_unix_s().is_none() => line("clock?"),
        None => line("future?"),
    };
    let l = &cal.laser;
    [
        text!(24, "unit   {}", cal.unit.as_str()),
        text!(24, "cal {y:04}-{m:02}-{day:02} {}", age.as_str()),
        text!(24, "signer {}", cal.signer),
        text!(24, "laser {:.0}mm {:.2}°", 1e3 * l.baseline_m(), l.angle_to_optical_axis().to_degrees()),
        text!(24, "file v{} {} B", cal.format_version, cal.file_len),
    ]
}

fn self_check<D: DrawTarget<Color = BinaryColor>>(
    d: &mut D,
    fw: &Firmware,
    cal: &UnitCalibration,
) -> Result<(), D::Error> {
    title(d, "SELF-CHECK", "OK")?;
    body(d, &self_check_lines(fw, cal))
}

/// The large figure and the lines under it on the live screen.
pub fn live_lines(fw: &Firmware, cal: &UnitCalibration) -> (Line, [Line; 3]) {
    let Some(r) = fw.reading() else {
        return (line("-.--- m"), [line("waiting for a dot"), line(""), line("")]);
    };
    let px = text!(24, "dot {:.1},{:.1}", r.dot_px[0], r.dot_px[1]);
    let Some(f) = r.fix else {
        let why = if cal.camera.contains(fslcal_core::Vec2::new(r.dot_px[0], r.dot_px[1])) {
            "no fix: off the beam"
        } else {
            "dot outside image"
        };
        return (line("-.--- m"), [line(why), px, line("")]);
    };
    if !f.explained {
        // A dot the calibration cannot explain gives no distance: a reflection, a glint, or
        // a moved laser (the drift monitor counts these).
        return (line("-.--- m"), [line("off the line: no dist."), px, text!(24, "off line {:.1} px", f.miss_px)]);
    }
    let sigma = match f.sigma_m {
        Some(s) => text!(24, "±{:.0} mm (1σ)", 1e3 * s),
        // Unknown (an imported calibration records no covariance), never ±0.
        None => line("± unknown (1σ)"),
    };
    let on_line = text!(24, "off line {:.1} px", f.miss_px);
    (text!(24, "{:.3} m", f.distance_m), [sigma, px, on_line])
}

fn live<D: DrawTarget<Color = BinaryColor>>(d: &mut D, fw: &Firmware, cal: &UnitCalibration) -> Result<(), D::Error> {
    let flag = if fw.drift().warning() { "DRIFT?" } else { "" };
    let right = text!(24, "{flag} #{}", fw.dots_seen());
    title(d, text!(24, "{} LIVE", cal.unit.as_str()).as_str(), right.as_str().trim_start())?;
    let (big, lines) = live_lines(fw, cal);
    large(d, big.as_str())?;
    lines_at(d, &UNDER_LARGE_TOP, &lines)
}

pub fn validation_lines(fw: &Firmware) -> (Line, Line, [Line; 3]) {
    let Some(v) = fw.validation() else {
        return (line(""), line("no result"), [line("validate with a"), line("slate length"), line("")]);
    };
    (
        line(if v.pass { "PASS" } else { "FAIL" }),
        text!(24, "{:+.1} %", v.error_pct),
        [
            text!(24, "measured {:.1} mm", v.measured_mm),
            text!(24, "true     {:.1} mm", v.true_mm),
            text!(24, "tolerance ±{VALIDATION_TOLERANCE_PCT:.0} %"),
        ],
    )
}

fn validation<D: DrawTarget<Color = BinaryColor>>(d: &mut D, fw: &Firmware) -> Result<(), D::Error> {
    let (verdict, big, lines) = validation_lines(fw);
    title(d, "VALIDATION", verdict.as_str())?;
    large(d, big.as_str())?;
    lines_at(d, &UNDER_LARGE_TOP, &lines)
}

pub fn drift_lines(fw: &Firmware) -> [Line; 5] {
    let (off, of) = fw.drift().off_line();
    [
        text!(24, "{off} of last {of} dots"),
        text!(24, "off the laser line"),
        text!(24, "median {:.1} px off", fw.drift().median_miss_px().unwrap_or(f64::NAN)),
        line("laser moved? recal."),
        line("OK ack   NEXT live"),
    ]
}

fn drift_warning<D: DrawTarget<Color = BinaryColor>>(d: &mut D, fw: &Firmware) -> Result<(), D::Error> {
    title(d, "LASER DRIFT?", "!")?;
    body(d, &drift_lines(fw))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn civil_dates_of_known_days() {
        assert_eq!(civil_date(0), (1970, 1, 1));
        // The format's worked example, 2026-06-01 09:30 UTC.
        assert_eq!(civil_date(1_780_306_200 / 86_400), (2026, 6, 1));
        assert_eq!(civil_date(11_016), (2000, 2, 29));
        assert_eq!(civil_date(-1), (1969, 12, 31));
    }

    #[test]
    fn long_reasons_wrap_at_a_space_within_the_display() {
        let [a, b] = wrap2("the payload runs into the signature");
        assert_eq!((a.as_str(), b.as_str()), ("the payload runs into", "the signature"));
        for l in rejection_lines("FSL-03", &Rejection::Damaged("bytes between the payload and the signature")) {
            assert!(l.as_str().chars().count() <= 21, "{l:?}");
        }
    }
}
