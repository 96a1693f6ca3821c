//! Vertices at exactly the same position, welded into one.
//!
//! Exports split vertices along UV, normal and patch seams (OBJ, FBX and glTF files
//! do; the Utah teapot in common test sets is 16 Bezier patches with 403 coincident
//! vertices). Algorithms that follow the surface (the shell's field, its checks)
//! would see each seam as two open boundaries facing each other at zero distance and
//! press the shell flat along it. Welding only bit-equal positions is exact: no two
//! distinct points are ever merged, so the welded mesh is the same surface.

use super::Mesh;
use glam::Vec3;
use rayon::prelude::*;

/// A mesh with its coincident vertices welded, and the way back.
#[derive(Debug, Clone)]
pub struct Weld {
    /// The welded mesh: one vertex per distinct position, in order of first use. Its
    /// faces lose corners repeated in a row (a quad with two corners on one point is
    /// a triangle); faces left with fewer than three corners, or with a corner
    /// repeated apart, have no area to speak of and are left out.
    pub mesh: Mesh,
    /// `of[v]`: the welded vertex of original vertex `v`.
    pub of: Vec<u32>,
}

impl Mesh {
    /// The mesh with vertices at bit-equal positions welded, or `None` when no two
    /// vertices share a position (the common case costs a sort, no copy). Only seams
    /// are welded: a group of copies whose welding would use an edge more than twice
    /// or twice the same way (windings that disagree across the seam), or put two
    /// faces on one set of vertices (a double-sided export, a mesh copied onto
    /// itself), stays split, as given.
    pub fn weld_coincident(&self) -> Option<Weld> {
        let key = |p: Vec3| p.to_array().map(|c| if c == 0.0 { 0 } else { c.to_bits() }); // -0.0 is 0.0
        let mut order: Vec<u32> = (0..self.vertex_count() as u32).collect();
        order.par_sort_unstable_by_key(|&v| (key(self.positions[v as usize]), v));
        // `lead[v]`: the lowest index at `v`'s position (the first of its group in the sort).
        let mut lead: Vec<u32> = (0..self.vertex_count() as u32).collect();
        let mut any = false;
        for pair in order.windows(2) {
            let (a, b) = (pair[0] as usize, pair[1] as usize);
            if key(self.positions[a]) == key(self.positions[b]) {
                lead[b] = lead[a];
                any = true;
            }
        }
        if !any {
            return None;
        }
        let faulty = self.weld_faults(&lead);
        let mut welded = false;
        for v in 0..lead.len() {
            if faulty[lead[v] as usize] {
                lead[v] = v as u32;
            }
            welded |= lead[v] != v as u32;
        }
        if !welded {
            return None;
        }
        // Welded vertices keep the order of their lead.
        let mut of = vec![0u32; self.vertex_count()];
        let mut positions = Vec::new();
        for v in 0..self.vertex_count() {
            of[v] = if lead[v] == v as u32 {
                positions.push(self.positions[v]);
                (positions.len() - 1) as u32
            } else {
                of[lead[v] as usize]
            };
        }
        let mut sizes = Vec::with_capacity(self.face_count());
        let mut corners = Vec::with_capacity(self.corners.len());
        let mut face = Vec::new();
        for f in self.faces() {
            if welded_face(f, &of, &mut face) {
                sizes.push(face.len() as u32);
                corners.extend_from_slice(&face);
            }
        }
        let mesh = Mesh::new(positions, &sizes, corners, None).expect("welding keeps indices in range and faces of 3 or more corners");
        Some(Weld { mesh, of })
    }
}

impl Mesh {
    /// Per lead vertex, whether welding every group to its lead (`lead`, see
    /// [`Mesh::weld_coincident`]) would make an edge at it used more than twice or
    /// twice the same way, or a face on the same vertices as another.
    fn weld_faults(&self, lead: &[u32]) -> Vec<bool> {
        let mut faulty = vec![false; lead.len()];
        let (mut edges, mut sets, mut face) = (Vec::new(), Vec::new(), Vec::new());
        for f in self.faces() {
            if welded_face(f, lead, &mut face) {
                edges.extend((0..face.len()).map(|i| (face[i], face[(i + 1) % face.len()])));
                let mut set = face.clone();
                set.sort_unstable();
                sets.push(set);
            }
        }
        edges.par_sort_unstable_by_key(|&(a, b)| (a.min(b), a.max(b), a));
        for run in edges.chunk_by(|x, y| (x.0.min(x.1), x.0.max(x.1)) == (y.0.min(y.1), y.0.max(y.1))) {
            if run.len() > 2 || run.windows(2).any(|w| w[0] == w[1]) {
                run.iter().for_each(|&(a, b)| (faulty[a as usize], faulty[b as usize]) = (true, true));
            }
        }
        sets.par_sort_unstable();
        for run in sets.chunk_by(|x, y| x == y).filter(|run| run.len() > 1) {
            run[0].iter().for_each(|&v| faulty[v as usize] = true);
        }
        faulty
    }
}

/// Face `f`'s corners through `map` into `out`, repeats in a row dropped; false when
/// fewer than three corners remain or one repeats apart (no area to speak of).
fn welded_face(f: &[u32], map: &[u32], out: &mut Vec<u32>) -> bool {
    out.clear();
    out.extend(f.iter().map(|&v| map[v as usize]));
    out.dedup();
    while out.len() > 1 && out.first() == out.last() {
        out.pop();
    }
    out.len() >= 3 && (0..out.len()).all(|i| !out[i + 1..].contains(&out[i]))
}

impl Weld {
    /// Per-vertex values of the original mesh on the welded one: for each welded
    /// vertex, the value of smallest magnitude among its originals (a thickness
    /// asked for differently on two sides of a seam gets the smaller).
    pub fn least<T: Copy + PartialOrd + Default + std::ops::Neg<Output = T>>(&self, values: &[T]) -> Vec<T> {
        let magnitude = |x: T| if x < T::default() { -x } else { x };
        let mut out: Vec<Option<T>> = vec![None; self.mesh.vertex_count()];
        for (v, &x) in values.iter().enumerate() {
            let slot = &mut out[self.of[v] as usize];
            if slot.is_none_or(|y| magnitude(x) < magnitude(y)) {
                *slot = Some(x);
            }
        }
        out.into_iter().map(|x| x.unwrap_or_default()).collect()
    }

    /// Positions of the original mesh moved to `positions`, on the welded mesh;
    /// `None` when vertices that were welded no longer share a position.
    pub fn positions(&self, positions: &[Vec3]) -> Option<Vec<Vec3>> {
        let mut out: Vec<Option<Vec3>> = vec![None; self.mesh.vertex_count()];
        for (v, &p) in positions.iter().enumerate() {
            match &mut out[self.of[v] as usize] {
                slot @ None => *slot = Some(p),
                Some(q) if *q == p => {}
                Some(_) => return None,
            }
        }
        Some(out.into_iter().map(|p| p.unwrap_or(Vec3::ZERO)).collect())
    }

    /// Per-vertex values of the welded mesh, given back to every original vertex.
    pub fn expand<T: Copy>(&self, values: &[T]) -> Vec<T> {
        self.of.iter().map(|&w| values[w as usize]).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two unit quads side by side, the shared edge's vertices given twice.
    fn split_pair() -> Mesh {
        let p = |x: f32, y: f32| Vec3::new(x, y, 0.0);
        let positions = vec![p(0.0, 0.0), p(1.0, 0.0), p(1.0, 1.0), p(0.0, 1.0), p(1.0, 0.0), p(2.0, 0.0), p(2.0, 1.0), p(1.0, 1.0)];
        Mesh::new(positions, &[4, 4], vec![0, 1, 2, 3, 4, 5, 6, 7], None).unwrap()
    }

    #[test]
    fn coincident_vertices_become_one_and_faces_keep_their_corners() {
        let weld = split_pair().weld_coincident().expect("two pairs coincide");
        assert_eq!(weld.mesh.vertex_count(), 6);
        assert_eq!(weld.of, vec![0, 1, 2, 3, 1, 4, 5, 2]);
        assert_eq!(weld.mesh.corners(), &[0, 1, 2, 3, 1, 4, 5, 2]);
        for (v, &w) in weld.of.iter().enumerate() {
            assert_eq!(weld.mesh.positions()[w as usize], split_pair().positions()[v]);
        }
        // The shared edge is now used by both faces: the seam is gone.
        let interior = crate::mesh::boundary_edges(&weld.mesh).len();
        assert_eq!((interior, crate::mesh::boundary_edges(&split_pair()).len()), (6, 8));
    }

    #[test]
    fn distinct_positions_are_never_merged_and_signed_zero_is_one_point() {
        assert!(crate::mesh::fixtures::cube().weld_coincident().is_none());
        let nudged = |d: f32| {
            let mut m = split_pair();
            m.set_position(4, Vec3::new(1.0 + d, 0.0, 0.0)).unwrap();
            m.set_position(7, Vec3::new(1.0 + d, 1.0, 0.0)).unwrap();
            m
        };
        assert!(nudged(f32::EPSILON).weld_coincident().is_none(), "one ulp apart stays apart");
        let mut m = nudged(0.0);
        m.set_position(0, Vec3::new(-0.0, 0.0, 0.0)).unwrap();
        m.set_position(3, Vec3::new(0.0, 1.0, -0.0)).unwrap();
        let mut extra = m.positions().to_vec();
        extra.push(Vec3::ZERO);
        let with_zero = Mesh::new(extra, &[4, 4, 3], vec![0, 1, 2, 3, 4, 5, 6, 7, 8, 6, 5], None).unwrap();
        let weld = with_zero.weld_coincident().unwrap();
        assert_eq!(weld.of[8], weld.of[0], "-0.0 and 0.0 are one point");
    }

    #[test]
    fn faces_that_lose_their_area_are_left_out_and_repeats_in_a_row_dropped() {
        let p = |x: f32, y: f32| Vec3::new(x, y, 0.0);
        // A quad whose last corner is a copy of its first (a triangle), and a triangle
        // with two corners on one point (no area).
        let positions = vec![p(0.0, 0.0), p(1.0, 0.0), p(0.0, 1.0), p(0.0, 0.0), p(1.0, 0.0), p(1.0, 0.0)];
        let mesh = Mesh::new(positions, &[4, 3], vec![0, 1, 2, 3, 4, 5, 2], None).unwrap();
        let weld = mesh.weld_coincident().unwrap();
        assert_eq!(weld.mesh.face_sizes(), vec![3]);
        assert_eq!(weld.mesh.corners(), &[0, 1, 2]);
    }

    #[test]
    fn copies_are_welded_only_where_they_make_a_seam() {
        // A double-sided card: the back faces reversed, on their own copies.
        let card = split_pair();
        let n = card.vertex_count() as u32;
        let mut positions = card.positions().to_vec();
        positions.extend_from_slice(card.positions());
        let mut corners = card.corners().to_vec();
        corners.extend(card.corners().chunks(4).flat_map(|q| q.iter().rev().map(|&v| v + n).collect::<Vec<_>>()));
        let two_sided = Mesh::new(positions, &[4; 4], corners, None).unwrap();
        assert!(two_sided.weld_coincident().is_none(), "front and back would stack their faces: left as given");
        // Windings that disagree across the seam: left split.
        let flipped = Mesh::new(split_pair().positions().to_vec(), &[4, 4], vec![0, 1, 2, 3, 7, 6, 5, 4], None).unwrap();
        assert!(flipped.weld_coincident().is_none());
        // A third face on the seam's edge: an edge of three faces, left split.
        let mut p = split_pair().positions().to_vec();
        p.extend([Vec3::new(1.0, 0.0, 0.0), Vec3::new(1.0, 1.0, 0.0), Vec3::new(1.0, 1.0, 1.0), Vec3::new(1.0, 0.0, 1.0)]);
        let fin = Mesh::new(p, &[4, 4, 4], vec![0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11], None).unwrap();
        assert!(fin.weld_coincident().is_none());
    }

    #[test]
    fn values_take_the_least_magnitude_and_come_back_per_original_vertex() {
        let weld = split_pair().weld_coincident().unwrap();
        let thickness = [1.0f32, 0.5, -0.25, 1.0, -0.3, 1.0, 1.0, 2.0];
        let welded = weld.least(&thickness);
        assert_eq!(welded, vec![1.0, -0.3, -0.25, 1.0, 1.0, 1.0]);
        assert_eq!(weld.expand(&welded), vec![1.0, -0.3, -0.25, 1.0, -0.3, 1.0, 1.0, -0.25]);
        let mut moved = split_pair().positions().to_vec();
        moved[1].z = 0.5;
        assert!(weld.positions(&moved).is_none(), "a welded pair pulled apart");
        moved[4].z = 0.5;
        assert_eq!(weld.positions(&moved).unwrap()[1], Vec3::new(1.0, 0.0, 0.5));
    }
}
