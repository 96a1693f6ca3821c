//! The triangle count a bake is expected to make, told to the user before a large bake
//! and checked against the budget: the bake's own occupancy field (textures, region,
//! holes, cutter, moved region) and marching-prism cases on a sample of the cells,
//! scaled to all cells.

use super::field::Field;
use super::lattice::Lattice;
use super::prism_table;
use crate::shell::Shell;
use crate::texture::mapping::CellMap;
use crate::Mesh;

/// Field samples the estimate may take: a few milliseconds, far below a bake.
const BUDGET: usize = 200_000;

pub(super) fn estimate_triangles(mesh: &Mesh, shell: &Shell, lattice: &Lattice, field: &Field, layers: u32) -> usize {
    let cells = lattice.tris.len();
    if cells == 0 {
        return 0;
    }
    let (n, m) = (lattice.n, layers as usize);
    let points: Vec<(u32, u32)> = lattice.local_points().collect();
    let picked = (BUDGET / (points.len() * (m + 1))).clamp(1, 256).min(cells);
    let mut triangles = 0usize;
    let mut values = vec![0.0f32; points.len() * (m + 1)];
    let mut scratch = Vec::new();
    for p in 0..picked {
        // Cells evenly spread over the mesh, so UV scales and weights vary as they do
        // in the bake.
        let t = p * cells / picked;
        let cell = CellMap::new(mesh, shell, &lattice.tris[t], &lattice.st[t]);
        for (k, &(i, j)) in points.iter().enumerate() {
            let column = &mut values[k * (m + 1)..][..m + 1];
            if lattice.boundary[lattice.key(t, i, j)] {
                column.fill(0.0);
                continue;
            }
            field.column(t, &cell, (i as f32 / n as f32, j as f32 / n as f32), column, &mut scratch);
            // The shell's base and outer layer are outside, as in the bake.
            column[0] = 0.0;
            column[m] = 0.0;
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
