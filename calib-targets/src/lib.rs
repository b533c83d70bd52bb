//! Calibration targets and synthetic underwater scenes with ground truth.
