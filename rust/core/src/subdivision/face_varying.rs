//! Face-varying data (UV maps) through the Catmull-Clark levels, as OpenSubdiv refines it
//! for Blender's Subdivision Surface modifier (Vtr::FVarLevel::completeTopologyFromFaceValues,
//! Vtr::FVarRefinement, Far::PrimvarRefiner::InterpolateFaceVarying). Each face corner refers
//! to a value; corners of one vertex with the same UV share a value, and an edge whose two
//! faces disagree on the value at either end is a seam.

use super::topology::{Level, NONE};
use super::{edge_point, face_point, limit_point, vertex_point};
use crate::{Error, Result};
use glam::{DVec2, Vec2};
use rayon::prelude::*;

/// Blender's UV Smooth (`uv_smooth`), as OpenSubdiv's face-varying linear interpolation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum UvSmooth {
    /// 'NONE' (FVAR_LINEAR_ALL): UVs subdivide bilinearly.
    Linear,
    /// 'PRESERVE_BOUNDARIES' (FVAR_LINEAR_BOUNDARIES), Blender's default: the values of a
    /// vertex on a seam or the mesh boundary (a seam's inner end included) stay, edge points
    /// there are midpoints, and the Catmull-Clark rules smooth the rest.
    #[default]
    PreserveBoundaries,
}

impl UvSmooth {
    /// Blender's `uv_smooth` names.
    pub fn parse(name: &str) -> Result<Self> {
        match name {
            "NONE" => Ok(Self::Linear),
            "PRESERVE_BOUNDARIES" => Ok(Self::PreserveBoundaries),
            _ => Err(Error::InvalidParameter(format!("uv_smooth must be 'PRESERVE_BOUNDARIES' or 'NONE', not {name:?}"))),
        }
    }
}

/// Blender's STD_UV_CONNECT_LIMIT: corners of one vertex whose UVs differ by less than this
/// in both coordinates share a value.
const CONNECT_LIMIT: f32 = 1e-4;

/// One face-varying channel of a level.
pub(super) struct Channel {
    /// The value of each corner.
    value: Vec<u32>,
    values: Vec<DVec2>,
}

/// Where a level's face-varying values stay put: per edge, the corner on each side
/// ([`NONE`] second on a boundary) and whether the edge is sharp (boundary or seam, or every
/// edge when linear); per value, whether its vertex lies on a sharp edge.
struct Sharp {
    sides: Vec<[u32; 2]>,
    edge: Vec<bool>,
    value: Vec<bool>,
}

impl Channel {
    /// Welds per-corner `uvs` into values as Blender's converter does
    /// (BKE_mesh_uv_vert_map_create): at each vertex, from its last corner back, a corner not
    /// yet taken starts a value with its UV and takes the earlier corners within
    /// [`CONNECT_LIMIT`].
    pub fn weld(level: &Level, uvs: &[Vec2]) -> Result<Self> {
        let n = level.corners.len();
        if uvs.len() != n {
            return Err(Error::InvalidParameter(format!("{} UVs given for {n} face corners", uvs.len())));
        }
        if let Some(c) = uvs.iter().position(|uv| !uv.is_finite()) {
            return Err(Error::InvalidParameter(format!("the UV of corner {c} is not finite ({})", uvs[c])));
        }
        let nv = level.positions.len();
        let mut start = vec![0usize; nv + 1];
        for &v in &level.corners {
            start[v as usize + 1] += 1;
        }
        for v in 0..nv {
            start[v + 1] += start[v];
        }
        let (mut fill, mut by_vertex) = (start.clone(), vec![0usize; n]);
        for (c, &v) in level.corners.iter().enumerate() {
            by_vertex[fill[v as usize]] = c;
            fill[v as usize] += 1;
        }
        let (mut value, mut values) = (vec![NONE; n], Vec::with_capacity(nv));
        for v in 0..nv {
            let around = &by_vertex[start[v]..start[v + 1]];
            for (i, &c) in around.iter().enumerate().rev() {
                if value[c] == NONE {
                    for &d in &around[..=i] {
                        if value[d] == NONE && (uvs[d] - uvs[c]).abs().cmplt(Vec2::splat(CONNECT_LIMIT)).all() {
                            value[d] = values.len() as u32;
                        }
                    }
                    values.push(uvs[c].as_dvec2());
                }
            }
        }
        Ok(Self { value, values })
    }

    fn at(&self, c: usize) -> DVec2 {
        self.values[self.value[c] as usize]
    }

    fn sharp(&self, level: &Level, smooth: UvSmooth) -> Sharp {
        let mut sides = vec![[NONE; 2]; level.edges.len()];
        for (c, &e) in level.corner_edge.iter().enumerate() {
            let s = &mut sides[e as usize];
            s[(s[0] != NONE) as usize] = c as u32;
        }
        let linear = smooth == UvSmooth::Linear;
        let value = |c: u32| self.value[c as usize];
        let next = |c: u32| level.next(c as usize) as u32;
        let edge: Vec<bool> = sides.iter().map(|&[c, d]| linear || d == NONE || value(c) != value(next(d)) || value(next(c)) != value(d)).collect();
        let mut vertex = vec![linear; level.positions.len()];
        for (&[a, b], _) in level.edges.iter().zip(&edge).filter(|(_, &sharp)| sharp) {
            vertex[a as usize] = true;
            vertex[b as usize] = true;
        }
        let mut sharp_value = vec![false; self.values.len()];
        for (&w, &v) in self.value.iter().zip(&level.corners) {
            sharp_value[w as usize] = vertex[v as usize];
        }
        Sharp { sides, edge, value: sharp_value }
    }

    /// Per value, over the corners that use it: their count and the sums of `edge(c)` and
    /// `face(c)`.
    fn rings(&self, edge: impl Fn(usize) -> DVec2, face: impl Fn(usize) -> DVec2) -> Vec<(u32, DVec2, DVec2)> {
        let mut r = vec![(0u32, DVec2::ZERO, DVec2::ZERO); self.values.len()];
        for (c, &w) in self.value.iter().enumerate() {
            let s = &mut r[w as usize];
            *s = (s.0 + 1, s.1 + edge(c), s.2 + face(c));
        }
        r
    }

    /// The channel on the child of `level` ([`Level::child`]'s numbering): face values are
    /// centroids; edge values the Catmull-Clark edge point, or on a sharp edge the midpoint
    /// on each side; sharp values stay and the others take the Catmull-Clark vertex point.
    pub fn refine(&self, level: &Level, smooth: UvSmooth) -> Self {
        let sharp = self.sharp(level, smooth);
        let face_values: Vec<DVec2> =
            (0..level.face_count()).into_par_iter().map(|f| face_point((level.offsets[f]..level.offsets[f + 1]).map(|c| self.at(c as usize)))).collect();
        let ends = |c: u32| self.at(c as usize) + self.at(level.next(c as usize));
        let (mut edge_value, mut edge_values) = (vec![0u32; level.corners.len()], Vec::with_capacity(level.edges.len()));
        for (e, &[c, d]) in sharp.sides.iter().enumerate() {
            if sharp.edge[e] {
                for s in [c, d].into_iter().filter(|&s| s != NONE) {
                    edge_value[s as usize] = edge_values.len() as u32;
                    edge_values.push(ends(s) * 0.5);
                }
            } else {
                let [f0, f1] = level.edge_faces[e];
                (edge_value[c as usize], edge_value[d as usize]) = (edge_values.len() as u32, edge_values.len() as u32);
                edge_values.push(edge_point(ends(c), face_values[f0 as usize], face_values[f1 as usize]));
            }
        }
        let rings = self.rings(|c| self.at(level.next(c)), |c| face_values[level.corner_face[c] as usize]);
        let vertex_values = self.values.iter().zip(&rings).zip(&sharp.value).map(
            |((&v, &(n, edges, faces)), &sharp)| {
                if sharp {
                    v
                } else {
                    vertex_point(v, n as f64, edges, faces)
                }
            },
        );
        let (nv, ne) = (self.values.len() as u32, edge_values.len() as u32);
        let value = (0..level.corners.len())
            .into_par_iter()
            .flat_map_iter(|c| [self.value[c], nv + edge_value[c], nv + ne + level.corner_face[c], nv + edge_value[level.prev(c)]])
            .collect();
        Self { value, values: vertex_values.chain(edge_values).chain(face_values).collect() }
    }

    /// The UV of each corner of the all-quad `level`; with `limit`, smooth values go to their
    /// limit by [`limit_point`] and sharp ones stay.
    pub fn per_corner(&self, level: &Level, smooth: UvSmooth, limit: bool) -> Vec<Vec2> {
        let values = if limit && smooth != UvSmooth::Linear {
            let sharp = self.sharp(level, smooth);
            let rings = self.rings(|c| self.at(level.next(c)), |c| self.at(c - c % 4 + (c + 2) % 4));
            self.values
                .iter()
                .zip(&rings)
                .zip(&sharp.value)
                .map(|((&v, &(n, edges, diagonals)), &sharp)| if sharp { v } else { limit_point(v, n as f64, edges, diagonals) })
                .collect()
        } else {
            self.values.clone()
        };
        self.value.par_iter().map(|&w| values[w as usize].as_vec2()).collect()
    }
}
