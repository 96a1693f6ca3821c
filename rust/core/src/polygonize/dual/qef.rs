//! The vertex of one piece: the point nearest, in the least-squares sense, to the
//! tangent planes at its edges' crossings (the quadratic error function of Ju, Losasso,
//! Schaefer and Warren 2002, *Dual Contouring of Hermite Data*, section 2.3), solved
//! about the crossings' mass point with small singular values truncated so flat and
//! creased pieces stay put along their free directions.

use glam::{DMat3, DVec3, Vec3};

/// Singular values below this share of the largest are dropped. Not from a paper's
/// number (Ju et al. truncate at 0.1 for unit normals): relative, so the cut does not
/// depend on how many crossings a piece has.
const TRUNCATE: f64 = 0.1;

/// Sums of the planes of one piece: `AᵀA` (symmetric, its six entries), `Aᵀb` with the
/// planes' offsets `b_i = n_i · p_i`, and the crossings' sum and count. This departs
/// from Ju et al. (section 2.3 keeps a QR form, since the normal equations `AᵀA` lose
/// half the digits): here they are summed in double precision and solved about the
/// mass point `c` (right side `Aᵀb - AᵀA c`) with small singular values truncated,
/// which for points of a few units and a dozen planes stays far below a float's
/// rounding. Kept as sums rather than the planes themselves: no array of planes to
/// clear per cell.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Qef {
    /// `xx, xy, xz, yy, yz, zz`.
    ata: [f64; 6],
    atb: DVec3,
    mass: DVec3,
    n: u32,
}

impl Qef {
    pub fn add(&mut self, p: Vec3, normal: Vec3) {
        let (p, n) = (p.as_dvec3(), normal.as_dvec3());
        self.ata[0] += n.x * n.x;
        self.ata[1] += n.x * n.y;
        self.ata[2] += n.x * n.z;
        self.ata[3] += n.y * n.y;
        self.ata[4] += n.y * n.z;
        self.ata[5] += n.z * n.z;
        self.atb += n * n.dot(p);
        self.mass += p;
        self.n += 1;
    }

    /// The mass point of the crossings.
    pub fn mass_point(&self) -> Vec3 {
        (self.mass / f64::from(self.n.max(1))).as_vec3()
    }

    /// The minimizer, clamped to the cell `[lo, hi]`.
    pub fn solve(&self, lo: Vec3, hi: Vec3) -> Vec3 {
        let c = self.mass / f64::from(self.n.max(1));
        let [xx, xy, xz, yy, yz, zz] = self.ata;
        let a = DMat3::from_cols(DVec3::new(xx, xy, xz), DVec3::new(xy, yy, yz), DVec3::new(xz, yz, zz));
        let b = self.atb - a * c;
        let (values, vectors) = eigen(a);
        let top = values.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let mut y = DVec3::ZERO;
        for (k, value) in values.iter().enumerate() {
            if top > 0.0 && value.abs() > TRUNCATE * top {
                let v = vectors.col(k);
                y += v * (v.dot(b) / value);
            }
        }
        (c + y).as_vec3().clamp(lo, hi)
    }
}

/// Eigenvalues and eigenvectors (columns) of a symmetric matrix by cyclic Jacobi
/// rotations.
fn eigen(m: DMat3) -> ([f64; 3], DMat3) {
    let mut a = m.to_cols_array_2d();
    let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for _ in 0..12 {
        let off = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
        if off < 1e-24 * (a[0][0] * a[0][0] + a[1][1] * a[1][1] + a[2][2] * a[2][2]).max(1e-300) {
            break;
        }
        for (p, q) in [(0, 1), (0, 2), (1, 2)] {
            if a[p][q].abs() < 1e-300 {
                continue;
            }
            let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
            let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
            let t = if theta == 0.0 { 1.0 } else { t };
            let c = 1.0 / (t * t + 1.0).sqrt();
            let s = t * c;
            // a <- Jᵀ a J with the rotation in the (p, q) plane.
            for row in &mut a {
                let (akp, akq) = (row[p], row[q]);
                row[p] = c * akp - s * akq;
                row[q] = s * akp + c * akq;
            }
            let (rp, rq) = (a[p], a[q]);
            for k in 0..3 {
                a[p][k] = c * rp[k] - s * rq[k];
                a[q][k] = s * rp[k] + c * rq[k];
            }
            for row in &mut v {
                let (vp, vq) = (row[p], row[q]);
                row[p] = c * vp - s * vq;
                row[q] = s * vp + c * vq;
            }
        }
    }
    // `v` holds rows of the rotation: column k of the product is eigenvector k.
    let vectors = DMat3::from_cols(DVec3::new(v[0][0], v[1][0], v[2][0]), DVec3::new(v[0][1], v[1][1], v[2][1]), DVec3::new(v[0][2], v[1][2], v[2][2]));
    ([a[0][0], a[1][1], a[2][2]], vectors)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn three_planes_meet_at_their_corner_and_one_plane_keeps_the_mass_point() {
        let mut q = Qef::default();
        let corner = Vec3::new(0.3, 0.6, 0.2);
        for (p, n) in [(Vec3::new(0.3, 0.1, 0.9), Vec3::X), (Vec3::new(0.9, 0.6, 0.1), Vec3::Y), (Vec3::new(0.1, 0.8, 0.2), Vec3::Z)] {
            q.add(p, n);
        }
        let x = q.solve(Vec3::ZERO, Vec3::ONE);
        assert!((x - corner).length() < 1e-5, "{x}");
        let mut flat = Qef::default();
        flat.add(Vec3::new(0.2, 0.5, 0.5), Vec3::X);
        flat.add(Vec3::new(0.2, 0.1, 0.3), Vec3::X);
        let x = flat.solve(Vec3::ZERO, Vec3::ONE);
        assert!((x - Vec3::new(0.2, 0.3, 0.4)).length() < 1e-6, "{x}");
        // A rotated, non-diagonal system.
        let n = [Vec3::new(1.0, 1.0, 0.0).normalize(), Vec3::new(-1.0, 1.0, 0.2).normalize(), Vec3::new(0.1, -0.3, 1.0).normalize()];
        let mut q = Qef::default();
        for (k, n) in n.iter().enumerate() {
            q.add(corner + n.any_orthogonal_vector() * 0.1 * (k as f32 + 1.0), *n);
        }
        let x = q.solve(Vec3::ZERO, Vec3::ONE);
        assert!((x - corner).length() < 1e-4, "{x}");
    }
}
