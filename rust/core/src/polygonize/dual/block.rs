//! One block of cells at the finest level: its lattice points sampled (with the other
//! blocks of its batch, each shared point once: [`Shared`]),
//! each sign-changing edge's crossing found once on the field (Illinois regula falsi)
//! with the analytic gradient there, and one vertex per piece of every cell
//! ([`super::cases`]) placed by its [`Qef`] (Ju et al. 2002, section 2.3). A batch's
//! crossings, gradients and vertex projections go to the field together ([`process`]).

use super::cases::{cases, ends, NONE};
use super::lattice::{Lattice, BLOCK};
use super::project::project;
use super::qef::Qef;
use crate::field::ScalarField;
use crate::polygonize::grid::{refine_crossings, REFINE_TOLERANCE};
use crate::polygonize::marching::Crossing;
use crate::{Error, Result};
use glam::{UVec3, Vec3};
use rayon::prelude::*;

/// Cells of a block, [`BLOCK`]³ (the ones past the lattice unused).
pub(super) const CELLS: usize = (BLOCK * BLOCK * BLOCK) as usize;

/// A sign-changing lattice edge that this block owns: the one along `axis` from the
/// lowest corner of one of its cells. Its quad joins the four cells around it.
#[derive(Debug, Clone, Copy)]
pub(super) struct OwnedEdge {
    pub from: UVec3,
    pub axis: u8,
    /// Whether `from` is inside (the quad faces `+axis`).
    pub from_inside: bool,
    /// The cut field's unit gradient at the crossing.
    pub normal: Vec3,
}

/// What a block gives the contouring.
#[derive(Debug, Clone, Default)]
pub(super) struct Block {
    /// Lowest cell.
    pub origin: UVec3,
    /// Per cell (`x` fastest, [`BLOCK`] per side): the index of its first vertex among
    /// the block's, `u32::MAX` without a surface.
    pub first: Vec<u32>,
    /// Per cell: its corners' signs (bit `c` set: corner `c` inside).
    pub config: Vec<u8>,
    /// Per vertex: the QEF minimizer and the crossings' mass point.
    pub qef: Vec<Vec3>,
    pub mass: Vec<Vec3>,
    /// Per vertex: its cell.
    pub cell: Vec<UVec3>,
    pub edges: Vec<OwnedEdge>,
}

pub(super) fn cell_index(local: UVec3) -> usize {
    (local.x + BLOCK * (local.y + BLOCK * local.z)) as usize
}

/// The lattice points of the block at `origin` (in cells), `x` fastest: the cut
/// field's samples there ([`Lattice::sample`]). Where a point lies and its lattice
/// coordinates follow from its place (`origin` plus its local coordinates).
pub(super) struct Samples {
    /// Cells of the block (fewer than [`BLOCK`] where it reaches the lattice's end).
    pub size: UVec3,
    pub values: Vec<f32>,
}

impl Samples {
    /// The block's lattice points sampled as one batch; a field that is not a number
    /// at one is an error. (The mesher and the count sample through [`Shared`]; this is
    /// the tests' reference.)
    #[cfg(test)]
    pub fn of<F: ScalarField + ?Sized>(field: &F, lattice: &Lattice, origin: UVec3) -> Result<Self> {
        let size = (lattice.cells - origin).min(UVec3::splat(BLOCK));
        let n = size + 1;
        let count = (n.x * n.y * n.z) as usize;
        let mut points = Vec::with_capacity(count);
        let mut at = Vec::with_capacity(count);
        for z in 0..n.z {
            for y in 0..n.y {
                for x in 0..n.x {
                    let g = origin + UVec3::new(x, y, z);
                    at.push(g);
                    points.push(lattice.point(g));
                }
            }
        }
        let mut values = vec![0.0; count];
        field.values(&points, &mut values);
        if let Some(i) = values.iter().position(|v| v.is_nan()) {
            return Err(Error::InvalidParameter(format!("the field is not a number at {}", points[i])));
        }
        for (v, g) in values.iter_mut().zip(&at) {
            *v = lattice.sample(*v, *g);
        }
        Ok(Self { size, values })
    }

    /// The block's lattice points looked up in `shared`, which holds them all.
    pub(super) fn from_shared(lattice: &Lattice, origin: UVec3, shared: &Shared) -> Self {
        let size = (lattice.cells - origin).min(UVec3::splat(BLOCK));
        let n = size + 1;
        let mut values = Vec::with_capacity((n.x * n.y * n.z) as usize);
        for z in 0..n.z {
            for y in 0..n.y {
                // A row's keys are consecutive: one search per row.
                let first = origin + UVec3::new(0, y, z);
                let row = &shared.values[shared.find(first)..][..n.x as usize];
                // [`Lattice::sample`] with the row's part of the face test made once.
                let row_on_face = first.y == 0 || first.z == 0 || first.y == lattice.cells.y || first.z == lattice.cells.z;
                values.extend((0..n.x).zip(row).map(|(x, &v)| {
                    let g = first + UVec3::new(x, 0, 0);
                    let cut = lattice.cut(v, lattice.point(g));
                    if row_on_face || g.x == 0 || g.x == lattice.cells.x {
                        cut.max(lattice.eps)
                    } else {
                        cut
                    }
                }));
            }
        }
        Self { size, values }
    }

    /// The index of local lattice point `p`.
    pub fn index(&self, p: UVec3) -> usize {
        let n = self.size + 1;
        (p.x + n.x * (p.y + n.y * p.z)) as usize
    }
}

/// The field's values at the lattice points of a batch of blocks, each point
/// evaluated once: a block alone samples its `(BLOCK + 1)³` points, and neighbouring
/// live blocks share the points of the faces between them (about a third of the
/// samples on issue 17's tree). In key order (`x` fastest), so a block's rows are
/// runs of consecutive keys.
///
/// The octree gives a batch's blocks depth first, so they mostly fill a small box of
/// the lattice: there the points are marked on a dense grid over that box, which lists
/// them in key order and finds a row by its index; a batch spread wider is sorted.
pub(super) struct Shared {
    /// Lattice points along x and y (for the keys).
    n: UVec3,
    keys: Vec<u64>,
    /// Per key: its lattice point (kept, not divided out of the key per evaluation).
    at: Vec<UVec3>,
    values: Vec<f32>,
    /// Points evaluated (the others' signs proven by the Lipschitz bound).
    evaluated: usize,
    /// Per point: whether its sign was proven rather than sampled.
    #[cfg(test)]
    proven: Vec<bool>,
    /// The dense grid: its lowest lattice point, its points per side, and per point
    /// its index among `keys` (`u32::MAX` where not one of the batch's).
    dense: Option<(UVec3, UVec3, Vec<u32>)>,
}

/// A dense grid at most this many times the points it marks (the batch's points
/// counted with repeats): not from a paper, a scan of a few bytes per entry against
/// a sort of the keys.
const DENSE_RATIO: usize = 8;

impl Shared {
    /// The lattice points of the blocks at `origins` (in cells), evaluated in parallel
    /// batches; a field that is not a number at one is an error.
    pub fn of<F: ScalarField + ?Sized>(field: &F, lattice: &Lattice, origins: &[UVec3]) -> Result<Self> {
        let mut shared = Self {
            n: lattice.cells + 1,
            keys: Vec::new(),
            at: Vec::new(),
            values: Vec::new(),
            evaluated: 0,
            #[cfg(test)]
            proven: Vec::new(),
            dense: None,
        };
        let size = |origin: UVec3| (lattice.cells - origin).min(UVec3::splat(BLOCK));
        let lo = origins.iter().fold(UVec3::MAX, |m, &o| m.min(o));
        let hi = origins.iter().fold(UVec3::ZERO, |m, &o| m.max(o + size(o)));
        let repeats: usize = origins.iter().map(|&o| ((size(o) + 1).as_u64vec3().element_product()) as usize).sum();
        let side = (hi + 1).saturating_sub(lo);
        let volume = side.as_u64vec3().element_product();
        if !origins.is_empty() && volume <= (DENSE_RATIO * repeats) as u64 {
            let local = |g: UVec3| ((g.x - lo.x) + side.x * ((g.y - lo.y) + side.y * (g.z - lo.z))) as usize;
            let mut index = vec![u32::MAX; volume as usize];
            for &origin in origins {
                let size = size(origin);
                for z in 0..=size.z {
                    for y in 0..=size.y {
                        let row = local(origin + UVec3::new(0, y, z));
                        index[row..=row + size.x as usize].fill(0);
                    }
                }
            }
            for z in 0..side.z {
                for y in 0..side.y {
                    for x in 0..side.x {
                        let i = (x + side.x * (y + side.y * z)) as usize;
                        if index[i] == 0 {
                            index[i] = shared.keys.len() as u32;
                            let g = lo + UVec3::new(x, y, z);
                            shared.keys.push(shared.key(g));
                            shared.at.push(g);
                        }
                    }
                }
            }
            shared.dense = Some((lo, side, index));
        } else {
            for &origin in origins {
                let size = size(origin);
                for z in 0..=size.z {
                    for y in 0..=size.y {
                        let row = shared.key(origin + UVec3::new(0, y, z));
                        shared.keys.extend(row..=row + u64::from(size.x));
                    }
                }
            }
            shared.keys.par_sort_unstable();
            shared.keys.dedup();
            shared.at = shared.keys.iter().map(|&k| shared.at(k)).collect();
        }
        shared.values = vec![0.0; shared.keys.len()];
        match field.lipschitz() {
            Some(l) if l.is_finite() && l >= 0.0 => shared.sample_near_surface(field, lattice, origins, l)?,
            _ => shared.evaluate(field, lattice, &(0..shared.keys.len()).collect::<Vec<_>>())?,
        }
        Ok(shared)
    }

    /// Whether lattice point `g`, one of the batch's, was decided by the Lipschitz
    /// bound rather than sampled.
    #[cfg(test)]
    pub fn proven(&self, g: UVec3) -> bool {
        self.proven.get(self.find(g)).copied().unwrap_or(false)
    }

    /// Whether the batch was listed on a dense grid (else sorted).
    #[cfg(test)]
    pub fn is_dense(&self) -> bool {
        self.dense.is_some()
    }

    /// Points evaluated.
    pub fn evaluated(&self) -> usize {
        self.evaluated
    }

    /// Evaluates the points `indices` (among the keys) in parallel batches; a field
    /// that is not a number at one is an error.
    fn evaluate<F: ScalarField + ?Sized>(&mut self, field: &F, lattice: &Lattice, indices: &[usize]) -> Result<()> {
        let point = |i: usize| lattice.point(self.at[i]);
        let mut values = vec![0.0; indices.len()];
        const CHUNK: usize = 4096;
        values.par_chunks_mut(CHUNK).zip(indices.par_chunks(CHUNK)).for_each(|(out, indices)| {
            let points: Vec<Vec3> = indices.iter().map(|&i| point(i)).collect();
            field.values(&points, out);
        });
        if let Some(k) = values.iter().position(|v| v.is_nan()) {
            return Err(Error::InvalidParameter(format!("the field is not a number at {}", point(indices[k]))));
        }
        for (&i, v) in indices.iter().zip(values) {
            self.values[i] = v;
        }
        self.evaluated += indices.len();
        Ok(())
    }

    /// The index ranges of the rows of the box of lattice points from `lo` spanning
    /// `size` cells, all the batch's.
    fn rows(&self, (lo, size): (UVec3, UVec3)) -> impl Iterator<Item = std::ops::RangeInclusive<usize>> + '_ {
        (0..=size.z).flat_map(move |z| (0..=size.y).map(move |y| (z, y))).map(move |(z, y)| {
            let row = self.find(lo + UVec3::new(0, y, z));
            row..=row + size.x as usize
        })
    }

    /// The batch's points sampled where the surface may pass, the rest decided by the
    /// field's Lipschitz bound `l` (the sphere-tracing argument of Hart 1996 on the
    /// lattice). Each block is cut into sub-blocks of 2³ cells; the centre of one
    /// (a lattice point) is sampled first, and where `|f| > l r` there, with `r` the
    /// distance to the sub-block's corners (rounding of the lattice's points
    /// included), `f` keeps that sign on the whole closed sub-block: no edge in it
    /// changes sign, and its points are given the centre's value rather than sampled,
    /// unless a sub-block not so proven also holds them. Inside proofs are not taken
    /// next to the box's faces, where the cut makes crossings (as the octree's
    /// descent does). Every sign-changing edge and every cell with a surface lies in
    /// sub-blocks not proven, all of whose points are sampled: the mesh is the one
    /// that sampling every point gives, bit for bit.
    fn sample_near_surface<F: ScalarField + ?Sized>(&mut self, field: &F, lattice: &Lattice, origins: &[UVec3], l: f32) -> Result<()> {
        // Sub-blocks: lowest lattice point and cells per side (fewer than 2 at the lattice's end).
        let mut subs: Vec<(UVec3, UVec3)> = Vec::with_capacity(origins.len() * 8);
        for &origin in origins {
            let size = (lattice.cells - origin).min(UVec3::splat(BLOCK));
            for z in (0..size.z).step_by(2) {
                for y in (0..size.y).step_by(2) {
                    for x in (0..size.x).step_by(2) {
                        let local = UVec3::new(x, y, z);
                        subs.push((origin + local, (size - local).min(UVec3::splat(2))));
                    }
                }
            }
        }
        let whole: Vec<usize> = (0..subs.len()).filter(|&k| subs[k].1 == UVec3::splat(2)).collect();
        let centres: Vec<usize> = whole.iter().map(|&k| self.find(subs[k].0 + 1)).collect();
        self.evaluate(field, lattice, &centres)?;
        let extent = lattice.lo.abs().max(lattice.hi.abs()).max_element();
        let reach = l * (lattice.step.length() * (1.0 + 1e-3) + 8.0 * f32::EPSILON * extent);
        // Per sub-block: the value proving its sign, if any.
        let mut proof: Vec<Option<f32>> = vec![None; subs.len()];
        for (&k, &c) in whole.iter().zip(&centres) {
            let (lo, v) = (subs[k].0, self.values[c]);
            let touches_faces = lo.cmpeq(UVec3::ZERO).any() || (lo + 2).cmpeq(lattice.cells).any();
            if v > reach || (v < -reach && !touches_faces) {
                proof[k] = Some(v);
            }
        }
        // 0: not yet known, 1: to sample, 2: sampled (the centres).
        let mut state = vec![0u8; self.keys.len()];
        for &c in &centres {
            state[c] = 2;
        }
        for (k, &sub) in subs.iter().enumerate() {
            if proof[k].is_none() {
                for row in self.rows(sub) {
                    for s in &mut state[row] {
                        *s = (*s).max(1);
                    }
                }
            }
        }
        let todo: Vec<usize> = (0..state.len()).filter(|&i| state[i] == 1).collect();
        #[cfg(test)]
        {
            self.proven = state.iter().map(|&s| s == 0).collect();
        }
        self.evaluate(field, lattice, &todo)?;
        for (k, &sub) in subs.iter().enumerate() {
            if let Some(v) = proof[k] {
                let rows: Vec<_> = self.rows(sub).collect();
                for row in rows {
                    for i in row {
                        if state[i] == 0 {
                            self.values[i] = v;
                        }
                    }
                }
            }
        }
        Ok(())
    }

    fn key(&self, g: UVec3) -> u64 {
        u64::from(g.x) + u64::from(self.n.x) * (u64::from(g.y) + u64::from(self.n.y) * u64::from(g.z))
    }

    fn at(&self, key: u64) -> UVec3 {
        let (nx, ny) = (u64::from(self.n.x), u64::from(self.n.y));
        UVec3::new((key % nx) as u32, (key / nx % ny) as u32, (key / (nx * ny)) as u32)
    }

    /// The index of lattice point `g`, one of the batch's.
    fn find(&self, g: UVec3) -> usize {
        match &self.dense {
            Some((lo, side, index)) => {
                let l = g - *lo;
                let i = index[(l.x + side.x * (l.y + side.y * l.z)) as usize];
                assert!(i != u32::MAX, "a batch's blocks' points are all evaluated");
                i as usize
            }
            None => self.keys.binary_search(&self.key(g)).expect("a batch's blocks' points are all evaluated"),
        }
    }
}

/// One block's cells and crossings, before the batch refines the crossings.
struct Found {
    block: Block,
    size: UVec3,
    /// Cells with a surface.
    active: Vec<UVec3>,
    /// Per lattice point and axis (`point * 3 + axis`): its crossing among the block's.
    slot: Vec<u32>,
    /// Per crossing: its edge's ends, whether each lies on the box's faces, and the
    /// first guess.
    ends: Vec<(Vec3, Vec3)>,
    on_face: Vec<(bool, bool)>,
    guesses: Vec<Crossing>,
    /// Per crossing: its edge in the batch, `3 ×` its first end's index in [`Shared`] `+ axis`.
    edge: Vec<usize>,
}

/// The block at `origin`: corner signs per cell and one crossing per sign-changing
/// edge, from the lattice samples in `shared`.
fn find(lattice: &Lattice, origin: UVec3, shared: &Shared) -> Found {
    let Samples { size, values } = Samples::from_shared(lattice, origin, shared);
    let n = size + 1;
    let point_index = |p: UVec3| (p.x + n.x * (p.y + n.y * p.z)) as usize;
    let count = (n.x * n.y * n.z) as usize;
    let table = cases();
    let block = Block { origin, first: vec![u32::MAX; CELLS], config: vec![0; CELLS], ..Default::default() };
    let mut found = Found {
        block,
        size,
        active: Vec::new(),
        slot: vec![u32::MAX; count * 3],
        ends: Vec::new(),
        on_face: Vec::new(),
        guesses: Vec::new(),
        edge: Vec::new(),
    };
    let inside: Vec<u8> = values.iter().map(|&v| u8::from(v <= 0.0)).collect();
    // Corner `c`'s point from its cell's lowest.
    let offset: [usize; 8] = std::array::from_fn(|c| point_index(UVec3::new(c as u32 & 1, c as u32 >> 1 & 1, c as u32 >> 2 & 1)));
    for z in 0..size.z {
        for y in 0..size.y {
            for x in 0..size.x {
                let cell = UVec3::new(x, y, z);
                let base = point_index(cell);
                let config = (0..8).fold(0u8, |m, c| m | inside[base + offset[c]] << c);
                found.block.config[cell_index(cell)] = config;
                if config != 0 && config != 255 {
                    found.active.push(cell);
                }
            }
        }
    }
    // About one and a half crossings per active cell (three to six crossing edges a
    // cell, each shared by four cells): room for three reserved once, not grown.
    let guess = found.active.len() * 3;
    found.ends.reserve(guess);
    found.on_face.reserve(guess);
    found.guesses.reserve(guess);
    found.edge.reserve(guess);
    for &cell in &found.active {
        let config = found.block.config[cell_index(cell)];
        let corner = |c: usize| cell + UVec3::new(c as u32 & 1, c as u32 >> 1 & 1, c as u32 >> 2 & 1);
        for e in (0..12).filter(|&e| table[config as usize].piece[e] != NONE) {
            let (a, b) = ends(e);
            let (pa, pb) = (point_index(corner(a)), point_index(corner(b)));
            let s = pa * 3 + e / 4;
            if found.slot[s] == u32::MAX {
                let (ga, gb) = (origin + corner(a), origin + corner(b));
                found.slot[s] = found.guesses.len() as u32;
                found.ends.push((lattice.point(ga), lattice.point(gb)));
                found.on_face.push((lattice.on_face(ga), lattice.on_face(gb)));
                found.guesses.push(Crossing::new(values[pa], values[pb], 0.0));
                found.edge.push(shared.find(ga) * 3 + e / 4);
            }
        }
    }
    found
}

/// Samples and contours the blocks at `origins` (in cells), their lattice points'
/// values taken from `shared`. Each block's crossings are found alone; then the
/// batch's crossings are refined, their gradients taken and its vertices pulled onto
/// the surface together, so the evaluator gets full blocks of points rather than a
/// few per block (each crossing and vertex is still computed alone: the same results).
/// An edge on the faces between blocks is refined once for all of them (about 40% of
/// the crossings on issue 17's tree): from the same samples, to the same result.
/// Returns the blocks and the evaluations made (the lattice points' left out).
pub(super) fn process<F: ScalarField + ?Sized>(field: &F, lattice: &Lattice, origins: &[UVec3], shared: &Shared) -> (Vec<Block>, usize) {
    let found: Vec<Found> = origins.par_iter().map(|&o| find(lattice, o, shared)).collect();
    let mut evaluations = 0;
    // Every crossing of the batch, block after block.
    let mut offsets = Vec::with_capacity(found.len());
    let mut total = 0;
    for f in &found {
        offsets.push(total);
        total += f.guesses.len();
    }
    // Each edge of the batch once: `unique[c]` is crossing `c`'s among them.
    let mut first = vec![u32::MAX; shared.keys.len() * 3];
    let mut unique: Vec<u32> = Vec::with_capacity(total);
    let mut guesses: Vec<Crossing> = Vec::with_capacity(total);
    let mut edge_ends: Vec<(Vec3, Vec3)> = Vec::with_capacity(total);
    let mut on_face: Vec<(bool, bool)> = Vec::with_capacity(total);
    for f in &found {
        for (k, &edge) in f.edge.iter().enumerate() {
            if first[edge] == u32::MAX {
                first[edge] = guesses.len() as u32;
                guesses.push(f.guesses[k]);
                edge_ends.push(f.ends[k]);
                on_face.push(f.on_face[k]);
            }
            unique.push(first[edge]);
        }
    }
    drop(first);
    let total = guesses.len();
    // Refine every crossing on the cut field, one batch per step.
    let along = |c: usize, t: f32| edge_ends[c].0.lerp(edge_ends[c].1, t);
    evaluations += refine_crossings(field, &mut guesses, along, |f, p| lattice.cut(f, p), REFINE_TOLERANCE * lattice.step.min_element());
    let mut places: Vec<Vec3> = guesses.iter().enumerate().map(|(c, g)| along(c, g.result())).collect();
    let mut normals = vec![Vec3::ZERO; places.len()];
    field.gradients(&places, &mut normals);
    evaluations += places.len();
    // Where an edge reaches the box's faces, the box may have made the crossing.
    let near: Vec<usize> = (0..total).filter(|&c| on_face[c].0 || on_face[c].1).collect();
    if !near.is_empty() {
        let near_points: Vec<Vec3> = near.iter().map(|&c| places[c]).collect();
        let mut f = vec![0.0; near.len()];
        field.values(&near_points, &mut f);
        for (&c, f) in near.iter().zip(f) {
            let (d, face) = lattice.to_box(places[c]);
            if d >= f {
                // The box made it: on the face itself, at the edge's end there.
                normals[c] = face;
                places[c] = if on_face[c].1 { edge_ends[c].1 } else { edge_ends[c].0 };
            }
        }
    }
    for g in &mut normals {
        *g = if g.is_finite() { g.normalize_or_zero() } else { Vec3::ZERO };
    }
    // One vertex per piece, block by block.
    let mut blocks: Vec<Block> = found
        .into_par_iter()
        .zip(offsets)
        .map(|(f, offset)| {
            let Found { mut block, size, active, slot, .. } = f;
            let n = size + 1;
            let point_index = |p: UVec3| (p.x + n.x * (p.y + n.y * p.z)) as usize;
            let table = cases();
            let origin = block.origin;
            // Most active cells hold one piece.
            block.qef.reserve(active.len());
            block.mass.reserve(active.len());
            block.cell.reserve(active.len());
            block.edges.reserve(active.len());
            for cell in active {
                let config = block.config[cell_index(cell)];
                let case = &table[config as usize];
                block.first[cell_index(cell)] = block.qef.len() as u32;
                let mut qefs = [Qef::default(); 4];
                let corner = |c: usize| cell + UVec3::new(c as u32 & 1, c as u32 >> 1 & 1, c as u32 >> 2 & 1);
                for e in (0..12).filter(|&e| case.piece[e] != NONE) {
                    let c = unique[offset + slot[point_index(corner(ends(e).0)) * 3 + e / 4] as usize] as usize;
                    qefs[case.piece[e] as usize].add(places[c], normals[c]);
                }
                let (lo, hi) = (lattice.point(origin + cell), lattice.point(origin + cell + 1));
                for q in &qefs[..case.pieces as usize] {
                    block.qef.push(q.solve(lo, hi));
                    block.mass.push(q.mass_point());
                    block.cell.push(origin + cell);
                }
                // The edges from the cell's lowest corner are the block's to contour.
                for axis in 0..3 {
                    let e = axis * 4;
                    if case.piece[e] != NONE {
                        let c = unique[offset + slot[point_index(cell) * 3 + axis] as usize] as usize;
                        block.edges.push(OwnedEdge { from: origin + cell, axis: axis as u8, from_inside: config & 1 == 1, normal: normals[c] });
                    }
                }
            }
            block
        })
        .collect();
    // Vertices far off the surface pulled onto it, the batch's together.
    let (mut qef, mut cell, mut mass) = (Vec::new(), Vec::new(), Vec::new());
    for b in &blocks {
        qef.extend_from_slice(&b.qef);
        cell.extend_from_slice(&b.cell);
        mass.extend_from_slice(&b.mass);
    }
    evaluations += project(field, lattice, &mut qef, &cell, Some(&mass));
    let mut moved = qef.into_iter();
    for b in &mut blocks {
        for q in &mut b.qef {
            *q = moved.next().expect("as many as the blocks hold");
        }
    }
    (blocks, evaluations)
}
