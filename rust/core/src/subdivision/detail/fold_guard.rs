//! How far a level's detail may move each vertex along its normal without folding the
//! surface. Two limits, both from the level's mesh before its detail:
//! - Focal distance: moving a surface by `d` along its normals keeps it a local
//!   embedding while `d` stays under the radius of curvature on the side it moves to
//!   (past it, offsets of a concave region cross over themselves; the normal part of a
//!   varying offset's gradient cannot fold it). Curvature is measured per edge as
//!   `k = (n_a - n_b) . (p_a - p_b) / |p_a - p_b|^2` (positive where the surface bends
//!   away from its normals), and a vertex may move out by [`FOCAL_SHARE`] / (largest
//!   `-k` at it) and in by [`FOCAL_SHARE`] / (largest `k`). A sharp concave crease
//!   (`k` about 1/edge) allows about half an edge.
//! - Edge length, for per-vertex random detail (the rock): at most [`FOLD_SLOPE`] times
//!   the vertex's shortest edge, so neighbours differ by a slope under 1/2 and the level
//!   makes no spikes where the mesh is finer than the detail (a dense scan, a UV sphere's
//!   poles). The limit halves with the edges from level to level, so a capped rock still
//!   falls as 1/f.
//!
//! - Clearance, for domes: level `l`'s domes rise at most [`CLEAR_SHARE`] `2^-l` of the
//!   distance along their normals to another part of the base (a thin part's other
//!   side, the next card across a narrow gap), measured from where the level's vertex is;
//!   over all levels a part rises at most [`CLEAR_SHARE`] of the gap, so two parts
//!   rising towards each other close at most 0.8 of it. Rays go from the level's
//!   vertices to the base's triangles, counting only a part met from its front, so the
//!   vertex's own stretch of base, which the smoothed level lies just inside of, never
//!   counts. The rock's random detail is not cast for (a ray per vertex at every level
//!   would cost more than the synthesis): its room from other parts comes from distances
//!   measured once on the base ([`super::gaps`], set by [`Limits::near`]).

use crate::shell::lp_distance::mesh_triangles;
use crate::spatial::{ray_triangle, Bvh};
use crate::Mesh;
use glam::{DVec3, Vec3};
use rayon::prelude::*;

/// The share of the radius of curvature a vertex may move towards its focal point.
pub const FOCAL_SHARE: f64 = 0.5;
/// The share of the distance to another part of the base domes may rise over all levels.
pub const CLEAR_SHARE: f64 = 0.4;

/// The share of its shortest edge a vertex's random detail may move it.
pub const FOLD_SLOPE: f64 = 0.25;

/// The base surface, for how far a vertex may move before it meets another part of it.
#[derive(Debug)]
pub(crate) struct Clearance {
    triangles: Vec<[DVec3; 3]>,
    normals: Vec<DVec3>,
    bvh: Bvh,
    reach: f64,
}

impl Clearance {
    pub(crate) fn of(base: &Mesh) -> Self {
        let triangles = mesh_triangles(base);
        let normals = triangles.iter().map(|t| (t[1] - t[0]).cross(t[2] - t[0]).normalize_or_zero()).collect();
        let bvh = Bvh::from_triangles(&triangles);
        Self { triangles, normals, bvh, reach: base.bbox_diagonal() as f64 }
    }

    /// The distance from `o` along the unit `dir` (a vertex's normal) to the first base
    /// triangle met from its front; `reach` (the base's diagonal) when there is none.
    fn along(&self, o: DVec3, dir: DVec3) -> f64 {
        let mut best = self.reach;
        self.bvh.query_segment(o, o + dir * self.reach, |t| {
            if self.normals[t as usize].dot(dir) < 0.0 {
                if let Some(h) = ray_triangle(o, dir, &self.triangles[t as usize]) {
                    best = best.min(h);
                }
            }
        });
        best
    }
}

/// How much of a model's detail the guard reduced, over all levels: vertices given
/// detail, and those of them whose detail was made smaller.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct Tally {
    pub placed: u64,
    pub limited: u64,
    /// Those of them whose detail lost more than [`SHRUNK_SHARE`] of its size.
    pub shrunk: u64,
}

/// The loss of size above which a reduced vertex counts as visibly shrunk: a dome kept
/// at 95% of its height reads as the dome asked for, one halved does not.
pub const SHRUNK_SHARE: f64 = 0.1;

/// The size of a vertex's detail, for [`Tally`].
pub(crate) trait Size {
    fn size(&self) -> f64;
}

impl Size for f64 {
    fn size(&self) -> f64 {
        self.abs()
    }
}

impl Size for DVec3 {
    fn size(&self) -> f64 {
        self.length()
    }
}

impl Tally {
    /// Counts one level's detail once per vertex, however many guards acted on it:
    /// `full[v]` what the model asked of vertex `v`, `kept[v]` what the guards left (placed
    /// where `full` is not zero, limited where `kept` differs from it, shrunk where it is
    /// under `1 - SHRUNK_SHARE` of its size).
    pub(crate) fn count<T: PartialEq + Default + Size + Copy + Sync>(&mut self, full: &[T], kept: &[T]) {
        self.count_with(full.len(), |v| (full[v], kept[v]));
    }

    /// [`Tally::count`] of the pairs (asked, kept) `at(v)` of vertices `0..n`.
    pub(crate) fn count_with<T: PartialEq + Default + Size>(&mut self, n: usize, at: impl Fn(usize) -> (T, T) + Sync) {
        let (placed, limited, shrunk) = (0..n)
            .into_par_iter()
            .map(|v| {
                let (full, kept) = at(v);
                let placed = full != T::default();
                let shrunk = placed && kept.size() < (1.0 - SHRUNK_SHARE) * full.size();
                (placed as u64, (placed && kept != full) as u64, shrunk as u64)
            })
            .reduce(|| (0, 0, 0), |a, b| (a.0 + b.0, a.1 + b.1, a.2 + b.2));
        self.add(Tally { placed, limited, shrunk });
    }

    /// Adds `other`'s counts (a blend's second model, another level).
    pub fn add(&mut self, other: Tally) {
        self.placed += other.placed;
        self.limited += other.limited;
        self.shrunk += other.shrunk;
    }

    /// The share of placed detail that was limited (0 when none was placed).
    pub fn share(&self) -> f64 {
        if self.placed == 0 {
            0.0
        } else {
            self.limited as f64 / self.placed as f64
        }
    }

    /// The share of placed detail that was visibly shrunk (0 when none was placed).
    pub fn shrunk_share(&self) -> f64 {
        if self.placed == 0 {
            0.0
        } else {
            self.shrunk as f64 / self.placed as f64
        }
    }
}

/// [`FOCAL_SHARE`] of the radius of curvature `1 / k` (none where the surface does not bend
/// that way).
fn reach(k: f64) -> f64 {
    if k > 0.0 {
        FOCAL_SHARE / k
    } else {
        f64::INFINITY
    }
}

/// Per vertex: how far it may move out (along its normal), how far in, and its shortest
/// edge, kept as one record of the curvatures and length they come from (read by
/// [`Limits::out`], [`Limits::inward`], [`Limits::shortest`]: no array per limit).
pub(crate) struct Limits {
    /// The largest curvature bending away from (k > 0) and towards (k < 0) the normal, and
    /// the shortest edge squared.
    at: Vec<[f64; 3]>,
    /// Outward limits [`Limits::clear_of`] lowered (empty until then).
    room: Vec<f64>,
    /// Limits both ways from the distance to other parts ([`Limits::near`]; empty for none).
    near: Vec<f64>,
}

impl Limits {
    /// The limits of every vertex of `mesh` (vertex normals `normals`): one pass over the
    /// faces' edges into one record per vertex (one cache line for both ends of an edge,
    /// not three; a parallel pass gathering per-corner records was slower on 2 busy cores).
    pub(crate) fn of(mesh: &Mesh, normals: &[Vec3]) -> Self {
        let p = mesh.positions();
        let mut at = vec![[0.0f64, 0.0, f64::INFINITY]; p.len()];
        for face in mesh.faces() {
            for (i, &a) in face.iter().enumerate() {
                let b = face[if i + 1 == face.len() { 0 } else { i + 1 }];
                let (a, b) = (a as usize, b as usize);
                let e = (p[a] - p[b]).as_dvec3();
                let length2 = e.length_squared();
                if length2 == 0.0 {
                    continue;
                }
                let k = (normals[a] - normals[b]).as_dvec3().dot(e) / length2;
                for v in [a, b] {
                    let r = &mut at[v];
                    *r = [r[0].max(k), r[1].max(-k), r[2].min(length2)];
                }
            }
        }
        Self { at, room: Vec::new(), near: Vec::new() }
    }

    /// How far vertex `v` may move out along its normal: [`FOCAL_SHARE`] of its radius of
    /// curvature towards that side, and its room from [`Limits::clear_of`].
    pub(crate) fn out(&self, v: usize) -> f64 {
        let focal = reach(self.at[v][1]);
        let focal = self.near.get(v).map_or(focal, |&r| focal.min(r));
        self.room.get(v).map_or(focal, |&r| focal.min(r))
    }

    /// How far vertex `v` may move in.
    pub(crate) fn inward(&self, v: usize) -> f64 {
        let focal = reach(self.at[v][0]);
        self.near.get(v).map_or(focal, |&r| focal.min(r))
    }

    /// Lowers both limits of every vertex to `room` (from [`super::gaps::Gaps`]).
    pub(crate) fn near(&mut self, room: Vec<f64>) {
        self.near = room;
    }

    /// Vertex `v`'s shortest edge (infinite when it has none of nonzero length).
    pub(crate) fn shortest(&self, v: usize) -> f64 {
        self.at[v][2].sqrt()
    }

    /// `d` (along vertex `v`'s normal) within what `v` may move.
    pub(crate) fn clamp(&self, v: usize, d: f64) -> f64 {
        d.clamp(-self.inward(v), self.out(v))
    }

    /// Lowers the outward limit of every vertex `rises` picks to level `level`'s share,
    /// [`CLEAR_SHARE`] `2^-level`, of its distance out to another part of the base.
    pub(crate) fn clear_of(&mut self, clearance: &Clearance, level: u32, p: &[Vec3], normals: &[Vec3], rises: impl Fn(usize) -> bool + Sync) {
        let share = CLEAR_SHARE * 0.5f64.powi(level as i32);
        let room: Vec<f64> = (0..p.len())
            .into_par_iter()
            .map(|v| match rises(v) {
                true => share * clearance.along(p[v].as_dvec3(), normals[v].as_dvec3()),
                false => f64::INFINITY,
            })
            .collect();
        match self.room.is_empty() {
            true => self.room = room,
            false => self.room.iter_mut().zip(room).for_each(|(o, r)| *o = o.min(r)),
        }
    }

    /// Random detail of `size(v)` times `unit(v)` (in [-1, 1]) at every vertex, each at
    /// most [`FOLD_SLOPE`] times its shortest edge and within its curvature limits.
    pub(crate) fn random(&self, size: impl Fn(usize) -> f64 + Sync, unit: impl Fn(usize) -> f64 + Sync, tally: &mut Tally) -> Vec<f64> {
        let wanted = |v: usize| size(v).abs().min(self.random_reach(v)).copysign(size(v));
        let out: Vec<f64> = (0..self.at.len()).into_par_iter().map(|v| self.clamp(v, wanted(v) * unit(v))).collect();
        tally.count_with(out.len(), |v| (size(v) * unit(v), out[v]));
        out
    }

    /// The largest random detail vertex `v` may take: [`FOLD_SLOPE`] times its shortest
    /// edge.
    fn random_reach(&self, v: usize) -> f64 {
        FOLD_SLOPE * self.shortest(v)
    }
}

/// Scales groups of vertices moved together (a berry dome, a growth seed's pull) each as a
/// whole by the least factor any of its members needs, `need(v)` (at most 1): a group too
/// large for its place is made smaller, never cut into a plateau whose step would fold.
/// `group[v]` is the group of vertex `v`, `u32::MAX` for none. Returns each group's factor
/// (the counting is [`Tally::count`]'s, once per level).
pub(crate) fn scale_groups(group: &[u32], need: impl Fn(usize) -> f64 + Sync) -> Vec<f64> {
    let groups = group.iter().filter(|&&g| g != u32::MAX).map(|&g| g as usize + 1).max().unwrap_or(0);
    let needs: Vec<(u32, f64)> = group.par_iter().enumerate().filter(|(_, &g)| g != u32::MAX).map(|(v, &g)| (g, need(v))).filter(|&(_, f)| f < 1.0).collect();
    let mut factor = vec![1.0f64; groups];
    for (g, f) in needs {
        let x = &mut factor[g as usize];
        *x = x.min(f);
    }
    factor
}

impl Clearance {
    /// The base's triangles' tree, triangle `t` and its unit normal (for [`super::gaps`]).
    pub(crate) fn bvh(&self) -> &Bvh {
        &self.bvh
    }
    pub(crate) fn triangle(&self, t: u32) -> &[DVec3; 3] {
        &self.triangles[t as usize]
    }
    pub(crate) fn normal(&self, t: u32) -> DVec3 {
        self.normals[t as usize]
    }

    /// The distance from `o` along the unit `dir` to the first base triangle met from
    /// its front, for the growth models' offsets (see `growth_guard`).
    pub(crate) fn distance_along(&self, o: DVec3, dir: DVec3) -> f64 {
        self.along(o, dir)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::vertex_normals;
    use crate::testmeshes;

    #[test]
    fn a_sphere_lets_its_vertices_in_by_about_half_its_radius_and_out_freely() {
        // A sphere of radius 2: k = 1/2 on every edge (bending away from the outward
        // normals), so a vertex may move in by FOCAL_SHARE * 2 and out without limit
        // (within 5%: angle-weighted vertex normals are not exactly radial).
        let mut sphere = testmeshes::icosphere(3);
        let scaled: Vec<Vec3> = sphere.positions().iter().map(|p| p.normalize() * 2.0).collect();
        sphere = Mesh::new(scaled, &sphere.face_sizes(), sphere.corners().to_vec(), None).unwrap();
        let limits = Limits::of(&sphere, &vertex_normals(&sphere));
        for v in 0..sphere.vertex_count() {
            assert!(limits.out(v).is_infinite(), "vertex {v}: out {}", limits.out(v));
            let expected = FOCAL_SHARE * 2.0;
            assert!((limits.inward(v) - expected).abs() < 0.05 * expected, "vertex {v}: in {}", limits.inward(v));
        }
        // Seen from inside (normals flipped), the same sphere is concave: out is limited.
        let flipped: Vec<Vec3> = vertex_normals(&sphere).iter().map(|n| -*n).collect();
        let inside = Limits::of(&sphere, &flipped);
        assert!((0..sphere.vertex_count()).all(|v| inside.inward(v).is_infinite() && (inside.out(v) - FOCAL_SHARE * 2.0).abs() < 0.05));
        assert_eq!(limits.clamp(0, 10.0), 10.0);
        assert!((limits.clamp(0, -10.0) + limits.inward(0)).abs() < 1e-12);
    }
}
