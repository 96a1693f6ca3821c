//! Joins the cells' pieces into one mesh: iso-vertices on cell boundaries with the same
//! global lattice-edge key become one vertex; the rest are already unique.

use super::polygonize::{Piece, UNSHARED};
use super::BakedMesh;
use glam::Vec3;
use rayon::prelude::*;

/// Normals: the texture gradients summed over a vertex's copies, normalized; the
/// area-weighted face normal where the gradient vanishes (cut walls, flat texture).
pub(super) fn merge(pieces: Vec<Piece>) -> BakedMesh {
    let mut remap: Vec<Vec<u32>> = pieces.iter().map(|p| vec![u32::MAX; p.keys.len()]).collect();
    let mut shared: Vec<(u64, u32, u32)> = Vec::new();
    let mut out = BakedMesh::default();
    let total: usize = pieces.iter().map(|p| p.keys.len()).sum();
    out.positions.reserve(total);
    out.texcoords.reserve(total);
    out.normals.reserve(total);
    for (pi, p) in pieces.iter().enumerate() {
        for (i, &key) in p.keys.iter().enumerate() {
            if key == UNSHARED {
                remap[pi][i] = out.positions.len() as u32;
                out.positions.push(p.pos[i]);
                out.texcoords.push(p.tex[i]);
                out.normals.push(p.grad[i]);
            } else {
                shared.push((key, pi as u32, i as u32));
            }
        }
    }
    shared.par_sort_unstable();
    let mut last = None;
    for &(key, pi, i) in &shared {
        let p = &pieces[pi as usize];
        if last != Some(key) {
            last = Some(key);
            out.positions.push(p.pos[i as usize]);
            out.texcoords.push(p.tex[i as usize]);
            out.normals.push(Vec3::ZERO);
        }
        let id = out.positions.len() - 1;
        out.normals[id] += p.grad[i as usize];
        remap[pi as usize][i as usize] = id as u32;
    }
    out.triangles.reserve(pieces.iter().map(|p| p.tris.len()).sum());
    for (p, map) in pieces.iter().zip(&remap) {
        for t in &p.tris {
            let t = t.map(|i| map[i as usize]);
            if t[0] != t[1] && t[1] != t[2] && t[0] != t[2] {
                out.triangles.push(t);
            }
        }
    }
    drop(pieces);
    let flat = |n: &Vec3| n.length_squared() <= 1e-20;
    if out.normals.iter().any(flat) {
        let mut face = vec![Vec3::ZERO; out.positions.len()];
        for t in &out.triangles {
            let [a, b, c] = t.map(|i| out.positions[i as usize]);
            let nrm = (b - a).cross(c - a);
            t.iter().for_each(|i| face[*i as usize] += nrm);
        }
        for (n, f) in out.normals.iter_mut().zip(face) {
            if flat(n) {
                *n = f;
            }
        }
    }
    out.normals.par_iter_mut().for_each(|n| *n = n.normalize_or_zero());
    out
}
