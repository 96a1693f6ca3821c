//! Hierarchical simplification of a bake's pieces: the cell-by-cell pass locks each
//! cell's rim and its one-ring, so where cells are small next to the texture (World-Size
//! tiles, fine base meshes) those locked rims hold most of the triangles and the bake
//! stays far over its budget (chain mail in World-Size tiles on the 13 k-face fandisk:
//! 4.9 M triangles for a budget of 1 M). Here neighbouring cells are grouped (up to
//! [`GROUP`] at a time, grown breadth first; bottom-up clusters as in multiresolution
//! hierarchies of simplified meshes, e.g. Hoppe's progressive meshes) and each group is
//! simplified as one piece with only its outer rim locked: its inner rims, untouched so
//! far, collapse. The same fault handling as a cell's ([`simplify::simplify`]): the
//! group's result must be a manifold with the same outer rim that neither crosses nor
//! touches itself; a group whose new triangles cross or touch another piece is put
//! back as it was ([`rounds`]: no two pieces met before the round, so only the new
//! triangles need testing).
//!
//! Every vertex but the outer rim and its one-ring may move, by at most the group's
//! error (the largest of its cells'), except the vertices of cells whose own error is
//! under half of that (they stay where their cell put them). So a cell's surface moves
//! by at most its own error in the cell pass and twice its error in the group: three
//! times its error in all, and at most twice the largest error of the group's cells.
//! That error bound is what binds at the add-on's defaults: on `bake_bench --budget`
//! (chain mail in world-size tiles, 5 k faces) the cell pass made 4.51 M triangles, of
//! which 1.49 M lie away from every rim and its one-ring, already at their cells'
//! largest error; the groups bring it to 2.31 M (moving only the freed rims and their
//! one-rings: 2.95 M; groups of 256 or 1024 cells that way: 2.73 M, 2.61 M), and even
//! the whole bake as one group, only UV seams locked, keeps 1.65 M for a budget of 1 M.
//! A rim vertex whose copies disagree in texture coordinates (a UV seam) stays locked,
//! so each cell's texture coordinates stay its own.

use super::simplify;
use crate::polygonize::weld::{Piece, UNSHARED};
use rayon::prelude::*;
use std::collections::HashMap;

/// Nodes (cells, then groups) joined into one group per round. One round of 64 cells
/// (fandisk below: 4.89 M to 2.64 M triangles, closed, no texture-coordinate jumps)
/// did better than four rounds of 4 (groups of 4, 16, 64 and 256 cells: 2.74 M) in
/// 40% of their time: each round simplifies nearly every triangle again, and the
/// freed rims of a round's groups stay locked in the next.
pub(super) const GROUP: usize = 64;

/// Rounds at most. The error bound of the module docs holds for one round: a second
/// would move every vertex again.
const ROUNDS: usize = 1;
const _: () = assert!(ROUNDS == 1, "the module docs' error bound is for one round");

/// How far apart (in tiles) two cells' texture coordinates of one rim vertex may be
/// and still count as the same: each cell interpolates its own, so copies on a rim
/// inside a chart differ by rounding (4e-8 tiles seen); across a seam by far more.
const AGREE: f32 = 1e-4;

/// A key no lattice edge has ([`crate::polygonize::weld::edge_key`] keys have two
/// different ends): for a vertex inside a group that two of its split pieces share.
fn made_key(round: usize, first: usize, v: usize) -> u128 {
    let id = (1u64 << 63) | ((round as u64) << 56) | ((first as u64) << 28) | v as u64;
    (u128::from(id) << 64) | u128::from(id)
}

/// A group's pieces, one per cell, and for each one's triangles whether the group made it.
type Split = (Vec<Piece>, Vec<Vec<bool>>);

/// What the bake knows about each cell for the grouping.
pub(super) struct Cells<'a> {
    /// Triangles each cell's lattice made (its share of the budget is this times the
    /// bake's share).
    pub sampled: &'a [usize],
    /// How far each cell's simplification may move its surface, in world units
    /// (its lattice step times its level's error).
    pub error: &'a [f32],
}

/// Simplifies `pieces` by groups of neighbouring cells while their total is over
/// `budget` (with `tolerance`), at most [`ROUNDS`] rounds; `share` is the fraction of
/// its sampled triangles each cell keeps. Stops between rounds once `cancelled`.
pub(super) fn rounds(pieces: &mut [Piece], cells: &Cells, share: f64, budget: usize, tolerance: f64, cancelled: impl Fn() -> bool) {
    let total = |pieces: &[Piece]| pieces.iter().map(|p| p.tris.len()).sum::<usize>();
    let n = pieces.len();
    // Nodes: groups of cells, each cell's node.
    let mut node_of: Vec<usize> = (0..n).collect();
    let mut nodes = n;
    for round in 0..ROUNDS {
        if budget == 0 || cancelled() || total(pieces) as f64 <= budget as f64 * (1.0 + tolerance) {
            return;
        }
        // Which cells make each rim key.
        let mut owners: HashMap<u128, Vec<u32>> = HashMap::new();
        for (c, p) in pieces.iter().enumerate() {
            for &k in p.keys.iter().filter(|&&k| k != UNSHARED) {
                let o = owners.entry(k).or_default();
                if o.last() != Some(&(c as u32)) {
                    o.push(c as u32);
                }
            }
        }
        // Node adjacency, through shared keys.
        let mut links: Vec<(usize, usize)> = owners
            .values()
            .flat_map(|o| {
                let nodes: Vec<usize> = o.iter().map(|&c| node_of[c as usize]).collect();
                nodes.iter().flat_map(|&a| nodes.iter().map(move |&b| (a, b))).filter(|(a, b)| a != b).collect::<Vec<_>>()
            })
            .collect();
        links.sort_unstable();
        links.dedup();
        let mut start = vec![0usize; nodes + 1];
        for &(a, _) in &links {
            start[a + 1] += 1;
        }
        for i in 0..nodes {
            start[i + 1] += start[i];
        }
        // Greedy groups of up to GROUP nodes, grown breadth first.
        let mut group_of = vec![usize::MAX; nodes];
        let mut groups = 0;
        for seed in 0..nodes {
            if group_of[seed] != usize::MAX {
                continue;
            }
            group_of[seed] = groups;
            let neighbours = |a: usize, visit: &mut dyn FnMut(usize)| links[start[a]..start[a + 1]].iter().for_each(|&(_, b)| visit(b));
            grow_group(&mut vec![seed], 0, GROUP, neighbours, |b| {
                let free = group_of[b] == usize::MAX;
                if free {
                    group_of[b] = groups;
                }
                free
            });
            groups += 1;
        }
        let cell_group: Vec<usize> = node_of.iter().map(|&nd| group_of[nd]).collect();
        let mut members: Vec<Vec<usize>> = vec![Vec::new(); groups];
        for (c, &g) in cell_group.iter().enumerate() {
            members[g].push(c);
        }
        // A key is inside its group where every cell making it is in the group and
        // they were in different nodes (the rims between nodes: untouched so far).
        let inner: HashMap<u128, bool> = owners
            .iter()
            .map(|(&k, o)| {
                let g = cell_group[o[0] as usize];
                let within = o.iter().all(|&c| cell_group[c as usize] == g);
                let across = o.iter().any(|&c| node_of[c as usize] != node_of[o[0] as usize]);
                (k, within && across)
            })
            .collect();
        // The groups' pieces are moved out (not copied: the bake's triangles are held
        // twice at most, before and after), and moved back where nothing changed.
        let mut before: Vec<Vec<Piece>> = members.iter().map(|m| m.iter().map(|&c| std::mem::take(&mut pieces[c])).collect()).collect();
        let made: Vec<Option<Split>> =
            members.par_iter().enumerate().map(|(g, m)| if m.len() < 2 { None } else { simplify_group(round, m, &before[g], &inner, cells, share) }).collect();
        let mut active = vec![false; groups];
        // Each cell's triangles the round made (not among the group's before).
        let mut fresh: Vec<Vec<bool>> = vec![Vec::new(); n];
        for (g, out) in made.into_iter().enumerate() {
            match out {
                Some((out, new)) => {
                    for ((&c, p), new) in members[g].iter().zip(out).zip(new) {
                        (pieces[c], fresh[c]) = (p, new);
                    }
                    active[g] = true;
                }
                None => {
                    for (&c, p) in members[g].iter().zip(std::mem::take(&mut before[g])) {
                        pieces[c] = p;
                    }
                }
            }
        }
        // Groups whose result crosses or touches another piece are put back; before
        // this round no two pieces met, so each pass puts back groups until none meets.
        while active.iter().any(|&a| a) {
            // Only the round's new triangles can meet a piece they did not meet before.
            // A group's own pieces were tested against each other as one piece
            // ([`simplify::simplify_fixed`]'s faults): only other pieces are asked.
            let bad: Vec<usize> = simplify::meeting_pieces(pieces, |c, t| fresh[c].get(t).copied().unwrap_or(false), |c, d| cell_group[c] != cell_group[d])
                .into_iter()
                .map(|c| cell_group[c])
                .filter(|&g| active[g])
                .collect();
            if bad.is_empty() {
                break;
            }
            for g in bad {
                if active[g] {
                    for (&c, p) in members[g].iter().zip(std::mem::take(&mut before[g])) {
                        (pieces[c], fresh[c]) = (p, Vec::new());
                    }
                    active[g] = false;
                }
            }
        }
        node_of = cell_group;
        nodes = groups;
    }
}

/// Grows a group breadth first: appends to `members` the neighbours (each node's
/// `neighbours(node, visit)`) of its members from `first` on that `take` accepts (it
/// marks them taken), until the group has `size` members.
pub(super) fn grow_group(
    members: &mut Vec<usize>,
    first: usize,
    size: usize,
    neighbours: impl Fn(usize, &mut dyn FnMut(usize)),
    mut take: impl FnMut(usize) -> bool,
) {
    let mut i = first;
    while i < members.len() && members.len() - first < size {
        let node = members[i];
        neighbours(node, &mut |n| {
            if members.len() - first < size && take(n) {
                members.push(n);
            }
        });
        i += 1;
    }
}

/// The pieces of the cells `members` (`pieces`, in that order) simplified as one, with
/// `inner` keys free, split back into one piece per cell; `None` where nothing changed.
fn simplify_group(round: usize, members: &[usize], pieces: &[Piece], inner: &HashMap<u128, bool>, cells: &Cells, share: f64) -> Option<Split> {
    // The merged piece: each key's copies become one vertex (free where `inner`
    // and the copies agree in texture coordinates, else locked as the group's rim);
    // each copy's texture coordinates are kept for its own cell.
    let mut merged = Piece::default();
    let mut origin: Vec<usize> = Vec::new(); // each merged vertex's first cell (index in members)
    let mut key_of: Vec<u128> = Vec::new(); // each merged vertex's own key (UNSHARED: none)
    let mut copies: HashMap<u128, u32> = HashMap::new();
    let mut own_attr: HashMap<(u32, usize), glam::Vec3> = HashMap::new();
    let mut movable: Vec<bool> = Vec::new();
    let mut cells_of: Vec<Vec<usize>> = Vec::new(); // the cells (indices in members) with a copy of each merged vertex
    let mut disagree: Vec<bool> = Vec::new(); // copies with different texture coordinates
    for (m, p) in pieces.iter().enumerate() {
        let mut map = Vec::with_capacity(p.pos.len());
        for i in 0..p.pos.len() {
            let (k, attr) = (p.keys[i], p.attr.get(i).copied().unwrap_or_default());
            if k != UNSHARED {
                if let Some(&v) = copies.get(&k) {
                    merged.grad[v as usize] += p.grad[i];
                    if (merged.attr[v as usize] - attr).length() > AGREE {
                        (movable[v as usize], merged.keys[v as usize], disagree[v as usize]) = (false, k, true);
                    }
                    own_attr.insert((v, m), attr);
                    if !cells_of[v as usize].contains(&m) {
                        cells_of[v as usize].push(m);
                    }
                    map.push(v);
                    continue;
                }
                copies.insert(k, merged.pos.len() as u32);
            }
            let v = merged.pos.len() as u32;
            let free = inner.get(&k) == Some(&true);
            merged.pos.push(p.pos[i]);
            merged.attr.push(attr);
            merged.grad.push(p.grad[i]);
            // Free keys are inside the merged piece; the others stay its rim.
            merged.keys.push(if free { UNSHARED } else { k });
            own_attr.insert((v, m), attr);
            cells_of.push(vec![m]);
            disagree.push(false);
            movable.push(free);
            origin.push(m);
            key_of.push(k);
            map.push(v);
        }
        merged.tris.extend(p.tris.iter().map(|t| t.map(|v| map[v as usize])));
    }
    if !movable.iter().any(|&m| m) {
        return None;
    }
    // Every vertex off the group's outer rim and its one-ring may move, not only the
    // freed rims and their one-rings (module doc: 2.31 M triangles against 2.95 M),
    // except those of a cell whose own error is under half the group's (a compressed
    // cell beside a full one): the group's error would move them by more than twice
    // their cell's.
    let sampled: usize = members.iter().map(|&c| cells.sampled[c]).sum();
    let target = (sampled as f64 * share).ceil() as usize;
    let error = members.iter().map(|&c| cells.error[c]).fold(0.0, f32::max);
    let had = merged.tris.len();
    if target >= had || error <= 0.0 {
        return None;
    }
    let fixed: Vec<bool> = cells_of.iter().map(|of| of.iter().any(|&m| cells.error[members[m]] < 0.5 * error)).collect();
    // The merged triangles before, each turned to start at its least vertex.
    let turned = |t: [u32; 3]| {
        let k = (0..3).min_by_key(|&k| t[k]).unwrap_or(0);
        [t[k], t[(k + 1) % 3], t[(k + 2) % 3]]
    };
    let mut original: Vec<[u32; 3]> = merged.tris.iter().map(|&t| turned(t)).collect();
    original.sort_unstable();
    let (out, kept) = simplify::simplify_fixed(merged, target, error, &fixed);
    if out.tris.len() >= had {
        return None;
    }
    // Split back into one piece per cell. A triangle's cell is one that has a copy of
    // each of its corners, so its texture coordinates are all that cell's. Looking
    // only at the cells the corners came from first is not enough: a triangle of cell C
    // whose corners were all first read from cells A and B (copies on C's rims) went to
    // A or B, with a corner's coordinates from across a UV seam (24 triangles jumping
    // by more than a tile in the test of many small cells). Where no cell has all three
    // (a collapse joined two cells' vertices over a freed rim, whose copies agree), the
    // cell of most corners takes the others' coordinates, only from vertices whose
    // copies all agree; otherwise the group is left as it was.
    let owner = |t: &[u32; 3]| -> Option<usize> {
        let orig = t.map(|v| kept[v as usize] as usize);
        if let Some(&m) = cells_of[orig[0]].iter().find(|m| cells_of[orig[1]].contains(m) && cells_of[orig[2]].contains(m)) {
            return Some(m);
        }
        let (m, _) = orig
            .iter()
            .flat_map(|&o| cells_of[o].iter().copied())
            .map(|m| (m, orig.iter().filter(|&&o| cells_of[o].contains(&m)).count()))
            .max_by_key(|&(m, n)| (n, std::cmp::Reverse(m)))?;
        orig.iter().all(|&o| cells_of[o].contains(&m) || !disagree[o]).then_some(m)
    };
    let owners: Vec<usize> = out.tris.iter().map(owner).collect::<Option<_>>()?;
    let mut users: Vec<u32> = vec![u32::MAX; out.pos.len()]; // the one cell using a vertex, or MAX - 1 for several
    let mut uses = vec![0u32; out.pos.len()];
    let mut split: Vec<Piece> = (0..members.len()).map(|_| Piece { simplified: true, ..Piece::default() }).collect();
    let mut fresh: Vec<Vec<bool>> = vec![Vec::new(); members.len()];
    let mut local: Vec<HashMap<u32, u32>> = vec![HashMap::new(); members.len()];
    for (t, &o) in out.tris.iter().zip(&owners) {
        for &v in t {
            if local[o].insert(v, 0).is_none() {
                uses[v as usize] += 1;
            }
            users[v as usize] = match users[v as usize] {
                u32::MAX => o as u32,
                u if u == o as u32 => u,
                _ => u32::MAX - 1,
            };
        }
    }
    local.iter_mut().for_each(HashMap::clear);
    for (t, &m) in out.tris.iter().zip(&owners) {
        let piece = &mut split[m];
        let tri = t.map(|v| {
            *local[m].entry(v).or_insert_with(|| {
                let original = kept[v as usize];
                let key = match key_of[original as usize] {
                    UNSHARED if users[v as usize] == u32::MAX - 1 => made_key(round, members[0], v as usize),
                    k => k,
                };
                piece.keys.push(key);
                piece.pos.push(out.pos[v as usize]);
                piece.attr.push(own_attr.get(&(original, m)).copied().unwrap_or(out.attr[v as usize]));
                // The copies' gradients sum to the merged one, as the weld sums them.
                piece.grad.push(out.grad[v as usize] / uses[v as usize] as f32);
                piece.pos.len() as u32 - 1
            })
        });
        piece.tris.push(tri);
        fresh[m].push(original.binary_search(&turned(t.map(|v| kept[v as usize]))).is_err());
    }
    if pieces.iter().all(|p| p.attr.is_empty()) {
        split.iter_mut().for_each(|p| p.attr.clear());
    }
    Some((split, fresh))
}
