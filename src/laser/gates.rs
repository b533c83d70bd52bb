//! The gates a careful lab applies to a laser fit before trusting it: enough photos, a
//! span along the laser, a plausible baseline, every used dot on the line, few outliers.

use super::fit::LaserFit;
use super::pipeline::LaserJob;

pub use super::outcome::{Gate, GateResult};

pub fn gate(job: &LaserJob, fit: &LaserFit, outliers: (usize, usize)) -> Vec<GateResult> {
    let g = &job.gates;
    let baseline = fit.laser.baseline_m();
    let worst_used =
        fit.photos.iter().flatten().filter(|p| p.outlier.is_none()).map(|p| p.residual_px).fold(0.0, f64::max);
    vec![
        GateResult {
            name: Gate::PhotosUsed,
            figure: format!("{}", fit.used),
            limit: format!(">= {}", g.min_photos),
            pass: fit.used >= g.min_photos,
        },
        GateResult {
            name: Gate::DotSpan,
            figure: format!("{:.2} m", fit.span_m),
            limit: format!(">= {:.2} m", g.min_span_m),
            pass: fit.span_m >= g.min_span_m,
        },
        GateResult {
            name: Gate::Baseline,
            figure: format!("{:.1} mm", baseline * 1e3),
            limit: format!("{:.1}-{:.1} mm", g.baseline_range_m.0 * 1e3, g.baseline_range_m.1 * 1e3),
            pass: (g.baseline_range_m.0..=g.baseline_range_m.1).contains(&baseline),
        },
        GateResult {
            name: Gate::WorstDotOffset,
            figure: format!("{worst_used:.2} px"),
            limit: format!("<= {:.1} px", g.max_dot_offset_px),
            pass: worst_used <= g.max_dot_offset_px,
        },
        GateResult {
            name: Gate::OutlierPhotos,
            figure: format!("{} of {}", outliers.0, outliers.1),
            limit: "<= 1/3".to_string(),
            pass: outliers.0 * 3 <= outliers.1,
        },
    ]
}
