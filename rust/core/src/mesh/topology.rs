//! Edge adjacency: which faces use each undirected edge, for boundary and
//! manifoldness checks and for closing shells with rims.

use super::Mesh;
use std::collections::HashMap;

/// How faces use one undirected edge: how many, and the first two, each with whether
/// it walks the edge from its smaller end.
#[derive(Debug, Clone, Copy)]
pub struct EdgeUses {
    pub count: u32,
    pub faces: [(u32, bool); 2],
}

impl EdgeUses {
    /// The directed half-edge of the first use.
    pub fn first_half_edge(&self, (lo, hi): (u32, u32)) -> (u32, u32) {
        if self.faces[0].1 {
            (lo, hi)
        } else {
            (hi, lo)
        }
    }
}

/// Undirected edge `(smaller, larger)` -> how faces use it.
pub struct EdgeMap {
    pub uses: HashMap<(u32, u32), EdgeUses>,
}

impl EdgeMap {
    pub fn of(mesh: &Mesh) -> Self {
        let mut uses: HashMap<(u32, u32), EdgeUses> = HashMap::with_capacity(mesh.corners().len());
        for (f, face) in mesh.faces().enumerate() {
            for i in 0..face.len() {
                let (a, b) = (face[i], face[(i + 1) % face.len()]);
                if a == b {
                    continue;
                }
                let e = uses.entry((a.min(b), a.max(b))).or_insert(EdgeUses { count: 0, faces: [(u32::MAX, false); 2] });
                if e.count < 2 {
                    e.faces[e.count as usize] = (f as u32, a < b);
                }
                e.count += 1;
            }
        }
        Self { uses }
    }
    pub fn count_with(&self, pred: impl Fn(u32) -> bool) -> usize {
        self.uses.values().filter(|e| pred(e.count)).count()
    }
    /// Uses of the undirected edge between `a` and `b`.
    pub fn get(&self, a: u32, b: u32) -> Option<&EdgeUses> {
        self.uses.get(&(a.min(b), a.max(b)))
    }
}

/// Directed boundary edges (used by exactly one face), in the direction that face uses
/// them, sorted for deterministic output.
pub fn boundary_edges(mesh: &Mesh) -> Vec<(u32, u32)> {
    let mut edges: Vec<(u32, u32)> = EdgeMap::of(mesh).uses.iter().filter(|(_, e)| e.count == 1).map(|(&k, e)| e.first_half_edge(k)).collect();
    edges.sort_unstable();
    edges
}

/// The connected parts of a mesh (vertices joined by faces; a loose vertex is a part
/// of its own): the part of each vertex, numbered in order of first vertex, and that
/// first vertex of each part.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Parts {
    pub of: Vec<u32>,
    pub first: Vec<u32>,
    pub count: usize,
}

/// [`Parts`] of `mesh`, by union-find over its faces' vertices.
pub fn vertex_parts(mesh: &Mesh) -> Parts {
    parts_of(mesh.vertex_count(), mesh.faces())
}

/// [`Parts`] of `vertices` vertices joined by `faces` (lists of vertex indices).
pub fn parts_of<'a>(vertices: usize, faces: impl Iterator<Item = &'a [u32]>) -> Parts {
    let mut up: Vec<u32> = (0..vertices as u32).collect();
    fn root(up: &mut [u32], mut v: u32) -> u32 {
        while up[v as usize] != v {
            up[v as usize] = up[up[v as usize] as usize]; // path halving
            v = up[v as usize];
        }
        v
    }
    for face in faces {
        for w in face.windows(2) {
            let (a, b) = (root(&mut up, w[0]), root(&mut up, w[1]));
            if a != b {
                up[a.max(b) as usize] = a.min(b);
            }
        }
    }
    let (mut of, mut first) = (vec![0u32; up.len()], Vec::new());
    for v in 0..up.len() as u32 {
        let r = root(&mut up, v);
        of[v as usize] = if r == v {
            first.push(v);
            first.len() as u32 - 1
        } else {
            of[r as usize]
        };
    }
    Parts { count: first.len(), of, first }
}

/// Faces' windings relative to their neighbours: faces joined through edges of exactly
/// two faces form a patch, and a face's `sign` is +1 where it walks each such edge
/// against its neighbour (consistent winding with the patch's first face) and -1
/// where it had to be reversed to be. A mesh wound consistently has every sign +1; a
/// face wound backwards among its neighbours gets -1. Non-orientable patches keep
/// the first sign each face is reached with.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Windings {
    pub sign: Vec<i8>,
    /// The patch of each face, numbered in order of first face.
    pub patch: Vec<u32>,
    pub patches: usize,
}

/// [`Windings`] of `mesh`'s faces, by a breadth-first walk over its manifold edges.
pub fn face_windings(mesh: &Mesh) -> Windings {
    let faces: Vec<&[u32]> = mesh.faces().collect();
    let edges = EdgeMap::of(mesh);
    let mut sign = vec![0i8; faces.len()];
    let mut patch = vec![u32::MAX; faces.len()];
    let mut patches = 0u32;
    let mut queue = std::collections::VecDeque::new();
    for start in 0..faces.len() {
        if patch[start] != u32::MAX {
            continue;
        }
        (sign[start], patch[start]) = (1, patches);
        queue.push_back(start);
        while let Some(f) = queue.pop_front() {
            let face = faces[f];
            for i in 0..face.len() {
                let (a, b) = (face[i], face[(i + 1) % face.len()]);
                let Some(&EdgeUses { count, faces: [(f0, up0), (f1, up1)] }) = edges.get(a, b) else { continue };
                if count != 2 || f0 == f1 {
                    continue;
                }
                let (g, same_way) = if f0 as usize == f { (f1, up0 == up1) } else { (f0, up0 == up1) };
                let g = g as usize;
                if patch[g] == u32::MAX {
                    // Walking the shared edge the same way means opposite windings.
                    (sign[g], patch[g]) = (if same_way { -sign[f] } else { sign[f] }, patches);
                    queue.push_back(g);
                }
            }
        }
        patches += 1;
    }
    Windings { sign, patch, patches: patches as usize }
}

/// Which items (faces, triangles, cells) use each vertex, in compressed rows.
#[derive(Debug, Clone, Default)]
pub struct Incidence {
    start: Vec<u32>,
    of: Vec<u32>,
}

impl Incidence {
    /// `items` lists each item's vertices (below `n`); item `k` is the `k`-th.
    pub fn new(n: usize, items: impl Iterator<Item = impl IntoIterator<Item = u32>> + Clone) -> Self {
        let mut start = vec![0u32; n + 1];
        for v in items.clone().flatten() {
            start[v as usize + 1] += 1;
        }
        for i in 0..n {
            start[i + 1] += start[i];
        }
        let mut fill = start.clone();
        let mut of = vec![0u32; start[n] as usize];
        for (k, it) in items.enumerate() {
            for v in it {
                of[fill[v as usize] as usize] = k as u32;
                fill[v as usize] += 1;
            }
        }
        Self { start, of }
    }

    /// The faces of `mesh` around each vertex.
    pub fn faces(mesh: &Mesh) -> Self {
        let faces: Vec<&[u32]> = mesh.faces().collect();
        Self::new(mesh.vertex_count(), faces.iter().map(|f| f.iter().copied()))
    }

    /// The items using vertex `v`.
    pub fn of(&self, v: usize) -> &[u32] {
        &self.of[self.start[v] as usize..self.start[v + 1] as usize]
    }
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

    #[test]
    fn incidence_lists_the_faces_around_each_vertex() {
        let cube = fixtures::cube();
        let around = Incidence::faces(&cube);
        for v in 0..8 {
            assert_eq!(around.of(v).len(), 3, "vertex {v}");
            assert!(around.of(v).iter().all(|&f| cube.face(f as usize).contains(&(v as u32))));
        }
    }
    #[test]
    fn windings_find_a_face_wound_backwards_and_separate_patches() {
        let cube = fixtures::cube();
        let w = face_windings(&cube);
        assert_eq!((w.patches, w.sign.iter().all(|&s| s == 1)), (1, true));
        // Face 2 reversed: it alone is -1 (or all the others, were it the first).
        let faces: Vec<Vec<u32>> = cube.faces().enumerate().map(|(f, v)| if f == 2 { v.iter().rev().copied().collect() } else { v.to_vec() }).collect();
        let sizes: Vec<u32> = faces.iter().map(|f| f.len() as u32).collect();
        let flipped = Mesh::new(cube.positions().to_vec(), &sizes, faces.concat(), None).unwrap();
        let w = face_windings(&flipped);
        assert_eq!(w.sign.iter().filter(|&&s| s == -1).count(), 1);
        assert_eq!(w.sign[2], -1);
        // Two cubes: two patches.
        let n = cube.vertex_count() as u32;
        let corners: Vec<u32> = cube.corners().iter().copied().chain(cube.corners().iter().map(|c| c + n)).collect();
        let positions: Vec<_> = cube.positions().iter().copied().chain(cube.positions().iter().map(|p| *p + glam::Vec3::X * 3.0)).collect();
        let sizes = [cube.face_sizes(), cube.face_sizes()].concat();
        let two = Mesh::new(positions, &sizes, corners, None).unwrap();
        let w = face_windings(&two);
        assert_eq!(w.patches, 2);
        assert!(w.patch[..6].iter().all(|&p| p == 0) && w.patch[6..].iter().all(|&p| p == 1));
    }
}
