//! The occupancy field the bake polygonizes: the placed textures (united), the partial
//! texture region blended with a base slab (figure 3.3), a moved region (chapter 7.2)
//! and holes (chapter 7.3), evaluated along a lattice column: everything but the
//! height `r` is fixed on a column, so each texture's `(s, t)` footprint, the region,
//! move and hole weights are found once and only the heights vary.

use super::bounds::MaxPyramid;
use super::effects::Effects;
use crate::texture::mapping::CellMap;
use crate::texture::volume::Column;
use crate::texture::TextureLayer;
use glam::{Vec2, Vec3};

pub(super) struct Occupancy<'a> {
    pub layers: &'a [TextureLayer],
    /// Region, holes, cutter and moved region ([`Effects`]).
    pub effects: &'a Effects,
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

impl Occupancy<'_> {
    fn footprints(&self, st: Vec2, out: &mut Vec<Column>) {
        footprints(self.layers, st, out);
    }

    #[inline]
    fn union(&self, footprints: &[Column], r: f32) -> f32 {
        union(self.layers, footprints, r)
    }

    /// An upper bound of the occupancy anywhere in the column over the triangle with
    /// corners `uv` (cell parameters) of cell `t`, all heights. Every factor of the
    /// blend is bounded on its own ([`Effects::bounds`]), the textures by their
    /// [`MaxPyramid`] over the `(s, t)` box of the corners; the base slab reaches 1.
    pub fn upper_bound(&self, t: usize, cell: &CellMap, uv: [(f32, f32); 3]) -> f32 {
        let w = uv.map(|(u, v)| cell.weights(u, v));
        let st = uv.map(|(u, v)| cell.texture(Vec3::new(u, v, 0.0)).truncate());
        let (lo, hi) = (st[0].min(st[1]).min(st[2]), st[0].max(st[1]).max(st[2]));
        let textures = || self.layers.iter().zip(self.bounds).map(|(l, b)| b.max_over(lo + l.offset, hi + l.offset)).fold(0.0, f32::max);
        let (textures_only, kept) = self.effects.bounds(t, &w);
        let bound = if textures_only { textures() } else { 1.0 };
        bound * kept
    }

    /// Occupancy at the lattice's [`Self::heights`] of the column at `(u, v)` of
    /// cell `t` (`cell` is its map), into `out`; `scratch` holds footprints.
    pub fn column(&self, t: usize, cell: &CellMap, uv: (f32, f32), out: &mut [f32], scratch: &mut Vec<Column>) {
        self.at_heights(t, cell, uv, self.heights, out, scratch);
    }

    /// Occupancy at one point `(u, v, r)` of cell `t`, between lattice points.
    pub fn at(&self, t: usize, cell: &CellMap, q: Vec3, scratch: &mut Vec<Column>) -> f32 {
        let mut out = [0.0];
        self.at_heights(t, cell, (q.x, q.y), &[q.z], &mut out, scratch);
        out[0]
    }

    /// Occupancy at `heights` of the column at `(u, v)` of cell `t`, into `out`.
    fn at_heights(&self, t: usize, cell: &CellMap, (u, v): (f32, f32), heights: &[f32], out: &mut [f32], scratch: &mut Vec<Column>) {
        let st = cell.texture(Vec3::new(u, v, 0.0)).truncate();
        let site = self.effects.site(t, &cell.weights(u, v), st);
        let (here, there) = site.needs();
        scratch.clear();
        self.footprints(st, scratch);
        if there {
            self.footprints(site.from, scratch);
        }
        let (placed, landed) = scratch.split_at(self.layers.len());
        let cutter = self.effects.has_cutter();
        for (a, &r) in out.iter_mut().zip(heights) {
            if cutter && self.effects.cut(cell.world(Vec3::new(u, v, r))) {
                *a = 0.0;
                continue;
            }
            let tex = if here { self.union(placed, r) } else { 0.0 };
            let moved = if there { self.union(landed, r) } else { 0.0 };
            *a = site.blend(self.effects, r, tex, moved);
        }
    }
}
