//! The base split for a bake whose cells span more texels than one cell's lattice can
//! hold ([`MAX_STEPS`](super::MAX_STEPS) steps per edge): every triangle of the
//! triangulated base cut into four at its edge midpoints, as often as needed, with
//! positions, directors, UVs and per-vertex weights interpolated linearly. A prism
//! cell's map `x(b, r) = sum b_i (p_i + r d_i)` is linear in the barycentrics `b`
//! (chapter 3.1), so each sub-cell maps exactly the part of its parent it covers: the
//! baked surface is the same, sampled more finely. Midpoints are shared through edge
//! keys, so the split is conforming and neighbouring cells still share their lattice.

use super::effects::holes;
use super::BakeParams;
use crate::shell::Shell;
use crate::texture::mapping::{TextureCoordinates, TriangleCells};
use crate::{Mesh, Result};
use glam::{Vec2, Vec3};
use std::collections::HashMap;

/// The most triangles a split base may have (its memory is the bake's, not the output's).
const MAX_SPLIT_TRIANGLES: usize = 1 << 20;

/// A split base: its mesh, shell and per-vertex settings, and the user's face each of its faces lies in.
pub(super) struct Split {
    pub mesh: Mesh,
    pub shell: Shell,
    pub params: BakeParams,
    pub faces: Vec<u32>,
}

/// Per-vertex values of the split base, grown a midpoint at a time.
struct Vertices {
    positions: Vec<Vec3>,
    vec3s: [Vec<Vec3>; 2],
    scalars: Vec<Vec<f32>>,
}

impl Vertices {
    fn midpoint(&mut self, a: usize, b: usize) -> u32 {
        let mid3 = |v: &mut Vec<Vec3>| v.push((v[a] + v[b]) * 0.5);
        mid3(&mut self.positions);
        self.vec3s.iter_mut().for_each(mid3);
        self.scalars.iter_mut().for_each(|v| v.push((v[a] + v[b]) * 0.5));
        self.positions.len() as u32 - 1
    }
}

/// `mesh` split `levels` times (each triangle into `4^levels`, fewer where that would
/// pass [`MAX_SPLIT_TRIANGLES`]); `None` for none.
pub(super) fn split(mesh: &Mesh, shell: &Shell, params: &BakeParams, levels: u32) -> Result<Option<Split>> {
    if levels == 0 {
        return Ok(None);
    }
    let cells = TriangleCells::new(mesh, &TextureCoordinates::of(mesh, 1.0));
    let levels = (0..=levels).rev().find(|&k| cells.triangles.len() << (2 * k) <= MAX_SPLIT_TRIANGLES).unwrap_or(0);
    if levels == 0 {
        return Ok(None);
    }
    // The shell's collapse is decided on the user's base (its median director) and
    // carried as holes, so the split does not move it.
    let weights = [params.region.clone(), holes(params, shell), params.moved.as_ref().map(|m| m.weights.clone())];
    let present: Vec<usize> = (0..3).filter(|&i| weights[i].is_some()).collect();
    let mut scalars: Vec<Vec<f32>> = present.iter().map(|&i| weights[i].clone().unwrap_or_default()).collect();
    scalars.extend([shell.achieved.clone(), shell.target.clone()]);
    let mut v = Vertices { positions: mesh.positions().to_vec(), vec3s: [shell.base_offset.clone(), shell.directors.clone()], scalars };
    let (mut tris, mut uvs, mut faces) = (cells.triangles, cells.st, cells.faces);
    for _ in 0..levels {
        let mut mids: HashMap<(u32, u32), u32> = HashMap::with_capacity(tris.len() * 3 / 2);
        let (mut t2, mut uv2, mut f2) = (Vec::with_capacity(tris.len() * 4), Vec::with_capacity(tris.len() * 4), Vec::with_capacity(tris.len() * 4));
        for ((t, uv), f) in tris.iter().zip(&uvs).zip(&faces) {
            let m: [u32; 3] = std::array::from_fn(|k| {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                *mids.entry((a.min(b), a.max(b))).or_insert_with(|| v.midpoint(a as usize, b as usize))
            });
            let n: [Vec2; 3] = std::array::from_fn(|k| (uv[k] + uv[(k + 1) % 3]) * 0.5);
            t2.extend([[t[0], m[0], m[2]], [m[0], t[1], m[1]], [m[2], m[1], t[2]], [m[0], m[1], m[2]]]);
            uv2.extend([[uv[0], n[0], n[2]], [n[0], uv[1], n[1]], [n[2], n[1], uv[2]], [n[0], n[1], n[2]]]);
            f2.extend([*f; 4]);
        }
        (tris, uvs, faces) = (t2, uv2, f2);
    }
    let corners: Vec<u32> = tris.iter().flatten().copied().collect();
    let split_mesh = Mesh::new(v.positions, &vec![3; tris.len()], corners, Some(uvs.into_iter().flatten().collect()))?;
    let target = v.scalars.pop().unwrap_or_default();
    let achieved = v.scalars.pop().unwrap_or_default();
    let [base_offset, directors] = v.vec3s;
    let split_shell = Shell { side: shell.side, base_offset, directors, achieved, target, check: shell.check };
    let mut split_params = BakeParams { holes: None, ..params.clone() };
    let mut scalars = v.scalars.into_iter();
    for i in present {
        let w = scalars.next();
        match i {
            0 => split_params.region = w,
            1 => split_params.holes = w,
            _ => split_params.moved.as_mut().into_iter().for_each(|m| m.weights = w.clone().unwrap_or_default()),
        }
    }
    Ok(Some(Split { mesh: split_mesh, shell: split_shell, params: split_params, faces }))
}
