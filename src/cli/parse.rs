//! Option values checked when the command line is parsed (clap `value_parser`s), so that a
//! wrong value is refused at once with its true cause, not after a long fit or as a
//! misleading failure later. A refused value is echoed as typed; a number fslcal prints
//! back is printed readably ([`show_number`]), never as a 309-digit decimal.

/// `x` as people read it: a plain decimal in a sane range, scientific notation otherwise.
pub fn show_number(x: f64) -> String {
    if x == 0.0 || (1e-4..1e7).contains(&x.abs()) {
        let s = format!("{x:.6}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else if x.is_finite() {
        format!("{x:.3e}")
    } else {
        x.to_string()
    }
}

/// A number typed for an option named `what`, refused with the reason when it is not one.
fn number(s: &str, what: &str) -> Result<f64, String> {
    let x: f64 = s.trim().parse().map_err(|_| format!("`{s}` is not a number ({what})"))?;
    if !x.is_finite() {
        return Err(format!("`{s}` is not a finite number ({what})"));
    }
    Ok(x)
}

/// A distance in pixels that must be above zero (`--max-dot-offset-px`, `--dot-sigma-px`).
pub fn positive_px(s: &str) -> Result<f64, String> {
    let x = number(s, "pixels")?;
    if x <= 0.0 {
        return Err(format!("`{s}`: expected a number of pixels above 0"));
    }
    if x > 10_000.0 {
        return Err(format!("`{s}`: {} px is larger than any photo; expected pixels, e.g. 4", show_number(x)));
    }
    Ok(x)
}

/// A tolerance in percent, above 0 and below 100 (`validate --tolerance`).
#[cfg_attr(not(feature = "vision"), allow(dead_code))]
pub fn percentage(s: &str) -> Result<f64, String> {
    let x = number(s, "percent")?;
    if !(x > 0.0 && x < 100.0) {
        return Err(format!("`{s}`: expected a percentage between 0 and 100, e.g. 3"));
    }
    Ok(x)
}

/// Deepest water a calibration can be made in, metres: far beyond any dive, well short of
/// a number nobody meant.
const MAX_WATER_DEPTH_M: f32 = 1000.0;

/// Water depth in metres, 0 at the surface (`--water-depth-m`); it is signed into the unit
/// file, so a sign slip must not be.
pub fn water_depth_m(s: &str) -> Result<f32, String> {
    let x = number(s, "metres of water")?;
    if x < 0.0 {
        return Err(format!("`{s}`: a depth is metres below the surface, 0 or more (e.g. 3.5)"));
    }
    if x > f64::from(MAX_WATER_DEPTH_M) {
        return Err(format!("`{s}`: {} m is deeper than any dive; expected metres, e.g. 3.5", show_number(x)));
    }
    Ok(x as f32)
}

/// Largest image side fslcal takes, pixels: larger than any camera sensor it may meet.
const MAX_IMAGE_SIDE_PX: u32 = 30_000;

/// `WIDTHxHEIGHT` in pixels, each 1..=30000 (the frames of `--camera-frame`, `--dots-frame`,
/// `--lens-frame`, `--lab-frame`).
pub fn image_size(s: &str) -> Result<(u32, u32), String> {
    let usage = "expected WIDTHxHEIGHT in pixels, e.g. 4000x3000";
    let (w, h) = s.split_once(['x', 'X']).ok_or(usage)?;
    let side = |t: &str| -> Result<u32, String> {
        let n: u64 =
            t.trim().parse().map_err(|_| format!("`{s}`: `{}` is not a whole number of pixels; {usage}", t.trim()))?;
        match u32::try_from(n) {
            Ok(n) if (1..=MAX_IMAGE_SIDE_PX).contains(&n) => Ok(n),
            _ => Err(format!("`{s}`: each side must be 1 to {MAX_IMAGE_SIDE_PX} pixels; {usage}")),
        }
    };
    Ok((side(w)?, side(h)?))
}

/// Most photos developed at once: each holds about 100 MB, and more threads than photos or
/// cores only wait.
pub const MAX_JOBS: usize = 64;

/// `--jobs N`, 1..=64.
pub fn jobs(s: &str) -> Result<usize, String> {
    match s.trim().parse::<usize>() {
        Ok(n) if (1..=MAX_JOBS).contains(&n) => Ok(n),
        _ => Err(format!("`{s}`: expected a number of photos at once from 1 to {MAX_JOBS} (about 100 MB each)")),
    }
}

/// `MIN,MAX` in millimetres, 0 < MIN < MAX <= 1000, as metres (`--baseline-range-mm`).
pub fn range_mm(s: &str) -> Result<(f64, f64), String> {
    let (a, b) = s.split_once(',').ok_or("expected MIN,MAX in millimetres, e.g. 78,145")?;
    let (a, b) = (number(a, "millimetres")?, number(b, "millimetres")?);
    if !(a > 0.0 && b > a) {
        return Err("expected 0 < MIN < MAX".into());
    }
    if b > 1000.0 {
        return Err(format!(
            "`{s}`: a camera-to-laser baseline of {} mm is not a rig; expected millimetres, e.g. 78,145",
            show_number(b)
        ));
    }
    Ok((a / 1e3, b / 1e3))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn absurd_numbers_are_printed_readably() {
        assert_eq!(show_number(42.17), "42.17");
        assert_eq!(show_number(0.0), "0");
        assert_eq!(show_number(-5.0), "-5");
        assert_eq!(show_number(1e308), "1.000e308");
        assert_eq!(show_number(f64::MAX), "1.798e308");
        assert_eq!(show_number(1.5e-9), "1.500e-9");
    }

    #[test]
    fn options_are_refused_with_their_true_cause() {
        for bad in ["0", "-1", "NaN", "nan", "inf", "1e308", "four"] {
            assert!(positive_px(bad).is_err(), "{bad}");
        }
        assert_eq!(positive_px("4").unwrap(), 4.0);
        assert!(positive_px("1e308").unwrap_err().contains("1.000e308 px is larger than any photo"));
        assert!(percentage("1e308").unwrap_err().starts_with("`1e308`: expected a percentage"));
        assert_eq!(percentage("3").unwrap(), 3.0);
        assert!(water_depth_m("-5").unwrap_err().contains("0 or more"));
        assert!(water_depth_m("NaN").unwrap_err().contains("not a finite number"));
        assert!(water_depth_m("inf").is_err());
        assert_eq!(water_depth_m("3.5").unwrap(), 3.5);
        assert!(image_size("99999999x99999999").unwrap_err().contains("each side must be 1 to 30000 pixels"));
        assert!(image_size("99999999999999999999x3").unwrap_err().contains("not a whole number of pixels"));
        assert_eq!(image_size("4000x3000").unwrap(), (4000, 3000));
        assert!(image_size("0x3000").is_err());
        assert!(jobs("99999").unwrap_err().contains("from 1 to 64"));
        assert!(jobs("0").is_err());
        assert_eq!(jobs("2").unwrap(), 2);
        assert_eq!(range_mm("78,145").unwrap(), (0.078, 0.145));
        for bad in ["1,inf", "nan,5", "5,1", "78,1e308"] {
            assert!(range_mm(bad).is_err(), "{bad}");
        }
    }
}
