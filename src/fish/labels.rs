//! Hand-labelled fish: a CSV (`photo,head_x,head_y,tail_x,tail_y[,dot_x,dot_y][,species]`)
//! or Label Studio's JSON export with keypoints, so the lab's existing labels work as they are.
//!
//! Label Studio's export is read by `photo::label_studio`, shared with the laser's hand
//! dots: keypoints in percent of the image become pixels by `u = x% / 100 * w - 0.5`
//! (docs/conventions.md).

use super::FishError;
use crate::photo::frame::Frame;
use fslcal_core::Vec2;
use std::path::Path;

/// One labelled fish.
#[derive(Clone, Debug, PartialEq)]
pub struct FishLabel {
    /// The photo as the label file names it (a path, a file name, or Label Studio's upload
    /// path with its hash prefix); matched to photos by [`FishLabel::names_photo`].
    pub photo: String,
    pub head_px: Vec2,
    pub tail_px: Vec2,
    pub dot_px: Option<Vec2>,
    pub species: Option<String>,
    /// The image the points were clicked on (a Label Studio keypoint's `original_width` x
    /// `original_height`); `None` for a CSV, whose pixels are the photo's.
    pub frame: Option<Frame>,
}

impl FishLabel {
    /// Whether this label belongs to `photo`: same file name, or Label Studio's
    /// `HASH-NAME` upload name for it.
    pub fn names_photo(&self, photo: &Path) -> bool {
        let Some(want) = photo.file_name().map(|n| n.to_string_lossy().into_owned()) else { return false };
        let have = self.photo.rsplit(['/', '\\']).next().unwrap_or(&self.photo);
        have == want || have.strip_suffix(want.as_str()).is_some_and(|p| p.ends_with('-'))
    }
}

/// Reads a label file; JSON (Label Studio) or CSV by its content.
pub fn read_labels(path: &Path) -> Result<Vec<FishLabel>, FishError> {
    let name = path.display().to_string();
    let text =
        std::fs::read_to_string(path).map_err(|e| FishError::Labels { path: name.clone(), why: e.to_string() })?;
    let labels = if crate::photo::label_studio::looks_like_json(&text) { label_studio(&text) } else { csv(&text) }
        .map_err(|why| FishError::Labels { path: name.clone(), why })?;
    if labels.is_empty() {
        return Err(FishError::Labels { path: name, why: "no labelled fish in it".into() });
    }
    Ok(labels)
}

const CSV_COLUMNS: [&str; 8] = ["photo", "head_x", "head_y", "tail_x", "tail_y", "dot_x", "dot_y", "species"];

fn csv(text: &str) -> Result<Vec<FishLabel>, String> {
    let mut columns: Vec<String> = CSV_COLUMNS.iter().map(|s| s.to_string()).collect();
    let mut out = Vec::new();
    let mut first = true;
    for (n, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let cells: Vec<&str> = line.split(',').map(str::trim).collect();
        // A header names its columns (any order, unknown ones ignored): a first line whose
        // second cell is not a number.
        let header = first && cells.get(1).is_some_and(|c| c.parse::<f64>().is_err());
        first = false;
        if header {
            columns = cells.iter().map(|c| c.to_ascii_lowercase()).collect();
            for need in &CSV_COLUMNS[..5] {
                if !columns.iter().any(|c| c == need) {
                    return Err(format!("the header has no `{need}` column (expected {})", CSV_COLUMNS.join(",")));
                }
            }
            continue;
        }
        let cell = |name: &str| {
            columns.iter().position(|c| c == name).and_then(|i| cells.get(i)).copied().filter(|c| !c.is_empty())
        };
        let number = |name: &str| -> Result<Option<f64>, String> {
            cell(name)
                .map(|c| {
                    c.parse::<f64>()
                        .ok()
                        .filter(|v| v.is_finite())
                        .ok_or(format!("line {}: `{name}` is `{c}`, not a number of pixels", n + 1))
                })
                .transpose()
        };
        let pair = |x: &str, y: &str| -> Result<Option<Vec2>, String> {
            match (number(x)?, number(y)?) {
                (Some(a), Some(b)) => Ok(Some(Vec2::new(a, b))),
                (None, None) => Ok(None),
                _ => Err(format!("line {}: `{x}` and `{y}` go together", n + 1)),
            }
        };
        let photo = cell("photo").ok_or(format!("line {}: no photo", n + 1))?;
        let missing = || format!("line {}: expected photo,head_x,head_y,tail_x,tail_y[,dot_x,dot_y][,species]", n + 1);
        out.push(FishLabel {
            photo: photo.to_string(),
            head_px: pair("head_x", "head_y")?.ok_or_else(missing)?,
            tail_px: pair("tail_x", "tail_y")?.ok_or_else(missing)?,
            dot_px: pair("dot_x", "dot_y")?,
            species: cell("species").map(str::to_string),
            frame: None,
        });
    }
    Ok(out)
}

/// Which fish part a keypoint label names.
fn part(label: &str) -> Option<&'static str> {
    match label.to_ascii_lowercase().as_str() {
        "head" | "snout" | "nose" => Some("head"),
        "tail" | "fork" | "caudal fork" | "tail fork" => Some("tail"),
        "dot" | "laser" | "laser dot" | "green laser" | "red laser" => Some("dot"),
        _ => None,
    }
}

/// Label Studio's JSON export (`photo::label_studio`): each task's current annotation, its
/// `keypointlabels` for the parts and a `choices` value for the species. Several fish in one
/// photo pair their heads and tails in order.
fn label_studio(text: &str) -> Result<Vec<FishLabel>, String> {
    let tasks = crate::photo::label_studio::parse(text).map_err(|e| e.to_string())?;
    let mut out = Vec::new();
    for task in &tasks {
        let Some(annotation) = task.current() else { continue };
        let photo =
            task.image.as_ref().ok_or_else(|| format!("{}: no `data.image` naming the photo", task.describe()))?;
        let (mut heads, mut tails, mut dots) = (vec![], vec![], vec![]);
        for k in &annotation.keypoints {
            match k.labels.first().and_then(|l| part(l)) {
                Some("head") => heads.push(k.pixel()),
                Some("tail") => tails.push(k.pixel()),
                Some(_) => dots.push(k.pixel()),
                None => {}
            }
        }
        if heads.len() != tails.len() {
            return Err(format!(
                "{}: {} head and {} tail keypoints; every fish needs both",
                task.describe(),
                heads.len(),
                tails.len()
            ));
        }
        let species = annotation.choices.first().cloned();
        // One annotation is of one image: its keypoints share their frame.
        let frame = annotation.keypoints.first().map(|k| k.frame);
        for (head_px, tail_px) in heads.into_iter().zip(tails) {
            out.push(FishLabel {
                photo: photo.clone(),
                head_px,
                tail_px,
                dot_px: dots.first().copied(),
                species: species.clone(),
                frame,
            });
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_with_and_without_header() {
        let a = csv("p1.jpg,10,20,110,25\n# note\np2.jpg,1,2,3,4,50.5,60,snapper\n").unwrap();
        assert_eq!(a.len(), 2);
        assert_eq!(a[1].dot_px, Some(Vec2::new(50.5, 60.0)));
        assert_eq!(a[1].species.as_deref(), Some("snapper"));
        let b = csv("species,photo,tail_x,tail_y,head_x,head_y\ngrouper,x.jpg,5,6,7,8\n").unwrap();
        assert_eq!(
            (b[0].head_px, b[0].tail_px, b[0].species.as_deref()),
            (Vec2::new(7.0, 8.0), Vec2::new(5.0, 6.0), Some("grouper"))
        );
        assert!(csv("x.jpg,1,2,3\n").unwrap_err().contains("line 1"));
        assert!(csv("x.jpg,1,2,3,4,5\n").unwrap_err().contains("go together"));
    }

    #[test]
    fn label_studio_upload_names_match_photos() {
        let l = FishLabel {
            photo: "/data/upload/3/8f2a91c0-P7010042.JPG".into(),
            head_px: Vec2::zeros(),
            tail_px: Vec2::zeros(),
            dot_px: None,
            species: None,
            frame: None,
        };
        assert!(l.names_photo(Path::new("dive/P7010042.JPG")));
        assert!(!l.names_photo(Path::new("dive/7010042.JPG")));
    }
}
