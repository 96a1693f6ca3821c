//! Volumetric textures from and to files (thick surfaces, chapter 3.2: a volumetric
//! texture is a 3D grid of alpha, sliced from the shell's base `r = 0` to its outer
//! layer `r = 1`).
//!
//! - A **PNG stack**: a folder of PNG slices, one per `z`, in natural file-name order
//!   (`slice_2.png` before `slice_10.png`); the first is the base. Alpha is the alpha
//!   channel when some slice has one that is not opaque everywhere, otherwise the
//!   Rec. 709 luminance of the stored values; 8- and 16-bit images both work.
//! - An **OpenEXR file** holding the whole grid as one picture `nx` wide and `ny·nz`
//!   high, one float32 channel `A`, slice `z` in rows `z·ny..(z+1)·ny` counted from the
//!   bottom, and the int attribute `thicket.depth = nz`. Blender opens it as an image.
//!
//! Picture rows run top-down; texture `y` grows upward (`y = height - 1 - row`), as in
//! Blender's images, so a texture looks the same in Blender whichever way it is saved.

use std::cmp::Ordering;
use std::path::{Path, PathBuf};

use exr::meta::attribute::{AttributeValue, Text};
use exr::prelude::{AnyChannel, AnyChannels, Encoding, FlatSamples, Image, Layer, LayerAttributes, WritableImage};
use image::{ImageBuffer, ImageFormat, ImageReader, Luma};
use rayon::prelude::*;

use super::VolumeTexture;
use crate::{Error, Result};

/// The EXR header attribute holding the number of slices.
pub const DEPTH_ATTRIBUTE: &str = "thicket.depth";

/// A texture from a folder of PNG slices, a `.png` file (the stack of its folder, as
/// picked in a file browser) or a `.exr` file.
pub fn load(path: &Path) -> Result<VolumeTexture> {
    if path.is_dir() {
        load_png_stack(path)
    } else if !path.exists() {
        Err(file_error(path, "no such file or folder"))
    } else if has_extension(path, "exr") {
        load_exr(path)
    } else if has_extension(path, "png") {
        let dir = path.parent().filter(|d| !d.as_os_str().is_empty());
        load_png_stack(dir.unwrap_or(Path::new(".")))
    } else {
        Err(file_error(path, "not a texture: expected a folder of PNG slices, a .png or a .exr file"))
    }
}

/// A texture from the PNG slices of `dir` (other files are ignored).
pub fn load_png_stack(dir: &Path) -> Result<VolumeTexture> {
    let files = png_files(dir)?;
    let slices = files.par_iter().map(|f| read_slice(f)).collect::<Result<Vec<_>>>()?;
    let (w, h) = (slices[0].width, slices[0].height);
    for (slice, file) in slices.iter().zip(&files) {
        if (slice.width, slice.height) != (w, h) {
            let (name, first) = (file_name(file), file_name(&files[0]));
            let message = format!("{name} is {}x{} but {first} is {w}x{h}", slice.width, slice.height);
            return Err(file_error(dir, message));
        }
    }
    let use_alpha = slices.iter().any(|s| s.alpha.as_ref().is_some_and(|a| a.iter().any(|&v| v < 1.0)));
    let texels = w * h;
    let mut alpha = Vec::with_capacity(texels * slices.len());
    for slice in slices {
        match (use_alpha, slice.alpha) {
            (true, Some(a)) => alpha.extend(a),
            (true, None) => alpha.extend(std::iter::repeat_n(1.0, texels)),
            (false, _) => alpha.extend(slice.luminance),
        }
    }
    let nz = alpha.len() / texels;
    VolumeTexture::new([w, h, nz], alpha).map_err(|e| file_error(dir, e.to_string()))
}

/// Writes one 16-bit grayscale PNG per slice, `{prefix}_000.png`, … into `dir`
/// (created if missing) and returns their paths. Refuses a folder holding other PNG
/// files, as loading the folder back would read them as slices too.
pub fn save_png_stack(t: &VolumeTexture, dir: &Path, prefix: &str) -> Result<Vec<PathBuf>> {
    let [nx, ny, nz] = t.dims();
    let (w, h) = (to_u32(nx, dir)?, to_u32(ny, dir)?);
    std::fs::create_dir_all(dir).map_err(|e| file_error(dir, format!("cannot create the folder: {e}")))?;
    let paths: Vec<PathBuf> = (0..nz).map(|z| dir.join(format!("{prefix}_{z:03}.png"))).collect();
    if let Some(other) = png_files(dir).unwrap_or_default().into_iter().find(|f| !paths.contains(f)) {
        let message = format!("the folder already holds {}, which would load as a slice; pick an empty folder", file_name(&other));
        return Err(file_error(dir, message));
    }
    for (z, path) in paths.iter().enumerate() {
        let slice = &t.samples()[z * nx * ny..(z + 1) * nx * ny];
        let picture = ImageBuffer::from_fn(w, h, |x, row| {
            let a = slice[x as usize + nx * (ny - 1 - row as usize)];
            Luma([(a * 65535.0).round() as u16])
        });
        picture.save_with_format(path, ImageFormat::Png).map_err(|e| file_error(path, format!("cannot write the PNG: {e}")))?;
    }
    Ok(paths)
}

/// A texture from an OpenEXR file. Alpha comes from channel `A`, or `Y`, or `R`; an
/// `A` that is 1 everywhere (an opaque RGBA picture) gives way to `Y` or `R` when
/// there is one. Without the [`DEPTH_ATTRIBUTE`] the picture is a single slice.
pub fn load_exr(path: &Path) -> Result<VolumeTexture> {
    if !path.is_file() {
        return Err(file_error(path, "no such file"));
    }
    let image = exr::prelude::read_first_flat_layer_from_file(path).map_err(|e| file_error(path, format!("not a readable OpenEXR file: {e}")))?;
    let layer = &image.layer_data;
    let (w, h) = (layer.size.width(), layer.size.height());
    if w == 0 || h == 0 {
        return Err(file_error(path, format!("the image is empty ({w}x{h})")));
    }
    let channel = |name: &str| layer.channel_data.list.iter().find(|c| c.name == *name);
    let opaque = |c: &&AnyChannel<FlatSamples>| c.sample_data.values_as_f32().all(|v| v == 1.0);
    let channel = match channel("A").filter(|a| !opaque(a)) {
        Some(a) => a,
        None => channel("Y").or_else(|| channel("R")).or_else(|| channel("A")).ok_or_else(|| {
            let names: Vec<String> = layer.channel_data.list.iter().map(|c| c.name.to_string()).collect();
            file_error(path, format!("no channel A, Y or R to read alpha from (it has {})", names.join(", ")))
        })?,
    };
    if channel.sampling != exr::math::Vec2(1, 1) {
        return Err(file_error(path, format!("channel {} is subsampled", channel.name)));
    }
    let nz = depth(&layer.attributes, h).map_err(|message| file_error(path, message))?;
    let ny = h / nz;
    let values: Vec<f32> = channel.sample_data.values_as_f32().collect();
    let alpha: Vec<f32> = values.chunks_exact(w).rev().flatten().copied().collect();
    if let Some(i) = alpha.iter().position(|a| !a.is_finite()) {
        let (x, y, z) = (i % w, (i / w) % ny, i / (w * ny));
        let message = format!("channel {} has the non-finite value {} at x={x}, y={y}, slice {z}", channel.name, alpha[i]);
        return Err(file_error(path, message));
    }
    VolumeTexture::new([w, ny, nz], alpha).map_err(|e| file_error(path, e.to_string()))
}

/// Writes the texture as one OpenEXR picture (float32 channel `A`, lossless ZIP), the
/// layout [`load_exr`] reads back exactly.
pub fn save_exr(t: &VolumeTexture, path: &Path) -> Result<()> {
    let [nx, ny, nz] = t.dims();
    let depth = i32::try_from(nz).map_err(|_| file_error(path, format!("{nz} slices are too many for OpenEXR")))?;
    // Samples are rows (y, z) counted from the bottom; the file lists them top-down.
    let rows: Vec<f32> = t.samples().chunks_exact(nx).rev().flatten().copied().collect();
    let channel = AnyChannel::new("A", FlatSamples::F32(rows));
    let mut attributes = LayerAttributes::default();
    attributes.other.insert(Text::from(DEPTH_ATTRIBUTE), AttributeValue::I32(depth));
    let layer = Layer::new((nx, ny * nz), attributes, Encoding::SMALL_LOSSLESS, AnyChannels::sort(std::iter::once(channel).collect()));
    Image::from_layer(layer).write().to_file(path).map_err(|e| file_error(path, format!("cannot write the OpenEXR file: {e}")))
}

/// One decoded PNG slice, rows ordered bottom-up.
struct Slice {
    width: usize,
    height: usize,
    luminance: Vec<f32>,
    /// Present when the image has an alpha channel.
    alpha: Option<Vec<f32>>,
}

fn read_slice(path: &Path) -> Result<Slice> {
    let image = ImageReader::open(path)
        .map_err(|e| file_error(path, format!("cannot open: {e}")))?
        .decode()
        .map_err(|e| file_error(path, format!("not a readable PNG image: {e}")))?;
    let (width, height) = (image.width() as usize, image.height() as usize);
    if width == 0 || height == 0 {
        return Err(file_error(path, format!("the image is empty ({width}x{height})")));
    }
    let (color, has_alpha) = (image.color().has_color(), image.color().has_alpha());
    let mut luminance = vec![0.0; width * height];
    let mut alpha = has_alpha.then(|| vec![0.0; width * height]);
    for (x, row, p) in image.to_rgba32f().enumerate_pixels() {
        let i = x as usize + width * (height - 1 - row as usize);
        luminance[i] = if color { 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2] } else { p[0] };
        if let Some(a) = alpha.as_mut() {
            a[i] = p[3];
        }
    }
    Ok(Slice { width, height, luminance, alpha })
}

/// The PNG files of `dir` in natural order; none is an error.
fn png_files(dir: &Path) -> Result<Vec<PathBuf>> {
    if !dir.exists() {
        return Err(file_error(dir, "no such folder"));
    }
    let entries = std::fs::read_dir(dir).map_err(|e| file_error(dir, format!("cannot read the folder: {e}")))?;
    let mut files = Vec::new();
    for entry in entries {
        let path = entry.map_err(|e| file_error(dir, format!("cannot read the folder: {e}")))?.path();
        if path.is_file() && has_extension(&path, "png") {
            files.push(path);
        }
    }
    if files.is_empty() {
        return Err(file_error(dir, "the folder holds no PNG slices"));
    }
    files.sort_by(|a, b| natural_cmp(&file_name(a), &file_name(b)));
    Ok(files)
}

/// The number of slices from the header: [`DEPTH_ATTRIBUTE`] (int or text), 1 without it.
fn depth(attributes: &LayerAttributes, height: usize) -> std::result::Result<usize, String> {
    let depth = match attributes.other.get(&Text::from(DEPTH_ATTRIBUTE)) {
        None => return Ok(1),
        Some(AttributeValue::I32(d)) => usize::try_from(*d).ok(),
        Some(AttributeValue::Text(d)) => d.to_string().trim().parse().ok(),
        Some(_) => None,
    };
    match depth {
        Some(d) if d > 0 && height.is_multiple_of(d) => Ok(d),
        _ => Err(format!("{DEPTH_ATTRIBUTE} is not a whole number of slices that divides the height {height}")),
    }
}

/// Compares names with digit runs as numbers: `slice_2` < `slice_10`.
fn natural_cmp(a: &str, b: &str) -> Ordering {
    natural_key(a).cmp(&natural_key(b)).then_with(|| a.cmp(b))
}

#[derive(PartialEq, Eq, PartialOrd, Ord)]
enum Chunk<'a> {
    /// A digit run without leading zeros, ordered by length first.
    Number(usize, &'a str),
    Text(&'a str),
}

fn natural_key(name: &str) -> Vec<Chunk<'_>> {
    let mut key = Vec::new();
    let mut rest = name;
    while let Some(first) = rest.chars().next() {
        let digits = first.is_ascii_digit();
        let end = rest.find(|c: char| c.is_ascii_digit() != digits).unwrap_or(rest.len());
        let (chunk, tail) = rest.split_at(end);
        key.push(if digits {
            let n = chunk.trim_start_matches('0');
            Chunk::Number(n.len(), n)
        } else {
            Chunk::Text(chunk)
        });
        rest = tail;
    }
    key
}

fn file_error(path: &Path, message: impl Into<String>) -> Error {
    Error::File { path: path.display().to_string(), message: message.into() }
}

fn file_name(path: &Path) -> String {
    path.file_name().map_or_else(|| path.display().to_string(), |n| n.to_string_lossy().into_owned())
}

fn has_extension(path: &Path, ext: &str) -> bool {
    path.extension().is_some_and(|e| e.eq_ignore_ascii_case(ext))
}

fn to_u32(n: usize, path: &Path) -> Result<u32> {
    u32::try_from(n).map_err(|_| file_error(path, format!("{n} texels are too many for a PNG")))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fresh, empty folder under the system's temp dir, removed when dropped.
    struct TempDir(PathBuf);

    impl TempDir {
        fn new(name: &str) -> Self {
            use std::sync::atomic::{AtomicUsize, Ordering};
            static COUNTER: AtomicUsize = AtomicUsize::new(0);
            let n = COUNTER.fetch_add(1, Ordering::Relaxed);
            let dir = std::env::temp_dir().join(format!("thicket-io-{}-{n}-{name}", std::process::id()));
            let _ = std::fs::remove_dir_all(&dir);
            std::fs::create_dir_all(&dir).unwrap();
            Self(dir)
        }
    }

    impl std::ops::Deref for TempDir {
        type Target = Path;
        fn deref(&self) -> &Path {
            &self.0
        }
    }

    impl Drop for TempDir {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }

    fn message(e: Error) -> String {
        assert!(matches!(e, Error::File { .. }), "{e:?}");
        e.to_string()
    }

    fn wave() -> VolumeTexture {
        VolumeTexture::from_fn([7, 5, 4], |c| 0.5 + 0.5 * (9.0 * c.x + 5.0 * c.y * c.z).sin()).unwrap()
    }

    /// A hand-written EXR with the given channels of `w × h` f32 samples.
    fn write_exr(path: &Path, w: usize, h: usize, channels: &[(&str, Vec<f32>)], depth: Option<AttributeValue>) {
        let list = channels.iter().map(|(n, v)| AnyChannel::new(*n, FlatSamples::F32(v.clone()))).collect();
        let mut attributes = LayerAttributes::default();
        if let Some(d) = depth {
            attributes.other.insert(Text::from(DEPTH_ATTRIBUTE), d);
        }
        let layer = Layer::new((w, h), attributes, Encoding::UNCOMPRESSED, AnyChannels::sort(list));
        Image::from_layer(layer).write().to_file(path).unwrap();
    }

    #[test]
    fn exr_round_trip_is_exact() {
        let dir = TempDir::new("exr");
        let t = wave();
        let path = dir.join("wave.exr");
        save_exr(&t, &path).unwrap();
        assert_eq!(load_exr(&path).unwrap(), t);
        assert_eq!(load(&path).unwrap(), t);
    }

    #[test]
    fn png_round_trip_is_16_bit() {
        let dir = TempDir::new("png");
        let t = wave();
        let paths = save_png_stack(&t, &dir.join("made/here"), "slice").unwrap();
        assert_eq!(file_name(&paths[3]), "slice_003.png");
        let back = load_png_stack(&dir.join("made/here")).unwrap();
        assert_eq!(back.dims(), t.dims());
        for (a, b) in back.samples().iter().zip(t.samples()) {
            assert!((a - b).abs() <= 0.5 / 65535.0 + 1e-7, "{a} vs {b}");
        }
        assert_eq!(load(&paths[0]).unwrap(), back, "a .png file loads its folder's stack");
        // Saving again over the same slices is fine; over a larger stack it is refused.
        save_png_stack(&t, &dir.join("made/here"), "slice").unwrap();
        let small = VolumeTexture::new([2, 2, 1], vec![0.0; 4]).unwrap();
        let e = message(save_png_stack(&small, &dir.join("made/here"), "slice").unwrap_err());
        assert!(e.contains("slice_001.png"), "{e}");
    }

    #[test]
    fn slices_sort_in_natural_order() {
        let mut names = vec!["s_10.png", "s_2.png", "s_1.png", "s_010b.png", "a.png", "s_02.png"];
        names.sort_by(|a, b| natural_cmp(a, b));
        assert_eq!(names, ["a.png", "s_1.png", "s_02.png", "s_2.png", "s_10.png", "s_010b.png"]);
        // Slice value z/10 in files numbered without padding: order is by number.
        let dir = TempDir::new("natural");
        for z in 0..12u16 {
            image::GrayImage::from_pixel(2, 1, Luma([z as u8 * 20])).save(dir.join(format!("slice_{z}.png"))).unwrap();
        }
        std::fs::write(dir.join("notes.txt"), "not a slice").unwrap();
        let t = load_png_stack(&dir).unwrap();
        assert_eq!(t.dims(), [2, 1, 12]);
        for z in 0..12 {
            assert!((t.samples()[2 * z] - (z * 20) as f32 / 255.0).abs() < 1e-6);
        }
    }

    #[test]
    fn png_and_exr_agree_on_which_way_is_up() {
        let dir = TempDir::new("flip");
        let t = VolumeTexture::from_fn([3, 4, 2], |c| c.y).unwrap();
        save_exr(&t, &dir.join("t.exr")).unwrap();
        save_png_stack(&t, &dir.join("png"), "slice").unwrap();
        let (exr, png) = (load(&dir.join("t.exr")).unwrap(), load(&dir.join("png")).unwrap());
        assert_eq!(exr, t);
        for (a, b) in png.samples().iter().zip(t.samples()) {
            assert!((a - b).abs() < 1e-4, "{a} vs {b}");
        }
        // Row 0 of a picture is its top: the last y of the slice (of the last slice in
        // the EXR, whose base slice lies at the bottom).
        let top = image::open(dir.join("png/slice_000.png")).unwrap().to_luma16();
        assert_eq!(top.get_pixel(0, 0)[0], (0.875f32 * 65535.0).round() as u16);
        let file = exr::prelude::read_first_flat_layer_from_file(dir.join("t.exr")).unwrap();
        let rows: Vec<f32> = file.layer_data.channel_data.list[0].sample_data.values_as_f32().step_by(3).collect();
        assert_eq!(rows, [0.875, 0.625, 0.375, 0.125, 0.875, 0.625, 0.375, 0.125]);
    }

    #[test]
    fn alpha_channel_wins_unless_opaque_everywhere() {
        let dir = TempDir::new("alpha");
        // Slice 0 opaque everywhere, slice 1 with some transparency: alpha is used.
        image::RgbaImage::from_pixel(2, 2, image::Rgba([255, 255, 255, 255])).save(dir.join("a0.png")).unwrap();
        image::RgbaImage::from_pixel(2, 2, image::Rgba([255, 255, 255, 51])).save(dir.join("a1.png")).unwrap();
        // A slice without alpha in an alpha stack counts as opaque.
        image::RgbImage::from_pixel(2, 2, image::Rgb([0, 0, 0])).save(dir.join("a2.png")).unwrap();
        let t = load_png_stack(&dir).unwrap();
        for (z, expected) in [1.0, 0.2, 1.0].into_iter().enumerate() {
            assert!(t.samples()[4 * z..4 * z + 4].iter().all(|a| (a - expected).abs() < 1e-6), "slice {z}");
        }
        // Opaque everywhere: luminance of the stored values, Rec. 709 weights.
        let dir = TempDir::new("luma");
        image::RgbaImage::from_pixel(1, 1, image::Rgba([255, 0, 0, 255])).save(dir.join("a0.png")).unwrap();
        image::RgbImage::from_pixel(1, 1, image::Rgb([0, 255, 0])).save(dir.join("a1.png")).unwrap();
        let gray16 = ImageBuffer::<Luma<u16>, Vec<u16>>::from_pixel(1, 1, Luma([32768]));
        gray16.save(dir.join("a2.png")).unwrap();
        let t = load_png_stack(&dir).unwrap();
        let expected = [0.2126, 0.7152, 32768.0 / 65535.0];
        for (a, b) in t.samples().iter().zip(expected) {
            assert!((a - b).abs() < 1e-6, "{a} vs {b}");
        }
    }

    #[test]
    fn exr_channels_and_depth() {
        let dir = TempDir::new("channels");
        // No depth attribute: one slice; Y is used without A.
        let path = dir.join("y.exr");
        write_exr(&path, 2, 3, &[("Y", vec![0.0, 0.1, 0.2, 0.3, 0.4, 0.5])], None);
        let t = load_exr(&path).unwrap();
        assert_eq!(t.dims(), [2, 3, 1]);
        assert_eq!(t.samples(), &[0.4, 0.5, 0.2, 0.3, 0.0, 0.1]);
        // An opaque RGBA picture reads R; a text depth attribute works too.
        let path = dir.join("rgba.exr");
        let r = vec![0.25; 8];
        write_exr(&path, 2, 4, &[("A", vec![1.0; 8]), ("G", vec![0.0; 8]), ("R", r)], Some(AttributeValue::Text(Text::from("2"))));
        let t = load_exr(&path).unwrap();
        assert_eq!(t.dims(), [2, 2, 2]);
        assert!(t.samples().iter().all(|&a| a == 0.25));
        // An all-solid texture still round-trips through A.
        let solid = VolumeTexture::new([2, 2, 2], vec![1.0; 8]).unwrap();
        save_exr(&solid, &dir.join("solid.exr")).unwrap();
        assert_eq!(load_exr(&dir.join("solid.exr")).unwrap(), solid);
    }

    #[test]
    fn png_errors_name_the_file() {
        let dir = TempDir::new("png-errors");
        let missing = dir.join("nowhere");
        assert!(message(load(&missing).unwrap_err()).contains("nowhere"));
        assert!(message(load_png_stack(&missing).unwrap_err()).contains("no such folder"));
        // No PNG in the folder.
        std::fs::write(dir.join("readme.txt"), "hello").unwrap();
        let e = message(load_png_stack(&dir).unwrap_err());
        assert!(e.contains("png-errors") && e.contains("no PNG"), "{e}");
        // A text file named .png: the decoder's message is kept.
        std::fs::write(dir.join("slice_0.png"), "definitely not a picture").unwrap();
        let e = message(load_png_stack(&dir).unwrap_err());
        assert!(e.contains("slice_0.png") && e.contains("not a readable PNG"), "{e}");
        // Slices of different sizes.
        image::GrayImage::new(64, 64).save(dir.join("slice_0.png")).unwrap();
        image::GrayImage::new(64, 32).save(dir.join("slice_3.png")).unwrap();
        let e = message(load_png_stack(&dir).unwrap_err());
        assert!(e.contains("slice_3.png is 64x32 but slice_0.png is 64x64"), "{e}");
        // A zero-size PNG (hand-made: encoders refuse to write one).
        let zero = TempDir::new("zero");
        std::fs::write(zero.join("empty.png"), zero_size_png()).unwrap();
        let e = message(load_png_stack(&zero).unwrap_err());
        assert!(e.contains("empty.png"), "{e}");
        // Unsupported file type.
        let e = message(load(&dir.join("readme.txt")).unwrap_err());
        assert!(e.contains("readme.txt") && e.contains("not a texture"), "{e}");
    }

    #[test]
    fn exr_errors_name_the_file() {
        let dir = TempDir::new("exr-errors");
        let e = message(load(&dir.join("gone.exr")).unwrap_err());
        assert!(e.contains("gone.exr") && e.contains("no such file"), "{e}");
        std::fs::write(dir.join("junk.exr"), "not an exr").unwrap();
        let e = message(load_exr(&dir.join("junk.exr")).unwrap_err());
        assert!(e.contains("junk.exr") && e.contains("not a readable OpenEXR"), "{e}");
        for (name, bad) in [("nan.exr", f32::NAN), ("inf.exr", f32::INFINITY)] {
            let mut v = vec![0.5; 4];
            v[1] = bad;
            write_exr(&dir.join(name), 2, 2, &[("A", v)], None);
            let e = message(load_exr(&dir.join(name)).unwrap_err());
            assert!(e.contains(name) && e.contains("non-finite") && e.contains("x=1, y=1, slice 0"), "{e}");
        }
        write_exr(&dir.join("depth.exr"), 2, 3, &[("A", vec![0.5; 6])], Some(AttributeValue::I32(2)));
        let e = message(load_exr(&dir.join("depth.exr")).unwrap_err());
        assert!(e.contains("depth.exr") && e.contains("divides the height 3"), "{e}");
        write_exr(&dir.join("z.exr"), 2, 2, &[("Z", vec![0.5; 4])], None);
        let e = message(load_exr(&dir.join("z.exr")).unwrap_err());
        assert!(e.contains("z.exr") && e.contains("no channel A, Y or R") && e.contains("it has Z"), "{e}");
    }

    /// A PNG whose header says 0×0 (valid signature and checksums).
    fn zero_size_png() -> Vec<u8> {
        fn chunk(out: &mut Vec<u8>, kind: &[u8; 4], data: &[u8]) {
            out.extend((data.len() as u32).to_be_bytes());
            let body: Vec<u8> = kind.iter().chain(data).copied().collect();
            out.extend(&body);
            out.extend(crc32(&body).to_be_bytes());
        }
        fn crc32(bytes: &[u8]) -> u32 {
            let mut crc = !0u32;
            for &b in bytes {
                crc ^= b as u32;
                for _ in 0..8 {
                    crc = if crc & 1 == 1 { (crc >> 1) ^ 0xEDB8_8320 } else { crc >> 1 };
                }
            }
            !crc
        }
        let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
        chunk(&mut png, b"IHDR", &[0, 0, 0, 0, 0, 0, 0, 0, 8, 0, 0, 0, 0]);
        chunk(&mut png, b"IEND", &[]);
        png
    }
}
