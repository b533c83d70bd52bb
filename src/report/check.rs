//! The report of `fslcal check --report DIR`: each photo's dot offset from the calibrated
//! laser line's image against the flag threshold, in photo order (a mount that moved during
//! a dive shows as a step or a climb), with thumbnails showing the dot and the line.
//!
//! The command fills a [`CheckReport`] from its own result and calls [`write`]; the fields
//! follow `fslcal check --json` (`photos`: file, dot_px, offset_px, flag; `drifted`,
//! `implied_direction_change_deg`).

use super::plot::{colour, Chart, Layer, Marker};
use super::thumbnail::{self, Overlay};
use super::{add_plot, file_name, thumbnail_cells, Cell, Page, ReportError, ReportFiles, Verdict};
use crate::calibration::outcome::{CandidateCheck, CheckSkip};
use crate::reason::Reason;
use fslcal_core::{CameraModel, LaserLine, Vec2};
use std::path::{Path, PathBuf};

/// One photo's line.
#[derive(Clone, Debug, Default)]
pub struct CheckPhoto {
    pub file: String,
    pub dot_px: Option<Vec2>,
    /// Perpendicular offset of the dot from the line's image, pixels.
    pub offset_px: Option<f64>,
    /// The offset beyond which this photo is flagged (it depends on the dot's distance and
    /// localisation), pixels.
    pub threshold_px: Option<f64>,
    pub flag: bool,
    /// Why the photo could not be checked.
    pub reason: Option<Reason<CheckSkip>>,
    /// Share of the plausible candidates' likelihood the dot carries (0-1).
    pub confidence: Option<f64>,
    /// Every dot-like blob in the band, as `fslcal check --json` lists them.
    pub candidates: Vec<CandidateCheck>,
}

impl CheckPhoto {
    /// Whether candidate `c` is the blob the search took for this photo's dot.
    fn is_the_dot(&self, c: &CandidateCheck) -> bool {
        self.dot_px.is_some_and(|d| (d - Vec2::new(c.pixel[0], c.pixel[1])).norm() < 1e-6)
    }
}

/// A drift-check run.
#[derive(Clone, Debug)]
pub struct CheckReport {
    pub calibration: String,
    pub camera: CameraModel,
    pub laser: LaserLine,
    /// A photo is flagged beyond this many sigmas of what the calibration and the dot's
    /// localisation explain.
    pub flag_sigmas: f64,
    pub photos: Vec<CheckPhoto>,
    pub drifted: bool,
    pub implied_direction_change_deg: Option<f64>,
    /// The calibration's covariance is known (an imported one records none: the threshold
    /// then counts the dot's localisation only, which the page says).
    pub covariance_known: bool,
}

fn offset_chart(r: &CheckReport) -> Chart {
    let mut c =
        Chart::new("Dot offset from the calibrated line, per photo", "photo (in the order given)", "offset (px)");
    let pick = |flag: bool| -> Vec<(f64, f64)> {
        r.photos
            .iter()
            .enumerate()
            .filter(|(_, p)| p.flag == flag)
            .filter_map(|(i, p)| Some((i as f64, p.offset_px?)))
            .collect()
    };
    let thresholds: Vec<(f64, f64)> =
        r.photos.iter().enumerate().filter_map(|(i, p)| Some((i as f64, p.threshold_px?))).collect();
    let top = thresholds.iter().map(|p| p.1).fold(1.0f64, f64::max);
    c.layers.push(Layer::Points {
        name: format!("flag threshold ({} sigma)", r.flag_sigmas),
        points: thresholds,
        colour: colour::LIMIT,
        marker: Marker::Cross,
    });
    c.layers.push(Layer::Points {
        name: "within".into(),
        points: pick(false),
        colour: colour::USED,
        marker: Marker::Circle,
    });
    let flagged = pick(true);
    let top = flagged.iter().map(|p| p.1).fold(top, f64::max);
    if !flagged.is_empty() {
        c.layers.push(Layer::Points {
            name: "flagged".into(),
            points: flagged,
            colour: colour::OUTLIER,
            marker: Marker::Cross,
        });
    }
    c.x_range = Some((-0.5, r.photos.len().max(1) as f64 - 0.5));
    c.y_range = Some((0.0, top * 1.2));
    c
}

#[cfg(feature = "vision")]
impl CheckReport {
    /// The report of `fslcal check`'s result.
    pub fn of(r: &crate::calibration::drift::DriftCheck, cal: &crate::calibration::Calibration) -> Self {
        CheckReport {
            calibration: cal.source.display().to_string(),
            camera: cal.camera,
            laser: cal.laser,
            flag_sigmas: crate::calibration::drift::FLAG_SIGMAS,
            photos: r
                .photos
                .iter()
                .map(|p| CheckPhoto {
                    file: p.file.clone(),
                    dot_px: p.dot_px.map(|d| Vec2::new(d[0], d[1])),
                    offset_px: p.offset_px,
                    threshold_px: p.explained_sigma_px.map(|s| s * crate::calibration::drift::FLAG_SIGMAS),
                    flag: p.flag,
                    reason: p.reason.clone(),
                    confidence: p.confidence,
                    candidates: p.candidates.clone(),
                })
                .collect(),
            drifted: r.drifted,
            implied_direction_change_deg: r.implied_direction_change_deg,
            covariance_known: fslcal_core::covariance_known(&cal.laser_covariance),
        }
    }
}

/// Writes the report into `dir`; returns the path of its `index.html`.
pub fn write(dir: &Path, r: &CheckReport) -> Result<PathBuf, ReportError> {
    let mut page = Page::new("fslcal check: laser drift report");
    let mut files = ReportFiles::default();
    let checked = r.photos.iter().filter(|p| p.offset_px.is_some()).count();
    let flagged = r.photos.iter().filter(|p| p.flag).count();
    page.paragraph(&format!(
        "{} photos ({checked} checked, {} without a usable dot); calibration {}.",
        r.photos.len(),
        r.photos.len() - checked,
        r.calibration
    ));
    if !r.covariance_known {
        page.note("The calibration's covariance is unknown (an imported calibration records none): each photo's flag threshold counts the dot's localisation only, not the calibration's uncertainty.");
    }
    let implied =
        r.implied_direction_change_deg.map_or(String::new(), |d| format!("; implied change of direction {d:.3} deg"));
    if checked == 0 {
        page.verdict(
            Verdict::Rejected,
            "NOT JUDGED: no photo has a dot the calibration can judge; each photo's reason is below.",
        );
    } else if r.drifted {
        page.verdict(Verdict::Rejected, &format!("DRIFTED: {flagged} of {checked} dots off the calibrated line{implied}. Recalibrate the laser before measuring these photos."));
    } else {
        page.verdict(Verdict::Accepted, &format!("No drift: {flagged} of {checked} dots flagged{implied}."));
    }
    page.heading("Offsets");
    add_plot(
        &mut page,
        &mut files,
        "check-offsets.svg",
        &offset_chart(r),
        "How far each photo's dot lies from the image of the calibrated laser line. A rigid laser keeps them all under the threshold; a step or a climb through the dive means the mount moved.",
    )?;
    page.heading("Photos");
    page.note("Drawn on each photo: the calibrated laser line's image (magenta), the dot found (red ring) and the other dot-like blobs near the line (small marks).");
    let line = thumbnail::laser_image_px(&r.camera, &r.laser);
    let overlays: Vec<(&str, Overlay)> = r
        .photos
        .iter()
        .map(|p| {
            let others =
                p.candidates.iter().filter(|c| !p.is_the_dot(c)).map(|c| Vec2::new(c.pixel[0], c.pixel[1])).collect();
            let overlay =
                Overlay { dot_px: p.dot_px, polylines_px: line.clone(), marks_px: others, ..Overlay::default() };
            (p.file.as_str(), overlay)
        })
        .collect();
    let mut rows = Vec::new();
    for (p, image) in r.photos.iter().zip(thumbnail_cells(&mut files, &overlays)) {
        let status = match (&p.reason, p.flag) {
            (Some(why), _) => Cell::Bad(format!("skipped: {why}")),
            (None, true) => Cell::Bad("flagged".into()),
            (None, false) => Cell::Good("within".into()),
        };
        rows.push(vec![
            image,
            file_name(&p.file).into(),
            status,
            p.dot_px.map_or("-".into(), |d| format!("({:.1}, {:.1})", d.x, d.y)).into(),
            p.offset_px.map_or("-".into(), |o| format!("{o:.2}")).into(),
            p.threshold_px.map_or("-".into(), |o| format!("{o:.2}")).into(),
        ]);
    }
    page.table(
        &["photo", "file", "result", "dot (px)", "offset (px)", "flag above (px)"],
        &[false, false, false, true, true, true],
        rows,
    );
    candidate_table(&mut page, r);
    files.write(dir, &page)
}

/// Every photo's dot-like blobs near the line and what the search made of each: the one it
/// took and with what confidence, the plausible ones that made a photo ambiguous, and why
/// each other one cannot be the dot.
fn candidate_table(page: &mut Page, r: &CheckReport) {
    page.heading("Candidates");
    page.note("Each dot-like blob near the calibrated line, strongest first. A blob is the dot when it is plausible (on the line within what the calibration explains, of a dot's size, brightness, colour and round outline at the distance its place implies) and carries 90% of the likelihood of the plausible blobs and of none of them being the dot (a lone weak or doubtful blob is withheld); blobs refused only for their colour or outline count against it (a scene that makes dot-like things there makes the survivor less certain).");
    let mut rows = Vec::new();
    for p in &r.photos {
        for c in &p.candidates {
            let verdict = match (p.is_the_dot(c), c.refused) {
                (true, _) => Cell::Good(format!("the dot (confidence {:.2})", p.confidence.unwrap_or(1.0))),
                (false, Some(why)) => Cell::Text(why.describe().into()),
                (false, None) if p.dot_px.is_some() => Cell::Text("plausible, weaker".into()),
                (false, None) => Cell::Bad("plausible: none clearly the dot".into()),
            };
            rows.push(vec![
                file_name(&p.file).into(),
                crate::dot::on_line::pixel_words(c.pixel).into(),
                format!("{:.2}", c.distance_m).into(),
                format!("{:.1} / {:.1}", c.offset_px, c.sigma_px).into(),
                format!("{:.0}", c.snr).into(),
                format!(
                    "{:.0} +- {:.0}",
                    c.colour_angle_deg,
                    c.colour_angle_sigma_deg.hypot(c.colour_texture_sigma_deg).max(0.5)
                )
                .into(),
                format!("{:.0}", c.white_deficit_deg).into(),
                c.outline_roughness.map_or("-".into(), |o| format!("{o:.3}")).into(),
                verdict,
            ]);
        }
    }
    if rows.is_empty() {
        page.paragraph("No dot-like blob near the calibrated line in any photo.");
        return;
    }
    page.table(
        &[
            "file",
            "blob (px)",
            "distance (m)",
            "offset / sigma (px)",
            "SNR",
            "colour angle (deg)",
            "white part short (deg)",
            "outline roughness",
            "verdict",
        ],
        &[false, true, true, true, true, true, true, true, false],
        rows,
    );
}

#[cfg(test)]
mod tests {
    use super::*;
    use fslcal_core::{Distortion, Vec3};

    #[test]
    fn drift_is_the_verdict_and_the_flagged_photo_stands_out() {
        let camera = CameraModel {
            width_px: 400,
            height_px: 300,
            fx_px: 300.0,
            fy_px: 300.0,
            cx_px: 199.5,
            cy_px: 149.5,
            distortion: Distortion::from_opencv([0.0; 5]),
        };
        let laser = LaserLine::from_point_direction(Vec3::new(-0.04, -0.1, 0.0), Vec3::new(0.01, 0.02, 1.0)).unwrap();
        // A real photo file, so the thumbnail is drawn with the line on it.
        let dir = tempfile::tempdir().unwrap();
        let photo = dir.path().join("fish.png");
        image::RgbImage::new(400, 300).save(&photo).unwrap();
        let on_line = laser.pixel_at_depth(&camera, 2.0).unwrap();
        let r = CheckReport {
            calibration: "laser.json".into(),
            camera,
            laser,
            flag_sigmas: 5.0,
            photos: vec![
                CheckPhoto {
                    file: photo.display().to_string(),
                    dot_px: Some(on_line),
                    offset_px: Some(0.4),
                    threshold_px: Some(3.0),
                    flag: false,
                    reason: None,
                    confidence: Some(0.95),
                    candidates: vec![
                        CandidateCheck {
                            pixel: [on_line.x, on_line.y],
                            snr: 80.0,
                            distance_m: 2.0,
                            offset_px: 0.4,
                            sigma_px: 0.6,
                            ..CandidateCheck::default()
                        },
                        CandidateCheck {
                            pixel: [on_line.x + 40.0, on_line.y - 30.0],
                            snr: 120.0,
                            distance_m: 1.4,
                            outline_roughness: Some(0.23),
                            refused: Some(crate::dot::on_line::Refusal::Ragged),
                            ..CandidateCheck::default()
                        },
                    ],
                },
                CheckPhoto {
                    file: photo.display().to_string(),
                    dot_px: Some(on_line + Vec2::new(12.0, 0.0)),
                    offset_px: Some(11.0),
                    threshold_px: Some(2.5),
                    flag: true,
                    reason: None,
                    confidence: Some(1.0),
                    candidates: Vec::new(),
                },
            ],
            drifted: true,
            implied_direction_change_deg: Some(0.21),
            covariance_known: true,
        };
        let out = dir.path().join("report");
        let html = std::fs::read_to_string(write(&out, &r).unwrap()).unwrap();
        assert!(
            html.contains("DRIFTED: 1 of 2 dots off the calibrated line; implied change of direction 0.210 deg"),
            "{html}"
        );
        assert!(html.contains("<td class=\"bad\">flagged</td>"));
        let svg = std::fs::read_to_string(out.join("plots/check-offsets.svg")).unwrap();
        assert!(svg.contains("flag threshold (5 sigma)"));
        assert!(html.contains("<td class=\"num\">2.50</td>"), "each photo's own threshold");
        // Each blob near the line with the search's verdict on it.
        assert!(html.contains("the dot (confidence 0.95)"), "{html}");
        assert!(html.contains("ragged outline"), "{html}");
        assert!(html.contains("<td class=\"num\">0.230</td>"), "its roughness: {html}");
        // The thumbnail shows the line through the on-line dot's pixel (scale 320/400).
        let thumb = image::open(out.join("thumbs/00-fish.jpg")).unwrap().to_rgb8();
        let (u, v) = ((0.8 * (on_line.x + 0.5) - 0.5).round() as u32, (0.8 * (on_line.y + 0.5) - 0.5).round() as u32);
        let p = thumb.get_pixel(u, v).0;
        assert!(p[0] > 150 && p[1] < 100 && p[2] > 150, "magenta line at the dot's pixel: {p:?}");
        assert!(!html.contains("covariance is unknown"));
        // An imported calibration's unknown covariance is said, not taken as zero.
        let unknown = CheckReport { covariance_known: false, ..r };
        let html = std::fs::read_to_string(write(&out, &unknown).unwrap()).unwrap();
        assert!(html.contains("covariance is unknown"), "{html}");
    }
}
