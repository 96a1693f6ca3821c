//! Joins pieces polygonized apart (a bake's cells, a grid's slabs) into one mesh:
//! iso-vertices on the pieces' common boundaries carry the same global lattice-edge
//! key and become one vertex; the rest are already unique. Pieces are copied in
//! parallel into their ranges of the output (prefix sums), and only the boundary
//! vertices go through a global sort.

use glam::Vec3;
use rayon::prelude::*;

/// Key of an iso-vertex that no other piece shares.
pub const UNSHARED: u128 = u128::MAX;

/// The key of the iso-vertex on the lattice edge between points `a` and `b` (global
/// point numbers): the same from both ends, so every piece that makes it agrees.
#[inline]
pub fn edge_key(a: u64, b: u64) -> u128 {
    let (lo, hi) = if a < b { (a, b) } else { (b, a) };
    (u128::from(lo) << 64) | u128::from(hi)
}

/// One piece of a polygonized surface before the weld.
#[derive(Default, Clone)]
pub struct Piece {
    /// Per vertex: its [`edge_key`] where another piece makes it too, else [`UNSHARED`].
    pub keys: Vec<u128>,
    pub pos: Vec<Vec3>,
    /// An attribute interpolated onto each vertex (a bake's texture coordinates); may
    /// be empty for every piece.
    pub attr: Vec<Vec3>,
    /// The field's gradient at each vertex (pointing outward); summed over a shared
    /// vertex's copies and normalized into its normal.
    pub grad: Vec<Vec3>,
    pub tris: Vec<[u32; 3]>,
    /// Simplified after polygonizing: its triangles are no longer the lattice's.
    pub simplified: bool,
}

impl Piece {
    pub fn with_capacity(vertices: usize, triangles: usize) -> Self {
        Self {
            keys: Vec::with_capacity(vertices),
            pos: Vec::with_capacity(vertices),
            attr: Vec::with_capacity(vertices),
            grad: Vec::with_capacity(vertices),
            tris: Vec::with_capacity(triangles),
            simplified: false,
        }
    }
}

/// The welded mesh.
#[derive(Debug, Default)]
pub struct Welded {
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    /// Per vertex (where shared, the first piece's); empty when no piece has any.
    pub attrs: Vec<Vec3>,
    pub triangles: Vec<[u32; 3]>,
    /// Per triangle corner, in its own piece (empty when no piece has attributes).
    pub corner_attrs: Vec<[Vec3; 3]>,
    /// Per triangle: the tag of the piece it came from.
    pub tags: Vec<u32>,
}

/// Splits `v` into consecutive mutable chunks of the given lengths.
fn chunks_mut<T>(mut v: &mut [T], lengths: impl Iterator<Item = usize>) -> Vec<&mut [T]> {
    let mut out = Vec::new();
    for n in lengths {
        let (head, tail) = std::mem::take(&mut v).split_at_mut(n);
        out.push(head);
        v = tail;
    }
    out
}

/// Welds `pieces`; `tags[i]` goes to every triangle of piece `i`. Normals: the
/// gradients summed over a vertex's copies, normalized; the area-weighted face normal
/// where the gradient vanishes.
pub fn weld(mut pieces: Vec<Piece>, tags: &[u32]) -> Welded {
    let carry = pieces.iter().any(|p| !p.attr.is_empty());
    // Boundary vertices: sorted by key, one output vertex per distinct key.
    let mut shared: Vec<(u128, u32, u32)> = pieces
        .par_iter()
        .enumerate()
        .flat_map_iter(|(pi, p)| p.keys.iter().enumerate().filter(|(_, k)| **k != UNSHARED).map(move |(i, k)| (*k, pi as u32, i as u32)))
        .collect();
    shared.par_sort_unstable();

    let own_unshared: Vec<usize> = pieces.par_iter().map(|p| p.keys.iter().filter(|k| **k == UNSHARED).count()).collect();
    let unshared_total: usize = own_unshared.iter().sum();
    let mut first_of_key = Vec::new();
    let mut shared_id = vec![0u32; shared.len()];
    for (s, &(key, _, _)) in shared.iter().enumerate() {
        if s == 0 || shared[s - 1].0 != key {
            first_of_key.push(s);
        }
        shared_id[s] = (unshared_total + first_of_key.len() - 1) as u32;
    }
    let total = unshared_total + first_of_key.len();
    let mut out = Welded {
        positions: vec![Vec3::ZERO; total],
        attrs: vec![Vec3::ZERO; if carry { total } else { 0 }],
        normals: vec![Vec3::ZERO; total],
        ..Default::default()
    };
    // Per piece: its unshared vertices copied out; each vertex's key is replaced by its
    // output index once read (the keys are not needed after that).
    {
        let mut starts = Vec::with_capacity(pieces.len());
        let mut acc = 0usize;
        for n in &own_unshared {
            starts.push(acc);
            acc += n;
        }
        let pos = chunks_mut(&mut out.positions[..unshared_total], own_unshared.iter().copied());
        let tex = chunks_mut(&mut out.attrs[..if carry { unshared_total } else { 0 }], own_unshared.iter().map(|&n| if carry { n } else { 0 }));
        let nrm = chunks_mut(&mut out.normals[..unshared_total], own_unshared.iter().copied());
        pieces.par_iter_mut().zip(pos).zip(tex).zip(nrm).zip(starts).for_each(|((((p, pos), tex), nrm), start)| {
            let mut k = 0;
            for i in 0..p.keys.len() {
                if p.keys[i] == UNSHARED {
                    pos[k] = p.pos[i];
                    if carry {
                        tex[k] = p.attr[i];
                    }
                    nrm[k] = p.grad[i];
                    p.keys[i] = (start + k) as u128;
                    k += 1;
                }
            }
        });
    }
    for (s, &(_, pi, i)) in shared.iter().enumerate() {
        let (p, id) = (&mut pieces[pi as usize], shared_id[s] as usize);
        if s == 0 || shared[s - 1].0 != shared[s].0 {
            out.positions[id] = p.pos[i as usize];
            if carry {
                out.attrs[id] = p.attr[i as usize];
            }
        }
        out.normals[id] += p.grad[i as usize];
        p.keys[i as usize] = id as u128;
    }
    let tri_counts: Vec<usize> = pieces.iter().map(|p| p.tris.len()).collect();
    let total_tris = tri_counts.iter().sum();
    out.triangles = vec![[0; 3]; total_tris];
    out.corner_attrs = vec![[Vec3::ZERO; 3]; if carry { total_tris } else { 0 }];
    out.tags = vec![0; total_tris];
    let tris = chunks_mut(&mut out.triangles, tri_counts.iter().copied());
    let corner_tex = chunks_mut(&mut out.corner_attrs, tri_counts.iter().map(|&n| if carry { n } else { 0 }));
    let tag_of = chunks_mut(&mut out.tags, tri_counts.iter().copied());
    pieces.par_iter().zip(tris).zip(corner_tex).zip(tag_of).enumerate().for_each(|(pi, (((p, dst), tex), tag))| {
        for (d, t) in dst.iter_mut().zip(&p.tris) {
            *d = t.map(|i| p.keys[i as usize] as u32);
        }
        for (c, t) in tex.iter_mut().zip(&p.tris) {
            *c = t.map(|i| p.attr[i as usize]);
        }
        tag.fill(tags[pi]);
    });
    // Freeing thousands of pieces takes a while; the caller need not wait for it.
    rayon::spawn(move || drop(pieces));
    let flat = |n: &Vec3| !(n.length_squared() > 1e-20); // NaN too
    if out.normals.par_iter().any(flat) {
        let mut face = vec![Vec3::ZERO; out.positions.len()];
        for t in &out.triangles {
            let [a, b, c] = t.map(|i| out.positions[i as usize]);
            let nrm = (b - a).cross(c - a);
            t.iter().for_each(|i| face[*i as usize] += nrm);
        }
        for (n, f) in out.normals.iter_mut().zip(face) {
            if flat(n) {
                *n = f;
            }
        }
    }
    out.normals.par_iter_mut().for_each(|n| *n = n.normalize_or_zero());
    out
}
