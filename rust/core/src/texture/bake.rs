//! Bake to geometry: the `alpha = 0.5` iso-surface of the texture over the whole shell
//! as one mesh (chapter 3: the thick surface's detailed surface).
//!
//! Every cell (a triangle prism; quads and n-gons are triangulated) is sampled on a
//! lattice of `resolution` steps per base edge and `layers` steps along the
//! directors. Lattice points are numbered globally — a mesh vertex, a point on a mesh
//! edge, or one inside a face — so neighbouring cells share the samples on their
//! common faces. Each small prism is split into three tetrahedra by the rule of
//! Dompierre et al. (each quad's diagonal through its smallest global index), which
//! agrees on shared faces, and polygonized by marching tetrahedra; iso-vertices are
//! keyed by the lattice edge they lie on. Shared samples, conforming splits and edge
//! keys make the result free of cracks and duplicated vertices.
//!
//! The shell's own boundary (base layer, outer layer, walls along open mesh edges) is
//! sampled as outside, so every baked surface is closed. Normals come from the texture
//! gradient carried to world space by each cell's map ([`CellMap::gradient_to_world`]).

use super::mapping::{CellMap, TextureCoordinates};
use super::VolumeTexture;
use crate::shell::Shell;
use crate::{Error, Mesh, Result};
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use std::collections::HashMap;

/// A texture placed in the shell: `(s, t)` offset (editing: move, combine).
#[derive(Debug, Clone)]
pub struct TextureLayer {
    pub texture: VolumeTexture,
    pub offset: Vec2,
}

/// Bake settings.
#[derive(Debug, Clone)]
pub struct BakeParams {
    /// Lattice steps along each base edge of a cell.
    pub resolution: u32,
    /// Lattice steps along the directors.
    pub layers: u32,
    /// UV tiling factor.
    pub tiling: f32,
    /// Where the texture exists (figure 3.3), per vertex in `[0, 1]`; elsewhere the
    /// base surface shows as a thin slab, blended smoothly in between. `None`: everywhere.
    pub region: Option<Vec<f32>>,
    /// Thickness of that base slab as a fraction of the shell (at least 1.5 layers).
    pub base_layer: f32,
    /// Refuse bakes whose estimate exceeds this many triangles.
    pub max_triangles: usize,
}

impl Default for BakeParams {
    fn default() -> Self {
        Self { resolution: 8, layers: 16, tiling: 1.0, region: None, base_layer: 0.1, max_triangles: 20_000_000 }
    }
}

/// The baked surface.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct BakedMesh {
    pub positions: Vec<Vec3>,
    pub triangles: Vec<[u32; 3]>,
    pub normals: Vec<Vec3>,
    /// `(s, t, r)` of each vertex.
    pub texcoords: Vec<Vec3>,
    /// True when the mesh had no UVs and each face got its own tile.
    pub per_face_tiles: bool,
}

/// Global numbering of the lattice points of all cells (without the layer index).
struct Lattice {
    n: u32,
    tris: Vec<[u32; 3]>,
    /// Corner `(s, t)` of each triangle.
    st: Vec<[Vec2; 3]>,
    edges: HashMap<(u32, u32), u32>,
    vertex_count: u32,
    /// Points on the shell's side walls (open boundary edges and their vertices).
    boundary: Vec<bool>,
}

impl Lattice {
    fn new(mesh: &Mesh, coords: &TextureCoordinates, n: u32) -> Self {
        let tri = mesh.triangulate();
        let mut st = Vec::with_capacity(tri.triangles.len());
        for (t, f) in tri.triangles.iter().zip(&tri.face_of_triangle) {
            let range = mesh.face_corner_range(*f as usize);
            let face = mesh.face(*f as usize);
            st.push(t.map(|v| coords.corner_st[range.start + face.iter().position(|c| *c == v).unwrap_or(0)]));
        }
        let mut edges = HashMap::new();
        let mut uses: Vec<u32> = Vec::new();
        for t in &tri.triangles {
            for k in 0..3 {
                let (a, b) = (t[k].min(t[(k + 1) % 3]), t[k].max(t[(k + 1) % 3]));
                let next = edges.len() as u32;
                let e = *edges.entry((a, b)).or_insert(next);
                if e as usize == uses.len() {
                    uses.push(0);
                }
                uses[e as usize] += 1;
            }
        }
        let mut me = Self { n, tris: tri.triangles, st, edges, vertex_count: mesh.vertex_count() as u32, boundary: Vec::new() };
        let mut boundary = vec![false; me.key_count()];
        for (&(a, b), &e) in &me.edges {
            if uses[e as usize] == 1 {
                boundary[a as usize] = true;
                boundary[b as usize] = true;
                for k in 1..n {
                    boundary[me.edge_key(a, b, k)] = true;
                }
            }
        }
        me.boundary = boundary;
        me
    }

    fn interior_per_face(&self) -> usize {
        let n = self.n as usize;
        if n < 3 {
            0
        } else {
            (n - 1) * (n - 2) / 2
        }
    }
    fn key_count(&self) -> usize {
        self.vertex_count as usize + self.edges.len() * (self.n as usize - 1) + self.tris.len() * self.interior_per_face()
    }
    /// Point `k` steps from `a` on edge `a-b`.
    fn edge_key(&self, a: u32, b: u32, k: u32) -> usize {
        let (lo, hi, k) = if a < b { (a, b, k) } else { (b, a, self.n - k) };
        let e = self.edges[&(lo, hi)] as usize;
        self.vertex_count as usize + e * (self.n as usize - 1) + (k as usize - 1)
    }
    /// Global key of local point `(i, j)` of triangle `t` (corner a at (0,0), b at
    /// (n,0), c at (0,n)).
    fn key(&self, t: usize, i: u32, j: u32) -> usize {
        let [a, b, c] = self.tris[t];
        let n = self.n;
        match (i, j) {
            (0, 0) => a as usize,
            _ if i == n => b as usize,
            _ if j == n => c as usize,
            (_, 0) => self.edge_key(a, b, i),
            (0, _) => self.edge_key(a, c, j),
            _ if i + j == n => self.edge_key(b, c, j),
            _ => {
                let (i, j, n) = (i as usize, j as usize, n as usize);
                let base = self.vertex_count as usize + self.edges.len() * (n - 1) + t * self.interior_per_face();
                base + (i - 1) * (n - 1) - (i - 1) * i / 2 + (j - 1)
            }
        }
    }
}

/// Occupancy of the placed textures at `c`: the union (max) of the layers, and the
/// gradient of the one that wins.
fn occupancy(layers: &[TextureLayer], c: Vec3) -> (f32, usize) {
    layers
        .iter()
        .map(|l| l.texture.sample(c + l.offset.extend(0.0)))
        .enumerate()
        .fold((f32::NEG_INFINITY, 0), |best, (k, a)| if a > best.0 { (a, k) } else { best })
}

/// Dompierre's prism split: permutation putting the smallest index first.
const PRISM_ROT: [[usize; 6]; 6] =
    [[0, 1, 2, 3, 4, 5], [1, 2, 0, 4, 5, 3], [2, 0, 1, 5, 3, 4], [3, 5, 4, 0, 2, 1], [4, 3, 5, 1, 0, 2], [5, 4, 3, 2, 1, 0]];

fn split_prism(ids: &[u64; 6]) -> [[usize; 4]; 3] {
    let k = (0..6).min_by_key(|&i| ids[i]).unwrap_or(0);
    let p = PRISM_ROT[k];
    let id = |i: usize| ids[p[i]];
    let t = if id(1).min(id(5)) < id(2).min(id(4)) {
        [[0, 1, 2, 5], [0, 1, 5, 4], [0, 4, 5, 3]]
    } else {
        [[0, 1, 2, 4], [0, 4, 2, 5], [0, 4, 5, 3]]
    };
    t.map(|tet| tet.map(|i| p[i]))
}

/// Per-cell output before the global merge.
#[derive(Default)]
struct Piece {
    keys: Vec<u64>,
    pos: Vec<Vec3>,
    tex: Vec<Vec3>,
    grad: Vec<Vec3>,
    tris: Vec<[u32; 3]>,
}

/// Bakes the iso-surface. `layers`: the textures (at least one), unioned.
pub fn bake(mesh: &Mesh, shell: &Shell, textures: &[TextureLayer], params: &BakeParams) -> Result<BakedMesh> {
    mesh.require_faces()?;
    if textures.is_empty() {
        return Err(Error::InvalidParameter("no texture to bake".into()));
    }
    if shell.directors.len() != mesh.vertex_count() {
        return Err(Error::InvalidParameter("the shell does not belong to this mesh".into()));
    }
    if !(1..=64).contains(&params.resolution) || !(2..=256).contains(&params.layers) {
        return Err(Error::InvalidParameter("resolution must be in 1..=64 and layers in 2..=256".into()));
    }
    if !(params.tiling > 0.0 && params.tiling.is_finite()) {
        return Err(Error::InvalidParameter("tiling must be a positive number".into()));
    }
    if let Some(r) = &params.region {
        if r.len() != mesh.vertex_count() || r.iter().any(|w| !w.is_finite()) {
            return Err(Error::InvalidParameter("region weights: one finite value per vertex".into()));
        }
    }
    let coords = TextureCoordinates::of(mesh, params.tiling);
    let (n, m) = (params.resolution, params.layers);
    let lattice = Lattice::new(mesh, &coords, n);
    let estimate = estimate_triangles(&lattice, textures, m);
    if estimate > params.max_triangles {
        return Err(Error::InvalidParameter(format!(
            "this bake would make about {estimate} triangles, over the limit of {}; lower the resolution or layers",
            params.max_triangles
        )));
    }
    let values = sample_lattice(mesh, shell, &lattice, textures, params);
    let pieces: Vec<Piece> = (0..lattice.tris.len())
        .into_par_iter()
        .map(|t| polygonize_cell(mesh, shell, &lattice, &values, textures, params, t))
        .collect();
    let mut out = merge(pieces);
    out.per_face_tiles = coords.per_face_tiles;
    Ok(out)
}

/// A rough triangle count before baking: lattice cells times the share of texel
/// edges of the texture that cross the iso-level (about two triangles per crossing
/// cell).
pub fn estimate_triangles_for(mesh: &Mesh, textures: &[TextureLayer], params: &BakeParams) -> usize {
    let coords = TextureCoordinates::of(mesh, params.tiling);
    estimate_triangles(&Lattice::new(mesh, &coords, params.resolution), textures, params.layers)
}

fn estimate_triangles(lattice: &Lattice, textures: &[TextureLayer], m: u32) -> usize {
    let Some(first) = textures.first() else { return 0 };
    let t = &first.texture;
    let [nx, ny, nz] = t.dims();
    let s = t.samples();
    let mut crossing = 0usize;
    for i in 0..s.len() {
        let x = i % nx;
        if x + 1 < nx && ((s[i] >= 0.5) != (s[i + 1] >= 0.5)) {
            crossing += 1;
        }
    }
    let share = crossing as f64 / (((nx.max(2) - 1) * ny * nz) as f64);
    let cells = lattice.tris.len() as f64 * (lattice.n as f64).powi(2) * m as f64;
    (cells * 3.0 * share * 2.0).ceil() as usize
}

/// `alpha` at every lattice point (point key × (layers + 1)), each computed in the
/// first cell that contains the point so shared points get one value.
fn sample_lattice(mesh: &Mesh, shell: &Shell, lattice: &Lattice, textures: &[TextureLayer], params: &BakeParams) -> Vec<f32> {
    let (n, m) = (lattice.n, params.layers);
    let keys = lattice.key_count();
    let mut owner = vec![(u32::MAX, 0u16, 0u16); keys];
    for t in 0..lattice.tris.len() {
        for i in 0..=n {
            for j in 0..=(n - i) {
                let k = lattice.key(t, i, j);
                if owner[k].0 == u32::MAX {
                    owner[k] = (t as u32, i as u16, j as u16);
                }
            }
        }
    }
    let layers = m as usize + 1;
    let base_layer = params.base_layer.max(1.5 / m as f32);
    let mut values = vec![0.0f32; keys * layers];
    values.par_chunks_mut(layers).enumerate().for_each(|(k, column)| {
        let (t, i, j) = owner[k];
        if t == u32::MAX || lattice.boundary[k] {
            return;
        }
        let t = t as usize;
        let cell = CellMap::new(mesh, shell, &lattice.tris[t], &lattice.st[t]);
        let (u, v) = (i as f32 / n as f32, j as f32 / n as f32);
        let w = region_weight(params, &lattice.tris[t], cell.weights(u, v));
        for (l, a) in column.iter_mut().enumerate().take(m as usize).skip(1) {
            let r = l as f32 / m as f32;
            let tex = occupancy(textures, cell.texture(Vec3::new(u, v, r))).0;
            let base = ((base_layer - r) * m as f32 + 0.5).clamp(0.0, 1.0);
            *a = w * tex + (1.0 - w) * base;
        }
    });
    values
}

fn region_weight(params: &BakeParams, corners: &[u32; 3], w: [f32; 4]) -> f32 {
    match &params.region {
        None => 1.0,
        Some(r) => (0..3).map(|k| r[corners[k] as usize].clamp(0.0, 1.0) * w[k]).sum(),
    }
}

fn polygonize_cell(
    mesh: &Mesh,
    shell: &Shell,
    lattice: &Lattice,
    values: &[f32],
    textures: &[TextureLayer],
    params: &BakeParams,
    t: usize,
) -> Piece {
    let (n, m) = (lattice.n, params.layers);
    let layers = m as u64 + 1;
    let cell = CellMap::new(mesh, shell, &lattice.tris[t], &lattice.st[t]);
    let base_layer = params.base_layer.max(1.5 / m as f32);
    let mut piece = Piece::default();
    let mut local: HashMap<u64, u32> = HashMap::new();
    // Local lattice point (i, j, l) -> (global id, parameters).
    let point = |i: u32, j: u32, l: u32| {
        let id = lattice.key(t, i, j) as u64 * layers + l as u64;
        (id, Vec3::new(i as f32 / n as f32, j as f32 / n as f32, l as f32 / m as f32))
    };
    let mut emit = |piece: &mut Piece, corners: [(u64, Vec3); 6]| {
        let ids = corners.map(|c| c.0);
        for tet in split_prism(&ids) {
            let v = tet.map(|k| corners[k]);
            let a = v.map(|(id, _)| values[id as usize]);
            let inside = a.map(|x| x >= 0.5);
            let count = inside.iter().filter(|b| **b).count();
            if count == 0 || count == 4 {
                continue;
            }
            // Iso-points on the tetrahedron's sign-changing edges.
            let mut iso = |piece: &mut Piece, p: usize, q: usize| -> u32 {
                let (lo, hi) = if v[p].0 < v[q].0 { (p, q) } else { (q, p) };
                let key = v[lo].0 * (values.len() as u64) + v[hi].0;
                if let Some(&i) = local.get(&key) {
                    return i;
                }
                let f = ((0.5 - a[lo]) / (a[hi] - a[lo])).clamp(0.0, 1.0);
                let q = v[lo].1.lerp(v[hi].1, f);
                let tex = cell.texture(q);
                let (_, winner) = occupancy(textures, tex);
                let layer = &textures[winner];
                let mut g = layer.texture.gradient(tex + layer.offset.extend(0.0));
                if params.region.is_some() {
                    let w = region_weight(params, &lattice.tris[t], cell.weights(q.x, q.y));
                    let dbase = if (q.z - base_layer).abs() * (m as f32) < 0.5 { -(m as f32) } else { 0.0 };
                    g = g * w + Vec3::Z * dbase * (1.0 - w);
                }
                let idx = piece.keys.len() as u32;
                piece.keys.push(key);
                piece.pos.push(cell.world(q));
                piece.tex.push(tex);
                piece.grad.push(-cell.gradient_to_world(q, g));
                local.insert(key, idx);
                idx
            };
            let ins: Vec<usize> = (0..4).filter(|k| inside[*k]).collect();
            let outs: Vec<usize> = (0..4).filter(|k| !inside[*k]).collect();
            let centre = |ks: &[usize]| ks.iter().map(|k| cell.world(v[*k].1)).sum::<Vec3>() / ks.len() as f32;
            let outward = centre(&outs) - centre(&ins);
            let push = |piece: &mut Piece, tri: [u32; 3]| {
                let p = tri.map(|i| piece.pos[i as usize]);
                let nrm = (p[1] - p[0]).cross(p[2] - p[0]);
                piece.tris.push(if nrm.dot(outward) < 0.0 { [tri[0], tri[2], tri[1]] } else { tri });
            };
            match count {
                1 | 3 => {
                    let (apex, others) = if count == 1 { (ins[0], outs) } else { (outs[0], ins) };
                    let tri = [iso(piece, apex, others[0]), iso(piece, apex, others[1]), iso(piece, apex, others[2])];
                    push(piece, tri);
                }
                _ => {
                    let (a0, a1, b0, b1) = (ins[0], ins[1], outs[0], outs[1]);
                    let q = [iso(piece, a0, b0), iso(piece, a0, b1), iso(piece, a1, b1), iso(piece, a1, b0)];
                    push(piece, [q[0], q[1], q[2]]);
                    push(piece, [q[0], q[2], q[3]]);
                }
            }
        }
    };
    for i in 0..n {
        for j in 0..(n - i) {
            let mut small = vec![[(i, j), (i + 1, j), (i, j + 1)]];
            if i + j + 2 <= n {
                small.push([(i + 1, j), (i + 1, j + 1), (i, j + 1)]);
            }
            for s in small {
                for l in 0..m {
                    let c = [
                        point(s[0].0, s[0].1, l),
                        point(s[1].0, s[1].1, l),
                        point(s[2].0, s[2].1, l),
                        point(s[0].0, s[0].1, l + 1),
                        point(s[1].0, s[1].1, l + 1),
                        point(s[2].0, s[2].1, l + 1),
                    ];
                    emit(&mut piece, c);
                }
            }
        }
    }
    piece
}

/// Joins the pieces: iso-vertices with the same lattice-edge key become one vertex
/// (normals summed, then normalized; the area-weighted face normal where the texture
/// gradient vanishes).
fn merge(pieces: Vec<Piece>) -> BakedMesh {
    let total: usize = pieces.iter().map(|p| p.keys.len()).sum();
    let mut order: Vec<(u64, u32, u32)> = Vec::with_capacity(total);
    for (pi, p) in pieces.iter().enumerate() {
        order.extend(p.keys.iter().enumerate().map(|(i, k)| (*k, pi as u32, i as u32)));
    }
    order.par_sort_unstable();
    let mut remap: Vec<Vec<u32>> = pieces.iter().map(|p| vec![0; p.keys.len()]).collect();
    let mut out = BakedMesh::default();
    let mut last = None;
    for &(key, pi, i) in &order {
        let p = &pieces[pi as usize];
        if last != Some(key) {
            last = Some(key);
            out.positions.push(p.pos[i as usize]);
            out.texcoords.push(p.tex[i as usize]);
            out.normals.push(Vec3::ZERO);
        }
        let id = out.positions.len() as u32 - 1;
        out.normals[id as usize] += p.grad[i as usize];
        remap[pi as usize][i as usize] = id;
    }
    let mut face_normals = vec![Vec3::ZERO; out.positions.len()];
    for (p, map) in pieces.iter().zip(&remap) {
        for t in &p.tris {
            let t = t.map(|i| map[i as usize]);
            if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
                continue;
            }
            let [a, b, c] = t.map(|i| out.positions[i as usize]);
            let nrm = (b - a).cross(c - a);
            t.iter().for_each(|i| face_normals[*i as usize] += nrm);
            out.triangles.push(t);
        }
    }
    for (n, f) in out.normals.iter_mut().zip(face_normals) {
        *n = if n.length_squared() > 1e-20 { n.normalize() } else { f.normalize_or_zero() };
    }
    out
}
