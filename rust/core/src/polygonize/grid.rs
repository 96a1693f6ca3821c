//! The second lattice: a regular grid of cubes over a box, each cube split along the
//! same diagonal into two triangular prisms, so any [`ScalarField`] is meshed by the
//! bake's marching prisms. Neighbouring prisms share whole faces (the split is the
//! same in every cube), so iso-vertices keyed by their lattice edge make a surface
//! without cracks. The solid is cut by the box (the field's maximum with the box's
//! signed distance): the surface is closed on the box's faces where it leaves it.
//!
//! The grid is marched in slabs of eight cube layers in parallel, each layer from
//! two planes of samples (one batch of [`ScalarField::values`] per plane) and a slot
//! per lattice edge of those planes for its iso-vertices, so memory grows with a
//! plane per slab in flight and with the output, not with the grid. Iso-vertices are
//! then refined on the field's own crossing, one batch per step for the whole slab,
//! and the slabs are joined by [`weld`] through the keys of the vertices on their
//! common planes. Normals are the cut field's gradient at the vertices, attributes
//! the field's own there.
//!
//! Fields that bound their values over boxes ([`ScalarField::interval`]) are culled
//! first: each slab is split in halves down to blocks of [`CULL_LEAF`] cells, a box is
//! dropped where its enclosure keeps one sign, and only the cells of the blocks left
//! are sampled and marched ([`live_cells`]). A dropped box makes no triangle in the
//! unculled run either (every sample in it has the same side), and the cells left see
//! the same samples, so the mesh is the same bit for bit.
//!
//! Values are taken as distance-like (unit-gradient fields, or near them): samples
//! within 1% of a cell of the level are moved off it by that much ([`OFF_ISO`]).

use super::estimate::{over_limit, peak_bytes, Mesher, Watch};
use super::marching::{march_prism, Crossing, OFF_ISO};
use super::weld::{edge_key, weld, Piece, UNSHARED};
use crate::field::ScalarField;
use crate::{Error, Result};
use glam::{UVec3, Vec3};
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};

/// The most cells along the box's longest side.
pub const MAX_RESOLUTION: u32 = 2048;

/// Cube layers per slab: a fixed number, so the output does not depend on the number
/// of threads; each slab samples one plane more than it owns.
pub(crate) const SLAB: u32 = 8;

/// The smallest blocks of cells that culling asks the field to bound (cells per side):
/// each split halves a box along every side longer than this. Not from a paper: of
/// 2, 4 and 8, the fastest on `implicit_mesh_bench`'s soft-CSG tree at 128 and 256
/// cells (a bound costs about as much as a few dozen samples).
const CULL_LEAF: u32 = 4;

/// Most evaluations refining one iso-vertex, and how near the level (in cells) ends it.
/// Not from a paper: with these the analytic torus's vertices lie within 0.013 cells
/// of its zero set (`field_mesh_bench`); the tolerance ends most refinements earlier.
const REFINE_STEPS: usize = 8;
pub(crate) const REFINE_TOLERANCE: f32 = 1e-4;

/// What [`mesh_field`] meshes, and how finely.
#[derive(Debug, Clone, PartialEq)]
pub struct GridParams {
    /// The box meshed: lowest and highest corner.
    pub bounds: (Vec3, Vec3),
    /// Cells along the box's longest side (at least 2); the other sides get as many as
    /// keep the cells nearest to cubes, and at least 2 (the box's faces are outside).
    pub resolution: u32,
    /// Iso-vertices on the field's own crossing of each edge (Illinois regula falsi,
    /// up to eight evaluations each); else the linear guess from the edge's samples.
    /// Either way they stay 1% of an edge from its ends.
    pub refine: bool,
}

/// A meshed field: a closed, consistently oriented 2-manifold (triangles face the
/// outside, where `f > 0`).
#[derive(Debug, Clone, Default)]
pub struct FieldMesh {
    pub positions: Vec<Vec3>,
    /// The cut field's unit gradient at each vertex (the box face's normal where the
    /// box cut the solid; the faces' normal where the field's gradient is not a number).
    pub normals: Vec<Vec3>,
    pub triangles: Vec<[u32; 3]>,
    /// [`ScalarField::attribute_count`] values per vertex.
    pub attributes: Vec<f32>,
    pub attribute_count: usize,
    /// Cells along x, y and z.
    pub cells: UVec3,
}

/// The grid's geometry.
struct Grid {
    lo: Vec3,
    hi: Vec3,
    step: Vec3,
    cells: UVec3,
    /// Iso-level offset of samples: [`OFF_ISO`] of the smallest cell side.
    eps: f32,
}

impl Grid {
    fn new(params: &GridParams) -> Result<Self> {
        let (step, cells, eps) = cells_for(params.bounds, params.resolution)?;
        Ok(Self { lo: params.bounds.0, hi: params.bounds.1, step, cells, eps })
    }
    fn point(&self, i: u32, j: u32, k: u32) -> Vec3 {
        self.lo + self.step * Vec3::new(i as f32, j as f32, k as f32)
    }
    fn lattice_point(&self, at: UVec3) -> Vec3 {
        self.point(at.x, at.y, at.z)
    }
    fn id(&self, i: u32, j: u32, k: u32) -> u64 {
        let (nx, ny) = (u64::from(self.cells.x) + 1, u64::from(self.cells.y) + 1);
        u64::from(i) + nx * (u64::from(j) + ny * u64::from(k))
    }
    fn to_box(&self, p: Vec3) -> (f32, Vec3) {
        to_box(self.lo, self.hi, p)
    }
    /// `-max(f, box)` at `p`: the solid cut by the box, inside `>= 0` as marching
    /// prisms count it. Not a number where `f` is not.
    fn cut(&self, f: f32, p: Vec3) -> f32 {
        if f.is_nan() {
            return f32::NAN;
        }
        -f.max(self.to_box(p).0)
    }
    /// The value marched at `p`: [`Grid::cut`] kept `eps` off the level (the box's own
    /// faces, and `f` not a number, outside; `f = 0` inside, as `V(f) = {f <= 0}`),
    /// and within a range where differences stay finite.
    fn sample(&self, f: f32, p: Vec3) -> f32 {
        const LIMIT: f32 = f32::MAX / 4.0;
        if f.is_nan() || self.to_box(p).0 >= 0.0 {
            let outside = if f > 0.0 { f.min(LIMIT) } else { 0.0 };
            return -self.eps.max(outside);
        }
        let v = self.cut(f, p);
        if v >= 0.0 {
            v.max(self.eps).min(LIMIT)
        } else {
            v.min(-self.eps).max(-LIMIT)
        }
    }
}

/// A field meshed without interval culling: `field` with its [`ScalarField::interval`]
/// hidden, everything else passed on. The mesh is the same (culling skips only cells
/// without a surface); for measuring what culling saves, and for fields whose
/// enclosures are not to be trusted.
pub struct Unculled<'a, F: ?Sized>(pub &'a F);

impl<F: ScalarField + ?Sized> ScalarField for Unculled<'_, F> {
    fn values(&self, points: &[Vec3], out: &mut [f32]) {
        self.0.values(points, out);
    }
    fn gradients(&self, points: &[Vec3], out: &mut [Vec3]) {
        self.0.gradients(points, out);
    }
    fn difference_step(&self) -> f32 {
        self.0.difference_step()
    }
    fn attribute_count(&self) -> usize {
        self.0.attribute_count()
    }
    fn attributes(&self, points: &[Vec3], out: &mut [f32]) {
        self.0.attributes(points, out);
    }
    fn value(&self, p: Vec3) -> f32 {
        self.0.value(p)
    }
}

/// Slots per lattice point: the edges to its `+x`, `+y`, `+x+y` (the cubes' split
/// diagonal) and `+z` neighbours, the only ones prisms have.
const DIRECTIONS: usize = 4;

/// Meshes the zero set of `field` inside `params.bounds`. Inside is `f <= 0`.
pub fn mesh_field<F: ScalarField + ?Sized>(field: &F, params: &GridParams) -> Result<FieldMesh> {
    mesh_field_watched(field, params, &Watch::default())
}

/// [`mesh_field`] under a [`Watch`]: progress counted in slabs, a cancel obeyed
/// between cube layers, and the memory limit checked as slabs finish against what
/// they made so far ([`peak_bytes`]): past it the build stops with an error naming
/// the limit.
pub fn mesh_field_watched<F: ScalarField + ?Sized>(field: &F, params: &GridParams, watch: &Watch<'_>) -> Result<FieldMesh> {
    let grid = Grid::new(params)?;
    watch.check()?;
    let nz = grid.cells.z;
    let slabs: Vec<(u32, u32)> = (0..nz).step_by(SLAB as usize).map(|k0| (k0, (k0 + SLAB).min(nz))).collect();
    // One step per slab, one for the weld and attributes.
    watch.start(slabs.len() + 1);
    // A field answers for every box or for none: asked once.
    let cull = field.interval(grid.lo, grid.hi).is_some();
    let made = [AtomicU64::new(0), AtomicU64::new(0)];
    let pieces: Vec<Piece> = slabs
        .par_iter()
        .map(|&(k0, k1)| {
            let piece = march_slab(field, &grid, k0, k1, params.refine, cull, watch)?;
            let vertices = made[0].fetch_add(piece.pos.len() as u64, Ordering::Relaxed) + piece.pos.len() as u64;
            let triangles = made[1].fetch_add(piece.tris.len() as u64, Ordering::Relaxed) + piece.tris.len() as u64;
            if let Some(limit) = watch.max_bytes {
                if peak_bytes(Mesher::Grid, grid.cells, 0, vertices, triangles) > limit {
                    return Err(over_limit(limit, &format!("slabs of cells marched already make {vertices} vertices")));
                }
            }
            watch.advance(1);
            Ok(piece)
        })
        .collect::<Result<_>>()?;
    watch.check()?;
    let tags: Vec<u32> = (0..pieces.len() as u32).collect();
    let welded = weld(pieces, &tags);
    let count = field.attribute_count();
    let mut attributes = vec![0.0; welded.positions.len() * count];
    if count > 0 {
        const CHUNK: usize = 4096;
        attributes.par_chunks_mut(CHUNK * count).zip(welded.positions.par_chunks(CHUNK)).for_each(|(out, points)| field.attributes(points, out));
    }
    watch.advance(1);
    Ok(FieldMesh { positions: welded.positions, normals: welded.normals, triangles: welded.triangles, attributes, attribute_count: count, cells: grid.cells })
}

/// The cells of layers `k0..k1` that may hold a surface, one flag per cell (`i`
/// fastest, then `j`, then the layer from `k0`): the slab's box split in halves along
/// every side longer than [`CULL_LEAF`] cells, and a box dropped where
/// [`ScalarField::interval`] shows that every sample in it is on one side:
///
/// - outside where `f > eps` over the box (the marched value `-max(f, box)` is
///   negative; samples on the grid's faces are outside anyway);
/// - inside where `f < -eps`, but for the cells with a corner on the grid's faces
///   (the solid is cut there): inner lattice points are strictly inside the grid's
///   box (its cells are at least `2e-5` of the coordinates, far above rounding), so
///   the cut value is `-f > 0` there.
///
/// The margin `eps` (1% of a cell, [`Grid::eps`]) covers the rounding of the values
/// to single precision and of the enclosure's own arithmetic. A cell without a
/// crossing makes no triangle and no vertex, so dropping it changes nothing; a cell
/// kept is marched from the same samples as without culling.
fn live_cells<F: ScalarField + ?Sized>(field: &F, grid: &Grid, k0: u32, k1: u32) -> Vec<bool> {
    let cells = UVec3::new(grid.cells.x, grid.cells.y, k1 - k0);
    let mut live = vec![false; (cells.x * cells.y * cells.z) as usize];
    // Boxes of cells `[lo, hi)` (layers counted from `k0`) still to decide.
    let mut boxes = vec![(UVec3::ZERO, cells)];
    while let Some((lo, hi)) = boxes.pop() {
        let (a, b) = (UVec3::new(lo.x, lo.y, lo.z + k0), UVec3::new(hi.x, hi.y, hi.z + k0));
        let mark = |live: &mut [bool], keep: &dyn Fn(UVec3) -> bool| {
            for k in lo.z..hi.z {
                for j in lo.y..hi.y {
                    let row = ((k * cells.y + j) * cells.x) as usize;
                    for i in (lo.x..hi.x).filter(|&i| keep(UVec3::new(i, j, k + k0))) {
                        live[row + i as usize] = true;
                    }
                }
            }
        };
        if let Some((l, u)) = field.interval(grid.lattice_point(a), grid.lattice_point(b)) {
            if l > grid.eps {
                continue;
            }
            if u < -grid.eps {
                // Inside: only the cells with a corner on the grid's faces (where the
                // box cuts the solid) have a surface.
                if !(a.cmpge(UVec3::ONE).all() && b.cmplt(grid.cells).all()) {
                    mark(&mut live, &|c| c.cmpeq(UVec3::ZERO).any() || (c + 1).cmpeq(grid.cells).any());
                }
                continue;
            }
        }
        let size = hi - lo;
        if size.max_element() <= CULL_LEAF {
            mark(&mut live, &|_| true);
            continue;
        }
        // Halves along every side longer than a leaf.
        let mid = lo + size / 2;
        let halves = |axis: usize| if size[axis] > CULL_LEAF { vec![(lo[axis], mid[axis]), (mid[axis], hi[axis])] } else { vec![(lo[axis], hi[axis])] };
        for &(z0, z1) in &halves(2) {
            for &(y0, y1) in &halves(1) {
                for &(x0, x1) in &halves(0) {
                    boxes.push((UVec3::new(x0, y0, z0), UVec3::new(x1, y1, z1)));
                }
            }
        }
    }
    live
}

/// The samples of plane `k`, marched values ([`Grid::sample`]); with `needed` (one
/// flag per lattice point of the plane), only those points are sampled and the others
/// keep what they had (no live cell reads them).
fn sample_plane<F: ScalarField + ?Sized>(field: &F, grid: &Grid, k: u32, needed: Option<&[bool]>, points: &mut Vec<Vec3>, out: &mut [f32]) {
    let (nx, ny) = (grid.cells.x, grid.cells.y);
    points.clear();
    let lattice = (0..=ny).flat_map(|j| (0..=nx).map(move |i| (i, j)));
    let Some(needed) = needed else {
        points.extend(lattice.map(|(i, j)| grid.point(i, j, k)));
        field.values(points, out);
        for (v, p) in out.iter_mut().zip(points.iter()) {
            *v = grid.sample(*v, *p);
        }
        return;
    };
    points.extend(lattice.zip(needed).filter(|(_, n)| **n).map(|((i, j), _)| grid.point(i, j, k)));
    if points.is_empty() {
        return;
    }
    let mut values = vec![0.0; points.len()];
    field.values(points, &mut values);
    let targets = out.iter_mut().zip(needed).filter(|(_, n)| **n).map(|(o, _)| o);
    for ((o, v), p) in targets.zip(values).zip(points.iter()) {
        *o = grid.sample(v, *p);
    }
}

/// The lattice points of plane `k` that a live cell of the slab `k0..k1` reads (the
/// corners of the live cells of the layers below and above it), written to `needed`;
/// `None` without culling (every point).
fn needed_points<'a>(grid: &Grid, live: Option<&[bool]>, k0: u32, k1: u32, k: u32, needed: &'a mut [bool]) -> Option<&'a [bool]> {
    let live = live?;
    let (nx, ny) = (grid.cells.x as usize, grid.cells.y as usize);
    needed.fill(false);
    let layers = [k.checked_sub(1).filter(|&l| l >= k0), Some(k).filter(|&l| l < k1)];
    for layer in layers.into_iter().flatten() {
        let cells = &live[(layer - k0) as usize * nx * ny..][..nx * ny];
        for j in 0..ny {
            for i in (0..nx).filter(|&i| cells[j * nx + i]) {
                for (di, dj) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    needed[(j + dj) * (nx + 1) + i + di] = true;
                }
            }
        }
    }
    Some(needed)
}

/// The piece of cube layers `k0..k1`; `cull`: only the [`live_cells`] are sampled and
/// marched. Stops at the watch's cancel between layers.
fn march_slab<F: ScalarField + ?Sized>(field: &F, grid: &Grid, k0: u32, k1: u32, refine: bool, cull: bool, watch: &Watch<'_>) -> Result<Piece> {
    watch.check()?;
    let (nx, ny) = (grid.cells.x, grid.cells.y);
    let plane = ((nx + 1) * (ny + 1)) as usize;
    let at = |i: u32, j: u32| i as usize + (nx as usize + 1) * j as usize;
    let live = cull.then(|| live_cells(field, grid, k0, k1));
    let mut needed = vec![false; if cull { plane } else { 0 }];
    let mut points = Vec::with_capacity(plane);
    // Values and iso-vertex slots of the layer's bottom and top planes; a plane's
    // in-plane edges keep their vertices from one layer to the next.
    let (mut below, mut above) = (vec![0.0f32; plane], vec![0.0f32; plane]);
    let (mut slots_below, mut slots_above) = (vec![u32::MAX; plane * DIRECTIONS], vec![u32::MAX; plane * DIRECTIONS]);
    sample_plane(field, grid, k0, needed_points(grid, live.as_deref(), k0, k1, k0, &mut needed), &mut points, &mut below);
    let mut piece = Piece::default();
    let mut ends: Vec<(Vec3, Vec3)> = Vec::new();
    let mut guesses: Vec<Crossing> = Vec::new();
    let mut tris = Vec::new();
    for k in k0..k1 {
        watch.check()?;
        sample_plane(field, grid, k + 1, needed_points(grid, live.as_deref(), k0, k1, k + 1, &mut needed), &mut points, &mut above);
        let layer = live.as_deref().map(|live| &live[((k - k0) * nx * ny) as usize..][..(nx * ny) as usize]);
        for j in 0..ny {
            for i in 0..nx {
                if layer.is_some_and(|layer| !layer[(j * nx + i) as usize]) {
                    continue;
                }
                // Two prisms per cube, bottom corners counter-clockwise seen from +z.
                for bottom in [[(i, j), (i + 1, j), (i + 1, j + 1)], [(i, j), (i + 1, j + 1), (i, j + 1)]] {
                    let corner = |c: usize| (bottom[c % 3], c >= 3);
                    let value = |c: usize| {
                        let ((a, b), up) = corner(c);
                        if up {
                            above[at(a, b)]
                        } else {
                            below[at(a, b)]
                        }
                    };
                    let vals: [f32; 6] = std::array::from_fn(value);
                    let vertex = |ca: usize, cb: usize| {
                        // From the lower lattice point to the higher one (x, y, then z).
                        let (mut a, mut b) = (ca, cb);
                        let ((ia, ja), ua) = corner(a);
                        let ((ib, jb), ub) = corner(b);
                        if (ub, jb, ib) < (ua, ja, ia) {
                            std::mem::swap(&mut a, &mut b);
                        }
                        let (((ia, ja), ua), ((ib, jb), ub)) = (corner(a), corner(b));
                        let (direction, slots) = match (ib - ia, jb - ja, ub != ua) {
                            (1, 0, false) => (0, if ua { &mut slots_above } else { &mut slots_below }),
                            (0, 1, false) => (1, if ua { &mut slots_above } else { &mut slots_below }),
                            (1, 1, false) => (2, if ua { &mut slots_above } else { &mut slots_below }),
                            _ => (3, &mut slots_below),
                        };
                        let slot = at(ia, ja) * DIRECTIONS + direction;
                        if slots[slot] != u32::MAX {
                            return slots[slot];
                        }
                        let (ka, kb) = (k + u32::from(ua), k + u32::from(ub));
                        let (xa, xb) = (grid.point(ia, ja, ka), grid.point(ib, jb, kb));
                        let guess = Crossing::new(value(a), value(b), 0.0);
                        // Vertices in the slab's first or last plane are made by the
                        // neighbouring slab too.
                        let shared = ka == kb && (ka == k0 || ka == k1);
                        let index = piece.pos.len() as u32;
                        piece.keys.push(if shared { edge_key(grid.id(ia, ja, ka), grid.id(ib, jb, kb)) } else { UNSHARED });
                        piece.pos.push(xa.lerp(xb, guess.result()));
                        ends.push((xa, xb));
                        guesses.push(guess);
                        slots[slot] = index;
                        index
                    };
                    march_prism(&vals, 0.0, false, vertex, &mut tris);
                }
            }
        }
        std::mem::swap(&mut below, &mut above);
        std::mem::swap(&mut slots_below, &mut slots_above);
        slots_above.fill(u32::MAX);
    }
    piece.tris = tris;
    if refine {
        refine_vertices(field, grid, &mut piece.pos, &ends, &mut guesses);
    }
    normals(field, grid, &mut piece);
    Ok(piece)
}

/// Moves each vertex onto the cut field's crossing of its edge.
fn refine_vertices<F: ScalarField + ?Sized>(field: &F, grid: &Grid, pos: &mut [Vec3], ends: &[(Vec3, Vec3)], guesses: &mut [Crossing]) {
    let along = |v: usize, t: f32| ends[v].0.lerp(ends[v].1, t);
    refine_crossings(field, guesses, along, |f, p| grid.cut(f, p), REFINE_TOLERANCE * grid.step.min_element());
    for (v, (p, guess)) in pos.iter_mut().zip(guesses.iter()).enumerate() {
        *p = along(v, guess.result());
    }
}

/// Steps every crossing `guesses[i]` on the edge `along(i, t)` (both meshers' lattice
/// edges) toward the zero of `cut` (the field's value `f` at `p` as the mesher cuts
/// it), [`REFINE_STEPS`] at most, until within `tolerance`: each step evaluates the
/// unfinished ones' next points as one batch. The evaluations made.
pub(crate) fn refine_crossings<F: ScalarField + ?Sized>(
    field: &F,
    guesses: &mut [Crossing],
    along: impl Fn(usize, f32) -> Vec3,
    cut: impl Fn(f32, Vec3) -> f32,
    tolerance: f32,
) -> usize {
    let mut pending: Vec<usize> = (0..guesses.len()).collect();
    let mut points = Vec::with_capacity(pending.len());
    let mut values = Vec::with_capacity(pending.len());
    let mut evaluations = 0;
    for _ in 0..REFINE_STEPS {
        if pending.is_empty() {
            break;
        }
        points.clear();
        points.extend(pending.iter().map(|&i| along(i, guesses[i].at())));
        values.resize(points.len(), 0.0);
        field.values(&points, &mut values);
        evaluations += points.len();
        let mut kept = 0;
        for n in 0..pending.len() {
            let i = pending[n];
            if guesses[i].step(cut(values[n], points[n]), tolerance) {
                pending[kept] = i;
                kept += 1;
            }
        }
        pending.truncate(kept);
    }
    evaluations
}

/// Each vertex's gradient of the cut field: the field's where it is inside the box,
/// the nearest box face's normal where the box cut it; zero where the field's is not
/// a number (the weld then takes the faces' normal).
///
/// Only vertices within one lattice edge of the box are asked which of the two made
/// them: a vertex farther inside lies on an edge with both ends inside the box (its
/// distance is 1-Lipschitz), where the cut field changes sign only with the field.
fn normals<F: ScalarField + ?Sized>(field: &F, grid: &Grid, piece: &mut Piece) {
    let n = piece.pos.len();
    piece.grad = vec![Vec3::ZERO; n];
    field.gradients(&piece.pos, &mut piece.grad);
    let edge = grid.step.length();
    let near: Vec<usize> = (0..n).filter(|&v| grid.to_box(piece.pos[v]).0 > -edge).collect();
    let points: Vec<Vec3> = near.iter().map(|&v| piece.pos[v]).collect();
    let mut values = vec![0.0; near.len()];
    field.values(&points, &mut values);
    for (&v, f) in near.iter().zip(&values) {
        let (d, face) = grid.to_box(piece.pos[v]);
        if d >= *f {
            piece.grad[v] = face;
        }
    }
    piece.grad.iter_mut().filter(|g| !g.is_finite()).for_each(|g| *g = Vec3::ZERO);
}

/// Signed distance from `p` to the box `lo..hi` (negative inside, the largest of the
/// per-axis distances: the box as a field whose max with another cuts it), and the
/// outward normal of the nearest face. Both meshers cut their solid by it.
pub(crate) fn to_box(lo: Vec3, hi: Vec3, p: Vec3) -> (f32, Vec3) {
    let (below, above) = (lo - p, p - hi);
    let d = below.max(above);
    let axis = if d.x >= d.y && d.x >= d.z {
        0
    } else if d.y >= d.z {
        1
    } else {
        2
    };
    let mut normal = Vec3::ZERO;
    normal[axis] = if below[axis] >= above[axis] { -1.0 } else { 1.0 };
    (d[axis], normal)
}

/// The cells of a box `bounds` meshed at `resolution` cells along its longest side
/// (both meshers' lattice): each cell's size, the cells along each axis and the
/// iso-level offset of samples ([`OFF_ISO`] of the smallest cell side). Boxes that are
/// not finite, empty, whose extent overflows, or whose cells single precision cannot
/// tell apart are refused, as are resolutions outside 2..=[`MAX_RESOLUTION`].
pub(crate) fn cells_for(bounds: (Vec3, Vec3), resolution: u32) -> Result<(Vec3, UVec3, f32)> {
    let (lo, hi) = bounds;
    let extent = hi - lo;
    if !(lo.is_finite() && hi.is_finite() && hi.cmpgt(lo).all() && extent.is_finite()) {
        return Err(Error::InvalidParameter(format!("the box to mesh must be finite and not empty, got {lo} to {hi}")));
    }
    if !(2..=MAX_RESOLUTION).contains(&resolution) {
        return Err(Error::InvalidParameter(format!("resolution must be 2 to {MAX_RESOLUTION} cells, got {resolution}")));
    }
    let h = extent.max_element() / resolution as f32;
    let cells = (extent / h).ceil().as_uvec3().clamp(UVec3::splat(2), UVec3::splat(resolution));
    let step = extent / cells.as_vec3();
    // Vertices 1% of a cell apart must stay apart in single precision.
    let far = lo.abs().max(hi.abs()).max_element();
    if step.min_element() < 2e-5 * far {
        return Err(Error::InvalidParameter(format!(
            "cells of {} are too small for single precision at coordinates near {far}: mesh a box nearer the origin or use fewer cells",
            step.min_element()
        )));
    }
    Ok((step, cells, OFF_ISO * step.min_element()))
}
