//! The triangle count a bake is expected to make, told to the user before a large bake
//! and checked against the budget: the marching-prism cases of a sample of the cells,
//! each sampled on its own lattice as the bake would (textures only: no shell, region
//! or holes), scaled to all cells.

use super::lattice::Lattice;
use super::{field, prism_table};
use super::TextureLayer;

/// Texture samples the estimate may take: a few milliseconds, far below a bake.
const BUDGET: usize = 200_000;

pub(super) fn estimate_triangles(lattice: &Lattice, textures: &[TextureLayer], layers: u32) -> usize {
    let cells = lattice.tris.len();
    if textures.is_empty() || cells == 0 {
        return 0;
    }
    let (n, m) = (lattice.n, layers as usize);
    let points: Vec<(u32, u32)> = lattice.local_points().collect();
    let picked = (BUDGET / (points.len() * (m + 1))).clamp(1, 64).min(cells);
    let mut triangles = 0usize;
    let mut values = vec![0.0f32; points.len() * (m + 1)];
    let mut footprint = Vec::with_capacity(textures.len());
    for p in 0..picked {
        // Cells evenly spread over the mesh, so UV scales vary as they do in the bake.
        let [a, b, c] = lattice.st[p * cells / picked];
        for (k, &(i, j)) in points.iter().enumerate() {
            let st = a + (b - a) * (i as f32 / n as f32) + (c - a) * (j as f32 / n as f32);
            footprint.clear();
            field::footprints(textures, st, &mut footprint);
            // The shell's base and outer layer are outside, as in the bake.
            for (l, v) in values[k * (m + 1)..][..m + 1].iter_mut().enumerate() {
                *v = if l > 0 && l < m { field::union(textures, &footprint, l as f32 / m as f32) } else { 0.0 };
            }
        }
        let column = |k: usize| &values[k * (m + 1)..][..m + 1];
        for [a, b, c] in lattice.small_triangles().map(|t| t.map(column)) {
            for l in 0..m {
                triangles += prism_table::classify(&[a[l], b[l], c[l], a[l + 1], b[l + 1], c[l + 1]]).count as usize;
            }
        }
    }
    (triangles as f64 * cells as f64 / picked as f64).ceil() as usize
}
