//! Sparse descent: the box's blocks of cells halved from the root while the field's
//! bounds cannot rule out the surface, so only the blocks that may hold it at the
//! finest level are sampled. Work and memory follow the surface, not the volume (the
//! octree culling of Schaefer, Ju and Warren 2007, section 4, here a test per box,
//! without a tree kept).
//!
//! The descent goes level by level, each level's boxes tested together: first by the
//! field's Lipschitz bound ([`ScalarField::lipschitz`]) from the value at each box's
//! centre, evaluated as one batch (Hart 1996's sphere-tracing argument: `|f(c)| > L r`
//! keeps one sign over the ball of radius `r` around `c`); the boxes that this cannot
//! decide by their interval bound ([`ScalarField::interval`]), all but single blocks
//! where there is a Lipschitz bound.

use super::lattice::{Lattice, BLOCK};
use crate::field::ScalarField;
use crate::polygonize::estimate::{over_limit, Watch, BYTES_PER_BLOCK};
use crate::Result;
use glam::{UVec3, Vec3};
use rayon::prelude::*;

/// One entry of a level, in cells of [`BLOCK`]: a box still to test, or a block kept.
#[derive(Clone, Copy)]
enum Entry {
    Box(UVec3, UVec3),
    Kept(UVec3),
}

/// The blocks (their lowest cell, in [`BLOCK`] steps) that may hold a surface, in a
/// fixed order (depth first, lower halves first) whatever the number of threads:
/// each level keeps its entries in that order, a box replaced by its halves.
///
/// A box of blocks is dropped where its field is proven outside by more than the
/// lattice's `eps` (every sample in it, faces included, is outside), or inside by more
/// than `eps` without touching the box's faces (where the box cuts the solid). A block
/// dropped has no sign change on any of its edges, so every cell around a crossing
/// edge is in a block kept.
///
/// Stops with [`crate::Error::Cancelled`] when the watch is cancelled (looked at between
/// levels), and with an error naming the limit when the blocks kept would pass the
/// watch's memory limit (each costs at least [`BYTES_PER_BLOCK`] once sampled).
pub(super) fn live_blocks<F: ScalarField + ?Sized>(field: &F, lattice: &Lattice, watch: &Watch<'_>) -> Result<Vec<UVec3>> {
    let blocks = (lattice.cells + BLOCK - 1) / BLOCK;
    let cull = field.interval(lattice.lo, lattice.hi).is_some();
    let lipschitz = field.lipschitz().filter(|l| l.is_finite() && *l >= 0.0);
    let most = watch.max_bytes.map_or(usize::MAX, |m| usize::try_from(m / BYTES_PER_BLOCK).unwrap_or(usize::MAX));
    let mut level = vec![Entry::Box(UVec3::ZERO, blocks)];
    loop {
        watch.check()?;
        let boxes: Vec<(UVec3, UVec3)> = level.iter().filter_map(|e| if let Entry::Box(lo, hi) = *e { Some((lo, hi)) } else { None }).collect();
        if boxes.is_empty() {
            break;
        }
        let mut open = may_hold(field, lattice, lipschitz, cull, &boxes).into_iter();
        let mut next = Vec::with_capacity(level.len() * 2);
        for entry in level {
            match entry {
                Entry::Kept(_) => next.push(entry),
                Entry::Box(lo, hi) => {
                    if !open.next().expect("one answer per box") {
                        continue;
                    }
                    let size = hi - lo;
                    if size == UVec3::ONE {
                        next.push(Entry::Kept(lo));
                        continue;
                    }
                    let mid = lo + size / 2;
                    let halves = |axis: usize| if size[axis] > 1 { vec![(lo[axis], mid[axis]), (mid[axis], hi[axis])] } else { vec![(lo[axis], hi[axis])] };
                    for &(z0, z1) in &halves(2) {
                        for &(y0, y1) in &halves(1) {
                            for &(x0, x1) in &halves(0) {
                                next.push(Entry::Box(UVec3::new(x0, y0, z0), UVec3::new(x1, y1, z1)));
                            }
                        }
                    }
                }
            }
        }
        let kept = next.iter().filter(|e| matches!(e, Entry::Kept(_))).count();
        if kept > most {
            return Err(over_limit(watch.max_bytes.unwrap_or(u64::MAX), &format!("{kept} blocks of cells may hold the surface")));
        }
        level = next;
    }
    Ok(level.into_iter().filter_map(|e| if let Entry::Kept(b) = e { Some(b) } else { None }).collect())
}

/// Per box of blocks `(lo, hi)`: whether the surface may pass through it (see
/// [`live_blocks`]). The Lipschitz test first, all centres in one batch; then the
/// interval bound on the boxes it leaves open (single blocks only without a
/// Lipschitz bound).
fn may_hold<F: ScalarField + ?Sized>(field: &F, lattice: &Lattice, lipschitz: Option<f32>, cull: bool, boxes: &[(UVec3, UVec3)]) -> Vec<bool> {
    let corners = |&(lo, hi): &(UVec3, UVec3)| (lattice.point(lo * BLOCK), lattice.point((hi * BLOCK).min(lattice.cells)));
    let touches_faces = |&(lo, hi): &(UVec3, UVec3)| lo.cmpeq(UVec3::ZERO).any() || (hi * BLOCK).min(lattice.cells).cmpeq(lattice.cells).any();
    // Outside by more than `eps` everywhere, or inside away from the faces.
    let drops = |b: &(UVec3, UVec3), l: f32, u: f32| l > lattice.eps || (u < -lattice.eps && !touches_faces(b));
    let mut open = vec![true; boxes.len()];
    if let Some(slope) = lipschitz {
        let centres: Vec<Vec3> = boxes.iter().map(corners).map(|(a, b)| a.lerp(b, 0.5)).collect();
        let mut values = vec![0.0; centres.len()];
        const CHUNK: usize = 4096;
        values.par_chunks_mut(CHUNK).zip(centres.par_chunks(CHUNK)).for_each(|(out, points)| field.values(points, out));
        // The ball around the centre through the box's corners, the rounding of the
        // centre and of the lattice's points included.
        let extent = lattice.lo.abs().max(lattice.hi.abs()).max_element();
        for ((b, open), v) in boxes.iter().zip(&mut open).zip(values) {
            let (a, c) = corners(b);
            let r = slope * (0.5 * (c - a).length() * (1.0 + 1e-3) + 8.0 * f32::EPSILON * extent);
            if v.is_finite() && drops(b, v - r, v + r) {
                *open = false;
            }
        }
    }
    if cull {
        // With a Lipschitz bound a block is left to it and to the sampling's own proofs
        // ([`super::block::Shared`]): on issue 17's tree the interval bound drops a
        // tenth of the blocks that it leaves open, fewer samples than the bounds cost.
        let interval = |k: usize| open[k] && (lipschitz.is_none() || boxes[k].1 - boxes[k].0 != UVec3::ONE);
        let undecided: Vec<usize> = (0..boxes.len()).filter(|&k| interval(k)).collect();
        let tested: Vec<bool> = undecided
            .par_iter()
            .map(|&k| {
                let (a, c) = corners(&boxes[k]);
                field.interval(a, c).is_none_or(|(l, u)| !drops(&boxes[k], l, u))
            })
            .collect();
        for (&k, t) in undecided.iter().zip(tested) {
            open[k] = t;
        }
    }
    open
}
