//! The report of `fslcal validate --report DIR`: each photo's known length measured the way
//! a fish is (scale from the laser dot only) against its true length, with the tolerance
//! band, against distance, so a direction error that grows with range shows as a slope.
//!
//! The command fills a [`ValidationReport`] from its own result and calls [`write`]; the
//! fields follow `fslcal validate --json` (`photos`: file, measured_mm, true_mm, error_pct,
//! pass).

use super::plot::{colour, Chart, Layer, Marker};
use super::thumbnail::Overlay;
use super::{add_plot, file_name, thumbnail_cells, Cell, Page, ReportError, ReportFiles, Verdict};
use crate::calibration::outcome::ValidationSkip;
use crate::reason::Reason;
use fslcal_core::Vec2;
use std::path::{Path, PathBuf};

/// One photo's line.
#[derive(Clone, Debug, Default)]
pub struct ValidationPhoto {
    pub file: String,
    /// Distance of the dot, metres (`None` when skipped).
    pub distance_m: Option<f64>,
    pub measured_mm: Option<f64>,
    pub true_mm: Option<f64>,
    pub error_pct: Option<f64>,
    pub pass: Option<bool>,
    /// Why the photo was not measured.
    pub reason: Option<Reason<ValidationSkip>>,
    /// The measured length's end points and the dot, full-resolution pixels, for the
    /// thumbnail.
    pub ends_px: Option<[Vec2; 2]>,
    pub dot_px: Option<Vec2>,
    /// The detected target's outline, pixels.
    pub target_outline_px: Vec<Vec2>,
}

/// A validation run.
#[derive(Clone, Debug, Default)]
pub struct ValidationReport {
    pub calibration: String,
    pub target: String,
    pub tolerance_pct: f64,
    pub photos: Vec<ValidationPhoto>,
    pub pass: bool,
    /// Slope of the length error against distance, percent per metre, with its own verdict
    /// (`None` when the photos do not span enough distance to tell).
    pub trend_pct_per_m: Option<(f64, bool)>,
}

#[cfg(feature = "vision")]
impl ValidationReport {
    /// The report of `fslcal validate`'s result.
    pub fn of(v: &crate::calibration::validate::Validation, calibration: &Path, target: String) -> Self {
        ValidationReport {
            calibration: calibration.display().to_string(),
            target: format!("{target}, length `{}` ({:.1} mm)", v.length_name, v.true_mm),
            tolerance_pct: v.tolerance_pct,
            photos: v
                .photos
                .iter()
                .map(|p| ValidationPhoto {
                    file: p.file.clone(),
                    distance_m: p.distance_m,
                    measured_mm: p.measured_mm,
                    true_mm: Some(p.true_mm),
                    error_pct: p.error_pct,
                    pass: p.pass,
                    reason: p.reason.clone(),
                    ends_px: p.ends_px,
                    dot_px: p.dot_px.map(|d| Vec2::new(d[0], d[1])),
                    target_outline_px: p.target_outline_px.clone(),
                })
                .collect(),
            pass: v.pass,
            trend_pct_per_m: v.slope_pct_per_m.map(|(b, _)| (b, !v.trend_fails)),
        }
    }
}

fn measured(r: &ValidationReport) -> impl Iterator<Item = &ValidationPhoto> {
    r.photos.iter().filter(|p| p.measured_mm.is_some() && p.true_mm.is_some() && p.distance_m.is_some())
}

fn points(r: &ValidationReport, pass: bool, f: impl Fn(&ValidationPhoto) -> Option<(f64, f64)>) -> Vec<(f64, f64)> {
    measured(r).filter(|p| p.pass.unwrap_or(false) == pass).filter_map(f).collect()
}

fn error_chart(r: &ValidationReport) -> Chart {
    let mut c = Chart::new("Length error per photo against distance", "distance (m)", "measured - true (%)");
    let xs: Vec<f64> = measured(r).filter_map(|p| p.distance_m).collect();
    let lo = xs.iter().copied().fold(f64::INFINITY, f64::min).min(0.5);
    let hi = xs.iter().copied().fold(f64::NEG_INFINITY, f64::max).max(lo + 1.0);
    let t = r.tolerance_pct;
    c.layers.push(Layer::Band {
        name: format!("tolerance ±{t}%"),
        x: vec![lo, hi],
        lower: vec![-t, -t],
        upper: vec![t, t],
        colour: colour::BAND,
    });
    c.layers.push(Layer::Line {
        name: String::new(),
        points: vec![(lo, 0.0), (hi, 0.0)],
        colour: colour::GREY,
        dashed: true,
    });
    let err = |p: &ValidationPhoto| Some((p.distance_m?, p.error_pct?));
    c.layers.push(Layer::Points {
        name: "pass".into(),
        points: points(r, true, err),
        colour: colour::USED,
        marker: Marker::Circle,
    });
    let fail = points(r, false, err);
    if !fail.is_empty() {
        c.layers.push(Layer::Points {
            name: "fail".into(),
            points: fail,
            colour: colour::OUTLIER,
            marker: Marker::Cross,
        });
    }
    if let Some((slope, _)) = r.trend_pct_per_m {
        let n = xs.len().max(1) as f64;
        let (mx, my) = (xs.iter().sum::<f64>() / n, measured(r).filter_map(|p| p.error_pct).sum::<f64>() / n);
        c.layers.push(Layer::Line {
            name: format!("trend {slope:+.2} %/m"),
            points: vec![(lo, my + slope * (lo - mx)), (hi, my + slope * (hi - mx))],
            colour: colour::FIT,
            dashed: false,
        });
    }
    c.x_range = Some((lo * 0.9, hi * 1.05));
    c
}

fn measured_vs_true_chart(r: &ValidationReport) -> Chart {
    let mut c = Chart::new("Measured against true length", "true length (mm)", "measured (mm)");
    let truths: Vec<f64> = measured(r).filter_map(|p| p.true_mm).collect();
    let lo = truths.iter().copied().fold(f64::INFINITY, f64::min) * 0.9;
    let hi = truths.iter().copied().fold(f64::NEG_INFINITY, f64::max) * 1.1;
    let (lo, hi) = if lo.is_finite() && hi > lo { (lo, hi) } else { (0.0, 1.0) };
    let t = r.tolerance_pct / 100.0;
    c.layers.push(Layer::Band {
        name: format!("tolerance ±{}%", r.tolerance_pct),
        x: vec![lo, hi],
        lower: vec![lo * (1.0 - t), hi * (1.0 - t)],
        upper: vec![lo * (1.0 + t), hi * (1.0 + t)],
        colour: colour::BAND,
    });
    c.layers.push(Layer::Line {
        name: "measured = true".into(),
        points: vec![(lo, lo), (hi, hi)],
        colour: colour::GREY,
        dashed: true,
    });
    let mt = |p: &ValidationPhoto| Some((p.true_mm?, p.measured_mm?));
    c.layers.push(Layer::Points {
        name: "pass".into(),
        points: points(r, true, mt),
        colour: colour::USED,
        marker: Marker::Circle,
    });
    let fail = points(r, false, mt);
    if !fail.is_empty() {
        c.layers.push(Layer::Points {
            name: "fail".into(),
            points: fail,
            colour: colour::OUTLIER,
            marker: Marker::Cross,
        });
    }
    c.x_range = Some((lo, hi));
    c
}

/// Writes the report into `dir`; returns the path of its `index.html`.
pub fn write(dir: &Path, r: &ValidationReport) -> Result<PathBuf, ReportError> {
    let mut page = Page::new("fslcal validate: length check report");
    let mut files = ReportFiles::default();
    let n = measured(r).count();
    page.paragraph(&format!(
        "{} photos ({n} measured, {} skipped); calibration {}; target {}; tolerance ±{}%.",
        r.photos.len(),
        r.photos.len() - n,
        r.calibration,
        r.target,
        r.tolerance_pct
    ));
    verdict_and_figures(&mut page, r);
    page.heading("Measured against true");
    for (name, chart, caption) in [
        ("validate-error.svg", error_chart(r), "Each photo's length error against its distance, with the tolerance band. Errors that climb or fall with distance mean a laser direction error, which a check at one distance misses."),
        ("validate-measured.svg", measured_vs_true_chart(r), "Measured against true length; the band is the tolerance."),
    ] {
        add_plot(&mut page, &mut files, name, &chart, caption)?;
    }
    photo_section(&mut page, &mut files, r);
    files.write(dir, &page)
}

/// The verdict, with the trend's, and the length error's mean, RMS and worst.
fn verdict_and_figures(page: &mut Page, r: &ValidationReport) {
    let n = measured(r).count();
    let passed = measured(r).filter(|p| p.pass == Some(true)).count();
    let trend = match r.trend_pct_per_m {
        Some((s, true)) => format!("; length error trend {s:+.2} %/m"),
        Some((s, false)) => format!("; length error trend {s:+.2} %/m FAILS: the laser direction is off"),
        None => String::new(),
    };
    if n == 0 {
        page.verdict(Verdict::Rejected, "NOT JUDGED: no photo could be measured; each photo's reason is below.");
        return;
    }
    let verdict = if r.pass { Verdict::Accepted } else { Verdict::Rejected };
    page.verdict(
        verdict,
        &format!(
            "{}: {passed} of {n} photos within ±{}%{trend}.",
            if r.pass { "PASS" } else { "FAIL" },
            r.tolerance_pct
        ),
    );
    let errors: Vec<f64> = measured(r).filter_map(|p| p.error_pct).collect();
    if errors.is_empty() {
        return;
    }
    let k = errors.len() as f64;
    let mean = errors.iter().sum::<f64>() / k;
    let rms = (errors.iter().map(|e| e * e).sum::<f64>() / k).sqrt();
    let worst = errors.iter().copied().fold(0.0f64, |a, e| if e.abs() > a.abs() { e } else { a });
    page.table(
        &["figure", "value"],
        &[false, false],
        vec![
            vec!["length error, mean".into(), format!("{mean:+.2}%").into()],
            vec!["length error, RMS".into(), format!("{rms:.2}%").into()],
            vec!["worst".into(), format!("{worst:+.2}%").into()],
            vec!["within tolerance".into(), format!("{passed} of {n}").into()],
        ],
    );
}

fn photo_section(page: &mut Page, files: &mut ReportFiles, r: &ValidationReport) {
    page.heading("Photos");
    page.note(
        "Drawn on each photo: the detected target (yellow), the measured length (green) and the laser dot (red ring).",
    );
    let overlays: Vec<(&str, Overlay)> = r
        .photos
        .iter()
        .map(|p| {
            let mut o = Overlay { dot_px: p.dot_px, ..Overlay::default() };
            if !p.target_outline_px.is_empty() {
                o.outlines_px.push(p.target_outline_px.clone());
            }
            o.measured_px.extend(p.ends_px);
            (p.file.as_str(), o)
        })
        .collect();
    let mut rows = Vec::new();
    for (p, image) in r.photos.iter().zip(thumbnail_cells(files, &overlays)) {
        let status = match (&p.reason, p.pass) {
            (Some(why), _) => Cell::Bad(format!("skipped: {why}")),
            (None, Some(true)) => Cell::Good("pass".into()),
            (None, _) => Cell::Bad("FAIL".into()),
        };
        let f = |v: Option<f64>, d: usize| v.map_or("-".to_string(), |v| format!("{v:.d$}"));
        rows.push(vec![
            image,
            file_name(&p.file).into(),
            status,
            f(p.distance_m, 3).into(),
            f(p.measured_mm, 1).into(),
            f(p.true_mm, 1).into(),
            p.error_pct.map_or("-".to_string(), |e| format!("{e:+.2}")).into(),
        ]);
    }
    page.table(
        &["photo", "file", "result", "distance (m)", "measured (mm)", "true (mm)", "error (%)"],
        &[false, false, false, true, true, true, true],
        rows,
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    fn photo(file: &str, d: f64, measured: f64, pass: bool) -> ValidationPhoto {
        ValidationPhoto {
            file: file.into(),
            distance_m: Some(d),
            measured_mm: Some(measured),
            true_mm: Some(200.0),
            error_pct: Some((measured - 200.0) / 2.0),
            pass: Some(pass),
            ..ValidationPhoto::default()
        }
    }

    #[test]
    fn a_failing_trend_is_named_and_every_photo_listed() {
        let dir = tempfile::tempdir().unwrap();
        let r = ValidationReport {
            calibration: "laser.json".into(),
            target: "slate:dive.toml".into(),
            tolerance_pct: 3.0,
            photos: vec![
                photo("a.jpg", 0.9, 196.0, true),
                photo("b.jpg", 2.1, 190.0, false),
                ValidationPhoto {
                    file: "c.jpg".into(),
                    reason: Some(ValidationSkip::NoDot.into()),
                    ..ValidationPhoto::default()
                },
            ],
            pass: false,
            trend_pct_per_m: Some((-2.5, false)),
        };
        let index = write(dir.path(), &r).unwrap();
        let html = std::fs::read_to_string(index).unwrap();
        assert!(html.contains("FAIL: 1 of 2 photos within ±3%; length error trend -2.50 %/m FAILS"), "{html}");
        assert!(html.contains("skipped: no laser dot found"));
        assert!(html.contains("<td class=\"num\">-5.00</td>"));
        let svg = std::fs::read_to_string(dir.path().join("plots/validate-error.svg")).unwrap();
        assert!(svg.contains("trend -2.50 %/m") && svg.contains("tolerance ±3%"));
        // Photos that cannot be read still get their row, with the reason.
        assert!(html.contains("no thumbnail: a.jpg: cannot read the photo"));
    }
}
