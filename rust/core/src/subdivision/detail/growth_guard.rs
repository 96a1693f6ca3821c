//! The fold guard for the tentacle and the spur, whose levels pull seed vertices by
//! world-space offsets (Velho et al. 4.2: magnitudes "directly proportional to scale"), so
//! they are not capped by the edges as the rock is: a pull many edges long is the model.
//! Each group of vertices moved together (here one seed) has its offsets scaled as a
//! whole, as a dome is, by the least factor any of its vertices needs so that
//! - the offset's part along the vertex normal stays within the focal limits of
//!   [`fold_guard`](super::fold_guard) (half the radius of curvature on the side it moves
//!   to, so a pull out of a concave crease stays under about half an edge), and
//! - the offset is at most the level's clearance share, [`CLEAR_SHARE`] `2^-l`, of the
//!   distance along it to another part of the base met from its front (the next card
//!   across a gap, the other side of a knot's loop), so over all levels two parts growing
//!   at each other close at most 0.8 of the gap, as domes do.
//!
//! Not the mushroom cloud: its flow is divergence-free and smooth, so it carries the
//! surface without crossing it (what crossings it makes come from faces longer than the
//! gaps they span), and its offsets run along the surface, where rays meet a scan's
//! bumps a hair away: scaling each ring by these limits left no mushroom on the bunny.
//! The fuse has its own limit ([`super::growth::FUSE_AXIS_SHARE`]).

use super::fold_guard::{scale_groups, Clearance, Limits, Tally, CLEAR_SHARE};
use glam::{DVec3, Vec3};

/// Scales `offsets` group by group (`group[v]` the group vertex `v` moves with,
/// `u32::MAX` for a vertex that does not move) to what every vertex of the group may
/// take at level `level`, counting moved and reduced vertices in `tally`.
#[allow(clippy::too_many_arguments)]
pub(crate) fn guard(offsets: &mut [DVec3], group: &[u32], p: &[Vec3], normals: &[Vec3], limits: &Limits, clearance: &Clearance, level: u32, tally: &mut Tally) {
    let share = CLEAR_SHARE * 0.5f64.powi(level as i32);
    let need = |v: usize| {
        let w = offsets[v];
        let length = w.length();
        if length == 0.0 {
            return 1.0;
        }
        let along = w.dot(normals[v].as_dvec3());
        let focal = if along == 0.0 { 1.0 } else { (limits.clamp(v, along) / along).clamp(0.0, 1.0) };
        let room = share * clearance.distance_along(p[v].as_dvec3(), w / length);
        focal.min(room / length)
    };
    let factor = scale_groups(group, need);
    let full: Vec<DVec3> = group.iter().zip(offsets.iter()).filter(|(&g, _)| g != u32::MAX).map(|(_, &w)| w).collect();
    let kept: Vec<DVec3> = group
        .iter()
        .zip(offsets.iter_mut())
        .filter(|(&g, _)| g != u32::MAX)
        .map(|(&g, w)| {
            *w *= factor[g as usize];
            *w
        })
        .collect();
    tally.count(&full, &kept);
}

#[cfg(test)]
mod tests {
    use crate::subdivision::detail::{synthesize, Model, Offsets, Tally};
    use crate::{testmeshes, Mesh};

    #[test]
    fn a_spur_grows_at_most_part_way_across_a_gap() {
        // Two sheets 0.2 apart facing each other; a spur from the lower one's middle pulls
        // 0.2 at level 1 and 0.4 at level 2, through the upper sheet unguarded. Guarded,
        // its tip stays under 0.4 of the gap (0.2 of it at level 1, 0.1 of what is left
        // at level 2), and the tally says so; a spur with room is left whole.
        let gap = 0.2f32;
        let lower = testmeshes::plane(8);
        let n = lower.vertex_count() as u32;
        let mut positions = lower.positions().to_vec();
        positions.extend(lower.positions().iter().map(|p| *p + glam::Vec3::Z * gap));
        let mut corners = lower.corners().to_vec();
        for q in lower.corners().chunks_exact(4) {
            corners.extend([q[3] + n, q[2] + n, q[1] + n, q[0] + n]);
        }
        let base = Mesh::new(positions, &vec![4; 2 * lower.face_count()], corners, None).unwrap();
        let seed = 4 * 9 + 4;
        let run = |length: f64| {
            let model = Model::Spur { length, seeds: vec![seed], spacing: 0.5 };
            let mut tally = Tally::default();
            let out = synthesize(&base, 2, model.initial_state(&base), |level, mesh, normals, state| {
                let offsets = model.displacements(level, mesh, normals, 0, state);
                tally = state.tally;
                let Offsets::World(w) = &offsets else { unreachable!() };
                assert!(w.iter().all(|w| w.is_finite()));
                offsets
            })
            .unwrap();
            (out.mesh.positions()[seed as usize].z, tally)
        };
        let (tip, tally) = run(gap as f64);
        assert!(tip > 0.05 * gap && tip < 0.4 * gap, "tip at {tip}");
        assert_eq!(tally, Tally { placed: 2, limited: 2 });
        let (tip, tally) = run(0.005);
        assert!(tip > 0.009 && tally.limited == 0, "tip at {tip}, {tally:?}");
    }
}
