//! Triangulation view of a polygon mesh: n-gons split as Blender splits them
//! ([`super::polyfill`]: ear clipping in the face's plane, concave ones correctly).
//! A quad folded onto its neighbour (two faces sharing three vertices, as on
//! Suzanne's chin) is split along its other diagonal when its first split would
//! repeat the neighbour's triangle: a repeated triangle is a cell of zero volume
//! whose shell and bake pieces would weld onto the neighbour's, using edges four times.

use super::Mesh;
use glam::Vec3;
use std::collections::HashMap;

/// Triangles of a mesh, each remembering the face it came from.
#[derive(Debug, Clone, Default)]
pub struct Triangulation {
    pub triangles: Vec<[u32; 3]>,
    pub face_of_triangle: Vec<u32>,
}

impl Triangulation {
    pub fn of(mesh: &Mesh) -> Self {
        let mut out = Self { triangles: Vec::with_capacity(mesh.corners().len().saturating_sub(2 * mesh.face_count())), face_of_triangle: Vec::new() };
        for (f, face) in mesh.faces().enumerate() {
            let before = out.triangles.len();
            face_triangles(mesh.positions(), face, &mut out.triangles);
            out.face_of_triangle.extend(std::iter::repeat_n(f as u32, out.triangles.len() - before));
        }
        out.split_folded_quads(mesh);
        out
    }

    /// Re-splits quads whose triangle repeats another face's triangle (the same three
    /// vertices) along their other diagonal, where that repeats nothing: one quad of
    /// a folded pair is enough, so a quad is re-split only while its triangle is still
    /// repeated.
    fn split_folded_quads(&mut self, mesh: &Mesh) {
        let key = |t: &[u32; 3]| {
            let mut k = *t;
            k.sort_unstable();
            k
        };
        let mut uses: HashMap<[u32; 3], u32> = HashMap::with_capacity(self.triangles.len());
        for t in &self.triangles {
            *uses.entry(key(t)).or_default() += 1;
        }
        if uses.values().all(|&n| n == 1) {
            return;
        }
        // Where each face's triangles start (a face of k corners has k - 2).
        let mut start = 0;
        for f in 0..mesh.face_count() {
            let q = mesh.face(f);
            let at = start;
            start += q.len().saturating_sub(2);
            if q.len() != 4 {
                continue;
            }
            let now = [self.triangles[at], self.triangles[at + 1]];
            if now.iter().all(|t| uses[&key(t)] == 1) {
                continue;
            }
            let other = if now[0][0] == q[0] { [[q[1], q[2], q[3]], [q[1], q[3], q[0]]] } else { [[q[0], q[1], q[2]], [q[0], q[2], q[3]]] };
            if other.iter().any(|t| uses.contains_key(&key(t))) {
                continue;
            }
            for t in &now {
                *uses.get_mut(&key(t)).expect("counted") -= 1;
            }
            for (k, t) in other.into_iter().enumerate() {
                uses.insert(key(&t), 1);
                self.triangles[at + k] = t;
            }
        }
    }
}

/// Appends the triangles of one face (always `face.len() - 2` of them).
pub fn face_triangles(p: &[Vec3], face: &[u32], out: &mut Vec<[u32; 3]>) {
    match face.len() {
        0..=2 => {}
        3 => out.push([face[0], face[1], face[2]]),
        4 => out.extend(split_quad(p, face)),
        _ => super::polyfill::split(p, face, out),
    }
}

/// Splits a quad along the diagonal that keeps both halves consistently oriented
/// (the shorter diagonal when both do).
fn split_quad(p: &[Vec3], q: &[u32]) -> [[u32; 3]; 2] {
    let [a, b, c, d] = [q[0], q[1], q[2], q[3]].map(|i| p[i as usize]);
    let n = newell_normal(&[a, b, c, d]);
    let ok_ac = (b - a).cross(c - a).dot(n) > 0.0 && (c - a).cross(d - a).dot(n) > 0.0;
    let ok_bd = (c - b).cross(d - b).dot(n) > 0.0 && (d - b).cross(a - b).dot(n) > 0.0;
    let use_ac = match (ok_ac, ok_bd) {
        (true, false) => true,
        (false, true) => false,
        _ => (c - a).length_squared() <= (d - b).length_squared(),
    };
    if use_ac {
        [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]
    } else {
        [[q[1], q[2], q[3]], [q[1], q[3], q[0]]]
    }
}

pub fn newell_normal(pts: &[Vec3]) -> Vec3 {
    let mut n = Vec3::ZERO;
    for i in 0..pts.len() {
        let (a, b) = (pts[i], pts[(i + 1) % pts.len()]);
        n += Vec3::new((a.y - b.y) * (a.z + b.z), (a.z - b.z) * (a.x + b.x), (a.x - b.x) * (a.y + b.y));
    }
    n
}

#[cfg(test)]
mod tests {
    use super::*;

    fn area(p: &[Vec3], t: &[[u32; 3]], n: Vec3) -> f32 {
        t.iter().map(|t| 0.5 * (p[t[1] as usize] - p[t[0] as usize]).cross(p[t[2] as usize] - p[t[0] as usize]).dot(n)).sum()
    }

    #[test]
    fn concave_ngon_keeps_area_and_orientation() {
        // An L-shaped hexagon of area 3 in the xy plane.
        let p: Vec<Vec3> = [[0., 0.], [2., 0.], [2., 1.], [1., 1.], [1., 2.], [0., 2.]].iter().map(|a| Vec3::new(a[0], a[1], 0.)).collect();
        let m = Mesh::new(p.clone(), &[6], (0..6).collect(), None).unwrap();
        let t = m.triangulate();
        assert_eq!(t.triangles.len(), 4);
        assert!((area(&p, &t.triangles, Vec3::Z) - 3.0).abs() < 1e-5);
        for tri in &t.triangles {
            assert!(area(&p, &[*tri], Vec3::Z) > 0.0, "triangle {tri:?} flipped");
        }
    }

    #[test]
    fn a_quad_folded_onto_its_neighbour_repeats_no_triangle() {
        // Suzanne's chin: two quads sharing vertices 0, 1 and 2, folded onto each other
        // with opposite normals; both splits run 1-2, repeating triangle 0-1-2.
        let p = vec![
            Vec3::new(0.0, -0.75, -0.195),
            Vec3::new(0.0, -0.797, -0.188),
            Vec3::new(0.0, -0.742, -0.141),
            Vec3::new(0.039, -0.781, -0.125),
            Vec3::new(-0.039, -0.781, -0.125),
        ];
        let m = Mesh::new(p, &[4, 4], vec![0, 1, 3, 2, 4, 1, 0, 2], None).unwrap();
        let t = m.triangulate();
        let mut keys: Vec<[u32; 3]> = t
            .triangles
            .iter()
            .map(|t| {
                let mut k = *t;
                k.sort_unstable();
                k
            })
            .collect();
        keys.sort_unstable();
        keys.dedup();
        assert_eq!(keys.len(), 4, "{:?}", t.triangles);
        assert_eq!(t.face_of_triangle, vec![0, 0, 1, 1]);
        // One quad of the pair is re-split; the other keeps the split chosen for it.
        let mut first = Vec::new();
        for f in 0..2 {
            super::face_triangles(m.positions(), m.face(f), &mut first);
        }
        let changed = (0..2).filter(|&f| t.triangles[2 * f..2 * f + 2] != first[2 * f..2 * f + 2]).count();
        assert_eq!(changed, 1, "{:?} from {first:?}", t.triangles);
        // Each face's triangles still cover exactly its own corners.
        for f in 0..2 {
            let mut used: Vec<u32> = t.triangles[2 * f..2 * f + 2].iter().flatten().copied().collect();
            used.sort_unstable();
            used.dedup();
            let mut corners = m.face(f).to_vec();
            corners.sort_unstable();
            assert_eq!(used, corners);
        }
    }

    #[test]
    fn quads_map_back_to_faces() {
        let m = crate::mesh::fixtures::cube();
        let t = m.triangulate();
        assert_eq!(t.triangles.len(), 12);
        assert_eq!(t.face_of_triangle, vec![0, 0, 1, 1, 2, 2, 3, 3, 4, 4, 5, 5]);
    }
}
