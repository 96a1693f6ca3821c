use super::*;
use crate::mesh::{fixtures, vertex_normals};
use crate::subdivision::{subdivide, Boundary, Options};
use crate::test_rng::Rng;
use crate::{hard_meshes, testmeshes};
use glam::DQuat;

/// The plain subdivision in the numbering of the synthesis.
fn plain(base: &Mesh, levels: u32) -> Mesh {
    levels_of(base, levels).unwrap().pop().unwrap()
}

/// `levels` subdivisions of `base` with every vertex pushed along its normal by a smooth
/// bump field plus noise of `noise` times the bbox diagonal: a sculpt with detail at every
/// level.
fn sculpted(base: &Mesh, levels: u32, noise: f32) -> Mesh {
    let mesh = plain(base, levels);
    let diag = mesh.bbox_diagonal();
    let mut rng = Rng(levels as u64 + 11);
    let moved = mesh
        .positions()
        .iter()
        .zip(vertex_normals(&mesh))
        .map(|(p, n)| {
            let h = 0.05 * diag * (7.0 * p.x / diag).sin() * (5.0 * p.y / diag).cos() + noise * diag * rng.range(-1.0, 1.0) as f32;
            *p + n * h
        })
        .collect();
    Mesh::new(moved, &mesh.face_sizes(), mesh.corners().to_vec(), None).unwrap()
}

fn max_error(a: &Mesh, b: &Mesh) -> f32 {
    a.positions().iter().zip(b.positions()).map(|(p, q)| p.distance(*q)).fold(0.0, f32::max) / a.bbox_diagonal()
}

fn meshes() -> Vec<(&'static str, Mesh)> {
    vec![("cube", fixtures::cube()), ("open grid", fixtures::grid(4)), ("n-gon star prism", hard_meshes::star_prism()), ("sphere", testmeshes::icosphere(1))]
}

#[test]
fn the_step_matrix_is_the_subdivision_step() {
    for (name, base) in meshes() {
        let mut rng = Rng(3);
        let p: Vec<DVec3> =
            base.positions().iter().map(|p| p.as_dvec3() + DVec3::new(rng.range(-0.1, 0.1), rng.range(-0.1, 0.1), rng.range(-0.1, 0.1))).collect();
        let moved = Mesh::new(p.iter().map(|p| p.as_vec3()).collect(), &base.face_sizes(), base.corners().to_vec(), None).unwrap();
        let want = subdivide(&moved, &Options { levels: 1, limit: false, boundary: Boundary::SmoothAll }).unwrap().mesh;
        let got = Step::of(&moved, &want).unwrap().rows.apply(&moved.positions().iter().map(|p| p.as_dvec3()).collect::<Vec<_>>());
        assert_eq!(got.len(), want.vertex_count());
        for (v, (g, w)) in got.iter().zip(want.positions()).enumerate() {
            assert!(g.as_vec3().distance(*w) < 1e-6, "{name} vertex {v}: {g} vs {w}");
        }
    }
}

#[test]
fn analysis_then_synthesis_reproduces_the_fine_mesh() {
    for (name, base) in meshes() {
        for levels in 1..=4 {
            let fine = sculpted(&base, levels, 0.01);
            let m = analyze(&fine, &base, levels).unwrap();
            assert_eq!(m.details.len(), levels as usize);
            assert_eq!(m.details.iter().map(Vec::len).collect::<Vec<_>>(), level_vertex_counts(&base, levels).unwrap());
            let back = synthesize(&m).unwrap();
            assert_eq!(back.corners(), fine.corners());
            let e = max_error(&fine, &back);
            assert!(e < 1e-5, "{name} at {levels} levels: {e} of the diagonal");
            // The details are not all on the finest level: the coarse levels carry the bumps.
            let size = |d: &[DVec3]| d.iter().map(|x| x.length()).fold(0.0, f64::max);
            assert!(size(&m.details[0]) > 1e-4 * fine.bbox_diagonal() as f64, "{name}: level 1 holds detail");
        }
    }
}

#[test]
fn a_plain_subdivision_has_no_details_and_gives_back_its_base() {
    for (name, base) in meshes() {
        for levels in 1..=3 {
            let m = analyze(&plain(&base, levels), &base, levels).unwrap();
            let diag = base.bbox_diagonal() as f64;
            for (l, d) in m.details.iter().enumerate() {
                let worst = d.iter().map(|x| x.length()).fold(0.0, f64::max);
                assert!(worst < 1e-6 * diag, "{name}, {levels} levels: level {} detail {worst}", l + 1);
            }
            for (v, (p, q)) in m.base.positions().iter().zip(base.positions()).enumerate() {
                assert!(p.distance(*q) < 1e-6 * diag as f32, "{name} base vertex {v}: {p} vs {q}");
            }
        }
    }
}

#[test]
fn details_follow_the_base_when_it_moves() {
    let base = testmeshes::icosphere(1);
    let levels = 3;
    let fine = sculpted(&base, levels, 0.005);
    let m = analyze(&fine, &base, levels).unwrap();
    // A rigid motion of the base gives the same motion of the fine mesh: the details are in
    // the local frames, not in world space.
    let (q, shift) = (DQuat::from_axis_angle(DVec3::new(1.0, -2.0, 0.5).normalize(), 1.1), DVec3::new(0.3, -1.0, 2.0));
    let moved = |p: &[Vec3]| p.iter().map(|p| (q * p.as_dvec3() + shift).as_vec3()).collect::<Vec<_>>();
    let rotated =
        Multires { base: Mesh::new(moved(m.base.positions()), &base.face_sizes(), base.corners().to_vec(), None).unwrap(), details: m.details.clone() };
    let want = Mesh::new(moved(fine.positions()), &fine.face_sizes(), fine.corners().to_vec(), None).unwrap();
    let e = max_error(&want, &synthesize(&rotated).unwrap());
    assert!(e < 1e-5, "rotated: {e}");
    // Had the details been world-space offsets, the rotated sculpt would be far off.
    let world: Vec<Vec3> = plain(&rotated.base, levels)
        .positions()
        .iter()
        .zip(fine.positions().iter().zip(plain(&m.base, levels).positions()))
        .map(|(p, (f, s))| *p + (*f - *s))
        .collect();
    let naive = Mesh::new(world, &fine.face_sizes(), fine.corners().to_vec(), None).unwrap();
    assert!(max_error(&want, &naive) > 1e-3);
    // Pushing one base vertex out carries its sculpted bumps out with it: near it, the
    // fine mesh minus the plain subdivision of its base is the same offset, turned with
    // the surface (its length kept), while the surface itself moved.
    let v = 5usize;
    let mut pushed = m.clone();
    let p = pushed.base.positions()[v];
    pushed.base.set_position(v, p * 1.3).unwrap();
    let out = synthesize(&pushed).unwrap();
    let offset = |fine: &Mesh, base: &Mesh, v: usize| fine.positions()[v] - plain(base, levels).positions()[v];
    let (before, after) = (offset(&fine, &m.base, v), offset(&out, &pushed.base, v));
    assert!(out.positions()[v].distance(fine.positions()[v]) > 0.1 * p.length(), "the surface moved");
    assert!((before.length() - after.length()).abs() < 0.05 * before.length() + 1e-6, "{before} then {after}");
}

#[test]
fn the_fine_faces_may_come_in_any_order_from_any_corner_but_not_renumbered() {
    // Blender's Multires, renumbered by match_subdivision, has Thicket's vertices and
    // faces, but its faces in its own order and from its own first corners.
    let base = fixtures::grid(3);
    let fine = sculpted(&base, 2, 0.01);
    let want = analyze(&fine, &base, 2).unwrap();
    let mut quads: Vec<[u32; 4]> = fine.corners().chunks_exact(4).map(|q| [q[0], q[1], q[2], q[3]]).collect();
    let mut rng = Rng(5);
    for (i, q) in quads.iter_mut().enumerate() {
        q.rotate_left(i % 4);
    }
    for i in (1..quads.len()).rev() {
        quads.swap(i, (rng.range(0.0, i as f64 + 1.0) as usize).min(i));
    }
    let shuffled = |quads: &[[u32; 4]]| Mesh::new(fine.positions().to_vec(), &fine.face_sizes(), quads.concat(), None).unwrap();
    assert!(analyze(&shuffled(&quads), &base, 2).unwrap() == want);
    // Two vertices' numbers swapped in the faces (positions as they were): refused.
    let (a, b) = (fine.corners()[0], fine.corners()[1]);
    let swapped: Vec<[u32; 4]> = quads
        .iter()
        .map(|q| {
            q.map(|v| {
                if v == a {
                    b
                } else if v == b {
                    a
                } else {
                    v
                }
            })
        })
        .collect();
    assert!(matches!(analyze(&shuffled(&swapped), &base, 2), Err(Error::InvalidMesh(m)) if m.contains("is none of theirs")));
    // A face repeated in place of another: refused.
    let mut repeated = quads.clone();
    repeated[0] = repeated[1];
    assert!(matches!(analyze(&shuffled(&repeated), &base, 2), Err(Error::InvalidMesh(m)) if m.contains("numbered otherwise")));
}

#[test]
fn bad_input_is_refused_with_a_message() {
    let base = fixtures::cube();
    let fine = plain(&base, 2);
    // Wrong levels, wrong base, another numbering.
    assert!(matches!(analyze(&fine, &base, 1), Err(Error::InvalidMesh(_))));
    assert!(matches!(analyze(&fine, &fixtures::grid(2), 2), Err(Error::InvalidMesh(_))));
    let mut reversed = fine.corners().to_vec();
    reversed.reverse();
    let renumbered = Mesh::new(fine.positions().to_vec(), &fine.face_sizes(), reversed, None).unwrap();
    assert!(matches!(analyze(&renumbered, &base, 2), Err(Error::InvalidMesh(m)) if m.contains("numbering")));
    assert!(matches!(analyze(&fine, &base, 0), Err(Error::InvalidParameter(_))));
    assert!(matches!(analyze(&fine, &base, 9), Err(Error::InvalidParameter(_))));
    // Details of the wrong count or not finite.
    let m = analyze(&fine, &base, 2).unwrap();
    let mut short = m.clone();
    short.details[1].pop();
    assert!(matches!(synthesize(&short), Err(Error::InvalidParameter(_))));
    let mut nan = m.clone();
    nan.details[0][3].x = f64::NAN;
    assert!(matches!(synthesize(&nan), Err(Error::InvalidParameter(_))));
    // From positions alone: the same as from the mesh; a wrong count or NaN refused.
    assert_eq!(analyze_positions(fine.positions().to_vec(), &base, 2).unwrap(), m);
    assert!(matches!(analyze_positions(fine.positions()[1..].to_vec(), &base, 2), Err(Error::InvalidMesh(_))));
    let mut p = fine.positions().to_vec();
    p[7].y = f32::NAN;
    assert!(matches!(analyze_positions(p, &base, 2), Err(Error::NonFinite { index: 7, .. })));
}

#[test]
fn limit_positions_and_matching_find_another_numbering() {
    // subdivide() numbers a level's edge points by the child edges, the synthesis by sorted
    // edges: the same limit points, another order, which matching recovers.
    for (name, base) in meshes() {
        let ours = limit_positions(&base, 3).unwrap();
        let theirs = subdivide(&base, &Options { levels: 3, limit: true, boundary: Boundary::SmoothAll }).unwrap().mesh;
        let order = match_points(theirs.positions(), &ours, 1e-5 * base.bbox_diagonal() as f64).unwrap();
        let moved = (0..ours.len()).filter(|&k| order[k] as usize != k).count();
        assert!(moved > 0 || name == "open grid", "{name}: the numberings differ");
        for (k, &i) in order.iter().enumerate() {
            assert!(ours[k].distance(theirs.positions()[i as usize]) < 1e-5 * base.bbox_diagonal(), "{name} vertex {k}");
        }
        // Their faces, renumbered, are ours.
        let renumbered: Vec<u32> = theirs.corners().iter().map(|&c| order.iter().position(|&i| i == c).unwrap() as u32).collect();
        let mine = plain(&base, 3);
        let key = |c: &[u32]| {
            let mut q: Vec<[u32; 4]> = c
                .chunks(4)
                .map(|q| {
                    let k = (0..4).min_by_key(|&k| q[k]).unwrap();
                    [q[k], q[(k + 1) % 4], q[(k + 2) % 4], q[(k + 3) % 4]]
                })
                .collect();
            q.sort();
            q
        };
        assert_eq!(key(&renumbered), key(mine.corners()), "{name}");
    }
    // Refusals: other sizes, too far, two on one.
    let a = [Vec3::ZERO, Vec3::X];
    assert!(match_points(&a, &[Vec3::ZERO], 0.1).is_err());
    assert!(match_points(&a, &[Vec3::ZERO, Vec3::Y], 0.1).is_err());
    assert!(match_points(&a, &[Vec3::ZERO, Vec3::new(0.01, 0.0, 0.0)], 0.1).is_err());
    assert_eq!(match_points(&a, &[Vec3::new(0.99, 0.0, 0.0), Vec3::ZERO], 0.1).unwrap(), vec![1, 0]);
}

#[test]
fn a_watched_analysis_counts_up_to_one_and_equals_the_plain_one() {
    let base = testmeshes::icosphere(2);
    let levels = 3;
    let fine = sculpted(&base, levels, 0.005);
    let progress = crate::progress::Progress::default();
    let seen = std::sync::Mutex::new(Vec::new());
    let finished = std::sync::atomic::AtomicBool::new(false);
    let m = std::thread::scope(|s| {
        s.spawn(|| {
            while !finished.load(std::sync::atomic::Ordering::Acquire) {
                seen.lock().unwrap().push(progress.fraction());
                std::thread::sleep(std::time::Duration::from_micros(100));
            }
        });
        let m = analyze_positions_watched(fine.positions().to_vec(), &base, levels, Some(&progress));
        finished.store(true, std::sync::atomic::Ordering::Release);
        m.unwrap()
    });
    assert_eq!(progress.fraction(), 1.0, "every stage counted to its end");
    let seen = seen.into_inner().unwrap();
    assert!(seen.windows(2).all(|w| w[0] <= w[1]), "not monotone: {seen:?}");
    assert!(seen.iter().any(|&f| f > 0.0 && f < 1.0), "no fraction between 0 and 1 seen");
    assert!(m == analyze_positions(fine.positions().to_vec(), &base, levels).unwrap());
    // With the faces checked too.
    let watched = crate::progress::Progress::default();
    assert!(analyze_watched(&fine, &base, levels, Some(&watched)).unwrap() == m);
    assert_eq!(watched.fraction(), 1.0);
}

#[test]
fn a_cancel_stops_the_analysis_at_its_next_check() {
    let base = testmeshes::icosphere(2);
    let levels = 4;
    let fine = sculpted(&base, levels, 0.005);
    // The canceller is another thread: on a loaded machine it may first run after the
    // analysis ended (then nothing was cancelled, and the run is tried again).
    let mut cancelled = 0;
    for _ in 0..5 {
        let progress = crate::progress::Progress::default();
        let (result, at_cancel) = std::thread::scope(|s| {
            let canceller = s.spawn(|| {
                while progress.fraction() < 0.2 {
                    std::thread::yield_now();
                }
                progress.cancel();
                progress.fraction()
            });
            let result = analyze_positions_watched(fine.positions().to_vec(), &base, levels, Some(&progress));
            (result, canceller.join().unwrap())
        });
        if result.is_ok() && at_cancel >= 1.0 {
            continue; // asked after the end
        }
        assert_eq!(result.unwrap_err(), Error::Cancelled);
        // At most the stage under way when it was asked (the finest fit: under half the work) goes on.
        assert!(progress.fraction() < at_cancel + 0.5, "stopped at {}, cancelled at {at_cancel}", progress.fraction());
        cancelled += 1;
        break;
    }
    assert_eq!(cancelled, 1, "no run was cancelled while under way");
    // Cancelled before it starts: nothing done.
    let early = crate::progress::Progress::default();
    early.cancel();
    assert_eq!(analyze_watched(&fine, &base, levels, Some(&early)).unwrap_err(), Error::Cancelled);
    assert_eq!(early.fraction(), 0.0);
}
