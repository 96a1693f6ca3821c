//! Artificial boundary faces (section 4.3.2): near an open boundary the averaged field
//! turns outward; one extra vertex per boundary vertex, displaced across the boundary
//! along the surface's tangent by the shell thickness, and a quad per boundary edge
//! (two triangles) make the field behave as if the surface continued.

use glam::{DVec3, Vec3};

use crate::mesh::parts_of;

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
    let length = |v: usize| {
        let s = across[v];
        let miter = if count[v] == 2 && s.length() > 0.5 { (2.0 / s.length()).min(3.0) } else { 1.0 };
        reach[v].abs() * miter
    };
    let room = room_ahead(edges, p, &across, &length);
    let size = loop_size(edges, p);
    let ext = |v: usize| -> DVec3 { (p[v] + across[v].normalize_or_zero() * length(v).min(room[v]).min(size[v])).as_dvec3() };
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

/// Per vertex, the radius of a circle as long as its boundary loop (perimeter over
/// 2 pi; infinity off the boundary). An extension reaches no further than that
/// ([`extension_faces`]): a hole whose rims do not face each other ([`room_ahead`]:
/// a scan's eye socket or mouth, sunk into the surface, or a narrow tube's end)
/// used to keep extensions of the full reach, up to 3 times the thickness at its
/// corners (the miter), many times the hole's size, lying along the surface beside
/// it. The field needs the surface continued about as far as the hole is wide
/// (4.3.2). A sheet's outer boundary is capped too where the reach (the thickness
/// times the miter, up to 3) passes its loop's radius: a square sheet of side `s`
/// at its corners above a thickness of about 0.21 s, along its edges above 0.64 s.
/// Loops are the connected components of the boundary edges, so only boundary
/// positions enter (an edit away from the boundary leaves them as they were).
fn loop_size(edges: &[(u32, u32)], p: &[Vec3]) -> Vec<f32> {
    let pairs: Vec<[u32; 2]> = edges.iter().map(|&(a, b)| [a, b]).collect();
    let loops = parts_of(p.len(), pairs.iter().map(|e| e.as_slice()));
    let mut perimeter = vec![0.0f64; loops.count];
    for &(a, b) in edges {
        perimeter[loops.of[a as usize] as usize] += p[a as usize].distance(p[b as usize]) as f64;
    }
    let mut size = vec![f32::INFINITY; p.len()];
    for &(a, b) in edges {
        for v in [a, b] {
            size[v as usize] = (perimeter[loops.of[v as usize] as usize] / std::f64::consts::TAU) as f32;
        }
    }
    size
}

/// Boundary vertices this many steps apart along their boundary loop or closer do
/// not limit each other's extension ([`room_ahead`]): a hole's corner's neighbours
/// lie 45 degrees off its extension.
const LOOP_STEPS: usize = 1;

/// Two boundary vertices face each other when each lies within this angle (its
/// cosine, 60 degrees) of the other's extension. A narrower cone left 30 (41
/// degrees) to 100 (30 degrees) times more exact integrals over the extensions of
/// the open Stanford bunny's holes (measured without the facing condition).
const AHEAD_COS: f32 = 0.5;

/// Per vertex, half the distance to the nearest other boundary vertex facing it
/// ([`AHEAD_COS`]: each ahead of the other's extension), closer than twice
/// `length(v)` (where two facing extensions would overlap; a distance, so the same
/// whichever way the mesh is turned) and more than [`LOOP_STEPS`] steps away along
/// the boundary; infinity where none.
/// A sheet's edges do not face each other's vertices (a corner's extension is
/// diagonal, the edge's perpendicular to it): there the extension keeps its reach.
///
/// A hole narrower than the thickness (a scan's holes) has its rim's extensions
/// cross it and pile up over each other: every trajectory near the hole then
/// passes close to many of them, and the tree evaluates them exactly, one by one
/// (the open Stanford bunny traced 5x slower than with no extension at all).
/// Stopped half way to the rim facing them, the extensions meet in the hole and
/// fill it about once, which is what they are for (4.3.2: the field behaves as if
/// the surface continued). Only boundary positions and directions enter, so an
/// edit away from the boundary leaves the extension as it was.
fn room_ahead(edges: &[(u32, u32)], p: &[Vec3], across: &[Vec3], length: &dyn Fn(usize) -> f32) -> Vec<f32> {
    let mut room = vec![f32::INFINITY; p.len()];
    let mut on: Vec<u32> = edges.iter().flat_map(|&(a, b)| [a, b]).collect();
    on.sort_unstable();
    on.dedup();
    // Neighbours along the loops (both ways), to skip the rim's near vertices.
    let mut next: Vec<(u32, u32)> = edges.iter().flat_map(|&(a, b)| [(a, b), (b, a)]).collect();
    next.sort_unstable();
    let near = |v: u32| {
        let mut seen = vec![v];
        let mut ring = vec![v];
        for _ in 0..LOOP_STEPS {
            let step: Vec<u32> =
                ring.iter().flat_map(|&u| next[next.partition_point(|e| e.0 < u)..].iter().take_while(move |e| e.0 == u).map(|e| e.1)).collect();
            ring = step.into_iter().filter(|w| !seen.contains(w)).collect();
            seen.extend(&ring);
        }
        seen
    };
    let at = |v: u32| p[v as usize].as_dvec3();
    let tree = crate::spatial::Bvh::from_boxes(on.iter().map(|&v| (at(v), at(v))).collect());
    for &v in &on {
        let (dir, reach) = (across[v as usize].normalize_or_zero(), length(v as usize));
        if dir == Vec3::ZERO || !(reach > 0.0) {
            continue;
        }
        // Facing extensions overlap once their rims are closer than the two reaches.
        let (x, r) = (at(v), DVec3::splat(2.0 * reach as f64));
        let mut nearest = f32::INFINITY;
        let mut skip: Option<Vec<u32>> = None;
        tree.query(x - r, x + r, |k| {
            let w = on[k as usize];
            let d = p[w as usize] - p[v as usize];
            let l = d.length();
            if w != v
                && l < nearest
                && l < 2.0 * reach
                && d.dot(dir) > AHEAD_COS * l
                && -d.dot(across[w as usize].normalize_or_zero()) > AHEAD_COS * l
                && !skip.get_or_insert_with(|| near(v)).contains(&w)
            {
                nearest = l;
            }
        });
        room[v as usize] = 0.5 * nearest;
    }
    room
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{boundary_edges, vertex_normals};
    use crate::shell::report::shell_report;
    use crate::shell::{build_shell, ShellParams, Side, Thickness};
    use crate::{testmeshes, Mesh};

    /// A unit sphere with a round hole at the top, `radius` wide.
    fn holed_sphere(radius: f32) -> Mesh {
        let s = testmeshes::icosphere(4);
        let p = s.positions();
        let keep: Vec<[u32; 3]> = s
            .triangulate()
            .triangles
            .into_iter()
            .filter(|t| t.iter().map(|&v| p[v as usize]).sum::<Vec3>().normalize().z < (1.0 - radius * radius).sqrt())
            .collect();
        let mut used: Vec<u32> = keep.iter().flatten().copied().collect();
        used.sort_unstable();
        used.dedup();
        let renumber = |v: u32| used.binary_search(&v).unwrap() as u32;
        let tris: Vec<[u32; 3]> = keep.iter().map(|t| t.map(renumber)).collect();
        Mesh::from_triangles(used.iter().map(|&v| p[v as usize]).collect(), &tris).unwrap()
    }

    /// An open tube, `n` vertices around (radius 1) and `rows` rows of edges along z.
    fn tube(n: u32, rows: u32, length: f32) -> Mesh {
        let at = |i: u32, j: u32| (i % n) + j * n;
        let angle = |i: u32| std::f32::consts::TAU * i as f32 / n as f32;
        let p: Vec<Vec3> = (0..=rows).flat_map(|j| (0..n).map(move |i| Vec3::new(angle(i).cos(), angle(i).sin(), length * j as f32 / rows as f32))).collect();
        let tris: Vec<[u32; 3]> = (0..rows)
            .flat_map(|j| (0..n).flat_map(move |i| [[at(i, j), at(i + 1, j), at(i + 1, j + 1)], [at(i, j), at(i + 1, j + 1), at(i, j + 1)]]))
            .collect();
        Mesh::from_triangles(p, &tris).unwrap()
    }

    /// Issue 14 (the ogre scan's eye sockets: rims that do not face each other kept
    /// extensions of the full reach, up to 3 times the thickness, beside holes far
    /// smaller than that). A narrow tube's rims continue the tube and face nothing:
    /// their extensions reach at most the radius of the rim loop (perimeter over 2 pi),
    /// where they used to reach the full thickness, 6 times the tube's radius; a wide
    /// tube's rims keep the full reach; the narrow tube's shell is clean.
    #[test]
    fn extensions_of_a_hole_facing_nothing_are_capped_by_its_size() {
        let narrow = Mesh::from_triangles(
            tube(24, 40, 2.0).positions().iter().map(|q| Vec3::new(0.05 * q.x, 0.05 * q.y, q.z)).collect(),
            &tube(24, 40, 2.0).triangulate().triangles,
        )
        .unwrap();
        let perimeter: f32 =
            boundary_edges(&narrow).iter().map(|&(a, b)| narrow.positions()[a as usize].distance(narrow.positions()[b as usize])).sum::<f32>() / 2.0;
        let size = perimeter / std::f32::consts::TAU;
        let reach = 0.15 * narrow.bbox_diagonal();
        assert!(reach > 5.0 * size, "the tube must be narrower than the extension: {size} {reach}");
        let lengths = extension_lengths(&narrow, reach);
        assert!(lengths.iter().all(|&l| l > 0.5 * size && l <= size * (1.0 + 1e-4)), "extensions longer than the rim's radius {size}: {lengths:?}");

        let wide = tube(24, 4, 2.0);
        let reach = 0.15 * wide.bbox_diagonal();
        assert!(extension_lengths(&wide, reach).iter().all(|&l| l >= reach * (1.0 - 1e-5)), "a wide rim keeps its reach {reach}");

        let t = Thickness::relative(0.1).per_vertex(&narrow, None).unwrap();
        let shell = build_shell(&narrow, &t, Side::Exterior, &ShellParams::default()).unwrap();
        let r = shell_report(&narrow, &shell);
        assert!(shell.check.clean, "{r:?}");
        assert_eq!((r.outer_self_intersections, r.outer_base_intersections, r.inverted_cells), (0, 0, 0), "{r:?}");
    }

    /// How far each boundary vertex's extension reaches (its far corner's distance).
    fn extension_lengths(mesh: &Mesh, reach: f32) -> Vec<f32> {
        let edges = boundary_edges(mesh);
        let tris = extension_faces(&edges, mesh.positions(), &vertex_normals(mesh), &vec![reach; mesh.vertex_count()]);
        assert_eq!(tris.len(), 2 * edges.len());
        tris.chunks(2).map(|t| t[0][2].distance(t[0][1]) as f32).collect()
    }

    /// Issue 14 (scans with holes): the extensions of a hole narrower than the
    /// thickness stop half way to the rim ahead of them, where they used to cross the
    /// hole and pile up (the open Stanford bunny traced 6x slower than without them,
    /// nearly all of it exact integrals over its holes' extensions). Each reaches at
    /// most half the hole's width; across a wide open boundary (a sheet's edge,
    /// nothing ahead) the extension keeps the whole reach; and the shell over the
    /// holed sphere is clean.
    #[test]
    fn extensions_stop_half_way_across_a_narrow_hole() {
        let mesh = holed_sphere(0.25);
        let p = mesh.positions();
        let rim: Vec<u32> = boundary_edges(&mesh).iter().map(|e| e.0).collect();
        let width = rim.iter().flat_map(|&a| rim.iter().map(move |&b| p[a as usize].distance(p[b as usize]))).fold(0.0, f32::max);
        let reach = 0.1 * mesh.bbox_diagonal();
        assert!(reach > width * 0.5 && rim.len() >= 12, "the hole must be narrower than the extension: {width} {reach}");
        let lengths = extension_lengths(&mesh, reach);
        assert!(lengths.iter().all(|&l| l > 0.0 && l <= 0.5 * width + 1e-6), "extensions longer than half the hole {width}: {lengths:?}");

        let sheet = testmeshes::plane(8);
        let reach = 0.1 * sheet.bbox_diagonal();
        let lengths = extension_lengths(&sheet, reach);
        assert!(lengths.iter().all(|&l| l >= reach * (1.0 - 1e-5)), "a sheet's edge keeps its reach {reach}: {lengths:?}");

        let t = Thickness::relative(0.1).per_vertex(&mesh, None).unwrap();
        let shell = build_shell(&mesh, &t, Side::Exterior, &ShellParams::default()).unwrap();
        let r = shell_report(&mesh, &shell);
        assert!(shell.check.clean, "{r:?}");
        assert_eq!((r.outer_self_intersections, r.outer_base_intersections, r.inverted_cells), (0, 0, 0), "{r:?}");
    }
}
