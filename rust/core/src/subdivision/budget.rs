//! What a subdivision will make, told before it is made: the faces of level `l` and the
//! memory the refinement holds at its peak, so callers refuse a level that would not fit
//! (issue 18's "levels above what fits in memory (estimate first)").

use crate::{Error, Mesh, Result};

/// Peak bytes held per face of the finest level: that level's topology (vertex positions
/// in f64, corners, each corner's face and edge, edges and their faces: about 130 bytes
/// per face, all quads), the level before it (a quarter of that) and the output mesh (f32
/// positions, corners, face sizes: about 32), rounded up. Measured as the growth of the
/// peak resident memory of the Python calls at 8.06 M faces: `subdivide` 179,
/// `procedural_detail` 190.
pub const BYTES_PER_FACE: u64 = 200;

/// Faces of `levels` Catmull-Clark levels of `mesh`: each face corner becomes a quad at
/// the first level, each quad four at every further one.
pub fn faces_at(mesh: &Mesh, levels: u32) -> u64 {
    match levels {
        0 => mesh.face_count() as u64,
        _ => faces_from_corners(mesh.corners().len() as u64, levels),
    }
}

/// Faces of `levels >= 1` Catmull-Clark levels of a mesh with `corners` face corners
/// (what callers holding only face sizes can tell).
pub fn faces_from_corners(corners: u64, levels: u32) -> u64 {
    corners.saturating_mul(4u64.saturating_pow(levels.max(1) - 1))
}

/// Refuses `levels` of `mesh` where the refinement would hold more than `max_bytes`
/// ([`BYTES_PER_FACE`] per face of the finest level), with a message giving the count
/// and the most levels that fit.
pub fn check_fits(mesh: &Mesh, levels: u32, max_bytes: u64) -> Result<()> {
    check(mesh, levels, max_bytes, BYTES_PER_FACE, "")
}

/// Peak bytes multiresolution analysis ([`super::multires::analyze`]) holds per face of
/// its finest level: every level's mesh and fitting target (f64 positions) kept at once,
/// the finest step's stencil matrix `S` as triplets (16 bytes each, about 11 per fine
/// face) and its transpose while both are sorted into compressed rows, then the synthesis
/// of the details against them. Measured with a counting allocator
/// (`tests/analysis_memory.rs`): 640 to 760 per face from 25 k to 310 k faces.
pub const ANALYSIS_BYTES_PER_FACE: u64 = 900;

/// [`check_fits`] for the analysis of a mesh `levels` subdivisions finer than `mesh`, at
/// [`ANALYSIS_BYTES_PER_FACE`].
pub fn check_analysis_fits(mesh: &Mesh, levels: u32, max_bytes: u64) -> Result<()> {
    check(mesh, levels, max_bytes, ANALYSIS_BYTES_PER_FACE, "the analysis of ")
}

fn check(mesh: &Mesh, levels: u32, max_bytes: u64, per_face: u64, what: &str) -> Result<()> {
    let bytes = |l: u32| faces_at(mesh, l).saturating_mul(per_face);
    if bytes(levels) <= max_bytes {
        return Ok(());
    }
    let fits = (1..levels).rev().find(|&l| bytes(l) <= max_bytes).unwrap_or(0);
    Err(Error::OverLimit(format!(
        "{what}{levels} subdivision levels of {} faces would make {} faces and need about {:.1} GB, more than the {:.1} GB allowed; {}",
        mesh.face_count(),
        faces_at(mesh, levels),
        bytes(levels) as f64 / 1e9,
        max_bytes as f64 / 1e9,
        if fits > 0 { format!("{fits} levels fit") } else { "not even one level fits".to_string() }
    )))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::fixtures;
    use crate::subdivision::{subdivide, Boundary, Options};

    #[test]
    fn face_counts_are_the_subdivisions_own() {
        let cube = fixtures::cube();
        for levels in 1..=3 {
            let made = subdivide(&cube, &Options { levels, limit: false, boundary: Boundary::SmoothAll }).unwrap().mesh.face_count() as u64;
            assert_eq!(faces_at(&cube, levels), made, "level {levels}");
        }
    }

    #[test]
    fn a_level_over_the_limit_is_refused_with_what_fits() {
        let cube = fixtures::cube(); // 24 corners: 24, 96, 384 faces
        assert!(check_fits(&cube, 3, 384 * BYTES_PER_FACE).is_ok());
        let Err(Error::OverLimit(m)) = check_fits(&cube, 3, 383 * BYTES_PER_FACE) else { panic!("not refused") };
        assert!(m.contains("384 faces") && m.contains("2 levels fit"), "{m}");
        assert!(matches!(check_fits(&cube, 1, 10), Err(Error::OverLimit(m)) if m.contains("not even one level")));
    }
}
