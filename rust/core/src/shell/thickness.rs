//! Per-vertex target thickness: an absolute length or a fraction of the bounding-box
//! diagonal, times an optional per-vertex factor (a Blender vertex group).

use crate::{Error, Mesh, Result};
use glam::Vec3;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ThicknessMode {
    /// `value` is a length in object space.
    Absolute,
    /// `value` is a fraction of the mesh's bounding-box diagonal.
    Relative,
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Thickness {
    pub value: f32,
    pub mode: ThicknessMode,
}

/// Thickness beyond this many bounding-box diagonals is refused as a typo, not a shell.
pub const MAX_THICKNESS_IN_DIAGONALS: f32 = 100.0;

impl Thickness {
    pub fn absolute(value: f32) -> Self {
        Self { value, mode: ThicknessMode::Absolute }
    }
    pub fn relative(value: f32) -> Self {
        Self { value, mode: ThicknessMode::Relative }
    }

    /// Resolves to one signed thickness per vertex. `factors`, when given, has one
    /// finite value per vertex (vertex-group weights; 0 gives no thickness there).
    ///
    /// Errors: zero or non-finite thickness, a thickness larger than
    /// [`MAX_THICKNESS_IN_DIAGONALS`] diagonals, a mesh whose vertices all coincide,
    /// factor arrays of the wrong length or with non-finite entries.
    pub fn per_vertex(&self, mesh: &Mesh, factors: Option<&[f32]>) -> Result<Vec<f32>> {
        self.per_vertex_at(mesh, mesh.positions(), factors)
    }

    /// [`per_vertex`](Self::per_vertex) were `mesh`'s vertices at `positions` (a
    /// shell following an edit sizes itself on the edited mesh).
    pub fn per_vertex_at(&self, mesh: &Mesh, positions: &[Vec3], factors: Option<&[f32]>) -> Result<Vec<f32>> {
        mesh.require_faces()?;
        let diag = mesh.bbox_diagonal_at(positions);
        if diag <= 0.0 || !diag.is_finite() {
            return Err(Error::InvalidMesh("all vertices coincide: the mesh has no size".into()));
        }
        if !self.value.is_finite() || self.value == 0.0 {
            return Err(Error::InvalidParameter(format!("thickness must be a non-zero number, got {}", self.value)));
        }
        let length = match self.mode {
            ThicknessMode::Absolute => self.value,
            ThicknessMode::Relative => self.value * diag,
        };
        if length.abs() > MAX_THICKNESS_IN_DIAGONALS * diag {
            return Err(Error::InvalidParameter(format!(
                "thickness {length} is more than {MAX_THICKNESS_IN_DIAGONALS} times the object's size ({diag}); \
                 use a smaller value or relative thickness"
            )));
        }
        match factors {
            None => Ok(vec![length; mesh.vertex_count()]),
            Some(f) if f.len() != mesh.vertex_count() => {
                Err(Error::InvalidParameter(format!("{} thickness factors given for {} vertices", f.len(), mesh.vertex_count())))
            }
            Some(f) => match f.iter().position(|w| !w.is_finite()) {
                Some(i) => Err(Error::InvalidParameter(format!("thickness factor of vertex {i} is not finite"))),
                None => Ok(f.iter().map(|w| w * length).collect()),
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::fixtures::cube;

    #[test]
    fn relative_scales_with_diagonal_and_factors() {
        let m = cube();
        let t = Thickness::relative(0.1).per_vertex(&m, None).unwrap();
        assert!((t[0] - 0.1 * 3f32.sqrt()).abs() < 1e-6);
        let f: Vec<f32> = (0..8).map(|i| i as f32 / 7.0).collect();
        let t = Thickness::absolute(2.0).per_vertex(&m, Some(&f)).unwrap();
        assert_eq!(t[0], 0.0);
        assert_eq!(t[7], 2.0);
    }

    #[test]
    fn absurd_values_are_refused_with_reasons() {
        let m = cube();
        for bad in [0.0, f32::NAN, f32::INFINITY, 1e6] {
            let e = Thickness::absolute(bad).per_vertex(&m, None).unwrap_err();
            assert!(matches!(e, Error::InvalidParameter(_)), "{bad}: {e}");
        }
        assert!(Thickness::absolute(-0.1).per_vertex(&m, None).is_ok(), "negative means inward");
        assert!(Thickness::absolute(0.1).per_vertex(&m, Some(&[1.0; 3])).is_err());
        assert_eq!(Thickness::absolute(0.1).per_vertex(&Mesh::default(), None).unwrap_err(), Error::EmptyMesh);
    }
}
