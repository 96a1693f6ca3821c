//! The occupancy field the bake polygonizes: the placed textures (united), the partial
//! texture region blended with a base slab (figure 3.3), a moved region (chapter 7.2)
//! and holes (chapter 7.3), evaluated along a lattice column: everything but the
//! height `r` is fixed on a column, so each texture's `(s, t)` footprint, the region,
//! move and hole weights are found once and only the heights vary.

use super::bounds::MaxPyramid;
use super::cutter::Cutter;
use super::uv_mask::UvMask;
use super::TextureLayer;
use crate::texture::mapping::CellMap;
use crate::texture::volume::Column;
use glam::{Vec2, Vec3};

pub(super) struct Field<'a> {
    pub layers: &'a [TextureLayer],
    pub tris: &'a [[u32; 3]],
    pub region: Option<&'a [f32]>,
    pub holes: Option<&'a [f32]>,
    pub cutter: Option<&'a Cutter>,
    /// Where the moved piece came from (a mask in `(s, t)`) and how far it went.
    pub moved: Option<(&'a UvMask, Vec2)>,
    /// Top of the base slab, in `r`.
    pub base_layer: f32,
    /// Layers along the directors (the slab's edge is one layer wide).
    pub layers_r: f32,
    /// Heights `r` of the lattice's layers, one per sample of a column.
    pub heights: &'a [f32],
    /// Per placed texture, its occupancy bounds.
    pub bounds: &'a [MaxPyramid],
}

/// Each texture's footprint at `st` (its offset added), appended to `out`.
fn footprints(layers: &[TextureLayer], st: Vec2, out: &mut Vec<Column>) {
    out.extend(layers.iter().map(|l| l.texture.column(st + l.offset)));
}

/// Union of the placed textures (max alpha, chapter 7.3) at height `r` over
/// `footprints` (one per layer).
#[inline]
fn union(layers: &[TextureLayer], footprints: &[Column], r: f32) -> f32 {
    layers.iter().zip(footprints).map(|(l, f)| l.texture.sample_column(f, r)).fold(0.0, f32::max)
}

impl Field<'_> {
    /// A per-vertex weight interpolated at barycentric weights `w` of cell `t`.
    #[inline]
    /// A per-vertex weight interpolated at barycentric `w` in cell `t`: exactly the
    /// corners' value where they agree (a region of weight 1 everywhere must blend in
    /// nothing, not a rounding error that moves samples across the iso-level).
    fn per_vertex(&self, values: Option<&[f32]>, t: usize, w: &[f32; 4]) -> Option<f32> {
        let c = self.tris[t];
        values.map(|v| {
            let corner = c.map(|i| v[i as usize].clamp(0.0, 1.0));
            if corner[0] == corner[1] && corner[1] == corner[2] {
                corner[0]
            } else {
                (0..3).map(|k| corner[k] * w[k]).sum::<f32>().clamp(0.0, 1.0)
            }
        })
    }

    fn footprints(&self, st: Vec2, out: &mut Vec<Column>) {
        footprints(self.layers, st, out);
    }

    #[inline]
    fn union(&self, footprints: &[Column], r: f32) -> f32 {
        union(self.layers, footprints, r)
    }

    /// An upper bound of the occupancy anywhere in the column over the triangle with
    /// corners `uv` (cell parameters) of cell `t`, all heights. Every factor of the
    /// blend in [`Self::column`] is bounded on its own: the per-vertex weights are linear
    /// in `(u, v)` (extremes at the corners), the textures by their [`MaxPyramid`] over
    /// the `(s, t)` box of the corners; the base slab (partial or moved regions) reaches 1.
    pub fn upper_bound(&self, t: usize, cell: &CellMap, uv: [(f32, f32); 3]) -> f32 {
        let w = uv.map(|(u, v)| cell.weights(u, v));
        let range = |values: Option<&[f32]>| {
            w.iter().filter_map(|w| self.per_vertex(values, t, w)).fold(None, |r: Option<(f32, f32)>, x| {
                Some(r.map_or((x, x), |(lo, hi)| (lo.min(x), hi.max(x))))
            })
        };
        let st = uv.map(|(u, v)| cell.texture(Vec3::new(u, v, 0.0)).truncate());
        let (lo, hi) = (st[0].min(st[1]).min(st[2]), st[0].max(st[1]).max(st[2]));
        let textures = || self.layers.iter().zip(self.bounds).map(|(l, b)| b.max_over(lo + l.offset, hi + l.offset)).fold(0.0, f32::max);
        // A moved region or a partial one shows the base slab.
        let full_presence = range(self.region).is_none_or(|(lo, _)| lo >= 1.0) && self.moved.is_none();
        let bound = if full_presence { textures() } else { 1.0 };
        let kept = range(self.holes).map_or(1.0, |(lo, _)| 1.0 - lo);
        bound * kept
    }

    /// Occupancy at the lattice's [`Self::heights`] of the column at `(u, v)` of
    /// cell `t` (`cell` is its map), into `out`; `scratch` holds footprints.
    pub fn column(&self, t: usize, cell: &CellMap, (u, v): (f32, f32), out: &mut [f32], scratch: &mut Vec<Column>) {
        let w = cell.weights(u, v);
        let st = cell.texture(Vec3::new(u, v, 0.0)).truncate();
        // Presence of the texture in place (1: texture, 0: base slab); a moved piece
        // leaves the base in its trace and shows where it landed.
        let mut presence = self.per_vertex(self.region, t, &w).unwrap_or(1.0);
        let mut arrived = 0.0;
        scratch.clear();
        self.footprints(st, scratch);
        if let Some((mask, d)) = &self.moved {
            presence *= 1.0 - mask.sample(st);
            arrived = mask.sample(st - *d);
            if arrived > 0.0 {
                self.footprints(st - *d, scratch);
            }
        }
        let kept = 1.0 - self.per_vertex(self.holes, t, &w).unwrap_or(0.0);
        let (here, there) = scratch.split_at(self.layers.len());
        for (a, &r) in out.iter_mut().zip(self.heights) {
            if self.cutter.is_some_and(|c| c.contains(cell.world(Vec3::new(u, v, r)))) {
                *a = 0.0;
                continue;
            }
            let base = ((self.base_layer - r) * self.layers_r + 0.5).clamp(0.0, 1.0);
            let tex = if presence > 0.0 { self.union(here, r) } else { 0.0 };
            let moved = if arrived > 0.0 { self.union(there, r) } else { 0.0 };
            *a = kept * (arrived * moved + (1.0 - arrived) * (presence * tex + (1.0 - presence) * base));
        }
    }
}
