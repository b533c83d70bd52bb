//! The simulator's dive scripts: one command per line, `#` starts a comment.
//!
//! ```text
//! clock 2026-11-25T08:00:00Z   set the real-time clock (UTC, or seconds since 1970)
//! load FILE                    a calibration file arrives (path relative to the script)
//! press next | press ok        a button
//! dot U V                      the camera saw the laser dot at pixel (U, V)
//! validate MEASURED_MM TRUE_MM a slate-length validation result
//! ```
//!
//! Parsed without std so the firmware could take the same commands over a serial console.

use crate::firmware::Button;
use core::fmt;

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Command<'a> {
    Clock { unix_s: i64 },
    Load { path: &'a str },
    Press(Button),
    Dot { u_px: f64, v_px: f64 },
    Validate { measured_mm: f64, true_mm: f64 },
}

impl Command<'_> {
    /// A short name for the screen this command leads to (file names of the simulator's PNGs).
    pub fn label(&self) -> &'static str {
        match self {
            Command::Clock { .. } => "clock",
            Command::Load { .. } => "load",
            Command::Press(Button::Next) => "press-next",
            Command::Press(Button::Ok) => "press-ok",
            Command::Dot { .. } => "dot",
            Command::Validate { .. } => "validate",
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ScriptError {
    UnknownCommand,
    /// Wrong number of arguments; the usage of the command.
    Usage(&'static str),
    BadNumber,
    BadTime,
}

impl fmt::Display for ScriptError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ScriptError::UnknownCommand => f.write_str("unknown command (clock, load, press, dot, validate)"),
            ScriptError::Usage(u) => write!(f, "usage: {u}"),
            ScriptError::BadNumber => f.write_str("not a finite number"),
            ScriptError::BadTime => f.write_str("not a time (YYYY-MM-DDTHH:MM:SSZ or seconds since 1970)"),
        }
    }
}

/// One line of a script: `Ok(None)` for blank lines and comments.
pub fn parse_line(line: &str) -> Result<Option<Command<'_>>, ScriptError> {
    let line = line.split('#').next().unwrap_or("").trim();
    let mut words = line.split_whitespace();
    let Some(cmd) = words.next() else { return Ok(None) };
    let mut args = [""; 3];
    let mut n = 0;
    for w in words {
        if n == args.len() {
            n += 1;
            break;
        }
        args[n] = w;
        n += 1;
    }
    let args = &args[..n.min(3)];
    let number = |s: &str| s.parse::<f64>().ok().filter(|v| v.is_finite()).ok_or(ScriptError::BadNumber);
    let command = match (cmd, args, n) {
        ("clock", [t], 1) => Command::Clock { unix_s: parse_time(t).ok_or(ScriptError::BadTime)? },
        ("clock", _, _) => return Err(ScriptError::Usage("clock 2026-11-25T08:00:00Z")),
        ("load", [p], 1) => Command::Load { path: p },
        ("load", _, _) => return Err(ScriptError::Usage("load FILE")),
        ("press", ["next"], 1) => Command::Press(Button::Next),
        ("press", ["ok"], 1) => Command::Press(Button::Ok),
        ("press", _, _) => return Err(ScriptError::Usage("press next|ok")),
        ("dot", [u, v], 2) => Command::Dot { u_px: number(u)?, v_px: number(v)? },
        ("dot", _, _) => return Err(ScriptError::Usage("dot U_PX V_PX")),
        ("validate", [m, t], 2) => Command::Validate { measured_mm: number(m)?, true_mm: number(t)? },
        ("validate", _, _) => return Err(ScriptError::Usage("validate MEASURED_MM TRUE_MM")),
        _ => return Err(ScriptError::UnknownCommand),
    };
    Ok(Some(command))
}

/// `YYYY-MM-DDTHH:MM:SSZ` (UTC) or plain seconds since 1970.
pub fn parse_time(s: &str) -> Option<i64> {
    if let Ok(secs) = s.parse::<i64>() {
        return Some(secs);
    }
    let b = s.as_bytes();
    if b.len() != 20 || b[4] != b'-' || b[7] != b'-' || b[10] != b'T' || b[13] != b':' || b[16] != b':' || b[19] != b'Z'
    {
        return None;
    }
    let num = |r: core::ops::Range<usize>| s.get(r)?.parse::<i64>().ok();
    let (y, mo, d) = (num(0..4)?, num(5..7)?, num(8..10)?);
    let (h, mi, sec) = (num(11..13)?, num(14..16)?, num(17..19)?);
    if !(1..=12).contains(&mo) || !(1..=31).contains(&d) || h > 23 || mi > 59 || sec > 60 {
        return None;
    }
    Some(days_from_civil(y, mo, d) * 86_400 + h * 3600 + mi * 60 + sec)
}

/// Days since 1970-01-01 of a proleptic Gregorian date (inverse of `screens::civil_date`).
fn days_from_civil(y: i64, m: i64, d: i64) -> i64 {
    let y = if m <= 2 { y - 1 } else { y };
    let era = y.div_euclid(400);
    let yoe = y.rem_euclid(400);
    let mp = (m + 9) % 12;
    let doy = (153 * mp + 2) / 5 + d - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    era * 146_097 + doe - 719_468
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::screens::civil_date;

    #[test]
    fn parses_every_command_and_refuses_bad_lines() {
        assert_eq!(parse_line("  # just a comment"), Ok(None));
        assert_eq!(parse_line("dot 2004.5 1700.25 # near"), Ok(Some(Command::Dot { u_px: 2004.5, v_px: 1700.25 })));
        assert_eq!(parse_line("press ok"), Ok(Some(Command::Press(Button::Ok))));
        assert_eq!(parse_line("load a.fslcal"), Ok(Some(Command::Load { path: "a.fslcal" })));
        assert_eq!(parse_line("validate 405 400"), Ok(Some(Command::Validate { measured_mm: 405.0, true_mm: 400.0 })));
        assert_eq!(parse_line("clock 2026-06-01T09:30:00Z"), Ok(Some(Command::Clock { unix_s: 1_780_306_200 })));
        assert_eq!(parse_line("dot 1 2 3"), Err(ScriptError::Usage("dot U_PX V_PX")));
        assert_eq!(parse_line("dot 1 nan"), Err(ScriptError::BadNumber));
        assert_eq!(parse_line("press hard"), Err(ScriptError::Usage("press next|ok")));
        assert_eq!(parse_line("clock yesterday"), Err(ScriptError::BadTime));
        assert_eq!(parse_line("swim"), Err(ScriptError::UnknownCommand));
    }

    #[test]
    fn time_parsing_inverts_the_screen_date() {
        for days in [-1000, 0, 11_016, 20_605, 60_000] {
            let (y, m, d) = civil_date(days);
            assert_eq!(days_from_civil(y, m as i64, d as i64), days);
        }
    }
}
