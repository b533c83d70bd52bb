//! Formatting into fixed stack buffers: the firmware has no allocator, and a screen line is
//! at most 21 characters of a 6-pixel font on a 128-pixel display.

use core::fmt;

/// A string of at most `N` bytes built with `write!`; text past the end is dropped (a
/// clipped line on the display is better than a failed screen).
#[derive(Clone, Copy)]
pub struct TextBuf<const N: usize> {
    bytes: [u8; N],
    len: usize,
}

impl<const N: usize> TextBuf<N> {
    pub const fn new() -> Self {
        TextBuf { bytes: [0; N], len: 0 }
    }

    pub fn as_str(&self) -> &str {
        // Only whole UTF-8 characters are ever copied in (see `write_str`).
        core::str::from_utf8(&self.bytes[..self.len]).unwrap_or("")
    }

    /// `format_args!` into a new buffer.
    pub fn from_fmt(args: fmt::Arguments) -> Self {
        let mut t = Self::new();
        let _ = fmt::write(&mut t, args);
        t
    }
}

impl<const N: usize> Default for TextBuf<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> fmt::Write for TextBuf<N> {
    fn write_str(&mut self, s: &str) -> fmt::Result {
        for ch in s.chars() {
            let mut utf8 = [0u8; 4];
            let enc = ch.encode_utf8(&mut utf8).as_bytes();
            if self.len + enc.len() > N {
                return Ok(());
            }
            self.bytes[self.len..self.len + enc.len()].copy_from_slice(enc);
            self.len += enc.len();
        }
        Ok(())
    }
}

impl<const N: usize> fmt::Debug for TextBuf<N> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Debug::fmt(self.as_str(), f)
    }
}

impl<const N: usize> PartialEq for TextBuf<N> {
    fn eq(&self, other: &Self) -> bool {
        self.as_str() == other.as_str()
    }
}

/// `text!(N, "...", args)`: a [`TextBuf`] of capacity `N`.
#[macro_export]
macro_rules! text {
    ($n:literal, $($arg:tt)*) => {
        $crate::text::TextBuf::<$n>::from_fmt(format_args!($($arg)*))
    };
}

#[cfg(test)]
mod tests {
    #[test]
    fn clips_at_capacity_on_a_character_boundary() {
        let t = text!(5, "{}±{}", 12, 345);
        assert_eq!(t.as_str(), "12±3");
        assert_eq!(text!(8, "{:.3} m", 2.34567).as_str(), "2.346 m");
    }
}
