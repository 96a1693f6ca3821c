//! One block of cells at the finest level: its lattice points sampled (with the other
//! blocks of its batch, each shared point once: [`Shared`]),
//! each sign-changing edge's crossing found once on the field (Illinois regula falsi)
//! with the analytic gradient there, and one vertex per piece of every cell
//! ([`super::cases`]) placed by its [`Qef`] (Ju et al. 2002, section 2.3).

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
    /// Field evaluations made (values and gradients, per point).
    pub evaluations: usize,
}

pub(super) fn cell_index(local: UVec3) -> usize {
    (local.x + BLOCK * (local.y + BLOCK * local.z)) as usize
}

/// The lattice points of the block at `origin` (in cells), `x` fastest: where they are,
/// their lattice coordinates, and the cut field's samples there ([`Lattice::sample`]).
pub(super) struct Samples {
    /// Cells of the block (fewer than [`BLOCK`] where it reaches the lattice's end).
    pub size: UVec3,
    pub points: Vec<Vec3>,
    pub at: Vec<UVec3>,
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
        Ok(Self { size, points, at, values })
    }

    /// The block's lattice points looked up in `shared`, which holds them all.
    pub(super) fn from_shared(lattice: &Lattice, origin: UVec3, shared: &Shared) -> Self {
        let size = (lattice.cells - origin).min(UVec3::splat(BLOCK));
        let n = size + 1;
        let count = (n.x * n.y * n.z) as usize;
        let mut points = Vec::with_capacity(count);
        let mut at = Vec::with_capacity(count);
        let mut values = Vec::with_capacity(count);
        for z in 0..n.z {
            for y in 0..n.y {
                // A row's keys are consecutive: one search per row.
                let row = shared.find(shared.key(origin + UVec3::new(0, y, z)));
                for x in 0..n.x {
                    let g = origin + UVec3::new(x, y, z);
                    let p = lattice.point(g);
                    at.push(g);
                    points.push(p);
                    values.push(lattice.sample(shared.values[row + x as usize], g));
                }
            }
        }
        Self { size, points, at, values }
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
/// samples on issue 17's tree). Sorted by their key (`x` fastest), so a block's rows
/// are runs of consecutive keys.
pub(super) struct Shared {
    /// Lattice points along x and y (for the keys).
    n: UVec3,
    keys: Vec<u64>,
    values: Vec<f32>,
}

impl Shared {
    /// The lattice points of the blocks at `origins` (in cells), evaluated in parallel
    /// batches; a field that is not a number at one is an error.
    pub fn of<F: ScalarField + ?Sized>(field: &F, lattice: &Lattice, origins: &[UVec3]) -> Result<Self> {
        let mut shared = Self { n: lattice.cells + 1, keys: Vec::new(), values: Vec::new() };
        for &origin in origins {
            let size = (lattice.cells - origin).min(UVec3::splat(BLOCK));
            for z in 0..=size.z {
                for y in 0..=size.y {
                    let row = shared.key(origin + UVec3::new(0, y, z));
                    shared.keys.extend(row..=row + u64::from(size.x));
                }
            }
        }
        shared.keys.par_sort_unstable();
        shared.keys.dedup();
        let points: Vec<Vec3> = shared.keys.iter().map(|&k| lattice.point(shared.at(k))).collect();
        shared.values = vec![0.0; points.len()];
        const CHUNK: usize = 4096;
        shared.values.par_chunks_mut(CHUNK).zip(points.par_chunks(CHUNK)).for_each(|(out, points)| field.values(points, out));
        if let Some(i) = shared.values.iter().position(|v| v.is_nan()) {
            return Err(Error::InvalidParameter(format!("the field is not a number at {}", points[i])));
        }
        Ok(shared)
    }

    /// Points evaluated.
    pub fn evaluated(&self) -> usize {
        self.keys.len()
    }

    fn key(&self, g: UVec3) -> u64 {
        u64::from(g.x) + u64::from(self.n.x) * (u64::from(g.y) + u64::from(self.n.y) * u64::from(g.z))
    }

    fn at(&self, key: u64) -> UVec3 {
        let (nx, ny) = (u64::from(self.n.x), u64::from(self.n.y));
        UVec3::new((key % nx) as u32, (key / nx % ny) as u32, (key / (nx * ny)) as u32)
    }

    fn find(&self, key: u64) -> usize {
        self.keys.binary_search(&key).expect("a batch's blocks' points are all evaluated")
    }
}

/// Samples and contours the block at `origin` (in cells), its lattice points' values
/// taken from `shared` (the evaluations it reports leave them out).
pub(super) fn process<F: ScalarField + ?Sized>(field: &F, lattice: &Lattice, origin: UVec3, shared: &Shared) -> Result<Block> {
    let Samples { size, points, at, values } = Samples::from_shared(lattice, origin, shared);
    let n = size + 1;
    let point_index = |p: UVec3| (p.x + n.x * (p.y + n.y * p.z)) as usize;
    let count = (n.x * n.y * n.z) as usize;
    let mut evaluations = 0;
    let table = cases();
    let mut block = Block { origin, first: vec![u32::MAX; CELLS], config: vec![0; CELLS], ..Default::default() };
    // Crossings, one per sign-changing edge of the block's lattice (slot: point * 3 + axis).
    let mut slot = vec![u32::MAX; count * 3];
    let mut crossings: Vec<(usize, usize, Crossing)> = Vec::new();
    let mut active: Vec<UVec3> = Vec::new();
    for z in 0..size.z {
        for y in 0..size.y {
            for x in 0..size.x {
                let cell = UVec3::new(x, y, z);
                let corner = |c: usize| cell + UVec3::new(c as u32 & 1, c as u32 >> 1 & 1, c as u32 >> 2 & 1);
                let config = (0..8).fold(0u8, |m, c| m | (u8::from(values[point_index(corner(c))] <= 0.0) << c));
                block.config[cell_index(cell)] = config;
                if config == 0 || config == 255 {
                    continue;
                }
                active.push(cell);
                for e in (0..12).filter(|&e| table[config as usize].piece[e] != NONE) {
                    let (a, b) = ends(e);
                    let (pa, pb) = (point_index(corner(a)), point_index(corner(b)));
                    let s = pa * 3 + e / 4;
                    if slot[s] == u32::MAX {
                        slot[s] = crossings.len() as u32;
                        crossings.push((pa, pb, Crossing::new(values[pa], values[pb], 0.0)));
                    }
                }
            }
        }
    }
    if active.is_empty() {
        return Ok(block);
    }
    // Refine every crossing on the cut field, one batch per step.
    let mut guesses: Vec<Crossing> = crossings.iter().map(|c| c.2).collect();
    let along = |c: usize, t: f32| points[crossings[c].0].lerp(points[crossings[c].1], t);
    evaluations += refine_crossings(field, &mut guesses, along, |f, p| lattice.cut(f, p), REFINE_TOLERANCE * lattice.step.min_element());
    let mut places: Vec<Vec3> = guesses.iter().enumerate().map(|(c, g)| along(c, g.result())).collect();
    let mut normals = vec![Vec3::ZERO; places.len()];
    field.gradients(&places, &mut normals);
    evaluations += places.len();
    // Where an edge reaches the box's faces, the box may have made the crossing.
    let near: Vec<usize> = (0..crossings.len()).filter(|&c| lattice.on_face(at[crossings[c].0]) || lattice.on_face(at[crossings[c].1])).collect();
    if !near.is_empty() {
        let near_points: Vec<Vec3> = near.iter().map(|&c| places[c]).collect();
        let mut f = vec![0.0; near.len()];
        field.values(&near_points, &mut f);
        for (&c, f) in near.iter().zip(f) {
            let (d, face) = lattice.to_box(places[c]);
            if d >= f {
                // The box made it: on the face itself, at the edge's end there.
                normals[c] = face;
                let (a, b) = (crossings[c].0, crossings[c].1);
                places[c] = if lattice.on_face(at[b]) { points[b] } else { points[a] };
            }
        }
    }
    for g in &mut normals {
        *g = if g.is_finite() { g.normalize_or_zero() } else { Vec3::ZERO };
    }
    // One vertex per piece.
    for cell in active {
        let config = block.config[cell_index(cell)];
        let case = &table[config as usize];
        block.first[cell_index(cell)] = block.qef.len() as u32;
        let mut qefs = [Qef::default(); 4];
        let corner = |c: usize| cell + UVec3::new(c as u32 & 1, c as u32 >> 1 & 1, c as u32 >> 2 & 1);
        for e in (0..12).filter(|&e| case.piece[e] != NONE) {
            let c = slot[point_index(corner(ends(e).0)) * 3 + e / 4] as usize;
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
                let c = slot[point_index(cell) * 3 + axis] as usize;
                block.edges.push(OwnedEdge { from: origin + cell, axis: axis as u8, from_inside: config & 1 == 1, normal: normals[c] });
            }
        }
    }
    evaluations += project(field, lattice, &mut block.qef, &block.cell, Some(&block.mass));
    block.evaluations = evaluations;
    Ok(block)
}
