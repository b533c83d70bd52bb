//! Pixels typed on the command line (`X,Y`) and hand-labelled dot files (`file,x,y`), shared
//! by the commands that take them.

use anyhow::{bail, Context};
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
/// (a path or a file name) and its dot. Two rows giving one photo different dots are
/// refused: which one is right is the labeller's call, not the last row's.
pub fn read_dots_csv(csv: &Path) -> anyhow::Result<Vec<(String, Vec2)>> {
    let text = std::fs::read_to_string(csv).with_context(|| format!("{}: cannot read the dots file", csv.display()))?;
    let mut dots: Vec<(String, Vec2)> = Vec::new();
    let mut first_line = std::collections::HashMap::new();
    for (n, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let (file, xy) = line.split_once(',').unwrap_or((line, ""));
        match parse_pixel(xy) {
            Some(px) => {
                let file = file.trim().to_string();
                if let Some(&(line_no, earlier)) = first_line.get(&file) {
                    if earlier != px {
                        bail!(
                            "{}:{}: a second, different dot for {file} (line {line_no} gives another); keep one row per photo",
                            csv.display(),
                            n + 1
                        );
                    }
                    continue;
                }
                first_line.insert(file.clone(), (n + 1, px));
                dots.push((file, px));
            }
            // A header row names its columns.
            None if n == 0 => continue,
            None => bail!("{}:{}: expected `file,x,y` with x and y in pixels, got `{line}`", csv.display(), n + 1),
        }
    }
    Ok(dots)
}
