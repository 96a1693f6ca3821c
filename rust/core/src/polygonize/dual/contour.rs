//! Quads: one per sign-changing lattice edge, joining the vertices that the four
//! cells around it give the piece holding that edge (dual contouring, Ju et al. 2002,
//! section 3.2; with one vertex per piece, the manifold variant of Schaefer, Ju and
//! Warren 2007). Then the vertices whose QEF position would fold a quad against the
//! crossing's gradient fall back to their mass point, and each quad is started at the
//! diagonal that splits it best.

use super::block::{cell_index, Block};
use super::cases::{cases, edge};
use super::lattice::BLOCK;
use crate::{Error, Result};
use glam::{UVec3, Vec3};
use rayon::prelude::*;

/// A quad (counter-clockwise seen from outside) and the crossing's gradient.
pub(super) type Quad = ([u32; 4], Vec3);

/// How many times vertices fall back and the quads are checked again. Not from a
/// paper: a fallback can fold a quad that did not fold, rarely more than twice.
const FALLBACK_ROUNDS: usize = 4;

/// The quads of every block's owned edges, in block order; `offsets[b]` is block `b`'s
/// first vertex.
pub(super) fn quads(blocks: &[Block], offsets: &[u32]) -> Result<Vec<Quad>> {
    // Blocks by their position (`z`, `y`, `x`), sorted: a binary search finds each
    // block's lower neighbours once (the default hash map's SipHash cost more).
    let key = |b: UVec3| [b.z, b.y, b.x];
    let mut index: Vec<([u32; 3], u32)> = blocks.iter().enumerate().map(|(i, b)| (key(b.origin / BLOCK), i as u32)).collect();
    index.sort_unstable();
    let table = cases();
    let find = |b: UVec3| index.binary_search_by_key(&key(b), |&(k, _)| k).ok().map(|i| index[i].1 as usize);
    let per_block: Vec<Result<Vec<Quad>>> = blocks
        .par_iter()
        .map(|block| {
            // The cells around an owned edge lie in this block or the ones one step
            // lower along some axes: `near[k]`, bit `a` of `k` set one lower along `a`.
            let home = block.origin / BLOCK;
            let near: [Option<usize>; 8] = std::array::from_fn(|k| {
                let d = UVec3::new(k as u32 & 1, k as u32 >> 1 & 1, k as u32 >> 2 & 1);
                home.cmpge(d).all().then(|| find(home - d)).flatten()
            });
            let vertex = |cell: UVec3, e: usize| -> Option<u32> {
                // Below the lattice (a wrapped coordinate) nothing is near.
                let b = near[(0..3).fold(0, |k, a| k | usize::from(cell[a] / BLOCK != home[a]) << a)]?;
                let local = cell_index(cell % BLOCK);
                let first = blocks[b].first[local];
                let piece = table[blocks[b].config[local] as usize].piece[e];
                (first != u32::MAX && piece != super::cases::NONE).then(|| offsets[b] + first + u32::from(piece))
            };
            let mut out = Vec::with_capacity(block.edges.len());
            for e in &block.edges {
                let a = e.axis as usize;
                let (b, c) = ((a + 1) % 3, (a + 2) % 3);
                let around = [(0, 0), (1, 0), (1, 1), (0, 1)].map(|(sb, sc)| {
                    let mut cell = e.from;
                    cell[b] = cell[b].wrapping_sub(sb);
                    cell[c] = cell[c].wrapping_sub(sc);
                    vertex(cell, edge(a, sb as usize, sc as usize))
                });
                let [Some(v0), Some(v1), Some(v2), Some(v3)] = around else {
                    return Err(Error::InvalidParameter(format!(
                        "the field's bounds ruled out a cell next to a crossing near lattice point {}: its interval or Lipschitz bound does not hold",
                        e.from
                    )));
                };
                out.push((if e.from_inside { [v0, v1, v2, v3] } else { [v3, v2, v1, v0] }, e.normal));
            }
            Ok(out)
        })
        .collect();
    let mut all = Vec::new();
    for q in per_block {
        all.extend(q?);
    }
    Ok(all)
}

/// The smaller agreement of the two triangles of `q` split along `0-2` (or `1-3`
/// with `other`) with `normal`: the cosine of the worse one's normal.
fn agreement(p: &[Vec3], q: &[u32; 4], normal: Vec3, other: bool) -> f32 {
    let [a, b, c, d] = if other { [q[1], q[2], q[3], q[0]] } else { *q }.map(|v| p[v as usize]);
    let n1 = (b - a).cross(c - a).normalize_or_zero();
    let n2 = (c - a).cross(d - a).normalize_or_zero();
    n1.dot(normal).min(n2.dot(normal))
}

/// Final positions: the QEF vertices, except those of quads that fold (a triangle of
/// the better split facing away from the crossing's gradient), which move to their
/// mass point; then every quad is rotated so its better split is `0-2`. Returns the
/// positions and the vertices moved.
pub(super) fn place(qef: Vec<Vec3>, mass: &[Vec3], quads: &mut [Quad]) -> (Vec<Vec3>, Vec<u32>) {
    let mut positions = qef;
    let mut fallen = vec![false; positions.len()];
    let mut moved_list = Vec::new();
    for _ in 0..FALLBACK_ROUNDS {
        let folded: Vec<u32> = quads
            .par_iter()
            .filter(|(q, n)| *n != Vec3::ZERO && agreement(&positions, q, *n, false).max(agreement(&positions, q, *n, true)) <= 0.0)
            .flat_map_iter(|(q, _)| q.iter().copied())
            .collect();
        let mut moved = false;
        for v in folded {
            if !fallen[v as usize] {
                fallen[v as usize] = true;
                positions[v as usize] = mass[v as usize];
                moved_list.push(v);
                moved = true;
            }
        }
        if !moved {
            break;
        }
    }
    quads.par_iter_mut().for_each(|(q, n)| {
        if agreement(&positions, q, *n, true) > agreement(&positions, q, *n, false) {
            *q = [q[1], q[2], q[3], q[0]];
        }
    });
    (positions, moved_list)
}
