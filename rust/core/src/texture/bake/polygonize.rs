//! Marching prisms over one cell's lattice (the triangles per case come from
//! [`super::prism_table`]). Iso-vertices are computed once per lattice edge within the
//! cell (a dense slot table indexed by the edge's lower endpoint and direction); those
//! on the cell's boundary carry a global edge key so [`super::merge`] can join them
//! with the neighbour's.

use super::lattice::Lattice;
use super::prism_table::{self, EDGES};
use crate::texture::mapping::CellMap;
use crate::{shell::Shell, Mesh};
use glam::{IVec3, Vec3};

/// Key of an iso-vertex that no other cell shares.
pub(super) const UNSHARED: u64 = u64::MAX;

/// One cell's output before the global merge.
#[derive(Default)]
pub(super) struct Piece {
    pub keys: Vec<u64>,
    pub pos: Vec<Vec3>,
    pub tex: Vec<Vec3>,
    pub grad: Vec<Vec3>,
    pub tris: Vec<[u32; 3]>,
}

/// Everything a cell needs, shared by all cells.
pub(super) struct Cells<'a> {
    pub mesh: &'a Mesh,
    pub shell: &'a Shell,
    pub lattice: &'a Lattice,
    /// `alpha` per lattice point and layer.
    pub values: &'a [f32],
    pub layers: u32,
}

/// Per-thread buffers, reused from cell to cell.
#[derive(Default)]
pub(super) struct Scratch {
    ids: Vec<u64>,
    vals: Vec<f32>,
    slots: Vec<u32>,
    touched: Vec<usize>,
    ij: Vec<(u32, u32)>,
    /// `(i, j, l)` of every local point.
    ijl: Vec<IVec3>,
    /// Lattice gradient per local point, computed on first use (NaN: not yet).
    grads: Vec<std::cell::Cell<Vec3>>,
    /// Sizes of the last piece, to reserve the next.
    last: (usize, usize),
    /// Per local column: bit `l` set when layer `l` is inside (columns of at most 64
    /// layers); else 1 when any layer is.
    masks: Vec<u64>,
    /// The lattice's small triangles ([`Lattice::small_triangles`]), listed once.
    smalls: Vec<[usize; 3]>,
}

impl Piece {
    fn with_capacity(vertices: usize, triangles: usize) -> Self {
        Self {
            keys: Vec::with_capacity(vertices),
            pos: Vec::with_capacity(vertices),
            tex: Vec::with_capacity(vertices),
            grad: Vec::with_capacity(vertices),
            tris: Vec::with_capacity(triangles),
        }
    }
}

impl Cells<'_> {
    pub fn polygonize(&self, s: &mut Scratch, t: usize) -> Piece {
        let (lat, n, m) = (self.lattice, self.lattice.n, self.layers);
        let lm = m as usize + 1;
        if s.ij.is_empty() {
            s.ij = lat.local_points().collect();
            s.smalls = lat.small_triangles().collect();
            s.ijl = s.ij.iter().flat_map(|&(i, j)| (0..lm as i32).map(move |l| IVec3::new(i as i32, j as i32, l))).collect();
        }
        let points = s.ij.len() * lm;
        s.ids.clear();
        s.vals.clear();
        for &(i, j) in &s.ij {
            let g = lat.key(t, i, j) * lm;
            s.ids.extend((0..lm).map(|l| (g + l) as u64));
            s.vals.extend_from_slice(&self.values[g..g + lm]);
        }
        let bitwise = lm <= 64;
        s.masks.clear();
        s.masks.extend(s.vals.chunks_exact(lm).map(|c| {
            if bitwise {
                c.iter().enumerate().fold(0u64, |bits, (l, a)| bits | (u64::from(*a >= 0.5) << l))
            } else {
                u64::from(c.iter().any(|a| *a >= 0.5))
            }
        }));
        if s.slots.len() < points * 27 {
            s.slots = vec![u32::MAX; points * 27];
        }
        let cell = CellMap::new(self.mesh, self.shell, &lat.tris[t], &lat.st[t]);
        let mut piece = Piece::with_capacity(s.last.0 + s.last.0 / 4, s.last.1 + s.last.1 / 4);
        // Orientation: triangles face from inside to outside in parameter space, flipped
        // where the cell map reverses orientation (interior shells).
        let flip = cell.jacobians(Vec3::new(1.0 / 3.0, 1.0 / 3.0, 0.5)).0.determinant() < 0.0;
        let total = self.values.len() as u64;
        let ijl = &s.ijl;
        let param = |lp: usize| ijl[lp];
        let on_rim = |lp: usize| {
            let p = ijl[lp];
            p.x == 0 || p.y == 0 || p.x + p.y == n as i32
        };
        let to_q = |p: IVec3| p.as_vec3() / Vec3::new(n as f32, n as f32, m as f32);
        s.grads.clear();
        s.grads.resize(points, std::cell::Cell::new(Vec3::NAN));
        let grads = &s.grads;
        let (ids, vals, slots, touched, masks) = (&s.ids, &s.vals, &mut s.slots, &mut s.touched, &s.masks);
        let value = |p: IVec3| -> Option<f32> {
            let ok = p.x >= 0 && p.y >= 0 && p.x + p.y <= n as i32 && (0..=m as i32).contains(&p.z);
            ok.then(|| vals[lat.local_index(p.x as u32, p.y as u32) * lm + p.z as usize])
        };
        // d alpha / d (i, j, l) at a lattice point, per lattice step.
        let lattice_gradient = |lp: usize| {
            let cached = grads[lp].get();
            if !cached.x.is_nan() {
                return cached;
            }
            let p = param(lp);
            let d = |e: IVec3| match (value(p + e), value(p - e)) {
                (Some(a), Some(b)) => (a - b) / 2.0,
                (Some(a), None) => a - vals[lp],
                (None, Some(b)) => vals[lp] - b,
                (None, None) => 0.0,
            };
            let g = Vec3::new(d(IVec3::X), d(IVec3::Y), d(IVec3::Z));
            grads[lp].set(g);
            g
        };
        let mut iso = |piece: &mut Piece, p: usize, q: usize| -> u32 {
            let (lo, hi) = if ids[p] < ids[q] { (p, q) } else { (q, p) };
            let d = param(hi) - param(lo) + IVec3::ONE;
            let slot = lo * 27 + (d.x * 9 + d.y * 3 + d.z) as usize;
            if slots[slot] != u32::MAX {
                return slots[slot];
            }
            let f = ((0.5 - vals[lo]) / (vals[hi] - vals[lo])).clamp(0.0, 1.0);
            let (qa, qb) = (to_q(param(lo)), to_q(param(hi)));
            let q = qa.lerp(qb, f);
            // Gradient: the lattice's central differences (one-sided on the cell's rim)
            // interpolated along the edge, carried to world space by the cell map.
            let g = lattice_gradient(lo).lerp(lattice_gradient(hi), f) * Vec3::new(n as f32, n as f32, m as f32);
            let grad = -cell.parameter_gradient_to_world(q, g);
            let idx = piece.pos.len() as u32;
            piece.keys.push(if on_rim(lo) && on_rim(hi) { ids[lo] * total + ids[hi] } else { UNSHARED });
            piece.pos.push(cell.world(q));
            piece.tex.push(cell.texture(q));
            piece.grad.push(grad);
            slots[slot] = idx;
            touched.push(slot);
            idx
        };
        let mut emit = |piece: &mut Piece, c: [usize; 6]| {
            let case = prism_table::classify(&c.map(|k| vals[k]));
            if case.count == 0 {
                return;
            }
            let mut verts = [u32::MAX; 9];
            for tri in &case.tris[..case.count as usize] {
                let t = tri.map(|e| {
                    let e = e as usize;
                    if verts[e] == u32::MAX {
                        verts[e] = iso(piece, c[EDGES[e][0]], c[EDGES[e][1]]);
                    }
                    verts[e]
                });
                piece.tris.push(if flip { [t[0], t[2], t[1]] } else { t });
            }
        };
        for &columns in &s.smalls {
            let base = columns.map(|c| c * lm);
            let mut prism = |l: usize| {
                emit(&mut piece, [base[0] + l, base[1] + l, base[2] + l, base[0] + l + 1, base[1] + l + 1, base[2] + l + 1])
            };
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
