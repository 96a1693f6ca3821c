//! One seeded random sequence for tests (xorshift64: deterministic, no dependency),
//! so that each test names only its seed.

use glam::DVec3;

/// A seeded xorshift64 sequence; the seed must not be zero.
pub struct Rng(pub u64);

impl Rng {
    /// The next number in `[0, 1)`.
    pub fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
    /// A number in `[lo, hi)`.
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.uniform()
    }
    /// A point of the cube `[-half, half)³`.
    pub fn vec(&mut self, half: f64) -> DVec3 {
        DVec3::new(self.range(-half, half), self.range(-half, half), self.range(-half, half))
    }
    /// A unit vector (directions not uniformly spread: rejection from a shell of the cube).
    pub fn unit(&mut self) -> DVec3 {
        loop {
            let v = self.vec(1.0);
            if v.length() > 0.2 && v.length() <= 1.0 {
                return v.normalize();
            }
        }
    }
    /// An index below `n` (`n > 0`).
    pub fn pick(&mut self, n: usize) -> usize {
        ((self.uniform() * n as f64) as usize).min(n - 1)
    }
}
