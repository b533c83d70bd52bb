//! Photo paths that are not valid UTF-8, found again from the text the reports carry.
//!
//! A photo's line in a result carries its path as text (`display()`), which replaces bytes
//! that are not UTF-8; the report's thumbnail is drawn later from that text, which then
//! names no file. The commands remember such paths when they take their photos, so that the
//! text leads back to the file.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, OnceLock};

fn table() -> &'static Mutex<HashMap<String, PathBuf>> {
    static TABLE: OnceLock<Mutex<HashMap<String, PathBuf>>> = OnceLock::new();
    TABLE.get_or_init(Default::default)
}

/// Remembers `path` when its text is not the path itself (only non-UTF-8 paths).
pub fn remember(path: &Path) {
    if path.to_str().is_none() {
        if let Ok(mut t) = table().lock() {
            t.insert(path.display().to_string(), path.to_path_buf());
        }
    }
}

/// The photo whose path displays as `text`.
pub fn path_of(text: &str) -> PathBuf {
    table().lock().ok().and_then(|t| t.get(text).cloned()).unwrap_or_else(|| PathBuf::from(text))
}

#[cfg(all(test, unix))]
mod tests {
    use super::*;
    use std::os::unix::ffi::OsStrExt;

    #[test]
    fn a_non_utf8_path_is_found_from_its_text() {
        let odd = Path::new(std::ffi::OsStr::from_bytes(b"/photos/dive\xff3.jpg"));
        let text = odd.display().to_string();
        assert_ne!(PathBuf::from(&text), odd, "the text alone names another file");
        remember(odd);
        assert_eq!(path_of(&text), odd);
        assert_eq!(path_of("/photos/plain.jpg"), PathBuf::from("/photos/plain.jpg"));
    }
}
