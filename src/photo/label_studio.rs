//! Label Studio's JSON export as the lab makes it: its tasks, the photo each names, each
//! task's current annotation (the newest not cancelled) and its keypoints as pixels of the
//! frame they were clicked in. One reader for fish labels and laser dots.
//!
//! A keypoint's `value.x`, `value.y` are percent of `original_width` x `original_height`
//! with (0, 0) at the image's top-left *edge*; in fslcal's pixel-centre convention that is
//! `u = x% / 100 * w - 0.5` (docs/conventions.md). The lab's own reader omits the `- 0.5`.

use crate::photo::frame::Frame;
use fslcal_core::Vec2;
use serde_json::Value;

/// Why an export cannot be read.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum LabelStudioError {
    #[error("not Label Studio JSON ({0})")]
    Json(String),
    #[error("expected a list of Label Studio tasks (`[{{\"data\": ..., \"annotations\": [...]}}, ...]`)")]
    NotTasks,
    #[error("{task}: {why}")]
    Task { task: String, why: String },
}

/// One task: a photo and the annotations people made of it.
#[derive(Clone, Debug, PartialEq)]
pub struct Task {
    /// Position in the export, from 0.
    pub index: usize,
    /// Label Studio's task id.
    pub id: Option<i64>,
    /// The photo as the task names it (`data.img`, `data.image`, or the task's only text
    /// field): a URL, an upload path or a file name.
    pub image: Option<String>,
    pub annotations: Vec<Annotation>,
}

/// One person's labelling of a task.
#[derive(Clone, Debug, PartialEq)]
pub struct Annotation {
    pub id: Option<i64>,
    /// Skipped in Label Studio (`was_cancelled`): not a labelling.
    pub cancelled: bool,
    /// Last change (`updated_at`, else `created_at`).
    pub time: Option<jiff::Timestamp>,
    pub keypoints: Vec<Keypoint>,
    /// `choices` values (a species, a flag), in order.
    pub choices: Vec<String>,
}

/// A clicked point.
#[derive(Clone, Debug, PartialEq)]
pub struct Keypoint {
    /// `keypointlabels`, e.g. `["Green Laser"]`.
    pub labels: Vec<String>,
    pub x_pct: f64,
    pub y_pct: f64,
    /// The image it was clicked on: `original_width` x `original_height`.
    pub frame: Frame,
}

impl Keypoint {
    /// The point in pixels of [`Keypoint::frame`], pixel-centre convention.
    pub fn pixel(&self) -> Vec2 {
        Vec2::new(
            self.x_pct / 100.0 * self.frame.width_px as f64 - 0.5,
            self.y_pct / 100.0 * self.frame.height_px as f64 - 0.5,
        )
    }

    pub fn has_label(&self, label: &str) -> bool {
        self.labels.iter().any(|l| l.eq_ignore_ascii_case(label))
    }
}

impl Task {
    /// `task 138992 (P2100001.JPG)`, as messages name it.
    pub fn describe(&self) -> String {
        let id = self.id.map_or_else(|| format!("task #{}", self.index + 1), |id| format!("task {id}"));
        match self.image_name() {
            Some(n) => format!("{id} ({n})"),
            None => id,
        }
    }

    /// The photo's file name: the last component of its path or URL, without a query.
    pub fn image_name(&self) -> Option<&str> {
        let image = self.image.as_deref()?;
        let path = image.split(['?', '#']).next().unwrap_or(image);
        path.rsplit(['/', '\\']).next().filter(|n| !n.is_empty())
    }

    /// Annotations that are labellings (not cancelled).
    pub fn live(&self) -> impl Iterator<Item = &Annotation> {
        self.annotations.iter().filter(|a| !a.cancelled)
    }

    /// The annotation that counts: the newest one not cancelled (by its time; of two with
    /// the same or no time, the later in the export).
    pub fn current(&self) -> Option<&Annotation> {
        self.live().enumerate().max_by(|(i, a), (j, b)| a.time.cmp(&b.time).then(i.cmp(j))).map(|(_, a)| a)
    }
}

/// Whether `text` is JSON rather than a CSV: its first non-blank character opens an array
/// or an object.
pub fn looks_like_json(text: &str) -> bool {
    text.trim_start_matches('\u{feff}').trim_start().starts_with(['[', '{'])
}

/// Reads an export: a list of tasks (or one task).
pub fn parse(text: &str) -> Result<Vec<Task>, LabelStudioError> {
    let v: Value =
        serde_json::from_str(text.trim_start_matches('\u{feff}')).map_err(|e| LabelStudioError::Json(e.to_string()))?;
    let tasks = match v {
        Value::Array(a) => a,
        Value::Object(_) => vec![v],
        _ => return Err(LabelStudioError::NotTasks),
    };
    tasks.iter().enumerate().map(|(index, t)| task(index, t)).collect()
}

fn task(index: usize, t: &Value) -> Result<Task, LabelStudioError> {
    if !t.is_object() || !(t.get("data").is_some() || t.get("annotations").is_some()) {
        return Err(LabelStudioError::NotTasks);
    }
    let image = t["data"]
        .as_object()
        .and_then(|d| d.get("img").or_else(|| d.get("image")).or_else(|| d.values().find(|v| v.is_string())))
        .and_then(Value::as_str)
        .map(str::to_string);
    let mut task = Task { index, id: t["id"].as_i64(), image, annotations: Vec::new() };
    // `completions` is what Label Studio called annotations before 1.0.
    let list = t["annotations"].as_array().or(t["completions"].as_array());
    for a in list.into_iter().flatten() {
        let annotation = annotation(a).map_err(|why| LabelStudioError::Task { task: task.describe(), why })?;
        task.annotations.push(annotation);
    }
    Ok(task)
}

fn annotation(a: &Value) -> Result<Annotation, String> {
    let time = ["updated_at", "created_at"]
        .iter()
        .find_map(|k| a[*k].as_str().and_then(|s| s.parse::<jiff::Timestamp>().ok()));
    let mut out = Annotation {
        id: a["id"].as_i64(),
        cancelled: a["was_cancelled"] == Value::Bool(true),
        time,
        keypoints: Vec::new(),
        choices: Vec::new(),
    };
    for r in a["result"].as_array().into_iter().flatten() {
        let value = &r["value"];
        if let Some(c) = value["choices"].as_array() {
            out.choices.extend(c.iter().filter_map(Value::as_str).map(str::to_string));
        } else if let Some(labels) = value["keypointlabels"].as_array() {
            out.keypoints.push(keypoint(r, labels)?);
        }
    }
    Ok(out)
}

fn keypoint(r: &Value, labels: &[Value]) -> Result<Keypoint, String> {
    let labels: Vec<String> = labels.iter().filter_map(Value::as_str).map(str::to_string).collect();
    let name = labels.first().map_or_else(|| "a keypoint".to_string(), |l| format!("keypoint `{l}`"));
    // Label Studio writes whole numbers; a script may write `4040.0`.
    let size =
        |k: &str| r[k].as_f64().filter(|n| *n >= 1.0 && *n <= u32::MAX as f64 && n.fract() == 0.0).map(|n| n as u32);
    let (Some(w), Some(h)) = (size("original_width"), size("original_height")) else {
        return Err(format!("{name} without a whole `original_width` and `original_height` (the image's size)"));
    };
    let (Some(x_pct), Some(y_pct)) = (r["value"]["x"].as_f64(), r["value"]["y"].as_f64()) else {
        return Err(format!("{name} without numbers `x` and `y`"));
    };
    let rotation = r["image_rotation"].as_f64().unwrap_or(0.0);
    if rotation != 0.0 {
        return Err(format!(
            "{name} was clicked on the image rotated by {rotation} deg in Label Studio; label it unrotated"
        ));
    }
    Ok(Keypoint { labels, x_pct, y_pct, frame: Frame::of_size(w, h) })
}

#[cfg(test)]
mod tests {
    use super::*;

    const EXPORT: &str = r#"[
      {"id": 7, "data": {"img": "https://nas:6021/label_studio/x/P2100001.JPG?v=2"}, "annotations": [
        {"id": 1, "was_cancelled": false, "created_at": "2025-02-12T02:46:47.060779Z", "updated_at": "2025-02-12T02:46:47.06Z",
         "result": [{"type": "keypointlabels", "value": {"x": 50.0, "y": 25.0, "keypointlabels": ["Green Laser"]},
                     "original_width": 4040, "original_height": 3016, "image_rotation": 0}]},
        {"id": 2, "was_cancelled": false, "updated_at": "2025-02-13T09:00:00Z",
         "result": [{"value": {"x": 10.0, "y": 20.0, "keypointlabels": ["Green Laser"]}, "original_width": 4040, "original_height": 3016}]},
        {"id": 3, "was_cancelled": true, "updated_at": "2025-02-14T09:00:00Z", "result": []}
      ]},
      {"id": 8, "data": {"image": "/data/upload/3/ab12-P2100002.JPG"}, "annotations": []}
    ]"#;

    #[test]
    fn reads_tasks_the_newest_live_annotation_and_pixel_centres() {
        let tasks = parse(EXPORT).unwrap();
        assert_eq!(tasks.len(), 2);
        assert_eq!(tasks[0].image_name(), Some("P2100001.JPG"));
        assert_eq!(tasks[1].image_name(), Some("ab12-P2100002.JPG"));
        assert_eq!(tasks[0].describe(), "task 7 (P2100001.JPG)");
        // The cancelled one is newer but does not count; of the two others the newer wins.
        let current = tasks[0].current().unwrap();
        assert_eq!(current.id, Some(2));
        assert_eq!(tasks[0].live().count(), 2);
        let k = &tasks[0].annotations[0].keypoints[0];
        assert!(k.has_label("green laser"));
        // 50% of 4040 is the edge between pixels 2019 and 2020: 2019.5 in centre terms.
        assert_eq!(k.pixel(), Vec2::new(2019.5, 753.5));
        assert_eq!(k.frame, Frame::of_size(4040, 3016));
        assert!(tasks[1].current().is_none());
    }

    #[test]
    fn refuses_what_it_cannot_place() {
        let no_size = r#"[{"id": 3, "data": {"img": "a.jpg"}, "annotations": [{"result": [{"value": {"x": 1, "y": 2, "keypointlabels": ["dot"]}}]}]}]"#;
        let e = parse(no_size).unwrap_err().to_string();
        assert!(e.starts_with("task 3 (a.jpg): keypoint `dot` without a whole `original_width`"), "{e}");
        let rotated = r#"[{"data": {"img": "a.jpg"}, "annotations": [{"result": [{"value": {"x": 1, "y": 2, "keypointlabels": ["dot"]}, "original_width": 10, "original_height": 10, "image_rotation": 90}]}]}]"#;
        assert!(parse(rotated).unwrap_err().to_string().contains("rotated by 90 deg"));
        assert_eq!(parse("[1, 2]").unwrap_err(), LabelStudioError::NotTasks);
        assert!(matches!(parse("photo,x,y"), Err(LabelStudioError::Json(_))));
        assert!(looks_like_json("\u{feff}  [") && !looks_like_json("file,x,y\n"));
    }
}
