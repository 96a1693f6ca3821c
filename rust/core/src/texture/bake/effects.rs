//! What a stack does to its placed textures besides placing them (thick surfaces,
//! chapter 7): a partial region blended with a base slab (figure 3.3), a region moved
//! along the surface (7.2), and holes, painted on vertices or cut by a closed mesh
//! (7.3). One definition of the occupancy for the bake, its estimate and the
//! renderers, so a preview shows what the bake makes.
//!
//! Everything but the height `r` is fixed along a column of a cell: [`Effects::site`]
//! finds that part once (the weights at the column, where a moved piece came from),
//! and [`Site::blend`] combines the textures' occupancy at each height.

use super::cutter::Cutter;
pub use super::uv_mask::Raster;
use super::uv_mask::UvMask;
use super::BakeParams;
use crate::shell::Shell;
use glam::{Vec2, Vec3};

/// A vertex whose director is shorter than this share of the shell's median counts as
/// collapsed (hole weight 1), up to twice that (weight 0). Not from the paper: chosen
/// on the hard meshes (touching_cubes, cards, Suzanne's head), whose collapsed
/// vertices have directors of exactly 0 or below 0.1% of the median, the next ones up
/// at 1% and more; see [`collapsed`].
const COLLAPSED: f32 = 0.005;

/// A vertex whose director is shorter than this share of its OWN target thickness
/// counts as compressed (hole weight 1), up to twice that (weight 0). Where the shell
/// must compress (cards closer together than the thickness), cells keep 1-2% of their
/// target: far above [`COLLAPSED`] of the median when the targets vary, yet their
/// lattice layers are ~1e-4 apart and the sheets stacked on them cross in single
/// precision (44-58 crossing pairs on 300 cards close together). Not from the paper:
/// chosen above those 1-2% with a margin (at 2.5%, 20 pairs remained on the interior
/// shell; at 5%, none on either side); a texture squeezed to under a tenth of its
/// thickness shows little detail anyway. Shells read back from directors have their
/// targets equal to their lengths, so only the median rule applies to them.
const COMPRESSED: f32 = 0.05;

/// The hole weight of a director of length `length` against a threshold `low`: 1 up
/// to `low`, fading to 0 at twice that.
fn fade(length: f32, low: f32) -> f32 {
    (2.0 - length / low).clamp(0.0, 1.0)
}

/// Hole weights where the shell has collapsed (where it must, between touching parts
/// or in a gap narrower than the thickness, thick surfaces 4.3): directors under
/// [`COLLAPSED`] of the median one, or under [`COMPRESSED`] of their vertex's own
/// target thickness. A cell without height has no room for the texture: its lattice
/// layers coincide (or lie a float's rounding apart) and the iso-surface there is
/// sheets on top of each other, crossing (thousands of triangle pairs on the hard
/// meshes). Cut away as a painted hole is, the texture ends inside the cells that
/// still have height, where the shell is at least half as thick as at their other
/// corners. One rule for the bake, its estimate and both renderers (they all take
/// the holes from [`Effects`]). None where no vertex collapsed; all ones where every
/// director is 0.
pub fn collapsed(shell: &Shell) -> Option<Vec<f32>> {
    let lengths: Vec<f32> = shell.directors.iter().map(|d| d.length()).collect();
    let mut sorted: Vec<f32> = lengths.iter().copied().filter(|l| *l > 0.0).collect();
    if sorted.is_empty() {
        // No height anywhere: nothing has room.
        return (!lengths.is_empty()).then(|| vec![1.0; lengths.len()]);
    }
    let mid = sorted.len() / 2;
    let median = *sorted.select_nth_unstable_by(mid, f32::total_cmp).1;
    let low = COLLAPSED * median;
    let own = |i: usize| shell.target.get(i).copied().filter(|t| t.is_finite() && *t > 0.0).map_or(0.0, |t| COMPRESSED * t);
    let weights: Vec<f32> = lengths.iter().enumerate().map(|(i, &l)| fade(l, low).max(if own(i) > 0.0 { fade(l, own(i)) } else { 0.0 })).collect();
    weights.iter().any(|&w| w > 0.0).then_some(weights)
}

/// The hole weights of `params` and of the shell's collapse together (the larger).
pub(super) fn holes(params: &BakeParams, shell: &Shell) -> Option<Vec<f32>> {
    match (params.holes.as_ref(), collapsed(shell)) {
        (Some(painted), Some(c)) => Some(painted.iter().zip(c).map(|(p, c)| p.clamp(0.0, 1.0).max(c)).collect()),
        (painted, c) => c.or_else(|| painted.cloned()),
    }
}

/// The effects of one stack over the cells (triangles of the triangulated base).
#[derive(Default)]
pub struct Effects {
    tris: Vec<[u32; 3]>,
    region: Option<Vec<f32>>,
    holes: Option<Vec<f32>>,
    cutter: Option<Cutter>,
    /// Where the moved piece came from (a mask in `(s, t)`) and how far it went.
    moved: Option<(UvMask, Vec2)>,
    /// Top of the base slab, in `r`.
    base_layer: f32,
    /// Layers along the directors (the slab's edge is one layer wide).
    layers: f32,
}

/// The part of the occupancy fixed along a column.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Site {
    /// The texture in place (1) or the base slab (0).
    pub presence: f32,
    /// How much of a moved piece landed here.
    pub arrived: f32,
    /// What the holes leave (1: no hole).
    pub kept: f32,
    /// Where in `(s, t)` the piece that landed here came from.
    pub from: Vec2,
}

impl Effects {
    /// The effects of `params` over cells `tris` with corner texture coordinates `st`,
    /// sampled with `layers` layers across the shell; a moved region's mask has
    /// `mask_resolution` texels along the longer side of the `(s, t)` box. Where
    /// `shell` has collapsed, the texture is cut away as by holes ([`collapsed`]).
    pub fn new(tris: &[[u32; 3]], st: &[[Vec2; 3]], params: &BakeParams, shell: &Shell, layers: usize, mask_resolution: usize) -> Self {
        let layers = layers.max(1) as f32;
        Self {
            tris: tris.to_vec(),
            region: params.region.clone(),
            holes: holes(params, shell),
            cutter: params.cutter.clone(),
            moved: params.moved.as_ref().map(|mv| (UvMask::new(tris, st, &mv.weights, mask_resolution), mv.offset * params.tiling)),
            base_layer: params.base_layer.max(1.5 / layers),
            layers,
        }
    }

    /// Whether the textures show everywhere as placed (nothing to blend, move or cut).
    pub fn is_none(&self) -> bool {
        self.region.is_none() && self.holes.is_none() && self.cutter.is_none() && self.moved.is_none()
    }

    /// A per-vertex weight interpolated at barycentric `w` in cell `t`: exactly the
    /// corners' value where they agree (a region of weight 1 everywhere must blend in
    /// nothing, not a rounding error that moves samples across the iso-level).
    fn per_vertex(&self, values: Option<&[f32]>, t: usize, w: &[f32; 4]) -> Option<f32> {
        let c = self.tris[t];
        values.map(|v| {
            let corner = c.map(|i| v[i as usize].clamp(0.0, 1.0));
            if corner[0] == corner[1] && corner[1] == corner[2] {
                corner[0]
            } else {
                (0..3).map(|k| corner[k] * w[k]).sum::<f32>().clamp(0.0, 1.0)
            }
        })
    }

    /// The column at barycentric weights `w` of cell `t`, whose texture point is `st`.
    pub fn site(&self, t: usize, w: &[f32; 4], st: Vec2) -> Site {
        let mut presence = self.per_vertex(self.region.as_deref(), t, w).unwrap_or(1.0);
        let (mut arrived, mut from) = (0.0, st);
        if let Some((mask, d)) = &self.moved {
            presence *= 1.0 - mask.sample(st);
            arrived = mask.sample(st - *d);
            from = st - *d;
        }
        let kept = 1.0 - self.per_vertex(self.holes.as_deref(), t, w).unwrap_or(0.0);
        Site { presence, arrived, kept, from }
    }

    /// Whether world point `p` lies inside the cutter (a hole through the shell).
    pub fn cut(&self, p: Vec3) -> bool {
        self.cutter.as_ref().is_some_and(|c| c.contains(p))
    }

    pub fn has_cutter(&self) -> bool {
        self.cutter.is_some()
    }

    /// The cutter, for renderers that sample it on a grid.
    pub fn cutter(&self) -> Option<&Cutter> {
        self.cutter.as_ref()
    }

    /// The moved region: where it came from as a raster in `(s, t)` (see
    /// [`Self::site`]) and how far it went.
    pub fn moved_raster(&self) -> Option<(Raster<'_>, Vec2)> {
        self.moved.as_ref().map(|(mask, d)| (mask.raster(), *d))
    }

    /// The region and hole weights at the corners of cell `t`, in `[0, 1]` (1 and 0
    /// where there is none); [`Self::site`] interpolates them, exactly where the
    /// corners agree.
    pub fn corner_weights(&self, t: usize) -> ([f32; 3], [f32; 3]) {
        let c = self.tris[t];
        let at = |values: Option<&[f32]>, none: f32| c.map(|i| values.map_or(none, |v| v[i as usize].clamp(0.0, 1.0)));
        (at(self.region.as_deref(), 1.0), at(self.holes.as_deref(), 0.0))
    }

    /// The base slab: its top in `r`, and the layers across the shell (its edge is one
    /// layer wide).
    pub fn base_slab(&self) -> (f32, f32) {
        (self.base_layer, self.layers)
    }

    /// Bounds over the triangle of cell `t` with corner weights `w`: whether the
    /// textures alone bound the occupancy (no base slab shows), and the most the holes
    /// keep. Per-vertex weights are linear, so their extremes are at the corners.
    pub fn bounds(&self, t: usize, w: &[[f32; 4]; 3]) -> (bool, f32) {
        let range = |values: Option<&[f32]>| {
            w.iter()
                .filter_map(|w| self.per_vertex(values, t, w))
                .fold(None, |r: Option<(f32, f32)>, x| Some(r.map_or((x, x), |(lo, hi)| (lo.min(x), hi.max(x)))))
        };
        let textures_only = range(self.region.as_deref()).is_none_or(|(lo, _)| lo >= 1.0) && self.moved.is_none();
        (textures_only, range(self.holes.as_deref()).map_or(1.0, |(lo, _)| 1.0 - lo))
    }

    /// The base slab's occupancy at height `r`.
    fn base(&self, r: f32) -> f32 {
        ((self.base_layer - r) * self.layers + 0.5).clamp(0.0, 1.0)
    }
}

impl Site {
    /// Whether the textures in place, and those of the piece that landed, matter.
    pub fn needs(&self) -> (bool, bool) {
        (self.presence > 0.0, self.arrived > 0.0)
    }

    /// The occupancy at height `r`, given the textures' occupancy in place (`here`)
    /// and where the landed piece came from (`there`).
    #[inline]
    pub fn blend(&self, effects: &Effects, r: f32, here: f32, there: f32) -> f32 {
        let (here, there) = (if self.presence > 0.0 { here } else { 0.0 }, if self.arrived > 0.0 { there } else { 0.0 });
        self.kept * (self.arrived * there + (1.0 - self.arrived) * (self.presence * here + (1.0 - self.presence) * effects.base(r)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn shell(lengths: &[f32]) -> Shell {
        Shell::from_directors(vec![Vec3::ZERO; lengths.len()], lengths.iter().map(|&l| Vec3::Z * l).collect())
    }

    #[test]
    fn collapse_is_measured_against_the_median_director() {
        assert_eq!(collapsed(&shell(&[1.0; 5])), None, "an even shell has no collapse");
        assert_eq!(collapsed(&shell(&[0.0; 4])), Some(vec![1.0; 4]), "a shell without height has room nowhere");
        // Under 0.5% of the median: weight 1; fading to 0 at 1%.
        let w = collapsed(&shell(&[1.0, 1.0, 1.0, 0.0, 0.004, 0.0075, 0.02])).unwrap();
        assert_eq!(&w[..5], &[0.0, 0.0, 0.0, 1.0, 1.0]);
        assert!((w[5] - 0.5).abs() < 1e-5 && w[6] == 0.0, "{w:?}");
        // Painted holes and the collapse together: the larger weight.
        let params = BakeParams { holes: Some(vec![0.3, 0.0, 1.0, 0.0, 0.0, 0.2, 0.0]), ..Default::default() };
        let merged = holes(&params, &shell(&[1.0, 1.0, 1.0, 0.0, 0.004, 0.0075, 0.02])).unwrap();
        assert_eq!(merged.iter().map(|w| (w * 100.0).round() / 100.0).collect::<Vec<_>>(), vec![0.3, 0.0, 1.0, 1.0, 1.0, 0.5, 0.0]);
    }

    #[test]
    fn a_compressed_vertex_is_measured_against_its_own_target() {
        // Targets 1 everywhere, lengths 1 but for two squeezed vertices: 3% of the
        // target is far above 0.5% of the median, yet compressed (weight 1); 7.5% fades.
        let mut s = shell(&[1.0, 1.0, 1.0, 1.0, 0.03, 0.075, 0.2]);
        s.target = vec![1.0; 7];
        let w = collapsed(&s).unwrap();
        assert_eq!(&w[..5], &[0.0, 0.0, 0.0, 0.0, 1.0]);
        assert!((w[5] - 0.5).abs() < 1e-5 && w[6] == 0.0, "{w:?}");
        // A vertex with no target (weight-0 group) is left to the median rule.
        s.target[4] = 0.0;
        assert_eq!(collapsed(&s).unwrap()[4], 0.0);
    }

    #[test]
    fn compressed_cells_between_close_cards_bake_without_crossings() {
        // 300 open cards, one in five 0.02-0.08 from an earlier one, shells 0.1 thick:
        // where the shell must compress, cells keep 1-2% of their target, more than
        // 0.5% of the median director, and their lattice sheets stacked ~1e-4 apart
        // crossed (44 pairs exterior, 58 interior on this mesh's OBJ export before the
        // per-target rule, all inside one card's cell).
        use crate::shell::{build_shell, ShellParams, Side, Thickness};
        use crate::texture::{Generator, Pattern, TextureLayer};
        let mesh = crate::hard_meshes::cards(300, 7);
        let t = Thickness::absolute(0.1).per_vertex(&mesh, None).unwrap();
        let tex = Generator::new(Pattern::ChainMail).generate([16, 16, 8]).unwrap();
        let layers = [TextureLayer { texture: tex, offset: Vec2::ZERO }];
        for side in [Side::Exterior, Side::Interior] {
            let s = build_shell(&mesh, &t, side, &ShellParams::default()).unwrap();
            let b = super::super::bake(&mesh, &s, &layers, &BakeParams::default()).unwrap();
            let check = crate::polygonize::SurfaceCheck::of(&b.positions, &b.triangles);
            assert!(check.is_closed_manifold(), "{side:?}: {check:?}");
            let m = crate::Mesh::from_triangles(b.positions.clone(), &b.triangles).unwrap();
            assert_eq!(crate::hard_meshes::self_intersections(&m), 0, "{side:?}");
        }
    }
}
