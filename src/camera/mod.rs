//! The camera's intrinsics: calibrating them from checkerboard photos, the residuals and
//! sigmas that say how far to trust them, and the OpenCV FileStorage YAML they live in.

#[cfg(feature = "vision")]
pub mod calibrate;
pub mod opencv_yaml;
pub mod outcome;
pub mod residuals;
