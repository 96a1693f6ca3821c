//! The occupancy field the bake polygonizes: the placed textures (united), the partial
//! texture region blended with a base slab (figure 3.3), a moved region (chapter 7.2)
//! and holes (chapter 7.3), evaluated at a cell's parameters `(u, v, r)`.

use super::cutter::Cutter;
use super::uv_mask::UvMask;
use super::TextureLayer;
use crate::texture::mapping::CellMap;
use glam::{Vec2, Vec3};

pub(super) struct Field<'a> {
    pub layers: &'a [TextureLayer],
    pub tris: &'a [[u32; 3]],
    pub region: Option<&'a [f32]>,
    pub holes: Option<&'a [f32]>,
    pub cutter: Option<&'a Cutter>,
    /// Where the moved piece came from (a mask in `(s, t)`) and how far it went.
    pub moved: Option<(UvMask, Vec2)>,
    /// Top of the base slab, in `r`.
    pub base_layer: f32,
    /// Layers along the directors (the slab's edge is one layer wide).
    pub layers_r: f32,
}

impl Field<'_> {
    /// One texture and no region, holes, move or cutter: alpha is the texture itself,
    /// so a lattice column can be sampled along one footprint.
    pub fn single_texture(&self) -> Option<&TextureLayer> {
        let plain = self.region.is_none() && self.holes.is_none() && self.cutter.is_none() && self.moved.is_none();
        match self.layers {
            [layer] if plain => Some(layer),
            _ => None,
        }
    }

    /// Union of the placed textures at texture point `c` (max alpha, chapter 7.3).
    #[inline]
    fn texture(&self, c: Vec3) -> f32 {
        self.layers.iter().map(|l| l.texture.sample(c + l.offset.extend(0.0))).fold(0.0, f32::max)
    }

    /// A per-vertex weight interpolated at barycentric weights `w` of cell `t`.
    #[inline]
    fn per_vertex(&self, values: Option<&[f32]>, t: usize, w: &[f32; 4]) -> Option<f32> {
        let c = self.tris[t];
        values.map(|v| (0..3).map(|k| v[c[k] as usize].clamp(0.0, 1.0) * w[k]).sum())
    }

    /// Occupancy at parameters `q` of cell `t` (`cell` is its map).
    pub fn alpha(&self, t: usize, cell: &CellMap, q: Vec3) -> f32 {
        if self.cutter.is_some_and(|c| c.contains(cell.world(q))) {
            return 0.0;
        }
        let w = cell.weights(q.x, q.y);
        let c = cell.texture(q);
        let base = ((self.base_layer - q.z) * self.layers_r + 0.5).clamp(0.0, 1.0);
        // Presence of the texture in place (1: texture, 0: base slab).
        let mut presence = self.per_vertex(self.region, t, &w).unwrap_or(1.0);
        let mut arrived = 0.0;
        let mut moved = 0.0;
        if let Some((mask, d)) = &self.moved {
            let st = c.truncate();
            // The trace left behind shows the base; the piece shows where it landed.
            presence *= 1.0 - mask.sample(st);
            arrived = mask.sample(st - *d);
            if arrived > 0.0 {
                moved = self.texture(c - d.extend(0.0));
            }
        }
        let here = if presence > 0.0 { self.texture(c) } else { 0.0 };
        let alpha = arrived * moved + (1.0 - arrived) * (presence * here + (1.0 - presence) * base);
        alpha * (1.0 - self.per_vertex(self.holes, t, &w).unwrap_or(0.0))
    }
}
