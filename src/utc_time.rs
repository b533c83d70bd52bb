//! UTC timestamps as seconds since 1970, printed and read as ISO 8601 (the proleptic
//! Gregorian calendar by Howard Hinnant's days-from-civil algorithm): enough for calibration
//! dates without a date-time dependency.

use std::time::{SystemTime, UNIX_EPOCH};

/// Seconds since 1970-01-01 UTC, now.
pub fn now_s() -> i64 {
    match SystemTime::now().duration_since(UNIX_EPOCH) {
        Ok(d) => d.as_secs() as i64,
        Err(e) => -(e.duration().as_secs() as i64),
    }
}

fn days_from_civil(y: i64, m: i64, d: i64) -> i64 {
    let y = if m <= 2 { y - 1 } else { y };
    let era = y.div_euclid(400);
    let yoe = y - era * 400;
    let doy = (153 * (m + if m > 2 { -3 } else { 9 }) + 2) / 5 + d - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    era * 146_097 + doe - 719_468
}

fn civil_from_days(z: i64) -> (i64, i64, i64) {
    let z = z + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    (yoe + era * 400 + i64::from(m <= 2), m, d)
}

fn fields(t_s: i64) -> (i64, i64, i64, i64, i64, i64) {
    let (days, secs) = (t_s.div_euclid(86_400), t_s.rem_euclid(86_400));
    let (y, m, d) = civil_from_days(days);
    (y, m, d, secs / 3600, secs / 60 % 60, secs % 60)
}

/// `2026-06-01T09:30:00Z`.
pub fn format_iso(t_s: i64) -> String {
    let (y, mo, d, h, mi, s) = fields(t_s);
    format!("{y:04}-{mo:02}-{d:02}T{h:02}:{mi:02}:{s:02}Z")
}

/// `2026-06-01 09:30:00+00:00`: what Python's `str(datetime.now(timezone.utc))` prints, the
/// form the FishSense lab's `metadata.json` carries.
pub fn format_python(t_s: i64) -> String {
    let (y, mo, d, h, mi, s) = fields(t_s);
    format!("{y:04}-{mo:02}-{d:02} {h:02}:{mi:02}:{s:02}+00:00")
}

/// `20260601T093000Z`: sorts by time and is safe in file names.
pub fn format_compact(t_s: i64) -> String {
    let (y, mo, d, h, mi, s) = fields(t_s);
    format!("{y:04}{mo:02}{d:02}T{h:02}{mi:02}{s:02}Z")
}

/// Reads `YYYY-MM-DD`, optionally followed by `T` or a space and `HH:MM[:SS[.frac]]`, and
/// a zone `Z` or `±HH:MM` (none means UTC). Fractions of a second are dropped.
pub fn parse_iso(text: &str) -> Option<i64> {
    let t = text.trim();
    let num =
        |s: &str| -> Option<i64> { (!s.is_empty() && s.bytes().all(|b| b.is_ascii_digit())).then(|| s.parse().ok())? };
    let date = t.get(..10)?;
    let (y, m, d) = (num(date.get(..4)?)?, num(date.get(5..7)?)?, num(date.get(8..10)?)?);
    if date.as_bytes()[4] != b'-' || date.as_bytes()[7] != b'-' || !(1..=12).contains(&m) || !(1..=31).contains(&d) {
        return None;
    }
    let mut secs = days_from_civil(y, m, d) * 86_400;
    let rest = &t[10..];
    if rest.is_empty() {
        return Some(secs);
    }
    let rest = rest.strip_prefix('T').or_else(|| rest.strip_prefix(' '))?;
    let zone_at = rest.find(['Z', '+', '-']).unwrap_or(rest.len());
    let (clock, zone) = rest.split_at(zone_at);
    let clock = clock.split('.').next()?;
    let mut parts = clock.split(':');
    let (h, mi) = (num(parts.next()?)?, num(parts.next()?)?);
    let s = parts.next().map_or(Some(0), num)?;
    if parts.next().is_some() || h > 23 || mi > 59 || s > 60 {
        return None;
    }
    secs += h * 3600 + mi * 60 + s;
    let offset = match zone {
        "" | "Z" => 0,
        z => {
            let sign = if z.starts_with('-') { -1 } else { 1 };
            let (zh, zm) = z[1..].split_once(':').unwrap_or((z.get(1..3)?, z.get(3..).unwrap_or("0")));
            sign * (num(zh)? * 3600 + num(zm)? * 60)
        }
    };
    Some(secs - offset)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn known_instants() {
        assert_eq!(format_iso(0), "1970-01-01T00:00:00Z");
        assert_eq!(format_iso(1_780_306_200), "2026-06-01T09:30:00Z");
        assert_eq!(format_iso(951_782_400), "2000-02-29T00:00:00Z");
        assert_eq!(format_compact(1_780_306_200), "20260601T093000Z");
        assert_eq!(format_python(1_780_306_200), "2026-06-01 09:30:00+00:00");
    }

    #[test]
    fn reads_what_python_and_iso_write() {
        assert_eq!(parse_iso("2026-06-01T09:30:00Z"), Some(1_780_306_200));
        assert_eq!(parse_iso("2026-06-01 09:30:00.123456+00:00"), Some(1_780_306_200));
        assert_eq!(parse_iso("2026-06-01 11:30:00+02:00"), Some(1_780_306_200));
        assert_eq!(parse_iso("2026-06-01"), Some(1_780_272_000));
        assert_eq!(parse_iso("2000-02-29T00:00"), Some(951_782_400));
        for bad in ["", "2026-13-01", "yesterday", "2026-06-01T25:00:00", "2026-06-01X"] {
            assert_eq!(parse_iso(bad), None, "{bad}");
        }
        for t in [-86_400 * 400, 0, 1_700_000_123, 4_102_444_799] {
            assert_eq!(parse_iso(&format_iso(t)), Some(t));
            assert_eq!(parse_iso(&format_python(t)), Some(t));
        }
    }
}
