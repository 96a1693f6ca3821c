//! Texture coordinates in the shell (chapter 3.1): `(s, t)` from the mesh's UV map
//! times a tiling factor, `r` along the directors; and the cell map between a cell's
//! parameters, world space and texture space, for the baker and the renderer.

use crate::shell::Shell;
use crate::Mesh;
use glam::{Mat3, Vec2, Vec3};

/// `(s, t)` of every face corner (Blender's loops).
#[derive(Debug, Clone, PartialEq)]
pub struct TextureCoordinates {
    pub corner_st: Vec<Vec2>,
    /// True when the mesh had no UVs and each face got its own tile.
    pub per_face_tiles: bool,
}

impl TextureCoordinates {
    /// The mesh's UVs times `tiling`; without UVs, one tile per face: quads get the
    /// unit square, triangles half of it, n-gons a unit-square-inscribed polygon.
    pub fn of(mesh: &Mesh, tiling: f32) -> Self {
        match mesh.uvs() {
            Some(uv) => Self { corner_st: uv.iter().map(|u| *u * tiling).collect(), per_face_tiles: false },
            None => {
                let mut st = Vec::with_capacity(mesh.corners().len());
                for f in mesh.faces() {
                    match f.len() {
                        3 => st.extend([Vec2::ZERO, Vec2::X, Vec2::Y]),
                        4 => st.extend([Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y]),
                        n => st.extend((0..n).map(|i| {
                            let a = std::f32::consts::TAU * i as f32 / n as f32;
                            Vec2::new(0.5 + 0.5 * a.cos(), 0.5 + 0.5 * a.sin())
                        })),
                    }
                }
                Self { corner_st: st.into_iter().map(|u| u * tiling.round().max(1.0)).collect(), per_face_tiles: true }
            }
        }
    }
}

/// The shell's cells as triangles (quads and n-gons triangulated) with the `(s, t)`
/// of their corners: what the bake and the renderers map textures through.
#[derive(Debug, Clone, PartialEq)]
pub struct TriangleCells {
    pub triangles: Vec<[u32; 3]>,
    pub st: Vec<[Vec2; 3]>,
    /// The mesh face each triangle comes from.
    pub faces: Vec<u32>,
}

impl TriangleCells {
    pub fn new(mesh: &Mesh, coords: &TextureCoordinates) -> Self {
        let tri = mesh.triangulate();
        let mut st = Vec::with_capacity(tri.triangles.len());
        for (t, f) in tri.triangles.iter().zip(&tri.face_of_triangle) {
            let range = mesh.face_corner_range(*f as usize);
            let face = mesh.face(*f as usize);
            st.push(t.map(|v| coords.corner_st[range.start + face.iter().position(|c| *c == v).unwrap_or(0)]));
        }
        Self { triangles: tri.triangles, st, faces: tri.face_of_triangle }
    }

    /// The map of cell `t` of `shell`.
    pub fn cell(&self, mesh: &Mesh, shell: &Shell, t: usize) -> CellMap {
        CellMap::new(mesh, shell, &self.triangles[t], &self.st[t])
    }
}

/// One cell of the shell: a triangle prism (3 corners) or a quad hexahedron (4), with
/// its base points, directors and corner `(s, t)`. Parameters are `(u, v, r)`:
/// barycentric `(1-u-v, u, v)` on a triangle, bilinear on a quad, `r ∈ [0, 1]` along
/// the directors (the map is linear in `r` along each director: chapter 3.1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CellMap {
    pub count: usize,
    pub base: [Vec3; 4],
    pub director: [Vec3; 4],
    pub st: [Vec2; 4],
}

impl CellMap {
    /// The cell over `corners` (vertex indices of a triangle or quad) of `shell`.
    pub fn new(mesh: &Mesh, shell: &Shell, corners: &[u32], st: &[Vec2]) -> Self {
        let p = mesh.positions();
        let mut m = Self { count: corners.len().min(4), base: [Vec3::ZERO; 4], director: [Vec3::ZERO; 4], st: [Vec2::ZERO; 4] };
        for (k, &v) in corners.iter().take(4).enumerate() {
            m.base[k] = shell.point(p, v as usize, 0.0);
            m.director[k] = shell.directors[v as usize];
            m.st[k] = st[k];
        }
        m
    }

    /// Corner weights at `(u, v)`.
    #[inline]
    pub fn weights(&self, u: f32, v: f32) -> [f32; 4] {
        if self.count == 4 {
            [(1.0 - u) * (1.0 - v), u * (1.0 - v), u * v, (1.0 - u) * v]
        } else {
            [1.0 - u - v, u, v, 0.0]
        }
    }

    /// World position at `(u, v, r)`.
    pub fn world(&self, q: Vec3) -> Vec3 {
        let w = self.weights(q.x, q.y);
        (0..self.count).map(|k| (self.base[k] + self.director[k] * q.z) * w[k]).sum()
    }

    /// Texture coordinates `(s, t, r)` at `(u, v, r)`.
    pub fn texture(&self, q: Vec3) -> Vec3 {
        let w = self.weights(q.x, q.y);
        let st: Vec2 = (0..self.count).map(|k| self.st[k] * w[k]).sum();
        st.extend(q.z)
    }

    /// Jacobians of the world and texture maps with respect to `(u, v, r)` at `q`.
    pub fn jacobians(&self, q: Vec3) -> (Mat3, Mat3) {
        let (u, v) = (q.x, q.y);
        // d weights / du, d weights / dv.
        let (du, dv): ([f32; 4], [f32; 4]) =
            if self.count == 4 { ([-(1.0 - v), 1.0 - v, v, -v], [-(1.0 - u), -u, u, 1.0 - u]) } else { ([-1.0, 1.0, 0.0, 0.0], [-1.0, 0.0, 1.0, 0.0]) };
        let w = self.weights(u, v);
        let (mut pu, mut pv, mut pr, mut su, mut sv) = (Vec3::ZERO, Vec3::ZERO, Vec3::ZERO, Vec2::ZERO, Vec2::ZERO);
        for k in 0..self.count {
            let x = self.base[k] + self.director[k] * q.z;
            pu += x * du[k];
            pv += x * dv[k];
            pr += self.director[k] * w[k];
            su += self.st[k] * du[k];
            sv += self.st[k] * dv[k];
        }
        (Mat3::from_cols(pu, pv, pr), Mat3::from_cols(su.extend(0.0), sv.extend(0.0), Vec3::Z))
    }

    /// A texture-space gradient (of alpha) carried to world space at `q`: the chain
    /// rule through the parameters, `∇_world = J_world^{-T} J_texture^T ∇_texture`.
    pub fn gradient_to_world(&self, q: Vec3, g: Vec3) -> Vec3 {
        let (_, jt) = self.jacobians(q);
        self.parameter_gradient_to_world(q, jt.transpose() * g)
    }

    /// A gradient with respect to the parameters `(u, v, r)` carried to world space at
    /// `q`: `J_world^{-T} ∇_param`.
    pub fn parameter_gradient_to_world(&self, q: Vec3, gp: Vec3) -> Vec3 {
        let (jw, _) = self.jacobians(q);
        let det = jw.determinant();
        if det.abs() < 1e-20 || !det.is_finite() {
            return Vec3::ZERO;
        }
        jw.inverse().transpose() * gp
    }

    /// The parameters `(u, v, r)` of world point `x`, by Newton's method from the cell
    /// centre; `None` when it does not converge (a point far outside the cell).
    pub fn invert(&self, x: Vec3) -> Option<Vec3> {
        let mut q = if self.count == 4 { Vec3::new(0.5, 0.5, 0.5) } else { Vec3::new(1.0 / 3.0, 1.0 / 3.0, 0.5) };
        for _ in 0..20 {
            let e = self.world(q) - x;
            if e.length_squared() < 1e-14 * (1.0 + x.length_squared()) {
                return Some(q);
            }
            let (jw, _) = self.jacobians(q);
            if jw.determinant().abs() < 1e-20 {
                return None;
            }
            q -= jw.inverse() * e;
            if !q.is_finite() {
                return None;
            }
        }
        ((self.world(q) - x).length() < 1e-4 * (1.0 + x.length())).then_some(q)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shell::{build_shell, ShellParams, Side, Thickness};

    #[test]
    fn cell_maps_round_trip_and_carry_gradients() {
        let m = crate::mesh::fixtures::cube();
        let t = Thickness::relative(0.1).per_vertex(&m, None).unwrap();
        let s = build_shell(&m, &t, Side::Exterior, &ShellParams::default()).unwrap();
        let tc = TextureCoordinates::of(&m, 2.0);
        assert!(tc.per_face_tiles && tc.corner_st[2] == Vec2::splat(2.0));
        let r = m.face_corner_range(0);
        let cell = CellMap::new(&m, &s, m.face(0), &tc.corner_st[r]);
        for q in [Vec3::new(0.2, 0.7, 0.3), Vec3::new(0.9, 0.1, 0.95)] {
            let x = cell.world(q);
            assert!((cell.invert(x).unwrap() - q).length() < 1e-4);
            // Gradient carried to world agrees with finite differences of f(world) = g·texture(q(world)).
            let g = Vec3::new(0.3, -1.0, 2.0);
            let gw = cell.gradient_to_world(q, g);
            let f = |x: Vec3| g.dot(cell.texture(cell.invert(x).unwrap()));
            let h = 1e-3;
            let fd = Vec3::new(f(x + Vec3::X * h) - f(x - Vec3::X * h), f(x + Vec3::Y * h) - f(x - Vec3::Y * h), f(x + Vec3::Z * h) - f(x - Vec3::Z * h))
                / (2.0 * h);
            assert!((gw - fd).length() < 2e-2 * fd.length(), "{gw} vs {fd}");
        }
    }
}
