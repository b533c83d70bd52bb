//! The report of `fslcal camera --report DIR`: the intrinsics with their 1-sigma, residual
//! vectors over the image, per-photo RMS bars, the frame's coverage by the boards, and every
//! photo with its detected corners (those left out of the solve in red).

use super::plot::{colour, Chart, Layer};
use super::thumbnail::Overlay;
use super::{add_plot, file_name, thumbnail_cells, Cell, Page, ReportError, ReportFiles, Verdict};
use crate::camera::calibrate::{CameraCalibration, CameraPhotoStatus, CornerResiduals};
use crate::camera::residuals::FRAME_CORNER_SHARE;
use calib_targets::Checkerboard;
use fslcal_core::Vec2;
use std::path::{Path, PathBuf};

/// Everything the camera report shows.
pub struct CameraReport<'a> {
    pub board: &'a Checkerboard,
    pub calibration: &'a CameraCalibration,
}

fn used(cal: &CameraCalibration) -> impl Iterator<Item = (usize, &CornerResiduals)> {
    cal.photos
        .iter()
        .enumerate()
        .filter(|(_, p)| p.status == CameraPhotoStatus::Used)
        .filter_map(|(i, p)| Some((i, p.corners.as_ref()?)))
}

/// The four outermost corners of a row-major grid `cols` wide, in order around it.
fn grid_outline(corners: &[Vec2], cols: usize) -> Vec<Vec2> {
    let n = corners.len();
    if cols == 0 || n < cols {
        return Vec::new();
    }
    vec![corners[0], corners[cols - 1], corners[n - 1], corners[n - cols]]
}

/// Residual vectors drawn from each corner, magnified so the 95th-percentile residual is
/// 2% of the image width: they are fractions of a pixel.
fn residual_chart(cal: &CameraCalibration) -> Chart {
    let (w, h) = (cal.camera.width_px as f64, cal.camera.height_px as f64);
    let mut lengths: Vec<f64> = used(cal)
        .flat_map(|(_, c)| c.residuals_px.iter().zip(&c.inlier).filter(|(_, k)| **k).map(|(r, _)| r.norm()))
        .filter(|l| l.is_finite())
        .collect();
    lengths.sort_by(f64::total_cmp);
    let p95 = lengths.get(lengths.len() * 95 / 100).copied().unwrap_or(1.0).max(1e-3);
    let gain = (0.02 * w / p95).round().max(1.0);
    let segments = |inlier: bool| -> Vec<((f64, f64), (f64, f64))> {
        used(cal)
            .flat_map(|(_, c)| {
                c.corners_px.iter().zip(&c.residuals_px).zip(&c.inlier).filter(move |(_, k)| **k == inlier).map(
                    move |((p, r), _)| {
                        let e = p + r * gain;
                        ((p.x, p.y), (e.x, e.y))
                    },
                )
            })
            .filter(|(_, e)| e.0.is_finite() && e.1.is_finite())
            .collect()
    };
    let mut c = Chart::new(&format!("Corner residuals over the image, magnified {gain:.0}x"), "u (px)", "v (px)");
    c.y_down = true;
    c.size_px = (520, 400);
    c.x_range = Some((-0.5, w - 0.5));
    c.y_range = Some((-0.5, h - 0.5));
    c.layers.push(Layer::Arrows { name: "in the solve".into(), segments: segments(true), colour: colour::USED });
    let out = segments(false);
    if !out.is_empty() {
        c.layers.push(Layer::Arrows { name: "outlier corner".into(), segments: out, colour: colour::OUTLIER });
    }
    c
}

fn rms_chart(cal: &CameraCalibration) -> Chart {
    let mut c = Chart::new("RMS per photo (per point)", "photo number", "RMS (px)");
    let bars = |status: CameraPhotoStatus| -> Vec<(f64, f64)> {
        cal.photos
            .iter()
            .enumerate()
            .filter(|(_, p)| p.status == status)
            .filter_map(|(i, p)| Some((i as f64, p.rms_px?)))
            .collect()
    };
    c.layers.push(Layer::Bars {
        name: "used".into(),
        bars: bars(CameraPhotoStatus::Used),
        width: 0.7,
        colour: colour::USED,
    });
    let rejected = bars(CameraPhotoStatus::Rejected);
    if !rejected.is_empty() {
        c.layers.push(Layer::Bars {
            name: "rejected photo".into(),
            bars: rejected,
            width: 0.7,
            colour: colour::OUTLIER,
        });
    }
    c.layers.push(Layer::HLine { name: format!("overall {:.3} px", cal.rms_px), y: cal.rms_px, colour: colour::GREY });
    c.x_range = Some((-0.8, cal.photos.len() as f64 - 0.2));
    c
}

fn coverage_chart(cal: &CameraCalibration, board: &Checkerboard) -> Chart {
    let (w, h) = (cal.camera.width_px as f64, cal.camera.height_px as f64);
    let mut c = Chart::new(
        &format!("Coverage: the boards span {:.0}% of the frame", 100.0 * cal.coverage.share),
        "u (px)",
        "v (px)",
    );
    c.y_down = true;
    c.size_px = (520, 400);
    c.x_range = Some((-0.5, w - 0.5));
    c.y_range = Some((-0.5, h - 0.5));
    let cols = board.inner_cols as usize;
    for (k, (_, corners)) in used(cal).enumerate() {
        let mut outline: Vec<(f64, f64)> = grid_outline(&corners.corners_px, cols).iter().map(|p| (p.x, p.y)).collect();
        let Some(&first) = outline.first() else { continue };
        outline.push(first);
        let name = if k == 0 { "board (used photo)".to_string() } else { String::new() };
        c.layers.push(Layer::Line { name, points: outline, colour: colour::USED, dashed: false });
    }
    // The frame-corner zones the coverage check looks in.
    let (zw, zh) = (FRAME_CORNER_SHARE * w, FRAME_CORNER_SHARE * h);
    for (k, (x, y, dx, dy)) in
        [(0.0, 0.0, zw, zh), (w, 0.0, -zw, zh), (0.0, h, zw, -zh), (w, h, -zw, -zh)].into_iter().enumerate()
    {
        let name = if k == 0 { "frame-corner zones".to_string() } else { String::new() };
        c.layers.push(Layer::Line {
            name,
            points: vec![(x + dx, y), (x + dx, y + dy), (x, y + dy)],
            colour: colour::LIMIT,
            dashed: true,
        });
    }
    c
}

/// Writes the report into `dir`; returns the path of its `index.html`.
pub fn write(dir: &Path, report: &CameraReport) -> Result<PathBuf, ReportError> {
    let cal = report.calibration;
    let cam = &cal.camera;
    let mut page = Page::new("fslcal camera: calibration report");
    let mut files = ReportFiles::default();
    let no_board = cal.photos.iter().filter(|p| p.status == CameraPhotoStatus::NoBoard).count();
    page.paragraph(&format!(
        "{} photos ({} used, {} rejected, {no_board} without the board); board {}; image {}x{} px.",
        cal.photos.len(),
        cal.used_photos(),
        cal.photo_outliers.0,
        report.board,
        cam.width_px,
        cam.height_px
    ));
    verdict(&mut page, cal);
    key_figures(&mut page, cal);
    page.heading("Residuals and coverage");
    let charts = [
        ("camera-residuals.svg", residual_chart(cal), "Each corner's residual (observed minus projected), magnified. Good: short, random directions everywhere. A swirl or arrows growing towards the edges is distortion the model did not capture; one photo's arrows all pointing one way is a bad pose or a bent board."),
        ("camera-rms.svg", rms_chart(cal), "RMS per photo. One photo far above the rest is misdetected or blurred; it is rejected when it stands out by the rules in the summary."),
        ("camera-coverage.svg", coverage_chart(cal, report.board), "The used boards' corner grids over the frame, and the frame-corner zones that must each hold a detected corner."),
    ];
    for (name, chart, caption) in charts {
        add_plot(&mut page, &mut files, name, &chart, caption)?;
    }
    photo_section(&mut page, &mut files, report);
    page.heading("How to read this");
    page.note("See docs/how-to-calibrate.md in the fslcal repository.");
    files.write(dir, &page)
}

fn verdict(page: &mut Page, cal: &CameraCalibration) {
    if cal.coverage.uncovered_frame_corners.is_empty() {
        page.verdict(
            Verdict::Accepted,
            &format!("Solved; the boards cover every corner of the frame ({:.0}% of it).", 100.0 * cal.coverage.share),
        );
    } else {
        page.verdict(
            Verdict::Warning,
            &format!(
                "Solved, but no board corner reached the frame's {} corner(s): the distortion there is extrapolated. Add photos with the board in those corners.",
                cal.coverage.uncovered_frame_corners.join(", ")
            ),
        );
    }
}

fn key_figures(page: &mut Page, cal: &CameraCalibration) {
    let (cam, s) = (&cal.camera, &cal.sigma);
    let d = cam.distortion;
    page.heading("Key figures");
    let worst = file_name(&cal.photos[cal.worst_photo].file);
    let rows: Vec<Vec<Cell>> = vec![
        vec!["RMS per point".into(), format!("{:.3} px over {} corners", cal.rms_px, cal.points).into()],
        vec!["worst corner".into(), format!("{:.2} px in {worst}", cal.worst_px).into()],
        vec![
            "outlier corners".into(),
            format!(
                "{} of {} (beyond {} robust sigmas of their photo)",
                cal.corner_outliers.0, cal.corner_outliers.1, cal.k_corner
            )
            .into(),
        ],
        vec!["outlier photos".into(), format!("{} of {}", cal.photo_outliers.0, cal.photo_outliers.1).into()],
        vec!["fx, fy".into(), format!("{:.2} ± {:.2} px, {:.2} ± {:.2} px", cam.fx_px, s[0], cam.fy_px, s[1]).into()],
        vec!["cx, cy".into(), format!("{:.2} ± {:.2} px, {:.2} ± {:.2} px", cam.cx_px, s[2], cam.cy_px, s[3]).into()],
        vec![
            "k1, k2, k3".into(),
            format!("{:+.5} ± {:.5}, {:+.5} ± {:.5}, {:+.5} ± {:.5}", d.k1, s[4], d.k2, s[5], d.k3, s[8]).into(),
        ],
        vec!["p1, p2".into(), format!("{:+.6} ± {:.6}, {:+.6} ± {:.6}", d.p1, s[6], d.p2, s[7]).into()],
        vec!["coverage".into(), format!("{:.0}% of the frame inside a used board", 100.0 * cal.coverage.share).into()],
    ];
    page.table(&["figure", "value"], &[false, false], rows);
    page.note("± is 1-sigma from the fit's covariance with the noise estimated per residual coordinate; OpenCV 4.6's own stdDeviationsIntrinsics are about 1.41x larger.");
}

fn photo_section(page: &mut Page, files: &mut ReportFiles, report: &CameraReport) {
    let (cal, board) = (report.calibration, report.board);
    page.heading("Photos");
    page.note("Drawn on each photo: the detected inner-corner grid (yellow) and corners (orange); corners left out of the solve in red.");
    let overlays: Vec<(&str, Overlay)> = cal
        .photos
        .iter()
        .map(|p| {
            let mut o = Overlay::default();
            if let Some(c) = &p.corners {
                o.outlines_px.push(grid_outline(&c.corners_px, board.inner_cols as usize));
                o.marks_px = c.corners_px.clone();
                o.bad_marks_px =
                    c.corners_px.iter().zip(&c.inlier).filter(|(_, k)| !**k).map(|(p, _)| *p).collect::<Vec<Vec2>>();
            }
            (p.file.as_str(), o)
        })
        .collect();
    let mut rows = Vec::new();
    for (p, image) in cal.photos.iter().zip(thumbnail_cells(files, &overlays)) {
        let status = match p.status {
            CameraPhotoStatus::Used => Cell::Good(p.status.to_string()),
            CameraPhotoStatus::Rejected => Cell::Bad(p.status.explained().into()),
            CameraPhotoStatus::NoBoard => {
                Cell::Bad(format!("skipped: no {}x{} checkerboard found", board.inner_cols, board.inner_rows))
            }
        };
        let corners = match (p.corners_used, p.corners_found) {
            (Some(u), Some(f)) => format!("{u}/{f}"),
            _ => "-".into(),
        };
        rows.push(vec![
            image,
            file_name(&p.file).into(),
            status,
            corners.into(),
            p.rms_px.map_or("-".into(), |r| format!("{r:.3}")).into(),
            p.worst_px.map_or("-".into(), |r| format!("{r:.2}")).into(),
        ]);
    }
    page.table(
        &["photo", "file", "status", "corners used", "RMS (px)", "worst (px)"],
        &[false, false, false, true, true, true],
        rows,
    );
}
