//! Artificial boundary faces (section 4.3.2): near an open boundary the averaged field
//! turns outward; one extra vertex per boundary vertex, displaced across the boundary
//! along the surface's tangent by the shell thickness, and a quad per boundary edge
//! (two triangles) make the field behave as if the surface continued.

use glam::{DVec3, Vec3};

/// Extension triangles along the directed open-boundary `edges` (two per edge, in
/// order; none for closed meshes). `normals` are unit vertex normals, `reach[v]` the
/// extension length at vertex `v`.
pub fn extension_faces(edges: &[(u32, u32)], p: &[Vec3], normals: &[Vec3], reach: &[f32]) -> Vec<[DVec3; 3]> {
    if edges.is_empty() {
        return Vec::new();
    }
    let mut across = vec![Vec3::ZERO; p.len()];
    for &(a, b) in edges {
        let (a, b) = (a as usize, b as usize);
        // The face lies to the left of a -> b (counter-clockwise about n): outward is right.
        let out = (p[b] - p[a]).cross(normals[a] + normals[b]).normalize_or_zero();
        across[a] += out;
        across[b] += out;
    }
    let mut count = vec![0u32; p.len()];
    for &(a, b) in edges {
        count[a as usize] += 1;
        count[b as usize] += 1;
    }
    // At a corner (two boundary edges) the sum of the two unit perpendiculars is
    // stretched to the miter length, so the extension quads also fill the corner.
    let ext = |v: usize| -> DVec3 {
        let s = across[v];
        let miter = if count[v] == 2 && s.length() > 0.5 { (2.0 / s.length()).min(3.0) } else { 1.0 };
        (p[v] + s.normalize_or_zero() * (reach[v].abs() * miter)).as_dvec3()
    };
    let mut tris = Vec::with_capacity(2 * edges.len());
    for &(a, b) in edges {
        let (a, b) = (a as usize, b as usize);
        let (pa, pb) = (p[a].as_dvec3(), p[b].as_dvec3());
        let (qa, qb) = (ext(a), ext(b));
        tris.push([pb, pa, qa]);
        tris.push([pb, qa, qb]);
    }
    tris
}
