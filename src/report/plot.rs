//! Plots as SVG text, drawn with plotters' SVG backend. Text is emitted as SVG `<text>` in
//! the browser's own sans-serif, so no font is read or embedded at run time.
//!
//! A [`Chart`] is a list of [`Layer`]s on one pair of axes; each command's report builds its
//! charts from its own figures and calls [`Chart::svg`].

use super::ReportError;
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::ops::Range;

/// A chart's drawing context: f64 axes on an SVG backend.
type Plot<'a, 'b> = ChartContext<'a, SVGBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// Colours used across reports, so a "used" dot looks the same in every plot.
pub mod colour {
    use plotters::style::RGBColor;
    pub const USED: RGBColor = RGBColor(31, 119, 180);
    pub const OUTLIER: RGBColor = RGBColor(214, 39, 40);
    pub const FIT: RGBColor = RGBColor(44, 160, 44);
    pub const LIMIT: RGBColor = RGBColor(160, 80, 0);
    pub const BAND: RGBColor = RGBColor(120, 120, 200);
    pub const GREY: RGBColor = RGBColor(110, 110, 110);
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Marker {
    Circle,
    Cross,
}

/// What a chart shows; every layer with a name gets a legend entry.
pub enum Layer {
    Points {
        name: String,
        points: Vec<(f64, f64)>,
        colour: RGBColor,
        marker: Marker,
    },
    Line {
        name: String,
        points: Vec<(f64, f64)>,
        colour: RGBColor,
        dashed: bool,
    },
    /// A shaded band between `lower` and `upper`, both sampled at the same x.
    Band {
        name: String,
        x: Vec<f64>,
        lower: Vec<f64>,
        upper: Vec<f64>,
        colour: RGBColor,
    },
    /// A horizontal line across the whole chart (a limit, a gate).
    HLine {
        name: String,
        y: f64,
        colour: RGBColor,
    },
    /// Segments from a point to a point (residual vectors), with a dot at the start.
    Arrows {
        name: String,
        segments: Vec<((f64, f64), (f64, f64))>,
        colour: RGBColor,
    },
    /// Vertical bars of width `width` centred at x.
    Bars {
        name: String,
        bars: Vec<(f64, f64)>,
        width: f64,
        colour: RGBColor,
    },
}

/// Where the legend sits; pick the corner the data leaves empty.
pub use plotters::chart::SeriesLabelPosition as LegendAt;

/// One chart: title, axes and layers. Ranges are taken from the data (padded) unless given.
pub struct Chart {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub size_px: (u32, u32),
    pub x_range: Option<(f64, f64)>,
    pub y_range: Option<(f64, f64)>,
    /// Image rows grow down: draw y increasing downwards (labels keep their true values).
    pub y_down: bool,
    /// `None`: the corner with the least data in it.
    pub legend_at: Option<LegendAt>,
    pub layers: Vec<Layer>,
}

impl Chart {
    pub fn new(title: &str, x_label: &str, y_label: &str) -> Self {
        Chart {
            title: title.to_string(),
            x_label: x_label.to_string(),
            y_label: y_label.to_string(),
            // Two side by side fit a 1100 px page.
            size_px: (520, 340),
            x_range: None,
            y_range: None,
            y_down: false,
            legend_at: None,
            layers: Vec::new(),
        }
    }

    fn data_extent(&self) -> ((f64, f64), (f64, f64)) {
        let mut xs = Vec::new();
        let mut ys = Vec::new();
        for l in &self.layers {
            match l {
                Layer::Points { points, .. } | Layer::Line { points, .. } => {
                    xs.extend(points.iter().map(|p| p.0));
                    ys.extend(points.iter().map(|p| p.1));
                }
                Layer::Band { x, lower, upper, .. } => {
                    xs.extend(x);
                    ys.extend(lower);
                    ys.extend(upper);
                }
                Layer::HLine { y, .. } => ys.push(*y),
                Layer::Arrows { segments, .. } => {
                    for (a, b) in segments {
                        xs.extend([a.0, b.0]);
                        ys.extend([a.1, b.1]);
                    }
                }
                Layer::Bars { bars, width, .. } => {
                    for (x, y) in bars {
                        xs.extend([x - width / 2.0, x + width / 2.0]);
                        ys.extend([0.0, *y]);
                    }
                }
            }
        }
        (padded_range(&xs), padded_range(&ys))
    }

    /// The corner whose quarter (40% wide, 40% high) holds the fewest data points or line
    /// samples: there the legend hides nothing.
    fn emptiest_corner(&self, (x0, x1): (f64, f64), (y0, y1): (f64, f64)) -> LegendAt {
        let mut pts: Vec<(f64, f64)> = Vec::new();
        for l in &self.layers {
            match l {
                Layer::Points { points, .. } => pts.extend(points),
                Layer::Line { points, .. } => {
                    for w in points.windows(2) {
                        pts.extend((0..=20).map(|k| {
                            let t = k as f64 / 20.0;
                            (w[0].0 + t * (w[1].0 - w[0].0), w[0].1 + t * (w[1].1 - w[0].1))
                        }));
                    }
                }
                Layer::HLine { y, .. } => pts.extend((0..=20).map(|k| (x0 + (x1 - x0) * k as f64 / 20.0, *y))),
                Layer::Band { x, lower, upper, .. } => {
                    pts.extend(x.iter().zip(lower).map(|(a, b)| (*a, *b)));
                    pts.extend(x.iter().zip(upper).map(|(a, b)| (*a, *b)));
                }
                Layer::Arrows { segments, .. } => pts.extend(segments.iter().map(|s| s.0)),
                Layer::Bars { bars, .. } => pts.extend(bars),
            }
        }
        // Fractions across the plot, with the top of the drawing at 1.
        let frac = |p: &(f64, f64)| {
            let fy = (p.1 - y0) / (y1 - y0);
            ((p.0 - x0) / (x1 - x0), if self.y_down { 1.0 - fy } else { fy })
        };
        let count = |right: bool, top: bool| {
            pts.iter()
                .map(frac)
                .filter(|(fx, fy)| {
                    (if right { *fx > 0.6 } else { *fx < 0.4 }) && (if top { *fy > 0.6 } else { *fy < 0.4 })
                })
                .count()
        };
        [
            (count(false, true), LegendAt::UpperLeft),
            (count(true, true), LegendAt::UpperRight),
            (count(false, false), LegendAt::LowerLeft),
            (count(true, false), LegendAt::LowerRight),
        ]
        .into_iter()
        .min_by_key(|c| c.0)
        .map_or(LegendAt::UpperRight, |c| c.1)
    }

    /// The chart as an SVG document.
    pub fn svg(&self) -> Result<String, ReportError> {
        let err = |e: &dyn std::fmt::Display| self.plot_error(e);
        let (auto_x, auto_y) = self.data_extent();
        let (x0, x1) = self.x_range.unwrap_or(auto_x);
        let (y0, y1) = self.y_range.unwrap_or(auto_y);
        // Rows growing down are drawn as negated values with negated labels.
        let s = if self.y_down { -1.0 } else { 1.0 };
        let (ya, yb) = if self.y_down { (-y1, -y0) } else { (y0, y1) };
        let mut out = String::new();
        {
            let root = SVGBackend::with_string(&mut out, self.size_px).into_drawing_area();
            root.fill(&WHITE).map_err(|e| err(&e))?;
            let mut chart = self.axes(&root, (x0..x1, ya..yb), s)?;
            // Areas first, so lines and points are drawn over them.
            let mut legend = false;
            for layer in &self.layers {
                legend |= self.draw_area(&mut chart, layer, s)?;
            }
            for layer in &self.layers {
                legend |= self.draw_mark(&mut chart, layer, s, (x0, x1))?;
            }
            if legend {
                chart
                    .configure_series_labels()
                    .position(self.legend_at.clone().unwrap_or_else(|| self.emptiest_corner((x0, x1), (y0, y1))))
                    .background_style(WHITE.mix(0.85))
                    .border_style(RGBColor(180, 180, 180))
                    .label_font(("sans-serif", 12))
                    .draw()
                    .map_err(|e| err(&e))?;
            }
            root.present().map_err(|e| err(&e))?;
        }
        Ok(out)
    }

    fn plot_error(&self, e: &dyn std::fmt::Display) -> ReportError {
        ReportError::Plot { name: self.title.clone(), message: e.to_string() }
    }

    /// The title, the axes with their labels, and the grid; `s` is -1 when rows grow down.
    fn axes<'a, 'b>(
        &self,
        root: &'a DrawingArea<SVGBackend<'b>, Shift>,
        (x_range, y_range): (Range<f64>, Range<f64>),
        s: f64,
    ) -> Result<Plot<'a, 'b>, ReportError> {
        let err = |e: &dyn std::fmt::Display| self.plot_error(e);
        let mut chart = ChartBuilder::on(root)
            .caption(&self.title, ("sans-serif", 16))
            .margin(8)
            .x_label_area_size(36)
            .y_label_area_size(58)
            .build_cartesian_2d(x_range, y_range)
            .map_err(|e| err(&e))?;
        chart
            .configure_mesh()
            .x_desc(&self.x_label)
            .y_desc(&self.y_label)
            .x_labels(7)
            .y_labels(6)
            .y_label_formatter(&|v| tidy(s * v))
            .x_label_formatter(&|v| tidy(*v))
            .light_line_style(RGBColor(235, 235, 235))
            .draw()
            .map_err(|e| err(&e))?;
        Ok(chart)
    }

    /// Draws a band or bars layer (others are drawn by [`Chart::draw_mark`]); true when it
    /// added a legend entry.
    fn draw_area(&self, chart: &mut Plot, layer: &Layer, s: f64) -> Result<bool, ReportError> {
        let err = |e: &dyn std::fmt::Display| self.plot_error(e);
        match layer {
            Layer::Band { name, x, lower, upper, colour } => {
                let mut poly: Vec<(f64, f64)> = x.iter().zip(upper).map(|(x, y)| (*x, s * y)).collect();
                poly.extend(x.iter().zip(lower).rev().map(|(x, y)| (*x, s * y)));
                let c = *colour;
                let a = chart
                    .draw_series(std::iter::once(Polygon::new(poly, c.mix(0.25).filled())))
                    .map_err(|e| err(&e))?;
                if !name.is_empty() {
                    a.label(name)
                        .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 16, y + 5)], c.mix(0.25).filled()));
                    return Ok(true);
                }
            }
            Layer::Bars { name, bars, width, colour } => {
                let c = *colour;
                let a =
                    chart
                        .draw_series(bars.iter().map(|(x, y)| {
                            Rectangle::new([(x - width / 2.0, 0.0), (x + width / 2.0, s * y)], c.filled())
                        }))
                        .map_err(|e| err(&e))?;
                if !name.is_empty() {
                    a.label(name).legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 16, y + 5)], c.filled()));
                    return Ok(true);
                }
            }
            _ => {}
        }
        Ok(false)
    }

    /// Draws a line, limit, points or arrows layer; true when it added a legend entry.
    fn draw_mark(&self, chart: &mut Plot, layer: &Layer, s: f64, (x0, x1): (f64, f64)) -> Result<bool, ReportError> {
        let err = |e: &dyn std::fmt::Display| self.plot_error(e);
        let (name, c) = match layer {
            Layer::Line { name, points, colour, dashed } => {
                let pts = points.iter().map(|p| (p.0, s * p.1));
                let style = colour.stroke_width(2);
                if *dashed {
                    chart.draw_series(DashedLineSeries::new(pts, 6, 4, style)).map_err(|e| err(&e))?;
                } else {
                    chart.draw_series(LineSeries::new(pts, style)).map_err(|e| err(&e))?;
                }
                (name, *colour)
            }
            Layer::HLine { name, y, colour } => {
                let style = colour.stroke_width(2);
                chart
                    .draw_series(DashedLineSeries::new([(x0, s * y), (x1, s * y)], 6, 4, style))
                    .map_err(|e| err(&e))?;
                (name, *colour)
            }
            Layer::Points { name, points, colour, marker } => {
                return self.draw_points(chart, name, points, *colour, *marker, s);
            }
            Layer::Arrows { name, segments, colour } => {
                let c = *colour;
                chart
                    .draw_series(
                        segments
                            .iter()
                            .map(|(a, b)| PathElement::new(vec![(a.0, s * a.1), (b.0, s * b.1)], c.stroke_width(1))),
                    )
                    .map_err(|e| err(&e))?;
                chart
                    .draw_series(segments.iter().map(|(a, _)| Circle::new((a.0, s * a.1), 1, c.filled())))
                    .map_err(|e| err(&e))?;
                (name, c)
            }
            Layer::Band { .. } | Layer::Bars { .. } => return Ok(false),
        };
        if name.is_empty() {
            return Ok(false);
        }
        chart
            .draw_series(std::iter::empty::<PathElement<(f64, f64)>>())
            .map_err(|e| err(&e))?
            .label(name)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], c.stroke_width(2)));
        Ok(true)
    }

    /// Draws a points layer with its marker; true when it added a legend entry.
    fn draw_points(
        &self,
        chart: &mut Plot,
        name: &str,
        points: &[(f64, f64)],
        c: RGBColor,
        marker: Marker,
        s: f64,
    ) -> Result<bool, ReportError> {
        let err = |e: &dyn std::fmt::Display| self.plot_error(e);
        match marker {
            Marker::Circle => {
                chart
                    .draw_series(points.iter().map(|p| Circle::new((p.0, s * p.1), 4, c.filled())))
                    .map_err(|e| err(&e))?;
            }
            Marker::Cross => {
                chart
                    .draw_series(points.iter().map(|p| Cross::new((p.0, s * p.1), 5, c.stroke_width(2))))
                    .map_err(|e| err(&e))?;
            }
        }
        if name.is_empty() {
            return Ok(false);
        }
        let legend = chart.draw_series(std::iter::empty::<Circle<(f64, f64), i32>>()).map_err(|e| err(&e))?.label(name);
        match marker {
            Marker::Circle => legend.legend(move |(x, y)| Circle::new((x + 8, y), 4, c.filled())),
            Marker::Cross => legend.legend(move |(x, y)| Cross::new((x + 8, y), 5, c.stroke_width(2))),
        };
        Ok(true)
    }
}

/// Data range padded by 5% each side; a single value gets a unit-wide range.
fn padded_range(v: &[f64]) -> (f64, f64) {
    let finite = v.iter().copied().filter(|x| x.is_finite());
    let lo = finite.clone().fold(f64::INFINITY, f64::min);
    let hi = finite.fold(f64::NEG_INFINITY, f64::max);
    if !lo.is_finite() {
        return (0.0, 1.0);
    }
    if hi - lo < 1e-12 {
        return (lo - 0.5, hi + 0.5);
    }
    let pad = 0.05 * (hi - lo);
    (lo - pad, hi + pad)
}

/// Axis labels without float noise: at most 3 decimals, trailing zeros dropped.
fn tidy(v: f64) -> String {
    let s = format!("{:.3}", if v.abs() < 5e-4 { 0.0 } else { v });
    let s = s.trim_end_matches('0').trim_end_matches('.');
    s.to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn draws_every_layer_kind_as_svg_without_fonts() {
        let mut c = Chart::new("residual <per> photo", "distance (m)", "residual (px)");
        c.layers.push(Layer::Band {
            name: "1-sigma".into(),
            x: vec![0.5, 5.0],
            lower: vec![-0.1, -1.0],
            upper: vec![0.1, 1.0],
            colour: colour::BAND,
        });
        c.layers.push(Layer::Points {
            name: "used".into(),
            points: vec![(1.0, 0.2), (2.0, 0.3)],
            colour: colour::USED,
            marker: Marker::Circle,
        });
        c.layers.push(Layer::Points {
            name: "outlier".into(),
            points: vec![(3.0, 5.0)],
            colour: colour::OUTLIER,
            marker: Marker::Cross,
        });
        c.layers.push(Layer::Line {
            name: "fit".into(),
            points: vec![(0.5, 0.0), (5.0, 0.0)],
            colour: colour::FIT,
            dashed: false,
        });
        c.layers.push(Layer::HLine { name: "gate".into(), y: 4.0, colour: colour::LIMIT });
        c.layers.push(Layer::Arrows {
            name: "vectors".into(),
            segments: vec![((1.0, 1.0), (1.5, 1.2))],
            colour: colour::GREY,
        });
        c.layers.push(Layer::Bars { name: "rms".into(), bars: vec![(1.0, 0.5)], width: 0.6, colour: colour::USED });
        let svg = c.svg().unwrap();
        assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
        assert!(svg.contains("width=\"520\"") && svg.contains("height=\"340\""));
        // Title escaped, legend entries present.
        assert!(svg.contains("residual &lt;per&gt; photo"), "{svg}");
        for label in ["used", "outlier", "fit", "gate", "1-sigma", "vectors", "rms"] {
            assert!(svg.contains(&format!(">{label}<")) || svg.contains(&format!(">\n{label}\n<")), "legend {label}");
        }
        assert!(
            !svg.contains("http://")
                || svg.matches("http://").all(|_| svg.contains("xmlns=\"http://www.w3.org/2000/svg\""))
        );
    }

    #[test]
    fn rows_growing_down_keep_their_true_labels() {
        let mut c = Chart::new("image", "u (px)", "v (px)");
        c.y_down = true;
        c.x_range = Some((0.0, 4000.0));
        c.y_range = Some((0.0, 3000.0));
        c.layers.push(Layer::Points {
            name: String::new(),
            points: vec![(100.0, 200.0)],
            colour: colour::USED,
            marker: Marker::Circle,
        });
        let svg = c.svg().unwrap();
        // plotters writes each label on its own line.
        assert!(svg.contains(">\n3000\n<") || svg.contains(">\n2500\n<"), "labels are positive rows: {svg}");
        assert!(!svg.contains(">\n-"), "no negated labels");
    }

    #[test]
    fn tidy_labels() {
        assert_eq!(tidy(1.5000001), "1.5");
        assert_eq!(tidy(-0.0001), "0");
        assert_eq!(tidy(3.0), "3");
    }
}
