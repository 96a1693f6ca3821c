//! Generated texture coordinates for meshes without a UV map: world-size tiles.
//!
//! Not from the papers. The dissertation (chapter 3.1) maps textures through the
//! mesh's `(s, t)` parameterization and assumes one exists; dense scans rarely have
//! one, and one tile per face ([`super::TextureCoordinates::of`]) makes the pattern's
//! size follow the triangles. This module gives such meshes coordinates in the
//! spirit of Blender's Smart UV Project with a world-size scale:
//!
//! 1. Charts: faces grouped by region growing over manifold edges (two faces, opposite
//!    windings), best-first by distance from the seed's centroid (compact charts),
//!    while every triangle of a face stays within [`CONE_DEGREES`] of the seed face's
//!    normal. Seeds are the lowest-numbered faces not yet in a chart, ties broken by
//!    face number: the result depends only on the mesh. `O(n log n)` (a heap).
//! 2. Projection: each chart onto the plane of its mean (area-weighted) normal, in a
//!    frame fixed by the world axis least aligned with that normal. Every triangle is
//!    within the cone of the seed normal, so the mean normal is too, and every
//!    triangle is within twice the cone (70 degrees) of the projection direction:
//!    its projected area is positive (at least `cos 70° ≈ 0.34` of its area), so no
//!    projection folds.
//! 3. Scale: `(s, t)` in tiles of `tile_size` mesh units, the projection stretched
//!    uniformly per chart so that the chart's area in tiles is its world area over
//!    `tile_size²` (a tilted face would otherwise get smaller projected tiles, so
//!    larger world tiles, than a face parallel to the plane).
//!
//! Seams between charts are UV seams: the bake welds across them as across a real UV
//! map's seams (the texture is discontinuous there, the geometry closed).

use super::bake::BudgetFit;
use crate::mesh::{EdgeMap, Triangulation};
use crate::{Error, Mesh, Result};
use glam::{DVec3, Vec2};
use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// Largest angle between a chart triangle's normal and its chart's seed normal.
pub const CONE_DEGREES: f32 = 35.0;

/// World-size texture coordinates of a mesh, with the charts they come from.
#[derive(Debug, Clone, PartialEq)]
pub struct Charts {
    /// The chart of every face, numbered from 0 in seed order.
    pub chart_of_face: Vec<u32>,
    /// How many charts.
    pub count: usize,
    /// `(s, t)` of every face corner (Blender's loops), in tiles.
    pub corner_st: Vec<Vec2>,
}

/// A candidate face in the growth heap: the nearest (then lowest-numbered) first.
#[derive(PartialEq)]
struct Candidate {
    distance: f64,
    face: u32,
}

impl Eq for Candidate {}

impl Ord for Candidate {
    fn cmp(&self, other: &Self) -> Ordering {
        // BinaryHeap pops the greatest: reverse both keys.
        other.distance.total_cmp(&self.distance).then(other.face.cmp(&self.face))
    }
}

impl PartialOrd for Candidate {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl Charts {
    /// Charts of `mesh` and the `(s, t)` of its corners, one tile every `tile_size`
    /// mesh units along the surface. `tile_size` must be positive and finite.
    pub fn of(mesh: &Mesh, tile_size: f32) -> Result<Self> {
        mesh.require_faces()?;
        if !(tile_size.is_finite() && tile_size > 0.0) {
            return Err(Error::InvalidParameter(format!("the tile size must be a positive length, not {tile_size}")));
        }
        let p = mesh.positions();
        let tri = Triangulation::of(mesh);
        let faces = mesh.face_count();
        // Area vectors (twice the area along the normal) of each triangle, in double.
        let area_vec = |t: &[u32; 3]| {
            let [a, b, c] = t.map(|v| p[v as usize].as_dvec3());
            (b - a).cross(c - a)
        };
        let mut first_triangle = vec![0u32; faces + 1];
        for &f in &tri.face_of_triangle {
            first_triangle[f as usize + 1] += 1;
        }
        for f in 0..faces {
            first_triangle[f + 1] += first_triangle[f];
        }
        let triangles_of = |f: usize| &tri.triangles[first_triangle[f] as usize..first_triangle[f + 1] as usize];
        let face_area_vec: Vec<DVec3> = (0..faces).map(|f| triangles_of(f).iter().map(area_vec).sum()).collect();
        let centroid: Vec<DVec3> = mesh.faces().map(|face| face.iter().map(|&v| p[v as usize].as_dvec3()).sum::<DVec3>() / face.len() as f64).collect();
        let cos_cone = f64::from(CONE_DEGREES.to_radians().cos());
        // Whether every (non-degenerate) triangle of face `f` is within the cone of `axis`.
        let within = |f: usize, axis: DVec3| {
            triangles_of(f).iter().all(|t| {
                let a = area_vec(t);
                let len = a.length();
                len == 0.0 || a.dot(axis) >= cos_cone * len
            })
        };
        let edges = EdgeMap::of(mesh);
        let neighbours = |f: usize, out: &mut Vec<u32>| {
            out.clear();
            let face = mesh.face(f);
            for i in 0..face.len() {
                let (a, b) = (face[i], face[(i + 1) % face.len()]);
                if let Some(e) = edges.get(a, b) {
                    if e.count == 2 && e.faces[0].1 != e.faces[1].1 {
                        let other = if e.faces[0].0 == f as u32 { e.faces[1].0 } else { e.faces[0].0 };
                        if other != f as u32 {
                            out.push(other);
                        }
                    }
                }
            }
        };

        const NONE: u32 = u32::MAX;
        let mut chart_of_face = vec![NONE; faces];
        let mut members: Vec<Vec<u32>> = Vec::new();
        let mut heap = BinaryHeap::new();
        let mut around = Vec::new();
        for seed in 0..faces {
            if chart_of_face[seed] != NONE {
                continue;
            }
            let chart = members.len() as u32;
            let axis = face_area_vec[seed].normalize_or_zero();
            let mut list = Vec::new();
            heap.clear();
            heap.push(Candidate { distance: 0.0, face: seed as u32 });
            while let Some(Candidate { face, .. }) = heap.pop() {
                let f = face as usize;
                // A face may be pushed by several neighbours; the seed always joins
                // (a degenerate seed has no axis: its chart is itself).
                if chart_of_face[f] != NONE || (f != seed && (axis == DVec3::ZERO || !within(f, axis))) {
                    continue;
                }
                chart_of_face[f] = chart;
                list.push(face);
                neighbours(f, &mut around);
                for &g in &around {
                    if chart_of_face[g as usize] == NONE {
                        heap.push(Candidate { distance: centroid[g as usize].distance_squared(centroid[seed]), face: g });
                    }
                }
            }
            members.push(list);
        }

        let inv = 1.0 / f64::from(tile_size);
        let mut corner_st = vec![Vec2::ZERO; mesh.corners().len()];
        for list in &members {
            let area: DVec3 = list.iter().map(|&f| face_area_vec[f as usize]).sum();
            let normal = area.normalize_or_zero();
            let normal = if normal == DVec3::ZERO { face_area_vec[list[0] as usize].normalize_or(DVec3::Z) } else { normal };
            let (u, v) = frame(normal);
            // World area over projected area (both doubled): the per-chart stretch.
            let world: f64 = list.iter().map(|&f| face_area_vec[f as usize].length()).sum();
            let projected = area.dot(normal);
            let stretch = if projected > 0.0 && world > 0.0 { (world / projected).sqrt() } else { 1.0 };
            let scale = inv * stretch;
            // From the chart's first corner: (s, t) stay small, so f32 keeps them exact to
            // far below a texel wherever the mesh lies (a scan at 5e5 units with a 1 cm
            // tile would have a step of f32 wider than a tile).
            let origin = p[mesh.face(list[0] as usize)[0] as usize].as_dvec3();
            for &f in list {
                let range = mesh.face_corner_range(f as usize);
                for (c, &vert) in range.zip(mesh.face(f as usize)) {
                    let q = p[vert as usize].as_dvec3() - origin;
                    corner_st[c] = Vec2::new((q.dot(u) * scale) as f32, (q.dot(v) * scale) as f32);
                }
            }
        }
        Ok(Self { chart_of_face, count: members.len(), corner_st })
    }
}

/// A right-handed frame `(u, v)` of the plane with `normal` (`u × v = normal`): `u`
/// from the world axis least aligned with the normal (lowest index on ties), so the
/// frame depends on the normal alone.
pub(crate) fn frame(normal: DVec3) -> (DVec3, DVec3) {
    let a = normal.abs();
    let axis = if a.x <= a.y && a.x <= a.z {
        DVec3::X
    } else if a.y <= a.z {
        DVec3::Y
    } else {
        DVec3::Z
    };
    let u = (axis - normal * axis.dot(normal)).normalize();
    (u, normal.cross(u))
}

/// The world-size coordinates of `mesh` as a UV map: `mesh` with `corner_st` as its UVs.
pub fn with_world_size_uvs(mesh: &Mesh, tile_size: f32) -> Result<Mesh> {
    let charts = Charts::of(mesh, tile_size)?;
    Mesh::new(mesh.positions().to_vec(), &mesh.face_sizes(), mesh.corners().to_vec(), Some(charts.corner_st))
}

/// The World-Size tile size, `start` or larger, at which a bake of `params` on `mesh`
/// (without a UV map) with generated coordinates is estimated within its triangle
/// budget, and the search's [`BudgetFit`] ([`crate::texture::bake::budget_scale`]: the
/// charts scale with the tile size, so the tiles grow by its factor). `shell` is the
/// shell over `mesh` (the generated UVs change no vertex). For a mesh whose one tile
/// per face holds more texture than the budget has room for, this is the fix: the
/// texture keeps its features, the tiles follow the surface's size, not its faces'.
pub fn budget_tile_size(
    mesh: &Mesh,
    shell: &crate::shell::Shell,
    textures: &[super::TextureLayer],
    params: &super::BakeParams,
    start: f32,
) -> Result<(f32, BudgetFit)> {
    let charted = with_world_size_uvs(mesh, start)?;
    let fit = super::bake::budget_scale(&charted, shell, textures, params)?;
    Ok((start * fit.scale, fit))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::fixtures::{cube, grid};
    use crate::{hard_meshes, testmeshes};

    /// Signed area of triangle `t` of face `f` in `(s, t)` space, and its world area.
    fn projected_and_world(mesh: &Mesh, charts: &Charts, tri: &Triangulation, k: usize) -> (f32, f32) {
        let t = tri.triangles[k];
        let f = tri.face_of_triangle[k] as usize;
        let range = mesh.face_corner_range(f);
        let face = mesh.face(f);
        let st = t.map(|v| charts.corner_st[range.start + face.iter().position(|c| *c == v).unwrap()]);
        let p = t.map(|v| mesh.positions()[v as usize]);
        let signed = (st[1] - st[0]).perp_dot(st[2] - st[0]) * 0.5;
        (signed, (p[1] - p[0]).cross(p[2] - p[0]).length() * 0.5)
    }

    fn meshes() -> Vec<(&'static str, Mesh)> {
        vec![
            ("sphere", testmeshes::icosphere(3)),
            ("torus knot", hard_meshes::torus_knot()),
            ("cube", cube()),
            ("grid", grid(20)),
            ("saddle", testmeshes::saddle(24)),
            ("bumpy head", testmeshes::bumpy_head(3)),
            ("bunny", testmeshes::bunny()),
        ]
    }

    #[test]
    fn charts_cover_every_face_and_are_connected() {
        for (name, mesh) in meshes() {
            let charts = Charts::of(&mesh, 0.1).unwrap();
            assert!(charts.chart_of_face.iter().all(|&c| (c as usize) < charts.count), "{name}: every face in a chart");
            assert!(charts.count >= 1 && charts.count <= mesh.face_count(), "{name}: {} charts", charts.count);
            assert_eq!(charts.corner_st.len(), mesh.corners().len());
            // Connected: from each chart's first face, its faces are reached over shared edges inside the chart.
            let edges = EdgeMap::of(&mesh);
            let mut reached = vec![false; mesh.face_count()];
            for c in 0..charts.count as u32 {
                let first = charts.chart_of_face.iter().position(|&x| x == c).unwrap();
                let mut stack = vec![first];
                reached[first] = true;
                while let Some(f) = stack.pop() {
                    let face = mesh.face(f);
                    for i in 0..face.len() {
                        let e = edges.get(face[i], face[(i + 1) % face.len()]).unwrap();
                        for &(g, _) in &e.faces[..(e.count as usize).min(2)] {
                            let g = g as usize;
                            if !reached[g] && charts.chart_of_face[g] == c {
                                reached[g] = true;
                                stack.push(g);
                            }
                        }
                    }
                }
            }
            assert!(reached.iter().all(|&r| r), "{name}: every chart is one connected patch");
        }
    }

    #[test]
    fn no_projected_triangle_flips() {
        for (name, mesh) in meshes() {
            let charts = Charts::of(&mesh, 0.1).unwrap();
            let tri = mesh.triangulate();
            for k in 0..tri.triangles.len() {
                let (signed, world) = projected_and_world(&mesh, &charts, &tri, k);
                if world > 1e-12 {
                    assert!(signed > 0.0, "{name}: triangle {k} projects to area {signed} (world {world})");
                }
            }
        }
    }

    #[test]
    fn a_curved_mesh_gets_several_charts_a_plane_one() {
        assert_eq!(Charts::of(&grid(20), 0.1).unwrap().count, 1);
        // Six faces of a cube, 90 degrees apart: six charts.
        assert_eq!(Charts::of(&cube(), 0.1).unwrap().count, 6);
        let sphere = testmeshes::icosphere(3);
        let n = Charts::of(&sphere, 0.1).unwrap().count;
        assert!(n > 6 && n < sphere.face_count() / 8, "sphere: {n} charts of {} faces", sphere.face_count());
    }

    #[test]
    fn one_tile_is_tile_size_world_units() {
        // On a plane, a straight segment of world length L spans L / tile_size tiles.
        let mesh = grid(20);
        for tile in [0.05f32, 0.13, 0.4] {
            let charts = Charts::of(&mesh, tile).unwrap();
            let (p, c) = (mesh.positions(), mesh.corners());
            for (i, j) in [(0, 1), (0, 2), (1, 3)] {
                let world = p[c[i] as usize].distance(p[c[j] as usize]);
                let tiles = charts.corner_st[i].distance(charts.corner_st[j]);
                assert!((tiles * tile / world - 1.0).abs() < 1e-3, "tile {tile}: {tiles} tiles over {world}");
            }
        }
        // On curved meshes, the total area in tiles is the world area over tile_size²
        // (each chart scaled to keep its area), and triangle by triangle the ratio of
        // the two stays near 1 (the projection's stretch within a chart).
        for (name, mesh) in meshes() {
            let tile = 0.07f32;
            let charts = Charts::of(&mesh, tile).unwrap();
            let tri = mesh.triangulate();
            let (mut proj, mut world, mut worst) = (0.0f64, 0.0f64, 0.0f32);
            for k in 0..tri.triangles.len() {
                let (s, w) = projected_and_world(&mesh, &charts, &tri, k);
                proj += f64::from(s);
                world += f64::from(w);
                if w > 1e-9 {
                    worst = worst.max((s * tile * tile / w).ln().abs());
                }
            }
            let ratio = proj * f64::from(tile * tile) / world;
            assert!((ratio - 1.0).abs() < 0.02, "{name}: area in tiles x tile² / world area = {ratio}");
            // Within a 35-degree cone the projection shrinks a triangle's area by at
            // most cos 70°; measured per triangle relative to its chart's scale.
            assert!(worst < 1.1, "{name}: worst log area ratio {worst}");
        }
    }

    #[test]
    fn deterministic() {
        let mesh = testmeshes::bumpy_head(3);
        let a = Charts::of(&mesh, 0.1).unwrap();
        let b = Charts::of(&mesh, 0.1).unwrap();
        assert_eq!(a, b);
        // Only the scale depends on the tile size.
        let c = Charts::of(&mesh, 0.2).unwrap();
        assert_eq!(a.chart_of_face, c.chart_of_face);
        assert!(a.corner_st.iter().zip(&c.corner_st).all(|(x, y)| (*x * 0.5 - *y).length() <= 1e-4 * x.length().max(1.0)));
    }

    #[test]
    fn a_bake_across_chart_seams_is_closed_and_does_not_cross_itself() {
        use crate::shell::{build_shell, ShellParams, Side, Thickness};
        use crate::texture::{bake, BakeParams, Generator, Pattern, TextureLayer};
        let bunny = testmeshes::bunny();
        let mesh = with_world_size_uvs(&bunny, bunny.bbox_diagonal() / 20.0).unwrap();
        assert!(Charts::of(&bunny, bunny.bbox_diagonal() / 20.0).unwrap().count > 10, "the seams are many");
        let t = Thickness::relative(0.03).per_vertex(&mesh, None).unwrap();
        let shell = build_shell(&mesh, &t, Side::Exterior, &ShellParams::default()).unwrap();
        let tex = Generator { thickness: 3.0, ..Generator::new(Pattern::ChainMail) }.generate([16, 16, 8]).unwrap();
        let params = BakeParams { resolution: 2, depth_steps: 8, ..Default::default() };
        let b = bake(&mesh, &shell, &[TextureLayer { texture: tex, offset: Vec2::ZERO }], &params).unwrap();
        assert!(!b.per_face_tiles && b.triangles.len() > 10_000, "{}", b.triangles.len());
        let check = crate::polygonize::SurfaceCheck::of(&b.positions, &b.triangles);
        assert!(check.is_closed_manifold(), "{check:?}");
        assert_eq!(hard_meshes::self_intersections(&Mesh::from_triangles(b.positions.clone(), &b.triangles).unwrap()), 0);
    }

    #[test]
    fn bad_tile_sizes_are_refused() {
        for t in [0.0, -1.0, f32::NAN, f32::INFINITY] {
            assert!(matches!(Charts::of(&cube(), t), Err(Error::InvalidParameter(_))), "{t}");
        }
    }

    #[test]
    fn with_world_size_uvs_sets_the_uv_map() {
        let mesh = testmeshes::icosphere(2);
        let uv = with_world_size_uvs(&mesh, 0.25).unwrap();
        assert_eq!(uv.uvs().unwrap(), &Charts::of(&mesh, 0.25).unwrap().corner_st[..]);
        assert_eq!(uv.corners(), mesh.corners());
    }
}
