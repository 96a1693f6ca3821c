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
use super::intersect::segment_crosses_triangle;
use super::{Shell, Side};
use crate::mesh::vertex_normals;
use crate::Mesh;
use glam::{DVec3, Vec3};
use rayon::prelude::*;

#[derive(Debug, Clone, PartialEq)]
pub struct ShellReport {
    /// Intersecting pairs of outer-layer (r = 1) triangles that share no vertex.
    pub outer_self_intersections: usize,
    /// Intersecting (outer-layer triangle, base triangle) pairs, ignoring pairs that
    /// share a vertex whose outer point coincides with the base point.
    pub outer_base_intersections: usize,
    /// Cells with a non-positive tetrahedron (see [`Cell::is_inverted`]).
    pub inverted_cells: usize,
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
    let n = vertex_normals(mesh);
    let (mut base_offset, mut directors) = (Vec::new(), Vec::new());
    for (v, t) in target.iter().enumerate() {
        let d = n[v] * t.abs();
        match side {
            Side::Exterior => (base_offset.push(Vec3::ZERO), directors.push(d)),
            Side::Interior => (base_offset.push(Vec3::ZERO), directors.push(-d)),
            Side::Envelope => (base_offset.push(-d * 0.5), directors.push(d)),
        };
    }
    let achieved = directors.iter().map(|d| d.length()).collect();
    Shell { side, base_offset, directors, achieved, target: target.iter().map(|t| t.abs()).collect() }
}

/// Vertices where the normal-offset shell of the same side and targets is locally valid.
pub fn normal_valid_vertices(mesh: &Mesh, side: Side, target: &[f32]) -> Vec<bool> {
    normal_valid_with(&Checker::new(mesh), mesh, side, target)
}

fn normal_valid_with(checker: &Checker, mesh: &Mesh, side: Side, target: &[f32]) -> Vec<bool> {
    let shell = normal_shell(mesh, side, target);
    let outer_bvh = checker.outer_tree(mesh, &shell, None);
    let f = checker.find(mesh, &shell, None, &outer_bvh);
    let p = mesh.positions();
    let bad = checker.defect_vertices(&f, p.len());
    // (b), (d): the vertex's own segment crossing the base or the outer layer away from it.
    let outer: Vec<[DVec3; 3]> = checker.tris.iter().map(|t| t.map(|i| dv(shell.point(p, i as usize, 1.0)))).collect();
    (0..p.len())
        .into_par_iter()
        .map(|v| {
            let (a, b) = (dv(shell.point(p, v, 0.0)), dv(shell.point(p, v, 1.0)));
            let mut hit = bad[v];
            for (tree, tris) in [(&checker.base_bvh, &checker.base), (&outer_bvh, &outer)] {
                tree.query(a.min(b), a.max(b), |j| {
                    let t = &checker.tris[j as usize];
                    if !t.contains(&(v as u32)) && segment_crosses_triangle(a, b, &tris[j as usize]) {
                        hit = true;
                    }
                });
            }
            !hit
        })
        .collect()
}

/// Counts what is wrong with `shell` and how much thickness it kept.
pub fn shell_report(mesh: &Mesh, shell: &Shell) -> ShellReport {
    let checker = Checker::new(mesh);
    let f = checker.find(mesh, shell, None, &checker.outer_tree(mesh, shell, None));
    let valid = normal_valid_with(&checker, mesh, shell.side, &shell.target);
    let normals = vertex_normals(mesh);
    let (mut min_ratio, mut sum, mut count, mut min_valid, mut n_valid) = (f32::INFINITY, 0.0f64, 0usize, f32::INFINITY, 0);
    let mut valid_at_95 = 0usize;
    for v in 0..mesh.vertex_count() {
        if !(shell.target[v] > 0.0) || normals[v] == Vec3::ZERO {
            continue;
        }
        let r = shell.achieved[v] / shell.target[v];
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
        min_ratio: if count > 0 { min_ratio } else { 1.0 },
        mean_ratio: if count > 0 { (sum / count as f64) as f32 } else { 1.0 },
        min_ratio_normal_valid: if n_valid > 0 { min_valid } else { 1.0 },
        normal_valid_vertices: n_valid,
        considered_vertices: count,
        normal_valid_at_95: if n_valid > 0 { valid_at_95 as f32 / n_valid as f32 } else { 1.0 },
    }
}
