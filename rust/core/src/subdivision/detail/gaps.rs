//! The room the rock has before a vertex meets another part of the base (a thin part's
//! other side, the next card across a narrow gap, a second box a hair away). The berry
//! and the growth models cast a ray per moved vertex; the rock moves every vertex at
//! every level, where a ray per vertex would cost more than the synthesis. Instead the
//! base is measured once: each base vertex's distance to the nearest base triangle of
//! another part (of another connected piece, or facing against the vertex's normal: a
//! thin part's other side, a card across a gap met from either side; the vertex's own
//! triangles never count), searched only within three of its longest edges, beyond which
//! no level's rock could be limited by it (a BVH distance query, [`Bvh::closest`](
//! crate::spatial::Bvh::closest)). Where no base vertex has another part within reach (a
//! torus, a sphere, a comb) nothing more is done and the rock is bit for bit what it was.
//! Otherwise the distances go down the levels with the per-vertex values (a new point
//! takes the least of its parents', [`Least`]), and at level `l` a vertex may move either
//! way along its normal by [`CLEAR_SHARE`] `2^-l` of its distance less twice its longest
//! edge at the level (a face's points stay that close to its vertices, and a new point
//! that close to its parents): a face whose vertices keep within their room never reaches
//! the other part however long it is against the gap, and over all levels a part moves
//! at most [`CLEAR_SHARE`] of the gap towards another. The rock asks at most a quarter of
//! a vertex's shortest edge at level `l` (about `2^-l` of the base's), and the room
//! exceeds that from about 1.6 base edges on: the reach of three keeps the limit
//! continuous.

use super::fold_guard::{Clearance, CLEAR_SHARE};
use super::Carried;
use crate::mesh::{vertex_normals, vertex_parts};
use crate::shell::intersect::point_triangle_distance2;
use crate::Mesh;
use rayon::prelude::*;

/// A distance carried to a finer level as the least of its parents' (a lower bound).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Least(pub f64);

impl Carried for Least {
    fn mean(values: impl Iterator<Item = Self>, _: usize) -> Self {
        Least(values.fold(f64::INFINITY, |a, b| a.min(b.0)))
    }
}

/// Per vertex of the current level: how far another part of the base is at least
/// (infinite where none is within reach).
#[derive(Debug)]
pub(crate) struct Gaps {
    gap: Vec<Least>,
}

impl Gaps {
    /// The distances of `base`'s vertices to other parts within `reach(longest edge at the
    /// vertex)`; `None` when no vertex has one within its reach.
    pub(crate) fn of(base: &Mesh, reach: impl Fn(f64) -> f64 + Sync) -> Option<Gaps> {
        let clearance = Clearance::of(base);
        let triangles = base.triangulate().triangles;
        let piece = vertex_parts(base).of;
        let normals = vertex_normals(base);
        let p = base.positions();
        let longest = longest_edges(base, |_| true);
        let gap: Vec<Least> = (0..p.len())
            .into_par_iter()
            .map(|v| {
                let (q, n) = (p[v].as_dvec3(), normals[v].as_dvec3());
                let other = |t: u32| {
                    let tri = triangles[t as usize];
                    !tri.contains(&(v as u32)) && (piece[tri[0] as usize] != piece[v] || clearance.normal(t).dot(n) < 0.0)
                };
                let near = clearance.bvh().closest(q, reach(longest[v]), |t| match other(t) {
                    true => point_triangle_distance2(q, clearance.triangle(t)).sqrt(),
                    false => f64::INFINITY,
                });
                Least(near.map_or(f64::INFINITY, |(_, d)| d))
            })
            .collect();
        gap.iter().any(|g| g.0.is_finite()).then(|| Gaps { gap })
    }

    /// Each vertex's distance to another part less twice its longest edge in `mesh` (0 at
    /// least; infinite where there is none).
    fn clear(&self, mesh: &Mesh) -> Vec<f64> {
        let longest = longest_edges(mesh, |v| self.gap[v].0.is_finite());
        self.gap.par_iter().zip(&longest).map(|(g, e)| (g.0 - 2.0 * e).max(0.0)).collect()
    }

    /// The rock's room at level `level` (both ways along the normal).
    pub(crate) fn rock_room(&self, level: u32, mesh: &Mesh) -> Vec<f64> {
        let share = CLEAR_SHARE * 0.5f64.powi(level as i32);
        self.clear(mesh).into_iter().map(|c| share * c).collect()
    }

    /// Carries the distances to `parent`'s child level.
    pub(super) fn carry(&mut self, parent: &super::Level) {
        self.gap = super::carried(parent, &self.gap);
    }
}

/// The longest edge at each vertex of `mesh`, measured at the ends of the edges one of
/// whose ends `wanted` picks (0 at the others).
fn longest_edges(mesh: &Mesh, wanted: impl Fn(usize) -> bool) -> Vec<f64> {
    let p = mesh.positions();
    let mut longest = vec![0.0f64; p.len()];
    for face in mesh.faces() {
        for (i, &a) in face.iter().enumerate() {
            let (a, b) = (a as usize, face[(i + 1) % face.len()] as usize);
            if wanted(a) || wanted(b) {
                let e = p[a].distance(p[b]) as f64;
                longest[a] = longest[a].max(e);
                longest[b] = longest[b].max(e);
            }
        }
    }
    longest
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hard_meshes::{self, self_intersections};
    use crate::subdivision::detail::{procedural_detail, synthesize, Model, State};
    use crate::testmeshes;

    #[test]
    fn the_rock_crosses_no_other_part() {
        // Thin parts and narrow gaps under half an edge, where the rock at 0.03 of the
        // diagonal crossed itself (2 levels: blade 190 pairs, touching boxes 667, 300
        // cards 1,000 and more): none left, and the guard reports what it reduced. The
        // models' own check is the float64 triangle test; the Python tests repeat it with
        // Blender's BVH overlap.
        for (name, base) in [("blade", hard_meshes::blade()), ("touching cubes", hard_meshes::touching_cubes()), ("cards", hard_meshes::cards(300, 3))] {
            assert_eq!(self_intersections(&base), 0, "{name}");
            let rock = Model::Rock { amplitude: 0.03 * base.bbox_diagonal() as f64 };
            let synthesized = crate::subdivision::recipe::synthesize(&base, 2, &crate::subdivision::recipe::Recipe::of(rock, 0)).unwrap();
            assert_eq!(self_intersections(&synthesized.detailed.mesh), 0, "{name}");
            assert!(synthesized.tally.limited > 0, "{name}");
            // The rock still moves the vertices away from the gaps.
            let plain = procedural_detail(&base, 2, &Model::Rock { amplitude: 0.0 }, 0).unwrap().mesh;
            let moved = plain.positions().iter().zip(synthesized.detailed.mesh.positions()).filter(|(a, b)| a.distance(**b) > 1e-6).count();
            assert!(moved > plain.vertex_count() / 3, "{name}: {moved} of {} moved", plain.vertex_count());
        }
    }

    #[test]
    fn distances_are_the_nearest_other_parts_by_brute_force() {
        // Each base vertex's gap against every triangle of the base: the nearest one of
        // another piece or facing against the vertex's normal, not the vertex's own,
        // within the reach; infinite beyond it.
        let base = hard_meshes::touching_cubes();
        let reach = 0.3;
        let gaps = Gaps::of(&base, |_| reach).expect("the boxes are 0.3% of the diagonal apart");
        let triangles = base.triangulate().triangles;
        let piece = vertex_parts(&base).of;
        assert_eq!(vertex_parts(&base).count, 2);
        let (p, normals) = (base.positions(), vertex_normals(&base));
        let corners = |t: &[u32; 3]| t.map(|v| p[v as usize].as_dvec3());
        let mut finite = 0;
        for v in 0..p.len() {
            let want = triangles
                .iter()
                .filter(|t| !t.contains(&(v as u32)))
                .filter(|t| {
                    let c = corners(t);
                    piece[t[0] as usize] != piece[v] || (c[1] - c[0]).cross(c[2] - c[0]).dot(normals[v].as_dvec3()) < 0.0
                })
                .map(|t| point_triangle_distance2(p[v].as_dvec3(), &corners(t)).sqrt())
                .fold(f64::INFINITY, f64::min);
            let want = if want < reach { want } else { f64::INFINITY };
            assert!(gaps.gap[v].0 == want || (gaps.gap[v].0 - want).abs() < 1e-12, "vertex {v}: {} against {want}", gaps.gap[v].0);
            finite += want.is_finite() as usize;
        }
        assert!(finite > 0 && finite < p.len());
    }

    #[test]
    fn meshes_without_close_parts_are_not_measured_further() {
        // No base vertex of a sphere or a torus has another part within three edges: the
        // rock there is exactly the unguarded one (nothing computed).
        for (name, base) in [("sphere", testmeshes::icosphere(3)), ("torus", torus())] {
            assert!(Gaps::of(&base, |edge| 3.0 * edge).is_none(), "{name}");
            let d = base.bbox_diagonal() as f64;
            let rock = Model::Rock { amplitude: 0.02 * d };
            let guarded = procedural_detail(&base, 2, &rock, 3).unwrap();
            let unguarded = synthesize(&base, 2, State::default(), |level, mesh, normals, state| rock.displacements(level, mesh, normals, 3, state)).unwrap();
            assert_eq!(guarded.mesh, unguarded.mesh, "{name}");
        }
        assert!(Gaps::of(&hard_meshes::blade(), |edge| 3.0 * edge).is_some());
    }

    /// A torus of 100 x 60 quads, tube radius 0.3 about a unit circle.
    fn torus() -> Mesh {
        let (major, minor) = (100u32, 60u32);
        let mut p = Vec::new();
        for i in 0..major {
            let u = i as f32 / major as f32 * std::f32::consts::TAU;
            for j in 0..minor {
                let v = j as f32 / minor as f32 * std::f32::consts::TAU;
                let r = 1.0 + 0.3 * v.cos();
                p.push(glam::Vec3::new(r * u.cos(), r * u.sin(), 0.3 * v.sin()));
            }
        }
        let at = |i: u32, j: u32| (i % major) * minor + j % minor;
        let corners: Vec<u32> = (0..major).flat_map(|i| (0..minor).flat_map(move |j| [at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)])).collect();
        Mesh::new(p, &vec![4; (major * minor) as usize], corners, None).unwrap()
    }
}
