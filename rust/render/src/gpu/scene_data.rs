//! The scene as the shaders read it: cells, per-corner gradient transforms and the
//! volume texture with its gradient (chapter 3.2: "the remaining texture channels are
//! used to store the gradient of the alpha values").

use bytemuck::{Pod, Zeroable};
use glam::{Mat3, Vec3};
use thicket_core::texture::CellMap;

/// A triangle prism as `Cell` in the shader: base corners with `s` in `w`, directors
/// with `t` in `w`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct GpuCell {
    pub corner: [[f32; 4]; 3],
    pub director: [[f32; 4]; 3],
}

impl GpuCell {
    pub fn new(c: &CellMap) -> Self {
        Self { corner: [0, 1, 2].map(|k| c.base[k].extend(c.st[k].x).to_array()), director: [0, 1, 2].map(|k| c.director[k].extend(c.st[k].y).to_array()) }
    }
}

/// `CellFrames` in the shader: `J_world^{-T}` (parameter gradients to world
/// gradients) at the six corners, `2k` on the base and `2k + 1` on the outer layer of
/// corner `k`; `mat3x3<f32>` columns are padded to 16 bytes.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct GpuFrames {
    pub corner: [[[f32; 4]; 3]; 6],
}

impl GpuFrames {
    /// The transforms at the corners (zero where the cell is degenerate).
    pub fn new(c: &CellMap) -> Self {
        let params = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let mut corner = [[[0.0; 4]; 3]; 6];
        for (k, q) in params.iter().enumerate() {
            for r in 0..2 {
                let m = corner_frame(c, q.with_z(r as f32));
                corner[2 * k + r] = [m.x_axis, m.y_axis, m.z_axis].map(|col| col.extend(0.0).to_array());
            }
        }
        Self { corner }
    }
}

/// `CellEffects` in the shader: the region and hole weights at a cell's three corners
/// (`w` unused), for [`thicket_core::texture::bake::Effects`] the GPU can draw.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct GpuEffects {
    pub region: [f32; 4],
    pub holes: [f32; 4],
}

/// The scene's per-vertex effects per cell (1 and 0 where a cutter or a moved
/// region comes without a region or holes): empty when there are none.
pub fn effects(scene: &crate::ShellScene) -> Vec<GpuEffects> {
    let e = &scene.effects;
    if e.is_none() {
        return Vec::new();
    }
    (0..scene.cells.len())
        .map(|t| {
            let (region, holes) = e.corner_weights(t);
            GpuEffects { region: [region[0], region[1], region[2], 0.0], holes: [holes[0], holes[1], holes[2], 0.0] }
        })
        .collect()
}

/// What the effects need besides the cells' corners: the moved region's mask in
/// `(s, t)` (a texture the shader reads texel by texel and interpolates as
/// [`thicket_core::texture::bake::Effects`] does on the CPU) and the cutter's
/// triangles in their bins (the shader runs the CPU's inside test,
/// [`thicket_core::texture::bake::Cutter::contains`]).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct EffectFields {
    pub moved: Option<MovedField>,
    pub cutter: Option<CutterField>,
}

/// The moved region's mask: its first texel's `(s, t)`, texel size, texel counts,
/// values (row by row) and how far it moved.
#[derive(Debug, Clone, PartialEq)]
pub struct MovedField {
    pub lo: [f32; 2],
    pub texel: f32,
    pub size: [usize; 2],
    pub value: Vec<f32>,
    pub offset: [f32; 2],
}

/// The cutter's triangles (three corners each), its bins' first `(x, y)`, bin size,
/// bins per side, and the bins as one list (offsets, then triangle indices).
#[derive(Debug, Clone, PartialEq)]
pub struct CutterField {
    pub corners: Vec<[f32; 4]>,
    pub first: [f32; 2],
    pub cell: f32,
    pub side: u32,
    pub bins: Vec<u32>,
}

impl EffectFields {
    /// Whether these are `scene`'s fields, compared in place (a moved region's mask
    /// can hold millions of texels: no copy of it per frame).
    pub fn are_of(&self, scene: &crate::ShellScene) -> bool {
        let e = &scene.effects;
        let moved = match (&self.moved, e.moved_raster()) {
            (None, None) => true,
            (Some(m), Some((r, d))) => m.lo == r.lo.to_array() && m.texel == r.texel && m.size == r.size && m.offset == d.to_array() && m.value == r.value,
            _ => false,
        };
        let cutter = match (&self.cutter, e.cutter()) {
            (None, None) => true,
            // The bins follow from the triangles.
            (Some(c), Some(cutter)) => {
                let tris = cutter.triangles();
                c.corners.len() == 3 * tris.len() && c.corners.iter().zip(tris.iter().flatten()).all(|(a, b)| a[..3] == b.to_array())
            }
            _ => false,
        };
        moved && cutter
    }
}

/// The scene's [`EffectFields`].
pub fn effect_fields(scene: &crate::ShellScene) -> EffectFields {
    let e = &scene.effects;
    let moved = e.moved_raster().map(|(r, d)| MovedField { lo: r.lo.to_array(), texel: r.texel, size: r.size, value: r.value.to_vec(), offset: d.to_array() });
    let cutter = e.cutter().map(|c| {
        let (tris, first, cell, side, bins) = c.flat_bins();
        let corners = tris.iter().flatten().map(|p| p.extend(0.0).to_array()).collect();
        CutterField { corners, first: first.to_array(), cell, side: side as u32, bins }
    });
    EffectFields { moved, cutter }
}

/// `Neighbours` in the shader: per side face of a cell (`u = 0`: corner 2 to corner
/// 0; `v = 0`: corner 0 to 1; `w = 0`: corner 1 to 2), the `(s, t)` that the cell
/// across the face has at the face's two corners, `(s_a, t_a, s_b, t_b)`; NaN where
/// the face is on the shell's boundary ([`NO_NEIGHBOUR`] in `s_a`). With them the shading pass tells whether
/// `alpha` jumps across a face (a UV seam, one tile per face, the shell's edge).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct GpuNeighbours {
    pub face: [[f32; 4]; 3],
}

/// `s_a` of a face on the shell's boundary (the shader's `NO_NEIGHBOUR`).
pub const NO_NEIGHBOUR: f32 = 3.0e38;

/// The corners `(a, b)` of each side face, in the shader's face order.
pub const SIDE_FACES: [(usize, usize); 3] = [(2, 0), (0, 1), (1, 2)];

/// The neighbours' texture coordinates across every side face. Cells meet where
/// two corners coincide: the same base point and the same director.
pub fn neighbours(cells: &[CellMap]) -> Vec<GpuNeighbours> {
    use std::collections::HashMap;
    type Corner = [u32; 6];
    let corner = |c: &CellMap, k: usize| -> Corner {
        let (b, d) = (c.base[k], c.director[k]);
        [b.x, b.y, b.z, d.x, d.y, d.z].map(|x| (x + 0.0).to_bits())
    };
    let mut edges: HashMap<(Corner, Corner), Vec<(u32, usize)>> = HashMap::with_capacity(cells.len() * 2);
    for (i, c) in cells.iter().enumerate() {
        for (f, (a, b)) in SIDE_FACES.iter().enumerate() {
            let (ka, kb) = (corner(c, *a), corner(c, *b));
            edges.entry((ka.min(kb), ka.max(kb))).or_default().push((i as u32, f));
        }
    }
    let mut out = vec![GpuNeighbours { face: [[NO_NEIGHBOUR; 4]; 3] }; cells.len()];
    for sharing in edges.values() {
        for &(i, f) in sharing {
            let Some(&(j, g)) = sharing.iter().find(|(j, _)| *j != i) else { continue };
            let (c, n) = (&cells[i as usize], &cells[j as usize]);
            let a = SIDE_FACES[f].0;
            let (na, nb) = SIDE_FACES[g];
            // The neighbour's corner at this cell's corner `a`, and at `b`.
            let (at_a, at_b) = if corner(n, na) == corner(c, a) { (na, nb) } else { (nb, na) };
            let (sa, sb) = (n.st[at_a], n.st[at_b]);
            out[i as usize].face[f] = [sa.x, sa.y, sb.x, sb.y];
        }
    }
    out
}

/// `J_world^{-T}` at parameters `q` of `c`.
fn corner_frame(c: &CellMap, q: Vec3) -> Mat3 {
    let (jw, _) = c.jacobians(q);
    let det = jw.determinant();
    if !(det.abs() > 1e-30 && det.is_finite()) {
        return Mat3::ZERO;
    }
    let m = jw.inverse().transpose();
    if m.is_finite() {
        m
    } else {
        Mat3::ZERO
    }
}

/// IEEE half-precision bits of `x`, rounded to nearest even; out-of-range values
/// saturate to the largest finite half (the gradient of a sharp step may be large).
pub fn f16_bits(x: f32) -> u16 {
    let bits = x.to_bits();
    let sign = ((bits >> 16) & 0x8000) as u16;
    let x = x.abs();
    if x.is_nan() {
        return sign | 0x7e00;
    }
    if x >= 65520.0 {
        return sign | 0x7bff;
    }
    if x < 6.103_515_6e-5 {
        // Subnormal half: multiples of 2^-24.
        let m = (x * 16_777_216.0).round_ties_even() as u16;
        return sign | m;
    }
    let b = x.to_bits();
    let exp = ((b >> 23) as i32) - 127 + 15;
    let mant = b & 0x7f_ffff;
    // Round the 23-bit mantissa to 10 bits, ties to even; a carry bumps the exponent.
    let mut h = ((exp as u32) << 10) | (mant >> 13);
    let rest = mant & 0x1fff;
    if rest > 0x1000 || (rest == 0x1000 && h & 1 == 1) {
        h += 1;
    }
    sign | h.min(0x7bff) as u16
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec2;

    fn f16_value(h: u16) -> f32 {
        let sign = if h & 0x8000 != 0 { -1.0 } else { 1.0 };
        let exp = ((h >> 10) & 0x1f) as i32;
        let mant = (h & 0x3ff) as f32;
        sign * if exp == 0 { mant * 2f32.powi(-24) } else { (1.0 + mant / 1024.0) * 2f32.powi(exp - 15) }
    }

    #[test]
    fn half_floats_round_to_nearest() {
        for x in [0.0, 0.5, 1.0, -2.0, 0.1, 0.333, 1e-5, 3e-8, 1000.7, 65504.0, -0.4999] {
            let y = f16_value(f16_bits(x));
            assert!((y - x).abs() <= x.abs() * 4.9e-4 + 3e-8, "{x} -> {y}");
        }
        assert_eq!(f16_bits(0.5), 0x3800);
        assert_eq!(f16_bits(1.0), 0x3c00);
        assert_eq!(f16_bits(-2.0), 0xc000);
        assert_eq!(f16_bits(1e9), 0x7bff);
        assert_eq!(f16_bits(f32::NAN) & 0x7e00, 0x7e00);
    }

    #[test]
    fn texels_hold_alpha_and_the_cpu_gradient() {
        let t = thicket_core::texture::VolumeTexture::from_fn([8, 6, 5], |c| (0.3 * c.x + 0.2 * c.z + 0.1 * (6.0 * c.y).sin()).fract()).unwrap();
        // The finest mip level, in the half floats the GPU gets.
        let texels: Vec<u16> = crate::mipmap::finest_level(&t).texels.iter().flat_map(|t| t.map(f16_bits)).collect();
        let [nx, ny, nz] = t.dims();
        assert_eq!(texels.len(), 4 * nx * ny * nz);
        for (x, y, z) in [(0, 0, 0), (3, 2, 1), (7, 5, 4), (1, 4, 2)] {
            let c = Vec3::new((x as f32 + 0.5) / nx as f32, (y as f32 + 0.5) / ny as f32, z as f32 / (nz - 1) as f32);
            let i = 4 * (x + nx * (y + ny * z));
            let g = t.gradient(c);
            let got = Vec3::new(f16_value(texels[i]), f16_value(texels[i + 1]), f16_value(texels[i + 2]));
            assert!((got - g).length() <= 2e-3 * (1.0 + g.length()), "{x} {y} {z}: {got} vs {g}");
            assert!((f16_value(texels[i + 3]) - t.sample(c)).abs() < 1e-3);
        }
    }

    #[test]
    fn neighbours_are_found_across_shared_faces() {
        // Two prisms sharing the edge (1, 0, 0)-(0, 1, 0), with different tiles.
        let d = Vec3::Z;
        let a = CellMap { count: 3, base: [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::ZERO], director: [d; 4], st: [Vec2::ZERO, Vec2::X, Vec2::Y, Vec2::ZERO] };
        let b = CellMap {
            count: 3,
            base: [Vec3::Y, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::ZERO],
            director: [d; 4],
            st: [Vec2::new(5.0, 6.0), Vec2::new(7.0, 8.0), Vec2::ZERO, Vec2::ZERO],
        };
        let n = neighbours(&[a, b]);
        // a's face w = 0 runs from its corner 1 (X) to corner 2 (Y): b has (7, 8) at X
        // and (5, 6) at Y.
        assert_eq!(n[0].face[2], [7.0, 8.0, 5.0, 6.0]);
        assert!(n[0].face[0][0] == NO_NEIGHBOUR && n[0].face[1][0] == NO_NEIGHBOUR);
        // b's face u = 0 runs from its corner 2 to corner 0 (boundary); v = 0 from
        // corner 0 (Y) to corner 1 (X): a has (0, 1) at Y and (1, 0) at X.
        assert_eq!(n[1].face[1], [0.0, 1.0, 1.0, 0.0]);
        assert!(n[1].face[0][0] == NO_NEIGHBOUR && n[1].face[2][0] == NO_NEIGHBOUR);
    }

    #[test]
    fn frames_carry_parameter_gradients() {
        let c = CellMap {
            count: 3,
            base: [Vec3::ZERO, Vec3::new(2.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.2), Vec3::ZERO],
            director: [Vec3::Z * 0.3, Vec3::new(0.1, 0.0, 0.4), Vec3::Z * 0.2, Vec3::ZERO],
            st: [Vec2::ZERO, Vec2::X, Vec2::Y, Vec2::ZERO],
        };
        let f = GpuFrames::new(&c);
        // Corner 1 on the outer layer: (u, v, r) = (1, 0, 1).
        let q = Vec3::new(1.0, 0.0, 1.0);
        let m = Mat3::from_cols_array_2d(&f.corner[3].map(|col| [col[0], col[1], col[2]]));
        let gp = Vec3::new(0.2, -0.7, 1.3);
        assert!((m * gp - c.parameter_gradient_to_world(q, gp)).length() < 1e-5);
        let cell = GpuCell::new(&c);
        assert_eq!(cell.corner[1], [2.0, 0.0, 0.0, 1.0]);
        assert_eq!(cell.director[2], [0.0, 0.0, 0.2, 1.0]);
    }
}
