//! Marching prisms over one cell's lattice ([`march_prism_centred`]: loops of six or more
//! crossings fanned from a centre vertex inside their prism), sampled only where the occupancy can change: the cell is
//! split into blocks (`block` lattice steps per edge, all heights); a block whose
//! [`Occupancy::upper_bound`] stays below the iso-level and whose rim samples (computed by
//! their owner cells) do too holds no surface and is skipped, so the neighbour sees the
//! same empty face. The other blocks are sampled and polygonized at the full lattice
//! resolution. Iso-vertices are computed once per lattice edge within the cell (a dense
//! slot table indexed by the edge's lower endpoint and its direction), placed on the
//! occupancy's crossing by [`crossing`]; those on the cell's rim carry a global edge
//! key so [`crate::polygonize::weld`] can join them with the neighbour's.

use super::lattice::{Lattice, Place};
use super::occupancy::Occupancy;
use crate::polygonize::marching::{centre_weights, crossing, linear, march_prism_centred, off_level, Refine};
use crate::polygonize::weld::{edge_key, Piece, UNSHARED};
use crate::texture::mapping::CellMap;
use crate::texture::volume::Column;
use crate::{shell::Shell, Mesh};
use glam::{IVec3, Vec3};
use rayon::prelude::*;

/// Everything a cell needs, shared by all cells.
pub(super) struct Cells<'a> {
    pub mesh: &'a Mesh,
    pub shell: &'a Shell,
    pub lattice: &'a Lattice,
    pub field: &'a Occupancy<'a>,
    /// Heights `r` of the lattice's layers (on the texture's slices when following it).
    pub heights: &'a [f32],
    /// Lattice steps per block edge (divides the lattice's `n`).
    pub block: u32,
    /// Skip blocks the bounds prove empty (off only to test that culling changes nothing).
    pub cull: bool,
    /// Per cell: its triangles are reversed ([`super::cell_flips`]).
    pub flips: &'a [bool],
    /// How far iso-vertices keep off the lattice points, per cell and per mesh vertex.
    pub margins: &'a Margins,
}

/// How close to a lattice point an iso-vertex may come, as a share of its lattice
/// edge ([`VERTEX_MARGIN`], more in twisted cells): per cell, and per mesh vertex the
/// most of the cells around it, which the iso-vertices on the cells' common sides
/// take (both cells then clamp alike).
pub(super) struct Margins {
    pub cell: Vec<f32>,
    pub vertex: Vec<f32>,
}

impl Margins {
    /// The margins of `triangles` (cells of `mesh` under `shell`) whose layers are
    /// `heights` apart. A cell's map is bilinear in `(u, v)` and `r`: a flat triangle
    /// between mapped iso-vertices is off the map's image by up to its twist, the
    /// directors' spread times the layer's height, over a lattice step (the
    /// narrowest altitude over `n`, which cancels). Where that is a sizeable share of
    /// a step (a knife edge's cap, fanned from its centre into cells 30 times thinner
    /// than the shell, whose directors turn 35 degrees across them) the sheets around
    /// a lattice point, [`VERTEX_MARGIN`] from it on either side, crossed: the
    /// margin grows with the twist ([`TWIST_MARGIN`]), up to [`MAX_VERTEX_MARGIN`].
    pub fn new(mesh: &Mesh, shell: &Shell, triangles: &[[u32; 3]], heights: &[f32]) -> Self {
        let layer = f64::from(heights.windows(2).map(|w| w[1] - w[0]).fold(0.0, f32::max));
        let p = mesh.positions();
        let cell: Vec<f32> = triangles
            .par_iter()
            .map(|t| {
                let d = t.map(|v| shell.directors[v as usize].as_dvec3());
                let spread = (0..3).map(|k| d[k].distance(d[(k + 1) % 3])).fold(0.0, f64::max);
                // The narrowest altitude of the cell's cross-section at r = 0, 1/2, 1.
                let narrowest = [0.0, 0.5, 1.0]
                    .iter()
                    .map(|&r| {
                        let x = t.map(|v| shell.point(p, v as usize, r).as_dvec3());
                        let longest = (0..3).map(|k| x[k].distance(x[(k + 1) % 3])).fold(0.0, f64::max);
                        (x[1] - x[0]).cross(x[2] - x[0]).length() / longest
                    })
                    .fold(f64::INFINITY, f64::min);
                let twist = layer * spread / narrowest;
                if twist.is_finite() {
                    (twist * TWIST_MARGIN).clamp(f64::from(VERTEX_MARGIN), f64::from(MAX_VERTEX_MARGIN)) as f32
                } else if spread == 0.0 {
                    VERTEX_MARGIN
                } else {
                    MAX_VERTEX_MARGIN
                }
            })
            .collect();
        let mut vertex = vec![VERTEX_MARGIN; mesh.vertex_count()];
        for (t, m) in triangles.iter().zip(&cell) {
            t.iter().for_each(|&v| vertex[v as usize] = vertex[v as usize].max(*m));
        }
        Self { cell, vertex }
    }
}

/// A block of a cell: the corners of its triangle (local lattice points), its small
/// triangles and the local points on the cell's rim.
struct Block {
    corners: [(u32, u32); 3],
    smalls: std::ops::Range<usize>,
    rim: Vec<usize>,
}

/// Per-thread buffers, reused from cell to cell.
#[derive(Default)]
pub(super) struct Scratch {
    ids: Vec<u64>,
    vals: Vec<f32>,
    /// Per local point: its column has been sampled.
    sampled: Vec<bool>,
    needed: Vec<usize>,
    footprints: Vec<Column>,
    slots: Vec<u32>,
    touched: Vec<usize>,
    ij: Vec<(u32, u32)>,
    /// `(i, j, l)` of every local point.
    ijl: Vec<IVec3>,
    /// Lattice gradient per local point, computed on first use (NaN: not yet).
    grads: Vec<std::cell::Cell<Vec3>>,
    /// Per vertex of the piece: the local point at the lower end of its lattice edge
    /// and its share of the edge from there (a loop's centre: none), for the centres
    /// of long loops.
    fracs: Vec<(usize, f32)>,
    /// Sizes of the last piece, to reserve the next.
    last: (usize, usize),
    /// Per local column: bit `l` set when layer `l` is inside (columns of at most 64
    /// layers); else 1 when any layer is.
    masks: Vec<u64>,
    /// The blocks and, block by block, their small triangles.
    blocks: Vec<Block>,
    smalls: Vec<[usize; 3]>,
    /// Blocks of this cell that may hold surface.
    mixed: Vec<usize>,
}

impl Scratch {
    /// The cell-independent tables: local points and blocks with their small triangles.
    fn prepare(&mut self, lat: &Lattice, layers: usize, block: u32) {
        if !self.ij.is_empty() {
            return;
        }
        self.ij = lat.local_points().collect();
        self.ijl = self.ij.iter().flat_map(|&(i, j)| (0..layers as i32).map(move |l| IVec3::new(i as i32, j as i32, l))).collect();
        let (n, k) = (lat.n, block);
        let on_rim = |(i, j): (u32, u32)| lat.place(i, j) != Place::Inside;
        for bi in 0..n / k {
            for bj in 0..n / k - bi {
                // The block's lower triangle, then its upper one where it exists.
                for upper in [false, true] {
                    if upper && bi + bj + 2 > n / k {
                        continue;
                    }
                    let (i0, j0) = (bi * k, bj * k);
                    let corners = if upper { [(i0 + k, j0), (i0 + k, j0 + k), (i0, j0 + k)] } else { [(i0, j0), (i0 + k, j0), (i0, j0 + k)] };
                    let start = self.smalls.len();
                    let mut rim = Vec::new();
                    for a in 0..k {
                        for b in 0..k {
                            let s = a + b;
                            let lower_small = if upper { s >= k } else { s < k };
                            let upper_small = if upper { s + 1 >= k } else { s + 1 < k };
                            let (i, j) = (i0 + a, j0 + b);
                            if lower_small && i + j < n {
                                self.smalls.push([(i, j), (i + 1, j), (i, j + 1)].map(|(i, j)| lat.local_index(i, j)));
                            }
                            if upper_small && i + j + 1 < n {
                                self.smalls.push([(i + 1, j), (i + 1, j + 1), (i, j + 1)].map(|(i, j)| lat.local_index(i, j)));
                            }
                        }
                    }
                    for (i, j) in lat.local_points() {
                        let inside = if upper { i <= i0 + k && j <= j0 + k && i + j >= i0 + j0 + k } else { i >= i0 && j >= j0 && i + j <= i0 + j0 + k };
                        if inside && on_rim((i, j)) {
                            rim.push(lat.local_index(i, j));
                        }
                    }
                    self.blocks.push(Block { corners, smalls: start..self.smalls.len(), rim });
                }
            }
        }
    }
}

impl Cells<'_> {
    /// `alpha` along the column at local point `(i, j)` of cell `t` (map `cell`), from
    /// the cell that owns the point, kept [`OFF_ISO`] off 0.5. The shell's base and
    /// outer layer and its side walls are outside.
    fn sample_column(&self, t: usize, cell: &CellMap, (i, j): (u32, u32), out: &mut [f32], footprints: &mut Vec<Column>) {
        let lat = self.lattice;
        if lat.on_wall(t, i, j) {
            out.fill(0.0);
            return;
        }
        let (o, oi, oj) = lat.owner(t, i, j);
        let owner = if o == t { *cell } else { CellMap::new(self.mesh, self.shell, &lat.tris[o], &lat.st[o]) };
        let n = lat.n as f32;
        self.field.column(o, &owner, (oi as f32 / n, oj as f32 / n), out, footprints);
        let m = out.len() - 1;
        out[0] = 0.0;
        out[m] = 0.0;
        for a in out.iter_mut() {
            *a = off_level(*a, 0.5, 1.0);
        }
    }

    /// Samples local point `p`'s column unless done, and its mask.
    fn ensure(&self, s: &mut Scratch, t: usize, cell: &CellMap, p: usize) {
        if s.sampled[p] {
            return;
        }
        let lm = self.heights.len();
        let column = &mut s.vals[p * lm..(p + 1) * lm];
        self.sample_column(t, cell, s.ij[p], column, &mut s.footprints);
        s.masks[p] = if lm <= 64 {
            column.iter().enumerate().fold(0u64, |bits, (l, a)| bits | (u64::from(*a >= 0.5) << l))
        } else {
            u64::from(column.iter().any(|a| *a >= 0.5))
        };
        let (i, j) = s.ij[p];
        let g = self.lattice.key(t, i, j) as u64 * lm as u64;
        s.ids[p * lm..(p + 1) * lm].iter_mut().enumerate().for_each(|(l, id)| *id = g + l as u64);
        s.sampled[p] = true;
    }

    /// Finds the blocks of cell `t` that may hold surface and samples their columns
    /// (and the columns beside them, for gradients).
    fn sample(&self, s: &mut Scratch, t: usize, cell: &CellMap) {
        let lat = self.lattice;
        let (n, lm) = (lat.n, self.heights.len());
        s.prepare(lat, lm, self.block);
        let points = s.ij.len();
        s.vals.resize(points * lm, 0.0);
        s.ids.resize(points * lm, 0);
        s.masks.clear();
        s.masks.resize(points, 0);
        s.sampled.clear();
        s.sampled.resize(points, false);
        s.mixed.clear();
        let blocks = std::mem::take(&mut s.blocks);
        for (b, block) in blocks.iter().enumerate() {
            let corners = block.corners.map(|(i, j)| (i as f32 / n as f32, j as f32 / n as f32));
            let mut mixed = !self.cull || self.field.upper_bound(t, cell, corners) >= 0.5;
            if !mixed {
                // The rim's samples come from the owner cells: check them as they are.
                for &p in &block.rim {
                    self.ensure(s, t, cell, p);
                    mixed |= s.masks[p] != 0;
                }
            }
            if mixed {
                s.mixed.push(b);
            }
        }
        // Every corner of a mixed block's small triangles, and its neighbours in (i, j).
        s.needed.clear();
        for &b in &s.mixed {
            for small in &s.smalls[blocks[b].smalls.clone()] {
                s.needed.extend_from_slice(small);
            }
        }
        let mut needed = std::mem::take(&mut s.needed);
        for k in 0..needed.len() {
            let (i, j) = s.ij[needed[k]];
            for (di, dj) in [(1i32, 0i32), (-1, 0), (0, 1), (0, -1)] {
                let (a, b) = (i as i32 + di, j as i32 + dj);
                if a >= 0 && b >= 0 && a + b <= n as i32 {
                    needed.push(lat.local_index(a as u32, b as u32));
                }
            }
        }
        for &p in &needed {
            self.ensure(s, t, cell, p);
        }
        s.needed = needed;
        s.blocks = blocks;
    }

    pub fn polygonize(&self, s: &mut Scratch, t: usize) -> Piece {
        let (lat, n, heights) = (self.lattice, self.lattice.n, self.heights);
        let lm = heights.len();
        let m = lm as u32 - 1;
        let cell = CellMap::new(self.mesh, self.shell, &lat.tris[t], &lat.st[t]);
        self.sample(s, t, &cell);
        let points = s.ij.len() * lm;
        let bitwise = lm <= 64;
        if s.slots.len() < points * EDGE_DIRECTIONS {
            s.slots = vec![u32::MAX; points * EDGE_DIRECTIONS];
        }
        let mut piece = Piece::with_capacity(s.last.0 + s.last.0 / 4, s.last.1 + s.last.1 / 4);
        // Orientation: triangles face from inside to outside in parameter space, flipped
        // where the shell's map reverses orientation (interior shells).
        let flip = self.flips[t];
        // Iso-vertices on the cell's sides keep the margin of the side's mesh vertices
        // (each point's corners of the cell: one at a corner, two on a side), which
        // the neighbour across it computes alike; the rest, the cell's own.
        let corners = lat.tris[t].map(|v| self.margins.vertex[v as usize]);
        let own = self.margins.cell[t];
        let ijl = &s.ijl;
        let param = |lp: usize| ijl[lp];
        let place = |p: IVec3| lat.place(p.x as u32, p.y as u32);
        let on_rim = |lp: usize| place(ijl[lp]) != Place::Inside;
        let to_q = |p: IVec3| Vec3::new(p.x as f32 / n as f32, p.y as f32 / n as f32, heights[p.z as usize]);
        s.grads.clear();
        s.grads.resize(points, std::cell::Cell::new(Vec3::NAN));
        let grads = &s.grads;
        let (ids, vals, slots, touched, masks) = (&s.ids, &s.vals, &mut s.slots, &mut s.touched, &s.masks);
        let footprints = &mut s.footprints;
        let fracs = &mut s.fracs;
        fracs.clear();
        let value = |p: IVec3| -> Option<f32> {
            let ok = p.x >= 0 && p.y >= 0 && p.x + p.y <= n as i32 && (0..=m as i32).contains(&p.z);
            ok.then(|| vals[lat.local_index(p.x as u32, p.y as u32) * lm + p.z as usize])
        };
        // d alpha / d (u, v, r) at a lattice point: differences over the neighbouring
        // lattice points (one-sided at the lattice's ends).
        let lattice_gradient = |lp: usize| {
            let cached = grads[lp].get();
            if !cached.x.is_nan() {
                return cached;
            }
            let p = param(lp);
            let d = |e: IVec3| match (value(p + e), value(p - e)) {
                (Some(a), Some(b)) => (a - b, 2),
                (Some(a), None) => (a - vals[lp], 1),
                (None, Some(b)) => (vals[lp] - b, 1),
                (None, None) => (0.0, 1),
            };
            let (dr, steps) = d(IVec3::Z);
            let l = p.z as usize;
            let span = match steps {
                2 => heights[l + 1] - heights[l - 1],
                _ if l + 1 < heights.len() && value(p + IVec3::Z).is_some() => heights[l + 1] - heights[l],
                _ => heights[l] - heights[l.saturating_sub(1)],
            };
            let (du, su) = d(IVec3::X);
            let (dv, sv) = d(IVec3::Y);
            let g = Vec3::new(du * n as f32 / su as f32, dv * n as f32 / sv as f32, if span > 0.0 { dr / span } else { 0.0 });
            grads[lp].set(g);
            g
        };
        let mut iso = |(piece, fracs): &mut (&mut Piece, &mut Vec<(usize, f32)>), p: usize, q: usize| -> u32 {
            let (lo, hi) = if ids[p] < ids[q] { (p, q) } else { (q, p) };
            let slot = lo * EDGE_DIRECTIONS + direction(param(hi) - param(lo));
            if slots[slot] != u32::MAX {
                return slots[slot];
            }
            let (qa, qb) = (to_q(param(lo)), to_q(param(hi)));
            let shared = on_rim(lo) && on_rim(hi);
            // Along a column the occupancy is linear between the texture's slices. On
            // the rim the neighbour makes the same vertex from the same two samples,
            // but its own field between them; and next to the rim, where the cells'
            // common side is curved, vertices moved off the linear guess let the two
            // cells' surfaces cross (found on a thin blade's interior shell): both
            // keep the linear guess there.
            let f = if param(lo).truncate() == param(hi).truncate() || on_rim(lo) || on_rim(hi) {
                linear(vals[lo], vals[hi], 0.5)
            } else {
                crossing(vals[lo], vals[hi], 0.5, CROSSING, |f| self.field.at(t, &cell, qa.lerp(qb, f), footprints))
            };
            // Kept off the lattice points ([`Margins`]); the same on both sides of the
            // rim (the neighbour clamps the same linear guess by the same margin).
            let side = place(param(lo)).corners() | place(param(hi)).corners();
            let margin = if shared && side.count_ones() <= 2 { (0..3).filter(|k| side >> k & 1 == 1).map(|k| corners[k]).fold(0.0, f32::max) } else { own };
            let f = f.clamp(margin, 1.0 - margin);
            let q = qa.lerp(qb, f);
            // Gradient: the lattice's central differences (one-sided on the cell's rim)
            // interpolated along the edge, carried to world space by the cell map.
            let g = lattice_gradient(lo).lerp(lattice_gradient(hi), f);
            let grad = -cell.parameter_gradient_to_world(q, g);
            let idx = piece.pos.len() as u32;
            piece.keys.push(if shared { edge_key(ids[lo], ids[hi]) } else { UNSHARED });
            piece.pos.push(cell.world(q));
            piece.attr.push(cell.texture(q));
            piece.grad.push(grad);
            fracs.push((lo, f));
            slots[slot] = idx;
            touched.push(slot);
            idx
        };
        // The centre of a long loop: inside the prism, never shared with another cell
        // (no key), its attributes interpolated from the prism's corners as an
        // iso-vertex's are from its edge's ends. A fan from one of the loop's own
        // vertices folds in curved or sheared cells, and its triangles crossed the
        // neighbouring prisms' surface.
        let centre = |(piece, fracs): &mut (&mut Piece, &mut Vec<(usize, f32)>), c: &[usize; 6], v: &[f32; 6], ring: &[(usize, usize, u32)]| -> u32 {
            let along = ring.iter().map(|&(a, b, id)| {
                let (lo, f) = fracs[id as usize];
                (a, b, if lo == c[a] { f } else { 1.0 - f })
            });
            let w = centre_weights(v, 0.5, along, own);
            let q: Vec3 = (0..6).map(|k| to_q(param(c[k])) * w[k]).sum();
            let g: Vec3 = (0..6).map(|k| lattice_gradient(c[k]) * w[k]).sum();
            let grad = -cell.parameter_gradient_to_world(q, g);
            let idx = piece.pos.len() as u32;
            piece.keys.push(UNSHARED);
            piece.pos.push(cell.world(q));
            piece.attr.push(cell.texture(q));
            piece.grad.push(grad);
            fracs.push((usize::MAX, 0.0));
            idx
        };
        let mut emit = |piece: &mut Piece, c: [usize; 6]| {
            let mut tris = std::mem::take(&mut piece.tris);
            let v = c.map(|k| vals[k]);
            march_prism_centred(
                &v,
                0.5,
                flip,
                &mut (&mut *piece, &mut *fracs),
                |ctx, a, b| iso(ctx, c[a], c[b]),
                |ctx, ring| centre(ctx, &c, &v, ring),
                &mut tris,
            );
            piece.tris = tris;
        };
        let (blocks, smalls, mixed) = (&s.blocks, &s.smalls, &s.mixed);
        for &columns in mixed.iter().flat_map(|&b| &smalls[blocks[b].smalls.clone()]) {
            let base = columns.map(|c| c * lm);
            let mut prism = |l: usize| emit(&mut piece, [base[0] + l, base[1] + l, base[2] + l, base[0] + l + 1, base[1] + l + 1, base[2] + l + 1]);
            let [a, b, c] = columns.map(|c| masks[c]);
            if bitwise {
                // Only the layers whose six corners are not all on one side.
                let (all, any) = (a & b & c, a | b | c);
                let uniform = (all & (all >> 1)) | !(any | (any >> 1));
                let mut mixed = !uniform & ((1u64 << m) - 1);
                while mixed != 0 {
                    prism(mixed.trailing_zeros() as usize);
                    mixed &= mixed - 1;
                }
            } else if a | b | c != 0 {
                // Columns with no inside sample make no surface.
                (0..m as usize).for_each(&mut prism);
            }
        }
        for slot in touched.drain(..) {
            slots[slot] = u32::MAX;
        }
        s.last = (piece.pos.len(), piece.tris.len());
        piece
    }
}

/// How close to a lattice point an iso-vertex may come, as a share of its lattice edge.
/// The cell map is bilinear (linear in `(u, v)` and in `r`, not in both), so a flat
/// triangle between mapped iso-vertices is off the map's image of the triangle between
/// their parameters by up to about a quarter of the directors' change over its span
/// times its height; where directors tilt fast (a knife edge's cap, sheared cells), that
/// is a few percent of a lattice step. Where the surface passes within that of a lattice
/// point (a strand tip holding one inside sample: the sheets on either side of it a
/// hundredth of a step apart, the marching's own [`OFF_ISO`] margin), their flat
/// triangles crossed: the blade's fur at the default settings had 12 crossing pairs in
/// the caps' cells next to the edge (4 per cell, none in parameter space). Not from the
/// paper: 0.02 left them, 0.05 and 0.1 remove them; 0.05 moves the surface by at most a
/// twentieth of a step (the simplifier moves it by up to 0.15). Twisted cells take
/// more ([`Margins`]).
///
/// [`OFF_ISO`]: crate::polygonize::marching::OFF_ISO
const VERTEX_MARGIN: f32 = 0.05;

/// A cell's margin per unit of its twist ([`Margins::new`]): a flat triangle over a
/// bilinear patch is off it by at most a quarter of the patch's twist. Not from the
/// paper: the blade's exterior grass (16 x 16 x 8, unsimplified) crossed at margins
/// of 0.05 on cap cells of twist 0.85 and not at 0.2.
const TWIST_MARGIN: f64 = 0.3;

/// The most margin a cell takes: its surface moves by up to this share of a step.
/// Cells twisted beyond `MAX_VERTEX_MARGIN / TWIST_MARGIN` (about 0.83; the blade's
/// caps measure 0.85) get no more, so a sharper edge under a thicker shell could
/// cross again there; a larger margin would fatten one-texel strands further.
const MAX_VERTEX_MARGIN: f32 = 0.25;

/// Refinement of an iso-vertex across a column's neighbour: three evaluations of the
/// texture (bake_fidelity: thin strands keep their width; more cost bake time).
const CROSSING: Refine = Refine { steps: 3, tolerance: 0.0 };

/// Directions of the prisms' edges from a lattice point: `±u`, `±v`, `±(u - v)` (the
/// small triangles' sides) and `±r` (the columns).
const EDGE_DIRECTIONS: usize = 8;

/// The slot of edge direction `d` (one of [`EDGE_DIRECTIONS`]) in the iso-vertex table.
#[inline]
fn direction(d: IVec3) -> usize {
    match (d.x, d.y, d.z) {
        (1, 0, 0) => 0,
        (-1, 0, 0) => 1,
        (0, 1, 0) => 2,
        (0, -1, 0) => 3,
        (1, -1, 0) => 4,
        (-1, 1, 0) => 5,
        (0, 0, 1) => 6,
        (0, 0, -1) => 7,
        _ => unreachable!("{d} is not the direction of a prism's edge"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::texture::{TextureCoordinates, TriangleCells};

    #[test]
    fn blocks_tile_the_cell_with_counter_clockwise_small_triangles() {
        let m = crate::testmeshes::icosphere(0);
        let coords = TextureCoordinates::of(&m, 1.0);
        for (n, block) in [(1, 1), (4, 1), (4, 2), (6, 3), (8, 8), (12, 4)] {
            let l = Lattice::new(&m, TriangleCells::new(&m, &coords), n);
            let mut s = Scratch::default();
            s.prepare(&l, 3, block);
            let pts: Vec<(u32, u32)> = l.local_points().collect();
            assert_eq!(s.blocks.len() as u32, (n / block) * (n / block), "n {n} block {block}");
            let mut seen = std::collections::HashSet::new();
            for b in &s.blocks {
                // Each small triangle lies in its block's triangle.
                let [a, bb, c] = b.corners.map(|(i, j)| glam::Vec2::new(i as f32, j as f32));
                for t in &s.smalls[b.smalls.clone()] {
                    let [p, q, r] = t.map(|k| (pts[k].0 as i64, pts[k].1 as i64));
                    assert_eq!((q.0 - p.0) * (r.1 - p.1) - (q.1 - p.1) * (r.0 - p.0), 1, "counter-clockwise");
                    let centre = glam::Vec2::new((p.0 + q.0 + r.0) as f32, (p.1 + q.1 + r.1) as f32) / 3.0;
                    let side = |u: glam::Vec2, v: glam::Vec2| (v - u).perp_dot(centre - u) > 0.0;
                    assert!(side(a, bb) && side(bb, c) && side(c, a), "n {n} block {block}: small triangle outside its block");
                    assert!(seen.insert(*t), "small triangle in two blocks");
                }
                // The rim list: exactly the block's points on the cell's rim.
                for &p in &b.rim {
                    let (i, j) = pts[p];
                    assert!(i == 0 || j == 0 || i + j == n);
                }
            }
            assert_eq!(seen.len() as u32, n * n, "n {n} block {block}: the blocks cover the cell");
        }
    }

    /// Bakes `pattern` (16x16x8, unsimplified) over `faces` of `mesh` under its
    /// `side` shell at 5% of the diagonal, checks that the bake is a closed 2-manifold
    /// without crossing pairs, and returns its triangle count and the shell.
    fn bake_faces_cleanly(mesh: &Mesh, faces: std::ops::Range<usize>, side: crate::shell::Side, pattern: crate::texture::Pattern) -> (usize, Shell) {
        use crate::shell::{build_shell, ShellParams, Thickness};
        use crate::texture::{bake::bake, BakeParams, Generator, TextureLayer};
        let t = Thickness::relative(0.05).per_vertex(mesh, None).unwrap();
        let s = build_shell(mesh, &t, side, &ShellParams::default()).unwrap();
        let corners: Vec<u32> = faces.clone().flat_map(|f| mesh.face(f).to_vec()).collect();
        let sizes: Vec<u32> = faces.map(|f| mesh.face(f).len() as u32).collect();
        let part = Mesh::new(mesh.positions().to_vec(), &sizes, corners, None).unwrap();
        let texture = Generator::new(pattern).generate([16, 16, 8]).unwrap();
        let layers = [TextureLayer { texture, offset: glam::Vec2::ZERO }];
        let b = bake(&part, &s, &layers, &BakeParams { triangle_budget: 0, ..Default::default() }).unwrap();
        let check = crate::polygonize::SurfaceCheck::of(&b.positions, &b.triangles);
        assert!(check.is_closed_manifold(), "{check:?}");
        let m = Mesh::from_triangles(b.positions.clone(), &b.triangles).unwrap();
        assert_eq!(crate::hard_meshes::self_intersections(&m), 0);
        (b.triangles.len(), s)
    }

    #[test]
    fn twisted_cells_keep_their_iso_vertices_further_off_the_lattice_points() {
        // The blade's exterior shell (5%) under grass at the default settings (a
        // 16x16x8 texture, the lattice following it, unsimplified): its caps are fanned
        // from their centre into cells about 30 times thinner than the shell, whose
        // directors turn 35 degrees across them. The sheets around a grass blade one
        // lattice point wide, 0.05 of a step off it on either side, crossed there (16
        // crossing pairs on these three faces, 36 on the whole blade); with the
        // margin grown with the cell's twist, none.
        let blade = crate::hard_meshes::blade();
        let (triangles, s) = bake_faces_cleanly(&blade, 1309..1312, crate::shell::Side::Exterior, crate::texture::Pattern::Grass);
        assert!(triangles > 1_000, "{triangles}");
        // The margins: the least on the blade's flat flank, more on the cap cells,
        // and each mesh vertex takes the most of the cells around it (the cells here:
        // the flank's, the caps' and the triangles beside the caps, some of which
        // meet cells of another margin at a vertex).
        let heights: Vec<f32> = (0..=16).map(|l| l as f32 / 16.0).collect();
        let caps: Vec<u32> = (1309..1312).flat_map(|f| blade.face(f).to_vec()).collect();
        let triangle = |f: usize| <[u32; 3]>::try_from(blade.face(f)).ok();
        let flank = blade.face(100);
        let mut cells = vec![[flank[0], flank[1], flank[2]]];
        cells.extend((1309..1312).map(|f| triangle(f).unwrap()));
        cells.extend((0..blade.face_count()).filter(|f| !(1309..1312).contains(f) && blade.face(*f).iter().any(|v| caps.contains(v))).filter_map(triangle));
        let margins = Margins::new(&blade, &s, &cells, &heights);
        assert_eq!(margins.cell[0], VERTEX_MARGIN);
        assert!(margins.cell[1..4].iter().all(|&m| m > 2.0 * VERTEX_MARGIN && m <= MAX_VERTEX_MARGIN), "{:?}", margins.cell);
        let around = |v: u32| cells.iter().zip(&margins.cell).filter(move |(c, _)| c.contains(&v)).map(|(_, &m)| m);
        let least = |v: u32| around(v).fold(f32::MAX, f32::min);
        let most = |v: u32| around(v).fold(0.0, f32::max);
        assert!(cells.iter().flatten().any(|&v| least(v) < most(v)), "no vertex between cells of different margins: {:?}", margins.cell);
        for &v in cells.iter().flatten() {
            assert_eq!(margins.vertex[v as usize], most(v), "vertex {v}");
        }
    }

    #[test]
    fn long_loops_fanned_from_a_centre_do_not_cross_in_sheared_cells() {
        // The coil's interior shell (5%) under chain mail at the default settings (a
        // 16x16x8 texture, the lattice following it, unsimplified here): its cells are
        // sheared along the tube, and loops of six crossings triangulated between their
        // own vertices (the table's fan, which the field polygonizer keeps) folded
        // across the neighbouring prisms' surface: 8 crossing pairs on these four faces
        // (1906 on the whole coil). Fanned from a centre inside their prism: none.
        let coil = crate::hard_meshes::coil();
        let (triangles, _) = bake_faces_cleanly(&coil, 32..36, crate::shell::Side::Interior, crate::texture::Pattern::ChainMail);
        assert!(triangles > 10_000, "{triangles}");
    }
}
