//! A procedural detail with its operations (Velho, Perlin, Ying and Biermann, sections
//! 5-6): a model placed at chosen levels, blended level by level with a second model
//! (Burt-Adelson), and modified locally; the blend parameter comes out beside the
//! scalar for the post-processing shader.

use super::detail::{self, Detailed, Model, Offsets, State, Tally};
use super::multires;
use super::operations::{Alpha, AlphaSource, Levels, Local};
use crate::mesh::{vertex_normals, Incidence};
use crate::{Error, Mesh, Result};
use glam::{DVec3, Vec3};

/// The most local modifications one recipe takes.
pub const MAX_LOCAL: usize = 16;

/// A second model blended in (6.1): its detail where `alpha` is 1, the first model's
/// where it is 0, mixed coefficient by coefficient at every level in between.
#[derive(Debug, Clone, PartialEq)]
pub struct Blend {
    pub model: Model,
    pub seed: u64,
    pub at: Levels,
    pub alpha: Alpha,
    pub motion: Motion,
}

/// What [`synthesize`] builds: `model` (random values from `seed`) adding detail at the
/// levels `at` only (5: features "placed at one level or simultaneously at different
/// scales"), optionally blended with a second model, then scaled by each local
/// modification (a gain above 1 before the models' fold guards, so it stays within their
/// limits). `sculpt`, analysed detail ([`multires::Multires::details`] of this base),
/// is added at its levels first, in the frames of each level's subdivided mesh (section 2);
/// the procedural detail of that level then acts on the sculpted surface, so it can go at
/// any level, coarser or finer than the sculpt's, and the sculpt follows it.
#[derive(Debug, Clone, PartialEq)]
pub struct Recipe {
    pub model: Model,
    pub seed: u64,
    pub at: Levels,
    pub blend: Option<Blend>,
    pub local: Vec<Local>,
    pub sculpt: Option<Vec<Vec<DVec3>>>,
    /// The animation time (section 3): it moves the models by their [`Motion`] and the
    /// blend's alpha by its sweep ([`Alpha::sweep`]); the shader takes it too
    /// ([`super::operations::Planet::at_time`]).
    pub time: f64,
    pub motion: Motion,
}

/// The largest animation time taken (in the scene's seconds times a speed).
pub const MAX_TIME: f64 = 1e6;

/// How time moves a model (section 3: "an animation time parameter can feed into (i) any
/// synthesized shape definition"; 4.2: the tentacle's "parameters can be time-varying
/// and be used for animation"): a tentacle turns by `spin` radians per unit of time, and
/// the model's size (a rock's or fuse's amplitude, a tentacle's, spur's or mushroom
/// cloud's length) grows from 0 at time 0 to its full value at time `grow` (0: full at
/// every time). A berry does not grow: its radius also sets its seeds' spacing, so its
/// domes would jump from place to place.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Motion {
    pub spin: f64,
    pub grow: f64,
}

impl Motion {
    pub fn validate(&self) -> Result<()> {
        if !(self.spin.is_finite() && self.spin.abs() <= MAX_TIME && self.grow.is_finite() && (0.0..=MAX_TIME).contains(&self.grow)) {
            return Err(Error::InvalidParameter(format!(
                "spin must be finite and grow between 0 and {MAX_TIME}, not spin {} and grow {}",
                self.spin, self.grow
            )));
        }
        Ok(())
    }

    /// `model` as it is at `time`.
    pub fn at(&self, model: &Model, time: f64) -> Model {
        let g = match self.grow > 0.0 {
            true => (time / self.grow).clamp(0.0, 1.0),
            false => 1.0,
        };
        match model.clone() {
            Model::Rock { amplitude } => Model::Rock { amplitude: amplitude * g },
            Model::Tentacle { length, theta, seeds, spacing } => Model::Tentacle { length: length * g, theta: theta + self.spin * time, seeds, spacing },
            Model::Spur { length, seeds, spacing } => Model::Spur { length: length * g, seeds, spacing },
            Model::Mushroom { radius, length, seeds } => Model::Mushroom { radius, length: length * g, seeds },
            Model::Fuse { amplitude, span, center, axis } => Model::Fuse { amplitude: amplitude * g, span, center, axis },
            berry @ Model::Berry { .. } => berry,
        }
    }
}

impl Recipe {
    /// `model` everywhere, at every level, alone.
    pub fn of(model: Model, seed: u64) -> Self {
        Recipe { model, seed, at: Levels::ALL, blend: None, local: Vec::new(), sculpt: None, time: 0.0, motion: Motion::default() }
    }

    fn validate(&self, base: &Mesh) -> Result<()> {
        if !(self.time.is_finite() && self.time.abs() <= MAX_TIME) {
            return Err(Error::InvalidParameter(format!("time must be finite and at most {MAX_TIME} in size, not {}", self.time)));
        }
        self.motion.validate()?;
        self.motion.at(&self.model, self.time).validate(base)?;
        if let Some(b) = &self.blend {
            b.motion.validate()?;
            b.motion.at(&b.model, self.time).validate(base)?;
            b.alpha.validate(base)?;
        }
        if self.local.len() > MAX_LOCAL {
            return Err(Error::InvalidParameter(format!("at most {MAX_LOCAL} local modifications, not {}", self.local.len())));
        }
        self.local.iter().try_for_each(|l| l.validate(base))?;
        self.sculpt.as_ref().map_or(Ok(()), |s| multires::validate_details(base, s))
    }
}

/// A detailed surface and, per vertex of its finest level, the blend parameter there (0
/// without a blend): what the planet's shader reads beside the scalar (6.2).
#[derive(Debug, Clone, PartialEq)]
pub struct Synthesized {
    pub detailed: Detailed,
    pub blend: Vec<f32>,
    /// How much of the placed detail the fold guard reduced (both models).
    pub tally: Tally,
}

/// Subdivides `base` by `levels` levels adding the recipe's detail at each (see
/// [`Recipe`]); the models keep their own seeds and states, so a model placed at
/// some levels only, or blended, has the same features it has alone.
pub fn synthesize(base: &Mesh, levels: u32, recipe: &Recipe) -> Result<Synthesized> {
    recipe.validate(base)?;
    let sculpt = recipe.sculpt.as_deref().unwrap_or_default();
    if sculpt.len() > levels as usize {
        return Err(Error::InvalidParameter(format!(
            "the sculpt has {} levels, more than the {levels} synthesized; synthesize at least as many",
            sculpt.len()
        )));
    }
    // The models as they are at this time.
    let model = recipe.motion.at(&recipe.model, recipe.time);
    let other = recipe.blend.as_ref().map(|b| b.motion.at(&b.model, recipe.time));
    let mut first = model.initial_state(base);
    first.second = other.as_ref().map(|m| Box::new(m.initial_state(base)));
    // Painted alpha: the weights, carried level by level by the synthesis.
    if let Some(AlphaSource::Painted { weights }) = recipe.blend.as_ref().map(|b| &b.alpha.source) {
        first.painted = weights.clone();
    }
    let mut blend_out = Vec::new();
    let detailed = detail::synthesize_in(base, levels, &mut first, |level, mesh, normals, first| {
        // The sculpt's detail of this level, and the sculpted surface the models then see.
        let sculpted = sculpt.get(level as usize - 1).map(|local| {
            let w = multires::to_world(mesh, normals, local);
            let moved = mesh.positions().iter().zip(&w).map(|(p, w)| (p.as_dvec3() + *w).as_vec3()).collect();
            let moved = Mesh::new(moved, &mesh.face_sizes(), mesh.corners().to_vec(), None).expect("the same topology, finite positions");
            let n = vertex_normals(&moved);
            (w, moved, n)
        });
        let (mesh, normals) = match &sculpted {
            Some((_, m, n)) => (m, &n[..]),
            None => (mesh, normals),
        };
        // A model runs at every level (its seeds and state evolve), but only its placed
        // levels move the surface and count in its tally.
        let placed = |at: Levels, d: Offsets| if at.has(level) { d } else { Offsets::Normal(vec![0.0; mesh.vertex_count()]) };
        let displaced = |model: &Model, at: Levels, seed: u64, state: &mut State| {
            let before = state.tally;
            let d = placed(at, model.displacements(level, mesh, normals, seed, state));
            if !at.has(level) {
                state.tally = before;
            }
            d
        };
        // Local modifications: each vertex's gain (the product of their weights). Its
        // part above 1 goes into each model's detail before the fold guard clamps it, so
        // an enhancement cannot take the detail past the guard's limits; its part below 1
        // scales the guarded detail (lowering detail within its limits folds nothing, and
        // gain 0 removes it exactly).
        let gain = (!recipe.local.is_empty()).then(|| {
            let incidence = Incidence::faces(mesh);
            let mut gain = vec![1.0; mesh.vertex_count()];
            for local in &recipe.local {
                gain.iter_mut().zip(local.weights(level, levels, mesh, &incidence)).for_each(|(g, w)| *g *= w);
            }
            gain
        });
        let above: Vec<f64> = match &gain {
            Some(g) if g.iter().any(|&g| g > 1.0) => g.iter().map(|&g| g.max(1.0)).collect(),
            _ => Vec::new(),
        };
        if let Some(second) = first.second.as_deref_mut() {
            second.gain = above.clone();
        }
        first.gain = above;
        let mut d = displaced(&model, recipe.at, recipe.seed, first);
        if let (Some(b), Some(other), Some(state)) = (&recipe.blend, &other, first.second.as_deref_mut()) {
            let other = displaced(other, b.at, b.seed, state);
            let alpha = b.alpha.at(level, mesh.positions(), &first.painted, recipe.time);
            d = mixed(d, other, &alpha, normals);
            if level == levels {
                blend_out = alpha.iter().map(|&a| a as f32).collect();
            }
        }
        if let Some(gain) = gain {
            scaled(&mut d, &gain.iter().map(|&g| g.min(1.0)).collect::<Vec<_>>());
        }
        match &sculpted {
            Some((w, _, _)) => Offsets::World(world(d, normals).iter().zip(w).map(|(d, w)| *d + *w).collect()),
            None => d,
        }
    })?;
    if blend_out.is_empty() {
        blend_out = vec![0.0; detailed.mesh.vertex_count()];
    }
    let mut tally = first.tally;
    if let Some(second) = first.second {
        tally.add(second.tally);
    }
    Ok(Synthesized { detailed, blend: blend_out, tally })
}

/// `(1 - alpha) a + alpha b`, per vertex (6.1: a linear combination of the two signals);
/// along the normals where both models move along them, else as world-space offsets.
fn mixed(a: Offsets, b: Offsets, alpha: &[f64], normals: &[Vec3]) -> Offsets {
    match (a, b) {
        (Offsets::Normal(a), Offsets::Normal(b)) => Offsets::Normal(a.iter().zip(&b).zip(alpha).map(|((a, b), t)| (1.0 - t) * a + t * b).collect()),
        (a, b) => {
            let (a, b) = (world(a, normals), world(b, normals));
            Offsets::World(a.iter().zip(&b).zip(alpha).map(|((a, b), &t)| *a * (1.0 - t) + *b * t).collect())
        }
    }
}

/// Offsets as world-space vectors (a displacement along the normal times the normal).
fn world(o: Offsets, normals: &[Vec3]) -> Vec<DVec3> {
    match o {
        Offsets::Normal(d) => d.iter().zip(normals).map(|(&d, n)| n.as_dvec3() * d).collect(),
        Offsets::World(w) => w,
    }
}

/// Each vertex's offset times its weight.
fn scaled(o: &mut Offsets, weights: &[f64]) {
    match o {
        Offsets::Normal(d) => d.iter_mut().zip(weights).for_each(|(d, w)| *d *= w),
        Offsets::World(v) => v.iter_mut().zip(weights).for_each(|(v, &w)| *v *= w),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::Incidence;
    use crate::subdivision::operations::hops;
    use crate::testmeshes;

    fn sphere() -> Mesh {
        testmeshes::icosphere(2)
    }

    fn rock(amplitude: f64) -> Model {
        Model::Rock { amplitude }
    }

    fn plane_blend(model: Model, width: f64, point: DVec3) -> Blend {
        Blend {
            model,
            seed: 2,
            at: Levels::ALL,
            alpha: Alpha { source: AlphaSource::Plane { point, direction: DVec3::new(1.0, 2.0, 0.0) }, width, sweep: 0.0 },
            motion: Motion::default(),
        }
    }

    #[test]
    fn a_recipe_of_one_model_is_that_model() {
        let base = sphere();
        let alone = detail::procedural_detail(&base, 3, &rock(0.05), 4).unwrap();
        let out = synthesize(&base, 3, &Recipe::of(rock(0.05), 4)).unwrap();
        assert_eq!(out.detailed, alone);
        assert!(out.blend.iter().all(|&b| b == 0.0));
    }

    #[test]
    fn a_blend_with_alpha_zero_or_one_is_the_single_model() {
        let base = sphere();
        let berry = Model::Berry { radius: 0.3, seeds: vec![], children: 2 };
        let far = DVec3::new(100.0, 0.0, 0.0);
        let (all_first, all_second) = (plane_blend(berry.clone(), 0.2, far), plane_blend(berry.clone(), 0.2, -far));
        let first = Recipe { blend: Some(all_first), ..Recipe::of(rock(0.05), 4) };
        assert_eq!(synthesize(&base, 3, &first).unwrap().detailed, detail::procedural_detail(&base, 3, &rock(0.05), 4).unwrap());
        let second = Recipe { blend: Some(all_second), ..Recipe::of(rock(0.05), 4) };
        let out = synthesize(&base, 3, &second).unwrap();
        assert_eq!(out.detailed, detail::procedural_detail(&base, 3, &berry, 2).unwrap());
        assert!(out.blend.iter().all(|&b| b == 1.0));
        // Painted: all 0 is the first model, all 1 the second.
        let painted = |w: f32| Recipe {
            blend: Some(Blend {
                model: berry.clone(),
                seed: 2,
                at: Levels::ALL,
                alpha: Alpha { source: AlphaSource::Painted { weights: vec![w; base.vertex_count()] }, width: 0.5, sweep: 0.0 },
                motion: Motion::default(),
            }),
            ..Recipe::of(rock(0.05), 4)
        };
        assert_eq!(synthesize(&base, 2, &painted(0.0)).unwrap().detailed, detail::procedural_detail(&base, 2, &rock(0.05), 4).unwrap());
        assert_eq!(synthesize(&base, 2, &painted(1.0)).unwrap().detailed, detail::procedural_detail(&base, 2, &berry, 2).unwrap());
    }

    #[test]
    fn a_plane_blend_mixes_inside_its_transition_only() {
        let base = sphere();
        let width = 0.4;
        let out = synthesize(&base, 3, &Recipe { blend: Some(plane_blend(rock(0.0), width, DVec3::ZERO)), ..Recipe::of(rock(0.05), 4) }).unwrap();
        // The finest level's transition is width / 4 wide: the blend parameter is 0 or 1
        // beyond it (measured on the detailed surface, which the rock moved a little).
        let dir = DVec3::new(1.0, 2.0, 0.0).normalize();
        let p = out.detailed.mesh.positions();
        let mut mixed = 0;
        for (q, &b) in p.iter().zip(&out.blend) {
            let s = q.as_dvec3().dot(dir);
            if s.abs() > width / 8.0 + 0.06 {
                assert_eq!(b, if s > 0.0 { 1.0 } else { 0.0 }, "at {s}");
            }
            mixed += (b > 0.0 && b < 1.0) as usize;
        }
        assert!(mixed > 0);
        // The flat second model where alpha is 1: the rock's coarse levels reach across
        // (their transition is wider, and subdivision spreads each level's detail by
        // about one of its rings), but far on that side the surface is the plain one.
        let plain = detail::synthesize(&base, 3, State::default(), |_, mesh, _, _| Offsets::Normal(vec![0.0; mesh.vertex_count()])).unwrap().mesh;
        let mut far_side = p.iter().zip(plain.positions()).filter(|(_, q)| q.as_dvec3().dot(dir) > width + 0.1);
        assert!(far_side.clone().count() > 10 && far_side.all(|(a, b)| a.distance(*b) < 1e-6));
    }

    #[test]
    fn local_modification_leaves_vertices_beyond_its_radius_untouched() {
        let base = sphere();
        let center = 7;
        let levels = 3;
        for radius in [1.0, 2.5, 3.5] {
            let local = Local { center, radius, gain: 0.0, levels: Levels::ALL };
            let plain = synthesize(&base, levels, &Recipe::of(rock(0.05), 4)).unwrap().detailed;
            let out = synthesize(&base, levels, &Recipe { local: vec![local], ..Recipe::of(rock(0.05), 4) }).unwrap().detailed;
            // Nothing changes `radius` base edges (radius * 2^3 hops of level 3) or farther
            // from the center, and something changes just inside.
            let d = hops(&out.mesh, &Incidence::faces(&out.mesh), center, u32::MAX);
            let (p, q) = (plain.mesh.positions(), out.mesh.positions());
            let bound = (radius * 8.0) as u32;
            let mut kept = 0;
            for v in 0..p.len() {
                if d[v] >= bound {
                    assert_eq!(p[v], q[v], "radius {radius}: vertex {v} at {} hops", d[v]);
                    kept += 1;
                }
            }
            assert!(kept > p.len() / 3, "{kept} of {} beyond the radius", p.len());
            assert!((0..p.len()).any(|v| d[v] + 1 == bound && p[v] != q[v]) || radius < 2.5, "radius {radius}: the change reaches the radius");
            if radius >= 2.5 {
                // Every level acts at the center (level 1 within floor(2 radius - 3.75) hops).
                assert!(out.scalar[center as usize].abs() < 1e-6, "gain 0 removes the detail at the center");
            }
            assert!(plain.scalar[center as usize].abs() > 1e-4);
        }
    }

    #[test]
    fn a_model_placed_at_some_levels_adds_nothing_at_the_others() {
        let base = sphere();
        let at2 = Recipe { at: Levels::of(&[2]).unwrap(), ..Recipe::of(rock(0.05), 4) };
        let out = synthesize(&base, 2, &at2).unwrap().detailed;
        // Level 1 adds nothing: the result is plain level 1, subdivided, plus level 2's detail.
        let level2_only = detail::synthesize(&base, 2, State::default(), |level, mesh, normals, state| {
            let d = rock(0.05).displacements(level, mesh, normals, 4, state);
            if level == 2 {
                d
            } else {
                Offsets::Normal(vec![0.0; mesh.vertex_count()])
            }
        })
        .unwrap();
        assert_eq!(out, level2_only);
        assert_ne!(out, detail::procedural_detail(&base, 2, &rock(0.05), 4).unwrap());
    }

    /// A sphere sculpted at levels 1-3 (bumps and noise along the normals), analysed.
    fn sculpt() -> (Mesh, Mesh, multires::Multires) {
        let base = sphere();
        let plain = detail::synthesize(&base, 3, State::default(), |_, m, _, _| Offsets::Normal(vec![0.0; m.vertex_count()])).unwrap().mesh;
        let n = vertex_normals(&plain);
        let moved = plain.positions().iter().zip(&n).map(|(p, n)| *p + *n * (0.006 * (25.0 * p.x).sin() * (21.0 * p.z).cos())).collect();
        let fine = Mesh::new(moved, &plain.face_sizes(), plain.corners().to_vec(), None).unwrap();
        let m = multires::analyze(&fine, &base, 3).unwrap();
        (base, fine, m)
    }

    #[test]
    fn a_sculpt_under_a_flat_model_is_the_sculpt() {
        let (_, fine, m) = sculpt();
        let recipe = Recipe { sculpt: Some(m.details.clone()), ..Recipe::of(rock(0.0), 4) };
        for levels in [3, 4] {
            let out = synthesize(&m.base, levels, &recipe).unwrap().detailed.mesh;
            let want = if levels == 3 {
                fine.clone()
            } else {
                detail::synthesize(&fine, 1, State::default(), |_, m, _, _| Offsets::Normal(vec![0.0; m.vertex_count()])).unwrap().mesh
            };
            let worst = out.positions().iter().zip(want.positions()).map(|(a, b)| a.distance(*b)).fold(0.0, f32::max);
            assert!(worst < 1e-5 * fine.bbox_diagonal(), "{levels} levels: {worst}");
        }
        // Its levels must fit in those made, and it must be of this base.
        assert!(matches!(synthesize(&m.base, 2, &recipe), Err(Error::InvalidParameter(_))));
        let other = Recipe { sculpt: Some(m.details.clone()), ..Recipe::of(rock(0.0), 4) };
        assert!(matches!(synthesize(&crate::mesh::fixtures::cube(), 3, &other), Err(Error::InvalidParameter(_))));
    }

    #[test]
    fn a_coarser_rock_carries_the_finer_sculpt_along() {
        let (_, fine, m) = sculpt();
        // The sculpt at levels 2-3 only, the rock at level 1 only.
        let mut details = m.details.clone();
        details[0].iter_mut().for_each(|d| *d = DVec3::ZERO);
        let rock1 = Recipe { at: Levels::of(&[1]).unwrap(), ..Recipe::of(rock(0.2), 4) };
        let both = Recipe { sculpt: Some(details.clone()), ..rock1.clone() };
        let flat_sculpt = Recipe { sculpt: Some(details), ..Recipe::of(rock(0.0), 4) };
        let plain = synthesize(&m.base, 3, &Recipe::of(rock(0.0), 4)).unwrap().detailed.mesh;
        let (r, b, s) = [&rock1, &both, &flat_sculpt].map(|x| synthesize(&m.base, 3, x).unwrap().detailed.mesh).into();
        let diag = fine.bbox_diagonal();
        // The rock moves the surface far more than the sculpt's features are high...
        let size = |a: &Mesh, b: &Mesh| a.positions().iter().zip(b.positions()).map(|(p, q)| p.distance(*q)).fold(0.0, f32::max);
        let feature = size(&s, &plain);
        assert!(feature > 0.001 * diag && size(&r, &plain) > 2.0 * feature, "{feature} {}", size(&r, &plain));
        // ... and the sculpted features ride on it: over the rock, the sculpted offsets keep
        // their heights along the normal (to a fraction of them: the rock's curvature bends
        // them), where world-space offsets (added as they are) would not.
        let (nr, np) = (vertex_normals(&r), vertex_normals(&plain));
        let rms = |x: &mut dyn Iterator<Item = f32>| {
            let (sum, n) = x.fold((0.0f64, 0usize), |(s, n), e| (s + (e as f64).powi(2), n + 1));
            (sum / n as f64).sqrt()
        };
        let height = |v: usize| (s.positions()[v] - plain.positions()[v]).dot(np[v]);
        let heights = rms(&mut (0..r.vertex_count()).map(height));
        let framed = rms(&mut (0..r.vertex_count()).map(|v| (b.positions()[v] - r.positions()[v]).dot(nr[v]) - height(v)));
        let world = rms(&mut (0..r.vertex_count()).map(|v| (s.positions()[v] - plain.positions()[v]).dot(nr[v]) - height(v)));
        assert!(framed < 0.2 * heights && world > 2.0 * framed, "rms heights {heights}, errors in frames {framed}, in world space {world}");
    }

    #[test]
    fn bad_operations_are_refused() {
        let base = sphere();
        let refuse = |r: Recipe| assert!(matches!(synthesize(&base, 2, &r), Err(Error::InvalidParameter(_))), "{r:?}");
        let local = |center, radius, gain| Recipe { local: vec![Local { center, radius, gain, levels: Levels::ALL }], ..Recipe::of(rock(0.05), 1) };
        refuse(local(100_000, 1.0, 0.0));
        refuse(local(0, 0.0, 0.0));
        refuse(local(0, 1.0, f64::NAN));
        refuse(Recipe { blend: Some(plane_blend(rock(0.05), -1.0, DVec3::ZERO)), ..Recipe::of(rock(0.05), 1) });
        let mut zero_dir = plane_blend(rock(0.05), 1.0, DVec3::ZERO);
        zero_dir.alpha.source = AlphaSource::Plane { point: DVec3::ZERO, direction: DVec3::ZERO };
        refuse(Recipe { blend: Some(zero_dir), ..Recipe::of(rock(0.05), 1) });
        let mut short = plane_blend(rock(0.05), 1.0, DVec3::ZERO);
        short.alpha.source = AlphaSource::Painted { weights: vec![0.5; 3] };
        refuse(Recipe { blend: Some(short), ..Recipe::of(rock(0.05), 1) });
        refuse(Recipe { blend: Some(plane_blend(rock(f64::INFINITY), 1.0, DVec3::ZERO)), ..Recipe::of(rock(0.05), 1) });
        assert!(Levels::of(&[0]).is_err() && Levels::of(&[32]).is_err());
    }

    #[test]
    fn time_moves_the_models_by_their_motion_and_the_alpha_by_its_sweep() {
        let base = sphere();
        let tentacle = |theta| Model::Tentacle { length: 0.05, theta, seeds: vec![3, 17], spacing: 0.5 };
        let at = |model: Model, motion: Motion, time: f64| synthesize(&base, 3, &Recipe { time, motion, ..Recipe::of(model, 4) }).unwrap().detailed;
        // A tentacle spinning 0.5 radians per unit of time, at time 3, is the tentacle
        // turned by 1.5; without spin, time changes nothing.
        let spun = at(tentacle(0.2), Motion { spin: 0.5, grow: 0.0 }, 3.0);
        assert_eq!(spun, at(tentacle(1.7), Motion::default(), 0.0));
        assert_ne!(spun, at(tentacle(0.2), Motion::default(), 0.0));
        assert_eq!(at(tentacle(0.2), Motion::default(), 3.0), at(tentacle(0.2), Motion::default(), 0.0));
        // Growing over 4 units of time: a quarter of the rock at time 1, the whole from 4 on.
        let grow = Motion { spin: 0.0, grow: 4.0 };
        assert_eq!(at(rock(0.05), grow, 1.0), at(rock(0.0125), Motion::default(), 0.0));
        assert_eq!(at(rock(0.05), grow, 9.0), at(rock(0.05), Motion::default(), 0.0));
        let flat = at(rock(0.05), grow, 0.0);
        assert!(flat.scalar.iter().all(|&h| h == 0.0), "nothing grown at time 0");
        // A sweeping plane at time 2 is the plane moved back by 2 sweeps.
        let sweep = |point: DVec3, sweep: f64, time: f64| {
            let mut b = plane_blend(rock(0.0), 0.3, point);
            b.alpha.sweep = sweep;
            synthesize(&base, 3, &Recipe { blend: Some(b), time, ..Recipe::of(rock(0.05), 4) }).unwrap()
        };
        let dir = DVec3::new(1.0, 2.0, 0.0).normalize();
        let (swept, moved) = (sweep(DVec3::ZERO, 0.1, 2.0), sweep(-0.2 * dir, 0.0, 0.0));
        assert!(swept.blend.iter().zip(&moved.blend).all(|(a, b)| (a - b).abs() < 1e-5));
        let p = |m: &Mesh| m.positions().to_vec();
        let worst = p(&swept.detailed.mesh).iter().zip(p(&moved.detailed.mesh)).map(|(a, b)| a.distance(b)).fold(0.0, f32::max);
        assert!(worst < 1e-5, "{worst}");
        assert!(swept.blend.iter().sum::<f32>() > sweep(DVec3::ZERO, 0.1, 0.0).blend.iter().sum::<f32>() + 1.0, "the second model's side grows");
        // Bad times and motions are refused.
        for r in [
            Recipe { time: f64::NAN, ..Recipe::of(rock(0.05), 1) },
            Recipe { motion: Motion { spin: 0.0, grow: -1.0 }, ..Recipe::of(rock(0.05), 1) },
            Recipe { motion: Motion { spin: f64::INFINITY, grow: 0.0 }, ..Recipe::of(rock(0.05), 1) },
        ] {
            assert!(matches!(synthesize(&base, 1, &r), Err(Error::InvalidParameter(_))), "{r:?}");
        }
    }
}
