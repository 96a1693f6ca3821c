//! Quality of a shell, counted: intersections of the outer layer with itself and with
//! the base, inverted cells, and thickness reached against thickness asked for.
//!
//! "Where normal displacement would itself have been valid": a vertex qualifies when,
//! in the normal-offset shell of the same side and target thickness (directors
//! `±target * normal`, envelopes split half/half), (a) no cell around it is inverted,
//! (b) its own director segment does not cross a base triangle away from it, and
//! (c) no outer-layer triangle around it intersects another outer-layer triangle or the
//! base, and (d) its director segment does not cross the outer layer away from it
//! (the slabs of facing surface parts would overlap, as between fins closer than
//! twice the thickness, even where the two outer layers do not intersect). There the field shell is expected to reach (nearly) the full thickness.

use super::defects::Checker;
use super::intersect::TriBvh;
use super::{Shell, Side};
use crate::mesh::vertex_normals;
use crate::Mesh;
use glam::{DVec3, Vec3};
use rayon::prelude::*;

#[derive(Debug, Clone, PartialEq)]
pub struct ShellReport {
    /// Intersecting pairs of skin triangles (the outer layer r = 1, and an envelope's
    /// inner layer r = 0) that share no vertex.
    pub outer_self_intersections: usize,
    /// Intersecting (skin triangle, base triangle) pairs, ignoring pairs that share
    /// a vertex whose skin point coincides with the base point.
    pub outer_base_intersections: usize,
    /// Intersecting pairs of either kind that involve a base triangle which crosses
    /// the base itself (not counted above: inherited from the input).
    pub inherited_intersections: usize,
    /// Pairs of base triangles that cross each other (the input's own).
    pub base_self_intersections: usize,
    /// Vertices (with a positive target and a normal) below 95% of their target.
    pub compressed_vertices: usize,
    /// Cells with a non-positive tetrahedron or whose map folds inside (see
    /// [`Cell::is_inverted`], [`Cell::map_folds`]).
    pub inverted_cells: usize,
    /// Cells enclosing another connected part of the base (a part wholly inside
    /// another part's shell, which crosses none of its skins).
    pub enclosing_cells: usize,
    /// achieved / target over vertices with a positive target and a normal.
    pub min_ratio: f32,
    pub mean_ratio: f32,
    /// Minimum ratio over the vertices where normal displacement would have been valid.
    pub min_ratio_normal_valid: f32,
    /// Number of such vertices, and of vertices considered at all.
    pub normal_valid_vertices: usize,
    pub considered_vertices: usize,
    /// Share of the normal-valid vertices that reach 95% of their target.
    pub normal_valid_at_95: f32,
}

fn dv(p: Vec3) -> DVec3 {
    p.as_dvec3()
}

/// The normal-displacement shell of the same side and targets.
pub fn normal_shell(mesh: &Mesh, side: Side, target: &[f32]) -> Shell {
    normal_shell_from(&vertex_normals(mesh), side, target)
}

/// [`normal_shell`] from the mesh's vertex normals.
fn normal_shell_from(n: &[Vec3], side: Side, target: &[f32]) -> Shell {
    let (base_offset, directors): (Vec<Vec3>, Vec<Vec3>) = target.iter().zip(n).map(|(t, n)| normal_shape(side, *n * t.abs())).unzip();
    let achieved = directors.iter().map(|d| d.length()).collect();
    Shell { side, base_offset, directors, achieved, target: target.iter().map(|t| t.abs()).collect(), check: Default::default() }
}

/// The base offset and director of normal displacement by `d` (normal times thickness).
pub(crate) fn normal_shape(side: Side, d: Vec3) -> (Vec3, Vec3) {
    match side {
        Side::Exterior => (Vec3::ZERO, d),
        Side::Interior => (Vec3::ZERO, -d),
        Side::Envelope => (-d * 0.5, d),
    }
}

/// Vertices where the normal-offset shell of the same side and targets is locally valid.
pub fn normal_valid_vertices(mesh: &Mesh, side: Side, target: &[f32]) -> Vec<bool> {
    normal_valid_with(&Checker::new(mesh), mesh, &vertex_normals(mesh), side, target)
}

fn normal_valid_with(checker: &Checker, mesh: &Mesh, normals: &[Vec3], side: Side, target: &[f32]) -> Vec<bool> {
    let mut valid = vec![false; mesh.vertex_count()];
    let all = (0..mesh.vertex_count() as u32).collect();
    NormalRoom::new(checker, mesh, normals, side, target).among(all, None).into_iter().for_each(|v| valid[v as usize] = true);
    valid
}

/// Asks for any vertices whether normal displacement is valid around them ((a)-(d)
/// above); the normal-offset shell's outer-layer tree is built on first need.
pub(crate) struct NormalRoom<'a> {
    checker: &'a Checker,
    mesh: &'a Mesh,
    pub shell: Shell,
    tree: Option<TriBvh>,
}

impl<'a> NormalRoom<'a> {
    /// `normals` are the mesh's vertex normals.
    pub fn new(checker: &'a Checker, mesh: &'a Mesh, normals: &[Vec3], side: Side, target: &[f32]) -> Self {
        Self { checker, mesh, shell: normal_shell_from(normals, side, target), tree: None }
    }

    /// Those of `vertices` with room. `like` is a tree over the same triangles whose
    /// layout the outer-layer tree may copy (refitting is cheaper than building).
    pub fn among(&mut self, vertices: Vec<u32>, like: Option<&TriBvh>) -> Vec<u32> {
        let (checker, mesh, normal) = (self.checker, self.mesh, &self.shell);
        let p = mesh.positions();
        let segment = |v: u32| (dv(normal.point(p, v as usize, 0.0)), dv(normal.point(p, v as usize, 1.0)));
        // (b) first, one segment per vertex: where parts are closer than the
        // thickness most vertices fail here, before any element around them is
        // checked. Then (a) and the base part of (c) around the survivors: they need
        // no outer-layer tree, and most of the rest that fail, fail there.
        let vertices: Vec<u32> = vertices.into_par_iter().filter(|&v| !checker.segment_crosses(mesh, v, segment(v).0, segment(v).1, None)).collect();
        let mut dirty = checker.clean();
        checker.mark_anew(vertices.iter().copied(), &mut dirty);
        let bad = checker.defect_vertex_list(&checker.find(mesh, normal, Some(&dirty), None));
        let vertices: Vec<u32> = vertices.into_iter().filter(|&v| bad.binary_search(&v).is_err()).collect();
        if vertices.is_empty() {
            return vertices;
        }
        // (d), then (c): the outer layer against the segments, then against itself
        // around the vertices left.
        let tree = &*self.tree.get_or_insert_with(|| checker.outer_tree(mesh, normal, like.cloned()));
        let vertices: Vec<u32> =
            vertices.into_par_iter().filter(|&v| !checker.segment_crosses(mesh, v, segment(v).0, segment(v).1, Some((normal, tree)))).collect();
        // Each triangle once: a vertex's triangles are its neighbours' too.
        let mut tris: Vec<u32> = vertices.iter().flat_map(|&v| checker.tris_of(v as usize)).copied().collect();
        tris.sort_unstable();
        tris.dedup();
        let crossing: Vec<u32> = tris.into_par_iter().filter(|&t| checker.outer_crosses(mesh, normal, t, tree)).collect();
        vertices.into_iter().filter(|&v| !checker.tris_of(v as usize).iter().any(|t| crossing.binary_search(t).is_ok())).collect()
    }
}

/// Counts what is wrong with `shell` and how much thickness it kept. On a base with
/// split seams whose copies share their directors (as shells built here do), on the
/// welded mesh ([`Mesh::weld_coincident`]): a seam is not a crossing, and its
/// vertices count once.
pub fn shell_report(mesh: &Mesh, shell: &Shell) -> ShellReport {
    if let Some((weld, welded)) = mesh.weld_coincident().and_then(|weld| shell.welded(&weld).map(|s| (weld, s))) {
        return shell_report(&weld.mesh, &welded);
    }
    let checker = Checker::new(mesh);
    let f = checker.find(mesh, shell, None, Some(&checker.outer_tree(mesh, shell, None)));
    let mut compressed = 0;
    let normals = vertex_normals(mesh);
    let valid = normal_valid_with(&checker, mesh, &normals, shell.side, &shell.target);
    let (mut min_ratio, mut sum, mut count, mut min_valid, mut n_valid) = (f32::INFINITY, 0.0f64, 0usize, f32::INFINITY, 0);
    let mut valid_at_95 = 0usize;
    for v in 0..mesh.vertex_count() {
        if !(shell.target[v] > 0.0) || normals[v] == Vec3::ZERO {
            continue;
        }
        let r = shell.achieved[v] / shell.target[v];
        compressed += usize::from(r < 0.95);
        min_ratio = min_ratio.min(r);
        sum += r as f64;
        count += 1;
        if valid[v] {
            min_valid = min_valid.min(r);
            n_valid += 1;
            valid_at_95 += usize::from(r >= 0.95);
        }
    }
    ShellReport {
        outer_self_intersections: f.self_pairs.len(),
        outer_base_intersections: f.base_pairs.len(),
        inverted_cells: f.inverted.len(),
        enclosing_cells: f.enclosing.len(),
        inherited_intersections: f.inherited,
        base_self_intersections: checker.base_self_pairs(),
        compressed_vertices: compressed,
        min_ratio: if count > 0 { min_ratio } else { 1.0 },
        mean_ratio: if count > 0 { (sum / count as f64) as f32 } else { 1.0 },
        min_ratio_normal_valid: if n_valid > 0 { min_valid } else { 1.0 },
        normal_valid_vertices: n_valid,
        considered_vertices: count,
        normal_valid_at_95: if n_valid > 0 { valid_at_95 as f32 / n_valid as f32 } else { 1.0 },
    }
}

/// The mesh's own intersections: how many pairs of its triangles (sharing no vertex)
/// cross, and the faces involved (sorted).
pub fn self_intersecting_faces(mesh: &Mesh) -> (usize, Vec<u32>) {
    let checker = Checker::new(mesh);
    (checker.base_self_pairs(), checker.own_faces())
}
