//! What a command prints with `--json` when its photos gave no result: nothing to fit
//! (`laser`), no photo with a dot the calibration can judge (`check`), nothing measured
//! (`validate`). The error and every photo's line, so each photo's fate is said whatever
//! the verdict; the exit status is 1.

use serde::{Deserialize, Serialize};

/// A run that read photos and ended without a result. `P` is the command's per-photo line
/// (`laser`'s, `check`'s or `validate`'s `photos` entry).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct RefusedDocument<P> {
    pub schema_version: u32,
    /// The one-line error the command also prints on stderr.
    pub error: String,
    /// Every photo given, in order, with what became of it.
    pub photos: Vec<P>,
}

impl<P> RefusedDocument<P> {
    pub fn new(error: impl std::fmt::Display, photos: Vec<P>) -> Self {
        RefusedDocument { schema_version: super::SCHEMA_VERSION, error: error.to_string(), photos }
    }
}
