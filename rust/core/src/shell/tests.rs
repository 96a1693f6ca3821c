//! End-to-end shell tests on generated meshes (chapter 4 behaviour).

use super::directors::{side_lengths, Tracer};
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

/// Zero defects, and 95% of the target thickness at every vertex where normal
/// displacement is valid.
fn assert_clean(name: &str, mesh: &Mesh) {
    for (frac, side) in [(0.1, Side::Exterior), (0.05, Side::Interior)] {
        let (s, r) = shell_of(mesh, frac, side);
        // The map a texture is drawn through does not fold inside any cell (the
        // bunny's shells had 8 and 5 such cells, all with upright tetrahedra, before
        // the checker looked at the map).
        let folding = geometry::prisms(mesh).iter().filter(|c| c.map_folds(mesh.positions(), &s)).count();
        assert_eq!(folding, 0, "{name} {side:?}: cells whose map folds");
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
fn bunny_is_clean() {
    assert_clean("bunny", &tm::bunny());
}

#[test]
fn a_short_director_along_the_surface_turns_to_the_normal() {
    // Shortening cannot unfold a cell whose corner's director lies nearly in the
    // surface (as trajectories bent by self-intersecting input do): once that short
    // the repair turns it to the vertex normal instead of pressing it flat.
    let mesh = tm::plane(4);
    let n = mesh.vertex_count();
    let target = vec![1.0f32; n];
    let mut directors = vec![Vec3::Z * repair::TURN_AT; n];
    let odd = 12; // an interior vertex
                  // Along the surface, and straight back into it.
    for wrong in [Vec3::new(1.0, 0.0, -0.05).normalize(), -Vec3::Z] {
        directors[odd] = wrong * repair::TURN_AT;
        let achieved = directors.iter().map(|d| d.length()).collect();
        let mut shell = Shell {
            side: Side::Exterior,
            base_offset: vec![Vec3::ZERO; n],
            directors: directors.clone(),
            achieved,
            target: target.clone(),
            check: Default::default(),
        };
        assert!(shell_report(&mesh, &shell).inverted_cells > 0);
        repair::untangle(&mesh, &mut shell, 4, directors::REPAIR_FACTOR);
        let r = shell_report(&mesh, &shell);
        assert_eq!((r.inverted_cells, r.outer_self_intersections, r.outer_base_intersections), (0, 0, 0), "{wrong}: {r:?}");
        assert!(shell.directors[odd].normalize().dot(Vec3::Z) > 0.999 && (shell.achieved[odd] - repair::TURN_AT).abs() < 1e-6);
        let near: Vec<usize> = mesh.faces().filter(|f| f.contains(&(odd as u32))).flatten().map(|&v| v as usize).collect();
        assert!((0..n).filter(|v| !near.contains(v)).all(|v| shell.directors[v] == Vec3::Z * repair::TURN_AT), "only the fold changes");
        assert!(near.iter().all(|&v| shell.directors[v].normalize().dot(Vec3::Z) > 0.999), "the fold's corners keep pointing up");
    }
}

#[test]
fn restore_gives_back_thickness_the_repair_took_and_stays_clean() {
    // Shortening alone leaves vertices beside the bunny's folds short where normal
    // displacement has room (the field bends their neighbours' directors); the
    // restore pass lengthens them and never shortens anything.
    let mesh = tm::bunny();
    for (frac, side) in [(0.1, Side::Exterior), (0.05, Side::Interior)] {
        let t = Thickness::relative(frac).per_vertex(&mesh, None).unwrap();
        let traced = build_shell(&mesh, &t, side, &ShellParams { repair_rounds: 0, ..Default::default() }).unwrap();
        let mut shortened = traced.clone();
        repair::untangle(&mesh, &mut shortened, ShellParams::default().repair_rounds, directors::REPAIR_FACTOR);
        let before = shell_report(&mesh, &shortened);
        assert_eq!((before.outer_self_intersections, before.outer_base_intersections, before.inverted_cells), (0, 0, 0));
        assert!(before.min_ratio_normal_valid < 0.95, "{side:?}: nothing to restore: {before:?}");
        let full = build_shell(&mesh, &t, side, &ShellParams::default()).unwrap();
        let after = shell_report(&mesh, &full);
        assert_eq!((after.outer_self_intersections, after.outer_base_intersections, after.inverted_cells), (0, 0, 0), "{after:?}");
        assert!(after.min_ratio_normal_valid >= 0.95, "{side:?}: {after:?}");
        assert!(after.mean_ratio >= before.mean_ratio, "{side:?}: {before:?} {after:?}");
        let longer = (0..mesh.vertex_count()).filter(|&v| full.achieved[v] > shortened.achieved[v] + 1e-6).count();
        assert!(longer > 0);
        for v in 0..mesh.vertex_count() {
            assert!(full.achieved[v] >= shortened.achieved[v] - 1e-6, "{side:?} v{v}: {} < {}", full.achieved[v], shortened.achieved[v]);
            assert!(full.achieved[v] <= full.target[v] * 1.0001 || full.achieved[v] <= traced.achieved[v] * 1.0001, "{side:?} v{v} overshoots");
        }
    }
}
#[test]
fn saddle_is_clean() {
    assert_clean("saddle", &tm::saddle(24));
}

/// Largest distance between two sets of directors.
fn worst(a: &[Vec3], b: &[Vec3]) -> f32 {
    a.iter().zip(b).map(|(a, b)| (*a - *b).length()).fold(0.0, f32::max)
}

/// The shell traced from scratch on `mesh` (directors before the repair pass).
fn traced(mesh: &Mesh, t: &[f32], side: Side, params: &ShellParams) -> Vec<Vec3> {
    incremental::IncrementalShell::new(mesh.clone(), t.to_vec(), side, params.clone()).unwrap().traced_directors()
}

fn bumped(mesh: &Mesh, centre: usize, height: f32, radius: f32) -> Vec<Vec3> {
    let normals = crate::mesh::vertex_normals(mesh);
    let c = mesh.positions()[centre];
    mesh.positions()
        .iter()
        .zip(&normals)
        .map(|(p, n)| {
            let w = (1.0 - (*p - c).length() / radius).max(0.0);
            *p + *n * height * w * w
        })
        .collect()
}

fn with_positions(mesh: &Mesh, positions: Vec<Vec3>) -> Mesh {
    Mesh::new(positions, &mesh.face_sizes(), mesh.corners().to_vec(), None).unwrap()
}

#[test]
fn incremental_update_matches_full_rebuild() {
    let mesh = tm::bumpy_head(3);
    let t = Thickness::relative(0.1).per_vertex(&mesh, None).unwrap();
    let h = t[0];
    let diag = mesh.bbox_diagonal();
    let moved = bumped(&mesh, 0, 0.01 * diag, 0.1 * diag);
    let edited = with_positions(&mesh, moved.clone());
    // theta = 0: every face integrated exactly, so refitted and rebuilt trees agree.
    let params = ShellParams { theta: 0.0, ..Default::default() };
    let reference = traced(&edited, &t, Side::Exterior, &params);
    let mut retraced = Vec::new();
    for tolerance in [0.0, incremental::DEFAULT_TOLERANCE] {
        let mut inc = incremental::IncrementalShell::new(mesh.clone(), t.clone(), Side::Exterior, params.clone()).unwrap();
        inc.tolerance = tolerance;
        let stats = inc.update(&moved, &t).unwrap();
        assert!(!stats.rebuilt && stats.changed > 0, "{stats:?}");
        assert!(stats.retraced < mesh.vertex_count() / 2, "{stats:?} of {}", mesh.vertex_count());
        let err = worst(&inc.traced_directors(), &reference);
        // Tolerance 0 retraces everything within reach: the rebuild's directors. A
        // tolerance keeps directors the bound says move by about that fraction.
        let allowed = if tolerance == 0.0 { 1e-4 * h } else { (tolerance as f32) * h };
        assert!(err <= allowed, "tolerance {tolerance}: worst {err} vs h {h} ({stats:?})");
        let full = build_shell(&edited, &t, Side::Exterior, &params).unwrap();
        assert_eq!(inc.shell().directors.len(), full.directors.len());
        let r = shell_report(inc.mesh(), inc.shell());
        assert_eq!((r.inverted_cells, r.outer_self_intersections, r.outer_base_intersections), (0, 0, 0), "{r:?}");
        eprintln!("tolerance {tolerance}: {stats:?}, worst {}", err / h);
        retraced.push(stats);
    }
    assert!(retraced[1].retraced < retraced[0].retraced && retraced[1].kept > 0, "the tolerance kept nothing: {retraced:?}");

    // With the default Barnes-Hut approximation the two trees differ in shape only.
    let params = ShellParams::default();
    let mut inc = incremental::IncrementalShell::new(mesh.clone(), t.clone(), Side::Exterior, params.clone()).unwrap();
    inc.update(&moved, &t).unwrap();
    let err = worst(&inc.traced_directors(), &traced(&edited, &t, Side::Exterior, &params));
    assert!(err < 0.05 * h, "worst {err} vs h {h}");
}

#[test]
fn incremental_update_resets_only_the_repair_around_the_edit() {
    // Inside the thin-toothed comb at 10% nearly every director is repaired, in one
    // connected region (3422 of 3494 vertices): an update used to reset and repair
    // all of it again, its cost a whole repair's. Now only the repaired directors within a few rings of the retraced
    // ones are reset; the shell stays clean and near a rebuild's.
    let mesh = tm::comb(3);
    let n = mesh.vertex_count();
    let t = Thickness::relative(0.1).per_vertex(&mesh, None).unwrap();
    let params = ShellParams::default();
    let mut inc = incremental::IncrementalShell::new(mesh.clone(), t.clone(), Side::Interior, params.clone()).unwrap();
    let raw = inc.traced_directors();
    let repaired: Vec<bool> = (0..n).map(|v| inc.shell().directors[v] != raw[v]).collect();
    // The largest connected region of repaired vertices (what the old reset spread over).
    let mut region = vec![usize::MAX; n];
    let mut sizes = Vec::new();
    for s in (0..n).filter(|&v| repaired[v]) {
        if region[s] != usize::MAX {
            continue;
        }
        let (id, mut stack, mut size) = (sizes.len(), vec![s], 0);
        region[s] = id;
        while let Some(v) = stack.pop() {
            size += 1;
            for f in mesh.faces().filter(|f| f.contains(&(v as u32))) {
                for &u in f {
                    if repaired[u as usize] && region[u as usize] == usize::MAX {
                        region[u as usize] = id;
                        stack.push(u as usize);
                    }
                }
            }
        }
        sizes.push(size);
    }
    let (largest, &size) = sizes.iter().enumerate().max_by_key(|s| *s.1).expect("the repair shortened something");
    assert!(size > n / 3, "largest repaired region {size} of {n}");
    // A bump at a repaired vertex of that region.
    let centre = (0..n).find(|&v| region[v] == largest).unwrap();
    let diag = mesh.bbox_diagonal();
    let moved = bumped(&mesh, centre, 0.005 * diag, 0.03 * diag);
    let stats = inc.update(&moved, &t).unwrap();
    assert!(!stats.rebuilt && stats.retraced < n / 10, "{stats:?} of {n}");
    assert!(stats.resettled < size / 2, "{stats:?}: reset most of the repaired region ({size} of {n})");
    let r = shell_report(inc.mesh(), inc.shell());
    assert_eq!((r.inverted_cells, r.outer_self_intersections, r.outer_base_intersections), (0, 0, 0), "{r:?}");
    let full = build_shell(&with_positions(&mesh, moved), &t, Side::Interior, &params).unwrap();
    let s = inc.shell();
    let far = (0..n).filter(|&v| (s.directors[v] - full.directors[v]).length() > 0.25 * full.target[v]).count();
    let mean = |s: &Shell| s.achieved.iter().zip(&s.target).map(|(a, t)| a / t).sum::<f32>() / n as f32;
    eprintln!("{stats:?} of {n}, region {size}; far {far}; mean {} vs {}", mean(s), mean(&full));
    assert!(far <= 3, "{far} directors more than a quarter of the target from a rebuild's");
    assert!((mean(s) - mean(&full)).abs() < 0.005, "mean ratio {} vs a rebuild's {}", mean(s), mean(&full));
}

#[test]
fn incremental_update_follows_boundaries_quads_and_thickness() {
    // An open quad sheet (boundary extension faces, quads split for integration):
    // moving a corner region and thickening some vertices gives the rebuilt shell.
    let mesh = tm::saddle(12);
    assert!(mesh.faces().all(|f| f.len() == 4));
    let diag = mesh.bbox_diagonal();
    let mut t = Thickness::relative(0.05).per_vertex(&mesh, None).unwrap();
    let params = ShellParams { theta: 0.0, ..Default::default() };
    for side in [Side::Exterior, Side::Envelope] {
        let mut inc = incremental::IncrementalShell::new(mesh.clone(), t.clone(), side, params.clone()).unwrap();
        inc.tolerance = 0.0;
        let moved = bumped(&mesh, 0, 0.02 * diag, 0.2 * diag);
        t[5] *= 1.5;
        t[6] *= 0.5;
        let stats = inc.update(&moved, &t).unwrap();
        assert!(!stats.rebuilt && stats.retraced > 0 && stats.retraced < mesh.vertex_count(), "{side:?}: {stats:?}");
        let edited = with_positions(&mesh, moved);
        let err = worst(&inc.traced_directors(), &traced(&edited, &t, side, &params));
        assert!(err <= 1e-4 * t[0], "{side:?}: worst {err}");
        assert_eq!(inc.shell().target, t.iter().map(|x| x.abs()).collect::<Vec<_>>());
        // Nothing changed: nothing to do.
        assert_eq!(inc.update(edited.positions(), &t).unwrap(), incremental::UpdateStats::default());
    }
}

#[test]
fn incremental_update_of_quads_whose_split_flips_keeps_the_checker_and_stays_clean() {
    // Bumps pushed into a flat quad sheet (square quads: equal diagonals): some
    // quads' shorter diagonal changes.
    // The checker holds both splits of every quad, so it is refitted rather than
    // rebuilt (a rebuild made every edit of a quad scan cost a full check); the
    // result is clean by the project's kept checker and by a fresh one.
    let mesh = tm::plane(40);
    assert!(mesh.faces().all(|f| f.len() == 4));
    let diag = mesh.bbox_diagonal();
    let t = Thickness::relative(0.15).per_vertex(&mesh, None).unwrap();
    let mut inc = incremental::IncrementalShell::new(mesh.clone(), t.clone(), Side::Exterior, ShellParams::default()).unwrap();
    let centre = mesh.vertex_count() / 2 + 3;
    for (step, height) in [0.04f32, -0.03, 0.05].into_iter().enumerate() {
        let moved = bumped(inc.mesh(), centre, height * diag, 0.08 * diag);
        let before = inc.mesh().triangulate().triangles;
        let edited = with_positions(inc.mesh(), moved.clone());
        let flipped = before.iter().zip(&edited.triangulate().triangles).filter(|(a, b)| a != b).count();
        assert!(step > 0 || flipped > 0, "the first edit must flip some quad splits");
        let stats = inc.update(&moved, &t).unwrap();
        assert!(!stats.rebuilt, "step {step}: {stats:?}");
        assert!(inc.shell().check.clean, "step {step}");
        let r = shell_report(&edited, inc.shell());
        assert_eq!((r.outer_self_intersections, r.outer_base_intersections, r.inverted_cells), (0, 0, 0), "step {step}: {r:?}");
    }
}

#[test]
fn incremental_update_rebuilds_after_large_changes_and_refuses_bad_input() {
    let mesh = tm::icosphere(2);
    let t = Thickness::relative(0.05).per_vertex(&mesh, None).unwrap();
    let mut inc = incremental::IncrementalShell::new(mesh.clone(), t.clone(), Side::Exterior, ShellParams::default()).unwrap();
    let scaled: Vec<Vec3> = mesh.positions().iter().map(|p| *p * 1.5).collect();
    let stats = inc.update(&scaled, &t).unwrap();
    assert!(stats.rebuilt && stats.retraced == mesh.vertex_count(), "{stats:?}");
    let full = build_shell(&with_positions(&mesh, scaled.clone()), &t, Side::Exterior, &ShellParams::default()).unwrap();
    assert!(worst(&inc.shell().directors, &full.directors) < 1e-6);
    assert!(inc.update(&scaled[1..], &t).is_err());
    let mut bad = scaled.clone();
    bad[3].x = f32::NAN;
    assert!(inc.update(&bad, &t).is_err());
    let mut bad_t = t.clone();
    bad_t[2] = f32::INFINITY;
    assert!(inc.update(&scaled, &bad_t).is_err());
    assert!(inc.move_vertices(&[(mesh.vertex_count() as u32, Vec3::ZERO)]).is_err());
    // A refused update leaves the shell as it was.
    assert!(worst(&inc.shell().directors, &full.directors) < 1e-6);
}

#[test]
fn incremental_update_with_a_thickness_rule_sizes_on_the_edited_mesh() {
    let mesh = tm::icosphere(2);
    let rule = Thickness::relative(0.1);
    let factors: Vec<f32> = (0..mesh.vertex_count()).map(|v| 0.5 + (v % 3) as f32 * 0.25).collect();
    let t = rule.per_vertex(&mesh, Some(&factors)).unwrap();
    let mut inc = incremental::IncrementalShell::new(mesh.clone(), t, Side::Exterior, ShellParams::default()).unwrap();
    // Stretch one vertex far out: the bounding box, so relative thickness, grows.
    let mut moved = mesh.positions().to_vec();
    moved[0] *= 3.0;
    inc.update_with(&moved, &rule, Some(&factors)).unwrap();
    let want = rule.per_vertex(&with_positions(&mesh, moved.clone()), Some(&factors)).unwrap();
    assert!(want[0] > 1.2 * rule.per_vertex(&mesh, Some(&factors)).unwrap()[0]);
    assert_eq!(inc.thickness(), &want[..]);
    assert!(inc.update_with(&moved[1..], &rule, None).is_err());
}

#[test]
fn incremental_update_of_a_folding_shell_stays_clean() {
    // Thick enough that the repair pass works; after a deformation the incremental
    // shell must be as clean as a rebuilt one.
    let mesh = tm::bunny();
    let t = Thickness::relative(0.1).per_vertex(&mesh, None).unwrap();
    let mut inc = incremental::IncrementalShell::new(mesh.clone(), t, Side::Exterior, ShellParams::default()).unwrap();
    let normals = crate::mesh::vertex_normals(&mesh);
    let centre = mesh.positions()[100];
    let diag = mesh.bbox_diagonal();
    // A smooth bump: 2% of the diagonal at the centre, zero at 8%.
    let moved: Vec<(u32, Vec3)> = (0..mesh.vertex_count())
        .filter_map(|v| {
            let w = 1.0 - (mesh.positions()[v] - centre).length() / (0.08 * diag);
            (w > 0.0).then(|| (v as u32, mesh.positions()[v] + normals[v] * 0.02 * diag * w * w))
        })
        .collect();
    assert!(!moved.is_empty());
    let retraced = inc.move_vertices(&moved).unwrap();
    assert!(retraced < mesh.vertex_count(), "retraced {retraced}");
    let r = shell_report(inc.mesh(), inc.shell());
    assert_eq!((r.inverted_cells, r.outer_self_intersections, r.outer_base_intersections), (0, 0, 0), "{r:?}");
}

#[test]
fn envelope_spans_both_sides() {
    let m = tm::icosphere(2);
    let t = Thickness::relative(0.1).per_vertex(&m, None).unwrap();
    let s = build_shell(&m, &t, Side::Envelope, &ShellParams::default()).unwrap();
    for (v, p) in m.positions().iter().enumerate() {
        let inner = s.point(m.positions(), v, 0.0);
        let outer = s.point(m.positions(), v, 1.0);
        assert!((inner.length() - (1.0 - t[v] / 2.0)).abs() < 0.01 * t[v], "{}", inner.length());
        assert!((outer.length() - (1.0 + t[v] / 2.0)).abs() < 0.01 * t[v]);
        assert!((s.achieved[v] - t[v]).abs() < 0.02 * t[v] && p.dot(s.directors[v]) > 0.0);
    }
    let r = report::shell_report(&m, &s);
    assert_eq!((r.inverted_cells, r.outer_self_intersections, r.outer_base_intersections), (0, 0, 0));
    let g = shell_geometry(&m, &s, ShellOutput::Solid).unwrap();
    assert!(g.mesh.report().is_closed_manifold());
    assert_eq!(prisms(&m).len(), m.face_count());
    assert_eq!(Side::parse("Envelope").unwrap(), Side::Envelope);
    assert!(Side::parse("sideways").is_err());
}

#[test]
fn quads_give_hexahedra_and_ngons_prisms() {
    let cube = crate::mesh::fixtures::cube();
    let cells = prisms(&cube);
    assert!(cells.len() == 6 && cells.iter().all(|c| c.is_hexahedron()));
    let t = Thickness::relative(0.05).per_vertex(&cube, None).unwrap();
    let s = build_shell(&cube, &t, Side::Exterior, &ShellParams::default()).unwrap();
    assert!(cells.iter().all(|c| !c.is_inverted(cube.positions(), &s)));
    let hex = Mesh::new((0..6).map(|i| Vec3::new((i as f32).cos(), (i as f32).sin(), 0.0)).collect(), &[6], (0..6).collect(), None).unwrap();
    assert_eq!(prisms(&hex).len(), 4);
}

/// Runs `f` under a hang guard: still running after five minutes, it aborts the test
/// binary, so a hang fails instead of stalling CI. Not a speed test (a loaded
/// machine took over 20 s here, which a wall-clock bound failed): speed lives in
/// `make bench`.
fn bounded<T>(f: impl FnOnce() -> T) -> T {
    use std::sync::mpsc::{channel, RecvTimeoutError};
    let (done, wait) = channel::<()>();
    let guard = std::thread::spawn(move || {
        if wait.recv_timeout(std::time::Duration::from_secs(300)) == Err(RecvTimeoutError::Timeout) {
            eprintln!("a shell build on bad input hung: still running after 300 s");
            std::process::abort();
        }
    });
    let out = f();
    drop(done);
    guard.join().unwrap();
    out
}

#[test]
fn bad_input_never_panics_or_hangs() {
    // Non-manifold: three triangles on one edge, plus a loose vertex.
    let p = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z, -Vec3::Y, Vec3::new(0.5, 0.5, 0.5), Vec3::splat(5.0)];
    let m = Mesh::new(p, &[3, 3, 3], vec![0, 1, 2, 1, 0, 3, 0, 1, 4], None).unwrap();
    let t = vec![0.3; m.vertex_count()];
    let s = bounded(|| build_shell(&m, &t, Side::Exterior, &ShellParams::default())).unwrap();
    assert_eq!(s.directors[6], Vec3::ZERO, "loose vertex");
    assert!(s.directors.iter().all(|d| d.is_finite()));
    // Zero-area faces (repeated and collinear corners) are skipped.
    let mut sphere = tm::icosphere(2);
    let n = sphere.vertex_count() as u32;
    let mut pos = sphere.positions().to_vec();
    pos.push(pos[0] * 2.0);
    let mut tris: Vec<[u32; 3]> = sphere.faces().map(|f| [f[0], f[1], f[2]]).collect();
    tris.push([0, 0, 1]);
    tris.push([0, n, n]);
    sphere = Mesh::from_triangles(pos, &tris).unwrap();
    let t = Thickness::relative(0.1).per_vertex(&sphere, None).unwrap();
    let s = bounded(|| build_shell(&sphere, &t, Side::Exterior, &ShellParams::default())).unwrap();
    assert!(s.directors.iter().all(|d| d.is_finite()));
    // Thickness far larger than the object: compressed, finite, bounded time.
    let m = tm::comb(1);
    for side in [Side::Exterior, Side::Interior, Side::Envelope] {
        let t = Thickness::relative(50.0).per_vertex(&m, None).unwrap();
        let s = bounded(|| build_shell(&m, &t, side, &ShellParams::default())).unwrap();
        assert!(s.directors.iter().all(|d| d.is_finite()));
        assert!(s.achieved.iter().zip(&s.target).all(|(a, t)| *a <= t * 1.01));
    }
    // Wrong lengths and non-finite thickness are errors, not panics.
    assert!(build_shell(&m, &[0.1], Side::Exterior, &ShellParams::default()).is_err());
    assert!(build_shell(&m, &vec![f32::NAN; m.vertex_count()], Side::Exterior, &ShellParams::default()).is_err());
    assert!(build_shell(&m, &vec![0.1; m.vertex_count()], Side::Exterior, &ShellParams { p: 1.0, ..Default::default() }).is_err());
}

#[test]
fn general_p_uses_quadrature_and_agrees_in_direction() {
    let m = tm::icosphere(2);
    let t = Thickness::relative(0.1).per_vertex(&m, None).unwrap();
    let s = build_shell(&m, &t, Side::Exterior, &ShellParams { p: 4.0, ..Default::default() }).unwrap();
    for (p, d) in m.positions().iter().zip(&s.directors) {
        assert!(d.normalize().dot(p.normalize()) > 0.999);
    }
    // d_p and g_p (4.3, 4.4) at a distance: the gradient points away and is close to 1.
    let f = lp_distance::AveragedDistance::new(&m, 3.0, 0.3);
    let x = Vec3::new(0.0, 0.0, 30.0);
    let g = f.gradient(x);
    assert!((g.length() - 1.0).abs() < 0.05 && g.z > 0.0, "{g}");
    assert!((f.distance(x) - 30.0).abs() < 1.5, "{}", f.distance(x));
}

#[test]
fn kept_directors_add_up_what_repeated_edits_spared_them() {
    // The same small edit, again and again: each alone keeps the far directors, but
    // what they were spared adds up, so later edits retrace some of them.
    let mesh = tm::bumpy_head(3);
    let t = Thickness::relative(0.1).per_vertex(&mesh, None).unwrap();
    let diag = mesh.bbox_diagonal();
    let mut inc = incremental::IncrementalShell::new(mesh.clone(), t.clone(), Side::Exterior, ShellParams::default()).unwrap();
    inc.tolerance = 0.05;
    let step = bumped(&mesh, 0, 0.002 * diag, 0.1 * diag);
    let mut counts = Vec::new();
    for k in 1..=8 {
        let positions: Vec<Vec3> = mesh.positions().iter().zip(&step).map(|(p, q)| *p + (*q - *p) * k as f32).collect();
        let stats = inc.update(&positions, &t).unwrap();
        assert!(!stats.rebuilt && stats.kept > 0, "{stats:?}");
        counts.push(stats.retraced);
    }
    // Without the sum every edit after the first retraces the same directors (the
    // bump's neighbourhood); with it, kept ones join them as their sums pass the
    // tolerance.
    assert!(counts[2..].iter().any(|&c| c > counts[1]), "retraced per edit {counts:?}");
}

#[test]
fn a_moved_loose_vertex_keeps_a_zero_director() {
    let sphere = tm::icosphere(2);
    let mut positions = sphere.positions().to_vec();
    positions.push(Vec3::new(5.0, 0.0, 0.0));
    let mesh = Mesh::new(positions.clone(), &sphere.face_sizes(), sphere.corners().to_vec(), None).unwrap();
    let t = Thickness::relative(0.05).per_vertex(&mesh, None).unwrap();
    let mut inc = incremental::IncrementalShell::new(mesh.clone(), t.clone(), Side::Exterior, ShellParams::default()).unwrap();
    let loose = positions.len() - 1;
    positions[loose] = Vec3::new(5.0, 1.0, 0.0);
    let stats = inc.update(&positions, &t).unwrap();
    assert_eq!((stats.changed, stats.retraced), (1, 1), "{stats:?}");
    assert_eq!(inc.shell().directors[loose], Vec3::ZERO);
    assert_eq!(inc.shell().achieved[loose], 0.0);
}

/// The sides and thicknesses (fraction of the bounding-box diagonal) every mesh is
/// held to: exterior 10% and 20%, interior 5% and 10%, envelope 10%.
pub(crate) const HARD_CASES: [(f32, Side); 5] =
    [(0.1, Side::Exterior), (0.2, Side::Exterior), (0.05, Side::Interior), (0.1, Side::Interior), (0.1, Side::Envelope)];

/// A per-vertex thickness factor that varies smoothly over the mesh (a vertex group).
pub(crate) fn wavy_factors(mesh: &Mesh) -> Vec<f32> {
    let (lo, hi) = mesh.bounds();
    mesh.positions().iter().map(|p| 0.5 + 0.5 * (((*p - lo) / (hi - lo).max(Vec3::splat(1e-6))).dot(Vec3::new(3.0, 2.0, 1.0)) * 2.0).sin().abs()).collect()
}

/// No defect at all, for every side and thickness, uniform and per-vertex.
pub(crate) fn assert_never_folds(name: &str, mesh: &Mesh) {
    for (frac, side) in HARD_CASES {
        for factors in [None, Some(wavy_factors(mesh))] {
            let t = Thickness::relative(frac).per_vertex(mesh, factors.as_deref()).unwrap();
            let s = build_shell(mesh, &t, side, &ShellParams::default()).unwrap();
            let r = shell_report(mesh, &s);
            let what = format!("{name} {side:?} {frac} factors={}: {r:?} {:?}", factors.is_some(), s.check);
            assert_eq!((r.outer_self_intersections, r.outer_base_intersections, r.inverted_cells, r.enclosing_cells), (0, 0, 0, 0), "{what}");
            assert!(s.check.clean, "{what}");
            let room = mean_room(mesh, &s);
            assert!(r.mean_ratio as f64 > 0.5 * room, "{what}: mean room {room}");
        }
    }
}

/// The mean share of its target each vertex could reach if the shells of two facing
/// parts met halfway along the normal line (the gap found by a ray along the normal,
/// outward for exterior shells, inward for interior ones, both for envelopes).
pub(crate) fn mean_room(mesh: &Mesh, shell: &Shell) -> f64 {
    let room = crate::hard_meshes::normal_room(mesh);
    let (mut sum, mut n) = (0.0f64, 0usize);
    for (v, [out, inn]) in room.into_iter().enumerate().filter(|(v, _)| shell.target[*v] > 0.0) {
        let t = shell.target[v];
        let share = match shell.side {
            Side::Exterior => out / (2.0 * t),
            Side::Interior => inn / (2.0 * t),
            Side::Envelope => (out / t).min(inn / t),
        };
        sum += share.min(1.0) as f64;
        n += 1;
    }
    sum / n.max(1) as f64
}

#[test]
fn generated_meshes_never_fold_at_any_side_or_thickness() {
    for (name, mesh) in [("head", tm::bumpy_head(3)), ("notch", tm::notched_box(2)), ("comb", tm::comb(2)), ("saddle", tm::saddle(16))] {
        assert_never_folds(name, &mesh);
    }
}

#[test]
fn hard_meshes_never_fold_at_any_side_or_thickness() {
    // Close fingers, a thin-walled cup, close strands, nearly touching parts, a sharp blade.
    for (name, mesh) in crate::hard_meshes::all_closed().into_iter().filter(|(n, _)| !matches!(*n, "bunny" | "comb")) {
        assert_never_folds(name, &mesh);
    }
}

#[test]
fn many_separate_open_cards_never_fold() {
    // Open parts, one in five 0.02-0.08 from a near-parallel neighbour: at a tenth of a
    // card and at a whole card of thickness.
    let mesh = crate::hard_meshes::cards(400, 7);
    for (thickness, side) in [(0.1, Side::Exterior), (1.0, Side::Exterior), (0.5, Side::Envelope), (0.1, Side::Interior)] {
        let t = Thickness::absolute(thickness).per_vertex(&mesh, None).unwrap();
        let s = build_shell(&mesh, &t, side, &ShellParams::default()).unwrap();
        let r = shell_report(&mesh, &s);
        let what = format!("{side:?} {thickness}: {r:?} {:?}", s.check);
        assert_eq!((r.outer_self_intersections, r.outer_base_intersections, r.inverted_cells, r.enclosing_cells), (0, 0, 0, 0), "{what}");
        assert!(s.check.clean && r.base_self_intersections == 0, "{what}");
        assert!(r.mean_ratio > 0.5, "{what}");
    }
}

/// A square card of half-size `half` at height `z`, facing +z, shifted by `(dx, dy)`.
fn card(half: f32, dx: f32, dy: f32, z: f32) -> [Vec3; 4] {
    [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)].map(|(x, y)| Vec3::new(dx + half * x, dy + half * y, z))
}

/// Whether `x` is inside the closed triangle mesh `solid`: the parity of the
/// crossings of a long segment in a direction no face of these tests lies along.
fn inside_solid(solid: &Mesh, x: Vec3) -> bool {
    let tri = solid.triangulate();
    let p = solid.positions();
    let (a, b) = (x.as_dvec3(), (x + Vec3::new(0.31, 0.57, 0.76).normalize() * 100.0).as_dvec3());
    let hits = tri.triangles.iter().filter(|t| intersect::segment_crosses_triangle(a, b, &t.map(|v| p[v as usize].as_dvec3()))).count();
    hits % 2 == 1
}

/// How many of `points` lie inside the closed shell solid of the mesh's first card
/// (vertices 0-3, one quad) under `shell` (ray parity).
fn inside_first_card(positions: &[Vec3], shell: &Shell, points: &[Vec3]) -> usize {
    let first = Mesh::new(positions[..4].to_vec(), &[4], (0..4).collect(), None).unwrap();
    let first_shell = Shell {
        side: shell.side,
        base_offset: shell.base_offset[..4].to_vec(),
        directors: shell.directors[..4].to_vec(),
        ..Shell::from_directors(vec![], vec![])
    };
    let solid = geometry::shell_geometry(&first, &first_shell, geometry::ShellOutput::Solid).unwrap().mesh;
    points.iter().filter(|x| inside_solid(&solid, **x)).count()
}

/// A card floating wholly inside another card's shell crosses none of its skins, and
/// one across its edge crosses only its side wall: both used to be swallowed (and a
/// bake of the first card's texture grew through the second). Checked independently
/// of the shell's own tests: no point of the second card lies inside the first
/// card's closed shell solid (ray parity).
#[test]
fn a_card_inside_or_across_another_cards_shell_is_not_swallowed() {
    // Inside: the second card's own shell is thin enough to stay inside the first's
    // too, so only the enclosure test sees it. Across: the second card's first vertex
    // (the part's probe) is outside the first card's shell, so only the walls see it.
    for (name, second, thin) in [("inside", card(0.3, 0.0, 0.05, 0.03), 0.02), ("across the edge", card(0.3, -0.75, 0.1, 0.03), 0.1)] {
        let positions: Vec<Vec3> = card(0.5, 0.0, 0.0, 0.0).into_iter().chain(second).collect();
        let mesh = Mesh::new(positions.clone(), &[4, 4], (0..8).collect(), None).unwrap();
        let thickness = [0.1, 0.1, 0.1, 0.1, thin, thin, thin, thin];
        for side in [Side::Exterior, Side::Envelope] {
            let s = build_shell(&mesh, &thickness, side, &ShellParams::default()).unwrap();
            let r = shell_report(&mesh, &s);
            let what = format!("{name} {side:?}: {r:?} {:?} achieved {:?}", s.check, s.achieved);
            assert_eq!((r.outer_self_intersections, r.outer_base_intersections, r.inverted_cells, r.enclosing_cells), (0, 0, 0, 0), "{what}");
            let first = Mesh::new(positions[..4].to_vec(), &[4], (0..4).collect(), None).unwrap();
            let first_shell =
                Shell { side, base_offset: s.base_offset[..4].to_vec(), directors: s.directors[..4].to_vec(), ..Shell::from_directors(vec![], vec![]) };
            let solid = geometry::shell_geometry(&first, &first_shell, geometry::ShellOutput::Solid).unwrap().mesh;
            for i in 0..=6 {
                for j in 0..=6 {
                    let (u, v) = (i as f32 / 6.0, j as f32 / 6.0);
                    let x = second[0].lerp(second[1], u).lerp(second[3].lerp(second[2], u), v);
                    assert!(!inside_solid(&solid, x), "{what}: point {x} of the second card is inside the first's shell");
                }
            }
            // The room is above the second card: it keeps most of its thickness.
            let kept = s.achieved[4..].iter().sum::<f32>() / 4.0 / thin;
            assert!(side != Side::Exterior || kept > 0.5, "{what}");
        }
    }
}

/// Two small grids crossing each other (a part that crosses the base, as in sculpts
/// and kitbashed debris) floating wholly inside a larger card's shell: their
/// crossing vertices are partly in and partly out of each other, but their other
/// vertices are probed, so the card's shell must not swallow them. It did when a
/// crossing part was not probed at all. Checked by ray parity on the card's solid.
#[test]
fn crossing_parts_inside_another_parts_shell_are_not_swallowed() {
    let grid = crate::mesh::fixtures::grid(4);
    let g = grid.vertex_count() as u32;
    // A flat grid at z = 0.05 and an upright one (x = 0.02) crossing it along its middle.
    let flat = grid.positions().iter().map(|q| Vec3::new(q.x / 20.0 - 0.1, q.y / 20.0 - 0.1, 0.05));
    let upright = grid.positions().iter().map(|q| Vec3::new(0.02, q.x / 20.0 - 0.1, q.y / 50.0 + 0.01));
    let positions: Vec<Vec3> = card(0.5, 0.0, 0.0, 0.0).into_iter().chain(flat).chain(upright).collect();
    let mut sizes = vec![4];
    sizes.extend(grid.face_sizes().iter().chain(&grid.face_sizes()));
    let corners: Vec<u32> = (0..4).chain(grid.corners().iter().map(|&v| v + 4)).chain(grid.corners().iter().map(|&v| v + 4 + g)).collect();
    let mesh = Mesh::new(positions.clone(), &sizes, corners, None).unwrap();
    let mut thickness = vec![0.004; positions.len()];
    thickness[..4].fill(0.1);
    let checker = defects::Checker::new(&mesh);
    assert!(checker.base_self_pairs() > 0, "the two grids must cross");
    for side in [Side::Exterior, Side::Envelope] {
        let s = build_shell(&mesh, &thickness, side, &ShellParams::default()).unwrap();
        let r = shell_report(&mesh, &s);
        let what = format!("{side:?}: {r:?} {:?} card {:?}", s.check, &s.achieved[..4]);
        assert_eq!((r.outer_self_intersections, r.outer_base_intersections, r.inverted_cells, r.enclosing_cells), (0, 0, 0, 0), "{what}");
        let swallowed = inside_first_card(&positions, &s, &positions[4..]);
        assert_eq!(swallowed, 0, "{what}: {swallowed} vertices of the crossing grids inside the card's shell");
    }
}

/// A third part crossing a card (a small upright quad through it) must not free the
/// card's cell from keeping out a part that crosses nothing: a small card floating
/// inside the first card's shell. The crossing exempts only the crossing part.
#[test]
fn a_crossing_elsewhere_does_not_let_a_cell_swallow_another_part() {
    let crosser = [Vec3::new(0.3, 0.2, -0.02), Vec3::new(0.3, 0.3, -0.02), Vec3::new(0.3, 0.3, 0.02), Vec3::new(0.3, 0.2, 0.02)];
    let positions: Vec<Vec3> = card(0.5, 0.0, 0.0, 0.0).into_iter().chain(card(0.1, -0.2, -0.2, 0.03)).chain(crosser).collect();
    let mesh = Mesh::new(positions.clone(), &[4, 4, 4], (0..12).collect(), None).unwrap();
    assert!(defects::Checker::new(&mesh).base_self_pairs() > 0, "the upright quad must cross the card");
    let mut thickness = vec![0.004; 12];
    thickness[..4].fill(0.1);
    for side in [Side::Exterior, Side::Envelope] {
        let s = build_shell(&mesh, &thickness, side, &ShellParams::default()).unwrap();
        let r = shell_report(&mesh, &s);
        let what = format!("{side:?}: {r:?} {:?} card {:?}", s.check, &s.achieved[..4]);
        assert!(s.check.clean && r.enclosing_cells == 0, "{what}");
        let swallowed = inside_first_card(&positions, &s, &positions[4..8]);
        assert_eq!(swallowed, 0, "{what}: the floating card is inside the first card's shell");
    }
}

/// Eyes sunk into a head (Suzanne's build): each small sphere crosses the big one and
/// sticks out by less than the thickness, so the head's cells over the crossing
/// faces hold part of it, inherited as the crossings are. The result must not
/// depend on which vertex of an eye is probed: the build (on spatially sorted
/// vertices) and the report (on the given order, and on the reversed order) agree
/// that nothing is left. The build called itself clean while the report found
/// enclosing cells when such cells were asked to enclose nothing.
#[test]
fn eyes_crossing_a_head_leave_no_enclosure_whatever_the_vertex_order() {
    let head = tm::icosphere(3);
    let eye = tm::icosphere(2);
    let mut positions: Vec<Vec3> = head.positions().to_vec();
    let mut sizes = head.face_sizes();
    let mut corners = head.corners().to_vec();
    for centre in [Vec3::new(0.35, 0.0, 0.9), Vec3::new(-0.35, 0.0, 0.9)] {
        let first = positions.len() as u32;
        positions.extend(eye.positions().iter().map(|q| centre + *q * 0.2));
        sizes.extend(eye.face_sizes());
        corners.extend(eye.corners().iter().map(|&v| v + first));
    }
    let n = positions.len() as u32;
    let reversed_corners: Vec<u32> = corners.iter().map(|&v| n - 1 - v).collect();
    let reversed_positions: Vec<Vec3> = positions.iter().rev().copied().collect();
    for (name, mesh) in
        [("given", Mesh::new(positions, &sizes, corners, None).unwrap()), ("reversed", Mesh::new(reversed_positions, &sizes, reversed_corners, None).unwrap())]
    {
        assert!(defects::Checker::new(&mesh).base_self_pairs() > 0, "the eyes must cross the head");
        for (frac, side) in [(0.1, Side::Exterior), (0.1, Side::Envelope), (0.05, Side::Interior)] {
            let (s, r) = shell_of(&mesh, frac, side);
            let what = format!("{name} {side:?}: {r:?} {:?}", s.check);
            assert!(s.check.clean, "{what}");
            assert_eq!((r.outer_self_intersections, r.outer_base_intersections, r.inverted_cells, r.enclosing_cells), (0, 0, 0, 0), "{what}");
        }
    }
}

/// An edit that moves a card into another card's shell, where it crosses nothing
/// and the cells holding it did not change: the incremental update finds it as a
/// rebuild does.
#[test]
fn an_edit_moving_a_card_into_another_cards_shell_is_repaired() {
    // The first card is a 6 x 6 grid (an edit of four vertices is then incremental).
    let sheet = crate::mesh::fixtures::grid(6);
    let n = sheet.vertex_count();
    let mut positions: Vec<Vec3> = sheet.positions().iter().map(|p| *p / 6.0 - Vec3::new(0.5, 0.5, 0.0)).collect();
    positions.extend(card(0.2, 0.0, 0.05, 0.6));
    let mut sizes = sheet.face_sizes();
    sizes.push(4);
    let corners: Vec<u32> = sheet.corners().iter().copied().chain(n as u32..n as u32 + 4).collect();
    let mesh = Mesh::new(positions.clone(), &sizes, corners, None).unwrap();
    let mut thickness = vec![0.1; n + 4];
    thickness[n..].fill(0.02);
    let mut live = incremental::IncrementalShell::new(mesh, thickness.clone(), Side::Exterior, ShellParams::default()).unwrap();
    // Even when the sheet's directors are all kept (the tolerance lets every one be),
    // so that none of its cells is checked again for its own sake.
    live.tolerance = 1e9;
    // Under the card's new place, the sheet's full thickness.
    let under: Vec<usize> = (0..n).filter(|&v| positions[v].x.abs() < 0.2 && (positions[v].y - 0.05).abs() < 0.2).collect();
    assert!(!under.is_empty() && under.iter().all(|&v| live.shell().achieved[v] > 0.09), "{:?}", live.shell().achieved);
    let mut moved = positions.clone();
    moved[n..].iter_mut().for_each(|p| p.z = 0.03);
    let stats = live.update(&moved, &thickness).unwrap();
    let r = shell_report(live.mesh(), live.shell());
    assert!(!stats.rebuilt && r.enclosing_cells == 0 && live.shell().check.clean, "{stats:?} {r:?}");
    assert!(under.iter().all(|&v| live.shell().achieved[v] < 0.035), "{:?}", under.iter().map(|&v| live.shell().achieved[v]).collect::<Vec<_>>());
    // As a rebuild of the edited mesh does.
    let rebuilt = build_shell(live.mesh(), &thickness, Side::Exterior, &ShellParams::default()).unwrap();
    assert!(under.iter().all(|&v| rebuilt.achieved[v] < 0.035) && shell_report(live.mesh(), &rebuilt).enclosing_cells == 0);
    // What the update flags for a moved part: the sheet's cells around the card's
    // probe (its first vertex), none of the card's own.
    let probe = moved[n];
    let near = defects::Checker::new(live.mesh()).cells_near_probes(live.mesh(), &[n as u32 + 2], &[], 0.05);
    assert!(!near.is_empty() && near.iter().all(|&v| (v as usize) < n && (positions[v as usize] - probe).length() < 0.05 + 0.25), "{near:?}");
}

/// Two open triangles meeting at one vertex, the first's boundary edge through the
/// second (the base crosses itself only between faces that share a vertex, which
/// is not counted as its own crossing): the side wall pressed flat is that edge, and
/// must not count, or no thickness at all would be clean.
#[test]
fn a_flat_wall_is_no_defect_so_zero_thickness_stays_valid() {
    let positions = vec![Vec3::new(1.0, 0.0, 1.0), Vec3::new(1.0, 0.0, -1.0), Vec3::ZERO, Vec3::new(2.0, -1.0, 0.0), Vec3::new(2.0, 1.0, 0.0)];
    let mesh = Mesh::new(positions, &[3, 3], vec![0, 1, 2, 2, 3, 4], None).unwrap();
    for side in [Side::Exterior, Side::Interior, Side::Envelope] {
        let flat = Shell { side, ..Shell::from_directors(vec![Vec3::ZERO; 5], vec![Vec3::ZERO; 5]) };
        let r = shell_report(&mesh, &flat);
        assert_eq!((r.outer_self_intersections, r.outer_base_intersections, r.inverted_cells), (0, 0, 0), "{side:?}: {r:?}");
        let s = build_shell(&mesh, &[0.2; 5], side, &ShellParams::default()).unwrap();
        assert!(s.check.clean, "{side:?}: {:?}", s.check);
    }
}

/// A loose vertex is no part to keep out of a shell: a sheet keeps its thickness
/// under one.
#[test]
fn a_loose_vertex_inside_a_shell_changes_nothing() {
    let sheet = crate::mesh::fixtures::grid(8);
    let n = sheet.vertex_count();
    let mut positions: Vec<Vec3> = sheet.positions().iter().map(|p| *p / 8.0).collect();
    positions.push(Vec3::new(0.55, 0.45, 0.05));
    let mesh = Mesh::new(positions, &sheet.face_sizes(), sheet.corners().to_vec(), None).unwrap();
    let alone =
        build_shell(&with_positions(&sheet, sheet.positions().iter().map(|p| *p / 8.0).collect()), &vec![0.1; n], Side::Exterior, &ShellParams::default())
            .unwrap();
    let s = build_shell(&mesh, &vec![0.1; n + 1], Side::Exterior, &ShellParams::default()).unwrap();
    assert_eq!(s.directors[..n], alone.directors[..], "the loose vertex moved the sheet's shell");
    assert_eq!(shell_report(&mesh, &s).enclosing_cells, 0);
}

#[test]
fn bunny_never_folds_at_any_side_or_thickness() {
    assert_never_folds("bunny", &tm::bunny());
}

/// Two spheres overlapping each other in one mesh (as sculpts and game assets do).
fn overlapping_spheres() -> Mesh {
    let s = tm::icosphere(3);
    let n = s.vertex_count() as u32;
    let mut p = s.positions().to_vec();
    p.extend(s.positions().iter().map(|q| *q * 0.6 + Vec3::new(1.1, 0.0, 0.0)));
    let tris = s.triangulate().triangles;
    let all: Vec<[u32; 3]> = tris.iter().copied().chain(tris.iter().map(|t| t.map(|v| v + n))).collect();
    Mesh::from_triangles(p, &all).unwrap()
}

#[test]
fn a_base_that_crosses_itself_gets_no_new_crossings() {
    let mesh = overlapping_spheres();
    let (pairs, faces) = report::self_intersecting_faces(&mesh);
    assert!(pairs > 0 && !faces.is_empty());
    for (frac, side) in HARD_CASES {
        let t = Thickness::relative(frac).per_vertex(&mesh, None).unwrap();
        let s = build_shell(&mesh, &t, side, &ShellParams::default()).unwrap();
        let r = shell_report(&mesh, &s);
        assert_eq!((r.outer_self_intersections, r.outer_base_intersections, r.inverted_cells), (0, 0, 0), "{side:?} {frac}: {r:?}");
        assert_eq!(r.base_self_intersections, pairs);
        assert!(r.inherited_intersections > 0, "{r:?}");
        // Away from the crossing the shell keeps its thickness.
        assert!(r.mean_ratio > 0.6, "{side:?} {frac}: {r:?}");
    }
}

#[test]
fn zero_thickness_is_valid_and_touching_parts_press_the_shell_flat() {
    // A pressed-flat shell (zero directors) has no inverted cell and no crossing.
    let mesh = tm::bunny();
    let n = mesh.vertex_count();
    for side in [Side::Exterior, Side::Interior, Side::Envelope] {
        let mut flat = Shell::from_directors(vec![Vec3::ZERO; n], vec![Vec3::ZERO; n]);
        flat.side = side;
        let r = shell_report(&mesh, &flat);
        assert_eq!((r.outer_self_intersections, r.outer_base_intersections, r.inverted_cells), (0, 0, 0), "{side:?}: {r:?}");
    }
    // Two boxes 0.2% of the diagonal apart: between them the shell goes to (nearly) zero.
    let boxes = tm::voxels([7, 3, 3], 2, |i, _, _| i != 3);
    let gap = 0.004 * boxes.bbox_diagonal();
    let moved: Vec<Vec3> = boxes.positions().iter().map(|p| if p.x > 3.5 { *p - Vec3::X * (1.0 - gap) } else { *p }).collect();
    let mesh = Mesh::new(moved, &boxes.face_sizes(), boxes.corners().to_vec(), None).unwrap();
    let t = Thickness::relative(0.1).per_vertex(&mesh, None).unwrap();
    let s = build_shell(&mesh, &t, Side::Exterior, &ShellParams::default()).unwrap();
    let r = shell_report(&mesh, &s);
    assert_eq!((r.outer_self_intersections, r.outer_base_intersections, r.inverted_cells), (0, 0, 0), "{r:?}");
    // Inside the facing side (its rim's directors leave the gap sideways).
    let inside = |c: f32| c > 0.25 && c < 2.75;
    let facing = (0..mesh.vertex_count()).filter(|&v| {
        let q = mesh.positions()[v];
        (q.x - 3.0).abs() < 1e-4 && inside(q.y) && inside(q.z)
    });
    for v in facing {
        assert!(s.achieved[v] <= gap, "v{v}: {} in a gap of {gap}", s.achieved[v]);
    }
}

#[test]
fn incremental_update_gives_back_thickness_where_an_edit_makes_room() {
    // Two spheres nearly touching, one with a deep dent facing the other: the
    // exterior shell is pressed thin in the dent. Pulling the dent back out, in one
    // update (a script) or in eight (a drag), makes room there; the incremental
    // shell must give the thickness back as a rebuild does, and stay clean at every
    // step.
    let spheres = crate::hard_meshes::two_spheres();
    let p = spheres.positions();
    let facing = (0..spheres.vertex_count()).filter(|&v| p[v].x < 0.0).max_by(|&a, &b| p[a].x.total_cmp(&p[b].x)).unwrap();
    let (radius, depth) = (0.35, 0.25);
    let region: Vec<usize> = (0..spheres.vertex_count()).filter(|&v| (p[v] - p[facing]).length() < radius).collect();
    let dented = with_positions(&spheres, bumped(&spheres, facing, -depth, radius));
    let t = Thickness::relative(0.1).per_vertex(&spheres, None).unwrap();
    let params = ShellParams::default();
    let ratio = |s: &Shell| region.iter().map(|&v| s.achieved[v] / s.target[v]).sum::<f32>() / region.len() as f32;
    let rebuilt = build_shell(&spheres, &t, Side::Exterior, &params).unwrap();
    let want = ratio(&rebuilt);
    // In one update (a script) and in eight (a drag).
    for steps in [1usize, 8] {
        let mut inc = incremental::IncrementalShell::new(dented.clone(), t.clone(), Side::Exterior, params.clone()).unwrap();
        let pressed = ratio(inc.shell());
        for k in 1..=steps {
            let moved = bumped(&spheres, facing, -depth * (steps - k) as f32 / steps as f32, radius);
            let stats = inc.update(&moved, &t).unwrap();
            assert!(!stats.rebuilt, "{stats:?}");
            let r = shell_report(inc.mesh(), inc.shell());
            assert_eq!((r.outer_self_intersections, r.outer_base_intersections, r.inverted_cells), (0, 0, 0), "step {k}: {r:?}");
        }
        let mine = ratio(inc.shell());
        eprintln!("dent pulled out in {steps}: pressed {pressed:.3}, incremental {mine:.3}, rebuilt {want:.3}");
        assert!(want > pressed + 0.1, "pulling the dent out must make room: {pressed} -> {want}");
        assert!(mine >= want - 0.005, "{steps} updates: incremental {mine} vs rebuilt {want} (pressed {pressed})");
    }
}

#[test]
fn the_repair_and_the_restore_stop_on_a_cancel() {
    // A traced comb shell folds (the repair has rounds to run); with a cancelled
    // watch the repair runs none and leaves the shell unfinished for the caller to
    // drop, without it the same shell is repaired clean.
    use super::defects::Checker;
    use super::repair::Repair;
    let mesh = tm::comb(2);
    let t = Thickness::relative(0.2).per_vertex(&mesh, None).unwrap();
    let traced = build_shell(&mesh, &t, Side::Exterior, &ShellParams { repair_rounds: 0, ..Default::default() }).unwrap();
    let checker = Checker::new(&mesh);
    let normals = crate::mesh::vertex_normals(&mesh);
    let cancelled = crate::progress::Progress::default();
    cancelled.cancel();
    for (cancel, name) in [(Some(&cancelled), "cancelled"), (None, "not cancelled")] {
        let mut shell = traced.clone();
        let repair = Repair { checker: &checker, mesh: &mesh, normals: &normals, rounds: 80, factor: 0.92, cancel, held: None, scales: true };
        let done = repair.settle(&mut None, &mut shell, None);
        if cancel.is_some() {
            assert!(!done.clean && done.rounds == 0 && shell.directors == traced.directors, "{name}: {done:?}");
        } else {
            assert!(done.clean && done.rounds > 0, "{name}: {done:?}");
        }
    }
}

/// Issue 14: outer triangles meeting only at a vertex pressed to zero thickness may
/// cross each other (or the base) away from it, which the tree tests skip as
/// neighbours; the cells over them then overlap as maps (on a public scan, cells of
/// faces with no vertex in common). On creased grids with one vertex pressed flat
/// and some of its neighbours leaning far, [`defects::Checker::find_star`] finds
/// such crossings, `find` reports them among the skin pairs, and the repair leaves
/// none and no other defect. (How many of them the other tests also catch is
/// printed: on these grids, all so far; the public scan had shells only this test
/// flags.)
#[test]
fn outer_triangles_crossing_at_a_pressed_vertex_are_found_and_repaired() {
    let mut rng = crate::test_rng::Rng(14);
    let (mut with_star, mut only_star) = (0, 0);
    for trial in 0..400 {
        let crease = [0.0f32, 1.0, 3.0][trial % 3];
        let grid = tm::height_grid(6, |x, _| crease * x.abs());
        let mesh = if trial % 2 == 0 { grid } else { Mesh::from_triangles(grid.positions().to_vec(), &grid.triangulate().triangles).unwrap() };
        let n = mesh.vertex_count();
        let normals = crate::mesh::vertex_normals(&mesh);
        let checker = defects::Checker::new(&mesh);
        let mut directors: Vec<Vec3> = normals.iter().map(|v| *v * 0.3).collect();
        let v = (rng.uniform() * n as f64) as usize;
        directors[v] = Vec3::ZERO;
        let ring: Vec<u32> = checker.tris_of(v).iter().flat_map(|&t| checker.tris[t as usize]).filter(|&q| q as usize != v).collect();
        for _ in 0..2 {
            let q = ring[(rng.uniform() * ring.len() as f64) as usize] as usize;
            directors[q] = (normals[q].as_dvec3() + rng.unit() * rng.range(0.5, 4.0)).normalize().as_vec3() * rng.range(0.1, 1.2) as f32;
        }
        let mut shell = Shell::from_directors(vec![Vec3::ZERO; n], directors);
        let star: Vec<_> = checker.find_star(&mesh, &shell, None, true).into_iter().filter(|h| h.0 != 2).collect();
        if star.is_empty() {
            continue;
        }
        with_star += 1;
        let found = checker.find(&mesh, &shell, None, Some(&checker.outer_tree(&mesh, &shell, None)));
        for h in &star {
            let pairs = if h.0 == 0 { &found.self_pairs } else { &found.base_pairs };
            assert!(pairs.iter().any(|&(i, j)| (i, j) == (h.1, h.2) || (j, i) == (h.1, h.2)), "trial {trial}: {h:?} not reported");
        }
        let (skin, base) = (star.iter().filter(|h| h.0 == 0).count(), star.iter().filter(|h| h.0 == 1).count());
        only_star += usize::from(found.self_pairs.len() == skin && found.base_pairs.len() == base && found.inverted.is_empty());
        let check = repair::untangle(&mesh, &mut shell, 80, 0.8);
        let r = shell_report(&mesh, &shell);
        assert!(check.clean, "trial {trial}: {check:?}");
        assert!(checker.find_star(&mesh, &shell, None, true).iter().all(|h| h.0 == 2), "trial {trial}");
        assert_eq!((r.outer_self_intersections, r.outer_base_intersections, r.inverted_cells), (0, 0, 0), "trial {trial}: {r:?}");
    }
    eprintln!("{with_star} shells with crossings at a pressed vertex, {only_star} of them found by nothing else");
    assert!(with_star >= 5, "{with_star}");
}

/// A closed cylinder as CAD parts come from STL files: each cap a fan of slivers
/// from one rim vertex, the side one tall quad per segment.
fn sliver_cylinder(n: u32) -> Mesh {
    let ring = |z: f32| {
        (0..n).map(move |k| {
            let a = std::f32::consts::TAU * k as f32 / n as f32;
            Vec3::new(a.cos(), a.sin(), z)
        })
    };
    let positions: Vec<Vec3> = ring(0.0).chain(ring(1.5)).collect();
    let (mut sizes, mut corners) = (Vec::new(), Vec::new());
    for k in 1..n - 1 {
        corners.extend([0, k + 1, k]); // bottom, facing down
        corners.extend([n, n + k, n + k + 1]); // top, facing up
        sizes.extend([3, 3]);
    }
    for k in 0..n {
        let j = (k + 1) % n;
        corners.extend([k, j, n + j, n + k]);
        sizes.push(4);
    }
    Mesh::new(positions, &sizes, corners, None).expect("valid cylinder")
}

#[test]
fn sliver_cylinder_is_clean_and_its_field_integrates_pieces() {
    let m = sliver_cylinder(48);
    assert_clean("sliver cylinder", &m);
    // Its slivers are far longer than the thickness: the field splits them.
    let t = Thickness::relative(0.1).per_vertex(&m, None).unwrap();
    let lengths = side_lengths(&t, Side::Exterior);
    let (tracer, tris) = Tracer::new(&m, &lengths, &ShellParams::default());
    assert!(tracer.tree.piece_count() > 2 * tris.len(), "{} pieces of {} triangles", tracer.tree.piece_count(), tris.len());
}

#[test]
fn only_slivers_longer_than_the_piece_size_are_split() {
    use super::directors::piece_max_edge;
    use glam::DVec3;
    let tri = |h: f64, l: f64| [DVec3::ZERO, DVec3::new(l, 0.0, 0.0), DVec3::new(0.5 * l, h, 0.0)];
    assert_eq!(piece_max_edge(&tri(0.1, 4.0), 0.5), 0.5); // a sliver 8 pieces long
    assert_eq!(piece_max_edge(&tri(3.0, 4.0), 0.5), f64::INFINITY); // fat: kept whole
    assert_eq!(piece_max_edge(&tri(0.01, 0.4), 0.5), f64::INFINITY); // shorter than a piece
    assert_eq!(piece_max_edge(&tri(0.1, 4.0), f64::INFINITY), f64::INFINITY);
}

#[test]
fn incremental_update_of_a_sliver_part_refits_its_pieces_and_matches_a_rebuild() {
    // Moving a few vertices and painting the thickness of two leaves every piece
    // where it was (one size from the median thickness): the tree is refitted, not
    // rebuilt, and the directors are a rebuild's.
    let mesh = sliver_cylinder(48);
    let diag = mesh.bbox_diagonal();
    let mut t = Thickness::relative(0.1).per_vertex(&mesh, None).unwrap();
    let params = ShellParams { theta: 0.0, ..Default::default() };
    let mut inc = incremental::IncrementalShell::new(mesh.clone(), t.clone(), Side::Exterior, params.clone()).unwrap();
    inc.tolerance = 0.0;
    let moved = bumped(&mesh, 5, 0.005 * diag, 0.1 * diag);
    t[7] *= 1.3;
    t[60] *= 0.7;
    let stats = inc.update(&moved, &t).unwrap();
    assert!(!stats.rebuilt && !stats.field_rebuilt && stats.retraced > 0, "{stats:?}");
    let edited = with_positions(&mesh, moved);
    let err = worst(&inc.traced_directors(), &traced(&edited, &t, Side::Exterior, &params));
    assert!(err <= 1e-4 * t[0], "worst {err}");
}

/// The stage timer (`examples/shell_stages.rs`) records every stage of a build while
/// on (other tests' builds may add to the sums, never remove a stage).
#[test]
fn stage_times_cover_a_build() {
    let m = tm::comb(1);
    let t = Thickness::relative(0.1).per_vertex(&m, None).unwrap();
    let _serial = timing::SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    timing::enable(true);
    let s = build_shell(&m, &t, Side::Exterior, &ShellParams::default()).unwrap();
    timing::enable(false);
    assert!(s.check.clean);
    let stages = timing::summed(&timing::take());
    for name in ["trace", "checker", "untangle", "untangle: find (round 0)", "restore"] {
        let found = stages.iter().find(|s| s.0 == name);
        assert!(found.is_some_and(|s| s.1 >= 0.0), "{name} missing from {stages:?}");
    }
}
