//! Local thickness reduction where the traced shell is still tangled: the field
//! trajectories never cross, but their straight chords (chapter 3.1) can, in sharp
//! concave corners and where trajectories converge. Vertices of inverted cells and of
//! intersecting outer-layer triangles get their directors shortened (towards the base
//! point, so thickness is reduced only locally), a bounded number of rounds.

use super::report::analyze;
use super::Shell;
use crate::Mesh;

/// Shrinks directors around defects by `factor` per round, for at most `rounds`
/// rounds; returns the number of rounds that changed something.
pub fn untangle(mesh: &Mesh, shell: &mut Shell, rounds: u32, factor: f32) -> u32 {
    let mut changed = 0;
    for _ in 0..rounds {
        let f = analyze(mesh, shell);
        let mut bad = vec![false; mesh.vertex_count()];
        for &(i, j) in &f.self_pairs {
            f.tris[i as usize].iter().chain(&f.tris[j as usize]).for_each(|v| bad[*v as usize] = true);
        }
        for &(i, _) in &f.base_pairs {
            f.tris[i as usize].iter().for_each(|v| bad[*v as usize] = true);
        }
        for (c, inv) in f.cells.iter().zip(&f.inverted) {
            if *inv {
                c.base().iter().for_each(|v| bad[*v as usize] = true);
            }
        }
        if !bad.iter().any(|b| *b) {
            break;
        }
        changed += 1;
        for (v, b) in bad.iter().enumerate() {
            if *b {
                shell.base_offset[v] *= factor;
                shell.directors[v] *= factor;
                shell.achieved[v] = shell.directors[v].length();
            }
        }
    }
    changed
}
