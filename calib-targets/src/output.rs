//! Writing scenes to disk: the photo as JPEG, its truth as JSON, the camera as OpenCV YAML.

use crate::fish::RenderedFish;
use crate::scene::RenderedScene;
use fslcal_core::CameraModel;
use image::RgbImage;
use serde::Serialize;
use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::Path;

/// JPEG quality of rendered photos: the TG-6's own fine JPEGs are about this.
pub const JPEG_QUALITY: u8 = 92;

fn write_atomically(path: &Path, write: impl FnOnce(&mut BufWriter<&File>) -> io::Result<()>) -> io::Result<()> {
    let tmp = path.with_extension(format!(
        "{}.tmp",
        path.extension().map(|e| e.to_string_lossy().into_owned()).unwrap_or_default()
    ));
    let result = (|| {
        let file = File::create(&tmp)?;
        {
            let mut w = BufWriter::new(&file);
            write(&mut w)?;
            w.flush()?;
        }
        file.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// Writes `DIR/NAME.jpg` and `DIR/NAME.truth.json`.
pub fn write_scene(dir: &Path, name: &str, scene: &RenderedScene) -> io::Result<()> {
    write_photo(dir, name, &scene.image, JPEG_QUALITY, &scene.truth)
}

/// Writes `DIR/NAME.jpg` at JPEG quality `quality` and its truth as `DIR/NAME.truth.json`.
pub fn write_photo(dir: &Path, name: &str, image: &RgbImage, quality: u8, truth: &impl Serialize) -> io::Result<()> {
    write_atomically(&dir.join(format!("{name}.jpg")), |w| {
        image::codecs::jpeg::JpegEncoder::new_with_quality(w, quality).encode_image(image).map_err(io::Error::other)
    })?;
    write_json(&dir.join(format!("{name}.truth.json")), truth)
}

/// Writes pretty JSON and a newline, atomically.
pub fn write_json(path: &Path, value: &impl Serialize) -> io::Result<()> {
    write_atomically(path, |w| {
        serde_json::to_writer_pretty(&mut *w, value).map_err(io::Error::other)?;
        w.write_all(b"\n")
    })
}

/// Writes a PNG atomically.
pub fn write_png(path: &Path, image: &RgbImage) -> io::Result<()> {
    write_atomically(path, |w| image.write_to(w, image::ImageFormat::Png).map_err(io::Error::other))
}

/// Writes `DIR/NAME.jpg`, its mask `DIR/NAME_mask.png` and `DIR/NAME.truth.json`.
pub fn write_fish(dir: &Path, name: &str, fish: &RenderedFish) -> io::Result<()> {
    write_atomically(&dir.join(format!("{name}.jpg")), |w| {
        image::codecs::jpeg::JpegEncoder::new_with_quality(w, JPEG_QUALITY)
            .encode_image(&fish.image)
            .map_err(io::Error::other)
    })?;
    write_atomically(&dir.join(format!("{name}_mask.png")), |w| {
        fish.mask.write_to(w, image::ImageFormat::Png).map_err(io::Error::other)
    })?;
    write_atomically(&dir.join(format!("{name}.truth.json")), |w| {
        serde_json::to_writer_pretty(&mut *w, &fish.truth).map_err(io::Error::other)?;
        w.write_all(b"\n")
    })
}

/// The camera as OpenCV's calibration sample writes it (FileStorage YAML).
pub fn camera_yaml(camera: &CameraModel) -> String {
    let d = camera.distortion.to_opencv();
    format!(
        "%YAML:1.0\n---\nimage_width: {}\nimage_height: {}\ncamera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ {:e}, 0., {:e}, 0., {:e}, {:e}, 0., 0., 1. ]\ndistortion_coefficients: !!opencv-matrix\n   rows: 1\n   cols: 5\n   dt: d\n   data: [ {:e}, {:e}, {:e}, {:e}, {:e} ]\n",
        camera.width_px, camera.height_px, camera.fx_px, camera.cx_px, camera.fy_px, camera.cy_px, d[0], d[1], d[2], d[3], d[4]
    )
}

/// Writes `camera.yml` atomically.
pub fn write_camera_yaml(path: &Path, camera: &CameraModel) -> io::Result<()> {
    write_atomically(path, |w| w.write_all(camera_yaml(camera).as_bytes()))
}
