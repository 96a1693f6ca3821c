//! End-to-end shell tests on generated meshes (chapter 4 behaviour).

use super::report::shell_report;
use super::*;
use crate::testmeshes as tm;
use crate::Mesh;
use glam::Vec3;

fn shell_of(mesh: &Mesh, frac: f32, side: Side) -> (Shell, report::ShellReport) {
    let t = Thickness::relative(frac).per_vertex(mesh, None).unwrap();
    let start = std::time::Instant::now();
    let s = build_shell(mesh, &t, side, &ShellParams::default()).unwrap();
    let el = start.elapsed();
    let r = shell_report(mesh, &s);
    eprintln!("{} verts {side:?} {frac}: {el:?} {r:?}", mesh.vertex_count());
    (s, r)
}

fn assert_clean(name: &str, mesh: &Mesh) {
    for (frac, side) in [(0.1, Side::Exterior), (0.05, Side::Interior)] {
        let (_, r) = shell_of(mesh, frac, side);
        assert_eq!(r.outer_self_intersections, 0, "{name} {side:?}: {r:?}");
        assert_eq!(r.outer_base_intersections, 0, "{name} {side:?}: {r:?}");
        assert_eq!(r.inverted_cells, 0, "{name} {side:?}: {r:?}");
        assert!(r.min_ratio_normal_valid >= 0.95, "{name} {side:?}: {r:?}");
    }
}

#[test]
fn sphere_directors_are_normals_at_full_thickness() {
    let m = tm::icosphere(3);
    for side in [Side::Exterior, Side::Interior] {
        let (s, _) = shell_of(&m, 0.1, side);
        let h = 0.1 * m.bbox_diagonal();
        for (p, d) in m.positions().iter().zip(&s.directors) {
            let n = p.normalize() * side.orientation();
            assert!(d.normalize().dot(n) > 0.999, "{side:?} {p}: {d}");
            assert!((d.length() / h - 1.0).abs() < 0.01, "{side:?} {p}: {} vs {h}", d.length());
        }
    }
}

#[test]
fn plane_directors_are_normals_at_full_thickness() {
    let m = tm::plane(16);
    let (s, r) = shell_of(&m, 0.1, Side::Exterior);
    let h = 0.1 * m.bbox_diagonal();
    for (p, d) in m.positions().iter().zip(&s.directors) {
        // Interior vertices: within 1.8 degrees; the boundary (artificial faces, 4.3.2): 3.6.
        let on_boundary = p.x.abs() == 1.0 || p.y.abs() == 1.0;
        let tol = if on_boundary { 0.998 } else { 0.9995 };
        assert!(d.normalize().dot(Vec3::Z) > tol, "{p}: {d}");
        assert!((d.length() / h - 1.0).abs() < 0.01, "{} vs {h}", d.length());
    }
    assert_eq!(r.inverted_cells, 0);
}

#[test]
fn bumpy_head_is_clean() {
    assert_clean("head", &tm::bumpy_head(4));
}
#[test]
fn notched_box_is_clean() {
    assert_clean("notch", &tm::notched_box(2));
}
#[test]
fn comb_is_clean() {
    assert_clean("comb", &tm::comb(2));
}
#[test]
#[ignore = "not yet met; see the report"]
fn bunny_is_clean() {
    assert_clean("bunny", &tm::bunny());
}
#[test]
fn saddle_is_clean() {
    assert_clean("saddle", &tm::saddle(24));
}
