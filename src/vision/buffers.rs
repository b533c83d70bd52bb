//! Pixel buffers kept per thread between photos. A 4000x3000 colour photo is a 36 MB
//! buffer: allocated fresh for every photo, the kernel maps and zeroes its 9000 pages again
//! each time (an eighth of a run went to those page faults). A buffer here goes back to
//! its thread's spares when its photo is dropped, and the next photo of the same size is
//! decoded straight into it.

use opencv::core::Mat;
use opencv::prelude::*;
use std::cell::RefCell;

/// Spares kept per thread: a photo's colour, grey, half, quarter and eighth images. (With
/// four, a photo's five buffers dropped in that order pushed the colour one out, and every
/// photo's 36 MB decode faulted its pages in afresh: a tenth of `laser`'s time.)
const MAX_SPARES: usize = 5;

thread_local! {
    static SPARES: RefCell<Vec<Mat>> = const { RefCell::new(Vec::new()) };
}

/// A spare of exactly this shape and type from this thread, or an empty `Mat` (OpenCV's
/// `create` then allocates; into a matching spare it writes in place).
pub(super) fn take(rows: i32, cols: i32, typ: i32) -> Mat {
    SPARES
        .with(|s| {
            let mut s = s.borrow_mut();
            let i = s.iter().position(|m| m.rows() == rows && m.cols() == cols && m.typ() == typ)?;
            Some(s.swap_remove(i))
        })
        .unwrap_or_default()
}

/// A buffer that returns to its thread's spares when dropped.
pub struct Buffer(Mat);

impl Buffer {
    pub(super) fn new(m: Mat) -> Buffer {
        Buffer(m)
    }
}

impl std::ops::Deref for Buffer {
    type Target = Mat;
    fn deref(&self) -> &Mat {
        &self.0
    }
}

impl Drop for Buffer {
    fn drop(&mut self) {
        let m = std::mem::take(&mut self.0);
        if m.empty() {
            return;
        }
        // A thread being torn down has no spares left to keep it in.
        let _ = SPARES.try_with(|s| {
            let mut s = s.borrow_mut();
            s.push(m);
            if s.len() > MAX_SPARES {
                // The smallest goes: the largest cost the most to fault in again.
                let bytes = |m: &Mat| m.total() * m.elem_size().unwrap_or(1);
                let smallest = (0..s.len()).min_by_key(|&i| bytes(&s[i])).unwrap_or(0);
                s.swap_remove(smallest);
            }
        });
    }
}
