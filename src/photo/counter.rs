//! How often this process has read and decoded photos. Decoding a 12-megapixel photo costs
//! more than anything else the tool does with it, so each command decodes a photo once;
//! `tests/decode_once.rs` holds every command to that with these counts.

use std::sync::atomic::{AtomicUsize, Ordering};

/// Photo reads and decodes since the process started (see [`counts`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PhotoCounts {
    /// Whole photo files read into memory.
    pub file_reads: usize,
    /// Reads of a photo's first MiB at most, for its EXIF or its size.
    pub header_reads: usize,
    /// Decodes to full resolution: a JPEG or PNG decoded, a raw's sensor read and developed.
    pub full_decodes: usize,
    /// Decodes to a reduced size only: libjpeg's DCT scaling, a raw binned without demosaic.
    pub reduced_decodes: usize,
}

impl std::ops::Sub for PhotoCounts {
    type Output = PhotoCounts;
    fn sub(self, o: PhotoCounts) -> PhotoCounts {
        PhotoCounts {
            file_reads: self.file_reads - o.file_reads,
            header_reads: self.header_reads - o.header_reads,
            full_decodes: self.full_decodes - o.full_decodes,
            reduced_decodes: self.reduced_decodes - o.reduced_decodes,
        }
    }
}

/// What is being counted.
#[derive(Clone, Copy, Debug)]
pub enum Event {
    FileRead,
    HeaderRead,
    FullDecode,
    ReducedDecode,
}

static COUNTS: [AtomicUsize; 4] = [AtomicUsize::new(0), AtomicUsize::new(0), AtomicUsize::new(0), AtomicUsize::new(0)];

/// Counts one event.
pub fn count(event: Event) {
    COUNTS[event as usize].fetch_add(1, Ordering::Relaxed);
}

/// The counts so far; the difference of two readings is what happened between them.
pub fn counts() -> PhotoCounts {
    let get = |e: Event| COUNTS[e as usize].load(Ordering::Relaxed);
    PhotoCounts {
        file_reads: get(Event::FileRead),
        header_reads: get(Event::HeaderRead),
        full_decodes: get(Event::FullDecode),
        reduced_decodes: get(Event::ReducedDecode),
    }
}
