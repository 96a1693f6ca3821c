//! Incremental shell update after local edits (section 7.1): the field is local
//! (4.3.1), so after moving some vertices only the directors whose support — the
//! points their trajectory evaluated, widened by the localization radius — reaches a
//! changed triangle are traced again. The patch tree is refitted, not rebuilt.

use super::directors::{
    assemble, check_inputs, integration_triangles, min_edges, side_lengths, trace_vertices, Trace, Tracer,
    REPAIR_FACTOR,
};
use super::{Shell, ShellParams, Side};
use crate::mesh::vertex_normals;
use crate::{Mesh, Result};
use glam::{DVec3, Vec3};
use rayon::prelude::*;

/// A shell kept up to date while its base mesh is edited.
pub struct IncrementalShell {
    mesh: Mesh,
    thickness: Vec<f32>,
    lengths: Vec<f32>,
    side: Side,
    params: ShellParams,
    tracer: Tracer,
    tris: Vec<[DVec3; 3]>,
    traces: Vec<(Trace, Trace)>,
    shell: Shell,
}

impl IncrementalShell {
    pub fn new(mesh: Mesh, thickness: Vec<f32>, side: Side, params: ShellParams) -> Result<Self> {
        check_inputs(&mesh, &thickness, &params)?;
        let lengths = side_lengths(&thickness, side);
        let tracer = Tracer::new(&mesh, &lengths, &params);
        let tris = integration_triangles(&mesh, &tracer.normals, &lengths, &params);
        let all: Vec<u32> = (0..mesh.vertex_count() as u32).collect();
        let traces = trace_vertices(&tracer, &mesh, &lengths, side, &params, &all);
        let mut shell = assemble(&mesh, &thickness, side, &traces);
        super::repair::untangle(&mesh, &mut shell, params.repair_rounds, REPAIR_FACTOR);
        Ok(Self { mesh, thickness, lengths, side, params, tracer, tris, traces, shell })
    }

    pub fn shell(&self) -> &Shell {
        &self.shell
    }
    pub fn mesh(&self) -> &Mesh {
        &self.mesh
    }

    /// Moves vertices to new positions and updates the shell; returns how many
    /// vertices were traced again.
    pub fn move_vertices(&mut self, moved: &[(u32, Vec3)]) -> Result<usize> {
        for &(v, p) in moved {
            self.mesh.set_position(v as usize, p)?;
        }
        // Normals and first steps change around the moved vertices only, but are cheap
        // to recompute in full.
        self.tracer.normals = vertex_normals(&self.mesh);
        self.tracer.min_edge = min_edges(&self.mesh);
        let tris = integration_triangles(&self.mesh, &self.tracer.normals, &self.lengths, &self.params);
        // Changed triangles: bounding spheres of their old and new shapes.
        let mut spheres: Vec<(DVec3, f64)> = Vec::new();
        for (old, new) in self.tris.iter().zip(&tris) {
            if old != new {
                for t in [old, new] {
                    let c = (t[0] + t[1] + t[2]) / 3.0;
                    spheres.push((c, t.iter().map(|p| (*p - c).length()).fold(0.0, f64::max)));
                }
            }
        }
        if tris.len() != self.tris.len() {
            // Topology of the extension changed (cannot happen when only positions
            // move); fall back to a full rebuild.
            *self = Self::new(self.mesh.clone(), self.thickness.clone(), self.side, self.params.clone())?;
            return Ok(self.mesh.vertex_count());
        }
        self.tracer.tree.refit(&tris);
        self.tris = tris;
        if spheres.is_empty() {
            return Ok(0);
        }
        // Vertices whose support may touch a changed triangle, or whose own normal moved.
        let (lo, hi) = spheres.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(l, h), (c, r)| (l.min(*c - *r), h.max(*c + *r)));
        let support = self.params.support;
        let p = self.mesh.positions();
        let lengths = &self.lengths;
        let dirty: Vec<u32> = (0..p.len() as u32)
            .into_par_iter()
            .filter(|&v| {
                let v = v as usize;
                let (o, i) = &self.traces[v];
                let reach = support * lengths[v] as f64 + 1e-6;
                let hit = |t: &Trace| {
                    let c = t.center.as_dvec3();
                    let r = t.radius as f64 + reach;
                    if c.cmplt(lo - r).any() || c.cmpgt(hi + r).any() {
                        return false;
                    }
                    spheres.iter().any(|(sc, sr)| (c - *sc).length() <= r + sr)
                };
                // A moved vertex itself, or one whose starting point lies in a changed triangle's sphere.
                hit(o) || hit(i) || spheres.iter().any(|(sc, sr)| (p[v].as_dvec3() - *sc).length() <= *sr)
            })
            .collect();
        let fresh = trace_vertices(&self.tracer, &self.mesh, &self.lengths, self.side, &self.params, &dirty);
        for (&v, t) in dirty.iter().zip(fresh) {
            self.traces[v as usize] = t;
        }
        // Retraced directors start unrepaired; the others keep their repair, and the
        // repair pass starts from the cells and triangles around the retraced ones.
        let fresh_shell = assemble(&self.mesh, &self.thickness, self.side, &self.traces);
        for &v in &dirty {
            let v = v as usize;
            self.shell.base_offset[v] = fresh_shell.base_offset[v];
            self.shell.directors[v] = fresh_shell.directors[v];
            self.shell.achieved[v] = fresh_shell.achieved[v];
        }
        super::repair::untangle_around(&self.mesh, &mut self.shell, self.params.repair_rounds, REPAIR_FACTOR, Some(&dirty));
        Ok(dirty.len())
    }
}
