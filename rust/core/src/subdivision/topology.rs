//! One subdivision level's connectivity: numbered edges and the faces on each side, built by
//! sorting once for the base mesh and derived directly (no hashing) for every finer level.

use crate::mesh::parts_of;
use crate::{Error, Mesh, Result};
use glam::DVec3;
use rayon::prelude::*;

/// No face on this side of an edge (a boundary edge has one face).
pub(super) const NONE: u32 = u32::MAX;

pub(super) struct Level {
    pub positions: Vec<DVec3>,
    pub offsets: Vec<u32>,
    pub corners: Vec<u32>,
    /// The face of each corner.
    pub corner_face: Vec<u32>,
    /// The edge from each corner to the next one of its face.
    pub corner_edge: Vec<u32>,
    pub edges: Vec<[u32; 2]>,
    /// The one or two faces of each edge ([`NONE`] second on a boundary).
    pub edge_faces: Vec<[u32; 2]>,
}

impl Level {
    /// The base level of `mesh`, refusing what Catmull-Clark cannot subdivide: faces that
    /// repeat a vertex, edges of more than two faces or of two faces wound against each other
    /// (OpenSubdiv, and so Blender, makes those edges non-manifold boundaries), vertices
    /// whose faces form more than one fan, vertices of no face.
    pub fn base(mesh: &Mesh) -> Result<Self> {
        if let Some((f, v)) = mesh.faces().enumerate().find_map(|(f, face)| repeated(face).map(|v| (f, v))) {
            return Err(Error::InvalidMesh(format!("face {f} uses vertex {v} more than once; merge or dissolve it before subdividing")));
        }
        let mut offsets = vec![0u32];
        offsets.extend(mesh.faces().scan(0, |end, face| {
            *end += face.len() as u32;
            Some(*end)
        }));
        let corners = mesh.corners().to_vec();
        let corner_face: Vec<u32> = mesh.faces().enumerate().flat_map(|(f, face)| std::iter::repeat_n(f as u32, face.len())).collect();
        let next = |c: usize| if c + 1 == offsets[corner_face[c] as usize + 1] as usize { offsets[corner_face[c] as usize] as usize } else { c + 1 };
        let mut keyed: Vec<(u32, u32, u32)> = (0..corners.len())
            .map(|c| {
                let (a, b) = (corners[c], corners[next(c)]);
                (a.min(b), a.max(b), c as u32)
            })
            .collect();
        keyed.par_sort_unstable();
        let (mut edges, mut corner_edge) = (Vec::with_capacity(corners.len() / 2 + 1), vec![0u32; corners.len()]);
        // Corner pairs that meet across an edge, at its two ends: they join one fan.
        let mut joined: Vec<[u32; 2]> = Vec::with_capacity(corners.len());
        for group in keyed.chunk_by(|x, y| (x.0, x.1) == (y.0, y.1)) {
            let (a, b) = (group[0].0, group[0].1);
            if group.len() > 2 {
                return Err(Error::InvalidMesh(format!(
                    "edge {a}-{b} is shared by {} faces; Catmull-Clark needs at most two faces per edge (non-manifold)",
                    group.len()
                )));
            }
            for &(_, _, c) in group {
                corner_edge[c as usize] = edges.len() as u32;
            }
            if let [(_, _, c), (_, _, d)] = *group {
                if corners[c as usize] == corners[d as usize] {
                    let (f, g) = (corner_face[c as usize], corner_face[d as usize]);
                    return Err(Error::InvalidMesh(format!(
                        "faces {f} and {g} run along edge {a}-{b} the same way, so their normals disagree (non-manifold for subdivision); recalculate normals before subdividing"
                    )));
                }
                // The corner of each face at each end of the edge.
                let at = |c: u32, v: u32| if corners[c as usize] == v { c } else { next(c as usize) as u32 };
                joined.push([at(c, a), at(d, a)]);
                joined.push([at(c, b), at(d, b)]);
            }
            edges.push([a, b]);
        }
        let fans = parts_of(corners.len(), joined.iter().map(|j| &j[..]));
        let mut fans_at = vec![0u32; mesh.vertex_count()];
        for &c in &fans.first {
            fans_at[corners[c as usize] as usize] += 1;
        }
        if let Some(v) = fans_at.iter().position(|&n| n != 1) {
            return Err(Error::InvalidMesh(if fans_at[v] == 0 {
                format!("vertex {v} belongs to no face; delete loose vertices before subdividing")
            } else {
                format!("the faces around vertex {v} form {} separate fans (non-manifold vertex); split it before subdividing", fans_at[v])
            }));
        }
        let edge_faces = edge_faces(edges.len(), &corner_edge, &corner_face);
        let positions = mesh.positions().iter().map(|p| p.as_dvec3()).collect();
        Ok(Self { positions, offsets, corners, corner_face, corner_edge, edges, edge_faces })
    }

    pub fn face_count(&self) -> usize {
        self.offsets.len() - 1
    }

    pub fn face(&self, f: usize) -> &[u32] {
        &self.corners[self.offsets[f] as usize..self.offsets[f + 1] as usize]
    }

    /// The corner after `c` in its face.
    pub fn next(&self, c: usize) -> usize {
        let f = self.corner_face[c] as usize;
        if c + 1 == self.offsets[f + 1] as usize {
            self.offsets[f] as usize
        } else {
            c + 1
        }
    }

    /// The corner before `c` in its face.
    pub fn prev(&self, c: usize) -> usize {
        let f = self.corner_face[c] as usize;
        if c == self.offsets[f] as usize {
            self.offsets[f + 1] as usize - 1
        } else {
            c - 1
        }
    }

    /// The next level's connectivity with `positions` (vertex points, then one edge point per
    /// edge, then one face point per face): corner `c` at vertex v of face f becomes quad `c`,
    /// (v, edge point after v, face point, edge point before v); edge e splits into child edges
    /// 2e (from its first end) and 2e + 1, and corner c adds the edge 2E + c from the edge
    /// point after it to the face point.
    pub fn child(&self, positions: Vec<DVec3>) -> Level {
        let (nv, ne) = (self.positions.len() as u32, self.edges.len() as u32);
        let half_at = |e: u32, v: u32| if self.edges[e as usize][0] == v { 2 * e } else { 2 * e + 1 };
        let (quads, quad_edges): (Vec<[u32; 4]>, Vec<[u32; 4]>) = (0..self.corners.len())
            .into_par_iter()
            .map(|c| {
                let (p, v) = (self.prev(c), self.corners[c]);
                let (after, before) = (self.corner_edge[c], self.corner_edge[p]);
                let face_point = nv + ne + self.corner_face[c];
                ([v, nv + after, face_point, nv + before], [half_at(after, v), 2 * ne + c as u32, 2 * ne + p as u32, half_at(before, v)])
            })
            .unzip();
        let mut edges: Vec<[u32; 2]> = self.edges.iter().enumerate().flat_map(|(e, &[a, b])| [[a, nv + e as u32], [nv + e as u32, b]]).collect();
        edges.extend((0..self.corners.len()).map(|c| [nv + self.corner_edge[c], nv + ne + self.corner_face[c]]));
        let corner_edge = quad_edges.into_flattened();
        let corner_face: Vec<u32> = (0..corner_edge.len() as u32).map(|c| c / 4).collect();
        let edge_faces = edge_faces(edges.len(), &corner_edge, &corner_face);
        let offsets = (0..=quads.len() as u32).map(|f| 4 * f).collect();
        Level { positions, offsets, corners: quads.into_flattened(), corner_face, corner_edge, edges, edge_faces }
    }
}

impl Level {
    /// [`Level::child`] with the edges numbered as [`Level::base`] numbers those of the
    /// child mesh (sorted by their (lower, higher) vertex), derived without sorting: first
    /// each vertex's halves of its edges in edge order (vertex by vertex), then each edge
    /// point's edges to the face points of its faces (edge by edge, faces in order). Its
    /// vertices are numbered as the child mesh's, so it is the level [`Level::base`] gives
    /// for that mesh, without the checks the base mesh has passed.
    pub fn child_as_base(&self, positions: Vec<DVec3>) -> Level {
        let (nv, ne) = (self.positions.len(), self.edges.len());
        // Group A: the half of edge e at its end k is edge `half[e][k]`.
        let mut start = vec![0u32; nv + 1];
        for &[a, b] in &self.edges {
            start[a as usize + 1] += 1;
            start[b as usize + 1] += 1;
        }
        for v in 0..nv {
            start[v + 1] += start[v];
        }
        let mut half = vec![[0u32; 2]; ne];
        for (e, &[a, b]) in self.edges.iter().enumerate() {
            half[e] = [start[a as usize], start[b as usize]];
            start[a as usize] += 1;
            start[b as usize] += 1;
        }
        drop(start);
        // Group B: the edges from edge point e to its faces' points start at `to_face[e]`.
        let mut to_face = Vec::with_capacity(ne);
        let mut next = 2 * ne as u32;
        for &[_, f1] in &self.edge_faces {
            to_face.push(next);
            next += 1 + (f1 != NONE) as u32;
        }
        let (nv32, ne32) = (nv as u32, ne as u32);
        let mut edges = vec![[0u32; 2]; next as usize];
        for (e, &[a, b]) in self.edges.iter().enumerate() {
            edges[half[e][0] as usize] = [a, nv32 + e as u32];
            edges[half[e][1] as usize] = [b, nv32 + e as u32];
            let [f0, f1] = self.edge_faces[e];
            let first = if f1 == NONE { f0 } else { f0.min(f1) };
            edges[to_face[e] as usize] = [nv32 + e as u32, nv32 + ne32 + first];
            if f1 != NONE {
                edges[to_face[e] as usize + 1] = [nv32 + e as u32, nv32 + ne32 + f0.max(f1)];
            }
        }
        let half_at = |e: u32, v: u32| half[e as usize][(self.edges[e as usize][0] != v) as usize];
        let face_edge = |e: u32, f: u32| {
            let [f0, f1] = self.edge_faces[e as usize];
            to_face[e as usize] + (f1 != NONE && f == f0.max(f1)) as u32
        };
        let (quads, quad_edges): (Vec<[u32; 4]>, Vec<[u32; 4]>) = (0..self.corners.len())
            .into_par_iter()
            .map(|c| {
                let (p, v, f) = (self.prev(c), self.corners[c], self.corner_face[c]);
                let (after, before) = (self.corner_edge[c], self.corner_edge[p]);
                ([v, nv32 + after, nv32 + ne32 + f, nv32 + before], [half_at(after, v), face_edge(after, f), face_edge(before, f), half_at(before, v)])
            })
            .unzip();
        let corner_edge = quad_edges.into_flattened();
        let corner_face: Vec<u32> = (0..corner_edge.len() as u32).map(|c| c / 4).collect();
        let edge_faces = edge_faces(edges.len(), &corner_edge, &corner_face);
        let offsets = (0..=quads.len() as u32).map(|f| 4 * f).collect();
        Level { positions, offsets, corners: quads.into_flattened(), corner_face, corner_edge, edges, edge_faces }
    }

    /// The next level's connectivity alone ([`Level::child`] with every position at the
    /// origin): what face-varying data refines on.
    pub fn child_topology(&self) -> Level {
        let n = self.positions.len() + self.edges.len() + self.face_count();
        self.child(vec![DVec3::ZERO; n])
    }
}

/// The faces on each side of each edge, from the edge and face of each corner.
fn edge_faces(edges: usize, corner_edge: &[u32], corner_face: &[u32]) -> Vec<[u32; 2]> {
    let mut sides = vec![[NONE; 2]; edges];
    for (&e, &f) in corner_edge.iter().zip(corner_face) {
        let s = &mut sides[e as usize];
        s[(s[0] != NONE) as usize] = f;
    }
    sides
}

/// A vertex that `face` lists twice.
fn repeated(face: &[u32]) -> Option<u32> {
    let mut sorted = face.to_vec();
    sorted.sort_unstable();
    sorted.windows(2).find(|w| w[0] == w[1]).map(|w| w[0])
}
