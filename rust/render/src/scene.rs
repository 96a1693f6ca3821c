//! A shell with its textures, ready to render: the cells (triangle prisms over the
//! triangulated base, chapter 3.1) with their maps, texture coordinates and bounds.

use glam::Vec3;
use thicket_core::shell::Shell;
use thicket_core::texture::bake::Effects;
use thicket_core::texture::{CellMap, TextureCoordinates, TextureLayer, TexturedShell, TriangleCells};
use thicket_core::{Error, Mesh, Result};

pub struct ShellScene {
    pub cells: Vec<CellMap>,
    /// Axis-aligned bounds of each cell (its six corners, padded for the bulge of the
    /// bilinear side faces).
    pub bounds: Vec<(Vec3, Vec3)>,
    pub textures: Vec<TextureLayer>,
    /// True when the mesh had no UVs and each face got its own tile.
    pub per_face_tiles: bool,
    /// The stack's region, holes, cutter and moved region, applied as the bake does
    /// ([`Effects`]; none by default).
    pub effects: Effects,
}

impl ShellScene {
    /// `textures` are united (max alpha), each shifted by its offset in `(s, t)`.
    pub fn new(mesh: &Mesh, shell: &Shell, textures: Vec<TextureLayer>, tiling: f32) -> Result<Self> {
        mesh.require_faces()?;
        if textures.is_empty() {
            return Err(Error::InvalidParameter("no texture to render".into()));
        }
        if shell.directors.len() != mesh.vertex_count() {
            return Err(Error::InvalidParameter("the shell does not belong to this mesh".into()));
        }
        if !(tiling > 0.0 && tiling.is_finite()) {
            return Err(Error::InvalidParameter("tiling must be a positive number".into()));
        }
        let coords = TextureCoordinates::of(mesh, tiling);
        let tri = TriangleCells::new(mesh, &coords);
        let cells: Vec<CellMap> = (0..tri.triangles.len()).map(|t| tri.cell(mesh, shell, t)).collect();
        let bounds = cells
            .iter()
            .map(|c| {
                let corners = (0..3).flat_map(|k| [c.base[k], c.base[k] + c.director[k]]);
                let (lo, hi) = corners.fold((Vec3::MAX, Vec3::MIN), |(a, b), p| (a.min(p), b.max(p)));
                let pad = (hi - lo).max_element() * 0.05;
                (lo - pad, hi + pad)
            })
            .collect();
        Ok(Self { cells, bounds, textures, per_face_tiles: coords.per_face_tiles, effects: Effects::default() })
    }

    /// The scene of a textured shell: its cells, textures and the stack's effects
    /// exactly as its bake applies them.
    pub fn of(textured: &TexturedShell) -> Result<Self> {
        let TexturedShell { mesh, shell, layers, params } = textured;
        Ok(Self::new(mesh, shell, layers.clone(), params.tiling)?.with_effects(textured.effects()?))
    }

    /// The scene with the stack's effects ([`thicket_core::texture::bake::effects`]
    /// of the same mesh, textures and settings as the bake).
    pub fn with_effects(self, effects: Effects) -> Self {
        debug_assert!(effects.is_none() || self.cells.iter().all(|c| c.count == 3), "effects are made for triangle cells");
        Self { effects, ..self }
    }

    /// The occupancy at parameters `q = (u, v, r)` of cell `c`: the united textures
    /// with the stack's effects applied, exactly as the bake samples it.
    pub fn occupancy(&self, c: usize, q: Vec3) -> f32 {
        let cell = &self.cells[c];
        if self.effects.is_none() {
            return self.alpha(cell.texture(q)).0;
        }
        if self.effects.cut(cell.world(q)) {
            return 0.0;
        }
        let st = cell.texture(Vec3::new(q.x, q.y, 0.0)).truncate();
        let site = self.effects.site(c, &cell.weights(q.x, q.y), st);
        let (here, there) = site.needs();
        let here = if here { self.alpha(st.extend(q.z)).0 } else { 0.0 };
        let there = if there { self.alpha(site.from.extend(q.z)).0 } else { 0.0 };
        site.blend(&self.effects, q.z, here, there)
    }

    /// Union of the textures at texture point `c` (max alpha) and the index of the
    /// layer that wins.
    pub fn alpha(&self, c: Vec3) -> (f32, usize) {
        self.textures.iter().map(|l| l.texture.sample(c + l.offset.extend(0.0))).enumerate().fold((f32::NEG_INFINITY, 0), |best, (k, a)| {
            if a > best.0 {
                (a, k)
            } else {
                best
            }
        })
    }

    /// `∇alpha` in texture space at `c`, from the winning layer.
    pub fn gradient(&self, c: Vec3) -> Vec3 {
        let (_, k) = self.alpha(c);
        let l = &self.textures[k];
        l.texture.gradient(c + l.offset.extend(0.0))
    }

    /// Bounds of the whole shell.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.bounds.iter().fold((Vec3::MAX, Vec3::MIN), |(a, b), (lo, hi)| (a.min(*lo), b.max(*hi)))
    }
}
