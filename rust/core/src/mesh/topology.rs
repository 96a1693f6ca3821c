//! Edge adjacency: which faces use each undirected edge, for boundary and
//! manifoldness checks and for closing shells with rims.

use super::Mesh;
use std::collections::HashMap;

/// Undirected edge -> number of faces using it, and the directed half-edge of its first use.
pub struct EdgeMap {
    pub uses: HashMap<(u32, u32), (u32, (u32, u32))>,
}

impl EdgeMap {
    pub fn of(mesh: &Mesh) -> Self {
        let mut uses: HashMap<(u32, u32), (u32, (u32, u32))> = HashMap::with_capacity(mesh.corners().len());
        for face in mesh.faces() {
            for i in 0..face.len() {
                let (a, b) = (face[i], face[(i + 1) % face.len()]);
                if a == b {
                    continue;
                }
                uses.entry((a.min(b), a.max(b))).or_insert((0, (a, b))).0 += 1;
            }
        }
        Self { uses }
    }
    pub fn count_with(&self, pred: impl Fn(u32) -> bool) -> usize {
        self.uses.values().filter(|(n, _)| pred(*n)).count()
    }
}

/// Directed boundary edges (used by exactly one face), in the direction that face uses
/// them, sorted for deterministic output.
pub fn boundary_edges(mesh: &Mesh) -> Vec<(u32, u32)> {
    let mut edges: Vec<(u32, u32)> =
        EdgeMap::of(mesh).uses.values().filter(|(n, _)| *n == 1).map(|(_, e)| *e).collect();
    edges.sort_unstable();
    edges
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::fixtures;

    #[test]
    fn closed_cube_has_no_boundary_grid_has_perimeter() {
        assert!(boundary_edges(&fixtures::cube()).is_empty());
        assert_eq!(boundary_edges(&fixtures::grid(3)).len(), 12);
    }
}
