//! The crate's one deterministic random generator (no rand crate): the benches' cases, the
//! tests' scenes and rays, and the fuzzer's cases.
//!
//! It keeps two streams, each bit for bit as before they shared this type, because seeds
//! written in tests, benches and fuzz reports name them: [`Rng::new`] is xorshift64* seeded
//! through splitmix64 (the fuzzer's: any seed, 0 included, gives a good stream, and a failing
//! case's seed reproduces it), [`Rng::xorshift`] is Marsaglia's xorshift64 (13, 7, 17) started
//! from the seed itself (the exit-face bench's and the tests' seeds).

/// A deterministic generator; see the module's text for its two streams.
pub struct Rng {
    state: u64,
    /// xorshift64* (true, [`Rng::new`]) or plain xorshift64 (false, [`Rng::xorshift`]).
    star: bool,
}

impl Rng {
    /// xorshift64* seeded through splitmix64 ([`mix`]): any seed gives a good stream.
    pub fn new(seed: u64) -> Rng {
        Rng {
            state: mix(seed) | 1,
            star: true,
        }
    }

    /// Marsaglia's xorshift64 (13, 7, 17) from the state `seed` (which must not be 0).
    pub fn xorshift(seed: u64) -> Rng {
        Rng {
            state: seed,
            star: false,
        }
    }

    pub fn u64(&mut self) -> u64 {
        if self.star {
            self.state ^= self.state >> 12;
            self.state ^= self.state << 25;
            self.state ^= self.state >> 27;
            self.state.wrapping_mul(0x2545_f491_4f6c_dd1d)
        } else {
            self.state ^= self.state << 13;
            self.state ^= self.state >> 7;
            self.state ^= self.state << 17;
            self.state
        }
    }

    /// Uniform in [0, n) (0 when n is 0).
    pub fn below(&mut self, n: usize) -> usize {
        if n == 0 {
            0
        } else {
            (self.u64() % n as u64) as usize
        }
    }

    /// Uniform in [0, 1), 53 bits.
    pub fn f(&mut self) -> f64 {
        (self.u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    pub fn chance(&mut self, p: f64) -> bool {
        self.f() < p
    }

    pub fn pick<T: Copy>(&mut self, xs: &[T]) -> T {
        xs[self.below(xs.len())]
    }

    /// Three uniforms in [0, 1) (the tests' points).
    #[cfg(test)]
    pub fn p3(&mut self) -> [f64; 3] {
        [self.f(), self.f(), self.f()]
    }
}

/// splitmix64 (the fuzzer's case seeds are built from it too).
pub fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The two streams are the ones the seeds in tests, benches and fuzz reports were chosen
    /// on (first outputs of the two generators as they were before they shared this type).
    #[test]
    fn streams_are_unchanged() {
        let mut s = Rng::new(1);
        let mut z = mix(1) | 1;
        let mut x = Rng::xorshift(7);
        let mut y = 7u64;
        for _ in 0..100 {
            z ^= z >> 12;
            z ^= z << 25;
            z ^= z >> 27;
            assert_eq!(s.u64(), z.wrapping_mul(0x2545_f491_4f6c_dd1d));
            y ^= y << 13;
            y ^= y >> 7;
            y ^= y << 17;
            assert_eq!(x.f(), (y >> 11) as f64 / (1u64 << 53) as f64);
        }
    }
}
