//! Keeps berry domes from leaning past vertical. The paper's domes grow "perpendicularly
//! to the evolving detail surface" (Velho et al., 4.2), so a level's dome on the wall of
//! the last level's dome pushes sideways, and its lower flank (whose own profile,
//! `R (1 - r^2/R^2)^(1/2)`, is vertical at the rim) faces down: an overhang, which on a
//! curved or crowded base crosses the next dome. Measured on the default UV sphere (berry
//! preset, 2 levels) every turned-over face was on a child dome: with no children, or at
//! level 1 alone, none was, since moving a surface along its own normals within the focal
//! limit turns no face of it over.
//!
//! The guard compares each quad's normal with the base's at the same place (level 1's
//! normals before its detail, carried to finer levels linearly as the subdivision carries
//! a point's position) and flattens, as a whole, every dome that would tip a face of its
//! past [`MAX_TILT_COS`] against the base's normal (or further than it already was).

use super::fold_guard::scale_groups;
use crate::mesh::Incidence;
use crate::Mesh;
use glam::{DVec3, Vec3};
use rayon::prelude::*;

/// The least cosine between a face's normal and the base's a dome may leave it at
/// (about 84 degrees): short of vertical by a margin for the carried normals' error and
/// the levels after it (a margin of 1 degree left 3 to 16 faces turned over on the test
/// meshes). A level-1 dome's rim faces, moved along the base's own normals, lean up to
/// `atan(h / edge)`; where its radius spans more than about ten edges they pass this and
/// the dome is flattened too (exempting faces moved along the base's normals let more
/// faces turn on the blade and homer).
pub const MAX_TILT_COS: f64 = 0.1;

/// Halvings of a dome before it is left out.
const ROUNDS: u32 = 8;

/// Dome displacements `d` (along `normals`; `dome[v]` the dome vertex `v` lies in,
/// `u32::MAX` for none) with every dome that would lean a face past [`MAX_TILT_COS`]
/// against `reference` (the base's normals) halved until none does, or left out after
/// [`ROUNDS`] halvings.
pub(crate) fn upright(p: &[Vec3], normals: &[Vec3], corners: &[u32], reference: &[Vec3], dome: &[u32], d: &mut [f64]) {
    let domes = dome.iter().filter(|&&k| k != u32::MAX).map(|&k| k as usize + 1).max().unwrap_or(0);
    if domes == 0 {
        return;
    }
    let mut factor = vec![1.0f64; domes];
    let cosine = |q: &dyn Fn(usize) -> DVec3, quad: &[u32]| tilt(q, quad, reference);
    let before: Vec<f64> = corners.par_chunks_exact(4).map(|quad| cosine(&|v| p[v].as_dvec3(), quad)).collect();
    for round in 0..=ROUNDS {
        let moved = |v: usize| match dome[v] {
            u32::MAX => p[v].as_dvec3(),
            k => p[v].as_dvec3() + normals[v].as_dvec3() * d[v] * factor[k as usize],
        };
        let tipped: Vec<u32> = corners
            .par_chunks_exact(4)
            .zip(&before)
            .filter(|(quad, &was)| quad.iter().any(|&v| dome[v as usize] != u32::MAX && d[v as usize] > 0.0) && cosine(&moved, quad) < was.min(MAX_TILT_COS))
            .flat_map_iter(|(quad, _)| quad.iter().copied())
            .collect();
        if tipped.is_empty() {
            break;
        }
        // Every dome with a vertex on a tipped face is halved (left out after the last round).
        let mut on_tipped = vec![false; p.len()];
        tipped.into_iter().for_each(|v| on_tipped[v as usize] = true);
        let cut = if round == ROUNDS { 0.0 } else { 0.5 };
        let halved = scale_groups(dome, |v| if on_tipped[v] { cut } else { 1.0 });
        factor.iter_mut().zip(halved).for_each(|(f, h)| *f *= h);
    }
    d.par_iter_mut().zip(dome).for_each(|(h, &k)| {
        if k != u32::MAX {
            *h *= factor[k as usize];
        }
    });
}

/// The cosine between quad `quad`'s normal (its diagonals' cross product, corners at
/// `q`) and the mean of its corners' `reference` normals.
fn tilt(q: &dyn Fn(usize) -> DVec3, quad: &[u32], reference: &[Vec3]) -> f64 {
    let m = (q(quad[2] as usize) - q(quad[0] as usize)).cross(q(quad[3] as usize) - q(quad[1] as usize));
    let r: DVec3 = quad.iter().map(|&v| reference[v as usize].as_dvec3()).sum();
    m.dot(r) / (m.length() * r.length()).max(f64::MIN_POSITIVE)
}

/// [`upright`]'s test for one dome alone, before it is placed (a berry child is placed
/// only where its dome stands).
pub(crate) struct Stand<'a> {
    p: &'a [Vec3],
    normals: &'a [Vec3],
    corners: &'a [u32],
    reference: &'a [Vec3],
    faces: Incidence,
}

impl<'a> Stand<'a> {
    /// For the quads of `mesh` (a level's control mesh) with its vertex `normals` and the
    /// base's carried normals `reference`.
    pub(crate) fn new(mesh: &'a Mesh, normals: &'a [Vec3], reference: &'a [Vec3]) -> Self {
        Stand { p: mesh.positions(), normals, corners: mesh.corners(), reference, faces: Incidence::faces(mesh) }
    }

    /// Whether the dome `dome` ((vertex, height along its normal), sorted by vertex), at
    /// full height and alone, tips no quad around it past [`MAX_TILT_COS`] against the
    /// reference (or further than it was).
    pub(crate) fn stands(&self, dome: &[(u32, f64)]) -> bool {
        let height = |v: usize| dome.binary_search_by_key(&(v as u32), |&(u, _)| u).map_or(0.0, |i| dome[i].1);
        let at = |v: usize| self.p[v].as_dvec3();
        let moved = |v: usize| at(v) + self.normals[v].as_dvec3() * height(v);
        dome.iter().flat_map(|&(v, _)| self.faces.of(v as usize)).all(|&f| {
            let quad = &self.corners[4 * f as usize..4 * f as usize + 4];
            tilt(&moved, quad, self.reference) >= tilt(&at, quad, self.reference).min(MAX_TILT_COS)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::newell_normal;
    use crate::subdivision::detail::{procedural_detail, Model};
    use crate::subdivision::{subdivide, Boundary, Options};
    use crate::testmeshes;

    /// Each quad's (Newell) normal, unnormalized.
    fn quad_normals(p: &[Vec3], corners: &[u32]) -> Vec<DVec3> {
        corners.chunks_exact(4).map(|q| newell_normal(&q.iter().map(|&v| p[v as usize]).collect::<Vec<_>>()).as_dvec3()).collect()
    }

    #[test]
    fn a_dome_on_a_wall_is_flattened_until_no_face_leans_past_vertical() {
        // A flat grid standing for a steep wall: its normals lean 80 degrees from the
        // base's (+z), so a hemisphere pushed along them tips its downhill flank over
        // (slope past 1/0.98); the guard halves that dome until no face tips past
        // MAX_TILT_COS, and leaves a dome elsewhere (pushed along +z) as it is.
        let grid = testmeshes::plane(40);
        let p = grid.positions();
        let lean = DVec3::new(80f64.to_radians().sin(), 0.0, 80f64.to_radians().cos()).as_vec3();
        let normals: Vec<Vec3> = p.iter().map(|q| if q.x < 0.5 { lean } else { Vec3::Z }).collect();
        let reference = vec![Vec3::Z; p.len()];
        let (r, centres) = (0.3f64, [Vec3::new(-0.4, 0.0, 0.0), Vec3::new(0.8, 0.0, 0.0)]);
        let (dome, full): (Vec<u32>, Vec<f64>) = p
            .iter()
            .map(|q| {
                let (k, c) = centres.iter().enumerate().map(|(k, c)| (k, q.distance(*c) as f64)).fold((0, f64::MAX), |a, b| if b.1 < a.1 { b } else { a });
                if c < r {
                    (k as u32, r * (1.0 - c * c / (r * r)).sqrt())
                } else {
                    (u32::MAX, 0.0)
                }
            })
            .unzip();
        let moved = |d: &[f64]| -> Vec<Vec3> { p.iter().zip(&normals).zip(d).map(|((q, n), &d)| *q + *n * d as f32).collect() };
        let cosines = |d: &[f64]| -> Vec<f64> { quad_normals(&moved(d), grid.corners()).iter().map(|m| m.z / m.length()).collect() };
        assert!(cosines(&full).iter().any(|&c| c <= 0.0), "the unguarded dome turns faces over");
        let mut d = full.clone();
        upright(p, &normals, grid.corners(), &reference, &dome, &mut d);
        assert!(cosines(&d).iter().all(|&c| c >= MAX_TILT_COS - 1e-9));
        let kept: Vec<f64> = (0..p.len()).filter(|&v| full[v] > 0.0).map(|v| d[v] / full[v]).collect();
        let (wall, flat): (Vec<usize>, Vec<usize>) = (0..p.len()).filter(|&v| full[v] > 0.0).partition(|&v| dome[v] == 0);
        let f = d[wall[0]] / full[wall[0]];
        assert!(f > 0.0 && f < 1.0 && (f.log2() - f.log2().round()).abs() < 1e-9, "halved as a whole: {f}");
        assert!(wall.iter().all(|&v| (d[v] / full[v] - f).abs() < 1e-12) && flat.iter().all(|&v| d[v] == full[v]), "{kept:?}");
    }

    #[test]
    fn berries_turn_no_face_over() {
        // Three levels of clusters on a sphere: every face of the result faces the way the
        // plain subdivision's face does.
        let base = testmeshes::icosphere(2);
        let out = procedural_detail(&base, 3, &Model::Berry { radius: 0.3, seeds: vec![], children: 4 }, 7).unwrap();
        let plain = subdivide(&base, &Options { levels: 3, limit: false, boundary: Boundary::SmoothAll }).unwrap().mesh;
        let (a, b) = (quad_normals(out.mesh.positions(), out.mesh.corners()), quad_normals(plain.positions(), plain.corners()));
        let turned = a.iter().zip(&b).filter(|(a, b)| a.dot(**b) <= 0.0).count();
        assert_eq!(turned, 0, "of {}", a.len());
        assert!(out.scalar.iter().any(|&s| s > 0.2), "domes stand");
    }
}
