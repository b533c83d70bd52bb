//! Calibration targets: what is printed, where its corners are, and how to name it on a
//! command line.

use serde::{Deserialize, Serialize};
use std::fmt;
use std::str::FromStr;

/// A printed checkerboard, counted by its *inner* corners (where four squares meet), as
/// OpenCV counts them.
///
/// The FishSense lab's board has 14x10 inner corners. Its square is nominally 41.3 mm but
/// measures 42.17 mm with calipers over many squares: taking the nominal size on trust is a
/// silent 2% scale error in every distance and length downstream. Measure yours over as many
/// squares as the calipers span, and divide.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Checkerboard {
    pub inner_cols: u32,
    pub inner_rows: u32,
    /// Side of one square, metres, as measured.
    pub square_m: f64,
}

/// White border around the squares, in squares: boards are printed with a margin and OpenCV
/// needs the outer squares' edges to stand out against something light.
pub const MARGIN_SQUARES: f64 = 0.6;

impl Checkerboard {
    /// The FishSense lab's board: 14x10 inner corners, 42.17 mm squares (measured; the nominal
    /// 41.3 mm is 2% off).
    pub fn fishsense() -> Self {
        Checkerboard { inner_cols: 14, inner_rows: 10, square_m: 0.04217 }
    }

    /// Inner corners in the target frame, metres: index `row * inner_cols + col`, point
    /// `(col * s, row * s, 0)`. Rows run along the image's x first, as OpenCV's
    /// `findChessboardCorners` returns them for a board that is not turned by more than about
    /// 45 degrees in the photo. (A board with an odd number of squares both ways looks the
    /// same turned by 180 degrees; OpenCV may then return the reverse order, which describes
    /// the same plane.)
    pub fn object_points(&self) -> Vec<[f64; 3]> {
        let s = self.square_m;
        (0..self.inner_rows)
            .flat_map(|r| (0..self.inner_cols).map(move |c| [c as f64 * s, r as f64 * s, 0.0]))
            .collect()
    }

    /// Colour of square `(i, j)` over the full board of `(cols + 1) x (rows + 1)` squares:
    /// black when `i + j` is even, so the top-left outer square is black.
    pub fn square_colour_is_black(i: i64, j: i64) -> bool {
        (i + j).rem_euclid(2) == 0
    }

    /// Corners of the physical board including its white margin, target frame, metres,
    /// clockwise from the top-left. The first square's outer corner is at `(-s, -s, 0)`.
    pub fn outline_m(&self) -> [[f64; 3]; 4] {
        let s = self.square_m;
        let m = s * (1.0 + MARGIN_SQUARES);
        let (w, h) = (self.inner_cols as f64 * s, self.inner_rows as f64 * s);
        [[-m, -m, 0.0], [w + m - s, -m, 0.0], [w + m - s, h + m - s, 0.0], [-m, h + m - s, 0.0]]
    }
}

impl fmt::Display for Checkerboard {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mm = (self.square_m * 1e5).round() / 1e2;
        write!(f, "checkerboard:{}x{}@{}mm", self.inner_cols, self.inner_rows, mm)
    }
}

/// Why a target description could not be read.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TargetParseError(String);

impl fmt::Display for TargetParseError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}; expected checkerboard:COLSxROWS@SQUAREmm with inner corners, e.g. checkerboard:14x10@42.17mm",
            self.0
        )
    }
}

impl std::error::Error for TargetParseError {}

impl FromStr for Checkerboard {
    type Err = TargetParseError;

    fn from_str(text: &str) -> Result<Self, Self::Err> {
        let err = |why: String| TargetParseError(why);
        let body = text.trim();
        let body = match body.split_once(':') {
            Some(("checkerboard", rest)) => rest,
            Some((kind, _)) => return Err(err(format!("`{text}`: unknown target kind `{kind}`"))),
            None => body,
        };
        let (grid, square) = body.split_once('@').ok_or_else(|| err(format!("`{text}`: no `@SQUARE` size")))?;
        let (cols, rows) = grid
            .split_once(['x', 'X'])
            .ok_or_else(|| err(format!("`{text}`: the corner count `{grid}` is not COLSxROWS")))?;
        let count = |s: &str| {
            s.trim().parse::<u32>().map_err(|_| err(format!("`{text}`: `{s}` is not a whole number of inner corners")))
        };
        let (inner_cols, inner_rows) = (count(cols)?, count(rows)?);
        if inner_cols < 2 || inner_rows < 2 {
            return Err(err(format!("`{text}`: a board needs at least 2x2 inner corners")));
        }
        let square = square.trim();
        let (number, scale) = if let Some(n) = square.strip_suffix("mm") {
            (n, 1e-3)
        } else if let Some(n) = square.strip_suffix('m') {
            (n, 1.0)
        } else {
            return Err(err(format!("`{text}`: the square size `{square}` needs a unit, mm or m")));
        };
        let square_m =
            number.trim().parse::<f64>().map_err(|_| err(format!("`{text}`: `{number}` is not a number")))? * scale;
        if !(0.001..=0.5).contains(&square_m) {
            return Err(err(format!("`{text}`: a {:.1} mm square is not plausible (1-500 mm)", square_m * 1e3)));
        }
        Ok(Checkerboard { inner_cols, inner_rows, square_m })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_and_prints_the_canonical_form() {
        let b: Checkerboard = "checkerboard:14x10@42.17mm".parse().unwrap();
        assert_eq!(b, Checkerboard::fishsense());
        assert_eq!(b.to_string(), "checkerboard:14x10@42.17mm");
        assert_eq!("9x6@0.025m".parse::<Checkerboard>().unwrap().to_string(), "checkerboard:9x6@25mm");
        for bad in ["14x10", "14x10@42", "14by10@42mm", "1x10@42mm", "14x10@0.1mm", "slate:x", "14x10@abcmm"] {
            let e = bad.parse::<Checkerboard>().unwrap_err().to_string();
            assert!(e.contains("expected checkerboard:COLSxROWS@SQUAREmm"), "{bad}: {e}");
        }
    }

    #[test]
    fn object_points_are_row_major() {
        let b = Checkerboard { inner_cols: 3, inner_rows: 2, square_m: 0.5 };
        let p = b.object_points();
        assert_eq!(p.len(), 6);
        assert_eq!(p[1], [0.5, 0.0, 0.0]);
        assert_eq!(p[3], [0.0, 0.5, 0.0]);
        assert_eq!(p[5], [1.0, 0.5, 0.0]);
        assert!(Checkerboard::square_colour_is_black(0, 0));
        assert!(!Checkerboard::square_colour_is_black(1, 0));
        // Outline: one square plus the margin beyond the outer inner corners.
        let o = b.outline_m();
        assert!((o[0][0] + 0.8).abs() < 1e-12 && (o[2][0] - 1.8).abs() < 1e-12 && (o[2][1] - 1.3).abs() < 1e-12);
    }
}
