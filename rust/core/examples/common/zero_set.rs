//! How far a mesh's vertices lie from a field's zero set, for the meshing benches
//! (`field_mesh_bench`, and `rust/peers` beside fidget).

use thicket_core::field::ScalarField;
use thicket_core::glam::Vec3;

/// The worst and mean `|f| / |grad f|` over `points`, in cells.
pub fn distance<F: ScalarField>(field: &F, points: &[Vec3], cell: f32) -> (f32, f32) {
    let mut values = vec![0.0; points.len()];
    let mut grads = vec![Vec3::ZERO; points.len()];
    field.values(points, &mut values);
    field.gradients(points, &mut grads);
    let d: Vec<f32> = values.iter().zip(&grads).map(|(v, g)| v.abs() / g.length().max(1e-6) / cell).collect();
    (d.iter().copied().fold(0.0, f32::max), d.iter().sum::<f32>() / d.len().max(1) as f32)
}
