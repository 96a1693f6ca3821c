//! The L_p-averaged distance to a surface and its gradient field (chapter 4.2):
//!
//! `d_p(x, M) = A^{1/p} (∫_M |x-y|^-p dy)^{-1/p}` (equation 4.3) and
//! `g_p = ∇d_p = (1/A) d_p^{p+1} ∫_M (x-y)|x-y|^{-p-2} dy` (equation 4.4).
//!
//! - [`exact`]: the closed-form triangle integral for p = 3 (Appendix A).
//! - [`quadrature`]: adaptive Gauss rules for any p (and the test reference).
//! - [`tree`]: the Barnes–Hut patch tree with localization (4.3.1, 4.4.2).
//! - [`boundary`]: artificial faces along open boundaries (4.3.2).

pub mod boundary;
pub mod exact;
pub mod quadrature;
pub mod tree;

pub use boundary::extension_faces;
pub use exact::{triangle_p3, TriangleIntegral};
pub use quadrature::Quadrature;
pub use tree::{FieldEval, Kernel, PatchTree};

use crate::Mesh;
use glam::{DVec3, Vec3};

/// The triangles of `mesh` (its triangulation view) as f64 corner positions.
pub fn mesh_triangles(mesh: &Mesh) -> Vec<[DVec3; 3]> {
    let p = mesh.positions();
    mesh.triangulate().triangles.iter().map(|t| t.map(|i| p[i as usize].as_dvec3())).collect()
}

/// The averaged distance function of a whole mesh (no localization), for inspection
/// and tests; shells use the localized evaluation of [`PatchTree::eval`].
pub struct AveragedDistance {
    tree: PatchTree,
    kernel: Kernel,
}

impl AveragedDistance {
    /// `theta` is the Barnes–Hut opening criterion (0 evaluates every face exactly).
    pub fn new(mesh: &Mesh, p: f64, theta: f64) -> Self {
        Self { tree: PatchTree::build(&mesh_triangles(mesh)), kernel: Kernel::new(p, theta) }
    }
    fn sample(&self, x: Vec3) -> FieldEval {
        self.tree.eval(x.as_dvec3(), f64::INFINITY, DVec3::ZERO, &self.kernel)
    }
    /// `d_p(x, M)`, equation 4.3.
    pub fn distance(&self, x: Vec3) -> f64 {
        let p = self.kernel.p;
        self.tree.total_area().powf(1.0 / p) * self.sample(x).value.powf(-1.0 / p)
    }
    /// `g_p(x, M)`, equation 4.4 (`push / p` is `∫ (x-y)|x-y|^{-p-2}`).
    pub fn gradient(&self, x: Vec3) -> DVec3 {
        let p = self.kernel.p;
        let e = self.sample(x);
        let a = self.tree.total_area();
        let d = a.powf(1.0 / p) * e.value.powf(-1.0 / p);
        e.push / p * (d.powf(p + 1.0) / a)
    }
}
