//! The *medial stop*: before the repair, each traced director is bounded by the room
//! along its chord, so that directors of two sheets facing each other across a gap
//! stop short of each other instead of crossing and being repaired (issue 14).
//!
//! The field already slows trajectories near the medial axis (4.3, figures 4.7-4.8),
//! but their straight chords (3.1) can still overlap across a gap narrower than the
//! two sheets' thicknesses together. Not from the thesis: the chord of vertex `v`
//! (length `l`) is cast as a ray against the base, its own triangles excluded; where
//! it meets the surface at distance `h < 2l`, the directors there reach back along
//! the ray by `b` (their components against it, interpolated at the hit), and where
//! `l + b > h` the two overlap: with `G = MARGIN · h`, `v` keeps `max(G/2, G - b)`,
//! a max-min fair share of the gap computed by each side alone (the two total at most
//! `G`: a side reaching back less than `G/2` leaves the other the rest, else each
//! keeps at most `G/2`), so a short director facing a long one keeps its length or
//! half the gap. Chords that do not overlap are left alone (bounding them too, or spreading
//! the bounds to neighbours, lowered the mean thickness ratio on the comb and on
//! beast; README, issue 14). The repair and its final check still run on the bounded
//! shell and guarantee it; the restore still gives back thickness where normals have
//! room.

use super::defects::Checker;
use super::{Shell, Side};
use crate::spatial::ray_triangle;
use crate::Mesh;
use glam::Vec3;
use rayon::prelude::*;

/// The share of the gap two overlapping facing directors keep together, so that
/// they stop apart.
pub const MARGIN: f64 = 0.9;

/// The room bound of the director of each of `which` (infinite where its chord
/// overlaps no facing director), the facing side's reach back measured on `facing`
/// (the traced directors, as a build measures them); `None` for envelopes, whose
/// directors cross the base.
pub(crate) fn room_bounds(checker: &Checker, mesh: &Mesh, shell: &Shell, which: &[u32], facing: &[Vec3]) -> Option<Vec<f64>> {
    if shell.side == Side::Envelope {
        return None;
    }
    let p = mesh.positions();
    let bound: Vec<f64> = which
        .par_iter()
        .with_min_len(64)
        .map(|&v| {
            let v = v as usize;
            let d = shell.directors[v].as_dvec3();
            let len = d.length();
            if !(len > 0.0) {
                return f64::INFINITY;
            }
            let (o, dir) = ((p[v] + shell.base_offset[v]).as_dvec3(), d / len);
            let v = v as u32;
            let hit = checker.base_bvh.first_on_ray(o, dir, 2.0 * len, |j| {
                (!checker.tris[j as usize].contains(&v)).then(|| ray_triangle(o, dir, &checker.base[j as usize])).flatten()
            });
            let Some((j, h)) = hit else { return f64::INFINITY };
            // How far the surface met grows back along the ray: its corners' directors
            // towards `o`, weighted by the barycentric coordinates of the hit.
            let t = &checker.base[j as usize];
            let x = o + dir * h;
            let w = barycentric(t, x);
            let back: f64 = checker.tris[j as usize].iter().zip(w).map(|(&c, w)| w * (-facing[c as usize].as_dvec3().dot(dir)).max(0.0)).sum();
            if len + back <= h {
                return f64::INFINITY;
            }
            let gap = MARGIN * h;
            (gap - back).max(0.5 * gap)
        })
        .collect();
    Some(bound)
}

/// Shortens the directors of `which` to their room bounds ([`room_bounds`]): all for
/// `None` (a build, whose directors are the traced ones); after an edit, the
/// directors reset to their traced value, with every vertex's traced director (the
/// others may hold an earlier stop or repair), so that the bounds are a build's.
/// Returns how many were shortened.
pub(crate) fn stop_at_room(checker: &Checker, mesh: &Mesh, shell: &mut Shell, which: Option<(&[u32], &[Vec3])>) -> usize {
    let _t = super::timing::Stage::start("medial stop");
    let all: Vec<u32>;
    let (which, bound) = match which {
        Some((w, traced)) => (w, room_bounds(checker, mesh, shell, w, traced)),
        None => {
            all = (0..mesh.vertex_count() as u32).collect();
            (&all[..], room_bounds(checker, mesh, shell, &all, &shell.directors))
        }
    };
    let Some(bound) = bound else { return 0 };
    let mut shortened = 0;
    for (&v, b) in which.iter().zip(bound) {
        let v = v as usize;
        let len = shell.achieved[v] as f64;
        if b < len {
            let f = (b / len) as f32;
            shell.directors[v] *= f;
            shell.base_offset[v] *= f;
            shell.achieved[v] = shell.directors[v].length();
            shortened += 1;
        }
    }
    shortened
}

/// Barycentric coordinates of `x` (on the plane of `t`) in triangle `t`, clamped to it.
fn barycentric(t: &[glam::DVec3; 3], x: glam::DVec3) -> [f64; 3] {
    let (e1, e2, d) = (t[1] - t[0], t[2] - t[0], x - t[0]);
    let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let den = d11 * d22 - d12 * d12;
    if !(den > 0.0) {
        return [1.0 / 3.0; 3];
    }
    let (a, b) = (d.dot(e1), d.dot(e2));
    let v = ((d22 * a - d12 * b) / den).clamp(0.0, 1.0);
    let w = ((d11 * b - d12 * a) / den).clamp(0.0, 1.0 - v);
    [1.0 - v - w, v, w]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shell::repair::tests::nearly_touching;
    use crate::shell::report::shell_report;
    use crate::shell::{build_shell, ShellParams, Thickness};

    /// Two unit spheres 0.05 apart with normal directors of 0.6: the directors facing
    /// across the gap overlap. The tree's first hit is the brute force's. After the
    /// stop, checked against every triangle: a stopped director keeps at least half
    /// of `MARGIN` of the gap, and at most what the least reach back of the hit
    /// triangle's corners (before the stop) leaves of it, or that half; a director not
    /// stopped overlaps not even that least reach, or is within that bound. Fewer
    /// directors cross the plane halfway between the spheres.
    /// (One pass: a director stopped for a facing one that was not stopped itself may
    /// still overlap it; the repair sees to those.)
    #[test]
    fn facing_directors_stop_short_of_each_other() {
        let (mesh, mut shell) = nearly_touching(0.6);
        let checker = Checker::new(&mesh);
        let p = mesh.positions();
        let before = shell.clone();
        let hit = |v: u32, s: &Shell| {
            let (o, dir) = (p[v as usize].as_dvec3(), s.directors[v as usize].as_dvec3().normalize());
            let far = 2.0 * s.achieved[v as usize] as f64;
            let tree = checker
                .base_bvh
                .first_on_ray(o, dir, far, |j| (!checker.tris[j as usize].contains(&v)).then(|| ray_triangle(o, dir, &checker.base[j as usize])).flatten());
            let brute = (0..checker.tris.len())
                .filter(|&j| !checker.tris[j].contains(&v))
                .filter_map(|j| ray_triangle(o, dir, &checker.base[j]).filter(|&h| h <= far).map(|h| (j as u32, h)))
                .min_by(|a, b| a.1.total_cmp(&b.1));
            assert_eq!(tree.map(|t| t.1), brute.map(|b| b.1), "vertex {v}");
            brute.map(|(j, h)| {
                let least =
                    checker.tris[j as usize].iter().map(|&c| (-before.directors[c as usize].as_dvec3().dot(dir)).max(0.0)).fold(f64::INFINITY, f64::min);
                (h, least)
            })
        };
        let hits: Vec<_> = (0..p.len() as u32).map(|v| hit(v, &before)).collect();
        let stopped = stop_at_room(&checker, &mesh, &mut shell, None);
        assert!(stopped >= 10, "{stopped}");
        let mut seen = 0;
        for (v, h) in hits.iter().enumerate() {
            let (len, now) = (before.achieved[v] as f64, shell.achieved[v] as f64);
            let share = |h: f64, least: f64| (MARGIN * h - least).max(0.5 * MARGIN * h) * (1.0 + 1e-5);
            if shell.directors[v] == before.directors[v] {
                assert!(h.is_none_or(|(h, least)| len + least <= h * (1.0 + 1e-5) || len <= share(h, least)), "vertex {v}: {len} {h:?}");
                continue;
            }
            seen += 1;
            let (h, least) = h.expect("a stopped director met the surface");
            assert!(now < len && shell.directors[v].normalize().dot(before.directors[v].normalize()) > 0.99999, "vertex {v}");
            assert!(now <= share(h, least) && now >= 0.5 * MARGIN * h * (1.0 - 1e-5), "vertex {v}: {now} of {len}, gap {h}, reach {least}");
        }
        assert_eq!(seen, stopped);
        // The left sphere's vertices come first (x < 0).
        let crossing = |s: &Shell| (0..p.len()).filter(|&v| (p[v].x + s.directors[v].x) * p[v].x < 0.0).count();
        assert!(crossing(&shell) < crossing(&before), "{} {}", crossing(&shell), crossing(&before));
        // Envelopes are left to the repair.
        let mut envelope = before.clone();
        envelope.side = Side::Envelope;
        assert_eq!(stop_at_room(&checker, &mesh, &mut envelope, None), 0);
    }

    /// The spheres with short directors (0.03) on the left facing long ones (0.6) on
    /// the right: a proportional share would cut the short ones to a tenth; the fair
    /// share lets each stopped left director keep its length or half of `MARGIN` of
    /// the gap, and along every chord that met the other sphere the two stopped sides
    /// stay apart (the director and the reach back at its hit, both after the stop,
    /// within the gap).
    #[test]
    fn a_short_director_facing_a_long_one_keeps_half_the_gap() {
        let (mesh, mut shell) = nearly_touching(0.6);
        let p = mesh.positions();
        for v in (0..p.len()).filter(|&v| p[v].x < 0.0) {
            shell.directors[v] *= 0.05;
            shell.achieved[v] = shell.directors[v].length();
        }
        let checker = Checker::new(&mesh);
        let before = shell.clone();
        let stopped = stop_at_room(&checker, &mesh, &mut shell, None);
        let (mut left, mut right, mut pairs) = (0, 0, 0);
        for (v, pv) in p.iter().enumerate() {
            let d = before.directors[v].as_dvec3();
            let (o, dir, len) = (pv.as_dvec3(), d.normalize(), d.length());
            let vi = v as u32;
            let hit = checker.base_bvh.first_on_ray(o, dir, 2.0 * len, |j| {
                (!checker.tris[j as usize].contains(&vi)).then(|| ray_triangle(o, dir, &checker.base[j as usize])).flatten()
            });
            let now = shell.achieved[v] as f64;
            if now == before.achieved[v] as f64 {
                continue;
            }
            let (j, h) = hit.expect("a stopped director met the surface");
            if pv.x < 0.0 {
                left += 1;
                assert!(now >= (0.5 * MARGIN * h).min(len) * (1.0 - 1e-5), "vertex {v}: {now} of {len}, gap {h}");
            } else {
                right += 1;
            }
            let w = barycentric(&checker.base[j as usize], o + dir * h);
            let back: f64 = checker.tris[j as usize].iter().zip(w).map(|(&c, w)| w * (-shell.directors[c as usize].as_dvec3().dot(dir)).max(0.0)).sum();
            if back > 0.0 {
                pairs += 1;
                assert!(now + back < h, "vertex {v}: {now} + {back} >= gap {h}");
            }
        }
        assert_eq!(left + right, stopped);
        assert!(left >= 1 && right >= 10 && pairs >= 10, "{left} {right} {pairs}");
    }

    /// Built with and without the stop on a thin-gap mesh (two spheres 0.05 apart, the
    /// comb): both shells are clean, the stop keeps the mean thickness ratio and the
    /// least ratio where normals have room, and the repair runs no more rounds. The
    /// stop fires on few of these traced shells (the spheres at 20%: 2 directors; the
    /// field's slowing near the medial axis keeps the others apart): the count is
    /// asserted so that the comparison is not of two equal builds only.
    #[test]
    fn a_thin_gap_shell_with_the_stop_is_clean_and_keeps_its_thickness() {
        let spheres = nearly_touching(0.6).0;
        let mut fired = Vec::new();
        for (name, mesh) in [("spheres", spheres), ("comb", crate::testmeshes::comb(1))] {
            for (side, fraction) in [(Side::Exterior, 0.1f32), (Side::Exterior, 0.2), (Side::Interior, 0.05)] {
                let t = Thickness::relative(fraction).per_vertex(&mesh, None).unwrap();
                let build = |medial_stop: bool| {
                    let shell = build_shell(&mesh, &t, side, &ShellParams { medial_stop, ..Default::default() }).unwrap();
                    let r = shell_report(&mesh, &shell);
                    let case = format!("{name} {side:?} {fraction} stop {medial_stop}");
                    assert!(shell.check.clean, "{case}: {:?}", shell.check);
                    assert_eq!((r.outer_self_intersections, r.outer_base_intersections, r.inverted_cells), (0, 0, 0), "{case}: {r:?}");
                    eprintln!("{case}: {:?} mean {} compressed {}", shell.check, r.mean_ratio, r.compressed_vertices);
                    (shell.check.rounds, r.mean_ratio, r.min_ratio_normal_valid)
                };
                let (plain, with) = (build(false), build(true));
                // How many traced directors the stop shortens here.
                let mut traced = build_shell(&mesh, &t, side, &ShellParams { medial_stop: false, repair_rounds: 0, ..Default::default() }).unwrap();
                let stopped = stop_at_room(&Checker::new(&mesh), &mesh, &mut traced, None);
                eprintln!("{name} {side:?} {fraction}: the stop shortened {stopped}");
                fired.push(stopped);
                assert!(with.1 >= plain.1 - 1e-4, "{name} {side:?} {fraction}: mean ratio {} < {}", with.1, plain.1);
                assert!(with.0 <= plain.0, "{name} {side:?} {fraction}: rounds {} > {}", with.0, plain.0);
                // Issue 14's 95% rule, or what the shell reached without the stop where
                // it does not (the spheres at 20%: 0.93).
                assert!(with.2 >= plain.2.min(0.95), "{name} {side:?} {fraction}: {} < {}", with.2, plain.2);
            }
        }
        assert!(fired.iter().sum::<usize>() >= 2, "{fired:?}");
    }

    /// The stop on the hand (fingers 2% of the diagonal apart) subdivided twice (51k
    /// vertices, the resolution `bench_shell.py` measures) at exterior 20%. Measured
    /// here it does not fire widely: it shortens 20 traced directors, and the repair
    /// took 38 rounds either way. Asserted: it fires, both shells are clean, the
    /// repair runs no more rounds with it than without, and the mean ratio and the
    /// share of vertices with room at 95% stay within rounding. Not asserted, as it
    /// does not hold: the least ratio among vertices with room, 0.0074 without the
    /// stop and 0.0053 with it (both far below issue 14's 95%).
    #[test]
    fn the_stop_on_the_subdivided_hand_keeps_it_clean() {
        let options = crate::subdivision::Options { levels: 2, ..Default::default() };
        let mesh = crate::subdivision::subdivide(&crate::hard_meshes::hand(), &options).unwrap().mesh;
        let t = Thickness::relative(0.2).per_vertex(&mesh, None).unwrap();
        let mut traced = build_shell(&mesh, &t, Side::Exterior, &ShellParams { medial_stop: false, repair_rounds: 0, ..Default::default() }).unwrap();
        let stopped = stop_at_room(&Checker::new(&mesh), &mesh, &mut traced, None);
        let build = |medial_stop: bool| {
            let shell = build_shell(&mesh, &t, Side::Exterior, &ShellParams { medial_stop, ..Default::default() }).unwrap();
            let r = shell_report(&mesh, &shell);
            assert!(shell.check.clean, "stop {medial_stop}: {:?}", shell.check);
            assert_eq!((r.outer_self_intersections, r.outer_base_intersections, r.inverted_cells), (0, 0, 0), "stop {medial_stop}: {r:?}");
            eprintln!("hand exterior 0.2 stop {medial_stop}: {:?} {r:?}", shell.check);
            (shell.check.rounds, r)
        };
        let ((plain_rounds, plain), (rounds, with)) = (build(false), build(true));
        eprintln!("the stop shortened {stopped} of {} directors", mesh.vertex_count());
        assert!(stopped >= 10, "{stopped}");
        assert!(rounds <= plain_rounds, "rounds {rounds} > {plain_rounds}");
        assert!(with.mean_ratio >= plain.mean_ratio - 1e-4, "mean {} < {}", with.mean_ratio, plain.mean_ratio);
        assert!(with.normal_valid_at_95 >= plain.normal_valid_at_95 - 1e-3, "{} < {}", with.normal_valid_at_95, plain.normal_valid_at_95);
    }
}
