//! The sign-changing lattice edges of a resolution counted without meshing: the
//! interval-culled descent's blocks ([`super::octree`]) sampled as the mesher samples
//! them (in its batches, on the lattice points they share: [`Shared`]), their crossings counted per edge direction. What
//! [`crate::polygonize::estimate`] scales to a finer lattice.

use super::block::{Samples, Shared};
use super::lattice::{Lattice, BLOCK};
use super::octree::live_blocks;
use super::BLOCKS_PER_LOOK;
use crate::field::ScalarField;
use crate::polygonize::estimate::Watch;
use crate::Result;
use glam::{UVec3, Vec3};
use rayon::prelude::*;

/// Crossings counted on one lattice.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Crossings {
    /// Sign-changing edges along x, y, z, and along the cells' `+x+y` diagonal (the
    /// grid mesher's prisms split every cube along it).
    pub edges: [u64; 4],
    /// The blocks of [`BLOCK`]³ cells the descent kept.
    pub live_blocks: u64,
    pub cells: UVec3,
    /// A cell's sides.
    pub step: Vec3,
}

impl Crossings {
    /// Each edge direction's vector, in cells.
    pub const DIRECTIONS: [UVec3; 4] = [UVec3::X, UVec3::Y, UVec3::Z, UVec3::new(1, 1, 0)];
}

/// The crossings of `field` (cut by the box, as both meshers cut it) on the lattice of
/// `bounds` at `resolution` cells along its longest side. Each edge is counted once,
/// by the block holding its first end (an edge on a block's upper face is its
/// neighbour's; a dropped neighbour has no crossing there).
pub fn count_crossings<F: ScalarField + ?Sized>(field: &F, bounds: (Vec3, Vec3), resolution: u32, watch: &Watch<'_>) -> Result<Crossings> {
    let lattice = Lattice::new(bounds, resolution)?;
    let live = live_blocks(field, &lattice, watch)?;
    let mut per_block = Vec::with_capacity(live.len());
    // In the mesher's batches, each batch's lattice points evaluated once ([`Shared`]).
    for batch in live.chunks(BLOCKS_PER_LOOK) {
        watch.check()?;
        let origins: Vec<UVec3> = batch.iter().map(|&b| b * BLOCK).collect();
        let shared = Shared::of(field, &lattice, &origins)?;
        per_block.par_extend(origins.par_iter().map(|&origin| {
            let s = Samples::from_shared(&lattice, origin, &shared);
            let inside = |p: UVec3| s.values[s.index(p)] <= 0.0;
            let mut edges = [0u64; 4];
            for z in 0..s.size.z {
                for y in 0..s.size.y {
                    for x in 0..s.size.x {
                        let p = UVec3::new(x, y, z);
                        let here = inside(p);
                        for (count, d) in edges.iter_mut().zip(Crossings::DIRECTIONS) {
                            *count += u64::from(here != inside(p + d));
                        }
                    }
                }
            }
            edges
        }));
    }
    let mut edges = [0u64; 4];
    for e in per_block {
        for (sum, n) in edges.iter_mut().zip(e) {
            *sum += n;
        }
    }
    Ok(Crossings { edges, live_blocks: live.len() as u64, cells: lattice.cells, step: lattice.step })
}
