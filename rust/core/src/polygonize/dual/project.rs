//! Vertices pulled onto the surface: where a vertex lies farther from the zero set than
//! [`FAR`] of a cell (measured as `|f| / |∇f|`, the field's own first-order distance),
//! Newton steps along the gradient move it there, kept inside its cell. The QEF's
//! minimizer can sit far off a thin or strongly curved piece (Ju et al. 2002 accept
//! this); the mass point of a curved piece sits inside its chord.

use super::lattice::Lattice;
use crate::field::ScalarField;
use glam::{UVec3, Vec3};

/// How far from the zero set, in cells, a vertex may stay. Not from a paper: a
/// tenth of a cell keeps sharp vertices (on the zero set already) where the QEF put them.
pub(super) const FAR: f32 = 0.1;

/// Newton steps at most.
const STEPS: usize = 4;

/// Moves each of `points` (in the cell at `cells`) that lies farther than [`FAR`] of a
/// cell from the zero set towards it by Newton steps; those still far after them are
/// replaced by `fallback` (when given) and moved again. Returns the evaluations made.
pub(super) fn project<F: ScalarField + ?Sized>(field: &F, lattice: &Lattice, points: &mut [Vec3], cells: &[UVec3], fallback: Option<&[Vec3]>) -> usize {
    let (far, evaluations) = newton(field, lattice, points, cells, (0..points.len()).collect());
    match fallback {
        Some(m) if !far.is_empty() => {
            for &v in &far {
                points[v] = m[v];
            }
            evaluations + newton(field, lattice, points, cells, far).1
        }
        _ => evaluations,
    }
}

/// Newton steps on `pending`; returns those still far and the evaluations made.
fn newton<F: ScalarField + ?Sized>(field: &F, lattice: &Lattice, points: &mut [Vec3], cells: &[UVec3], mut pending: Vec<usize>) -> (Vec<usize>, usize) {
    let far = FAR * lattice.step.min_element();
    let mut evaluations = 0;
    let mut batch: Vec<Vec3> = Vec::new();
    let mut values = Vec::new();
    let mut gradients = Vec::new();
    for step in 0..=STEPS {
        if pending.is_empty() {
            break;
        }
        batch.clear();
        batch.extend(pending.iter().map(|&v| points[v]));
        values.resize(batch.len(), 0.0);
        field.values(&batch, &mut values);
        evaluations += batch.len();
        let close = |f: f32, g: Vec3| !(f.is_finite() && g.is_finite() && g != Vec3::ZERO) || f.abs() <= far * g.length();
        // Gradients only where a value is far.
        let mut kept = 0;
        for k in 0..pending.len() {
            if lattice.cut(values[k], batch[k]).abs() > far * 0.5 {
                (pending[kept], batch[kept], values[kept]) = (pending[k], batch[k], values[k]);
                kept += 1;
            }
        }
        pending.truncate(kept);
        batch.truncate(kept);
        gradients.resize(batch.len(), Vec3::ZERO);
        field.gradients(&batch, &mut gradients);
        evaluations += batch.len();
        let mut kept = 0;
        for k in 0..pending.len() {
            let v = pending[k];
            let (f, g) = (lattice.cut(values[k], batch[k]), gradients[k]);
            if close(f, g) {
                continue;
            }
            if step < STEPS {
                let (lo, hi) = (lattice.point(cells[v]), lattice.point(cells[v] + 1));
                points[v] = (points[v] - g * (f / g.length_squared())).clamp(lo, hi);
            }
            pending[kept] = v;
            kept += 1;
        }
        pending.truncate(kept);
    }
    (pending, evaluations)
}
