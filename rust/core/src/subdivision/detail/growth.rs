//! The morphogenic models of section 4.2 (tentacle, spur, mushroom cloud), whose
//! displacement grows with the level ("directly proportional to scale"), and the fuse of
//! 6.1. Each returns one world-space offset per vertex of the level.
//!
//! Tentacle: the paper's `magnitude = reference_length * level` is taken literally (not the
//! level's edge length): each level's pull is longer while the subdivision after it spreads
//! it over half the width, so the tip lengthens and thins; a pull scaled by the edge length
//! would shrink with the level, the fractal class the paper contrasts. The paper negates the
//! whole vector on even levels; negating its normal part would push the tip back through
//! the surface on every even level (level 2 pulls `-2 length` against the `~0.56 length`
//! level 1 left), so only the tangential part is negated: the turn from level to level is
//! then `pi/3 + pi`, a steady twist of 120 degrees about the normal (counterclockwise seen
//! from outside), and the normal part always grows outward.

use super::fold_guard::Tally;
use super::frames::{first_neighbours, frames_of};
use super::Grid;
use crate::Mesh;
use glam::{DVec3, Vec3};
use rayon::prelude::*;
use std::f64::consts::PI;

/// The tentacle's pull at level `l` in the seed's frame (t, b, n): `length * l *
/// (±sin(theta + l pi/3), ±cos(theta + l pi/3), 1)`, the sign `-` on even levels.
pub fn tentacle_local(level: u32, length: f64, theta: f64) -> DVec3 {
    let phase = theta + PI / 3.0 * level as f64;
    let sign = if level.is_multiple_of(2) { -1.0 } else { 1.0 };
    length * level as f64 * DVec3::new(sign * phase.sin(), sign * phase.cos(), 1.0)
}

/// The spur's pull at level `l`: `length * l` along the normal.
pub fn spur_local(level: u32, length: f64) -> DVec3 {
    DVec3::new(0.0, 0.0, length * level as f64)
}

/// Offsets moving each of `seeds` by `local` in its frame, every other vertex by nothing.
pub fn at_seeds(mesh: &Mesh, normals: &[Vec3], seeds: &[u32], local: DVec3) -> Vec<DVec3> {
    let next = first_neighbours(mesh.faces(), mesh.vertex_count());
    let mut out = vec![DVec3::ZERO; mesh.vertex_count()];
    for (&s, frame) in seeds.iter().zip(frames_of(mesh.positions(), normals, &next, seeds)) {
        out[s as usize] = frame.to_world(local);
    }
    out
}

/// A mushroom cloud's vortex ring: the flow of [`Ring::velocity`] about `center` and `axis`
/// within `radius`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ring {
    pub center: DVec3,
    pub axis: DVec3,
    pub radius: f64,
}

impl Ring {
    /// The ring of a seed at `p` with normal `n` (level 1): centred `radius / 2` above it.
    pub fn over(p: Vec3, n: Vec3, radius: f64) -> Self {
        let axis = n.as_dvec3().try_normalize().unwrap_or(DVec3::Z);
        Ring { center: p.as_dvec3() + 0.5 * radius * axis, axis, radius }
    }

    /// A rising vortex ring with compact support: the axisymmetric flow of Stokes stream
    /// function `psi = r^2 (1 - s^2)^2 / 2`, `s^2 = (r^2 + z^2) / a^2`, `r` the distance from
    /// the axis, `z` the height over the centre, `a` the radius; zero for `s >= 1`. Its
    /// velocity `u_r = 2 r z (1 - s^2) / a^2`, `u_z = (1 - s^2)(1 - s^2 - 2 r^2 / a^2)` is
    /// divergence-free (volume is kept), 1 up the axis at the centre, outward above the
    /// centre, down on the outside and inward below: stem, cap and rolling rim. A
    /// simplification of Hill's spherical vortex, whose `psi` is `r^2 (1 - s^2)`.
    pub fn velocity(&self, q: DVec3) -> DVec3 {
        let o = q - self.center;
        let z = o.dot(self.axis);
        let radial = o - z * self.axis;
        let a2 = self.radius * self.radius;
        let r2 = radial.length_squared();
        let w = 1.0 - (r2 + z * z) / a2;
        if w <= 0.0 {
            return DVec3::ZERO;
        }
        radial * (2.0 * z * w / a2) + self.axis * (w * (w - 2.0 * r2 / a2))
    }
}

/// Offsets carrying each point for a time `time` along the summed flow of `rings` (the
/// midpoint rule, steps short against the radius). A point no ring reaches stays put.
pub fn advect(p: &[Vec3], rings: &[Ring], time: f64) -> Vec<DVec3> {
    let Some(reach) = rings.iter().map(|r| r.radius).reduce(f64::max) else {
        return vec![DVec3::ZERO; p.len()];
    };
    let grid = Grid::new(rings.iter().map(|r| r.center), reach);
    let velocity = |q: DVec3| grid.within(q, reach).map(|(k, _)| rings[k].velocity(q)).sum::<DVec3>();
    let min_radius = rings.iter().map(|r| r.radius).reduce(f64::min).unwrap_or(reach);
    // Speeds are at most about 1: steps of at most 1/8 of the smallest ring.
    let steps = (8.0 * time.abs() / min_radius).ceil().clamp(1.0, 256.0) as usize;
    let dt = time / steps as f64;
    p.par_iter()
        .map(|q| {
            let start = q.as_dvec3();
            let mut x = start;
            for _ in 0..steps {
                let v = velocity(x);
                if v == DVec3::ZERO {
                    break;
                }
                x += dt * velocity(x + 0.5 * dt * v);
            }
            x - start
        })
        .collect()
}

/// The share of its distance to the fuse's axis a point may move towards it: the radial
/// map `rho -> rho + step(z)` is one to one while `rho + step > 0`, and a step past the
/// axis (on a flat end, near where the surface meets the axis) turns the faces there over.
pub const FUSE_AXIS_SHARE: f64 = 0.5;

/// The fuse profile with its first `terms` terms, `sin(sum_{i < terms} 2^-i sin(t^(2^i)))`.
pub fn fuse_profile(t: f64, terms: u32) -> f64 {
    let (mut power, mut sum) = (t, 0.0);
    for i in 0..terms {
        sum += 0.5f64.powi(i as i32) * power.sin();
        power *= power;
    }
    sum.sin()
}

/// The largest distance along `axis` (unit) from `center` of `positions`.
pub fn half_extent(positions: &[Vec3], center: DVec3, axis: DVec3) -> f64 {
    positions.iter().map(|p| (p.as_dvec3() - center).dot(axis).abs()).fold(0.0, f64::max)
}

/// The fuse's level `level`: each point moves away from the axis (through `center`, unit
/// `axis`) by `amplitude * (profile(t, l) - profile(t, l - 1))`, `t = span * z / reach`,
/// `z` its axial coordinate, times `gain[v]` where given (a local modification's), so after `L` levels the radial offsets sum to `amplitude *
/// profile(t, L)` (less what the subdivision in between smooths). Points on the axis stay,
/// and a point moves towards the axis by at most [`FUSE_AXIS_SHARE`] of its distance to
/// it (the fold guard's part for the fuse, counted in `tally`): `rho + step` stays
/// positive and increasing in `rho`, so no face is carried across the axis.
#[allow(clippy::too_many_arguments)]
pub fn fuse(p: &[Vec3], level: u32, amplitude: f64, gain: &[f64], span: f64, center: DVec3, axis: DVec3, reach: f64, tally: &mut Tally) -> Vec<DVec3> {
    let moved: Vec<(DVec3, bool)> = p
        .par_iter()
        .enumerate()
        .map(|(v, q)| {
            let o = q.as_dvec3() - center;
            let z = o.dot(axis);
            let t = span * z / reach;
            let step = amplitude * gain.get(v).copied().unwrap_or(1.0) * (fuse_profile(t, level) - fuse_profile(t, level - 1));
            let radial = o - z * axis;
            let floor = -FUSE_AXIS_SHARE * radial.length();
            radial.try_normalize().map_or((DVec3::ZERO, false), |e| (e * step.max(floor), step < floor))
        })
        .collect();
    if amplitude != 0.0 {
        tally.placed += moved.iter().filter(|(w, _)| *w != DVec3::ZERO).count() as u64;
        tally.limited += moved.iter().filter(|(_, limited)| *limited).count() as u64;
    }
    moved.into_iter().map(|(w, _)| w).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_fuse_never_carries_a_point_across_its_axis() {
        // At the far end (t = -span) level 1's step is amplitude * sin(sin(-1.5)), 0.84
        // of it towards the axis: a point 0.01 from the axis would land 0.83 past it; it
        // moves to half its distance instead, on its own side, and the tally counts it.
        // A point 2 from the axis takes the whole step.
        let p = [Vec3::new(0.01, 0.0, -1.0), Vec3::new(0.0, 2.0, -1.0), Vec3::new(0.0, 0.0, -1.0)];
        let mut tally = Tally::default();
        let w = fuse(&p, 1, 1.0, &[], 1.5, DVec3::ZERO, DVec3::Z, 1.0, &mut tally);
        let step = (-1.5f64).sin().sin();
        assert!((w[0] - DVec3::new(-0.005, 0.0, 0.0)).length() < 1e-9, "{}", w[0]);
        assert!((w[1] - DVec3::new(0.0, step, 0.0)).length() < 1e-9, "{}", w[1]);
        assert_eq!(w[2], DVec3::ZERO);
        assert_eq!(tally, Tally { placed: 2, limited: 1 });
    }

    #[test]
    fn the_vortex_ring_keeps_volume_and_turns_the_right_way() {
        // Divergence by central differences is zero inside, the flow rises on the axis,
        // goes out above the centre, down outside and in below; nothing beyond the radius.
        let ring = Ring { center: DVec3::new(0.3, -0.2, 0.5), axis: DVec3::new(1.0, 2.0, 2.0) / 3.0, radius: 0.7 };
        let (n, e) = (ring.axis, DVec3::new(2.0, -1.0, 0.0).normalize());
        let h = 1e-5;
        let mut rng = crate::test_rng::Rng(5);
        for _ in 0..500 {
            let q = ring.center + rng.vec(0.6);
            let div: f64 = (0..3)
                .map(|k| {
                    let d = DVec3::AXES[k] * h;
                    (ring.velocity(q + d)[k] - ring.velocity(q - d)[k]) / (2.0 * h)
                })
                .sum();
            assert!(div.abs() < 1e-6, "divergence {div} at {q}");
        }
        let at = |r: f64, z: f64| ring.velocity(ring.center + e * r * ring.radius + n * z * ring.radius);
        assert!((at(0.0, 0.0) - n).length() < 1e-12);
        assert!(at(0.3, 0.3).dot(e) > 0.0 && at(0.3, -0.3).dot(e) < 0.0 && at(0.8, 0.0).dot(n) < 0.0);
        assert_eq!(at(0.8, 0.7), DVec3::ZERO);
    }

    #[test]
    fn the_fuse_profile_is_the_papers_sum() {
        for t in [-1.3f64, 0.0, 0.4, 1.1, 2.0] {
            let want = (t.sin() + (t * t).sin() / 2.0 + (t * t * t * t).sin() / 4.0).sin();
            assert!((fuse_profile(t, 3) - want).abs() < 1e-12);
            assert_eq!(fuse_profile(t, 0), 0.0);
        }
    }

    #[test]
    fn the_tentacle_turns_120_degrees_a_level_and_keeps_growing_out() {
        for theta in [0.0, 0.7, -2.0] {
            for l in 1..6 {
                let (a, b) = (tentacle_local(l, 0.1, theta), tentacle_local(l + 1, 0.1, theta));
                let turn = (b.y.atan2(b.x) - a.y.atan2(a.x)).rem_euclid(2.0 * PI);
                assert!((turn - 2.0 * PI / 3.0).abs() < 1e-12, "level {l}: {turn}");
                assert!((a.z - 0.1 * l as f64).abs() < 1e-15 && (a.truncate().length() - a.z).abs() < 1e-12);
            }
        }
    }

    use super::super::frames::Frame;
    use super::super::{procedural_detail, synthesize, Detailed, Model, Offsets, State};
    use crate::mesh::vertex_normals;
    use crate::subdivision::{subdivide, Boundary, Options};
    use crate::{testmeshes, Error};

    /// `levels` one-level subdivisions, as the synthesis makes them (one call of
    /// [`subdivide`] for several levels numbers the new vertices of the later ones
    /// differently: only the base's vertices keep their indices in both).
    fn plain(base: &Mesh, levels: u32) -> Mesh {
        (0..levels).fold(base.clone(), |m, _| subdivide(&m, &Options { levels: 1, limit: false, boundary: Boundary::SmoothAll }).unwrap().mesh)
    }

    /// Vertices of `out` farther than `far` from `from` in `reference` (plain subdivision)
    /// sit where it puts them; returns how many did, and how many nearer ones moved.
    fn far_vertices_stay(out: &Detailed, reference: &Mesh, from: Vec3, far: f32) -> (usize, usize) {
        let (mut stayed, mut moved) = (0, 0);
        for (v, (q, p)) in out.mesh.positions().iter().zip(reference.positions()).enumerate() {
            if p.distance(from) > far {
                assert!(q.distance(*p) < 1e-6, "vertex {v} at {p}, {} from the seed at {from}, moved {}", p.distance(from), q.distance(*p));
                stayed += 1;
            } else {
                moved += (q.distance(*p) > 1e-4) as usize;
            }
        }
        (stayed, moved)
    }

    #[test]
    fn a_tentacle_seed_moves_by_the_formula_in_its_frame_at_level_1() {
        let base = testmeshes::icosphere(2);
        let (length, theta) = (0.05, 0.4);
        let out = procedural_detail(&base, 1, &Model::Tentacle { length, theta, seeds: vec![7], spacing: 0.5 }, 0).unwrap();
        let reference = plain(&base, 1);
        let p = reference.positions();
        // The frame from the plain level: its normal, the tangent towards the vertex after
        // 7 in the first face holding it.
        let face = reference.faces().find(|f| f.contains(&7)).unwrap();
        let next = face[(face.iter().position(|&v| v == 7).unwrap() + 1) % face.len()];
        let frame = Frame::new(vertex_normals(&reference)[7].as_dvec3(), (p[next as usize] - p[7]).as_dvec3());
        let moved = (out.mesh.positions()[7] - p[7]).as_dvec3();
        let want = frame.to_world(length * DVec3::new((theta + PI / 3.0).sin(), (theta + PI / 3.0).cos(), 1.0));
        assert!((moved - want).length() < 1e-6, "{moved} against {want}");
        assert!((out.scalar[7] as f64 - length).abs() < 1e-6);
        let (stayed, moved) = far_vertices_stay(&out, &reference, p[7], 1e-3);
        assert_eq!((stayed, moved), (p.len() - 1, 1));
    }

    #[test]
    fn the_tentacle_tip_turns_120_degrees_from_level_to_level() {
        // A flat grid, the seed at its centre: each level's pull, seen from above, turns by
        // 120 degrees counterclockwise; the frame tilts with the tip, so within 3 degrees.
        let base = crate::mesh::fixtures::grid(8);
        let model = Model::Tentacle { length: 0.005, theta: 0.3, seeds: vec![40], spacing: 1.0 };
        let mut pulls = Vec::new();
        synthesize(&base, 4, State::default(), |level, mesh, normals, state| {
            let out = model.displacements(level, mesh, normals, 0, state);
            let Offsets::World(w) = &out else { unreachable!() };
            pulls.push(w[40]);
            assert!(w.iter().enumerate().all(|(v, w)| v == 40 || *w == DVec3::ZERO));
            out
        })
        .unwrap();
        for (l, pair) in pulls.windows(2).enumerate() {
            let turn = (pair[1].y.atan2(pair[1].x) - pair[0].y.atan2(pair[0].x)).rem_euclid(2.0 * PI).to_degrees();
            assert!((turn - 120.0).abs() < 3.0, "levels {} to {}: {turn} degrees ({pulls:?})", l + 1, l + 2);
            assert!(pair[1].z > pair[0].z && pair[0].z > 0.0, "{pulls:?}");
        }
    }

    #[test]
    fn growth_leaves_far_vertices_where_subdivision_puts_them() {
        // A pull at level 1 reaches two level-1 edges at most (the support of a cubic
        // B-spline); icosphere(2)'s level-1 edges are about 0.16 long.
        let base = testmeshes::icosphere(2);
        let reference = plain(&base, 3);
        let from = reference.positions()[7];
        for model in [
            Model::Tentacle { length: 0.03, theta: 1.0, seeds: vec![7], spacing: 0.5 },
            Model::Spur { length: 0.03, seeds: vec![7], spacing: 0.5 },
            Model::Mushroom { radius: 0.3, length: 0.1, seeds: vec![7] },
        ] {
            let out = procedural_detail(&base, 3, &model, 0).unwrap();
            let far = if matches!(model, Model::Mushroom { .. }) { 0.3 + 0.4 } else { 0.4 };
            let (stayed, moved) = far_vertices_stay(&out, &reference, from, far);
            assert!(stayed > reference.vertex_count() / 2 && moved > 10, "{model:?}: {stayed} stayed, {moved} moved");
        }
    }

    #[test]
    fn a_spur_grows_along_the_normal() {
        let base = testmeshes::icosphere(2);
        let length = 0.04;
        let model = Model::Spur { length, seeds: vec![3, 9], spacing: 0.5 };
        synthesize(&base, 3, State::default(), |level, mesh, normals, state| {
            let out = model.displacements(level, mesh, normals, 0, state);
            let Offsets::World(w) = &out else { unreachable!() };
            for s in [3, 9] {
                let want = normals[s].as_dvec3() * length * level as f64;
                assert!((w[s] - want).length() < 1e-7, "level {level}, seed {s}: {} against {want}", w[s]);
            }
            out
        })
        .unwrap();
        let out = procedural_detail(&base, 1, &model, 0).unwrap();
        let reference = plain(&base, 1);
        let moved = (out.mesh.positions()[3] - reference.positions()[3]).as_dvec3();
        assert!((moved - vertex_normals(&reference)[3].as_dvec3() * length).length() < 1e-6, "{moved}");
    }

    /// An open tube of radius 1 about the z axis, z from -2 to 2.
    fn tube(around: u32, rows: u32) -> Mesh {
        let mut p = Vec::new();
        for j in 0..=rows {
            for i in 0..around {
                let a = 2.0 * std::f32::consts::PI * i as f32 / around as f32;
                p.push(Vec3::new(a.cos(), a.sin(), 4.0 * j as f32 / rows as f32 - 2.0));
            }
        }
        let mut corners = Vec::new();
        for j in 0..rows {
            for i in 0..around {
                let (a, b) = (j * around + i, j * around + (i + 1) % around);
                corners.extend([a, b, b + around, a + around]);
            }
        }
        Mesh::new(p, &vec![4; (around * rows) as usize], corners, None).unwrap()
    }

    #[test]
    fn the_fuse_radius_follows_the_profile() {
        // At the finest level each vertex's distance from the axis exceeds plain
        // subdivision's by amplitude * profile(t, levels) within 1% of the amplitude (the
        // levels after a term smooth it a little: 0.18% measured), away from the tube's open ends.
        let base = tube(32, 24);
        let (amplitude, span, levels) = (0.1, 1.5, 3);
        let out = procedural_detail(&base, levels, &Model::Fuse { amplitude, span, center: DVec3::ZERO, axis: DVec3::Z * 3.0 }, 0).unwrap();
        let reference = plain(&base, levels);
        let mut worst: f64 = 0.0;
        let mut checked = 0;
        for (q, p) in out.mesh.positions().iter().zip(reference.positions()) {
            if q.z.abs() < 1.5 {
                let t = span * q.z as f64 / 2.0;
                let got = q.truncate().length() as f64 - p.truncate().length() as f64;
                worst = worst.max((got - amplitude * fuse_profile(t, levels)).abs());
                checked += 1;
            }
        }
        assert!(checked > 1000 && worst < 0.01 * amplitude, "worst {worst} over {checked} vertices");
    }

    #[test]
    fn a_mushroom_cloud_has_a_cap_over_its_stem_and_keeps_the_volume() {
        // On a flat grid the cloud's cap overhangs its stem: faces under the cap face the
        // ground (a displaced height field never does), high above it. On a closed sphere
        // the flow, divergence-free, keeps the enclosed volume of plain subdivision
        // within 2% (1.5% measured: the surface samples the flow at its vertices only).
        let base = testmeshes::plane(16);
        let radius = 0.5;
        let centre = 16 * 17 / 2 + 8; // the vertex at (0, 0)
        let out = procedural_detail(&base, 3, &Model::Mushroom { radius, length: 0.4 * radius, seeds: vec![centre] }, 0).unwrap();
        let p = out.mesh.positions();
        let top = p.iter().map(|q| q.z).fold(0.0, f32::max);
        let mut down = 0;
        for face in out.mesh.faces() {
            let (a, b, c, d) = (p[face[0] as usize], p[face[1] as usize], p[face[2] as usize], p[face[3] as usize]);
            let normal = (c - a).cross(d - b);
            let mid = (a + b + c + d) / 4.0;
            if normal.z < 0.0 {
                assert!(mid.z > 0.2 * top && mid.truncate().length() < 1.5 * radius as f32, "a face down at {mid}");
                down += 1;
            }
        }
        assert!(top > radius as f32 && down > 20, "top {top}, {down} faces facing down");
        let sphere = testmeshes::icosphere(2);
        let cloud = procedural_detail(&sphere, 3, &Model::Mushroom { radius: 0.4, length: 0.15, seeds: vec![] }, 3).unwrap();
        let (before, after) = (plain(&sphere, 3).signed_volume(), cloud.mesh.signed_volume());
        let bulk = cloud.mesh.positions().iter().zip(plain(&sphere, 3).positions()).map(|(a, b)| a.distance(*b)).fold(0.0, f32::max);
        assert!(bulk > 0.2 && ((after - before) / before).abs() < 0.02, "volume {before} then {after}, largest move {bulk}");
    }

    #[test]
    fn growth_is_seeded_and_its_bad_parameters_refused() {
        let base = testmeshes::icosphere(2);
        for model in [
            Model::Tentacle { length: 0.03, theta: 0.0, seeds: vec![], spacing: 0.5 },
            Model::Spur { length: 0.03, seeds: vec![], spacing: 0.5 },
            Model::Mushroom { radius: 0.3, length: 0.1, seeds: vec![] },
        ] {
            let a = procedural_detail(&base, 2, &model, 1).unwrap();
            assert_eq!(a, procedural_detail(&base, 2, &model, 1).unwrap());
            assert_ne!(a.mesh.positions(), procedural_detail(&base, 2, &model, 2).unwrap().mesh.positions(), "{model:?}");
        }
        let refuse = |m: Model| assert!(matches!(procedural_detail(&base, 2, &m, 0), Err(Error::InvalidParameter(_))), "{m:?}");
        refuse(Model::Tentacle { length: f64::NAN, theta: 0.0, seeds: vec![], spacing: 0.5 });
        refuse(Model::Tentacle { length: 0.1, theta: f64::INFINITY, seeds: vec![], spacing: 0.5 });
        refuse(Model::Tentacle { length: 0.1, theta: 0.0, seeds: vec![1000], spacing: 0.5 });
        refuse(Model::Spur { length: 1e3, seeds: vec![], spacing: 0.5 });
        refuse(Model::Spur { length: 0.1, seeds: vec![], spacing: 0.0 });
        refuse(Model::Mushroom { radius: -0.3, length: 0.1, seeds: vec![] });
        refuse(Model::Mushroom { radius: 0.3, length: 0.1, seeds: vec![162] });
        refuse(Model::Fuse { amplitude: 0.1, span: 0.0, center: DVec3::ZERO, axis: DVec3::Z });
        refuse(Model::Fuse { amplitude: 0.1, span: 5.0, center: DVec3::ZERO, axis: DVec3::Z });
        refuse(Model::Fuse { amplitude: 0.1, span: 1.0, center: DVec3::ZERO, axis: DVec3::ZERO });
        refuse(Model::Fuse { amplitude: 0.1, span: 1.0, center: DVec3::NAN, axis: DVec3::Z });
        // A flat plane has no extent along its normal.
        assert!(matches!(
            procedural_detail(&testmeshes::plane(2), 1, &Model::Fuse { amplitude: 0.1, span: 1.0, center: DVec3::ZERO, axis: DVec3::Z }, 0),
            Err(Error::InvalidParameter(_))
        ));
    }
}
