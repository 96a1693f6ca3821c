//! Sparse descent: the box's blocks of cells halved from the root while the field's
//! interval bound ([`ScalarField::interval`]) cannot rule out the surface, so only the
//! blocks that may hold it at the finest level are sampled. Work and memory follow the
//! surface, not the volume (the octree culling of Schaefer, Ju and Warren 2007, section
//! 4, here a test per box, without a tree kept).

use super::lattice::{Lattice, BLOCK};
use crate::field::ScalarField;
use crate::polygonize::estimate::{over_limit, Watch, BYTES_PER_BLOCK};
use crate::Result;
use glam::UVec3;
use rayon::prelude::*;
use std::sync::atomic::{AtomicUsize, Ordering};

/// What the descent checks as it goes: the watch's cancel, and the blocks kept so far
/// against the most the memory limit lets the mesher hold.
struct Guard<'a> {
    watch: &'a Watch<'a>,
    kept: AtomicUsize,
    most: usize,
}

impl Guard<'_> {
    fn stopped(&self) -> bool {
        self.watch.is_cancelled() || self.kept.load(Ordering::Relaxed) > self.most
    }
}

/// The blocks (their lowest cell, in [`BLOCK`] steps) that may hold a surface, in a
/// fixed order (depth first, lower halves first) whatever the number of threads.
///
/// A box of blocks is dropped where its enclosure is outside by more than the
/// lattice's `eps` (every sample in it, faces included, is outside), or inside by more
/// than `eps` without touching the box's faces (where the box cuts the solid). A block
/// dropped has no sign change on any of its edges, so every cell around a crossing
/// edge is in a block kept.
///
/// Stops with [`crate::Error::Cancelled`] when the watch is cancelled, and with an
/// error naming the limit when the blocks kept would pass the watch's memory limit
/// (each costs at least [`BYTES_PER_BLOCK`] once sampled).
pub(super) fn live_blocks<F: ScalarField + ?Sized>(field: &F, lattice: &Lattice, watch: &Watch<'_>) -> Result<Vec<UVec3>> {
    let blocks = (lattice.cells + BLOCK - 1) / BLOCK;
    let cull = field.interval(lattice.lo, lattice.hi).is_some();
    let most = watch.max_bytes.map_or(usize::MAX, |m| usize::try_from(m / BYTES_PER_BLOCK).unwrap_or(usize::MAX));
    let guard = Guard { watch, kept: AtomicUsize::new(0), most };
    let live = descend(field, lattice, cull, &guard, UVec3::ZERO, blocks);
    watch.check()?;
    let kept = guard.kept.load(Ordering::Relaxed);
    if kept > most {
        return Err(over_limit(watch.max_bytes.unwrap_or(u64::MAX), &format!("{kept} blocks of cells may hold the surface")));
    }
    Ok(live)
}

fn descend<F: ScalarField + ?Sized>(field: &F, lattice: &Lattice, cull: bool, guard: &Guard<'_>, lo: UVec3, hi: UVec3) -> Vec<UVec3> {
    if guard.stopped() {
        return Vec::new();
    }
    let (a, b) = (lo * BLOCK, (hi * BLOCK).min(lattice.cells));
    if cull {
        if let Some((l, u)) = field.interval(lattice.point(a), lattice.point(b)) {
            if l > lattice.eps {
                return Vec::new();
            }
            let touches_faces = a.cmpeq(UVec3::ZERO).any() || b.cmpeq(lattice.cells).any();
            if u < -lattice.eps && !touches_faces {
                return Vec::new();
            }
        }
    }
    let size = hi - lo;
    if size == UVec3::ONE {
        guard.kept.fetch_add(1, Ordering::Relaxed);
        return vec![lo];
    }
    let mid = lo + size / 2;
    let halves = |axis: usize| if size[axis] > 1 { vec![(lo[axis], mid[axis]), (mid[axis], hi[axis])] } else { vec![(lo[axis], hi[axis])] };
    let mut children = Vec::with_capacity(8);
    for &(z0, z1) in &halves(2) {
        for &(y0, y1) in &halves(1) {
            for &(x0, x1) in &halves(0) {
                children.push((UVec3::new(x0, y0, z0), UVec3::new(x1, y1, z1)));
            }
        }
    }
    // Large boxes in parallel; `collect` keeps the children's order.
    if size.max_element() > 4 {
        children.into_par_iter().flat_map_iter(|(l, h)| descend(field, lattice, cull, guard, l, h)).collect()
    } else {
        children.into_iter().flat_map(|(l, h)| descend(field, lattice, cull, guard, l, h)).collect()
    }
}
