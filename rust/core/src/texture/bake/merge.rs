//! Joins the cells' pieces into one mesh: iso-vertices on cell boundaries with the same
//! global lattice-edge key become one vertex; the rest are already unique. Pieces are
//! copied in parallel into their ranges of the output (prefix sums), and only the
//! boundary vertices go through a global sort.

use super::polygonize::{Piece, UNSHARED};
use super::BakedMesh;
use glam::Vec3;
use rayon::prelude::*;

/// Splits `v` into consecutive mutable chunks of the given lengths.
fn chunks_mut<T>(mut v: &mut [T], lengths: impl Iterator<Item = usize>) -> Vec<&mut [T]> {
    let mut out = Vec::new();
    for n in lengths {
        let (head, tail) = std::mem::take(&mut v).split_at_mut(n);
        out.push(head);
        v = tail;
    }
    out
}

/// Normals: the texture gradients summed over a vertex's copies, normalized; the
/// area-weighted face normal where the gradient vanishes.
/// `faces`: each piece's base face (pieces in cell order).
pub(super) fn merge(mut pieces: Vec<Piece>, faces: &[u32]) -> BakedMesh {
    // Boundary vertices: sorted by key, one output vertex per distinct key.
    let mut shared: Vec<(u128, u32, u32)> = pieces
        .par_iter()
        .enumerate()
        .flat_map_iter(|(pi, p)| {
            p.keys.iter().enumerate().filter(|(_, k)| **k != UNSHARED).map(move |(i, k)| (*k, pi as u32, i as u32))
        })
        .collect();
    shared.par_sort_unstable();

    let own_unshared: Vec<usize> = pieces.par_iter().map(|p| p.keys.iter().filter(|k| **k == UNSHARED).count()).collect();
    let unshared_total: usize = own_unshared.iter().sum();
    let mut first_of_key = Vec::new();
    let mut shared_id = vec![0u32; shared.len()];
    for (s, &(key, _, _)) in shared.iter().enumerate() {
        if s == 0 || shared[s - 1].0 != key {
            first_of_key.push(s);
        }
        shared_id[s] = (unshared_total + first_of_key.len() - 1) as u32;
    }
    let total = unshared_total + first_of_key.len();
    let mut out = BakedMesh {
        positions: vec![Vec3::ZERO; total],
        texcoords: vec![Vec3::ZERO; total],
        normals: vec![Vec3::ZERO; total],
        ..Default::default()
    };
    // Per piece: its unshared vertices copied out; each vertex's key is replaced by its
    // output index once read (the keys are not needed after that).
    {
        let mut starts = Vec::with_capacity(pieces.len());
        let mut acc = 0usize;
        for n in &own_unshared {
            starts.push(acc);
            acc += n;
        }
        let pos = chunks_mut(&mut out.positions[..unshared_total], own_unshared.iter().copied());
        let tex = chunks_mut(&mut out.texcoords[..unshared_total], own_unshared.iter().copied());
        let nrm = chunks_mut(&mut out.normals[..unshared_total], own_unshared.iter().copied());
        pieces.par_iter_mut().zip(pos).zip(tex).zip(nrm).zip(starts).for_each(|((((p, pos), tex), nrm), start)| {
            let mut k = 0;
            for i in 0..p.keys.len() {
                if p.keys[i] == UNSHARED {
                    pos[k] = p.pos[i];
                    tex[k] = p.tex[i];
                    nrm[k] = p.grad[i];
                    p.keys[i] = (start + k) as u128;
                    k += 1;
                }
            }
        });
    }
    for (s, &(_, pi, i)) in shared.iter().enumerate() {
        let (p, id) = (&mut pieces[pi as usize], shared_id[s] as usize);
        if s == 0 || shared[s - 1].0 != shared[s].0 {
            out.positions[id] = p.pos[i as usize];
            out.texcoords[id] = p.tex[i as usize];
        }
        out.normals[id] += p.grad[i as usize];
        p.keys[i as usize] = id as u128;
    }
    let tri_counts: Vec<usize> = pieces.iter().map(|p| p.tris.len()).collect();
    let total_tris = tri_counts.iter().sum();
    out.triangles = vec![[0; 3]; total_tris];
    out.corner_texcoords = vec![[Vec3::ZERO; 3]; total_tris];
    out.source_face = vec![0; total_tris];
    let tris = chunks_mut(&mut out.triangles, tri_counts.iter().copied());
    let corner_tex = chunks_mut(&mut out.corner_texcoords, tri_counts.iter().copied());
    let face_of = chunks_mut(&mut out.source_face, tri_counts.iter().copied());
    pieces.par_iter().zip(tris).zip(corner_tex).zip(face_of).enumerate().for_each(|(pi, (((p, dst), tex), face))| {
        for ((d, c), t) in dst.iter_mut().zip(tex.iter_mut()).zip(&p.tris) {
            *d = t.map(|i| p.keys[i as usize] as u32);
            *c = t.map(|i| p.tex[i as usize]);
        }
        face.fill(faces[pi]);
    });
    // Freeing thousands of pieces takes a while; the caller need not wait for it.
    rayon::spawn(move || drop(pieces));
    let flat = |n: &Vec3| n.length_squared() <= 1e-20;
    if out.normals.par_iter().any(flat) {
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
