//! The *joint trade* of the restore (issue 14's 95% rule; not from the thesis): a
//! vertex with room (its normal line meets no other surface within its thickness)
//! left short because lengthening it alone folds a cell with its neighbours or
//! crosses the facing skin is lifted to just over 95% of its target together with
//! shortening what blocks it, where that keeps the mean thickness ratio.
//!
//! For a short vertex `v` with room, along its own direction and then its normal:
//! `v` is set to [`AT_GOAL`] of its target and the shell checked around it; the
//! corners of every defect found (its neighbours' cells, the facing skin
//! triangles) become *blockers*. The blockers are then, in turn: turned onto their
//! normals at their length, turned halfway, and shortened together to a share `s`
//! of their length. `s` is the least share whose loss of
//! ratio (summed over the blockers) is at most `v`'s gain, so that the mean ratio
//! cannot drop; a blocker at 95% or more of its target keeps at least [`AT_GOAL`] of
//! it (no vertex leaves the 95% rule for another). The first that is clean is kept,
//! `s` raised by bisection ([`STEPS`]) to the least loss that stays clean; where none
//! is, the last one's defects with new corners add blockers, for at most [`ROUNDS`]
//! rounds and [`MOST_BLOCKERS`]. Every kept trade was checked exactly around all it moved, so a clean
//! shell stays clean. Measured (exterior 20%): the blade's share of vertices with
//! room at 95% 0.955 -> 0.983 (mean ratio 0.918 -> 0.935; 0.994 and 0.945 with four
//! rounds and no bound on the blockers, at the knot's cost below), the torus knot's
//! 0.365 -> 0.410 (mean 0.6337 -> 0.6343): there the short vertices' neighbours
//! have no room on their normals either, and turning them folds against the
//! facing strand.

use super::defects::{Checker, Dirty, Findings};
use super::intersect::TriBvh;
use super::restore::{blend, set, unit, Shape, AT_GOAL, GOAL};
use super::Shell;
use crate::Mesh;

/// Most passes over the vertices left short.
const PASSES: usize = 3;

/// Rounds of growing the blockers, and the most blockers a trade moves: on the
/// torus knot at exterior 20% four rounds without a bound cost 18 s of CPU for 92
/// vertices (the restore had taken 0.5 s), most of it checking trades with 30-40
/// blockers that never came clean.
const ROUNDS: usize = 2;
const MOST_BLOCKERS: usize = 16;

/// Bisection steps from the least share of their length the blockers may keep
/// towards their whole length.
const STEPS: usize = 5;

/// One trade's state: the vertex's proposed shape and length, and each blocker's
/// original shape, length and target, the vertex's original first.
struct Trade {
    v: u32,
    shape: Shape,
    length: f32,
    /// (vertex, shape, length): the vertex's, then the blockers'.
    saved: Vec<(u32, Shape, f32)>,
}

/// Tries the trade for each of `short` (vertices with room, in order) still short of
/// [`GOAL`]; `normal` is the normal-offset shell. `outer` is kept in step with
/// `shell`. Returns how many were lifted.
#[allow(clippy::too_many_arguments)]
pub(super) fn trade(
    checker: &Checker,
    outer: &mut TriBvh,
    mesh: &Mesh,
    shell: &mut Shell,
    normal: &Shell,
    short: &[u32],
    dirty: &mut Dirty,
    cancel: Option<&crate::progress::Progress>,
) -> usize {
    let (mut traded, mut pending) = (0, short.to_vec());
    // Passes while one keeps something, each over the vertices beside what the last
    // moved (a trade's shortened blocker may leave room for a vertex tried before).
    for _ in 0..PASSES {
        let mut moved = Vec::new();
        for &v in &pending {
            let w = v as usize;
            if cancel.is_some_and(|p| p.is_cancelled()) {
                return traded;
            }
            if !(shell.achieved[w] < GOAL * shell.target[w]) {
                continue;
            }
            let own = unit(shell, w);
            let along = unit(normal, w);
            let ways = [blend(own.or(along), along, 0.0), if own.is_some() { blend(own, along, 1.0) } else { None }];
            for shape in ways.into_iter().flatten() {
                if let Some(group) = trade_one(checker, outer, mesh, shell, normal, v, shape, dirty) {
                    traded += 1;
                    moved.extend(group);
                    break;
                }
            }
        }
        if moved.is_empty() {
            break;
        }
        let mut near = vec![false; shell.target.len()];
        moved.iter().flat_map(|&w| checker.cell_corners_around(w as usize)).chain(moved.iter().copied()).for_each(|w| near[w as usize] = true);
        pending.retain(|&v| near[v as usize] && shell.achieved[v as usize] < GOAL * shell.target[v as usize]);
    }
    traded
}

/// The trade for `v` with its unit shape `shape`: kept (the vertices it moved) or
/// undone (None).
#[allow(clippy::too_many_arguments)]
fn trade_one(
    checker: &Checker,
    outer: &mut TriBvh,
    mesh: &Mesh,
    shell: &mut Shell,
    normal: &Shell,
    v: u32,
    shape: Shape,
    dirty: &mut Dirty,
) -> Option<Vec<u32>> {
    let w = v as usize;
    let length = AT_GOAL * shell.target[w];
    let gain = (length - shell.achieved[w]) / shell.target[w];
    let mut t =
        Trade { v, shape: (shape.0 * length, shape.1 * length), length, saved: vec![(v, (shell.base_offset[w], shell.directors[w]), shell.achieved[w])] };
    let mut found = apply(checker, outer, mesh, shell, normal, &t, (1.0, 0.0), dirty);
    if found.is_clean() {
        return Some(vec![v]);
    }
    for _ in 0..ROUNDS {
        // New blockers: the defects' corners not yet moved by the trade.
        let fresh: Vec<u32> = checker.defect_vertex_list(&found).into_iter().filter(|b| !t.saved.iter().any(|s| s.0 == *b)).collect();
        if fresh.is_empty() || t.saved.len() + fresh.len() > MOST_BLOCKERS + 1 {
            break;
        }
        t.saved.extend(fresh.into_iter().map(|b| (b, (shell.base_offset[b as usize], shell.directors[b as usize]), shell.achieved[b as usize])));
        let least = least_share(shell, &t, gain);
        // Turned towards their normals at their length (the mean kept as it is),
        // then shortened as far as the mean allows, then both.
        for (s, turn) in [(1.0, 1.0), (1.0, 0.5), (least, 0.0)] {
            found = apply(checker, outer, mesh, shell, normal, &t, (s, turn), dirty);
            if !found.is_clean() {
                continue;
            }
            // The least loss that stays clean.
            let (mut ok, mut bad, mut last_ok) = (s, 1.0f32, true);
            for _ in 0..if s < 1.0 { STEPS } else { 0 } {
                let mid = 0.5 * (ok + bad);
                last_ok = apply(checker, outer, mesh, shell, normal, &t, (mid, turn), dirty).is_clean();
                match last_ok {
                    true => ok = mid,
                    false => bad = mid,
                }
            }
            if !last_ok {
                apply(checker, outer, mesh, shell, normal, &t, (ok, turn), dirty);
            }
            return Some(t.saved.iter().map(|s| s.0).collect());
        }
    }
    // Undone: everything back as it was (clean).
    for &(b, s, l) in &t.saved {
        set(shell, b as usize, s, l);
    }
    checker.mark_anew(t.saved.iter().map(|s| s.0), dirty);
    checker.refit_outer(mesh, shell, outer, &dirty.tri_list);
    None
}

/// A blocker's length at share `s` of its original `length`: not below [`AT_GOAL`]
/// of its target where it was at [`GOAL`] or more.
fn kept(s: f32, length: f32, target: f32) -> f32 {
    let floor = if length >= GOAL * target { (AT_GOAL * target).min(length) } else { 0.0 };
    (s * length).max(floor)
}

/// The least share of their lengths the blockers of `t` may keep, their loss of
/// ratio not above `gain`.
fn least_share(shell: &Shell, t: &Trade, gain: f32) -> f32 {
    let loss = |s: f32| -> f32 { t.saved[1..].iter().map(|&(b, _, l)| (l - kept(s, l, shell.target[b as usize])) / shell.target[b as usize]).sum() };
    if loss(0.0) <= gain {
        return 0.0;
    }
    let (mut lo, mut hi) = (0.0f32, 1.0f32); // loss(lo) > gain >= loss(hi)
    for _ in 0..20 {
        let mid = 0.5 * (lo + hi);
        match loss(mid) <= gain {
            true => hi = mid,
            false => lo = mid,
        }
    }
    hi
}

/// Sets the vertex of `t` to its proposed shape and its blockers to share `s` of
/// their lengths, turned by `turn` towards their normals, and checks the shell
/// around all of them.
#[allow(clippy::too_many_arguments)]
fn apply(
    checker: &Checker,
    outer: &mut TriBvh,
    mesh: &Mesh,
    shell: &mut Shell,
    normal: &Shell,
    t: &Trade,
    (s, turn): (f32, f32),
    dirty: &mut Dirty,
) -> Findings {
    set(shell, t.v as usize, t.shape, t.length);
    for &(b, (o, d), l) in &t.saved[1..] {
        let w = b as usize;
        let now = kept(s, l, shell.target[w]);
        match (l > 0.0 && l.is_finite()).then(|| blend(Some((o / l, d / l)), unit(normal, w), turn)).flatten() {
            Some((o, d)) => set(shell, w, (o * now, d * now), now),
            None => set(shell, w, (o, d), l),
        }
    }
    checker.mark_anew(t.saved.iter().map(|s| s.0), dirty);
    checker.refit_outer(mesh, shell, outer, &dirty.tri_list);
    checker.find(mesh, shell, Some(dirty), Some(outer))
}
