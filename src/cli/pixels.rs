//! Pixels typed on the command line (`X,Y`) and hand-labelled dot files (`file,x,y`), shared
//! by the commands that take them.

use crate::photo::dot_labels::{self, DotsFormat};
use anyhow::bail;
use fslcal_core::Vec2;
use std::path::Path;

/// `X,Y` in pixels (docs/conventions.md), both finite.
pub fn parse_pixel(s: &str) -> Option<Vec2> {
    let (x, y) = s.split_once(',')?;
    let (x, y) = (x.trim().parse::<f64>().ok()?, y.trim().parse::<f64>().ok()?);
    (x.is_finite() && y.is_finite()).then(|| Vec2::new(x, y))
}

/// For clap: `X,Y` in pixels.
pub fn pixel_arg(s: &str) -> Result<Vec2, String> {
    parse_pixel(s).ok_or_else(|| format!("expected X,Y in pixels, got `{s}`"))
}

/// A CSV of `file,x,y` rows (a header row and `#` comments allowed): the photo as written
/// (a path or a file name) and its dot. Anything else (a Label Studio export, a file of no
/// rows) is refused with the reason rather than read as no dots.
pub fn read_dots_csv(csv: &Path) -> anyhow::Result<Vec<(String, Vec2)>> {
    let file = dot_labels::read(csv, "laser")?;
    if file.format != DotsFormat::Csv {
        bail!(
            "{}: a Label Studio export; this command takes the dots as a `file,x,y` CSV in the photos' pixels (`fslcal laser --dots` reads Label Studio exports)",
            csv.display()
        );
    }
    Ok(file.dots.into_iter().map(|d| (d.photo, d.pixel)).collect())
}
