//! The textured shell (thick surfaces, chapter 3): a base mesh, its shell, the
//! volumetric textures placed in it and the stack's effects (a partial region, holes,
//! a cutter and a moved region, chapter 7). One object, checked once, from which the
//! bake, its estimate and both renderers take what they show, so a preview and the
//! bake of the same object cannot disagree about their inputs.

use super::bake::{self, BakeParams, BakedMesh, BudgetFit, Effects, Estimate};
use super::TextureLayer;
use crate::shell::Shell;
use crate::{Mesh, Result};

#[derive(Debug, Clone)]
pub struct TexturedShell {
    pub mesh: Mesh,
    pub shell: Shell,
    /// The placed textures, united (max alpha).
    pub layers: Vec<TextureLayer>,
    /// Tiling, the effects and the bake's lattice and budget.
    pub params: BakeParams,
}

impl TexturedShell {
    /// The textured shell, once the settings are checked against the mesh and shell
    /// (the checks every bake, estimate and render makes; [`BakeParams`]).
    pub fn new(mesh: Mesh, shell: Shell, layers: Vec<TextureLayer>, params: BakeParams) -> Result<Self> {
        params.check(&mesh, &shell, &layers)?;
        Ok(Self { mesh, shell, layers, params })
    }

    /// The `alpha = 0.5` iso-surface as one closed mesh ([`bake::bake`]).
    pub fn bake(&self) -> Result<BakedMesh> {
        bake::bake(&self.mesh, &self.shell, &self.layers, &self.params)
    }

    /// What [`Self::bake`] is expected to make ([`bake::estimate_bake`]).
    /// [`TexturedShell::bake`] watched by `progress` (cells baked, a cancel flag)
    /// instead of the settings' own.
    pub fn bake_watched(&self, progress: Option<std::sync::Arc<crate::progress::Progress>>) -> Result<BakedMesh> {
        let params = BakeParams { progress, ..self.params.clone() };
        bake::bake(&self.mesh, &self.shell, &self.layers, &params)
    }

    pub fn estimate(&self) -> Result<Estimate> {
        bake::estimate_bake(&self.mesh, &self.shell, &self.layers, &self.params)
    }

    /// How many times larger its tiles must be for the bake to fit its triangle budget
    /// ([`bake::budget_scale`]; needs a UV map, generated ones included), watched by
    /// `progress` (estimates made, a cancel flag).
    pub fn budget_fit(&self, progress: Option<std::sync::Arc<crate::progress::Progress>>) -> Result<BudgetFit> {
        bake::budget_scale(&self.mesh, &self.shell, &self.layers, &BakeParams { progress, ..self.params.clone() })
    }

    /// The stack's effects as the bake applies them, for the renderers
    /// ([`bake::effects`]).
    pub fn effects(&self) -> Result<Effects> {
        bake::effects(&self.mesh, &self.shell, &self.layers, &self.params)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shell::{build_shell, ShellParams, Side, Thickness};
    use crate::texture::{Generator, Pattern};

    fn parts() -> (Mesh, Shell, Vec<TextureLayer>) {
        let mesh = crate::testmeshes::icosphere(1);
        let t = Thickness::relative(0.05).per_vertex(&mesh, None).unwrap();
        let shell = build_shell(&mesh, &t, Side::Exterior, &ShellParams::default()).unwrap();
        let texture = Generator::new(Pattern::Rivets).generate([16, 16, 8]).unwrap();
        (mesh, shell, vec![TextureLayer { texture, offset: glam::Vec2::ZERO }])
    }

    #[test]
    fn bad_settings_are_refused_when_made_not_later() {
        let (mesh, shell, layers) = parts();
        let n = mesh.vertex_count();
        let bad = [
            BakeParams { resolution: 0, ..Default::default() },
            BakeParams { tiling: f32::NAN, ..Default::default() },
            BakeParams { region: Some(vec![1.0; n + 1]), ..Default::default() },
        ];
        for params in bad {
            assert!(TexturedShell::new(mesh.clone(), shell.clone(), layers.clone(), params).is_err());
        }
        assert!(TexturedShell::new(mesh.clone(), shell.clone(), Vec::new(), BakeParams::default()).is_err());
        let other = crate::testmeshes::icosphere(0);
        assert!(TexturedShell::new(other, shell, layers, BakeParams::default()).is_err());
    }

    #[test]
    fn bake_estimate_and_effects_are_those_of_its_parts() {
        let (mesh, shell, layers) = parts();
        let holes: Vec<f32> = mesh.positions().iter().map(|p| f32::from(p.x > 0.0)).collect();
        let params = BakeParams { holes: Some(holes), triangle_budget: 0, resolution: 4, ..Default::default() };
        let ts = TexturedShell::new(mesh.clone(), shell.clone(), layers.clone(), params.clone()).unwrap();
        let baked = ts.bake().unwrap();
        assert_eq!(baked, bake::bake(&mesh, &shell, &layers, &params).unwrap());
        assert_eq!(ts.estimate().unwrap(), bake::estimate_bake(&mesh, &shell, &layers, &params).unwrap());
        assert!(!ts.effects().unwrap().is_none(), "the holes are an effect the renderers apply");
        let plain = TexturedShell::new(mesh, shell, layers, BakeParams::default()).unwrap();
        assert!(plain.effects().unwrap().is_none());
    }
}
