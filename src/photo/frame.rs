//! The pixel grids a pixel can be measured in (the picture fslcal develops, the sensor's
//! whole readout the lab's tools develop, or an image known only by its size) and the exact
//! maps between them; also the lab's undistorted images, whose pixels are distorted back.
//!
//! fslcal develops a raw file's *picture*: the sensor's active area, as rawler reports it
//! (the maker note's crop, else the camera definition's). The TG-6's is 4000x3000 at
//! (8, 8) of a 4040x3016 readout ([`TG6`]). The FishSense lab's `fsl preprocess` develops
//! the whole readout, so its JPGs, the labels clicked on them and its `...-lens-raw.pkg`
//! lens calibrations are in the 4040x3016 frame: the same sensor pixel is 8 px right and
//! 8 px down of where it is in fslcal's picture. Every pixel that comes in is given its
//! [`Frame`] and mapped by a [`FrameMap`], which moves pixels and a camera's principal point
//! by the crop offset and changes nothing else (the focal lengths and the distortion are
//! the lens's, whatever the crop). A pair of sizes neither of which is a known crop of the
//! other is refused, naming both: a resized or differently cropped image cannot be placed.

use fslcal_core::{CameraModel, Vec2};

/// Where a sensor's picture sits in its whole readout.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SensorLayout {
    /// The camera model, as people name it.
    pub body: &'static str,
    /// The sensor's whole readout, pixels.
    pub readout_px: [u32; 2],
    /// The picture (the active area fslcal develops), pixels.
    pub picture_px: [u32; 2],
    /// The picture's top-left pixel in the readout.
    pub picture_origin_px: [u32; 2],
}

/// The Olympus TG-6: what rawler reports for it (its camera definition's crop, `[8, 8, 32,
/// 8]` from the left, top, right and bottom, and the same crop in the maker note the TG-6
/// writes) and the size of the lab's `fsl preprocess` JPGs (`original_width` x
/// `original_height` in their Label Studio exports).
pub const TG6: SensorLayout =
    SensorLayout { body: "TG-6", readout_px: [4040, 3016], picture_px: [4000, 3000], picture_origin_px: [8, 8] };

/// The sensors fslcal can place frames of.
pub const KNOWN_LAYOUTS: [SensorLayout; 1] = [TG6];

/// Which grid of a known sensor a frame is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FramePlace {
    /// The picture fslcal develops (the active area; also the camera's own JPEG).
    Picture(SensorLayout),
    /// The sensor's whole readout, as the lab's tools develop it.
    Readout(SensorLayout),
    /// Not a grid of a known sensor: only its size is known.
    Unplaced,
}

/// The pixel grid a pixel was measured in: its size and, when it is a grid of a known
/// sensor, where it sits on that sensor.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Frame {
    pub width_px: u32,
    pub height_px: u32,
    pub place: FramePlace,
}

impl Frame {
    /// The frame of an image of this size: placed on a known sensor when the size is one
    /// of its grids.
    pub fn of_size(width_px: u32, height_px: u32) -> Frame {
        let size = [width_px, height_px];
        let place = KNOWN_LAYOUTS
            .iter()
            .find_map(|l| {
                if l.picture_px == size {
                    Some(FramePlace::Picture(*l))
                } else if l.readout_px == size {
                    Some(FramePlace::Readout(*l))
                } else {
                    None
                }
            })
            .unwrap_or(FramePlace::Unplaced);
        Frame { width_px, height_px, place }
    }

    /// The frame a camera's intrinsics are in, by its image size.
    pub fn of_camera(camera: &CameraModel) -> Frame {
        Frame::of_size(camera.width_px, camera.height_px)
    }

    /// The frame fslcal develops photos of the same sensor in: a readout's picture, any
    /// other frame itself.
    pub fn developed(&self) -> Frame {
        match self.place {
            FramePlace::Readout(l) => {
                Frame { width_px: l.picture_px[0], height_px: l.picture_px[1], place: FramePlace::Picture(l) }
            }
            _ => *self,
        }
    }

    /// Top-left pixel of this grid in its sensor's readout, when placed.
    fn readout_origin_px(&self) -> Option<[u32; 2]> {
        match self.place {
            FramePlace::Picture(l) => Some(l.picture_origin_px),
            FramePlace::Readout(_) => Some([0, 0]),
            FramePlace::Unplaced => None,
        }
    }

    /// `4040x3016 (the TG-6's whole sensor readout, as the lab's tools develop it)`.
    pub fn describe(&self) -> String {
        let size = format!("{}x{}", self.width_px, self.height_px);
        match self.place {
            FramePlace::Picture(l) => format!("{size} (the {}'s picture, as fslcal develops it)", l.body),
            FramePlace::Readout(l) => {
                format!("{size} (the {}'s whole sensor readout, as the lab's tools develop it)", l.body)
            }
            FramePlace::Unplaced => size,
        }
    }

    /// The exact map from pixels of this frame to pixels of `to`: the identity between
    /// frames of one size, the crop offset between two grids of one sensor.
    pub fn map_to(&self, to: &Frame) -> Result<FrameMap, FrameError> {
        let size = |f: &Frame| [f.width_px, f.height_px];
        if size(self) == size(to) {
            return Ok(FrameMap { shift_px: Vec2::zeros(), to: *to });
        }
        let same_sensor = match (self.place, to.place) {
            (FramePlace::Picture(a) | FramePlace::Readout(a), FramePlace::Picture(b) | FramePlace::Readout(b)) => {
                a == b
            }
            _ => false,
        };
        match (self.readout_origin_px(), to.readout_origin_px()) {
            (Some(a), Some(b)) if same_sensor => {
                Ok(FrameMap { shift_px: Vec2::new(a[0] as f64 - b[0] as f64, a[1] as f64 - b[1] as f64), to: *to })
            }
            _ => Err(FrameError::CannotPlace { from: size(self), to: size(to) }),
        }
    }
}

impl std::fmt::Display for Frame {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}x{}", self.width_px, self.height_px)
    }
}

/// Why pixels of one frame cannot be used in another.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum FrameError {
    #[error(
        "pixels measured on a {}x{} image cannot be placed on fslcal's {}x{} image: neither is a known crop of the other (fslcal knows the TG-6's 4040x3016 sensor readout and its 4000x3000 picture at (8, 8)); a resized or cropped image's pixels cannot be used",
        from[0], from[1], to[0], to[1]
    )]
    CannotPlace { from: [u32; 2], to: [u32; 2] },
}

/// An exact map between two frames: `p_to = p_from + shift_px`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameMap {
    /// Added to every pixel, pixels; whole numbers, so adding it is exact for any pixel
    /// coordinate below 2^52.
    pub shift_px: Vec2,
    pub to: Frame,
}

impl FrameMap {
    pub fn is_identity(&self) -> bool {
        self.shift_px == Vec2::zeros()
    }

    pub fn pixel(&self, p: Vec2) -> Vec2 {
        p + self.shift_px
    }

    /// The same lens in the target frame: the principal point moves with the crop, the
    /// focal lengths and the distortion (functions of the normalised image) do not.
    pub fn camera(&self, c: &CameraModel) -> CameraModel {
        CameraModel {
            width_px: self.to.width_px,
            height_px: self.to.height_px,
            cx_px: c.cx_px + self.shift_px.x,
            cy_px: c.cy_px + self.shift_px.y,
            ..*c
        }
    }

    /// `moved by (-8, -8) px`, or `unchanged`.
    pub fn describe(&self) -> String {
        if self.is_identity() {
            "unchanged".into()
        } else {
            format!("moved by ({:+}, {:+}) px", self.shift_px.x, self.shift_px.y)
        }
    }
}

/// What the image a pixel was clicked on showed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum ImageGeometry {
    /// The photo as the lens made it, distortion and all (fslcal's pictures, the camera's
    /// JPEGs).
    AsShot,
    /// Undistorted with the lens's own camera matrix kept (OpenCV's `undistort(img, K, D)`,
    /// which the lab's `fsl preprocess --lens-calibration` runs): a pixel there is
    /// `K · x` for the ideal normalised point `x`.
    Undistorted,
}

impl ImageGeometry {
    /// The as-shot pixel of a pixel on this kind of image, `camera` being the lens in the
    /// pixel's frame. `None` where the distortion model folds over (far outside the frame).
    pub fn as_shot(self, camera: &CameraModel, p: Vec2) -> Option<Vec2> {
        match self {
            ImageGeometry::AsShot => Some(p),
            ImageGeometry::Undistorted => {
                let x = Vec2::new((p.x - camera.cx_px) / camera.fx_px, (p.y - camera.cy_px) / camera.fy_px);
                let d = camera.pixel_of_normalised(x);
                (d.x.is_finite() && d.y.is_finite()).then_some(d)
            }
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            ImageGeometry::AsShot => "as-shot",
            ImageGeometry::Undistorted => "undistorted",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fslcal_core::Distortion;

    fn raw_frame_camera() -> CameraModel {
        CameraModel {
            width_px: 4040,
            height_px: 3016,
            fx_px: 2911.75,
            fy_px: 2912.5,
            cx_px: 2019.123456789,
            cy_px: 1509.0625,
            distortion: Distortion::from_opencv([-0.1175, 0.0512, 0.00091, -0.00042, -0.0139]),
        }
    }

    #[test]
    fn the_tg6_grids_are_placed_and_mapped_by_the_crop() {
        let readout = Frame::of_size(4040, 3016);
        let picture = Frame::of_size(4000, 3000);
        assert_eq!(readout.place, FramePlace::Readout(TG6));
        assert_eq!(readout.developed(), picture);
        let m = readout.map_to(&picture).unwrap();
        assert_eq!(m.shift_px, Vec2::new(-8.0, -8.0));
        assert_eq!(picture.map_to(&readout).unwrap().shift_px, Vec2::new(8.0, 8.0));
        assert!(picture.map_to(&picture).unwrap().is_identity());
        // Unknown sizes map only onto themselves; the refusal names both sizes.
        let small = Frame::of_size(800, 600);
        assert!(small.map_to(&Frame::of_size(800, 600)).unwrap().is_identity());
        let err = readout.map_to(&small).unwrap_err().to_string();
        assert!(err.contains("4040x3016") && err.contains("800x600"), "{err}");
        assert!(Frame::of_size(2000, 1500).map_to(&picture).is_err());
    }

    #[test]
    fn a_camera_moves_only_its_principal_point_and_comes_back_bit_exact() {
        let raw = raw_frame_camera();
        let to_picture = Frame::of_camera(&raw).map_to(&Frame::of_size(4000, 3000)).unwrap();
        let pic = to_picture.camera(&raw);
        assert_eq!((pic.width_px, pic.height_px), (4000, 3000));
        assert_eq!((pic.fx_px, pic.fy_px, pic.distortion), (raw.fx_px, raw.fy_px, raw.distortion));
        assert_eq!(pic.cx_px, raw.cx_px - 8.0);
        let back = Frame::of_camera(&pic).map_to(&Frame::of_camera(&raw)).unwrap().camera(&pic);
        assert_eq!(back, raw);
        // The same ray through the same sensor pixel in both frames.
        let p_raw = Vec2::new(1234.5, 2345.25);
        let (a, b) = (raw.ray(p_raw).unwrap(), pic.ray(to_picture.pixel(p_raw)).unwrap());
        assert!((a - b).norm() < 1e-15, "{a} {b}");
    }

    #[test]
    fn an_undistorted_pixel_is_distorted_back_to_where_the_lens_put_it() {
        let cam = raw_frame_camera();
        for p in [Vec2::new(300.0, 200.0), Vec2::new(2019.0, 1509.0), Vec2::new(3900.5, 2950.25)] {
            let x = cam.undistort(p).unwrap();
            let undistorted = Vec2::new(cam.fx_px * x.x + cam.cx_px, cam.fy_px * x.y + cam.cy_px);
            let back = ImageGeometry::Undistorted.as_shot(&cam, undistorted).unwrap();
            assert!((back - p).norm() < 1e-9, "{p} -> {back}");
            assert_eq!(ImageGeometry::AsShot.as_shot(&cam, p), Some(p));
        }
    }
}
