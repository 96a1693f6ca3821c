//! Output images to a [`Frame`]: both `Rgba32Float` targets are copied into one
//! mappable buffer, their rows padded to wgpu's 256-byte alignment, and unpacked.

use glam::{Vec3, Vec4};
use thicket_core::{Error, Result};

use super::device::Gpu;
use crate::image_out::Frame;

/// Bytes per texel of the output targets (four `f32`).
const TEXEL: u32 = 16;

/// Bytes of one image row in the buffer: `width` texels, rounded up to
/// `COPY_BYTES_PER_ROW_ALIGNMENT`.
pub fn padded_row(width: u32) -> u32 {
    let align = wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
    (width * TEXEL).div_ceil(align) * align
}

/// The mappable buffer for two images of `width × height`.
pub fn buffer(device: &wgpu::Device, width: u32, height: u32) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback"),
        size: 2 * padded_row(width) as u64 * height as u64,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    })
}

/// Records the copies of `color` and `normal_depth` into `buffer`.
pub fn copy(encoder: &mut wgpu::CommandEncoder, color: &wgpu::Texture, normal_depth: &wgpu::Texture, buffer: &wgpu::Buffer) {
    let (w, h) = (color.width(), color.height());
    let row = padded_row(w);
    for (k, texture) in [color, normal_depth].into_iter().enumerate() {
        encoder.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo { texture, mip_level: 0, origin: wgpu::Origin3d::ZERO, aspect: wgpu::TextureAspect::All },
            wgpu::TexelCopyBufferInfo {
                buffer,
                layout: wgpu::TexelCopyBufferLayout { offset: k as u64 * row as u64 * h as u64, bytes_per_row: Some(row), rows_per_image: Some(h) },
            },
            wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
        );
    }
}

/// Maps `buffer` (after its copies were submitted), waits and unpacks the frame.
pub fn read(gpu: &Gpu, buffer: &wgpu::Buffer, width: u32, height: u32) -> Result<Frame> {
    let (tx, rx) = std::sync::mpsc::channel();
    buffer.map_async(wgpu::MapMode::Read, .., move |r| {
        let _ = tx.send(r);
    });
    gpu.wait()?;
    match rx.recv() {
        Ok(Ok(())) => {}
        Ok(Err(e)) => return Err(Error::InvalidParameter(format!("reading the GPU image back failed: {e}"))),
        Err(_) => return Err(Error::InvalidParameter("reading the GPU image back never finished".into())),
    }
    let frame = {
        let view = buffer.get_mapped_range(..).map_err(|e| Error::InvalidParameter(format!("reading the GPU image back failed: {e}")))?;
        unpack(&view, width, height)
    };
    buffer.unmap();
    Ok(frame)
}

/// The frame from the two padded images (colour, then normal and depth) in `bytes`.
/// Pixels with any alpha keep their colour (the transparency of double mipmaps is
/// fractional); depth and normal only where a surface was hit (a non-zero normal).
pub fn unpack(bytes: &[u8], width: u32, height: u32) -> Frame {
    let row = padded_row(width) as usize;
    let image = row * height as usize;
    let texel = |at: usize| Vec4::from_array(bytemuck::pod_read_unaligned::<[f32; 4]>(&bytes[at..at + TEXEL as usize]));
    Frame::from_pixels(
        width,
        height,
        || (),
        |_, x, y| {
            let at = y * row + x * TEXEL as usize;
            let color = texel(at);
            let nd = texel(image + at);
            let normal = Vec3::new(nd.x, nd.y, nd.z);
            let surface = normal.length_squared() > 0.25;
            (color.w > 0.0).then(|| if surface { (color, nd.w, normal) } else { (color, f32::INFINITY, Vec3::ZERO) })
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_are_padded_to_256_bytes() {
        assert_eq!(padded_row(16), 256);
        assert_eq!(padded_row(1), 256);
        assert_eq!(padded_row(17), 512);
        assert_eq!(padded_row(1024), 16384);
    }

    #[test]
    fn padded_images_unpack() {
        let (w, h) = (3u32, 2u32);
        let row = padded_row(w) as usize;
        let mut bytes = vec![0u8; 2 * row * h as usize];
        let mut put = |offset: usize, v: [f32; 4]| {
            for (k, x) in v.iter().enumerate() {
                bytes[offset + 4 * k..offset + 4 * k + 4].copy_from_slice(&x.to_le_bytes());
            }
        };
        // Pixel (2, 1) covered; its normal and depth in the second image.
        put(row + 32, [0.1, 0.2, 0.3, 1.0]);
        put(row * 2 + row + 32, [0.0, 0.0, 1.0, 4.5]);
        // Pixel (0, 1): only a semi-transparent medium (double mipmaps), no surface.
        put(row, [0.5, 0.5, 0.5, 0.25]);
        let f = unpack(&bytes, w, h);
        assert_eq!(f.rgba[3], Vec4::new(0.5, 0.5, 0.5, 0.25));
        assert!(f.depth[3].is_infinite() && f.normal[3] == Vec3::ZERO);
        assert_eq!(f.rgba[5], Vec4::new(0.1, 0.2, 0.3, 1.0));
        assert_eq!(f.normal[5], Vec3::Z);
        assert_eq!(f.depth[5], 4.5);
        assert_eq!(f.rgba[0], Vec4::ZERO);
        assert!(f.depth[0].is_infinite() && f.normal[0] == Vec3::ZERO);
        assert_eq!(f.coverage(), 1.25 / 6.0);
    }
}
