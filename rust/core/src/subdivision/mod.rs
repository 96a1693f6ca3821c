//! Catmull-Clark subdivision of polygon meshes, the base of the multiresolution surfaces of
//! Velho, Perlin, Ying and Biermann (section 2: each finer level is the subdivided coarser
//! one, plus details). Rules of Catmull and Clark (1978) with the boundary rules of DeRose,
//! Kass and Truong (1998) as OpenSubdiv and Blender's Subdivision Surface modifier apply
//! them; limit positions by the masks of Halstead, Kass and DeRose (1993).

pub mod budget;
pub mod detail;
mod face_varying;
pub mod multires;
pub mod operations;
pub mod recipe;
mod topology;

use crate::{Error, Mesh, Result};
use face_varying::Channel;
pub use face_varying::UvSmooth;
use glam::{DVec3, Vec2, Vec3};
use rayon::prelude::*;
use std::ops::{Add, Div, Mul};
use topology::{Level, NONE};

/// The most levels [`subdivide`] takes: each level multiplies the faces by 4.
pub const MAX_LEVELS: u32 = 6;

/// How boundary vertices with a single face (the corners of an open grid) move: Blender's
/// `boundary_smooth`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Boundary {
    /// 'ALL' (Blender's default; OpenSubdiv's VTX_BOUNDARY_EDGE_ONLY): every boundary vertex
    /// follows the cubic B-spline curve rule, corners included, so they round off.
    #[default]
    SmoothAll,
    /// 'PRESERVE_CORNERS' (VTX_BOUNDARY_EDGE_AND_CORNER): vertices of one face stay put.
    KeepCorners,
}

impl Boundary {
    /// Blender's `boundary_smooth` names.
    pub fn parse(name: &str) -> Result<Self> {
        match name {
            "ALL" => Ok(Self::SmoothAll),
            "PRESERVE_CORNERS" => Ok(Self::KeepCorners),
            _ => Err(Error::InvalidParameter(format!("boundary_smooth must be 'ALL' or 'PRESERVE_CORNERS', not {name:?}"))),
        }
    }
}

/// What [`subdivide`] does.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Options {
    /// Levels of subdivision, 1 to [`MAX_LEVELS`].
    pub levels: u32,
    /// Push the last level's vertices onto the limit surface (Blender's `use_limit_surface`).
    pub limit: bool,
    pub boundary: Boundary,
}

impl Default for Options {
    fn default() -> Self {
        Self { levels: 1, limit: true, boundary: Boundary::SmoothAll }
    }
}

/// A subdivided mesh (all quads) and the base face each of its faces lies in, so per-face
/// attributes (material indices) carry over: `attribute[source_face[f]]`.
#[derive(Debug, Clone, PartialEq)]
pub struct Subdivided {
    pub mesh: Mesh,
    pub source_face: Vec<u32>,
}

/// Catmull-Clark subdivision of `mesh` by `options.levels` levels. Base vertex `i` stays
/// vertex `i`; each level appends the edge points, then the face points, and splits face
/// corner `c` into child quad `c`, so the children of a base face are contiguous. Refuses
/// non-manifold input (an edge of 3 or more faces, a vertex whose faces form several fans),
/// loose vertices, faces that repeat a vertex, and outputs beyond 2^32 corners.
pub fn subdivide(mesh: &Mesh, options: &Options) -> Result<Subdivided> {
    Ok(subdivide_with_uvs(mesh, options, UvSmooth::default(), &[])?.0)
}

/// [`subdivide`], carrying per-corner UV maps (`uvs`, each one UV per base corner) through
/// every level as face-varying data by the `smooth` rule, as Blender's modifier does with its
/// UV Smooth option; returns each map per corner of the subdivided mesh. With
/// `options.limit`, the UVs go to their limit as the positions do.
pub fn subdivide_with_uvs(mesh: &Mesh, options: &Options, smooth: UvSmooth, uvs: &[&[Vec2]]) -> Result<(Subdivided, Vec<Vec<Vec2>>)> {
    check_levels(mesh, options.levels)?;
    let mut level = Level::base(mesh)?;
    let mut channels = uvs.iter().map(|uv| Channel::weld(&level, uv)).collect::<Result<Vec<_>>>()?;
    let mut source_face: Vec<u32> = (0..mesh.face_count() as u32).collect();
    for _ in 0..options.levels {
        source_face = level.corner_face.iter().map(|&f| source_face[f as usize]).collect();
        channels = channels.iter().map(|c| c.refine(&level, smooth)).collect();
        level = level.refine(options.boundary);
    }
    let uvs = channels.iter().map(|c| c.per_corner(&level, smooth, options.limit)).collect();
    let to_f32 = |p: &[DVec3]| p.iter().map(|p| p.as_vec3()).collect::<Vec<Vec3>>();
    let positions = if options.limit { to_f32(&level.limit_positions(options.boundary)) } else { to_f32(&level.positions) };
    let sizes = vec![4u32; level.corners.len() / 4];
    let mesh = Mesh::new(positions, &sizes, level.corners, None)?;
    Ok((Subdivided { mesh, source_face }, uvs))
}

/// Per-corner UV maps (`uvs`, each one UV per corner of `mesh`) through `levels`
/// Catmull-Clark levels by the `smooth` rule, on the connectivity alone: the UVs
/// [`subdivide_with_uvs`] gives without the limit (face-varying values do not depend on
/// the positions, so none are subdivided), one per corner of the subdivided mesh, whose
/// corners [`detail::procedural_detail`] orders as [`subdivide`] does. The detail's
/// levels are control meshes, never the limit surface, so the UVs are not taken to it.
pub fn subdivide_uvs(mesh: &Mesh, levels: u32, smooth: UvSmooth, uvs: &[&[Vec2]]) -> Result<Vec<Vec<Vec2>>> {
    check_levels(mesh, levels)?;
    let mut level = Level::base(mesh)?;
    let mut channels = uvs.iter().map(|uv| Channel::weld(&level, uv)).collect::<Result<Vec<_>>>()?;
    for _ in 0..levels {
        channels = channels.iter().map(|c| c.refine(&level, smooth)).collect();
        level = level.child_topology();
    }
    Ok(channels.iter().map(|c| c.per_corner(&level, smooth, false)).collect())
}

/// Refuses levels outside 1 to [`MAX_LEVELS`], a mesh of no face, and outputs beyond 2^32
/// corners.
fn check_levels(mesh: &Mesh, levels: u32) -> Result<()> {
    if !(1..=MAX_LEVELS).contains(&levels) {
        return Err(Error::InvalidParameter(format!("subdivision levels must be 1 to {MAX_LEVELS}, not {levels}")));
    }
    mesh.require_faces()?;
    let out_corners = mesh.corners().len() as u64 * 4u64.pow(levels);
    if out_corners > u32::MAX as u64 {
        return Err(Error::OverLimit(format!(
            "{levels} levels of subdivision would make {out_corners} face corners, more than a mesh can hold (2^32); use fewer levels"
        )));
    }
    Ok(())
}

/// What the subdivision rules average: positions and face-varying values.
trait Point: Copy + Send + Sync + Add<Output = Self> + Mul<f64, Output = Self> + Div<f64, Output = Self> + std::iter::Sum {}
impl<T: Copy + Send + Sync + Add<Output = T> + Mul<f64, Output = T> + Div<f64, Output = T> + std::iter::Sum> Point for T {}

/// Catmull-Clark's face point: the centroid.
fn face_point<T: Point>(points: impl ExactSizeIterator<Item = T>) -> T {
    let n = points.len() as f64;
    points.sum::<T>() / n
}

/// Catmull-Clark's smooth edge point from the sum of the edge's ends and its two face points.
fn edge_point<T: Point>(ends: T, f0: T, f1: T) -> T {
    (ends + f0 + f1) * 0.25
}

/// Catmull-Clark's smooth vertex point, (n-2)/n v + sum(e_i)/n^2 + sum(f_i)/n^2, from the
/// sums of the n edge neighbours and n face points.
fn vertex_point<T: Point>(v: T, n: f64, edges: T, faces: T) -> T {
    v * ((n - 2.0) / n) + (edges + faces) / (n * n)
}

/// The limit of a smooth vertex of an all-quad level, (n^2 v + 4 sum(e_i) + sum(d_i)) /
/// (n (n + 5)), e_i the edge neighbours and d_i the quad vertices opposite v (Halstead et
/// al. 1993; OpenSubdiv's Catmull-Clark limit mask).
fn limit_point<T: Point>(v: T, n: f64, edges: T, diagonals: T) -> T {
    (v * (n * n) + edges * 4.0 + diagonals) / (n * (n + 5.0))
}

/// Per-vertex sums over a level's neighbourhoods, gathered in one pass over edges and corners.
struct Rings {
    /// Faces around each vertex, and the sum of their centroids (or, for the limit mask,
    /// of the quad vertices opposite it).
    faces: Vec<u32>,
    face_sum: Vec<DVec3>,
    /// The sum of the other ends of the edges at each vertex.
    edge_sum: Vec<DVec3>,
    /// Boundary edges at each vertex, and the sum of their other ends.
    boundary: Vec<u32>,
    boundary_sum: Vec<DVec3>,
}

impl Rings {
    fn of(level: &Level, per_corner: impl Fn(usize) -> DVec3) -> Self {
        let n = level.positions.len();
        let mut r = Self {
            faces: vec![0; n],
            face_sum: vec![DVec3::ZERO; n],
            edge_sum: vec![DVec3::ZERO; n],
            boundary: vec![0; n],
            boundary_sum: vec![DVec3::ZERO; n],
        };
        for (c, &v) in level.corners.iter().enumerate() {
            r.faces[v as usize] += 1;
            r.face_sum[v as usize] += per_corner(c);
        }
        let p = &level.positions;
        for (e, &[a, b]) in level.edges.iter().enumerate() {
            let (a, b) = (a as usize, b as usize);
            r.edge_sum[a] += p[b];
            r.edge_sum[b] += p[a];
            if level.edge_faces[e][1] == NONE {
                r.boundary[a] += 1;
                r.boundary[b] += 1;
                r.boundary_sum[a] += p[b];
                r.boundary_sum[b] += p[a];
            }
        }
        r
    }

    /// Each vertex of `p` by the rule for its kind: corners that [`Boundary::KeepCorners`]
    /// holds stay, boundary vertices take `curve(v, sum of the boundary neighbours)`, inner
    /// ones `inner(v, valence, sum of the edge neighbours, face sum)`.
    fn each_vertex(
        &self,
        p: &[DVec3],
        boundary: Boundary,
        curve: impl Fn(DVec3, DVec3) -> DVec3 + Sync,
        inner: impl Fn(DVec3, f64, DVec3, DVec3) -> DVec3 + Sync,
    ) -> Vec<DVec3> {
        (0..p.len())
            .into_par_iter()
            .map(|v| {
                if boundary == Boundary::KeepCorners && self.boundary[v] > 0 && self.faces[v] == 1 {
                    p[v]
                } else if self.boundary[v] > 0 {
                    curve(p[v], self.boundary_sum[v])
                } else {
                    inner(p[v], self.faces[v] as f64, self.edge_sum[v], self.face_sum[v])
                }
            })
            .collect()
    }
}

impl Level {
    /// One Catmull-Clark step: face points (centroids), edge points (the mean of the ends
    /// and the two face points; the midpoint on a boundary) and vertex points
    /// ((n-2)/n v + sum(e_i)/n^2 + sum(f_i)/n^2 inside; (e1 + 6 v + e2)/8 on a boundary, the
    /// cubic B-spline curve rule).
    fn refine(&self, boundary: Boundary) -> Level {
        self.child(self.points(boundary))
    }

    /// The next level's positions as [`Level::refine`] makes them: vertex points, then one
    /// edge point per edge, then one face point per face.
    fn points(&self, boundary: Boundary) -> Vec<DVec3> {
        let p = &self.positions;
        let face_points: Vec<DVec3> = (0..self.face_count()).into_par_iter().map(|f| face_point(self.face(f).iter().map(|&v| p[v as usize]))).collect();
        let edge_points: Vec<DVec3> = self
            .edges
            .par_iter()
            .zip(&self.edge_faces)
            .map(|(&[a, b], &[f0, f1])| {
                let ends = p[a as usize] + p[b as usize];
                if f1 == NONE {
                    ends * 0.5
                } else {
                    edge_point(ends, face_points[f0 as usize], face_points[f1 as usize])
                }
            })
            .collect();
        let rings = Rings::of(self, |c| face_points[self.corner_face[c] as usize]);
        let vertex_points = rings.each_vertex(p, boundary, |v, ends| (v * 6.0 + ends) / 8.0, vertex_point);
        [vertex_points, edge_points, face_points].concat()
    }

    /// The limit positions of an all-quad level's vertices: [`limit_point`] inside,
    /// (e1 + 4 v + e2) / 6 on a boundary (the cubic B-spline curve's point); kept corners stay.
    fn limit_positions(&self, boundary: Boundary) -> Vec<DVec3> {
        let p = &self.positions;
        let rings = Rings::of(self, |c| p[self.corners[c - c % 4 + (c + 2) % 4] as usize]);
        rings.each_vertex(p, boundary, |v, ends| (v * 4.0 + ends) / 6.0, limit_point)
    }
}

#[cfg(test)]
mod tests;
