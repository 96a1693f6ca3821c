//! The slice geometry (chapter 5.1, figure 5.1): per cell, `slices` slices in the
//! direction closest to the view, plus the cell's faces.
//!
//! A triangle prism has four families of slices: layers of constant `r` (flat
//! triangles between the base and the outer layer, exact in the cell map) and
//! sections of constant `u`, `v` or `w = 1 − u − v` (quads across the prism, each drawn
//! as two triangles; the cell map is bilinear on them, so the shader refines their
//! fragments' parameters by Newton's method on the map instead of trusting the
//! linearly interpolated ones). Every family is a fixed *template* in cell parameters
//! `(u, v, r)`, the same for all cells; the vertex shader maps it through each cell.
//! Per frame only the family of each cell is chosen, on the CPU: the one whose
//! parameter changes fastest along the view ray through the cell's centre, `|∇p · d|`
//! largest, i.e. the one whose slices the ray crosses most often. For a cube-shaped cell
//! this is the paper's "slices oriented in the direction closest to the view
//! direction"; for thin shells it favours the layers, as their spacing is smaller.
//!
//! Every template also holds the cell's five faces (chapter 5.3: "we also render the
//! faces of the hexahedron"). The three side faces are shared with the neighbouring
//! cells; the whole template is drawn slightly inside the cell (moved toward its
//! centre by [`FACE_INSET`] in parameters), so the two copies of a shared face, one per
//! cell and each with its own cell's texture coordinates, have a definite order along
//! any ray, and a ray entering a cell meets that cell's copy of the face first:
//! the paper's "rendering the boundaries between textures twice, with a small offset
//! towards each of the textures". The last outside and the first inside sample of a
//! surface crossing are then in one cell, except where the crossing lies between
//! the two copies (the shading pass then tells a jump of `alpha` across the face from
//! a continuous crossing). Side faces are drawn as fans around their centres, so
//! both copies of a twisted face are triangulated alike.

use std::ops::Range;

use glam::{Vec2, Vec3};
use rayon::prelude::*;
use thicket_core::texture::CellMap;

/// A family of slices through a triangle prism: the parameter held constant.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Family {
    /// Layers `r = const` (parallel to the base).
    R = 0,
    /// Sections `u = const`.
    U = 1,
    /// Sections `v = const`.
    V = 2,
    /// Sections `1 − u − v = const`.
    W = 3,
}

impl Family {
    pub const ALL: [Family; 4] = [Family::R, Family::U, Family::V, Family::W];
}

/// Face codes carried by template vertices (0: an interior slice); the shader's
/// `FACE_*` constants.
pub const FACE_U0: u32 = 1;
pub const FACE_V0: u32 = 2;
pub const FACE_W0: u32 = 3;
pub const FACE_BASE: u32 = 4;
pub const FACE_TOP: u32 = 5;

/// How far the side faces are drawn inside their cell, as a share of the way to the
/// cell's centre: the parameter distance to the face is a third of it.
pub const FACE_INSET: f32 = 1e-3;

/// Fewest and most slices per cell (the faces count as the first and last layer).
pub const MIN_SLICES: u32 = 2;
pub const MAX_SLICES: u32 = 1024;

/// Where the camera is: a point (perspective) or a view direction (orthographic).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Eye {
    Point(Vec3),
    Direction(Vec3),
}

/// The family of slices for `cell` seen from `eye` (layers for a degenerate cell).
pub fn choose_family(cell: &CellMap, eye: Eye) -> Family {
    let centre = Vec3::new(1.0 / 3.0, 1.0 / 3.0, 0.5);
    let d = match eye {
        Eye::Point(p) => cell.world(centre) - p,
        Eye::Direction(d) => d,
    };
    let (jw, _) = cell.jacobians(centre);
    let det = jw.determinant();
    if !(det.abs() > 1e-30 && det.is_finite() && d.is_finite()) {
        return Family::R;
    }
    // Rows of J^{-1}: the world gradients of u, v and r.
    let inv = jw.inverse();
    let (gu, gv, gr) = (inv.row(0), inv.row(1), inv.row(2));
    let scores = [gr.dot(d).abs(), gu.dot(d).abs(), gv.dot(d).abs(), (gu + gv).dot(d).abs()];
    let mut best = 0;
    for (k, s) in scores.iter().enumerate().skip(1) {
        if *s > scores[best] {
            best = k;
        }
    }
    Family::ALL[best]
}

/// The slice templates for one slice count: template vertices `(u, v, r, tag)`,
/// three per triangle, `tag = face + 8 × family` (the shader refines the parameters
/// of the sections' fragments, whose map is bilinear), and each family's range.
#[derive(Debug, Clone, PartialEq)]
pub struct Templates {
    pub slices: u32,
    pub vertices: Vec<[f32; 4]>,
    pub ranges: [Range<u32>; 4],
}

/// Templates for `slices` slices per cell (clamped to [`MIN_SLICES`, `MAX_SLICES`]):
/// the two end slices of each family are faces of the prism (for the sections, the
/// far end is an edge and is skipped), the `slices − 2` others are evenly spaced.
pub fn templates(slices: u32) -> Templates {
    let m = slices.clamp(MIN_SLICES, MAX_SLICES);
    let mut vertices = Vec::new();
    let mut ranges: [Range<u32>; 4] = Default::default();
    let faces = faces();
    for family in Family::ALL {
        let start = vertices.len() as u32;
        let tag = 8 * family as u32;
        for k in 1..m - 1 {
            let p = k as f32 / (m - 1) as f32;
            let (a, b) = match family {
                Family::R => {
                    push_triangle(&mut vertices, [Vec3::new(0.0, 0.0, p), Vec3::new(1.0, 0.0, p), Vec3::new(0.0, 1.0, p)], tag);
                    continue;
                }
                Family::U => (Vec2::new(p, 0.0), Vec2::new(p, 1.0 - p)),
                Family::V => (Vec2::new(0.0, p), Vec2::new(1.0 - p, p)),
                Family::W => (Vec2::new(1.0 - p, 0.0), Vec2::new(0.0, 1.0 - p)),
            };
            push_quad(&mut vertices, a, b, tag);
        }
        for (tri, face) in &faces {
            push_triangle(&mut vertices, *tri, *face + tag);
        }
        ranges[family as usize] = start..vertices.len() as u32;
    }
    // Everything is drawn inside the side faces' copies, so that a ray meets the copy
    // of the face it enters a cell through before any other sample of that cell.
    for v in &mut vertices {
        let p = inset(Vec2::new(v[0], v[1]));
        (v[0], v[1]) = (p.x, p.y);
    }
    Templates { slices: m, vertices, ranges }
}

/// The layers of the transparency pass (chapter 6.5.2): `count` layers
/// `r = (k + 1/2) / count` from the base outward, one triangle (three template
/// vertices, no face code) each. They are not inset: neighbouring cells' layers meet
/// edge to edge at identical positions, so blending never covers a pixel twice.
pub fn haze_layers(count: u32) -> Vec<[f32; 4]> {
    let mut vertices = Vec::new();
    for k in 0..count.max(1) {
        let r = (k as f32 + 0.5) / count.max(1) as f32;
        push_triangle(&mut vertices, [Vec3::new(0.0, 0.0, r), Vec3::new(1.0, 0.0, r), Vec3::new(0.0, 1.0, r)], 0);
    }
    vertices
}

/// Moves `(u, v)` toward the cell's centre by [`FACE_INSET`] of the way.
fn inset(p: Vec2) -> Vec2 {
    p + (Vec2::splat(1.0 / 3.0) - p) * FACE_INSET
}

/// The prism's faces as triangles with their codes.
fn faces() -> Vec<([Vec3; 3], u32)> {
    let corners = [Vec2::ZERO, Vec2::X, Vec2::Y];
    let mut out = vec![(corners.map(|c| c.extend(0.0)), FACE_BASE), (corners.map(|c| c.extend(1.0)), FACE_TOP)];
    for (a, b, face) in [(2, 0, FACE_U0), (0, 1, FACE_V0), (1, 2, FACE_W0)] {
        // A fan around the face's centre: the same four triangles whichever way round
        // the neighbour lists the edge, so its copy of a twisted (non-planar) side face
        // stays parallel to this one instead of crossing it along the other diagonal.
        let (a, b) = (corners[a], corners[b]);
        let ring = [a.extend(0.0), b.extend(0.0), b.extend(1.0), a.extend(1.0)];
        let centre = ((a + b) * 0.5).extend(0.5);
        for k in 0..4 {
            out.push(([ring[k], ring[(k + 1) % 4], centre], face));
        }
    }
    out
}

fn push_triangle(out: &mut Vec<[f32; 4]>, tri: [Vec3; 3], tag: u32) {
    out.extend(tri.map(|p| [p.x, p.y, p.z, tag as f32]));
}

/// The section between base points `a` and `b` (in `(u, v)`), from `r = 0` to `r = 1`.
fn push_quad(out: &mut Vec<[f32; 4]>, a: Vec2, b: Vec2, tag: u32) {
    let (a0, b0, b1, a1) = (a.extend(0.0), b.extend(0.0), b.extend(1.0), a.extend(1.0));
    push_triangle(out, [a0, b0, b1], tag);
    push_triangle(out, [a0, b1, a1], tag);
}

/// The cells grouped by family for one frame: cell indices, family by family, and
/// how many cells each family has.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Grouping {
    pub order: Vec<u32>,
    pub counts: [u32; 4],
}

impl Grouping {
    /// The instance range of `family` in [`Grouping::order`].
    pub fn range(&self, family: Family) -> Range<u32> {
        let start: u32 = self.counts[..family as usize].iter().sum();
        start..start + self.counts[family as usize]
    }
}

/// Chooses every cell's family (in parallel) and groups the cells by it.
pub fn group_cells(cells: &[CellMap], eye: Eye) -> Grouping {
    let families: Vec<Family> = cells.par_iter().with_min_len(1024).map(|c| choose_family(c, eye)).collect();
    let mut counts = [0u32; 4];
    for f in &families {
        counts[*f as usize] += 1;
    }
    let mut next = [0u32, counts[0], counts[0] + counts[1], counts[0] + counts[1] + counts[2]];
    let mut order = vec![0u32; cells.len()];
    for (i, f) in families.iter().enumerate() {
        order[next[*f as usize] as usize] = i as u32;
        next[*f as usize] += 1;
    }
    Grouping { order, counts }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A prism over the unit right triangle, thickness `h`, straight directors.
    fn prism(h: f32) -> CellMap {
        CellMap {
            count: 3,
            base: [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::ZERO],
            director: [Vec3::Z * h, Vec3::Z * h, Vec3::Z * h, Vec3::ZERO],
            st: [Vec2::ZERO, Vec2::X, Vec2::Y, Vec2::ZERO],
        }
    }

    #[test]
    fn families_follow_the_view() {
        let cell = prism(1.0);
        let from = |d: Vec3| choose_family(&cell, Eye::Direction(d));
        assert_eq!(from(Vec3::NEG_Z), Family::R);
        assert_eq!(from(Vec3::X), Family::U);
        assert_eq!(from(Vec3::NEG_Y), Family::V);
        assert_eq!(from(Vec3::new(1.0, 1.0, 0.1)), Family::W);
        // A point eye: the direction to the cell's centre counts.
        assert_eq!(choose_family(&cell, Eye::Point(Vec3::new(0.3, 0.3, 10.0))), Family::R);
        // A thin shell keeps its layers until the view is nearly tangent.
        let thin = prism(0.05);
        assert_eq!(choose_family(&thin, Eye::Direction(Vec3::new(1.0, 0.0, -0.2))), Family::R);
        assert_eq!(choose_family(&thin, Eye::Direction(Vec3::new(1.0, 0.0, -0.01))), Family::U);
        // Degenerate: layers.
        assert_eq!(choose_family(&prism(0.0), Eye::Direction(Vec3::X)), Family::R);
        assert_eq!(choose_family(&cell, Eye::Direction(Vec3::NAN)), Family::R);
    }

    #[test]
    fn templates_slice_the_prism() {
        for m in [2, 3, 8, 32] {
            let t = templates(m);
            assert_eq!(t.slices, m);
            assert_eq!(t.vertices.len() % 3, 0);
            // Layers: m - 2 triangles; sections: two each; plus 2 + 3 x 4 face triangles.
            assert_eq!(t.ranges[0].len() as u32, 3 * (m - 2 + 14));
            for f in 1..4 {
                assert_eq!(t.ranges[f].len() as u32, 3 * (2 * (m - 2) + 14));
            }
            assert_eq!(t.ranges[3].end as usize, t.vertices.len());
            let d = FACE_INSET / 3.0;
            for (i, v) in t.vertices.iter().enumerate() {
                let (u, w, r) = (v[0], v[1], v[2]);
                assert!(u >= d - 1e-6 && w >= d - 1e-6 && u + w <= 1.0 - d + 1e-6 && (0.0..=1.0).contains(&r), "{v:?}");
                let family = t.ranges.iter().position(|range| range.contains(&(i as u32))).unwrap();
                assert_eq!(v[3] as u32 / 8, family as u32);
                let face = v[3] as u32 % 8;
                // Side faces sit FACE_INSET / 3 inside the prism, everything else within.
                match face {
                    FACE_U0 => assert!((u - d).abs() < 1e-6),
                    FACE_V0 => assert!((w - d).abs() < 1e-6),
                    FACE_W0 => assert!((1.0 - u - w - d).abs() < 1e-6),
                    FACE_BASE => assert_eq!(r, 0.0),
                    FACE_TOP => assert_eq!(r, 1.0),
                    _ => assert_eq!(face, 0),
                }
            }
            // Interior layers are evenly spaced.
            let r = t.ranges[0].start as usize..t.ranges[0].end as usize;
            let layers: Vec<f32> = t.vertices[r].iter().filter(|v| v[3] == 0.0).map(|v| v[2]).collect();
            for (k, r) in layers.chunks(3).enumerate() {
                assert!((r[0] - (k + 1) as f32 / (m - 1) as f32).abs() < 1e-6);
            }
            // A section u = p: its vertices have u = p moved inward.
            let r = t.ranges[1].start as usize..t.ranges[1].end as usize;
            let first = t.vertices[r][0];
            let p = 1.0 / (m - 1) as f32;
            assert!(m == 2 || (first[0] - (p + (1.0 / 3.0 - p) * FACE_INSET)).abs() < 1e-6, "{first:?}");
        }
        assert_eq!(templates(0).slices, MIN_SLICES);
        assert_eq!(templates(1 << 20).slices, MAX_SLICES);
    }

    #[test]
    fn cells_are_grouped_by_family() {
        let cells: Vec<CellMap> = (0..10)
            .map(|i| {
                let mut c = prism(1.0);
                c.base = c.base.map(|b| b + Vec3::X * 3.0 * i as f32);
                c
            })
            .collect();
        // An eye far along +x: the cells in front of it are seen along x (family U).
        let g = group_cells(&cells, Eye::Point(Vec3::new(100.0, 0.3, 0.5)));
        assert_eq!(g.counts, [0, 10, 0, 0]);
        let g = group_cells(&cells, Eye::Direction(Vec3::NEG_Z));
        assert_eq!(g.counts, [10, 0, 0, 0]);
        assert_eq!(g.range(Family::R), 0..10);
        assert_eq!(g.range(Family::U), 10..10);
        let mut sorted = g.order.clone();
        sorted.sort();
        assert_eq!(sorted, (0..10).collect::<Vec<u32>>());
    }
}
