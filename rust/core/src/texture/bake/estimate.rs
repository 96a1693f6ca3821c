//! The triangle count a bake is expected to make, told to the user before a large bake
//! and checked against the budget: the marching-prism cases of a sample of the cells,
//! each sampled on its own lattice as the bake would (textures only: no shell, region
//! or holes), scaled to all cells.

use super::lattice::Lattice;
use super::prism_table;
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
    for p in 0..picked {
        // Cells evenly spread over the mesh, so UV scales vary as they do in the bake.
        let [a, b, c] = lattice.st[p * cells / picked];
        for (k, &(i, j)) in points.iter().enumerate() {
            let st = a + (b - a) * (i as f32 / n as f32) + (c - a) * (j as f32 / n as f32);
            for l in 0..=m {
                // The shell's base and outer layer are outside, as in the bake.
                let r = l as f32 / m as f32;
                let inner = l > 0 && l < m;
                values[k * (m + 1) + l] =
                    if inner { textures.iter().map(|t| t.texture.sample((st + t.offset).extend(r))).fold(0.0, f32::max) } else { 0.0 };
            }
        }
        let column = |i: u32, j: u32| &values[lattice.local_index(i, j) * (m + 1)..][..m + 1];
        for i in 0..n {
            for j in 0..n - i {
                let up = [(i, j), (i + 1, j), (i, j + 1)];
                let down = [(i + 1, j), (i + 1, j + 1), (i, j + 1)];
                for corners in if i + j + 2 <= n { vec![up, down] } else { vec![up] } {
                    let [a, b, c] = corners.map(|(i, j)| column(i, j));
                    for l in 0..m {
                        triangles += prism_table::classify(&[a[l], b[l], c[l], a[l + 1], b[l + 1], c[l + 1]]).count as usize;
                    }
                }
            }
        }
    }
    (triangles as f64 * cells as f64 / picked as f64).ceil() as usize
}
