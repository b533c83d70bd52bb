//! UTC timestamps as whole seconds since 1970, printed and read as ISO 8601 in the forms
//! fslcal and the FishSense lab write.
//!
//! The calendar and the parsing are `jiff`'s: the lab's API carries `created_at` with a zone,
//! and its older metadata carries naive local times that must be placed in an IANA zone or
//! at an offset before they mean an instant; `jiff` has both (its `Pieces` tell a naive
//! time from a zoned one, `TimeZone::get` reads the system's tzdb), where the hand-written
//! civil-date arithmetic this module used to hold had neither. A copy of the tz database is
//! built in (`tzdb-bundle-always`) and used only where the system has none, so a zone name
//! means the same on a handheld without tzdata as on a laptop.

use jiff::civil::Time;
use jiff::fmt::temporal::Pieces;
use jiff::Timestamp;

/// Seconds since 1970-01-01 UTC, now.
pub fn now_s() -> i64 {
    Timestamp::now().as_second()
}

/// `t_s` printed with `pattern` (strftime), or, for an instant outside years -9999..=9999
/// (only a corrupt or hostile file holds one), the bare count of seconds, so that printing
/// never fails.
fn format_with(t_s: i64, pattern: &str) -> String {
    match Timestamp::from_second(t_s) {
        Ok(t) => t.strftime(pattern).to_string(),
        Err(_) => format!("{t_s}s-since-1970"),
    }
}

/// `2026-06-01T09:30:00Z`.
pub fn format_iso(t_s: i64) -> String {
    format_with(t_s, "%Y-%m-%dT%H:%M:%SZ")
}

/// `2026-06-01 09:30:00+00:00`: what Python's `str(datetime.now(timezone.utc))` prints, the
/// form the FishSense lab's `metadata.json` carries.
pub fn format_python(t_s: i64) -> String {
    format_with(t_s, "%Y-%m-%d %H:%M:%S+00:00")
}

/// `20260601T093000Z`: sorts by time and is safe in file names.
pub fn format_compact(t_s: i64) -> String {
    format_with(t_s, "%Y%m%dT%H%M%SZ")
}

/// Reads `YYYY-MM-DD`, optionally followed by `T` or a space and `HH:MM[:SS[.frac]]`, and
/// a zone `Z`, `±HH:MM` or an IANA name in brackets (`[Pacific/Guam]`). Fractions of a
/// second are dropped. A time with no zone at all is read as UTC.
pub fn parse_iso(text: &str) -> Option<i64> {
    let pieces = Pieces::parse(text.trim()).ok()?;
    let civil = pieces.date().to_datetime(pieces.time().unwrap_or(Time::midnight()));
    let instant = match (pieces.to_numeric_offset(), pieces.to_time_zone().ok()?) {
        (Some(offset), _) => offset.to_timestamp(civil).ok()?,
        (None, Some(zone)) => zone.to_timestamp(civil).ok()?,
        (None, None) => jiff::tz::Offset::UTC.to_timestamp(civil).ok()?,
    };
    Some(instant.as_second())
}

/// Why a time from another tool's file cannot be placed in time.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum PlaceTimeError {
    #[error("`{0}` is not a date and time fslcal reads (ISO 8601, e.g. 2025-02-10T18:32:05+00:00)")]
    Unreadable(String),
    #[error("`{0}` has no time zone (a local time, as the lab's 2023 tools wrote it): say where it was written with --timezone, e.g. --timezone America/Los_Angeles or --timezone -08:00")]
    Naive(String),
}

/// Reads a time as [`parse_iso`] does, except that a time without a zone is placed in
/// `zone` and refused without one, where `parse_iso` would take it for UTC.
pub fn parse_iso_in(text: &str, zone: Option<&jiff::tz::TimeZone>) -> Result<i64, PlaceTimeError> {
    let unreadable = || PlaceTimeError::Unreadable(text.trim().to_string());
    let pieces = Pieces::parse(text.trim()).map_err(|_| unreadable())?;
    let zoned = pieces.to_numeric_offset().is_some() || pieces.to_time_zone().map_err(|_| unreadable())?.is_some();
    match (zoned, zone) {
        (true, _) => parse_iso(text).ok_or_else(unreadable),
        (false, Some(zone)) => {
            let civil = pieces.date().to_datetime(pieces.time().unwrap_or(Time::midnight()));
            zone.to_timestamp(civil).map(|t| t.as_second()).map_err(|_| unreadable())
        }
        (false, None) => Err(PlaceTimeError::Naive(text.trim().to_string())),
    }
}

/// `--timezone`: an IANA zone (`America/Los_Angeles`) or a fixed offset (`-08:00`, `+0530`,
/// `Z`, `UTC`).
pub fn parse_zone(text: &str) -> Result<jiff::tz::TimeZone, String> {
    let t = text.trim();
    if t.eq_ignore_ascii_case("utc") || t.eq_ignore_ascii_case("z") {
        return Ok(jiff::tz::TimeZone::UTC);
    }
    if t.starts_with(['+', '-']) {
        let digits: String = t[1..].chars().filter(|c| *c != ':').collect();
        let (h, m) = match digits.len() {
            2 => (digits.parse::<i32>().ok(), Some(0)),
            4 => (digits[..2].parse::<i32>().ok(), digits[2..].parse::<i32>().ok()),
            _ => (None, None),
        };
        // Earth's offsets run from -12:00 to +14:00.
        let (Some(h @ 0..=14), Some(m @ 0..=59)) = (h, m) else {
            return Err(format!("`{t}` is not an offset like -08:00"));
        };
        let seconds = (h * 3600 + m * 60) * if t.starts_with('-') { -1 } else { 1 };
        return jiff::tz::Offset::from_seconds(seconds)
            .map(jiff::tz::TimeZone::fixed)
            .map_err(|_| format!("`{t}` is not an offset like -08:00"));
    }
    jiff::tz::TimeZone::get(t).map_err(|_| {
        format!(
            "`{t}` is not a time zone fslcal knows (an IANA name like America/Los_Angeles, or an offset like -08:00)"
        )
    })
}

/// `2026-06-01T09:30:00+00:00`: ISO 8601 with its zone spelled as Python's `isoformat()`
/// writes it, which every Python's `datetime.fromisoformat` reads (the lab's API bodies).
pub fn format_iso_offset(t_s: i64) -> String {
    format_with(t_s, "%Y-%m-%dT%H:%M:%S+00:00")
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
        // Before 1970, and beyond what a calendar prints.
        assert_eq!(format_iso(-1), "1969-12-31T23:59:59Z");
        assert_eq!(format_iso(i64::MAX), format!("{}s-since-1970", i64::MAX));
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

    #[test]
    fn reads_offsets_in_every_iso_spelling_and_named_zones() {
        for text in [
            "2026-06-01T11:30:00+0200",
            "2026-06-01T11:30+02",
            "2026-06-01T02:30:00-07:00",
            "20260601T093000Z",
            "2026-06-01T09:30:00z",
            // Guam has no daylight saving: UTC+10 all year.
            "2026-06-01T19:30:00[Pacific/Guam]",
            // An offset and a zone name: the offset is what the writer meant.
            "2026-06-01T11:30:00+02:00[Europe/Paris]",
        ] {
            assert_eq!(parse_iso(text), Some(1_780_306_200), "{text}");
        }
        assert_eq!(parse_iso("2026-06-01T09:30:00[Not/AZone]"), None);
    }

    #[test]
    fn a_naive_time_needs_a_zone_and_a_zoned_one_keeps_its_own() {
        // The lab's 2023 metadata: `str(datetime.now())` in San Diego in June (UTC-7).
        let naive = "2026-06-01 02:30:00.123456";
        assert!(matches!(parse_iso_in(naive, None), Err(PlaceTimeError::Naive(_))));
        let la = parse_zone("America/Los_Angeles").unwrap();
        assert_eq!(parse_iso_in(naive, Some(&la)), Ok(1_780_306_200));
        assert_eq!(parse_iso_in(naive, Some(&parse_zone("-07:00").unwrap())), Ok(1_780_306_200));
        assert_eq!(parse_iso_in(naive, Some(&parse_zone("-0700").unwrap())), Ok(1_780_306_200));
        // A time that says its zone is not moved by --timezone.
        assert_eq!(parse_iso_in("2026-06-01 09:30:00+00:00", Some(&la)), Ok(1_780_306_200));
        assert!(matches!(parse_iso_in("soon", Some(&la)), Err(PlaceTimeError::Unreadable(_))));
        assert!(parse_zone("Mars/Olympus").is_err() && parse_zone("+25").is_err());
        assert_eq!(format_iso_offset(1_780_306_200), "2026-06-01T09:30:00+00:00");
        assert_eq!(parse_iso(&format_iso_offset(1_780_306_200)), Some(1_780_306_200));
    }

    #[test]
    fn zone_names_work_without_a_system_tz_database() {
        // What `TimeZone::get` falls back to on a handheld with no /usr/share/zoneinfo:
        // the copy built in (jiff's `tzdb-bundle-always`).
        let bundled = jiff::tz::TimeZoneDatabase::bundled();
        let guam = bundled.get("Pacific/Guam").expect("the bundled tz database has Pacific/Guam");
        let t = guam.to_timestamp(jiff::civil::date(2026, 6, 1).at(19, 30, 0, 0)).unwrap();
        assert_eq!(t.as_second(), 1_780_306_200);
    }
}
