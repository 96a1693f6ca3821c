//! Local thickness reduction where the traced shell is still tangled, ending in a
//! shell with no defect at all. The field trajectories never cross, but their
//! straight chords (chapter 3.1, "virtual trajectories") can, in sharp concave corners
//! and where trajectories converge; the thesis accepts this (4.6). We do not: every
//! defect — an inverted cell, or a skin triangle crossing another one or the base
//! ([`super::defects`], exact tests in double precision) — has its corners' directors
//! shortened towards their base points, so thickness is reduced only there.
//!
//! Two phases share one loop:
//! 1. *Repair*, for `rounds` rounds: each defect's corners shrink to the scale at
//!    which that defect alone is gone ([`crossing_scale`]: the exact test of the
//!    pair or cell, re-run on its corners' directors scaled down in steps, then
//!    bisected; the least over the corner's defects, times a margin), or by `factor`
//!    where no scale removes it. Not from the thesis (4.6 accepts crossing chords):
//!    a fixed factor needs dozens of rounds where a director must lose most of its
//!    length (issue 14's scans ran all 80), the scale of the crossing few. A folded
//!    corner already below [`TURN_AT`] of its target that points away from its
//!    side's normal (a trajectory bent by self-intersecting input) turns to the
//!    normal, at the same length: no length unfolds such a cell.
//! 2. *Final check*, until no defect is left: each defect's corners are halved and
//!    their neighbours shortened less (a smooth fall-off over [`FALL_OFF`] rings). A
//!    director below [`SNAP`] of its target becomes zero. Zero thickness is always
//!    valid (a flat cell is not inverted, the skins then lie on a base that does not
//!    cross itself, and crossings inherited from a self-intersecting base are not
//!    defects), and every round shortens a non-zero director of each defect, so the
//!    loop ends; after [`HALVING_ROUNDS`] it sets defect corners to zero at once, which
//!    bounds it by the vertex count.
//!
//! There is no floor: where two parts touch, the shell is pressed to zero. After the
//! first round only the triangles and cells touching a changed director are checked
//! again, so later rounds cost in proportion to the defects left.

use super::defects::{Checker, Findings};
use super::intersect::TriBvh;
use super::report::normal_shape;
use super::Shell;
use crate::mesh::vertex_normals;
use crate::Mesh;
use glam::Vec3;
use rayon::prelude::*;
use std::cell::Cell;
use std::sync::atomic::{AtomicU32, Ordering};

/// A folded director shorter than this share of its target, pointing away from its
/// side's normal, turns to the normal. The constants of the repair and its final
/// check (this one to [`HALVING_ROUNDS`]) are not from the thesis (its shells have no
/// final check): they were chosen on `make bench`'s hard meshes (`bench_shell.py`)
/// for zero crossings with the most thickness kept.
pub const TURN_AT: f32 = 0.05;

/// Below this share of its target a director is set to zero (pressed flat).
pub const SNAP: f32 = 1e-3;

/// Shortening in one final-check round: a defect's corners, then each ring around.
pub const FALL_OFF: [f32; 3] = [0.5, 0.7, 0.85];

/// Final-check rounds that halve; later ones set defect corners to zero.
pub const HALVING_ROUNDS: u32 = 60;

/// What the repair and the final check did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ShellCheck {
    /// Faces of the base that cross another part of the base (their crossings are
    /// inherited by any shell, and not counted as defects).
    pub base_crossing_faces: usize,
    /// Repair rounds that changed something.
    pub rounds: u32,
    /// Final-check rounds that changed something.
    pub check_rounds: u32,
    /// Vertices the final check shortened.
    pub check_shortened: usize,
    /// No defect is left (always, unless `rounds` is 0 or the base has no faces).
    pub clean: bool,
}

/// Shrinks directors around defects, for at most `rounds` rounds, to each defect's
/// crossing scale (by `factor` where none removes it), then runs the final check
/// until the shell is clean.
pub fn untangle(mesh: &Mesh, shell: &mut Shell, rounds: u32, factor: f32) -> ShellCheck {
    untangle_around(mesh, shell, rounds, factor, None)
}

/// [`untangle`], checking at first only the triangles and cells around `seeds` (all
/// of them for `None`): after a local edit the rest of the shell is known clean.
pub fn untangle_around(mesh: &Mesh, shell: &mut Shell, rounds: u32, factor: f32, seeds: Option<&[u32]>) -> ShellCheck {
    if rounds == 0 || mesh.vertex_count() == 0 {
        return ShellCheck::default();
    }
    let checker = Checker::new(mesh);
    let normals = vertex_normals(mesh);
    Repair { checker: &checker, mesh, normals: &normals, rounds, factor, cancel: None, held: None, scales: true }.untangle(&mut None, shell, seeds)
}

/// What the repair and restore passes use besides the shell: the mesh, its defect
/// checker and vertex normals, and the repair's rounds and fall-back factor.
pub(crate) struct Repair<'a> {
    pub checker: &'a Checker,
    pub mesh: &'a Mesh,
    pub normals: &'a [Vec3],
    pub rounds: u32,
    pub factor: f32,
    /// Once this is cancelled the repair stops at its next round and the restore at
    /// its next batch, leaving the shell unfinished (`clean` false): the caller
    /// drops it ([`crate::Error::Cancelled`]).
    pub cancel: Option<&'a crate::progress::Progress>,
    /// Directors the repair rounds (not the final check) leave alone where a defect
    /// has another corner to shorten: after a local edit, the repaired directors
    /// around the reset region keep the length their earlier repair gave them.
    pub held: Option<&'a [bool]>,
    /// Whether repair rounds shorten each defect's corners to its crossing scale
    /// ([`crossing_scale`]); false: by `factor` alone, as before the scales (kept to
    /// measure one against the other).
    pub scales: bool,
}

impl<'a> Repair<'a> {
    /// A build's repair: `rounds` rounds at the crossing scales (by
    /// [`REPAIR_FACTOR`](super::directors::REPAIR_FACTOR) where none removes a
    /// defect), no director held, cancelled through `cancel`.
    pub fn for_build(checker: &'a Checker, mesh: &'a Mesh, normals: &'a [Vec3], rounds: u32, cancel: Option<&'a crate::progress::Progress>) -> Self {
        Repair { checker, mesh, normals, rounds, factor: super::directors::REPAIR_FACTOR, cancel, held: None, scales: true }
    }
}

impl Repair<'_> {
    /// Whether the caller cancelled.
    pub fn cancelled(&self) -> bool {
        self.cancel.is_some_and(|p| p.is_cancelled())
    }
}

impl Repair<'_> {
    /// [`untangle_around`] with a skin tree kept by the caller (the incremental shell
    /// keeps it between edits): a kept tree must match `shell` except around `seeds`.
    pub fn untangle(&self, outer_bvh: &mut Option<TriBvh>, shell: &mut Shell, seeds: Option<&[u32]>) -> ShellCheck {
        let Repair { checker, mesh, rounds, .. } = *self;
        let mut done = ShellCheck { base_crossing_faces: checker.own_faces().len(), ..Default::default() };
        if rounds == 0 || mesh.vertex_count() == 0 {
            return done;
        }
        let mut dirty = seeds.map(|s| {
            let mut d = checker.clean();
            s.iter().for_each(|v| checker.mark_around(*v as usize, &mut d));
            d
        });
        // A kept tree is refitted where the seeds' directors changed; otherwise in full.
        let mut outer = match (outer_bvh.take(), &dirty) {
            (Some(mut tree), Some(d)) if tree.len() == checker.items(shell.side) => {
                checker.refit_outer(mesh, shell, &mut tree, &d.tri_list);
                tree
            }
            (reuse, _) => checker.outer_tree(mesh, shell, reuse),
        };
        // Two flag sets, swapped round after round: clearing costs what they held.
        let mut next = checker.clean();
        let mut shortened = vec![false; mesh.vertex_count()];
        let mut streak = Streaks { last: vec![0; mesh.vertex_count()], length: vec![0; mesh.vertex_count()] };
        let mut scale = vec![1.0f32; mesh.vertex_count()];
        for round in 0.. {
            if self.cancelled() {
                break;
            }
            let found = {
                let _t = super::timing::Stage::start(if round == 0 { "untangle: find (round 0)" } else { "untangle: find (later)" });
                checker.find(mesh, shell, dirty.as_ref(), Some(&outer))
            };
            super::timing::count("# untangle: flagged tris", dirty.as_ref().map_or(checker.tris.len(), |d| d.tri_list.len()));
            super::timing::count("# untangle: defects", found.self_pairs.len() + found.base_pairs.len() + found.inverted.len() + found.enclosing.len());
            if found.is_clean() {
                done.clean = true;
                break;
            }
            next.clear();
            let any = if round < rounds {
                self.repair_round(&found, shell, &mut next, round, &mut streak)
            } else {
                let halving = round - rounds < HALVING_ROUNDS;
                self.check_round(&found, shell, &mut next, &mut scale, halving, &mut shortened)
            };
            if !any {
                break; // defects whose corners are all zero: only on a base that crosses itself in a way not flagged
            }
            match round < rounds {
                true => done.rounds += 1,
                false => done.check_rounds += 1,
            }
            // Only the skin triangles around shortened directors moved.
            let _t = super::timing::Stage::start("untangle: refit");
            checker.refit_outer(mesh, shell, &mut outer, &next.tri_list);
            match dirty.as_mut() {
                Some(d) => std::mem::swap(d, &mut next),
                None => dirty = Some(std::mem::replace(&mut next, checker.clean())),
            }
        }
        done.check_shortened = shortened.iter().filter(|&&s| s).count();
        *outer_bvh = Some(outer);
        done
    }

    /// One repair round: shrink (or turn) the corners of every defect; flags what
    /// changed in `next`. Returns whether anything changed.
    fn repair_round(&self, found: &Findings, shell: &mut Shell, next: &mut super::defects::Dirty, round: u32, streaks: &mut Streaks) -> bool {
        let Repair { checker, normals, factor, .. } = *self;
        let mut folded: Vec<u32> = found.inverted.iter().flat_map(|&c| checker.cells[c as usize].base()).copied().collect();
        folded.sort_unstable();
        let corners = self.corners_to_shorten(found, &shell.achieved);
        let (aims, tests) = {
            let _t = super::timing::Stage::start("untangle: crossing scales");
            self.crossing_scales(found, shell, &corners, None, true)
        };
        super::timing::count("# crossing scales: exact tests", tests);
        let mut any = false;
        for (v, aim) in corners.into_iter().zip(aims) {
            let folds = folded.binary_search(&v).is_ok();
            let v = v as usize;
            let length = shell.achieved[v];
            let along = normal_shape(shell.side, normals[v]).1;
            if length <= 0.0 {
                continue; // nothing to shorten or turn
            } else if folds && length <= TURN_AT * shell.target[v] && along != Vec3::ZERO && shell.directors[v].dot(along) < 0.999 * length {
                (shell.base_offset[v], shell.directors[v]) = normal_shape(shell.side, normals[v] * length);
            } else {
                let k = streaks.length[v];
                streaks.length[v] = if streaks.last[v] == round { k + 1 } else { 0 };
                streaks.last[v] = round + 1;
                let k = streaks.length[v] as f32 / ACCELERATION;
                let plain = factor.powf(1.0 + k);
                let scaled = |s: f32| if s > 0.0 { s * MARGIN } else { 0.5 } * factor.powf(k);
                let f = match aim {
                    Aim::Scale(s) => scaled(s).min(CAP),
                    Aim::Both(s) => scaled(s).min(plain),
                    Aim::Factor => plain,
                };
                shorten(shell, v, f);
            }
            checker.mark_around(v, next);
            any = true;
        }
        any
    }

    /// One final-check round: halve the corners of every defect and shorten the rings
    /// around them less ([`FALL_OFF`]), or set the corners to zero once `halving` is
    /// over. Returns whether anything changed.
    fn check_round(
        &self,
        found: &Findings,
        shell: &mut Shell,
        next: &mut super::defects::Dirty,
        scale: &mut [f32],
        halving: bool,
        shortened: &mut [bool],
    ) -> bool {
        let checker = self.checker;
        let corners = checker.defect_vertex_list(found);
        let mut touched: Vec<u32> = Vec::new();
        let mut ring: Vec<u32> = corners.clone();
        for (k, &f) in FALL_OFF.iter().enumerate() {
            let f = if halving {
                f
            } else if k == 0 {
                0.0
            } else {
                break;
            };
            for &v in &ring {
                if scale[v as usize] == 1.0 {
                    touched.push(v);
                }
                scale[v as usize] = scale[v as usize].min(f);
            }
            if k + 1 < FALL_OFF.len() {
                let mut around: Vec<u32> = ring.iter().flat_map(|&v| checker.cell_corners_around(v as usize)).collect();
                around.sort_unstable();
                around.dedup();
                ring = around;
            }
        }
        let mut any = false;
        for v in touched {
            let v = v as usize;
            let f = std::mem::replace(&mut scale[v], 1.0);
            if shell.achieved[v] > 0.0 {
                shorten(shell, v, f);
                shortened[v] = true;
                checker.mark_around(v, next);
                any = true;
            }
        }
        any
    }
}

impl Repair<'_> {
    /// For each of `corners` (sorted), what shortens it this round: the least, over
    /// the defects it is a corner of, of the largest common scale of the defect's
    /// corners at which the defect is gone ([`crossing_scale`]); the plain factor
    /// where a defect of it does not vanish so (an enclosure, a pair of triangles
    /// sharing a vertex) or does not reappear when re-tested.
    ///
    /// The defects are measured in `chunk`s on copies of the shell, in parallel (by
    /// default, chunks where there are [`PARALLEL_DEFECTS`], else one after another
    /// on `shell`): each test gives its shell back unchanged, so the aims are the same
    /// whatever the chunks and threads. With `prune`, a defect that cannot lower any
    /// of its corners' least scale so far is measured only that far (the aims are
    /// the same: [`crossing_scale`]'s `enough`). Also gives how many exact tests
    /// the measures ran (what pruning saves).
    fn crossing_scales(&self, found: &Findings, shell: &mut Shell, corners: &[u32], chunk: Option<usize>, prune: bool) -> (Vec<Aim>, usize) {
        let (checker, mesh) = (self.checker, self.mesh);
        let mut aims = vec![Aim::Factor; corners.len()];
        if !self.scales {
            return (aims, 0);
        }
        // Each defect's corners and scale, then the least per corner.
        let defects: Vec<Defect> = (found.self_pairs.iter().map(|&(i, j)| Defect::Pair(true, i, j)))
            .chain(found.base_pairs.iter().map(|&(i, j)| Defect::Pair(false, i, j)))
            .chain(found.inverted.iter().map(|&c| Defect::Inverted(c)))
            .chain(found.enclosing.iter().map(|&c| Defect::Enclosing(c)))
            .collect();
        let p = mesh.positions();
        // The least scale found so far per corner (f32 bits: non-negative floats order
        // as their bits), shared by the chunks: a defect that cannot lower it for any
        // of its corners is not measured to the end ([`crossing_scale`]'s `enough`).
        let least: Vec<AtomicU32> = (0..corners.len()).map(|_| AtomicU32::new(1.0f32.to_bits())).collect();
        // Per defect: its corners, its scale and how many exact tests measured it.
        let measure = |shell: &mut Shell, d: &Defect| -> (Vec<u32>, Option<f32>, usize) {
            let tests = Cell::new(0usize);
            let counted = |crosses: bool| {
                tests.set(tests.get() + 1);
                crosses
            };
            let (mine, scale) = match *d {
                Defect::Pair(self_pair, i, j) => {
                    let all: &[&[u32]] = if self_pair { &[checker.item_vertices(i), checker.item_vertices(j)] } else { &[checker.item_vertices(i)] };
                    let mine = self.mine(all, &shell.achieved, corners);
                    let test = |s: &Shell| counted(checker.pair_crosses(mesh, s, self_pair, i, j));
                    let gamma = if self_pair { SELF_DAMPING } else { 1.0 };
                    let floor = if prune { self.floor(&mine, corners, &least) } else { f32::INFINITY };
                    let scale = crossing_scale(shell, &mine, &test, &|s| enough(s, gamma, floor)).map(|s| s.powf(gamma));
                    (mine, scale)
                }
                Defect::Inverted(c) => {
                    let cell = &checker.cells[c as usize];
                    let mine = self.mine(&[cell.base()], &shell.achieved, corners);
                    let floor = if prune { self.floor(&mine, corners, &least) } else { f32::INFINITY };
                    let scale = crossing_scale(shell, &mine, &|s: &Shell| counted(cell.is_inverted(p, s)), &|s| enough(s, 1.0, floor));
                    (mine, scale)
                }
                Defect::Enclosing(c) => return (self.mine(&[checker.cells[c as usize].base()], &shell.achieved, corners), None, 0),
            };
            if let Some(s) = scale {
                mine.iter().for_each(|v| _ = least[corners.binary_search(v).unwrap()].fetch_min(s.to_bits(), Ordering::Relaxed));
            }
            (mine, scale, tests.get())
        };
        let chunk =
            chunk.or_else(|| (defects.len() >= PARALLEL_DEFECTS).then(|| defects.len().div_ceil(4 * rayon::current_num_threads()).max(PARALLEL_DEFECTS / 4)));
        let measured: Vec<(Vec<u32>, Option<f32>, usize)> = match chunk {
            None => defects.iter().map(|d| measure(shell, d)).collect(),
            Some(chunk) => {
                let view: &Shell = shell;
                defects
                    .par_chunks(chunk)
                    .flat_map_iter(|part| {
                        let mut copy = view.clone();
                        part.iter().map(|d| measure(&mut copy, d)).collect::<Vec<_>>()
                    })
                    .collect()
            }
        };
        let mut seen = vec![false; corners.len()];
        let mut fallback = vec![false; corners.len()];
        let mut best = vec![1.0f32; corners.len()];
        let mut tests = 0;
        for (mine, scale, measured_with) in measured {
            tests += measured_with;
            for v in mine {
                let k = corners.binary_search(&v).unwrap();
                match scale {
                    Some(s) => {
                        seen[k] = true;
                        best[k] = best[k].min(s);
                    }
                    None => fallback[k] = true,
                }
            }
        }
        for k in 0..corners.len() {
            aims[k] = match (seen[k], fallback[k]) {
                (true, false) => Aim::Scale(best[k]),
                (true, true) => Aim::Both(best[k]),
                _ => Aim::Factor,
            };
        }
        (aims, tests)
    }

    /// The largest least scale so far ([`crossing_scales`](Self::crossing_scales)'s
    /// `least`, per corner of `corners`) among `mine`: a defect whose scale is at
    /// least this lowers no corner's.
    fn floor(&self, mine: &[u32], corners: &[u32], least: &[AtomicU32]) -> f32 {
        mine.iter().map(|v| f32::from_bits(least[corners.binary_search(v).unwrap()].load(Ordering::Relaxed))).fold(0.0, f32::max)
    }

    /// Those of [`defect_corners`](Self::defect_corners) among `corners` (sorted).
    fn mine(&self, all: &[&[u32]], achieved: &[f32], corners: &[u32]) -> Vec<u32> {
        self.defect_corners(all, achieved).filter(|v| corners.binary_search(v).is_ok()).collect()
    }

    /// The corners a repair round shortens of a defect whose corners are `all`: see
    /// [`corners_to_shorten`](Self::corners_to_shorten).
    fn defect_corners<'b>(&self, all: &'b [&'b [u32]], achieved: &'b [f32]) -> impl Iterator<Item = u32> + 'b {
        let held = self.held;
        let free = move |v: &u32| held.is_none_or(|h| !h[*v as usize] && achieved[*v as usize] > 0.0);
        let any_free = held.is_none() || all.iter().flat_map(|c| c.iter()).any(free);
        let mut out: Vec<u32> = all.iter().flat_map(|c| c.iter().copied()).filter(move |v| !any_free || free(v)).collect();
        out.sort_unstable();
        out.dedup();
        out.into_iter()
    }

    /// The corners of every defect a repair round shortens, sorted, each once: all of
    /// them, or where some are [`held`](Repair::held), the others that still have
    /// length (the held ones too where a defect has no such other corner: otherwise a
    /// defect whose free corners are already at zero would stop the repair before its
    /// final check).
    fn corners_to_shorten(&self, found: &Findings, achieved: &[f32]) -> Vec<u32> {
        let checker = self.checker;
        let Some(held) = self.held else { return checker.defect_vertex_list(found) };
        let mut out = Vec::new();
        let mut add = |corners: &[&[u32]]| {
            let all = corners.iter().flat_map(|c| c.iter().copied());
            let free = |v: &u32| !held[*v as usize] && achieved[*v as usize] > 0.0;
            match all.clone().any(|v| free(&v)) {
                true => out.extend(all.filter(free)),
                false => out.extend(all),
            }
        };
        for &(i, j) in &found.self_pairs {
            add(&[checker.item_vertices(i), checker.item_vertices(j)]);
        }
        for &(i, _) in &found.base_pairs {
            add(&[checker.item_vertices(i)]);
        }
        for &c in found.inverted.iter().chain(&found.enclosing) {
            add(&[checker.cells[c as usize].base()]);
        }
        out.sort_unstable();
        out.dedup();
        out
    }
}

/// A defect as [`Repair::crossing_scales`] measures it: a skin pair (true) or a
/// skin/base pair (false) of items, an inverted cell, a cell enclosing a probe.
#[derive(Debug, Clone, Copy)]
enum Defect {
    Pair(bool, u32, u32),
    Inverted(u32),
    Enclosing(u32),
}

/// Fewer defects than this are measured on the shell itself, one after another;
/// more, in chunks on copies of it (at least a quarter of this many per copy, four
/// chunks per thread). Issue 14: on a sculpt that crosses itself (beast, 32k
/// vertices, exterior 10%) the first repair rounds measure 10^5-10^6 skin pairs,
/// each up to ~30 exact tests, a tenth of the build on one core.
const PARALLEL_DEFECTS: usize = 256;

/// What shortens a corner in a repair round: the scale its defects ask for, that
/// and the plain factor (whichever is less), or the plain factor alone.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Aim {
    Scale(f32),
    Both(f32),
    Factor,
}

/// Bisection steps of [`crossing_scale`] after its scan: the scale is found to
/// within `(1 - STEP) / 16` of itself.
const BISECTIONS: u32 = 4;

/// The step of [`crossing_scale`]'s scan down from the current lengths.
const STEP: f32 = 0.9;

/// A corner is shortened to this share of the scale its defects ask for (the scale
/// is where the defect alone vanishes; its neighbours move too).
const MARGIN: f32 = 0.99;

/// A skin pair's corners go only part of the way (in the logarithm) to the scale the
/// pair asks for: `scale^SELF_DAMPING`. Both triangles' corners shorten, and a
/// triangle crossing several others takes the least of their scales, so the full
/// scale shortens both parts about twice as much as the gap needs (two spheres 0.05
/// apart at 0.6 thickness: mean ratio 0.842 at the full scale, 0.855 at this one,
/// 0.846 for the plain factor).
const SELF_DAMPING: f32 = 0.5;

/// The least shortening of a corner in a repair round (the defect was found at
/// this length, so it must shorten). A corner whose defect stays down to [`SNAP`]
/// is halved; a corner shortened round after round goes further, by the plain
/// factor's acceleration ([`ACCELERATION`]).
const CAP: f32 = 0.98;

/// The largest common scale of the directors (and base offsets) of `corners` at
/// which `crosses` no longer holds: the exact test re-run at scales falling by
/// [`STEP`] from the current lengths (a defect gone at one scale may come back
/// below it, so the largest is searched from above), then [`BISECTIONS`] bisection
/// steps; 0 where it holds down to [`SNAP`], `None` where it does not hold at the
/// current lengths. The shell is given back unchanged.
///
/// Where the caller has `enough` (any scale at least this large changes nothing for
/// it), the least scan step that is enough is tested first: if the defect is gone
/// there, the first step without it is at least as large, and so is the scale, so
/// that step is returned, a lower bound of the scale that is still enough (one test
/// instead of a dozen; the first repair round on issue 14's beast measures 10^6
/// pairs, each corner in hundreds); likewise the bisection stops once its lower end
/// is enough.
fn crossing_scale(shell: &mut Shell, corners: &[u32], crosses: &dyn Fn(&Shell) -> bool, enough: &dyn Fn(f32) -> bool) -> Option<f32> {
    if corners.is_empty() || !crosses(shell) {
        return None;
    }
    let saved: Vec<(Vec3, Vec3)> = corners.iter().map(|&v| (shell.base_offset[v as usize], shell.directors[v as usize])).collect();
    let set = |shell: &mut Shell, s: f32| {
        for (&v, &(o, d)) in corners.iter().zip(&saved) {
            shell.base_offset[v as usize] = o * s;
            shell.directors[v as usize] = d * s;
        }
    };
    let steps = std::iter::successors(Some(1.0f32), |&s| (s > SNAP).then_some(s * STEP)).skip(1);
    if let Some(least) = steps.clone().take_while(|&s| enough(s)).last() {
        set(shell, least);
        let gone = !crosses(shell);
        set(shell, 1.0);
        if gone {
            return Some(least);
        }
    }
    // Down from the current lengths in steps of STEP (a defect may come back at
    // smaller scales: the largest scale where it is gone is wanted), then bisected.
    let (mut lo, mut hi) = (0.0f32, 1.0f32);
    for s in steps {
        set(shell, s);
        if !crosses(shell) {
            lo = s;
            break;
        }
        hi = s;
    }
    for _ in 0..BISECTIONS * (lo > 0.0) as u32 {
        if enough(lo) {
            break; // the scale is at least `lo`
        }
        let mid = 0.5 * (lo + hi);
        set(shell, mid);
        if crosses(shell) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    set(shell, 1.0);
    Some(lo)
}

/// Whether a defect's scale of at least `s` (before `s^gamma`) would lower no
/// corner's least scale `floor`: `s^gamma` with room for `powf`'s rounding (under
/// an ulp either way, so a larger scale never maps below it).
fn enough(s: f32, gamma: f32, floor: f32) -> bool {
    s.powf(gamma) * (1.0 - 1e-6) >= floor
}

/// Per vertex: one past the last repair round that shortened it (0: none yet) and how
/// many rounds before that did in a row.
struct Streaks {
    last: Vec<u32>,
    length: Vec<u32>,
}

/// A director shortened `k` repair rounds in a row before this one is shortened by
/// `factor^(1 + k / ACCELERATION)`. Where the geometry leaves little room (cards
/// close together, parts that touch, a base that crosses itself) a defect outlives
/// dozens of rounds of the plain factor, and the repair used to run out of rounds
/// before its final check took over. Not from the thesis; chosen on `make bench`'s
/// meshes: 8000 cards 77 -> 36 rounds (3.2 -> 2.4 s), Suzanne's envelope 1.16 ->
/// 0.92 CPU-s, mean thickness ratios within 0.004 of the plain factor's (8 cut the
/// rounds further but cost up to 0.02).
const ACCELERATION: f32 = 16.0;

/// Shortens director `v` (and an envelope's base offset) by `f`, to zero below [`SNAP`].
fn shorten(shell: &mut Shell, v: usize, f: f32) {
    let f = if shell.achieved[v] * f < SNAP * shell.target[v] { 0.0 } else { f };
    shell.base_offset[v] *= f;
    shell.directors[v] *= f;
    shell.achieved[v] = shell.directors[v].length();
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::shell::report::shell_report;
    use crate::shell::Side;
    use crate::testmeshes as tm;

    /// Two unit spheres 0.05 apart with normal directors of length `length`: their
    /// outer layers cross wide around the gap.
    pub(crate) fn nearly_touching(length: f32) -> (Mesh, Shell) {
        let ball = tm::icosphere(3);
        let n = ball.vertex_count();
        let positions: Vec<Vec3> = [-1.025f32, 1.025].iter().flat_map(|&x| ball.positions().iter().map(move |p| *p + Vec3::X * x)).collect();
        let corners: Vec<u32> = (0..2u32).flat_map(|k| ball.corners().iter().map(move |&c| c + k * n as u32)).collect();
        let sizes: Vec<u32> = [ball.face_sizes(), ball.face_sizes()].concat();
        let mesh = Mesh::new(positions, &sizes, corners, None).unwrap();
        let directors: Vec<Vec3> = vertex_normals(&mesh).iter().map(|d| *d * length).collect();
        let m = mesh.vertex_count();
        let shell = Shell {
            side: Side::Exterior,
            base_offset: vec![Vec3::ZERO; m],
            achieved: directors.iter().map(|d| d.length()).collect(),
            directors,
            target: vec![length; m],
            check: Default::default(),
        };
        (mesh, shell)
    }

    /// The crossing scales measured in parallel chunks on copies of the shell, and
    /// with defects that cannot lower a corner's scale cut short, are those of one
    /// full pass over the defects, and the shell is given back unchanged.
    #[test]
    fn crossing_scales_in_parallel_chunks_equal_one_pass() {
        let (mesh, mut shell) = nearly_touching(0.6);
        let (checker, normals) = (Checker::new(&mesh), vertex_normals(&mesh));
        let factor = crate::shell::directors::REPAIR_FACTOR;
        let repair = Repair { checker: &checker, mesh: &mesh, normals: &normals, rounds: 80, factor, cancel: None, held: None, scales: true };
        let found = checker.find(&mesh, &shell, None, Some(&checker.outer_tree(&mesh, &shell, None)));
        let defects = found.self_pairs.len() + found.base_pairs.len() + found.inverted.len() + found.enclosing.len();
        assert!(defects > 40, "{found:?}");
        let corners = repair.corners_to_shorten(&found, &shell.achieved);
        let before = shell.clone();
        let (one_pass, full_tests) = repair.crossing_scales(&found, &mut shell, &corners, None, false);
        assert!(one_pass.iter().any(|a| matches!(a, Aim::Scale(s) if *s < 0.9)), "{one_pass:?}");
        // Pruned in one chunk (one copy, the least scales seen in a fixed order, also
        // past PARALLEL_DEFECTS), the measures run fewer exact tests. (A pruned measure
        // whose first test fails scans on, so a parallel schedule could make a pruned
        // pass run more; unpruned runs exactly as many.)
        let (pruned, pruned_tests) = repair.crossing_scales(&found, &mut shell, &corners, Some(usize::MAX), true);
        assert_eq!(pruned, one_pass);
        assert!(pruned_tests < full_tests, "pruned {pruned_tests} exact tests, full {full_tests}");
        for chunk in [1, 7, usize::MAX] {
            for prune in [false, true] {
                let (chunked, tests) = repair.crossing_scales(&found, &mut shell, &corners, Some(chunk), prune);
                assert_eq!(chunked, one_pass, "chunks of {chunk}, pruned {prune}");
                assert!(prune || tests == full_tests, "chunks of {chunk}: {tests} exact tests, full {full_tests}");
            }
        }
        assert_eq!((shell.directors, shell.base_offset), (before.directors, before.base_offset));
    }

    /// A scale measured with `enough` is the full measure's wherever that is below
    /// the floor, and at least the floor (never above the full measure) elsewhere;
    /// some measures are cut short.
    #[test]
    fn crossing_scale_cut_short_only_where_enough() {
        let (mesh, mut shell) = nearly_touching(0.6);
        let checker = Checker::new(&mesh);
        let found = checker.find(&mesh, &shell, None, Some(&checker.outer_tree(&mesh, &shell, None)));
        let (mut short, mut below) = (0, 0);
        for &(i, j) in found.self_pairs.iter().chain(&found.base_pairs) {
            let self_pair = found.self_pairs.contains(&(i, j));
            let mut corners: Vec<u32> = checker.item_vertices(i).to_vec();
            if self_pair {
                corners.extend(checker.item_vertices(j));
            }
            let test = |s: &Shell| checker.pair_crosses(&mesh, s, self_pair, i, j);
            // Pairs only `find_star` tests (at one vertex) have no scale here.
            let Some(full) = crossing_scale(&mut shell, &corners, &test, &|_| false) else { continue };
            for floor in [0.3f32, 0.6, 0.85, 0.95] {
                let cut = crossing_scale(&mut shell, &corners, &test, &|s| s >= floor).unwrap();
                match full < floor {
                    true => assert_eq!(cut, full, "{i} {j} floor {floor}"),
                    false => assert!(cut >= floor && cut <= full, "{i} {j} floor {floor}: {cut} {full}"),
                }
                short += usize::from(cut != full);
                below += usize::from(full < floor);
            }
        }
        assert!(short > 20 && below > 20, "{short} cut short, {below} below the floor");
    }

    #[test]
    fn crossing_scales_untangle_nearly_touching_parts_in_few_rounds() {
        let (mesh, traced) = nearly_touching(0.6);
        let before = shell_report(&mesh, &traced);
        assert!(before.outer_self_intersections > 50, "{before:?}");
        let (checker, normals) = (Checker::new(&mesh), vertex_normals(&mesh));
        let run = |plain: bool| {
            let mut shell = traced.clone();
            let factor = crate::shell::directors::REPAIR_FACTOR;
            let repair = Repair { checker: &checker, mesh: &mesh, normals: &normals, rounds: 80, factor, cancel: None, held: None, scales: !plain };
            let check = repair.untangle(&mut None, &mut shell, None);
            let r = shell_report(&mesh, &shell);
            assert!(check.clean, "plain {plain}: {check:?}");
            assert_eq!((r.outer_self_intersections, r.outer_base_intersections, r.inverted_cells), (0, 0, 0), "plain {plain}: {r:?}");
            (check, r.mean_ratio)
        };
        let (old, old_mean) = run(true);
        let (new, new_mean) = run(false);
        eprintln!("plain factor: {old:?} mean {old_mean}; crossing scales: {new:?} mean {new_mean}");
        assert!(old.rounds >= 20, "the plain factor needs many rounds here: {old:?}");
        assert!(new.rounds <= 15 && new.check_rounds == 0, "{new:?}");
        assert!(new_mean >= old_mean, "{new_mean} < {old_mean}");
    }
}
