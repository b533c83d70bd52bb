//! The report of `fslcal laser --report DIR`: verdict and gates, the dots in 3D with the
//! fitted line from the side and from above, residuals against distance, the predicted
//! distance and length error with the calibration's 1-sigma band, and every photo as a
//! thumbnail with the board, dot and laser line drawn on it, or the reason it was skipped.
//!
//! Written also when gates fail or the fit is refused: that is when people need it.

use super::plot::{colour, Chart, Layer, Marker};
use super::thumbnail::{self, Overlay};
use super::{add_plot, file_name, thumbnail_cells, Cell, Page, ReportError, ReportFiles, Verdict};
use crate::laser::fit::{distance_sigma, FitError};
use crate::laser::gates::GateResult;
use crate::laser::pipeline::{CandidateRole, LaserCalibration, LaserJob, PhotoReport, PhotoStatus};
use fslcal_core::{CameraModel, LaserLine, Vec2, Vec3};
use nalgebra::Matrix4;
use std::path::{Path, PathBuf};

/// What the run produced.
pub enum LaserOutcome<'a> {
    /// A fit, accepted or rejected by its gates.
    Fitted(&'a LaserCalibration),
    /// No fit could be made, for `reason`.
    Refused { reason: &'a FitError, photos: &'a [PhotoReport] },
}

/// Everything the laser report shows.
pub struct LaserReport<'a> {
    pub job: &'a LaserJob,
    /// The camera file as given on the command line (shown, not read).
    pub camera_file: &'a Path,
    pub outcome: LaserOutcome<'a>,
}

/// Figures derived from the fit for the page and the plots.
struct PhotoPoint {
    index: usize,
    point_m: Vec3,
    distance_m: f64,
    residual_px: f64,
    /// Depth the fitted laser reads from this photo's dot, minus the board's depth, metres.
    laser_depth_error_m: Option<f64>,
    outlier: bool,
}

fn photo_points(cal: &LaserCalibration, camera: &CameraModel) -> Vec<PhotoPoint> {
    let laser = &cal.fit.laser;
    cal.fit
        .photos
        .iter()
        .enumerate()
        .filter_map(|(index, p)| {
            let p = p.as_ref()?;
            let dot = Vec2::new(p.dot_px[0], p.dot_px[1]);
            Some(PhotoPoint {
                index,
                point_m: Vec3::from(p.point_m),
                distance_m: p.distance_m,
                residual_px: p.residual_px,
                laser_depth_error_m: laser.fix_from_pixel(camera, dot).map(|f| f.depth_m - p.distance_m),
                outlier: p.outlier.is_some(),
            })
        })
        .collect()
}

/// Depths to draw the line and the band over: the dots' range widened to the working
/// range a diver measures fish in.
fn depth_axis(cal: &LaserCalibration) -> (f64, f64) {
    (cal.fit.depth_range_m.0.clamp(0.1, 0.5), cal.fit.depth_range_m.1.max(5.0))
}

fn samples(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    (0..n).map(|k| lo + (hi - lo) * k as f64 / (n - 1) as f64).collect()
}

/// Side (z, y) or top (z, x) view of the dots and the fitted line, millimetres across.
fn view_chart(cal: &LaserCalibration, points: &[PhotoPoint], axis: usize) -> Chart {
    let (name, across) = if axis == 1 { ("from the side", "y, down (mm)") } else { ("from above", "x, right (mm)") };
    let mut c = Chart::new(&format!("Dots and fitted laser, {name}"), "depth z (m)", across);
    c.y_down = axis == 1;
    let (lo, hi) = depth_axis(cal);
    let line: Vec<(f64, f64)> =
        samples(0.0, hi, 2).into_iter().map(|z| (z, 1e3 * cal.fit.laser.point_at_depth(z)[axis])).collect();
    c.layers.push(Layer::Line { name: "fitted laser".into(), points: line, colour: colour::FIT, dashed: false });
    c.layers.push(Layer::Line {
        name: "optical axis".into(),
        points: vec![(0.0, 0.0), (hi, 0.0)],
        colour: colour::GREY,
        dashed: true,
    });
    let pick = |outlier: bool| -> Vec<(f64, f64)> {
        points.iter().filter(|p| p.outlier == outlier).map(|p| (p.point_m.z, 1e3 * p.point_m[axis])).collect()
    };
    c.layers.push(Layer::Points {
        name: "dot (used)".into(),
        points: pick(false),
        colour: colour::USED,
        marker: Marker::Circle,
    });
    let outliers = pick(true);
    if !outliers.is_empty() {
        c.layers.push(Layer::Points {
            name: "dot (outlier)".into(),
            points: outliers,
            colour: colour::OUTLIER,
            marker: Marker::Cross,
        });
    }
    c.x_range = Some((0.0, hi.max(lo) * 1.02));
    c
}

fn residual_chart(cal: &LaserCalibration, points: &[PhotoPoint], gate_px: f64) -> Chart {
    let mut c = Chart::new("Dot offset from the fitted line, per photo", "distance (m)", "offset (px)");
    let pick = |outlier: bool| -> Vec<(f64, f64)> {
        points.iter().filter(|p| p.outlier == outlier).map(|p| (p.distance_m, p.residual_px)).collect()
    };
    c.layers.push(Layer::HLine { name: format!("gate {gate_px:.1} px"), y: gate_px, colour: colour::LIMIT });
    c.layers.push(Layer::HLine {
        name: format!("RMS {:.2} px", cal.fit.residual_rms_px),
        y: cal.fit.residual_rms_px,
        colour: colour::GREY,
    });
    c.layers.push(Layer::Points {
        name: "used".into(),
        points: pick(false),
        colour: colour::USED,
        marker: Marker::Circle,
    });
    let outliers = pick(true);
    let top = outliers.iter().map(|p| p.1).fold(gate_px, f64::max);
    if !outliers.is_empty() {
        c.layers.push(Layer::Points {
            name: "outlier".into(),
            points: outliers,
            colour: colour::OUTLIER,
            marker: Marker::Cross,
        });
    }
    let (lo, hi) = depth_axis(cal);
    c.x_range = Some((lo * 0.9, hi * 1.02));
    c.y_range = Some((0.0, (top * 1.15).min(50.0 * gate_px)));
    c
}

/// The calibration's predicted 1-sigma distance error over the working range, metres.
fn sigma_curve(camera: &CameraModel, laser: &LaserLine, covariance: &[[f64; 4]; 4], depths: &[f64]) -> Vec<f64> {
    let cov = Matrix4::from(*covariance).transpose();
    depths.iter().map(|&z| distance_sigma(camera, laser, &cov, z).unwrap_or(f64::NAN)).collect()
}

/// Predicted distance error (mm) or, with `relative`, length error (%) against distance.
fn error_chart(cal: &LaserCalibration, camera: &CameraModel, points: &[PhotoPoint], relative: bool) -> Chart {
    let (title, unit) = if relative {
        ("Length error from the distance error", "length error (%)")
    } else {
        ("Distance read from the dot vs the board's", "distance error (mm)")
    };
    let mut c = Chart::new(title, "distance (m)", unit);
    let (lo, hi) = depth_axis(cal);
    let z = samples(lo, hi, 40);
    let sigma = sigma_curve(camera, &cal.fit.laser, &cal.fit.covariance, &z);
    // A length scales with the distance it is measured at (L = D n w / f): its relative
    // error is the distance's.
    let scale = |z: f64| if relative { 100.0 / z } else { 1e3 };
    let upper: Vec<f64> = z.iter().zip(&sigma).map(|(z, s)| s * scale(*z)).collect();
    c.layers.push(Layer::Band {
        name: "calibration 1-sigma".into(),
        x: z.clone(),
        lower: upper.iter().map(|u| -u).collect(),
        upper,
        colour: colour::BAND,
    });
    c.layers.push(Layer::Line {
        name: String::new(),
        points: vec![(lo, 0.0), (hi, 0.0)],
        colour: colour::GREY,
        dashed: true,
    });
    let pick = |outlier: bool| -> Vec<(f64, f64)> {
        points
            .iter()
            .filter(|p| p.outlier == outlier)
            .filter_map(|p| p.laser_depth_error_m.map(|e| (p.distance_m, e * scale(p.distance_m))))
            .collect()
    };
    c.layers.push(Layer::Points {
        name: "photo (used)".into(),
        points: pick(false),
        colour: colour::USED,
        marker: Marker::Circle,
    });
    let outliers = pick(true);
    if !outliers.is_empty() {
        c.layers.push(Layer::Points {
            name: "photo (outlier)".into(),
            points: outliers,
            colour: colour::OUTLIER,
            marker: Marker::Cross,
        });
    }
    c.x_range = Some((lo * 0.9, hi * 1.02));
    c
}

fn overlay(report: &PhotoReport, camera: &CameraModel, laser: Option<&LaserLine>) -> Overlay {
    let mut o = Overlay::default();
    if let Some(b) = &report.board {
        o.outlines_px.push(b.outline_px.clone());
        o.marks_px = b.corners_px.clone();
        o.predicted_px = laser.and_then(|l| camera.project(&l.hit(&b.plane)?));
    }
    o.dot_px = report.dot_px.map(|d| Vec2::new(d[0], d[1]));
    if let Some(l) = laser {
        o.polylines_px = thumbnail::laser_image_px(camera, l);
    }
    o
}

fn mm(v: f64) -> String {
    format!("{:.2} mm", v * 1e3)
}

/// Writes the report into `dir`; returns the path of its `index.html`.
pub fn write(dir: &Path, report: &LaserReport) -> Result<PathBuf, ReportError> {
    let job = report.job;
    let camera = &job.camera;
    let (cal, photos) = match &report.outcome {
        LaserOutcome::Fitted(cal) => (Some(*cal), cal.photos.as_slice()),
        LaserOutcome::Refused { photos, .. } => (None, *photos),
    };
    let mut page = Page::new("fslcal laser: calibration report");
    let mut files = ReportFiles::default();
    let used = photos.iter().filter(|p| p.status == PhotoStatus::Used).count();
    page.paragraph(&format!(
        "{} photos ({used} used, {} skipped); target {}; camera file {}.",
        photos.len(),
        photos.len() - used,
        job.target,
        report.camera_file.display(),
    ));
    verdict(&mut page, &report.outcome);
    if let Some(cal) = cal {
        let points = photo_points(cal, camera);
        key_figures(&mut page, cal, camera, &points, photos);
        gates_table(&mut page, &cal.gates);
        fit_plots(&mut page, &mut files, job, cal, &points)?;
    }
    photo_section(&mut page, &mut files, photos, camera, cal.map(|c| &c.fit.laser));
    candidate_section(&mut page, photos);
    page.heading("How to read this");
    page.note(
        "See docs/how-to-calibrate.md in the fslcal repository: what RMS, worst offset, outliers, span and \
         baseline to expect, and what to do when a calibration is rejected.",
    );
    files.write(dir, &page)
}

fn verdict(page: &mut Page, outcome: &LaserOutcome) {
    match outcome {
        LaserOutcome::Refused { reason, .. } => page.verdict(Verdict::Rejected, &format!("NOT FITTED: {reason}")),
        LaserOutcome::Fitted(cal) if cal.accepted() => page.verdict(Verdict::Accepted, "ACCEPTED: every gate passes."),
        LaserOutcome::Fitted(cal) => {
            let failed: Vec<String> = cal.gates.iter().filter(|g| !g.pass).map(GateResult::failure_text).collect();
            page.verdict(
                Verdict::Rejected,
                &format!("REJECTED: {}. No calibration file was written.", failed.join("; ")),
            );
        }
    }
}

fn gates_table(page: &mut Page, gates: &[GateResult]) {
    page.heading("Gates");
    page.table(
        &["gate", "figure", "limit", "result"],
        &[false, true, false, false],
        gates
            .iter()
            .map(|g| {
                vec![
                    g.name.as_str().into(),
                    g.figure.clone().into(),
                    g.limit.clone().into(),
                    if g.pass { Cell::Good("pass".into()) } else { Cell::Bad("FAIL".into()) },
                ]
            })
            .collect(),
    );
}

fn fit_plots(
    page: &mut Page,
    files: &mut ReportFiles,
    job: &LaserJob,
    cal: &LaserCalibration,
    points: &[PhotoPoint],
) -> Result<(), ReportError> {
    let camera = &job.camera;
    page.heading("The dots and the fitted line");
    page.note(
        "Each dot is where the camera ray through it meets its photo's board. The across-axis scale is \
         stretched: a straight row of dots is the laser; a dot off the row is a reflection, a glint or a moved laser.",
    );
    let charts = [
        ("laser-side.svg", view_chart(cal, points, 1), "Side view: depth against height (y grows down, as in the camera frame)."),
        ("laser-above.svg", view_chart(cal, points, 0), "Top view: depth against the sideways offset."),
        (
            "residuals.svg",
            residual_chart(cal, points, job.gates.max_dot_offset_px),
            "How far each photo's dot lies from where the fitted line meets its board, in pixels. Used dots must stay under the gate; crosses are outliers left out of the fit.",
        ),
        (
            "distance-error.svg",
            error_chart(cal, camera, points, false),
            "The distance the fitted laser reads from each photo's dot, minus the board's distance from its pose. The band is the calibration's own predicted 1-sigma distance error; points spread wider than it by the dot's localisation.",
        ),
        (
            "length-error.svg",
            error_chart(cal, camera, points, true),
            "The same as a fish-length error: a length scales with its distance (L = D n w / f), so its relative error is the distance's.",
        ),
    ];
    for (name, chart, caption) in charts {
        add_plot(page, files, name, &chart, caption)?;
    }
    Ok(())
}

fn key_figures(
    page: &mut Page,
    cal: &LaserCalibration,
    camera: &CameraModel,
    points: &[PhotoPoint],
    photos: &[PhotoReport],
) {
    let f = &cal.fit;
    let l = &f.laser;
    let worst = points
        .iter()
        .filter(|p| !p.outlier)
        .max_by(|a, b| a.residual_px.total_cmp(&b.residual_px))
        .map_or(String::new(), |p| format!(" in {}", file_name(&photos[p.index].file)));
    let errors: Vec<f64> = points.iter().filter(|p| !p.outlier).filter_map(|p| p.laser_depth_error_m).collect();
    let n = errors.len().max(1) as f64;
    let mean = errors.iter().sum::<f64>() / n;
    let rms = (errors.iter().map(|e| e * e).sum::<f64>() / n).sqrt();
    let sig: Vec<String> = f
        .distance_sigma_m
        .iter()
        .map(|(z, s)| format!("{:.1} mm at {z:.0} m ({:.2}%)", s * 1e3, 100.0 * s / z))
        .collect();
    let rows: Vec<Vec<Cell>> = vec![
        vec![
            "dot offset from the line, RMS".into(),
            format!("{:.2} px ({:.2} mm on the board)", f.residual_rms_px, f.residual_rms_mm).into(),
        ],
        vec![
            "worst used dot".into(),
            format!("{:.2} px ({:.2} mm){worst}", f.residual_worst_px, f.residual_worst_mm).into(),
        ],
        vec!["outliers".into(), format!("{} of {}", cal.outliers.0, cal.outliers.1).into()],
        vec![
            "dots' depths; span along the laser".into(),
            format!("{:.2}-{:.2} m; {:.2} m", f.depth_range_m.0, f.depth_range_m.1, f.span_m).into(),
        ],
        vec!["laser origin (camera xy-plane)".into(), f.origin_text().into()],
        vec!["baseline".into(), mm(l.baseline_m()).into()],
        vec!["laser direction".into(), f.direction_text().into()],
        vec!["predicted 1-sigma distance error".into(), sig.join("; ").into()],
        vec![
            "distance read from the dot minus the board's, used photos".into(),
            format!("mean {:+.1} mm, RMS {:.1} mm over {} photos", mean * 1e3, rms * 1e3, errors.len()).into(),
        ],
        vec![
            "camera".into(),
            format!(
                "{}x{} px, fx {:.1} px, fy {:.1} px",
                camera.width_px, camera.height_px, camera.fx_px, camera.fy_px
            )
            .into(),
        ],
    ];
    page.heading("Key figures");
    page.table(&["figure", "value"], &[false, false], rows);
}

/// Every photo's dot candidates and what the consensus over photos made of them: why the
/// chosen one won (on the line most photos agree on) or why none was used.
fn candidate_section(page: &mut Page, photos: &[PhotoReport]) {
    let rows: Vec<Vec<Cell>> = photos
        .iter()
        .flat_map(|p| {
            p.candidates.iter().map(move |c| {
                let role = match c.role {
                    CandidateRole::Chosen => Cell::Good("chosen: on the line most photos agree on".into()),
                    CandidateRole::StrongOffLine => Cell::Bad("off the line but strong: judged by the fit".into()),
                    CandidateRole::Ambiguous => Cell::Bad("ambiguous: another blob as close to the line".into()),
                    CandidateRole::OffLine => Cell::Text("off the line".into()),
                    CandidateRole::Undecided => Cell::Text("no consensus line".into()),
                };
                vec![
                    file_name(&p.file).into(),
                    format!("({:.1}, {:.1})", c.px[0], c.px[1]).into(),
                    format!("{:.0}", c.colour_score).into(),
                    format!("{:.0}", c.colour_angle_deg).into(),
                    format!("{:.1}", c.radius_px).into(),
                    c.saturated_px.to_string().into(),
                    c.line_offset_px.map_or("-".into(), |o| format!("{o:.1}")).into(),
                    role,
                ]
            })
        })
        .collect();
    if rows.is_empty() {
        return;
    }
    page.heading("Dot candidates");
    page.note(
        "Every dot-like blob found on each photo's target. Colour: contrast along the laser's colour over the local \
         background, less its off-colour part, in noise sigmas, and the angle of its chroma from the laser's. The \
         dot is chosen jointly over photos: the candidate on the one 3D line most photos agree on, never the \
         strongest blob of a photo.",
    );
    page.table(
        &[
            "file",
            "blob (px)",
            "colour (sigma)",
            "chroma angle (deg)",
            "radius (px)",
            "clipped px",
            "off line (px)",
            "decision",
        ],
        &[false, true, true, true, true, true, true, false],
        rows,
    );
}

fn photo_section(
    page: &mut Page,
    files: &mut ReportFiles,
    photos: &[PhotoReport],
    camera: &CameraModel,
    laser: Option<&LaserLine>,
) {
    page.heading("Photos");
    page.note(
        "Drawn on each photo: the target's outline from its pose (yellow, padded as the dot search is), a \
         checkerboard's detected corners (orange), the dot used (red ring), the fitted laser line's image (magenta) \
         and where it meets this photo's target (white cross).",
    );
    let overlays: Vec<(&str, Overlay)> = photos.iter().map(|p| (p.file.as_str(), overlay(p, camera, laser))).collect();
    let mut rows = Vec::new();
    for (p, image) in photos.iter().zip(thumbnail_cells(files, &overlays)) {
        let name = file_name(&p.file);
        let status = match (&p.reason, p.dot_source) {
            (Some(r), _) => Cell::Bad(format!("{}: {r}", p.status)),
            (None, Some(src)) => Cell::Good(format!("{} (dot {})", p.status, src.as_str())),
            (None, None) => Cell::Good(p.status.to_string()),
        };
        rows.push(vec![
            image,
            name.into(),
            status,
            p.distance_m.map_or("-".into(), |d| format!("{d:.3}")).into(),
            p.dot_px.map_or("-".into(), |d| format!("({:.1}, {:.1})", d[0], d[1])).into(),
            p.residual_px.map_or("-".into(), |r| format!("{r:.2}")).into(),
            p.board_rms_px.map_or("-".into(), |r| format!("{r:.2}")).into(),
        ]);
    }
    page.table(
        &["photo", "file", "status", "distance (m)", "dot (px)", "offset (px)", "board RMS (px)"],
        &[false, false, false, true, true, true, true],
        rows,
    );
}
