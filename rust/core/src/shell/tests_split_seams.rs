//! Shells of bases with split seams (coincident vertices, as exports leave them):
//! built and updated as the welded surface they are.

use super::incremental::IncrementalShell;
use super::report::shell_report;
use super::*;
use crate::testmeshes as tm;
use crate::Mesh;
use glam::Vec3;

/// `mesh` with the faces above z = 0 given their own copies of the vertices they
/// share with the faces below: one surface, two parts by topology.
fn split_at_equator(mesh: &Mesh) -> Mesh {
    let upper: Vec<bool> = mesh.faces().map(|f| f.iter().map(|&v| mesh.positions()[v as usize].z).sum::<f32>() > 0.0).collect();
    let mut used_below = vec![false; mesh.vertex_count()];
    mesh.faces().zip(&upper).filter(|(_, &up)| !up).for_each(|(f, _)| f.iter().for_each(|&v| used_below[v as usize] = true));
    let mut positions = mesh.positions().to_vec();
    let mut copy = vec![u32::MAX; mesh.vertex_count()];
    let mut corners = Vec::new();
    for (f, &up) in mesh.faces().zip(&upper) {
        for &v in f {
            if up && used_below[v as usize] {
                if copy[v as usize] == u32::MAX {
                    copy[v as usize] = positions.len() as u32;
                    positions.push(positions[v as usize]);
                }
                corners.push(copy[v as usize]);
            } else {
                corners.push(v);
            }
        }
    }
    Mesh::new(positions, &mesh.face_sizes(), corners, None).unwrap()
}

fn thickness(mesh: &Mesh, frac: f32) -> Vec<f32> {
    Thickness::relative(frac).per_vertex(mesh, None).unwrap()
}

#[test]
fn a_split_seam_is_built_as_the_welded_surface_not_pressed_flat() {
    let whole = tm::icosphere(3);
    let split = split_at_equator(&whole);
    let seam = split.vertex_count() - whole.vertex_count();
    assert!(seam > 10 && crate::mesh::boundary_edges(&split).len() == 2 * seam, "the split leaves two boundaries along the seam");
    for side in [Side::Exterior, Side::Interior, Side::Envelope] {
        let at = |m: &Mesh| build_shell(m, &thickness(m, 0.1), side, &ShellParams::default()).unwrap();
        let (ours, reference) = (at(&split), at(&whole));
        // Each copy of a seam vertex has the welded vertex's director: the sphere's.
        for (v, p) in split.positions().iter().enumerate() {
            let w = whole.positions().iter().position(|q| q == p).unwrap();
            assert_eq!(ours.directors[v], reference.directors[w], "{side:?} vertex {v}");
            assert_eq!(ours.base_offset[v], reference.base_offset[w], "{side:?} vertex {v}");
        }
        let r = shell_report(&split, &ours);
        assert_eq!((r.outer_self_intersections, r.outer_base_intersections, r.inverted_cells), (0, 0, 0), "{side:?}: {r:?}");
        assert!(r.min_ratio > 0.99, "{side:?}: the seam keeps its thickness: {r:?}");
    }
}

#[test]
fn an_incremental_shell_keeps_its_seams_welded_and_rebuilds_when_they_part() {
    let split = split_at_equator(&tm::icosphere(3));
    let t = thickness(&split, 0.1);
    let mut inc = IncrementalShell::new(split.clone(), t.clone(), Side::Exterior, ShellParams::default()).unwrap();
    assert_eq!(inc.mesh(), &split);
    assert_eq!(inc.shell().directors.len(), split.vertex_count());
    // Both copies of a seam vertex pushed out together: a local update, and the same
    // shell as building the moved mesh anew, up to the update's tolerance.
    let v = (0..split.vertex_count()).find(|&v| split.positions()[v].z.abs() < 1e-6).unwrap();
    let copies: Vec<usize> = (0..split.vertex_count()).filter(|&u| split.positions()[u] == split.positions()[v]).collect();
    assert_eq!(copies.len(), 2);
    let mut moved = split.positions().to_vec();
    copies.iter().for_each(|&u| moved[u] *= 1.05);
    let stats = inc.update(&moved, &t).unwrap();
    assert!(!stats.rebuilt && stats.changed == 2, "{stats:?}");
    let mut edited = split.clone();
    copies.iter().for_each(|&u| edited.set_position(u, moved[u]).unwrap());
    let fresh = build_shell(&edited, &t, Side::Exterior, &ShellParams::default()).unwrap();
    let h = 0.1 * split.bbox_diagonal();
    let worst = inc.shell().directors.iter().zip(&fresh.directors).map(|(a, b)| (*a - *b).length()).fold(0.0, f32::max);
    assert!(worst <= 0.05 * h, "worst {worst} against h {h}");
    assert_eq!(inc.shell().directors[copies[0]], inc.shell().directors[copies[1]]);
    // One copy pulled away: the seam opens there, and the shell is rebuilt with it.
    moved[copies[1]] += Vec3::new(0.0, 0.0, 0.02);
    let stats = inc.update(&moved, &t).unwrap();
    assert!(stats.rebuilt, "{stats:?}");
    assert_eq!(inc.mesh().positions(), &moved[..]);
    let r = shell_report(inc.mesh(), inc.shell());
    assert_eq!((r.outer_self_intersections, r.outer_base_intersections, r.inverted_cells), (0, 0, 0), "{r:?}");
    // Put back onto its partner: the seam closes again, as a fresh build welds it.
    moved[copies[1]] = moved[copies[0]];
    let stats = inc.update(&moved, &t).unwrap();
    assert!(stats.rebuilt, "{stats:?}");
    let mut closed = split.clone();
    copies.iter().for_each(|&u| closed.set_position(u, moved[u]).unwrap());
    let fresh = build_shell(&closed, &t, Side::Exterior, &ShellParams::default()).unwrap();
    let worst = inc.shell().directors.iter().zip(&fresh.directors).map(|(a, b)| (*a - *b).length()).fold(0.0, f32::max);
    assert!(worst <= 0.05 * h, "worst {worst} against h {h}");
    assert_eq!(inc.shell().directors[copies[0]], inc.shell().directors[copies[1]]);
}

/// A vertex off the seam moved (each moved vertex alone at its position before and
/// after: the seams are not looked at again), then one moved onto another vertex
/// (a new coincidence: welding looks again and the shell is rebuilt welded there).
#[test]
fn an_incremental_shell_of_a_seamed_mesh_updates_lone_vertices_locally() {
    let split = split_at_equator(&tm::icosphere(3));
    let t = thickness(&split, 0.1);
    let mut inc = IncrementalShell::new(split.clone(), t.clone(), Side::Exterior, ShellParams::default()).unwrap();
    let lone = (0..split.vertex_count()).find(|&v| split.positions()[v].z > 0.5).unwrap();
    let mut moved = split.positions().to_vec();
    moved[lone] *= 1.05;
    let stats = inc.update(&moved, &t).unwrap();
    assert!(!stats.rebuilt && stats.changed == 1, "{stats:?}");
    assert_eq!(inc.mesh().positions(), &moved[..]);
    let mut edited = split.clone();
    edited.set_position(lone, moved[lone]).unwrap();
    let fresh = build_shell(&edited, &t, Side::Exterior, &ShellParams::default()).unwrap();
    let h = 0.1 * split.bbox_diagonal();
    let worst = inc.shell().directors.iter().zip(&fresh.directors).map(|(a, b)| (*a - *b).length()).fold(0.0, f32::max);
    assert!(worst <= 0.05 * h, "worst {worst} against h {h}");
    for v in 0..split.vertex_count() {
        let w = (0..split.vertex_count()).find(|&u| split.positions()[u] == split.positions()[v]).unwrap();
        assert_eq!(inc.shell().directors[v], inc.shell().directors[w], "seam copies {w} and {v} share their director");
    }
    // Onto a neighbour's position: a new coincidence, so the seams are welded anew,
    // as a fresh build would weld them (or leave them split where that would fault).
    let other = (0..split.vertex_count()).find(|&v| v != lone && split.positions()[v].z > 0.5).unwrap();
    moved[lone] = moved[other];
    let stats = inc.update(&moved, &t).unwrap();
    assert!(stats.rebuilt, "{stats:?}");
    assert_eq!(inc.mesh().positions(), &moved[..]);
}

#[test]
fn a_solid_over_a_split_seam_has_no_walls_inside() {
    let whole = tm::icosphere(3);
    let split = split_at_equator(&whole);
    let shell = build_shell(&split, &thickness(&split, 0.1), Side::Exterior, &ShellParams::default()).unwrap();
    let solid = shell_geometry(&split, &shell, ShellOutput::Solid).unwrap();
    let reference =
        shell_geometry(&whole, &build_shell(&whole, &thickness(&whole, 0.1), Side::Exterior, &ShellParams::default()).unwrap(), ShellOutput::Solid).unwrap();
    // The seam's rims (two coincident walls facing each other) are left out: the same
    // faces as the unsplit sphere's solid, none of them a rim.
    assert_eq!(solid.mesh.face_count(), reference.mesh.face_count());
    assert_eq!(solid.mesh.face_count(), 2 * split.face_count());
    // An offset shell's copies have their own normals: the rims close the crack.
    let offset = build_geometry(&split, &normal_offset_directors(&split, &thickness(&split, 0.1)), ShellOutput::Solid).unwrap();
    assert!(offset.mesh.face_count() > 2 * split.face_count());
}
