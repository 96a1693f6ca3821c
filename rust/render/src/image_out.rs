//! A rendered frame — linear RGBA colour, depth, world normal per pixel, row 0 at the
//! top — and its outputs.

use std::path::Path;

use glam::{Vec3, Vec4};
use thicket_core::{Error, Result};

#[derive(Debug, Clone, PartialEq)]
pub struct Frame {
    pub width: u32,
    pub height: u32,
    /// Linear colour with straight (unpremultiplied) alpha; alpha 0 where the ray
    /// meets no surface.
    pub rgba: Vec<Vec4>,
    /// Distance in front of the camera along its view axis; infinite where empty.
    pub depth: Vec<f32>,
    /// Unit world-space normal; zero where empty.
    pub normal: Vec<Vec3>,
}

impl Frame {
    /// An empty frame (background: transparent, infinitely far).
    pub fn empty(width: u32, height: u32) -> Self {
        let n = width as usize * height as usize;
        Self { width, height, rgba: vec![Vec4::ZERO; n], depth: vec![f32::INFINITY; n], normal: vec![Vec3::ZERO; n] }
    }

    /// A frame whose pixel `(x, y)` (row 0 at the top) is `pixel(state, x, y)`: colour,
    /// depth and normal where a surface is hit, nothing (empty) elsewhere. Rows are
    /// filled in parallel, each worker with its own `init()` state.
    pub fn from_pixels<S>(
        width: u32,
        height: u32,
        init: impl Fn() -> S + Sync + Send,
        pixel: impl Fn(&mut S, usize, usize) -> Option<(Vec4, f32, Vec3)> + Sync + Send,
    ) -> Self {
        use rayon::prelude::*;
        let mut frame = Self::empty(width, height);
        let w = (width as usize).max(1);
        frame.rgba.par_chunks_mut(w).zip(frame.depth.par_chunks_mut(w)).zip(frame.normal.par_chunks_mut(w)).enumerate().for_each_init(
            init,
            |state, (y, ((rgba, depth), normal))| {
                for x in 0..rgba.len() {
                    if let Some((c, d, n)) = pixel(state, x, y) {
                        (rgba[x], depth[x], normal[x]) = (c, d, n);
                    }
                }
            },
        );
        frame
    }

    /// Share of the image the object covers: the mean alpha (each pixel a surface
    /// covers counts 1, a semi-transparent one its alpha).
    pub fn coverage(&self) -> f32 {
        self.rgba.iter().map(|c| c.w.clamp(0.0, 1.0)).sum::<f32>() / self.rgba.len().max(1) as f32
    }
}

/// Depth written to the OpenEXR `Z` channel where no surface was hit: Blender's own
/// background depth (render passes use 10¹⁰), finite so compositing maths stays finite.
pub const EXR_EMPTY_DEPTH: f32 = 1e10;

/// sRGB encoding of a linear value, clamped to `[0, 1]`.
fn srgb(linear: f32) -> f32 {
    let c = if linear.is_nan() { 0.0 } else { linear.clamp(0.0, 1.0) };
    if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

fn to_u8(v: f32) -> u8 {
    (v * 255.0).round().clamp(0.0, 255.0) as u8
}

fn file_error(path: &Path, message: impl Into<String>) -> Error {
    Error::File { path: path.display().to_string(), message: message.into() }
}

/// A clear error when the folder to write into does not exist.
fn require_folder(path: &Path) -> Result<()> {
    match path.parent() {
        Some(dir) if !dir.as_os_str().is_empty() && !dir.is_dir() => {
            Err(file_error(path, format!("cannot write: the folder {} does not exist", dir.display())))
        }
        _ => Ok(()),
    }
}

impl Frame {
    fn check_size(&self, path: &Path) -> Result<usize> {
        let n = self.width as usize * self.height as usize;
        if n == 0 || self.rgba.len() != n || self.depth.len() != n || self.normal.len() != n {
            return Err(file_error(path, format!("the frame's buffers do not hold {}x{} pixels", self.width, self.height)));
        }
        Ok(n)
    }

    /// 8-bit RGB, rows top-down: the frame over a linear `background` colour,
    /// sRGB-encoded (for pictures without transparency).
    pub fn rgb8_over(&self, background: Vec3) -> Vec<u8> {
        self.rgba
            .iter()
            .flat_map(|c| {
                let over = c.truncate() * c.w + background * (1.0 - c.w);
                [to_u8(srgb(over.x)), to_u8(srgb(over.y)), to_u8(srgb(over.z))]
            })
            .collect()
    }

    /// 8-bit RGBA, rows top-down: colour sRGB-encoded from linear, alpha straight.
    pub fn rgba8_top_down(&self) -> Vec<u8> {
        self.rgba.iter().flat_map(|c| [to_u8(srgb(c.x)), to_u8(srgb(c.y)), to_u8(srgb(c.z)), to_u8(c.w)]).collect()
    }

    /// Writes the colour as an 8-bit RGBA PNG (sRGB colour, straight alpha).
    pub fn save_png(&self, path: impl AsRef<Path>) -> Result<()> {
        let path = path.as_ref();
        self.check_size(path)?;
        require_folder(path)?;
        let picture = image::RgbaImage::from_raw(self.width, self.height, self.rgba8_top_down())
            .ok_or_else(|| file_error(path, "the frame's buffers do not match its size"))?;
        picture.save_with_format(path, image::ImageFormat::Png).map_err(|e| file_error(path, format!("cannot write the PNG: {e}")))
    }

    /// Writes one OpenEXR image (float32, lossless ZIP) with the channels `R`, `G`,
    /// `B`, `A` (linear colour, straight alpha), `Z` (depth along the view axis;
    /// [`EXR_EMPTY_DEPTH`] where empty) and `N.X`, `N.Y`, `N.Z` (unit world normal,
    /// zero where empty). Rows run top-down, as in the frame.
    pub fn save_exr(&self, path: impl AsRef<Path>) -> Result<()> {
        use exr::prelude::{AnyChannel, AnyChannels, Encoding, FlatSamples, Image, Layer, LayerAttributes, WritableImage};
        let path = path.as_ref();
        self.check_size(path)?;
        require_folder(path)?;
        let channel = |name: &str, values: Vec<f32>| AnyChannel::new(name, FlatSamples::F32(values));
        let channels = vec![
            channel("R", self.rgba.iter().map(|c| c.x).collect()),
            channel("G", self.rgba.iter().map(|c| c.y).collect()),
            channel("B", self.rgba.iter().map(|c| c.z).collect()),
            channel("A", self.rgba.iter().map(|c| c.w).collect()),
            channel("Z", self.depth.iter().map(|d| if d.is_finite() { *d } else { EXR_EMPTY_DEPTH }).collect()),
            channel("N.X", self.normal.iter().map(|n| n.x).collect()),
            channel("N.Y", self.normal.iter().map(|n| n.y).collect()),
            channel("N.Z", self.normal.iter().map(|n| n.z).collect()),
        ];
        let layer = Layer::new(
            (self.width as usize, self.height as usize),
            LayerAttributes::default(),
            Encoding::SMALL_LOSSLESS,
            AnyChannels::sort(channels.into_iter().collect()),
        );
        Image::from_layer(layer).write().to_file(path).map_err(|e| file_error(path, format!("cannot write the OpenEXR file: {e}")))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame() -> Frame {
        let mut f = Frame::empty(5, 3);
        // Pixel (x = 1, y = 0), top row: half-grey, opaque, 2.5 deep, facing +Z.
        f.rgba[1] = Vec4::new(0.5, 0.2, 1.0, 1.0);
        f.depth[1] = 2.5;
        f.normal[1] = Vec3::Z;
        f
    }

    fn temp_dir(name: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("thicket-render-{name}-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    #[test]
    fn png_is_written_and_read_back() {
        let f = frame();
        let dir = temp_dir("png");
        let path = dir.join("frame.png");
        f.save_png(&path).unwrap();
        let back = image::open(&path).unwrap().to_rgba8();
        assert_eq!(back.dimensions(), (5, 3));
        // sRGB(0.5) = 188, sRGB(0.2) = 124; alpha straight.
        assert_eq!(back.get_pixel(1, 0).0, [188, 124, 255, 255]);
        assert_eq!(back.get_pixel(0, 2).0, [0, 0, 0, 0]);
        assert_eq!(f.rgba8_top_down()[4..8], [188, 124, 255, 255]);
        // Over a white background: the opaque pixel keeps its colour, the empty one
        // is white.
        assert_eq!(f.rgb8_over(Vec3::ONE)[3..6], [188, 124, 255]);
        assert_eq!(f.rgb8_over(Vec3::ONE)[6 * 3..6 * 3 + 3], [255, 255, 255]);
        std::fs::remove_dir_all(dir).ok();
    }

    #[test]
    fn exr_is_written_and_read_back() {
        let f = frame();
        let dir = temp_dir("exr");
        let path = dir.join("frame.exr");
        f.save_exr(&path).unwrap();
        let image = exr::prelude::read_first_flat_layer_from_file(&path).unwrap();
        let layer = &image.layer_data;
        assert_eq!((layer.size.width(), layer.size.height()), (5, 3));
        let mut names: Vec<String> = layer.channel_data.list.iter().map(|c| c.name.to_string()).collect();
        names.sort();
        assert_eq!(names, ["A", "B", "G", "N.X", "N.Y", "N.Z", "R", "Z"]);
        let values = |name: &str| -> Vec<f32> {
            let c = layer.channel_data.list.iter().find(|c| c.name == *name).unwrap();
            c.sample_data.values_as_f32().collect()
        };
        assert_eq!(values("R")[1], 0.5);
        assert_eq!(values("A")[..3], [0.0, 1.0, 0.0]);
        assert_eq!(values("Z")[1], 2.5);
        assert_eq!(values("Z")[0], EXR_EMPTY_DEPTH);
        assert_eq!(values("N.Z")[1], 1.0);
        std::fs::remove_dir_all(dir).ok();
    }

    #[test]
    fn writing_into_a_missing_folder_names_the_file() {
        let f = frame();
        let path = std::env::temp_dir().join("thicket-render-no-such-folder").join("frame.png");
        for e in [f.save_png(&path).unwrap_err(), f.save_exr(path.with_extension("exr")).unwrap_err()] {
            match e {
                Error::File { path: p, message } => {
                    assert!(p.contains("thicket-render-no-such-folder") && p.contains("frame."), "{p}");
                    assert!(message.contains("does not exist"), "{message}");
                }
                e => panic!("{e:?}"),
            }
        }
        // A frame whose buffers do not match its size is an error too, not a panic.
        let mut bad = frame();
        bad.depth.pop();
        assert!(bad.save_exr(std::env::temp_dir().join("thicket-render-bad.exr")).is_err());
        assert!(Frame::empty(0, 0).save_png(std::env::temp_dir().join("thicket-render-empty.png")).is_err());
    }
}
