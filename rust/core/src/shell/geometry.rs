//! Shell geometry from base mesh + directors: offset layers, the outer surface, and
//! the closed solid (outer surface + reversed base + rim quads along boundaries).

use crate::mesh::{boundary_edges, vertex_normals};
use crate::{Error, Mesh, Result};
use glam::Vec3;

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

/// Generated shell geometry, with per-vertex provenance so callers can attach
/// attributes (directors, thickness) without recomputing anything.
#[derive(Debug, Clone)]
pub struct ShellMesh {
    pub mesh: Mesh,
    /// Base-mesh vertex each output vertex comes from.
    pub source_vertex: Vec<u32>,
    /// Shell parameter r of each output vertex (0 = base, 1 = outer surface).
    pub layer: Vec<f32>,
}

/// Largest number of layers one request may ask for.
pub const MAX_LAYERS: u32 = 256;

/// Builds the requested geometry. Loose vertices are left out. When the directors point
/// to the back side of the surface on the whole (inward offset), faces are flipped so
/// that solids still face outward.
pub fn build_geometry(mesh: &Mesh, directors: &[Vec3], output: ShellOutput) -> Result<ShellMesh> {
    mesh.require_faces()?;
    if directors.len() != mesh.vertex_count() {
        return Err(Error::InvalidParameter(format!(
            "{} directors given for {} vertices",
            directors.len(),
            mesh.vertex_count()
        )));
    }
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
        ShellOutput::Layers(n) if n == 0 || n > MAX_LAYERS => {
            return Err(Error::InvalidParameter(format!("layer count must be 1..={MAX_LAYERS}, got {n}")))
        }
        ShellOutput::Layers(n) => (1..=n).map(|k| k as f32 / n as f32).collect(),
    };

    let nv = used.len();
    let mut positions = Vec::with_capacity(nv * layers.len());
    let mut source_vertex = Vec::with_capacity(nv * layers.len());
    let mut layer = Vec::with_capacity(nv * layers.len());
    for &r in &layers {
        for &v in &used {
            positions.push(mesh.positions()[v as usize] + r * directors[v as usize]);
            source_vertex.push(v);
            layer.push(r);
        }
    }

    let mut sizes = Vec::new();
    let mut corners = Vec::new();
    for (k, &r) in layers.iter().enumerate() {
        // In a solid the base layer (r = 0) faces the other way than the outer layer.
        let reverse = flip ^ (output == ShellOutput::Solid && r == 0.0);
        let base = (k * nv) as u32;
        for face in mesh.faces() {
            sizes.push(face.len() as u32);
            let mapped = face.iter().map(|&v| base + remap[v as usize]);
            if reverse {
                corners.extend(mapped.rev());
            } else {
                corners.extend(mapped);
            }
        }
    }
    if output == ShellOutput::Solid {
        let (outer, inner) = (0u32, nv as u32);
        for (a, b) in boundary_edges(mesh) {
            let (a, b) = (remap[a as usize], remap[b as usize]);
            let quad = if flip {
                [inner + b, inner + a, outer + a, outer + b]
            } else {
                [inner + a, inner + b, outer + b, outer + a]
            };
            sizes.push(4);
            corners.extend(quad);
        }
    }
    let mesh = Mesh::new(positions, &sizes, corners, None)?;
    Ok(ShellMesh { mesh, source_vertex, layer })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::fixtures::{cube, grid};
    use crate::shell::normal_offset_directors;

    /// Signed volume by the divergence theorem; positive for outward-facing closed meshes.
    fn volume(m: &Mesh) -> f32 {
        let p = m.positions();
        m.triangulate()
            .triangles
            .iter()
            .map(|t| p[t[0] as usize].dot(p[t[1] as usize].cross(p[t[2] as usize])) / 6.0)
            .sum()
    }

    #[test]
    fn open_grid_solid_is_closed_and_outward() {
        let m = grid(3);
        let d = normal_offset_directors(&m, &vec![0.5; m.vertex_count()]);
        let s = build_geometry(&m, &d, ShellOutput::Solid).unwrap();
        assert!(s.mesh.report().is_closed_manifold());
        assert!((volume(&s.mesh) - 9.0 * 0.5).abs() < 1e-4, "{}", volume(&s.mesh));
    }

    #[test]
    fn inward_grid_solid_still_outward() {
        let m = grid(2);
        let d = normal_offset_directors(&m, &vec![-0.25; m.vertex_count()]);
        let s = build_geometry(&m, &d, ShellOutput::Solid).unwrap();
        assert!(s.mesh.report().is_closed_manifold());
        assert!((volume(&s.mesh) - 4.0 * 0.25).abs() < 1e-4);
    }

    #[test]
    fn cube_solid_is_two_closed_shells_with_wall_volume() {
        let m = cube();
        let d: Vec<Vec3> = m.positions().iter().map(|p| *p * 0.2).collect(); // scale cube by 1.2
        let s = build_geometry(&m, &d, ShellOutput::Solid).unwrap();
        assert!(s.mesh.report().is_closed_manifold());
        assert!((volume(&s.mesh) - (1.2f32.powi(3) - 1.0)).abs() < 1e-4);
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
}
