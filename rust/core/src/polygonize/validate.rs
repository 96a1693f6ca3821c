//! Output validation: what makes a polygonized surface unusable for 3D printing,
//! booleans or remeshing, counted on its triangles alone. The polygonizer's contract
//! is a closed 2-manifold ([`SurfaceCheck::is_closed_manifold`]); its tests and the
//! bake's hold it to that.

use glam::Vec3;
use std::collections::HashMap;

/// Counts of the faults of a triangle mesh.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct SurfaceCheck {
    pub vertices: usize,
    pub triangles: usize,
    /// Edges used by one triangle only.
    pub boundary_edges: usize,
    /// Edges used by more than two triangles.
    pub overused_edges: usize,
    /// Edges that two triangles walk the same way (neighbours facing opposite ways).
    pub misoriented_edges: usize,
    /// Vertices whose triangles form more than one fan (two sheets touching at a point).
    pub pinched_vertices: usize,
    /// Triangles with a repeated vertex or exactly zero area (coincident or collinear
    /// corners in single precision).
    pub degenerate_triangles: usize,
    /// Triangles on the same three vertices as another (either orientation).
    pub duplicate_triangles: usize,
    /// Connected pieces, joined through shared vertices (pieces touching at a point
    /// count as one; [`SurfaceCheck::pinched_vertices`] reports those points).
    pub components: usize,
    /// `V - E + F`: 2 per closed sphere-like piece, 2 - 2g for genus g.
    pub euler_characteristic: i64,
}

impl SurfaceCheck {
    pub fn of(positions: &[Vec3], triangles: &[[u32; 3]]) -> Self {
        let mut check = Self { vertices: positions.len(), triangles: triangles.len(), ..Default::default() };
        // Directed edges: (a, b) -> uses; undirected counts from both directions.
        let mut directed: HashMap<(u32, u32), u32> = HashMap::with_capacity(3 * triangles.len());
        let mut faces: HashMap<[u32; 3], u32> = HashMap::with_capacity(triangles.len());
        for t in triangles {
            let [a, b, c] = t.map(|v| positions[v as usize]);
            if t[0] == t[1] || t[1] == t[2] || t[2] == t[0] || (b - a).cross(c - a).length_squared() == 0.0 {
                check.degenerate_triangles += 1;
            }
            let mut sorted = *t;
            sorted.sort_unstable();
            *faces.entry(sorted).or_default() += 1;
            for k in 0..3 {
                *directed.entry((t[k], t[(k + 1) % 3])).or_default() += 1;
            }
        }
        check.duplicate_triangles = faces.values().map(|&n| n as usize - 1).sum();
        let mut edges = 0usize;
        for (&(a, b), &n) in &directed {
            let back = directed.get(&(b, a)).copied().unwrap_or(0);
            if n > 1 {
                check.misoriented_edges += 1;
            }
            // Each undirected edge once: from its smaller end, or from the only direction used.
            if a < b || back == 0 {
                edges += 1;
                match n + back {
                    1 => check.boundary_edges += 1,
                    2 => {}
                    _ => check.overused_edges += 1,
                }
            }
        }
        check.pinched_vertices = vertex_fans(positions.len(), triangles).iter().filter(|&&f| f > 1).count();
        check.components = components(positions.len(), triangles);
        let used = {
            let mut seen = vec![false; positions.len()];
            triangles.iter().flatten().for_each(|&v| seen[v as usize] = true);
            seen.iter().filter(|s| **s).count()
        };
        check.euler_characteristic = used as i64 - edges as i64 + triangles.len() as i64;
        check
    }

    /// Closed, every edge between exactly two triangles walking it opposite ways, every
    /// vertex one fan, nothing degenerate or duplicated.
    pub fn is_closed_manifold(&self) -> bool {
        self.boundary_edges == 0
            && self.overused_edges == 0
            && self.misoriented_edges == 0
            && self.pinched_vertices == 0
            && self.degenerate_triangles == 0
            && self.duplicate_triangles == 0
    }
}

/// Each vertex's number of fans: the edge-connected pieces of its incident triangles
/// (saturating at 255; 0 for a vertex of no triangle). A vertex inside a manifold
/// surface has one; more where sheets touch at a point (a pinched vertex).
pub(crate) fn vertex_fans(vertices: usize, triangles: &[[u32; 3]]) -> Vec<u8> {
    // Per vertex, its triangles' other two corners; a fan joins triangles that share
    // one of them. Union-find over the corner pairs of each vertex.
    let mut start = vec![0usize; vertices + 1];
    for &v in triangles.iter().flatten() {
        start[v as usize + 1] += 1;
    }
    for i in 0..vertices {
        start[i + 1] += start[i];
    }
    let mut fill = start.clone();
    let mut around = vec![(0u32, 0u32); start[vertices]];
    for t in triangles {
        for k in 0..3 {
            let v = t[k] as usize;
            around[fill[v]] = (t[(k + 1) % 3], t[(k + 2) % 3]);
            fill[v] += 1;
        }
    }
    let mut fans = vec![0u8; vertices];
    let mut parent: Vec<usize> = Vec::new();
    for v in 0..vertices {
        let ring = &around[start[v]..start[v + 1]];
        if ring.len() < 2 {
            fans[v] = ring.len() as u8;
            continue;
        }
        parent.clear();
        parent.extend(0..ring.len());
        fn find(p: &mut [usize], mut i: usize) -> usize {
            while p[i] != i {
                p[i] = p[p[i]];
                i = p[i];
            }
            i
        }
        for i in 0..ring.len() {
            for j in i + 1..ring.len() {
                let (a, b) = (ring[i], ring[j]);
                if a.0 == b.0 || a.0 == b.1 || a.1 == b.0 || a.1 == b.1 {
                    let (x, y) = (find(&mut parent, i), find(&mut parent, j));
                    parent[x] = y;
                }
            }
        }
        let roots = (0..ring.len()).filter(|&i| find(&mut parent, i) == i).count();
        fans[v] = roots.min(255) as u8;
    }
    fans
}

/// Edge-connected pieces of the triangles.
fn components(vertices: usize, triangles: &[[u32; 3]]) -> usize {
    // Triangles sharing a vertex within a manifold share an edge too; joining by
    // vertices counts pieces touching at a point as one, which pinched_vertices reports.
    let mut parent: Vec<u32> = (0..vertices as u32).collect();
    fn find(p: &mut [u32], mut i: u32) -> u32 {
        while p[i as usize] != i {
            p[i as usize] = p[p[i as usize] as usize];
            i = p[i as usize];
        }
        i
    }
    for t in triangles {
        for k in 1..3 {
            let (a, b) = (find(&mut parent, t[0]), find(&mut parent, t[k]));
            parent[a as usize] = b;
        }
    }
    let mut used = vec![false; vertices];
    triangles.iter().flatten().for_each(|&v| used[v as usize] = true);
    (0..vertices as u32).filter(|&v| used[v as usize] && find(&mut parent, v) == v).count()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tetrahedron() -> (Vec<Vec3>, Vec<[u32; 3]>) {
        (vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z], vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]])
    }

    #[test]
    fn a_tetrahedron_is_a_closed_manifold_sphere() {
        let (p, t) = tetrahedron();
        let c = SurfaceCheck::of(&p, &t);
        assert!(c.is_closed_manifold(), "{c:?}");
        assert_eq!((c.components, c.euler_characteristic), (1, 2));
    }

    #[test]
    fn each_fault_is_counted() {
        let (p, t) = tetrahedron();
        // A missing face: three boundary edges.
        let c = SurfaceCheck::of(&p, &t[1..]);
        assert_eq!(c.boundary_edges, 3);
        // A flipped face: its three edges are walked twice the same way.
        let mut flipped = t.clone();
        flipped[0] = [0, 1, 2];
        let c = SurfaceCheck::of(&p, &flipped);
        assert_eq!(c.misoriented_edges, 3);
        // A duplicated face facing the other way: three edges used three times.
        let mut doubled = t.clone();
        doubled.push([0, 1, 2]);
        let c = SurfaceCheck::of(&p, &doubled);
        assert_eq!((c.duplicate_triangles, c.overused_edges), (1, 3));
        // Two tetrahedra sharing one vertex: pinched there, one piece by vertices.
        let mut p2 = p.clone();
        p2.extend([Vec3::new(-1.0, 0.0, 0.0), Vec3::new(0.0, -1.0, 0.0), Vec3::new(0.0, 0.0, -1.0)]);
        let mut t2 = t.clone();
        t2.extend([[0, 4, 5], [0, 5, 6], [0, 6, 4], [4, 6, 5]]);
        let c = SurfaceCheck::of(&p2, &t2);
        assert_eq!(c.pinched_vertices, 1, "{c:?}");
        assert!(!c.is_closed_manifold());
        // A degenerate triangle.
        let c = SurfaceCheck::of(&p, &[[0, 0, 1]]);
        assert_eq!(c.degenerate_triangles, 1);
    }
}
