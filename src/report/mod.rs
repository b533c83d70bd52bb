//! The HTML report `--report DIR` writes: one `index.html` with the plots (SVG files beside
//! it) and photo thumbnails (JPEG, in `thumbs/`). Nothing is fetched from the network: no
//! scripts, no web fonts, no external style sheets, so a report opens on a laptop on a boat.
//!
//! A command's report is a [`Page`] of sections (figures, tables, thumbnails) plus the files
//! it refers to, written by [`ReportFiles::write`]. The plots come from [`plot`] and the
//! thumbnails from [`thumbnail`]; each command's page lives in its own submodule
//! (`report::laser::write(dir, ...)`), so adding one is a page builder and a `--report` flag.

#[cfg(feature = "vision")]
pub mod camera;
pub mod check;
#[cfg(feature = "vision")]
pub mod laser;
pub mod plot;
pub mod thumbnail;
pub mod validate;

use crate::atomic_file::replace_dir_atomically;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// The cause is in the message, not a `source`, or `{:#}` would say it twice.
    #[error("{path}: cannot write the report: {cause}")]
    Io { path: String, cause: std::io::Error },
    #[error("cannot draw the plot `{name}`: {message}")]
    Plot { name: String, message: String },
}

/// Escapes text for HTML content and attribute values.
pub fn escape(text: &str) -> String {
    let mut s = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => s.push_str("&amp;"),
            '<' => s.push_str("&lt;"),
            '>' => s.push_str("&gt;"),
            '"' => s.push_str("&quot;"),
            '\'' => s.push_str("&#39;"),
            c => s.push(c),
        }
    }
    s
}

/// A file name safe in a URL and on every filesystem: letters, digits, `-`, `_`, `.`.
pub fn safe_file_name(name: &str) -> String {
    name.chars().map(|c| if c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.') { c } else { '_' }).collect()
}

/// Draws `chart` into `plots/NAME` beside the page and shows it as a figure.
pub fn add_plot(
    page: &mut Page,
    files: &mut ReportFiles,
    name: &str,
    chart: &plot::Chart,
    caption: &str,
) -> Result<(), ReportError> {
    let src = format!("plots/{name}");
    files.add(src.clone(), chart.svg()?.into_bytes());
    page.figure(&src, &chart.title, caption, chart.size_px);
    Ok(())
}

/// A photo's file name without its folders, as tables show it.
pub fn file_name(path: &str) -> String {
    Path::new(path).file_name().map_or_else(|| path.to_string(), |n| n.to_string_lossy().into_owned())
}

/// Thumbnail width, pixels: enough to see a dot's ring against the board, small enough for
/// a 20-photo report to stay well under a megabyte.
pub const THUMBNAIL_WIDTH_PX: u32 = 320;

/// Draws each photo's thumbnail (in parallel) with its overlay, adds the JPEGs to `files`
/// as `thumbs/NN-name.jpg`, and returns one table cell per photo: the image, or why there
/// is none (an unreadable photo still gets its row).
pub fn thumbnail_cells(files: &mut ReportFiles, photos: &[(&str, thumbnail::Overlay)]) -> Vec<Cell> {
    use rayon::prelude::*;
    let drawn: Vec<Result<thumbnail::Thumbnail, thumbnail::ThumbnailError>> = photos
        .par_iter()
        // The photo itself, even when its path is not UTF-8 and the text lost some bytes.
        .map(|(path, overlay)| thumbnail::draw(&crate::photo::names::path_of(path), THUMBNAIL_WIDTH_PX, overlay))
        .collect();
    photos
        .iter()
        .zip(drawn)
        .enumerate()
        .map(|(i, ((path, _), t))| match t {
            Ok(t) => {
                let name = file_name(path);
                let stem =
                    Path::new(&name).file_stem().map_or_else(|| name.clone(), |s| s.to_string_lossy().into_owned());
                let src = format!("thumbs/{i:02}-{}.jpg", safe_file_name(&stem));
                files.add(src.clone(), t.jpeg);
                Cell::Image { src, alt: name, width_px: t.width_px, height_px: t.height_px }
            }
            Err(e) => Cell::Bad(format!("no thumbnail: {e}")),
        })
        .collect()
}

/// A verdict shown in a coloured banner at the top of the page.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    Accepted,
    /// Usable, with a caveat the reader must weigh.
    Warning,
    Rejected,
}

/// One table cell; `Bad` cells are highlighted (a failed gate, an outlier).
pub enum Cell {
    Text(String),
    Bad(String),
    Good(String),
    /// A thumbnail (path relative to the report) with its alternative text.
    Image {
        src: String,
        alt: String,
        width_px: u32,
        height_px: u32,
    },
}

impl From<String> for Cell {
    fn from(s: String) -> Self {
        Cell::Text(s)
    }
}

impl From<&str> for Cell {
    fn from(s: &str) -> Self {
        Cell::Text(s.to_string())
    }
}

/// An HTML page assembled section by section.
pub struct Page {
    title: String,
    body: String,
}

const STYLE: &str = "body{font-family:sans-serif;max-width:1100px;margin:1em auto;padding:0 1em;color:#222}\
h1{font-size:1.5em}h2{font-size:1.2em;margin-top:1.6em;border-bottom:1px solid #ccc}\
table{border-collapse:collapse;margin:.5em 0}td,th{border:1px solid #ccc;padding:.25em .5em;text-align:left;vertical-align:top}\
th{background:#f3f3f3}td.num{text-align:right;font-variant-numeric:tabular-nums}\
.bad{background:#fde2e2;color:#8b0000}.good{background:#e3f4e3}\
.verdict{font-size:1.2em;font-weight:bold;padding:.5em 1em;margin:1em 0}\
.verdict.accepted{background:#e3f4e3;border:2px solid #2e7d32}.verdict.rejected{background:#fde2e2;border:2px solid #b71c1c}\
.verdict.warning{background:#fff4d6;border:2px solid #b26a00}\
figure{display:inline-block;margin:.5em 1em .5em 0;vertical-align:top}figcaption{font-size:.9em;max-width:520px;color:#444}\
img{max-width:100%;height:auto}td img{max-width:none}.note{color:#555;font-size:.95em}code{background:#f3f3f3;padding:0 .2em}";

impl Page {
    pub fn new(title: &str) -> Self {
        Page { title: title.to_string(), body: String::new() }
    }

    pub fn heading(&mut self, text: &str) {
        let _ = writeln!(self.body, "<h2>{}</h2>", escape(text));
    }

    pub fn paragraph(&mut self, text: &str) {
        let _ = writeln!(self.body, "<p>{}</p>", escape(text));
    }

    pub fn note(&mut self, text: &str) {
        let _ = writeln!(self.body, "<p class=\"note\">{}</p>", escape(text));
    }

    pub fn verdict(&mut self, verdict: Verdict, text: &str) {
        let class = match verdict {
            Verdict::Accepted => "accepted",
            Verdict::Warning => "warning",
            Verdict::Rejected => "rejected",
        };
        let _ = writeln!(self.body, "<div class=\"verdict {class}\">{}</div>", escape(text));
    }

    /// Lines of preformatted text (a command's terminal summary).
    pub fn preformatted(&mut self, text: &str) {
        let _ = writeln!(self.body, "<pre>{}</pre>", escape(text));
    }

    /// A figure: an image file beside the page (relative path) with its caption.
    pub fn figure(&mut self, src: &str, alt: &str, caption: &str, size: (u32, u32)) {
        let _ = writeln!(
            self.body,
            "<figure><img src=\"{}\" alt=\"{}\" width=\"{}\" height=\"{}\"><figcaption>{}</figcaption></figure>",
            escape(src),
            escape(alt),
            size.0,
            size.1,
            escape(caption)
        );
    }

    /// A table; `numeric[i]` right-aligns column `i`.
    pub fn table(&mut self, header: &[&str], numeric: &[bool], rows: Vec<Vec<Cell>>) {
        self.body.push_str("<table>\n<tr>");
        for h in header {
            let _ = write!(self.body, "<th>{}</th>", escape(h));
        }
        self.body.push_str("</tr>\n");
        for row in rows {
            self.body.push_str("<tr>");
            for (i, cell) in row.into_iter().enumerate() {
                let num = numeric.get(i).copied().unwrap_or(false);
                let td = |kind: &str| match (kind, num) {
                    ("", false) => "<td>".to_string(),
                    ("", true) => "<td class=\"num\">".to_string(),
                    (k, false) => format!("<td class=\"{k}\">"),
                    (k, true) => format!("<td class=\"{k} num\">"),
                };
                let _ = match cell {
                    Cell::Text(t) => write!(self.body, "{}{}</td>", td(""), escape(&t)),
                    Cell::Bad(t) => write!(self.body, "{}{}</td>", td("bad"), escape(&t)),
                    Cell::Good(t) => write!(self.body, "{}{}</td>", td("good"), escape(&t)),
                    Cell::Image { src, alt, width_px, height_px } => write!(
                        self.body,
                        "<td><img src=\"{}\" alt=\"{}\" width=\"{width_px}\" height=\"{height_px}\"></td>",
                        escape(&src),
                        escape(&alt)
                    ),
                };
            }
            self.body.push_str("</tr>\n");
        }
        self.body.push_str("</table>\n");
    }

    pub fn html(&self) -> String {
        format!(
            "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
             <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n\
             <title>{title}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n<h1>{title}</h1>\n{body}\
             <p class=\"note\">{FOOTER_MARK} {version}. Self-contained: open this file offline; \
             the plots and thumbnails are the files beside it.</p>\n</body>\n</html>\n",
            title = escape(&self.title),
            body = self.body,
            version = env!("CARGO_PKG_VERSION"),
        )
    }
}

/// The files of one report, relative to its folder. The folder is written whole into a
/// temporary folder and swapped in with one rename ([`replace_dir_atomically`]): a reader, a
/// crash or a kill sees the old report or the new one, never a page beside another run's
/// plots, and no thumbnail of an earlier run stays.
#[derive(Default)]
pub struct ReportFiles {
    files: Vec<(PathBuf, Vec<u8>)>,
}

impl ReportFiles {
    pub fn add(&mut self, relative: impl Into<PathBuf>, bytes: Vec<u8>) {
        self.files.push((relative.into(), bytes));
    }

    /// Total size of the files so far, bytes.
    pub fn size_bytes(&self) -> usize {
        self.files.iter().map(|(_, b)| b.len()).sum()
    }

    /// Replaces the folder `dir` (created if missing) with these files and `index.html`.
    /// Returns the path of `index.html`.
    pub fn write(self, dir: &Path, page: &Page) -> Result<PathBuf, ReportError> {
        let io = |path: &Path, cause| ReportError::Io { path: path.display().to_string(), cause };
        replace_dir_atomically(dir, |tmp| {
            for (rel, bytes) in &self.files {
                let path = tmp.join(rel);
                if let Some(parent) = path.parent() {
                    std::fs::create_dir_all(parent)?;
                }
                std::fs::write(&path, bytes)?;
            }
            std::fs::write(tmp.join("index.html"), page.html().as_bytes())
        })
        .map_err(|e| io(dir, e))?;
        Ok(dir.join("index.html"))
    }
}

/// Whether the folder `dir` may be replaced by a report: it does not exist, is empty, or
/// holds an fslcal report and nothing else (`index.html` written by fslcal, `plots/`,
/// `thumbs/`). Writing a report replaces the whole folder, so a folder of photos or notes
/// given by mistake must be refused, not emptied.
pub fn replaceable_report_folder(dir: &Path) -> Result<(), ForeignFolder> {
    let entries = match std::fs::read_dir(dir) {
        Ok(e) => e,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(()),
        Err(_) if dir.exists() => return Err(ForeignFolder::NotAFolder),
        Err(_) => return Ok(()),
    };
    let names: Vec<String> =
        entries.filter_map(|e| e.ok()).map(|e| e.file_name().to_string_lossy().into_owned()).collect();
    if names.is_empty() {
        return Ok(());
    }
    let ours = std::fs::read(dir.join("index.html"))
        .is_ok_and(|html| html.windows(FOOTER_MARK.len()).any(|w| w == FOOTER_MARK.as_bytes()));
    let mut foreign: Vec<String> =
        names.into_iter().filter(|n| !matches!(n.as_str(), "index.html" | "plots" | "thumbs")).collect();
    foreign.sort();
    match (ours, foreign.is_empty()) {
        (true, true) => Ok(()),
        (false, _) => Err(ForeignFolder::NotAReport),
        (true, false) => Err(ForeignFolder::OtherFiles(foreign.join(", "))),
    }
}

/// Why a folder cannot take a report.
#[derive(Debug, PartialEq, thiserror::Error)]
pub enum ForeignFolder {
    #[error("a file, not a folder")]
    NotAFolder,
    #[error("a folder that is not an fslcal report (writing the report would replace everything in it)")]
    NotAReport,
    #[error("an fslcal report with other files in it ({0}), which writing the report would delete")]
    OtherFiles(String),
}

/// What every page's footer says; tells a folder fslcal wrote from one it did not.
const FOOTER_MARK: &str = "Written by fslcal";

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escapes_markup_and_names() {
        assert_eq!(escape("<a href=\"x\">&'"), "&lt;a href=&quot;x&quot;&gt;&amp;&#39;");
        assert_eq!(safe_file_name("dive 3/photo #1.JPG"), "dive_3_photo__1.JPG");
    }

    #[test]
    fn writes_the_files_then_the_page_and_refers_to_nothing_outside() {
        let dir = tempfile::tempdir().unwrap();
        let mut page = Page::new("Test <report>");
        page.verdict(Verdict::Rejected, "REJECTED: span 0.3 m < 0.6 m");
        page.figure("plots/a.svg", "a", "caption", (10, 10));
        page.table(&["a", "b"], &[false, true], vec![vec!["x".into(), Cell::Bad("1.0".into())]]);
        let mut files = ReportFiles::default();
        files.add("plots/a.svg", b"<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"10\" height=\"10\"/>".to_vec());
        let index = files.write(&dir.path().join("r"), &page).unwrap();
        let html = std::fs::read_to_string(&index).unwrap();
        assert!(html.contains("<title>Test &lt;report&gt;</title>"));
        assert!(html.contains("<td class=\"bad num\">1.0</td>"));
        assert!(dir.path().join("r/plots/a.svg").is_file());
        assert!(!html.contains("http"), "the page must not refer to the network");
    }

    #[test]
    fn only_an_earlier_report_or_an_empty_folder_is_replaced() {
        let dir = tempfile::tempdir().unwrap();
        let r = dir.path().join("r");
        assert_eq!(replaceable_report_folder(&r), Ok(()), "missing");
        std::fs::create_dir(&r).unwrap();
        assert_eq!(replaceable_report_folder(&r), Ok(()), "empty");
        ReportFiles::default().write(&r, &Page::new("x")).unwrap();
        assert_eq!(replaceable_report_folder(&r), Ok(()), "an earlier report");
        std::fs::write(r.join("notes.txt"), b"mine").unwrap();
        assert_eq!(replaceable_report_folder(&r), Err(ForeignFolder::OtherFiles("notes.txt".into())));
        let photos = dir.path().join("photos");
        std::fs::create_dir(&photos).unwrap();
        std::fs::write(photos.join("photo_00.jpg"), b"jpeg").unwrap();
        assert_eq!(replaceable_report_folder(&photos), Err(ForeignFolder::NotAReport));
        let file = dir.path().join("file");
        std::fs::write(&file, b"x").unwrap();
        assert_eq!(replaceable_report_folder(&file), Err(ForeignFolder::NotAFolder));
    }
}
