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
use std::collections::HashMap;

/// A position as welding compares it: its bits, -0.0 taken as 0.0 (equal keys, the
/// same point).
pub(crate) fn position_key(p: Vec3) -> [u32; 3] {
    p.to_array().map(|c| if c == 0.0 { 0 } else { c.to_bits() })
}

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
        let key = position_key;
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

    /// Per welded vertex, its first original vertex (the lowest index at its position).
    pub fn leads(&self) -> Vec<u32> {
        let mut leads = vec![u32::MAX; self.mesh.vertex_count()];
        for (v, &w) in self.of.iter().enumerate() {
            if leads[w as usize] == u32::MAX {
                leads[w as usize] = v as u32;
            }
        }
        leads
    }

    /// Whether `same(v, lead)` holds for every original vertex `v` and the lead of its
    /// welded vertex ([`Weld::leads`]): whether per-vertex values agree across seams.
    pub fn copies_agree(&self, leads: &[u32], same: impl Fn(usize, usize) -> bool) -> bool {
        self.of.iter().enumerate().all(|(v, &w)| same(v, leads[w as usize] as usize))
    }
}

/// How many vertices lie at each position ([`position_key`]). Welding depends only
/// on which vertices share a position, so an edit changes the seams only where a
/// moved vertex shared its position before or shares its new one: that is read from
/// the moved vertices alone, without sorting them all again.
#[derive(Debug, Clone, Default)]
pub(crate) struct Crowding {
    count: HashMap<[u32; 3], u32>,
}

impl Crowding {
    pub fn new(positions: &[Vec3]) -> Self {
        let mut count = HashMap::with_capacity(positions.len());
        positions.iter().for_each(|&p| *count.entry(position_key(p)).or_insert(0) += 1);
        Self { count }
    }

    /// Whether every vertex moved `from -> to` (all of an edit's moves, each vertex
    /// once) is alone at its position before and after the edit: then no seam is
    /// made, parted or changed. False does not mean the seams changed (a seam moved
    /// whole keeps its copies together), only that welding must look again.
    pub fn moves_alone(&self, moves: &[(Vec3, Vec3)]) -> bool {
        let before = |p: Vec3| self.count.get(&position_key(p)).copied().unwrap_or(0);
        if moves.iter().any(|&(from, _)| before(from) != 1) {
            return false;
        }
        let mut after: HashMap<[u32; 3], i64> = HashMap::with_capacity(2 * moves.len());
        for &(from, to) in moves {
            *after.entry(position_key(from)).or_insert(before(from) as i64) -= 1;
            *after.entry(position_key(to)).or_insert(before(to) as i64) += 1;
        }
        moves.iter().all(|&(_, to)| after[&position_key(to)] == 1)
    }

    /// Takes an edit's moves (as [`Crowding::moves_alone`]) into the counts.
    pub fn apply(&mut self, moves: &[(Vec3, Vec3)]) {
        for &(from, to) in moves {
            let key = position_key(from);
            match self.count.get_mut(&key) {
                Some(n) if *n > 1 => *n -= 1,
                _ => {
                    self.count.remove(&key);
                }
            }
            *self.count.entry(position_key(to)).or_insert(0) += 1;
        }
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

    #[test]
    fn leads_are_each_groups_first_vertex_and_copies_agree_only_when_equal() {
        let weld = split_pair().weld_coincident().unwrap();
        assert_eq!(weld.leads(), vec![0, 1, 2, 3, 5, 6]);
        let mut value = [0.0f32, 1.0, 2.0, 3.0, 1.0, 5.0, 6.0, 2.0];
        assert!(weld.copies_agree(&weld.leads(), |v, lead| value[v] == value[lead]));
        value[7] = 2.5;
        assert!(!weld.copies_agree(&weld.leads(), |v, lead| value[v] == value[lead]));
    }

    /// `moves_alone` against its definition: every moved vertex alone at its
    /// position before the edit, and after it, by brute force over all positions.
    #[test]
    fn crowding_sees_seams_made_parted_or_moved_from_the_moves_alone() {
        let before = split_pair().positions().to_vec();
        let crowding = Crowding::new(&before);
        let alone = |p: &[Vec3], v: usize| p.iter().filter(|&&q| position_key(q) == position_key(p[v])).count() == 1;
        let check = |edit: &[(usize, Vec3)]| {
            let mut after = before.clone();
            edit.iter().for_each(|&(v, p)| after[v] = p);
            let moves: Vec<(Vec3, Vec3)> = edit.iter().map(|&(v, p)| (before[v], p)).collect();
            let expected = edit.iter().all(|&(v, _)| alone(&before, v) && alone(&after, v));
            assert_eq!(crowding.moves_alone(&moves), expected, "{edit:?}");
            let mut applied = crowding.clone();
            applied.apply(&moves);
            let fresh = Crowding::new(&after);
            assert_eq!(applied.count, fresh.count, "{edit:?}");
            expected
        };
        let (far, z) = (Vec3::new(5.0, 5.0, 5.0), Vec3::Z);
        assert!(check(&[(0, far)]), "a lone vertex moved into the open");
        assert!(!check(&[(1, far)]), "a seam's copy pulled off");
        assert!(!check(&[(1, before[1] + z), (4, before[4] + z)]), "a seam moved whole: welding looks again");
        assert!(!check(&[(0, before[5])]), "a lone vertex moved onto another");
        assert!(check(&[(0, before[5]), (5, far)]), "onto a position its owner left in the same edit");
        assert!(check(&[(0, before[3]), (3, before[0])]), "two lone vertices swapped");
        assert!(check(&[(0, far), (3, far + Vec3::X)]), "two lone vertices moved apart");
        assert!(!check(&[(0, far), (3, far)]), "two lone vertices moved onto one point");
        assert!(!check(&[(0, Vec3::new(0.0, 0.0, -0.0)), (3, Vec3::new(-0.0, 0.0, 0.0))]), "-0.0 is 0.0");
    }
}
