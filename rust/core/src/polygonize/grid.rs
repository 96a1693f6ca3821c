//! The second lattice: a regular grid of cubes over a box, each cube split along the
//! same diagonal into two triangular prisms, so any [`ScalarField`] is meshed by the
//! bake's marching prisms. Neighbouring prisms share whole faces (the split is the
//! same in every cube), so iso-vertices keyed by their lattice edge make a surface
//! without cracks. The solid is cut by the box (the field's maximum with the box's
//! signed distance): the surface is closed on the box's faces where it leaves it.
//!
//! The grid is marched in slabs of cube layers in parallel; a slab samples its own
//! planes (one batch of [`ScalarField::values`] per plane), keeps a slot per lattice
//! edge for its iso-vertices, and the slabs are joined by [`weld`] through the keys of
//! the vertices on their common planes. Normals are the field's gradient at the
//! vertices, attributes the field's own at the vertices (one batch per slab).

use super::marching::{crossing, linear, march_prism, Refine, OFF_ISO};
use super::weld::{edge_key, weld, Piece, UNSHARED};
use crate::field::ScalarField;
use crate::{Error, Result};
use glam::{UVec3, Vec3};
use rayon::prelude::*;

/// The most cells along the box's longest side.
pub const MAX_RESOLUTION: u32 = 2048;

/// What [`mesh_field`] meshes, and how finely.
#[derive(Debug, Clone, PartialEq)]
pub struct GridParams {
    /// The box meshed: lowest and highest corner.
    pub bounds: (Vec3, Vec3),
    /// Cells along the box's longest side; the other sides get as many as keep the
    /// cells nearest to cubes.
    pub resolution: u32,
    /// Iso-vertices on the field's own crossing of each edge ([`crossing`]); else the
    /// linear guess from the edge's two samples.
    pub refine: bool,
}

/// A meshed field: a closed, consistently oriented 2-manifold (triangles face the
/// outside, where `f > 0`).
#[derive(Debug, Clone, Default)]
pub struct FieldMesh {
    pub positions: Vec<Vec3>,
    /// The field's unit gradient at each vertex.
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
    step: Vec3,
    cells: UVec3,
}

impl Grid {
    fn new(params: &GridParams) -> Result<Self> {
        let (lo, hi) = params.bounds;
        if !(lo.is_finite() && hi.is_finite() && hi.cmpgt(lo).all()) {
            return Err(Error::InvalidParameter(format!("the box to mesh must be finite and not empty, got {lo} to {hi}")));
        }
        if !(1..=MAX_RESOLUTION).contains(&params.resolution) {
            return Err(Error::InvalidParameter(format!("resolution must be 1 to {MAX_RESOLUTION} cells, got {}", params.resolution)));
        }
        let extent = hi - lo;
        let h = extent.max_element() / params.resolution as f32;
        let cells = (extent / h).ceil().max(Vec3::ONE).as_uvec3().min(UVec3::splat(params.resolution));
        Ok(Self { lo, step: extent / cells.as_vec3(), cells })
    }
    fn point(&self, i: u32, j: u32, k: u32) -> Vec3 {
        self.lo + self.step * Vec3::new(i as f32, j as f32, k as f32)
    }
    fn id(&self, i: u32, j: u32, k: u32) -> u64 {
        let (nx, ny) = (u64::from(self.cells.x) + 1, u64::from(self.cells.y) + 1);
        u64::from(i) + nx * (u64::from(j) + ny * u64::from(k))
    }
    /// The value marched at `p` for the field's value `f` there: `-max(f, box)` where
    /// `box` is the signed distance to the box (the solid cut by the box, so the
    /// surface closes on the box's faces), kept [`OFF_ISO`] off the level, and
    /// outside where the field has no value.
    fn inside(&self, f: f32, p: Vec3, scale: f32) -> f32 {
        if !f.is_finite() {
            return -scale;
        }
        let (lo, hi) = (self.lo, self.lo + self.step * self.cells.as_vec3());
        let to_box = (lo - p).max(p - hi).max_element();
        // On the level counts as outside, so the box's own faces are.
        let eps = OFF_ISO * scale;
        let g = f.max(to_box);
        if g >= 0.0 {
            -g.max(eps)
        } else {
            (-g).max(eps)
        }
    }
}

/// Slots per lattice point: the edges to its `+x`, `+y`, `+x+y` (the cubes' split
/// diagonal) and `+z` neighbours, the only ones prisms have.
const DIRECTIONS: usize = 4;

/// Meshes the zero set of `field` inside `params.bounds`. Inside is `f <= 0`.
pub fn mesh_field<F: ScalarField + ?Sized>(field: &F, params: &GridParams) -> Result<FieldMesh> {
    let grid = Grid::new(params)?;
    let nz = grid.cells.z;
    // Slabs: enough for every thread to take several, few enough that the planes
    // sampled twice (where slabs meet) stay a small share.
    let slab = nz.div_ceil((4 * rayon::current_num_threads() as u32).min(nz)).max(2);
    let slabs: Vec<(u32, u32)> = (0..nz).step_by(slab as usize).map(|k0| (k0, (k0 + slab).min(nz))).collect();
    let pieces: Vec<Piece> = slabs.par_iter().map(|&(k0, k1)| march_slab(field, &grid, k0, k1, params.refine)).collect();
    let tags: Vec<u32> = (0..pieces.len() as u32).collect();
    let welded = weld(pieces, &tags);
    let count = field.attribute_count();
    let mut attributes = vec![0.0; welded.positions.len() * count];
    if count > 0 {
        const CHUNK: usize = 4096;
        attributes.par_chunks_mut(CHUNK * count).zip(welded.positions.par_chunks(CHUNK)).for_each(|(out, points)| field.attributes(points, out));
    }
    Ok(FieldMesh { positions: welded.positions, normals: welded.normals, triangles: welded.triangles, attributes, attribute_count: count, cells: grid.cells })
}

/// The piece of cube layers `k0..k1`.
fn march_slab<F: ScalarField + ?Sized>(field: &F, grid: &Grid, k0: u32, k1: u32, refine: bool) -> Piece {
    let (nx, ny) = (grid.cells.x, grid.cells.y);
    let plane = ((nx + 1) * (ny + 1)) as usize;
    let planes = (k1 - k0 + 1) as usize;
    // Values, as `-f` so that inside is `>= 0` as marching prisms count it.
    let scale = grid.step.min_element();
    let mut values = vec![0.0f32; plane * planes];
    let mut points = Vec::with_capacity(plane);
    for (k, out) in (k0..=k1).zip(values.chunks_exact_mut(plane)) {
        points.clear();
        points.extend((0..=ny).flat_map(|j| (0..=nx).map(move |i| (i, j))).map(|(i, j)| grid.point(i, j, k)));
        field.values(&points, out);
        for (v, p) in out.iter_mut().zip(&points) {
            *v = grid.inside(*v, *p, scale);
        }
    }
    let local = |i: u32, j: u32, k: u32| i as usize + (nx as usize + 1) * (j as usize + (ny as usize + 1) * (k - k0) as usize);
    let mut slots = vec![u32::MAX; plane * planes * DIRECTIONS];
    let mut piece = Piece::default();
    let mut tris = Vec::new();
    for k in k0..k1 {
        for j in 0..ny {
            for i in 0..nx {
                // Two prisms per cube, bottom corners counter-clockwise seen from +z.
                for bottom in [[(i, j), (i + 1, j), (i + 1, j + 1)], [(i, j), (i + 1, j + 1), (i, j + 1)]] {
                    let corner = |c: usize| {
                        let (a, b) = bottom[c % 3];
                        (a, b, k + (c / 3) as u32)
                    };
                    let vals: [f32; 6] = std::array::from_fn(|c| {
                        let (a, b, kk) = corner(c);
                        values[local(a, b, kk)]
                    });
                    march_prism(
                        &vals,
                        0.0,
                        false,
                        |ca, cb| {
                            let (mut pa, mut pb) = (corner(ca), corner(cb));
                            if grid.id(pb.0, pb.1, pb.2) < grid.id(pa.0, pa.1, pa.2) {
                                std::mem::swap(&mut pa, &mut pb);
                            }
                            let direction = match (pb.0 - pa.0, pb.1 - pa.1, pb.2 - pa.2) {
                                (1, 0, 0) => 0,
                                (0, 1, 0) => 1,
                                (1, 1, 0) => 2,
                                _ => 3,
                            };
                            let (la, lb) = (local(pa.0, pa.1, pa.2), local(pb.0, pb.1, pb.2));
                            let slot = la * DIRECTIONS + direction;
                            if slots[slot] != u32::MAX {
                                return slots[slot];
                            }
                            let (xa, xb) = (grid.point(pa.0, pa.1, pa.2), grid.point(pb.0, pb.1, pb.2));
                            let (va, vb) = (values[la], values[lb]);
                            let f = if refine {
                                let at = |f: f32| {
                                    let x = xa.lerp(xb, f);
                                    grid.inside(field.value(x), x, scale)
                                };
                                crossing(va, vb, 0.0, Refine { steps: 8, tolerance: 1e-4 * scale }, at)
                            } else {
                                linear(va, vb, 0.0)
                            };
                            // Vertices in the slab's first or last plane are made by the
                            // neighbouring slab too.
                            let shared = pa.2 == pb.2 && (pa.2 == k0 || pa.2 == k1);
                            let index = piece.pos.len() as u32;
                            piece.keys.push(if shared { edge_key(grid.id(pa.0, pa.1, pa.2), grid.id(pb.0, pb.1, pb.2)) } else { UNSHARED });
                            piece.pos.push(xa.lerp(xb, f));
                            slots[slot] = index;
                            index
                        },
                        &mut tris,
                    );
                }
            }
        }
    }
    piece.tris = tris;
    piece.grad = vec![Vec3::ZERO; piece.pos.len()];
    field.gradients(&piece.pos, &mut piece.grad);
    piece
}
