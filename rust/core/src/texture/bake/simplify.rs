//! Simplification of one cell's piece of a bake to its share of the triangle budget:
//! meshoptimizer's quadric edge collapse, within an absolute error (a fraction of a
//! lattice step, so the silhouette stays where the sampling put it). The vertices on
//! the cell's rim and their neighbours are locked, so every rim vertex keeps its whole
//! one-ring: the rim stays as the neighbouring piece has it, and no collapse can draw
//! a chord between two rim vertices across the cell's face (the neighbour could draw
//! the same one, and the edge would be used four times). A result that is not a
//! manifold piece with the same rim (edge collapse does not test the link condition:
//! a thin strand can close into a sheet) is refused, once pillows are dropped; the
//! vertices around the faults are locked and their connected parts simplified again,
//! or in the end the piece is kept whole.

use crate::polygonize::validate::vertex_fans;
use crate::polygonize::weld::{Piece, UNSHARED};
use crate::shell::intersect::triangles_meet;
use crate::spatial::{tri_box, Bvh};
use glam::DVec3;
use meshopt::{SimplifyOptions, VertexDataAdapter};
use rayon::prelude::*;

/// Attempts before a piece whose simplification keeps failing is kept whole.
const ATTEMPTS: usize = 6;

/// Simplifies `piece` toward `target` triangles, moving the surface by at most `error`
/// (world units). Each connected part (a fur strand, a ring of chain mail) is
/// simplified on its own, to its share of `target`, and only the parts with a fault
/// are simplified again: a bake's piece holds a hundred or more parts, and nearly every
/// piece had a fault somewhere (a strand tip collapsed into a pillow, a neck into an
/// edge), so simplifying the whole piece again took 2.3 simplifications per piece.
pub(super) fn simplify(piece: Piece, target: usize, error: f32) -> Piece {
    simplify_fixed(piece, target, error, &[]).0
}

/// [`simplify`] with the vertices where `fixed` is true locked too (none where it is
/// empty). Also returns each output vertex's index in `piece`.
pub(super) fn simplify_fixed(piece: Piece, target: usize, error: f32, fixed: &[bool]) -> (Piece, Vec<u32>) {
    let same = |piece: Piece| {
        let n = piece.pos.len() as u32;
        (piece, (0..n).collect())
    };
    if target >= piece.tris.len() || piece.tris.len() < 8 {
        return same(piece);
    }
    let share = target as f64 / piece.tris.len() as f64;
    let ring = OneRings::new(&piece.tris, piece.pos.len());
    let on_rim = |v: u32| piece.keys[v as usize] != UNSHARED;
    let mut lock: Vec<bool> = (0..piece.pos.len() as u32).map(|v| on_rim(v) || fixed.get(v as usize).copied().unwrap_or(false)).collect();
    for v in (0..piece.pos.len() as u32).filter(|&v| on_rim(v)) {
        ring.of(v).iter().for_each(|&w| lock[w as usize] = true);
    }
    let parts = Parts::of(&piece.tris, piece.pos.len());
    let before = Shape::of(&piece.tris, piece.pos.len());
    let mut kept: Vec<Vec<[u32; 3]>> = parts.tris.iter().map(|p| p.iter().map(|&t| piece.tris[t as usize]).collect()).collect();
    let mut redo: Vec<bool> = vec![true; kept.len()];
    let mut simplified = vec![false; kept.len()];
    for _ in 0..ATTEMPTS {
        for (c, part) in kept.iter_mut().enumerate().filter(|(c, _)| redo[*c]) {
            *part = simplify_part(&piece, &parts.tris[c], &lock, share, error);
            simplified[c] = true;
        }
        let fresh: Vec<bool> = kept.iter().zip(&redo).flat_map(|(p, &r)| std::iter::repeat_n(r, p.len())).collect();
        let tris = kept.concat();
        if tris.len() == piece.tris.len() {
            return same(piece);
        }
        let faulty = faults(&piece, &before, &tris, &fresh);
        if faulty.is_empty() {
            return compact(piece, tris);
        }
        // Lock two rings around each fault, and simplify its part again.
        redo.iter_mut().for_each(|r| *r = false);
        for v in faulty {
            redo[parts.of_vertex[v as usize] as usize] = true;
            lock[v as usize] = true;
            for &w in ring.of(v) {
                lock[w as usize] = true;
                ring.of(w).iter().for_each(|&x| lock[x as usize] = true);
            }
        }
    }
    // Still faulty after every attempt: those parts as the lattice made them, the
    // others simplified, where that has no fault (bubbles on a 320-face head: 22
    // cells of 320 were kept whole, 516 k triangles for a share of 69 k).
    for (c, part) in kept.iter_mut().enumerate().filter(|(c, _)| redo[*c]) {
        *part = parts.tris[c].iter().map(|&t| piece.tris[t as usize]).collect();
        simplified[c] = false;
    }
    let fresh: Vec<bool> = kept.iter().zip(&simplified).flat_map(|(p, &r)| std::iter::repeat_n(r, p.len())).collect();
    let tris = kept.concat();
    if tris.len() < piece.tris.len() && faults(&piece, &before, &tris, &fresh).is_empty() {
        return compact(piece, tris);
    }
    same(piece)
}

/// The triangles `part` (indices into `piece.tris`) simplified toward their `share`
/// within `error`, `lock`ed vertices kept, as triangles of `piece`'s vertices.
fn simplify_part(piece: &Piece, part: &[u32], lock: &[bool], share: f64, error: f32) -> Vec<[u32; 3]> {
    let original = || part.iter().map(|&t| piece.tris[t as usize]).collect();
    // Nothing may move (a part far from a group's freed rims): checked before the
    // part's vertices are numbered, as most parts of a group are so.
    if part.len() < 2 || part.iter().all(|&t| piece.tris[t as usize].iter().all(|&v| lock[v as usize])) {
        return original();
    }
    // The part's own vertices, numbered from 0 (meshoptimizer's work is per vertex).
    let mut local: std::collections::HashMap<u32, u32> = std::collections::HashMap::with_capacity(part.len());
    let mut global = Vec::with_capacity(part.len());
    let indices: Vec<u32> = part
        .iter()
        .flat_map(|&t| piece.tris[t as usize])
        .map(|v| {
            *local.entry(v).or_insert_with(|| {
                global.push(v);
                global.len() as u32 - 1
            })
        })
        .collect();
    let pos: Vec<glam::Vec3> = global.iter().map(|&v| piece.pos[v as usize]).collect();
    let locks: Vec<bool> = global.iter().map(|&v| lock[v as usize]).collect();
    let Ok(adapter) = VertexDataAdapter::new(bytemuck::cast_slice(&pos), std::mem::size_of::<glam::Vec3>(), 0) else {
        return original();
    };
    let target = (part.len() as f64 * share).ceil() as usize;
    let kept = meshopt::simplify_with_locks(&indices, &adapter, &locks, target * 3, error, SimplifyOptions::ErrorAbsolute, None);
    let mut tris: Vec<[u32; 3]> = kept.chunks_exact(3).map(|t| [global[t[0] as usize], global[t[1] as usize], global[t[2] as usize]]).collect();
    drop_pillows(&mut tris);
    tris
}

/// Removes pairs of coincident opposite triangles (the same three vertices, facing
/// both ways): where a strand's tip thinner than the error collapses into such a
/// pillow, alone or glued to the surface along its edges (those edges then used four
/// times). It encloses nothing, and without it the rest is closed as before (it used
/// each of its edges once each way); what is still faulty is found by [`faults`].
/// They were most of the first attempt's faults (fur on a 320-face head: 2,811 pillows
/// in 320 pieces, and 7,550 directed edges used twice, 2,116 once they are dropped).
fn drop_pillows(tris: &mut Vec<[u32; 3]>) {
    // Each triangle as its vertex set and whether its least vertex is followed by
    // the greater of the other two (its orientation).
    let mut keyed: Vec<([u32; 3], bool, usize)> = tris
        .iter()
        .enumerate()
        .map(|(i, &t)| {
            let k = (0..3).min_by_key(|&k| t[k]).unwrap_or(0);
            let (b, c) = (t[(k + 1) % 3], t[(k + 2) % 3]);
            ([t[k], b.min(c), b.max(c)], b > c, i)
        })
        .collect();
    keyed.sort_unstable();
    let mut gone = vec![false; tris.len()];
    for group in keyed.chunk_by(|a, b| a.0 == b.0).filter(|g| g.len() > 1) {
        // Pair each triangle facing one way with one facing the other.
        for (a, b) in group.iter().filter(|k| !k.1).zip(group.iter().filter(|k| k.1)) {
            (gone[a.2], gone[b.2]) = (true, true);
        }
    }
    let mut i = 0;
    tris.retain(|_| {
        i += 1;
        !gone[i - 1]
    });
}

/// A triangle list's connected parts (through shared vertices): each part's triangles,
/// and each vertex's part.
struct Parts {
    tris: Vec<Vec<u32>>,
    of_vertex: Vec<u32>,
}

impl Parts {
    fn of(tris: &[[u32; 3]], vertices: usize) -> Self {
        let shared = crate::mesh::parts_of(vertices, tris.iter().map(|t| t.as_slice()));
        // Numbered in order of their first triangle; a vertex of no triangle has none.
        let mut index = vec![u32::MAX; shared.count];
        let mut parts: Vec<Vec<u32>> = Vec::new();
        for (i, t) in tris.iter().enumerate() {
            let r = shared.of[t[0] as usize] as usize;
            if index[r] == u32::MAX {
                index[r] = parts.len() as u32;
                parts.push(Vec::new());
            }
            parts[index[r] as usize].push(i as u32);
        }
        let of_vertex = shared.of.iter().map(|&r| index[r as usize]).collect();
        Self { tris: parts, of_vertex }
    }
}

/// Each vertex's neighbours, in one array (compressed rows).
struct OneRings {
    start: Vec<u32>,
    neighbours: Vec<u32>,
}

impl OneRings {
    fn new(tris: &[[u32; 3]], vertices: usize) -> Self {
        // Each vertex's two neighbours in each of its triangles, bucketed by vertex
        // (counting sort), then each short row sorted and its repeats dropped (the
        // same rows as sorting all six pairs per triangle, which was most of this).
        let mut start = vec![0u32; vertices + 1];
        for t in tris {
            t.iter().for_each(|&v| start[v as usize + 1] += 2);
        }
        for v in 0..vertices {
            start[v + 1] += start[v];
        }
        let mut fill = start.clone();
        let mut all = vec![0u32; start[vertices] as usize];
        for t in tris {
            for k in 0..3 {
                let v = t[k] as usize;
                let at = fill[v] as usize;
                (all[at], all[at + 1]) = (t[(k + 1) % 3], t[(k + 2) % 3]);
                fill[v] += 2;
            }
        }
        // Compacted rows: `start` becomes each row's start after deduplication.
        let mut neighbours = Vec::with_capacity(all.len() / 2);
        let mut from = 0;
        for v in 0..vertices {
            let row = &mut all[from..start[v + 1] as usize];
            from = start[v + 1] as usize;
            row.sort_unstable();
            start[v] = neighbours.len() as u32;
            let mut last = None;
            for &w in row.iter() {
                if last != Some(w) {
                    neighbours.push(w);
                    last = Some(w);
                }
            }
        }
        start[vertices] = neighbours.len() as u32;
        Self { start, neighbours }
    }

    fn of(&self, v: u32) -> &[u32] {
        &self.neighbours[self.start[v as usize] as usize..self.start[v as usize + 1] as usize]
    }
}

fn edge(a: u32, b: u32) -> u64 {
    (u64::from(a) << 32) | u64::from(b)
}

fn ends(e: u64) -> [u32; 2] {
    [(e >> 32) as u32, e as u32]
}

/// A triangle list's sorted directed edges, its open ones (no reverse), its
/// triangles sorted, and each vertex's number of fans ([`vertex_fans`]). Edge collapse
/// can pinch two sheets together at a vertex (a neck thinner than the error collapsed
/// to a point) while every edge stays used twice: Blender's bmesh then calls the
/// vertex not manifold (chain mail on Suzanne's head, interior 5%, 16 x 16 x 8
/// texture: 5 such vertices; the cup's exterior: 76), and so do booleans and slicers.
struct Shape {
    directed: Vec<u64>,
    open: Vec<u64>,
    tris: Vec<[u32; 3]>,
    fans: Vec<u8>,
}

impl Shape {
    fn of(tris: &[[u32; 3]], vertices: usize) -> Self {
        let mut directed: Vec<u64> = tris.iter().flat_map(|t| (0..3).map(move |k| edge(t[k], t[(k + 1) % 3]))).collect();
        directed.sort_unstable();
        let open = directed.iter().copied().filter(|&e| {
            let [a, b] = ends(e);
            directed.binary_search(&edge(b, a)).is_err()
        });
        let open = open.collect();
        let mut sorted = tris.to_vec();
        sorted.sort_unstable();
        Self { directed, open, tris: sorted, fans: vertex_fans(vertices, tris) }
    }

    fn has_edge(&self, a: u32, b: u32) -> bool {
        self.directed.binary_search(&edge(a, b)).is_ok() || self.directed.binary_search(&edge(b, a)).is_ok()
    }
}

/// The vertices of `after` where it is not a manifold piece with the rim of `piece`
/// (whose shape is `before`): on directed edges used twice, on edges open in one and
/// not the other, on new edges joining two rim vertices, in degenerate or new flat
/// triangles (zero area), in coincident ones (also
/// opposite: equal vertex sets), at vertices pinched into more fans than they had,
/// or in [`crossings`].
fn faults(piece: &Piece, before: &Shape, after: &[[u32; 3]], fresh: &[bool]) -> Vec<u32> {
    let now = Shape::of(after, piece.pos.len());
    let mut bad: Vec<u32> = now.directed.windows(2).filter(|w| w[0] == w[1]).flat_map(|w| ends(w[0])).collect();
    bad.extend((0..piece.pos.len() as u32).filter(|&v| now.fans[v as usize] > before.fans[v as usize]));
    // Open edges changed: merge the two sorted lists.
    let (mut i, mut j) = (0, 0);
    while i < before.open.len() || j < now.open.len() {
        match (before.open.get(i), now.open.get(j)) {
            (Some(a), Some(b)) if a == b => (i, j) = (i + 1, j + 1),
            (Some(a), Some(b)) if a < b => {
                bad.extend(ends(*a));
                i += 1;
            }
            (Some(a), None) => {
                bad.extend(ends(*a));
                i += 1;
            }
            (_, Some(b)) => {
                bad.extend(ends(*b));
                j += 1;
            }
            (None, None) => unreachable!(),
        }
    }
    let on_rim = |v: u32| piece.keys[v as usize] != UNSHARED;
    bad.extend(now.directed.iter().map(|&e| ends(e)).filter(|&[a, b]| on_rim(a) && on_rim(b) && !before.has_edge(a, b)).flatten());
    let flat_and_new = |t: &[u32; 3]| {
        let [a, b, c] = t.map(|v| piece.pos[v as usize]);
        (b - a).cross(c - a) == glam::Vec3::ZERO && before.tris.binary_search(t).is_err()
    };
    bad.extend(after.iter().filter(|t| t[0] == t[1] || t[1] == t[2] || t[0] == t[2] || flat_and_new(t)).flatten());
    let mut sets: Vec<[u32; 3]> = after
        .iter()
        .map(|t| {
            let mut t = *t;
            t.sort_unstable();
            t
        })
        .collect();
    sets.sort_unstable();
    bad.extend(sets.windows(2).filter(|w| w[0] == w[1]).flat_map(|w| w[0]));
    bad.extend(crossings(piece, before, after, fresh));
    bad.sort_unstable();
    bad.dedup();
    bad
}

/// How close two triangles sharing no vertex may come before they count as touching.
/// Contacts within `f32` rounding (about 1e-7 of the coordinates) are ambiguous, and
/// common after collapses among the lattice's regular vertices; Blender's own overlap
/// test sees them only where a needle lies along a neighbour (its plane is
/// ill-defined). So 1e-6 of the longer triangle's longest edge where either is a
/// needle (least altitude under 1e-4 of its longest edge, found on the bakes where
/// Blender reported contacts), else 1e-9: exact contacts (a vertex on another
/// triangle's plane in `f32` coordinates) are caught either way.
fn touch(a: &[DVec3; 3], b: &[DVec3; 3]) -> f64 {
    let longest = |t: &[DVec3; 3]| (0..3).map(|k| t[k].distance_squared(t[(k + 1) % 3])).fold(0.0, f64::max).sqrt();
    let needle = |t: &[DVec3; 3]| (t[1] - t[0]).cross(t[2] - t[0]).length() < 1e-4 * longest(t) * longest(t);
    let scale = longest(a).max(longest(b));
    if needle(a) || needle(b) {
        1e-6 * scale
    } else {
        1e-9 * scale
    }
}

/// The vertices of the new triangles of `after` (those not in `before`) that cross or
/// touch ([`triangles_meet`]) another triangle of `after` sharing no vertex with it,
/// and of those they meet. A collapse moves the surface by up to the error, which can push
/// it through a sheet closer than that.
fn crossings(piece: &Piece, before: &Shape, after: &[[u32; 3]], fresh: &[bool]) -> Vec<u32> {
    let corners = |t: &[u32; 3]| t.map(|v| piece.pos[v as usize].as_dvec3());
    let tris: Vec<[DVec3; 3]> = after.iter().map(corners).collect();
    let new: Vec<u32> = (0..after.len() as u32).filter(|&i| fresh[i as usize] && before.tris.binary_search(&after[i as usize]).is_err()).collect();
    overlapping_boxes(&tris, &new, |i, j, bad| {
        let (t, u) = (&after[i], &after[j]);
        if !u.iter().any(|v| t.contains(v)) && triangles_meet(&tris[i], &tris[j], touch(&tris[i], &tris[j])) {
            bad.extend(t.iter().chain(u));
        }
    })
}

/// What `found(i, j, out)` collects for each `i` of `asking` and `j` of `tris` whose
/// boxes overlap (`j` may equal `i`). Where few are asked (a group of the hierarchy,
/// most of it locked, or its new triangles among the whole bake's) a tree of those is
/// asked with every triangle, otherwise a tree of all with each asked one: the same
/// pairs, far less building.
fn overlapping_boxes<T: Send>(tris: &[[DVec3; 3]], asking: &[u32], found: impl Fn(usize, usize, &mut Vec<T>) + Sync) -> Vec<T> {
    if asking.len() * 4 < tris.len() {
        let few: Vec<[DVec3; 3]> = asking.iter().map(|&i| tris[i as usize]).collect();
        let tree = Bvh::from_triangles(&few);
        (0..tris.len())
            .into_par_iter()
            .flat_map_iter(|j| {
                let (lo, hi) = tri_box(&tris[j]);
                let mut out = Vec::new();
                tree.query(lo, hi, |k| found(asking[k as usize] as usize, j, &mut out));
                out
            })
            .collect()
    } else {
        let tree = Bvh::from_triangles(tris);
        asking
            .par_iter()
            .flat_map_iter(|&i| {
                let (lo, hi) = tri_box(&tris[i as usize]);
                let mut out = Vec::new();
                tree.query(lo, hi, |j| found(i as usize, j as usize, &mut out));
                out
            })
            .collect()
    }
}

/// The piece with only `tris` and the vertices they use, and each one's index in `piece`.
fn compact(piece: Piece, tris: Vec<[u32; 3]>) -> (Piece, Vec<u32>) {
    let mut map = vec![u32::MAX; piece.pos.len()];
    let mut out = Piece::default();
    let mut from = Vec::new();
    for &v in tris.iter().flatten() {
        if map[v as usize] == u32::MAX {
            map[v as usize] = out.pos.len() as u32;
            from.push(v);
            out.keys.push(piece.keys[v as usize]);
            out.pos.push(piece.pos[v as usize]);
            out.attr.push(piece.attr[v as usize]);
            out.grad.push(piece.grad[v as usize]);
        }
    }
    out.tris = tris.into_iter().map(|t| t.map(|v| map[v as usize])).collect();
    out.simplified = true;
    (out, from)
}

/// The simplified pieces with a triangle crossing or touching ([`triangles_meet`]) a
/// triangle of another piece (triangles joined at a rim vertex, whose keys match, do
/// not count). Each
/// piece checked its own triangles ([`crossings`]), and its rim is kept, but near the
/// rim a simplified triangle may still pass through a neighbour's where the surface
/// runs along the cell's curved side face. The bake puts such pieces back unsimplified,
/// and checks again until none is left (the lattice's own surface has no crossings).
pub(super) fn crossing_pieces(pieces: &[Piece]) -> Vec<usize> {
    if !pieces.iter().any(|p| p.simplified) {
        return Vec::new();
    }
    let mut bad = meeting_pieces(pieces, |p, _| pieces[p].simplified, |_, _| true);
    bad.retain(|&p| pieces[p].simplified);
    bad
}

/// The pieces with a triangle crossing or touching a triangle of another piece, where
/// one of the two is `asked(piece, triangle)`, and those they meet: where no two
/// pieces met before some triangles were made, only those need asking. Pairs of
/// pieces that are not `apart(piece, other)` are not tested (their triangles were
/// tested against each other already: a group of the hierarchy, simplified as one).
pub(super) fn meeting_pieces(pieces: &[Piece], asked: impl Fn(usize, usize) -> bool + Sync, apart: impl Fn(usize, usize) -> bool + Sync) -> Vec<usize> {
    let owner: Vec<(u32, u32)> = pieces.iter().enumerate().flat_map(|(p, piece)| (0..piece.tris.len() as u32).map(move |t| (p as u32, t))).collect();
    let corners = |(p, t): (u32, u32)| {
        let piece = &pieces[p as usize];
        piece.tris[t as usize].map(|v| piece.pos[v as usize].as_dvec3())
    };
    let tris: Vec<[DVec3; 3]> = owner.par_iter().map(|&o| corners(o)).collect();
    let asking: Vec<u32> = (0..owner.len() as u32).into_par_iter().filter(|&i| asked(owner[i as usize].0 as usize, owner[i as usize].1 as usize)).collect();
    // A vertex's identity across pieces: its rim key, or (piece, index) inside.
    let id = |p: u32, v: u32| {
        let key = pieces[p as usize].keys[v as usize];
        if key == UNSHARED {
            (u128::from(p) << 32 | u128::from(v), false)
        } else {
            (key, true)
        }
    };
    let ids = |i: usize| {
        let (p, t) = owner[i];
        pieces[p as usize].tris[t as usize].map(|v| id(p, v))
    };
    // Whether asked triangle `i` (its vertices' identities `ids`) meets triangle `j`
    // of another piece, apart from it, sharing no vertex with it.
    let meet = |i: usize, ids: &[(u128, bool); 3], j: usize| {
        let (q, u) = owner[j];
        !pieces[q as usize].tris[u as usize].iter().any(|&w| ids.contains(&id(q, w))) && triangles_meet(&tris[i], &tris[j], touch(&tris[i], &tris[j]))
    };
    let asks = |i: usize, j: usize| owner[i].0 != owner[j].0 && apart(owner[i].0 as usize, owner[j].0 as usize);
    let mut bad: Vec<usize> = overlapping_boxes(&tris, &asking, |i, j, out| {
        if asks(i, j) && meet(i, &ids(i), j) {
            out.extend([owner[i].0 as usize, owner[j].0 as usize]);
        }
    });
    bad.sort_unstable();
    bad.dedup();
    bad
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sorted(mut tris: Vec<[u32; 3]>) -> Vec<[u32; 3]> {
        tris.sort_unstable();
        tris
    }

    #[test]
    fn pillows_are_dropped_in_pairs_and_parts_are_found() {
        // A tetrahedron with a pillow glued onto one face (its triangle three times,
        // once facing in), and a pillow alone with a third copy.
        let mut tris = vec![[0, 1, 2], [0, 2, 3], [0, 3, 1], [1, 3, 2], [1, 2, 0], [0, 2, 1], [4, 5, 6], [6, 5, 4], [5, 6, 4]];
        let parts = Parts::of(&tris, 8);
        assert_eq!(parts.tris, vec![vec![0, 1, 2, 3, 4, 5], vec![6, 7, 8]]);
        assert_eq!(parts.of_vertex[..7], [0, 0, 0, 0, 1, 1, 1]);
        drop_pillows(&mut tris);
        // One opposite pair each: the tetrahedron is closed again, one copy is left.
        assert_eq!(tris.len(), 5);
        assert_eq!(sorted(tris[..4].to_vec()), sorted(vec![[0, 2, 3], [0, 3, 1], [1, 3, 2], [1, 2, 0]]));
        assert!(tris[4] == [4, 5, 6] || tris[4] == [5, 6, 4]);
        let mut none = vec![[0, 1, 2], [0, 2, 3]];
        drop_pillows(&mut none);
        assert_eq!(none.len(), 2);
    }

    #[test]
    fn fans_count_the_sheets_pinched_at_a_vertex() {
        // Two tetrahedra sharing vertex 0: two fans there, one elsewhere, none unused.
        let tris = vec![[0, 1, 2], [0, 2, 3], [0, 3, 1], [1, 3, 2], [0, 4, 5], [0, 5, 6], [0, 6, 4], [4, 6, 5]];
        assert_eq!(vertex_fans(8, &tris), [2, 1, 1, 1, 1, 1, 1, 0]);
    }

    /// An hourglass (a closed surface of revolution) whose neck is far thinner than
    /// the error: collapsing the neck's ring to a point keeps every edge used twice
    /// but pinches the two bulbs together at one vertex. The simplifier must refuse
    /// that (on the code without the fan check the result had a vertex with 2 fans).
    #[test]
    fn simplifying_never_pinches_a_neck_to_a_vertex() {
        let (segments, rings) = (16u32, 17u32);
        let mut piece = Piece::default();
        // Poles at z = -1 and 1; ring k at z = -1 + 2 (k + 1) / (rings + 1).
        piece.pos.push(glam::Vec3::new(0.0, 0.0, -1.0));
        for k in 0..rings {
            let z = -1.0 + 2.0 * (k + 1) as f32 / (rings + 1) as f32;
            let radius = if k == rings / 2 { 1e-3 } else { 0.4 * (std::f32::consts::PI * (z.abs() - 0.05).max(0.0) / 0.95).sin().max(0.05) };
            for i in 0..segments {
                let a = std::f32::consts::TAU * i as f32 / segments as f32;
                piece.pos.push(glam::Vec3::new(radius * a.cos(), radius * a.sin(), z));
            }
        }
        piece.pos.push(glam::Vec3::new(0.0, 0.0, 1.0));
        let top = piece.pos.len() as u32 - 1;
        let at = |k: u32, i: u32| 1 + k * segments + i % segments;
        for i in 0..segments {
            piece.tris.push([0, at(0, i + 1), at(0, i)]);
            piece.tris.push([top, at(rings - 1, i), at(rings - 1, i + 1)]);
            for k in 0..rings - 1 {
                piece.tris.push([at(k, i), at(k, i + 1), at(k + 1, i + 1)]);
                piece.tris.push([at(k, i), at(k + 1, i + 1), at(k + 1, i)]);
            }
        }
        let n = piece.pos.len();
        (piece.keys, piece.attr, piece.grad) = (vec![UNSHARED; n], vec![glam::Vec3::ZERO; n], vec![glam::Vec3::Z; n]);
        assert!(vertex_fans(n, &piece.tris).iter().all(|&f| f == 1));
        let before = piece.tris.len();
        let out = simplify(piece, 40, 0.05);
        assert!(out.tris.len() < before, "simplified: {} of {before}", out.tris.len());
        let pinched = vertex_fans(out.pos.len(), &out.tris).iter().filter(|&&f| f > 1).count();
        assert_eq!(pinched, 0, "{} triangles", out.tris.len());
        let shape = Shape::of(&out.tris, out.pos.len());
        assert!(shape.open.is_empty() && shape.directed.windows(2).all(|w| w[0] != w[1]));
    }
}
