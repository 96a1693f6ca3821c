//! Scalar fields over space, the one interface every implicit feature evaluates and
//! [`crate::polygonize`] meshes: a value per point, negative inside (`V(f) = {f <= 0}`,
//! as in Akleman and Chen's unit-gradient functions), its gradient and any attributes
//! it carries (a colour, a primitive id), all batched over point arrays so an
//! implementation can vectorize and callers parallelize over chunks.
//!
//! Implementors so far: the procedural texture patterns ([`crate::texture::procedural::PatternField`])
//! and the implicit field trees ([`crate::implicit::FieldTree`], which also bound their
//! values over boxes: [`ScalarField::interval`]).

use glam::Vec3;

/// A scalar field with its gradient and carried attributes, evaluated on batches of
/// points. `Sync`: polygonizers evaluate it from many threads at once.
pub trait ScalarField: Sync {
    /// `f` at each point (`out.len() == points.len()`); negative inside.
    fn values(&self, points: &[Vec3], out: &mut [f32]);

    /// `∇f` at each point. The default is central differences of [`Self::values`] with
    /// step [`Self::difference_step`]; fields that know their gradient analytically
    /// (unit-gradient trees, section 5 of Akleman and Chen) override it.
    fn gradients(&self, points: &[Vec3], out: &mut [Vec3]) {
        central_differences(self, points, self.difference_step(), out);
    }

    /// The step of the default [`Self::gradients`], in the field's units of length.
    fn difference_step(&self) -> f32 {
        1e-3
    }

    /// How many attribute values the field carries per point (0: none).
    fn attribute_count(&self) -> usize {
        0
    }

    /// The attributes at each point, [`Self::attribute_count`] values per point.
    fn attributes(&self, points: &[Vec3], out: &mut [f32]) {
        let _ = (points, out);
    }

    /// An enclosure `(lo, hi)` of `f` over the box `[lo, hi]`: every value the field
    /// gives at a point of the box (its faces included) lies in it, so it is never
    /// NaN there; and the field's values at a point do not depend on the batch it is
    /// asked in. `None` (the default): the field cannot bound itself. Polygonizers
    /// skip the boxes whose enclosure keeps one sign ([`crate::polygonize::mesh_field`]);
    /// a field answers for every box or for none.
    fn interval(&self, lo: Vec3, hi: Vec3) -> Option<(f32, f32)> {
        let _ = (lo, hi);
        None
    }

    /// A Lipschitz bound `L`: `|f(x) - f(y)| <= L |x - y|` everywhere, so a value
    /// `|f(x)| > L r` proves one sign over the ball of radius `r` around `x`. `None`
    /// (the default): the field cannot bound its slope. Polygonizers skip samples
    /// that such a proof decides ([`crate::polygonize::dual`]).
    fn lipschitz(&self) -> Option<f32> {
        None
    }

    /// `f` at one point.
    fn value(&self, p: Vec3) -> f32 {
        let mut out = [0.0];
        self.values(&[p], &mut out);
        out[0]
    }
}

/// `∇f` by central differences with step `h`, evaluated as one batch of six points
/// per point.
pub fn central_differences<F: ScalarField + ?Sized>(field: &F, points: &[Vec3], h: f32, out: &mut [Vec3]) {
    const AXES: [Vec3; 3] = [Vec3::X, Vec3::Y, Vec3::Z];
    let probes: Vec<Vec3> = points.iter().flat_map(|&p| AXES.iter().flat_map(move |&a| [p + a * h, p - a * h])).collect();
    let mut values = vec![0.0; probes.len()];
    field.values(&probes, &mut values);
    for (g, v) in out.iter_mut().zip(values.chunks_exact(6)) {
        *g = Vec3::new(v[0] - v[1], v[2] - v[3], v[4] - v[5]) / (2.0 * h);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Paraboloid;
    impl ScalarField for Paraboloid {
        fn values(&self, points: &[Vec3], out: &mut [f32]) {
            for (o, p) in out.iter_mut().zip(points) {
                *o = p.x * p.x + 2.0 * p.y * p.y - p.z;
            }
        }
    }

    #[test]
    fn the_default_gradient_is_central_differences_of_the_values() {
        let points = [Vec3::new(0.5, -0.25, 1.0), Vec3::new(-1.0, 2.0, 0.0)];
        let mut g = [Vec3::ZERO; 2];
        Paraboloid.gradients(&points, &mut g);
        for (p, g) in points.iter().zip(g) {
            let want = Vec3::new(2.0 * p.x, 4.0 * p.y, -1.0);
            assert!((g - want).length() < 1e-2, "{g} vs {want}");
        }
        assert_eq!(Paraboloid.value(Vec3::new(1.0, 1.0, 1.0)), 2.0);
        assert_eq!(Paraboloid.attribute_count(), 0);
        assert_eq!(Paraboloid.interval(Vec3::ZERO, Vec3::ONE), None);
    }
}
