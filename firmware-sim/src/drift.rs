//! Has the laser moved since calibration? A dot on the calibrated line has its camera ray
//! meet the line (`DotFix::miss_m` = 0); when the mount is knocked, every dot misses it by a
//! similar amount. One stray dot (a reflection, a mis-detection) must not raise the alarm,
//! so the warning needs most of the recent dots off the line.

/// Dots remembered.
pub const DRIFT_WINDOW: usize = 8;
/// Of the remembered dots, this many must be off the line to warn.
pub const DRIFT_MIN_OFF: usize = 5;
/// A dot is off the line when its ray misses the line by more than this many pixels at the
/// dot's depth: about eight times the half-pixel localisation error of a detected dot, so
/// noise alone practically never crosses it, while a laser tilted by 0.1 deg out of the
/// plane of camera and beam (1.7 mm per metre, ~5 px at any range with f = 2900 px) does.
/// A tilt within that plane looks like a change of distance and no single dot can show it:
/// that is what the slate validation is for.
pub const DRIFT_OFF_LINE_PX: f64 = 4.0;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DriftMonitor {
    miss_px: [f32; DRIFT_WINDOW],
    len: usize,
    next: usize,
}

impl Default for DriftMonitor {
    fn default() -> Self {
        Self::new()
    }
}

impl DriftMonitor {
    pub const fn new() -> Self {
        DriftMonitor { miss_px: [0.0; DRIFT_WINDOW], len: 0, next: 0 }
    }

    pub fn push(&mut self, miss_px: f64) {
        self.miss_px[self.next] = miss_px as f32;
        self.next = (self.next + 1) % DRIFT_WINDOW;
        self.len = (self.len + 1).min(DRIFT_WINDOW);
    }

    /// Forget the dots so far: the diver has seen the warning; warn again only when fresh
    /// dots are off the line.
    pub fn acknowledge(&mut self) {
        *self = Self::new();
    }

    fn recent(&self) -> &[f32] {
        &self.miss_px[..self.len]
    }

    /// Remembered dots and how many of them are off the line.
    pub fn off_line(&self) -> (usize, usize) {
        let off = self.recent().iter().filter(|&&m| m as f64 > DRIFT_OFF_LINE_PX).count();
        (off, self.len)
    }

    pub fn warning(&self) -> bool {
        self.off_line().0 >= DRIFT_MIN_OFF
    }

    /// Median miss of the remembered dots, pixels.
    pub fn median_miss_px(&self) -> Option<f64> {
        let mut sorted = self.miss_px;
        let s = &mut sorted[..self.len];
        if s.is_empty() {
            return None;
        }
        s.sort_unstable_by(|a, b| a.total_cmp(b));
        let mid = s.len() / 2;
        Some(if s.len() % 2 == 1 { s[mid] as f64 } else { 0.5 * (s[mid - 1] as f64 + s[mid] as f64) })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn warns_only_when_most_recent_dots_are_off() {
        let mut d = DriftMonitor::new();
        for m in [0.3, 9.0, 0.2, 0.5, 12.0, 0.4, 0.3, 0.2] {
            d.push(m);
        }
        assert_eq!(d.off_line(), (2, 8));
        assert!(!d.warning());
        for m in [6.0, 7.0, 5.0] {
            d.push(m);
        }
        // Window now 0.5 12 0.4 0.3 0.2 6 7 5: four off.
        assert_eq!(d.off_line(), (4, 8));
        d.push(8.0);
        assert!(d.warning());
        assert_eq!(d.median_miss_px(), Some(5.5));
        d.acknowledge();
        assert_eq!(d.off_line(), (0, 0));
        assert!(!d.warning());
    }
}
