//! Shell geometry from base mesh + directors: offset layers, the outer surface, and
//! the closed solid (outer surface + reversed base + rim quads along boundaries).

use super::Shell;
use crate::mesh::{boundary_edges, vertex_normals};
use crate::{Error, Mesh, Result};
use glam::{DVec3, Vec3};

/// What to build from a shell.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ShellOutput {
    /// The surface at r = 1 only.
    Outer,
    /// Layers r = k/N for k = 1..=N, each a copy of the base faces.
    Layers(u32),
    /// A closed solid: outer surface, base surface reversed, rims along open boundaries.
    Solid,
}

impl ShellOutput {
    /// `"outer"`, `"solid"` or `"layers"` (then `layers` copies).
    pub fn parse(s: &str, layers: u32) -> crate::Result<Self> {
        match s {
            "outer" => Ok(ShellOutput::Outer),
            "solid" => Ok(ShellOutput::Solid),
            "layers" => Ok(ShellOutput::Layers(layers)),
            other => Err(crate::Error::InvalidParameter(format!("output must be 'outer', 'solid' or 'layers', not {other:?}"))),
        }
    }
}

/// Generated shell geometry, with per-vertex provenance so callers can attach
/// attributes (directors, thickness) without recomputing anything.
#[derive(Debug, Clone)]
pub struct ShellMesh {
    pub mesh: Mesh,
    /// Base-mesh vertex each output vertex comes from.
    pub source_vertex: Vec<u32>,
    /// Shell parameter r of each output vertex (0 = base, 1 = outer surface).
    pub layer: Vec<f32>,
    /// Base-mesh face corner each output face corner comes from (a rim's corners: the
    /// corners of the face along that boundary edge), so UV maps carry over.
    pub source_corner: Vec<u32>,
    /// Base-mesh face each output face comes from (a rim: the face along its edge),
    /// so material indices carry over.
    pub source_face: Vec<u32>,
}

/// Largest number of layers one request may ask for.
pub const MAX_LAYERS: u32 = 256;

/// Builds the requested geometry. Loose vertices are left out. When the directors point
/// to the back side of the surface on the whole (inward offset), faces are flipped so
/// that solids still face outward.
pub fn build_geometry(mesh: &Mesh, directors: &[Vec3], output: ShellOutput) -> Result<ShellMesh> {
    check_len(mesh, directors.len(), "directors")?;
    let p = mesh.positions();
    layered_geometry(mesh, directors, output, |v, r| p[v] + r * directors[v])
}

/// Builds the requested geometry of a [`Shell`]: layer r of vertex v at
/// `position + base_offset + r * director` (so `Solid` spans the whole envelope).
pub fn shell_geometry(mesh: &Mesh, shell: &Shell, output: ShellOutput) -> Result<ShellMesh> {
    check_len(mesh, shell.directors.len(), "directors")?;
    check_len(mesh, shell.base_offset.len(), "base offsets")?;
    let p = mesh.positions();
    layered_geometry(mesh, &shell.directors, output, |v, r| shell.point(p, v, r))
}

fn check_len(mesh: &Mesh, n: usize, what: &str) -> Result<()> {
    mesh.require_faces()?;
    if n != mesh.vertex_count() {
        return Err(Error::InvalidParameter(format!("{n} {what} given for {} vertices", mesh.vertex_count())));
    }
    Ok(())
}

/// Shared by [`build_geometry`] and [`shell_geometry`]: `at(v, r)` places layer r of v.
fn layered_geometry(mesh: &Mesh, directors: &[Vec3], output: ShellOutput, at: impl Fn(usize, f32) -> Vec3) -> Result<ShellMesh> {
    // Compact numbering of the vertices that faces use, in base-mesh order (so layer
    // vertex k is base vertex k when there are no loose vertices, as in Solidify).
    let mut is_used = vec![false; mesh.vertex_count()];
    mesh.corners().iter().for_each(|&v| is_used[v as usize] = true);
    let used: Vec<u32> = (0..mesh.vertex_count() as u32).filter(|&v| is_used[v as usize]).collect();
    let mut remap = vec![u32::MAX; mesh.vertex_count()];
    used.iter().enumerate().for_each(|(i, &v)| remap[v as usize] = i as u32);
    let normals = vertex_normals(mesh);
    let outward: f32 = used.iter().map(|&v| directors[v as usize].dot(normals[v as usize])).sum();
    let flip = outward < 0.0;

    let layers: Vec<f32> = match output {
        ShellOutput::Outer => vec![1.0],
        ShellOutput::Solid => vec![1.0, 0.0],
        ShellOutput::Layers(n) if n == 0 || n > MAX_LAYERS => return Err(Error::InvalidParameter(format!("layer count must be 1..={MAX_LAYERS}, got {n}"))),
        ShellOutput::Layers(n) => (1..=n).map(|k| k as f32 / n as f32).collect(),
    };

    let nv = used.len();
    let mut positions = Vec::with_capacity(nv * layers.len());
    let mut source_vertex = Vec::with_capacity(nv * layers.len());
    let mut layer = Vec::with_capacity(nv * layers.len());
    for &r in &layers {
        for &v in &used {
            positions.push(at(v as usize, r));
            source_vertex.push(v);
            layer.push(r);
        }
    }

    let polygons = written_polygons(mesh);
    let mut sizes = Vec::new();
    let mut corners = Vec::new();
    let mut source_corner = Vec::new();
    let mut source_face = Vec::new();
    for (k, &r) in layers.iter().enumerate() {
        // In a solid the base layer (r = 0) faces the other way than the outer layer.
        let reverse = flip ^ (output == ShellOutput::Solid && r == 0.0);
        let base = (k * nv) as u32;
        for (f, from) in polygons.iter() {
            sizes.push(from.len() as u32);
            source_face.push(f);
            // Reversed from the first corner on (`0 k-1 .. 1`), so that Blender splits
            // a quad along the same diagonal as the base's (`blender_quad_flips`).
            let at = |c: &u32| base + remap[mesh.corners()[*c as usize] as usize];
            if reverse {
                let order = from[..1].iter().chain(from[1..].iter().rev());
                corners.extend(order.clone().map(at));
                source_corner.extend(order);
            } else {
                corners.extend(from.iter().map(at));
                source_corner.extend(from);
            }
        }
    }
    if output == ShellOutput::Solid {
        let (outer, inner) = (0u32, nv as u32);
        // The face and corners along each boundary edge: (face, corner of a, corner of b).
        let mut along = std::collections::HashMap::new();
        for (f, face) in mesh.faces().enumerate() {
            let start = mesh.face_corner_range(f).start as u32;
            for i in 0..face.len() {
                let j = (i + 1) % face.len();
                along.insert((face[i], face[j]), (f as u32, start + i as u32, start + j as u32));
            }
        }
        let closed = welded_seam_edges(mesh, &at);
        for (a, b) in boundary_edges(mesh) {
            if closed.as_ref().is_some_and(|closed| closed(a, b)) {
                continue; // a split seam the layers close: no walls inside the solid
            }
            let (f, ca, cb) = along.get(&(a, b)).copied().or_else(|| along.get(&(b, a)).map(|&(f, cb, ca)| (f, ca, cb))).unwrap_or((0, 0, 0));
            let (a, b) = (remap[a as usize], remap[b as usize]);
            let (quad, from) = if flip {
                ([inner + b, inner + a, outer + a, outer + b], [cb, ca, ca, cb])
            } else {
                ([inner + a, inner + b, outer + b, outer + a], [ca, cb, cb, ca])
            };
            sizes.push(4);
            corners.extend(quad);
            source_corner.extend(from);
            source_face.push(f);
        }
    }
    let mesh = Mesh::new(positions, &sizes, corners, None)?;
    Ok(ShellMesh { mesh, source_vertex, layer, source_corner, source_face })
}

/// The polygons each layer is written with, as the base corners they come from: faces
/// of up to four corners as they are, larger ones as the triangles of
/// [`Mesh::triangulate`] (Blender's own split of the base's n-gon), the split the
/// shell's cells are checked over ([`prisms`]). Written as n-gons, a skin's would be
/// split by Blender by the skin's own shape, over which a cell the check passed can
/// fold (a hexagon of a public 32 k-vertex scan, exterior 10%); quads stay, as the
/// check covers both of their splits ([`Cell::blender_splits_cross`]).
struct WrittenPolygons {
    faces: Vec<u32>,
    /// Where each polygon's corners start in `from`, and one past the last.
    starts: Vec<usize>,
    from: Vec<u32>,
}

impl WrittenPolygons {
    fn push(&mut self, face: usize, from: impl IntoIterator<Item = u32>) {
        self.from.extend(from);
        self.faces.push(face as u32);
        self.starts.push(self.from.len());
    }
    fn iter(&self) -> impl Iterator<Item = (u32, &[u32])> + '_ {
        self.faces.iter().zip(self.starts.windows(2)).map(|(&f, w)| (f, &self.from[w[0]..w[1]]))
    }
}

fn written_polygons(mesh: &Mesh) -> WrittenPolygons {
    let mut out = WrittenPolygons { faces: Vec::with_capacity(mesh.face_count()), starts: vec![0], from: Vec::with_capacity(mesh.corners().len()) };
    let tri = mesh.faces().any(|face| face.len() > 4).then(|| mesh.triangulate());
    let mut t = 0;
    for (f, face) in mesh.faces().enumerate() {
        let range = mesh.face_corner_range(f);
        let n = tri.as_ref().map_or(0, |tri| tri.face_of_triangle[t..].iter().take_while(|&&g| g as usize == f).count());
        match &tri {
            Some(tri) if face.len() > 4 => {
                let corner = |v: u32| (range.start + face.iter().position(|&u| u == v).expect("a triangle of the face")) as u32;
                for triangle in &tri.triangles[t..t + n] {
                    out.push(f, triangle.map(corner));
                }
            }
            _ => out.push(f, range.map(|c| c as u32)),
        }
        t += n;
    }
    out
}

/// For a base with split seams ([`Mesh::weld_coincident`]) whose copies share their
/// layers' points (a shell built welded), whether a boundary edge of the base is a
/// seam edge, interior once welded: its rim would be a wall inside the solid,
/// doubled by its copy's facing the other way. `None` without such seams.
fn welded_seam_edges(mesh: &Mesh, at: &impl Fn(usize, f32) -> Vec3) -> Option<impl Fn(u32, u32) -> bool> {
    let weld = mesh.weld_coincident()?;
    let leads = weld.leads();
    if !weld.copies_agree(&leads, |v, lead| [0.0, 1.0].iter().all(|&r| at(v, r) == at(lead, r))) {
        return None; // copies apart (an offset shell's own normals): rims close the gap
    }
    let open: std::collections::HashSet<(u32, u32)> = boundary_edges(&weld.mesh).into_iter().map(|(a, b)| (a.min(b), a.max(b))).collect();
    Some(move |a: u32, b: u32| {
        let (a, b) = (weld.of[a as usize], weld.of[b as usize]);
        !open.contains(&(a.min(b), a.max(b)))
    })
}

/// One volumetric cell of a shell: the slab over one base face (chapter 3.1, "each
/// slab is a deformation of a prism"). `vertices` are base-mesh vertex ids; the cell's
/// corners are those vertices at r = 0 followed by the same vertices at r = 1.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Cell {
    /// Base face the cell lies over.
    pub face: u32,
    /// 3 (triangle prism) or 4 (hexahedron) base vertices; `vertices[3]` unused for prisms.
    pub vertices: [u32; 4],
    pub count: u8,
}

impl Cell {
    pub fn is_hexahedron(&self) -> bool {
        self.count == 4
    }
    pub fn base(&self) -> &[u32] {
        &self.vertices[..self.count as usize]
    }
    /// Corner positions: r = 0 ring then r = 1 ring.
    pub fn corners(&self, positions: &[Vec3], shell: &Shell) -> Vec<Vec3> {
        let b = self.base();
        b.iter().map(|&v| shell.point(positions, v as usize, 0.0)).chain(b.iter().map(|&v| shell.point(positions, v as usize, 1.0))).collect()
    }
    /// Signed volumes (f64) of the tetrahedra of a fixed decomposition: each prism
    /// `(a b c | a' b' c')` into `(a b c a') (b c a' b') (c a' b' c')`; a hexahedron
    /// `(a b c d)` into the prisms over both splits of its base, `(a b c)`, `(a c d)`
    /// and `(b c d)`, `(b d a)` (whoever shows the shell may split it either way),
    /// each where its base triangle faces the way the quad does. Positive for a valid
    /// cell of an outward shell (base counter-clockwise seen from outside). A
    /// tetrahedron with two coincident corners (a zero director: the cell is pressed
    /// flat there) is reported as `None`.
    pub fn tet_volumes(&self, positions: &[Vec3], shell: &Shell) -> Vec<Option<f64>> {
        let vol = |t: [DVec3; 4]| {
            let flat = (0..4).any(|i| (i + 1..4).any(|j| t[i] == t[j]));
            (!flat).then(|| tet_volume(t))
        };
        self.tets(positions, shell).map(vol).collect()
    }

    /// The tetrahedra of [`tet_volumes`](Self::tet_volumes)' decomposition.
    fn tets<'a>(&self, positions: &'a [Vec3], shell: &Shell) -> impl Iterator<Item = [DVec3; 4]> + 'a {
        let (x, d) = self.rings(positions, shell);
        let top = move |q: usize| x[q] + d[q];
        self.upright_splits(positions).flat_map(move |[i, j, l]| [[x[i], x[j], x[l], top(i)], [x[j], x[l], top(i), top(j)], [x[l], top(i), top(j), top(l)]])
    }

    /// Each corner's base point (r = 0) and director (r = 1 minus r = 0), in double
    /// precision; unused slots of a prism are zero.
    fn rings(&self, positions: &[Vec3], shell: &Shell) -> ([DVec3; 4], [DVec3; 4]) {
        let (mut x, mut d) = ([DVec3::ZERO; 4], [DVec3::ZERO; 4]);
        for (q, &v) in self.base().iter().enumerate() {
            x[q] = shell.point(positions, v as usize, 0.0).as_dvec3();
            d[q] = shell.point(positions, v as usize, 1.0).as_dvec3() - x[q];
        }
        (x, d)
    }

    /// The base triangles the cell's checks split it over: a prism's own, or both
    /// splits of a hexahedron's base, `(a b c)`, `(a c d)` and `(b c d)`, `(b d a)`,
    /// each only where it faces the way the quad does. A base triangle of zero area
    /// has no inside to fold, and one facing away from its quad folds the base itself.
    fn upright_splits<'a>(&self, positions: &'a [Vec3]) -> impl Iterator<Item = [usize; 3]> + 'a {
        const QUAD: [[usize; 3]; 4] = [[0, 1, 2], [0, 2, 3], [1, 2, 3], [1, 3, 0]];
        const TRIANGLE: [[usize; 3]; 1] = [[0, 1, 2]];
        let splits: &'static [[usize; 3]] = if self.is_hexahedron() { &QUAD } else { &TRIANGLE };
        let vertices = self.vertices;
        let base_at = move |q: usize| positions[vertices[q] as usize].as_dvec3();
        let facing = match self.count {
            4 => crate::mesh::newell_normal(&vertices.map(|v| positions[v as usize])).as_dvec3(),
            _ => (base_at(1) - base_at(0)).cross(base_at(2) - base_at(0)),
        };
        splits.iter().copied().filter(move |t| {
            let base = t.map(base_at);
            (base[1] - base[0]).cross(base[2] - base[0]).dot(facing) > 0.0
        })
    }

    /// Whether `x` lies strictly inside the cell: inside a tetrahedron of its
    /// decomposition (of either split of a hexahedron's base, as
    /// [`tet_volumes`](Self::tet_volumes) checks both), in double precision. A cell
    /// pressed flat has no inside.
    pub fn encloses(&self, positions: &[Vec3], shell: &Shell, x: DVec3) -> bool {
        self.tets(positions, shell).any(|t| {
            let whole = tet_volume(t);
            whole != 0.0
                && (0..4).all(|i| {
                    let mut part = t;
                    part[i] = x;
                    tet_volume(part) * whole > 0.0
                })
        })
    }
    /// A cell is inverted when a tetrahedron of the fixed decomposition has a
    /// non-positive volume once oriented by the shell side (interior shells grow
    /// inward), in double precision. Tetrahedra pressed flat by a zero director do not
    /// count: a cell of zero height is the shell compressed to nothing there, not a
    /// fold (so zero thickness is always valid, which the final check relies on).
    ///
    /// The tetrahedra are not enough: the map a texture is drawn through,
    /// `P(u, v, r) = Σ b_i(u, v) (x_i + r d_i)` over each triangle of either split
    /// (chapter 3.1), can fold inside a cell whose tetrahedra are all upright, where
    /// its directors differ many times in length (found on public scans and CAD
    /// parts: bakes crossed themselves in such cells). So a cell is inverted too where
    /// that map's Jacobian is negative anywhere ([`Cell::map_folds`]), and where Blender
    /// would draw a skin crossing its base ([`Cell::blender_splits_cross`]).
    pub fn is_inverted(&self, positions: &[Vec3], shell: &Shell) -> bool {
        let s = shell.side.orientation() as f64;
        self.tet_volumes(positions, shell).iter().any(|v| v.is_some_and(|v| s * v <= 0.0))
            || self.map_folds(positions, shell)
            || self.blender_splits_cross(positions, shell)
    }

    /// Whether Blender draws a skin of this hexahedron (its layer at r = 0 or 1) and
    /// the base (the mesh as given) over different diagonals, and the skin then crosses
    /// the base inside the cell. Blender splits each quad by its own shape
    /// ([`blender_quad_flips`](crate::mesh::blender_quad_flips)), so a skin bent far
    /// from its base can take the other diagonal; the tetrahedra and the map check each
    /// split with both rings split alike. Found on a public scan: 40 such pairs at
    /// exterior 10%, skins pinned at one corner and long at the next.
    pub fn blender_splits_cross(&self, positions: &[Vec3], shell: &Shell) -> bool {
        if !self.is_hexahedron() {
            return false;
        }
        let base = self.vertices.map(|v| positions[v as usize]);
        let flips = crate::mesh::blender_quad_flips(base);
        let halves = |flip: bool| if flip { [[0, 1, 3], [1, 2, 3]] } else { [[0, 1, 2], [0, 2, 3]] };
        [0.0, 1.0].iter().any(|&r| {
            let ring = self.vertices.map(|v| shell.point(positions, v as usize, r));
            if ring == base || crate::mesh::blender_quad_flips(ring) == flips {
                return false;
            }
            halves(!flips)
                .iter()
                .any(|s| halves(flips).iter().any(|b| super::intersect::triangles_intersect(&s.map(|k| ring[k].as_dvec3()), &b.map(|k| base[k].as_dvec3()))))
        })
    }

    /// Whether the Jacobian of the cell's map `P(u, v, r)` over a triangle of either
    /// split of its base (those [`tet_volumes`](Self::tet_volumes) checks), oriented by
    /// the shell side, is negative somewhere in the cell. For a fixed `r` the map is
    /// affine in `(u, v)`, so `∂P/∂u × ∂P/∂v` is constant and `∂P/∂r = Σ b_i d_i` is
    /// affine: the Jacobian is least at a corner, where it is
    /// `q_m(r) = ((e_1 + r f_1) × (e_2 + r f_2)) · d_m`, a quadratic in `r`, least at
    /// `r = 0`, `r = 1` or its vertex. Exact up to double rounding; a zero director
    /// (a cell pressed flat at that corner) gives zero, not a fold.
    pub fn map_folds(&self, positions: &[Vec3], shell: &Shell) -> bool {
        let side = shell.side.orientation() as f64;
        let (x, d) = self.rings(positions, shell);
        self.upright_splits(positions).any(|[i, j, l]| {
            let (e1, f1, e2, f2) = (x[j] - x[i], d[j] - d[i], x[l] - x[i], d[l] - d[i]);
            let (n0, n1, n2) = (e1.cross(e2), e1.cross(f2) + f1.cross(e2), f1.cross(f2));
            [i, j, l].iter().any(|&m| {
                let (a, b, c) = (side * n0.dot(d[m]), side * n1.dot(d[m]), side * n2.dot(d[m]));
                let q = |r: f64| a + r * (b + r * c);
                let vertex = if c > 0.0 { -b / (2.0 * c) } else { -1.0 };
                q(0.0) < 0.0 || q(1.0) < 0.0 || (vertex > 0.0 && vertex < 1.0 && q(vertex) < 0.0)
            })
        })
    }
}

/// The signed volume of tetrahedron `t` (positive when `t[3]` lies on
/// the side of `t[0] t[1] t[2]` its counter-clockwise normal points to).
fn tet_volume(t: [DVec3; 4]) -> f64 {
    (t[1] - t[0]).cross(t[2] - t[0]).dot(t[3] - t[0]) / 6.0
}

/// The cells of a shell: triangle prisms over triangles, hexahedra over quads, and
/// prisms over the triangles of n-gons (split as in [`Mesh::triangulate`]): one cell
/// per polygon a shell result is written with ([`written_polygons`]).
pub fn prisms(mesh: &Mesh) -> Vec<Cell> {
    let corners = mesh.corners();
    written_polygons(mesh)
        .iter()
        .filter(|(_, from)| (3..=4).contains(&from.len()))
        .map(|(face, from)| {
            let mut vertices = [0; 4];
            vertices.iter_mut().zip(from).for_each(|(v, &c)| *v = corners[c as usize]);
            Cell { face, vertices, count: from.len() as u8 }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::fixtures::{cube, grid};
    use crate::shell::normal_offset_directors;

    #[test]
    fn open_grid_solid_is_closed_and_outward() {
        let m = grid(3);
        let d = normal_offset_directors(&m, &vec![0.5; m.vertex_count()]);
        let s = build_geometry(&m, &d, ShellOutput::Solid).unwrap();
        assert!(s.mesh.report().is_closed_manifold());
        assert!((s.mesh.signed_volume() - 9.0 * 0.5).abs() < 1e-4, "{}", s.mesh.signed_volume());
    }

    #[test]
    fn inward_grid_solid_still_outward() {
        let m = grid(2);
        let d = normal_offset_directors(&m, &vec![-0.25; m.vertex_count()]);
        let s = build_geometry(&m, &d, ShellOutput::Solid).unwrap();
        assert!(s.mesh.report().is_closed_manifold());
        assert!((s.mesh.signed_volume() - 4.0 * 0.25).abs() < 1e-4);
    }

    #[test]
    fn cube_solid_is_two_closed_shells_with_wall_volume() {
        let m = cube();
        let d: Vec<Vec3> = m.positions().iter().map(|p| *p * 0.2).collect(); // scale cube by 1.2
        let s = build_geometry(&m, &d, ShellOutput::Solid).unwrap();
        assert!(s.mesh.report().is_closed_manifold());
        assert!((s.mesh.signed_volume() - (1.2f32.powi(3) - 1.0)).abs() < 1e-4);
    }

    #[test]
    fn n_gons_are_written_as_the_triangles_their_cells_are_checked_over() {
        // A closed hexagonal prism whose hexagons zigzag out of plane: Blender would
        // split them its own way, so every layer writes the checked triangles instead;
        // quads and provenance stay as they were.
        let ring = |z: f32, zig: f32| {
            (0..6).map(move |k| {
                let a = k as f32 * std::f32::consts::TAU / 6.0;
                Vec3::new(a.cos(), a.sin(), z + if k % 2 == 0 { zig } else { -zig })
            })
        };
        let positions: Vec<Vec3> = ring(0.0, 0.15).chain(ring(1.0, 0.2)).collect();
        let mut corners: Vec<u32> = (0..6).rev().collect();
        corners.extend(6..12);
        for k in 0..6 {
            corners.extend([k, (k + 1) % 6, 6 + (k + 1) % 6, 6 + k]);
        }
        let mut sizes = vec![6, 6];
        sizes.extend([4; 6]);
        let m = Mesh::new(positions, &sizes, corners, None).unwrap();
        let d = normal_offset_directors(&m, &vec![0.1; m.vertex_count()]);
        let cells = prisms(&m);
        assert_eq!(cells.len(), 2 * 4 + 6);
        for output in [ShellOutput::Outer, ShellOutput::Solid, ShellOutput::Layers(3)] {
            let s = build_geometry(&m, &d, output).unwrap();
            assert!(s.mesh.faces().all(|f| f.len() <= 4));
            let layers = match output {
                ShellOutput::Layers(n) => n as usize,
                ShellOutput::Solid => 2,
                ShellOutput::Outer => 1,
            };
            assert_eq!(s.mesh.face_count(), layers * cells.len());
            // Every written corner comes from a base corner of the same vertex and face.
            for (f, face) in s.mesh.faces().enumerate() {
                for (k, &v) in face.iter().enumerate() {
                    let c = s.source_corner[s.mesh.face_corner_range(f).start + k] as usize;
                    assert_eq!(m.corners()[c], s.source_vertex[v as usize]);
                    assert!(m.face_corner_range(s.source_face[f] as usize).contains(&c));
                }
            }
            // The outer layer's polygons are the cells' bases, in order.
            for (cell, face) in cells.iter().zip(s.mesh.faces()) {
                let written: Vec<u32> = face.iter().map(|&v| s.source_vertex[v as usize]).collect();
                assert_eq!(&written[..], cell.base());
            }
            if output == ShellOutput::Solid {
                assert!(s.mesh.report().is_closed_manifold());
                assert!(s.mesh.signed_volume() > 0.0);
            }
        }
    }

    #[test]
    fn a_skin_that_blender_splits_the_other_way_may_not_cross_its_base() {
        // A cell of a public scan's exterior shell (10%) as built before this check
        // (its skin pinned at corner 3, long at 0 and 2): tetrahedra and map upright
        // for each split, but Blender splits the skin along 1-3 and the base along
        // 0-2, and there the skin's halves cross the base's.
        let base =
            [[-62.731304, 2.328666, 15.387598], [-62.62873, 2.812_173, 15.570518], [-63.170296, 2.862898, 15.040281], [-63.292_36, 2.484_942, 14.667986]];
        let directors =
            [[-0.7616215, -0.27686393, 0.8440895], [-0.05605139, -0.020082219, 0.071_717_92], [-0.91614574, -0.326_759_2, 0.650_471_8], [0.0, 0.0, 0.0]];
        let m = Mesh::new(base.map(Vec3::from_array).to_vec(), &[4], vec![0, 1, 2, 3], None).unwrap();
        let cell = prisms(&m)[0];
        let shell = |scale: f32| Shell::from_directors(vec![Vec3::ZERO; 4], directors.map(|d| Vec3::from_array(d) * scale).to_vec());
        let skin = |scale: f32| (0..4).map(|v| shell(scale).point(m.positions(), v, 1.0)).collect::<Vec<_>>();
        let flips = |q: &[Vec3]| crate::mesh::blender_quad_flips([q[0], q[1], q[2], q[3]]);
        assert!(!flips(m.positions()) && flips(&skin(1.0)));
        let s = shell(1.0);
        assert!(cell.tet_volumes(m.positions(), &s).iter().all(|v| v.is_none_or(|v| v > 0.0)) && !cell.map_folds(m.positions(), &s));
        assert!(cell.blender_splits_cross(m.positions(), &s) && cell.is_inverted(m.positions(), &s));
        // The same skin moved along as a whole (one split for both) and the cell
        // pressed flat are fine.
        let lifted = Shell::from_directors(vec![Vec3::ZERO; 4], vec![Vec3::new(-0.5, -0.2, 0.6); 4]);
        assert!(!cell.blender_splits_cross(m.positions(), &lifted) && !cell.blender_splits_cross(m.positions(), &shell(0.0)));
    }

    #[test]
    fn layers_and_provenance() {
        let m = grid(1);
        let d = vec![Vec3::Z; 4];
        let s = build_geometry(&m, &d, ShellOutput::Layers(4)).unwrap();
        assert_eq!(s.mesh.vertex_count(), 16);
        assert_eq!(s.mesh.face_count(), 4);
        assert_eq!(s.layer[4], 0.5);
        assert_eq!(s.mesh.positions()[4].z, 0.5);
        assert!(build_geometry(&m, &d, ShellOutput::Layers(0)).is_err());
        assert!(build_geometry(&m, &d[..3], ShellOutput::Outer).is_err());
    }
    #[test]
    fn a_cell_folds_where_its_maps_jacobian_turns_negative_even_with_upright_tetrahedra() {
        // Random prisms over a triangle facing +z, directors of lengths 0.02 to 1.5
        // leaning up to about 60 degrees: map_folds against the map's Jacobian by
        // central differences on a dense (u, v, r) grid (an independent reference).
        let mut rng = crate::test_rng::Rng(7);
        let positions = vec![Vec3::ZERO, Vec3::X, Vec3::Y];
        let cell = Cell { face: 0, vertices: [0, 1, 2, 0], count: 3 };
        let (mut folds, mut upright_but_folding, mut undecided) = (0, 0, 0);
        for _ in 0..3000 {
            let directors: Vec<Vec3> = (0..3)
                .map(|_| {
                    let lean = rng.vec(1.0).truncate().as_vec2() * 1.7;
                    lean.extend(1.0).normalize() * rng.range(0.02, 1.5) as f32
                })
                .collect();
            let shell = Shell::from_directors(vec![Vec3::ZERO; 3], directors.clone());
            let map = |u: f64, v: f64, r: f64| {
                let b = [1.0 - u - v, u, v];
                (0..3).map(|i| (positions[i].as_dvec3() + directors[i].as_dvec3() * r) * b[i]).sum::<DVec3>()
            };
            let h = 1e-5;
            let mut least = f64::INFINITY;
            for i in 0..=12 {
                for j in 0..=12 - i {
                    for k in 0..=24 {
                        let (u, v, r) = (i as f64 / 12.0, j as f64 / 12.0, k as f64 / 24.0);
                        let du = (map(u + h, v, r) - map(u - h, v, r)) / (2.0 * h);
                        let dv = (map(u, v + h, r) - map(u, v - h, r)) / (2.0 * h);
                        let dr = (map(u, v, r + h) - map(u, v, r - h)) / (2.0 * h);
                        least = least.min(du.cross(dv).dot(dr));
                    }
                }
            }
            let exact = cell.map_folds(&positions, &shell);
            // The grid misses folds thinner than its spacing: only clear cases count.
            if least < -1e-3 {
                assert!(exact, "a fold of {least} was missed: {directors:?}");
            } else if least > 1e-6 {
                assert!(!exact, "an upright map was called folded: {directors:?}");
            } else {
                undecided += 1;
            }
            folds += usize::from(exact);
            let tets_upright = cell.tet_volumes(&positions, &shell).iter().all(|v| v.is_some_and(|v| v > 0.0));
            upright_but_folding += usize::from(exact && tets_upright);
        }
        assert!(folds > 100 && upright_but_folding > 10, "{folds} folding, {upright_but_folding} of them with upright tetrahedra");
        assert!(undecided < 300, "{undecided}");
        // Such a cell is inverted; a cell pressed flat at one corner is not.
        let flat = Shell::from_directors(vec![Vec3::ZERO; 3], vec![Vec3::ZERO, Vec3::Z, Vec3::Z]);
        assert!(!cell.map_folds(&positions, &flat) && !cell.is_inverted(&positions, &flat));
    }
}
