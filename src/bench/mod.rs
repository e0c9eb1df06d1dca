//! Benchmarks that live in the core (the exit-face micro-benchmark), and the one deterministic
//! random generator the benches and tests share.

pub mod exitface;

pub use exitface::{cases, exitface, time_method, Case};

/// Deterministic xorshift (the bench's cases and the tests need no rand crate).
pub(crate) struct Rng(pub u64);
impl Rng {
    pub fn f(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Three uniforms in [0, 1) (the tests' points).
    #[cfg(test)]
    pub fn p3(&mut self) -> [f64; 3] {
        [self.f(), self.f(), self.f()]
    }
}
