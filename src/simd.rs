//! The instruction-set level of the kernels that have a vector version, chosen at run time.
//!
//! The wheel is built for baseline x86-64, so it runs on any x86-64 CPU. A kernel with an AVX2
//! version (`traverse::packet`'s per-ray exits) takes it when the CPU has AVX2.
//! `TETRACE_SIMD=scalar` caps the level, so tests can compare every level on one machine.
//!
//! Answers are the same at every level, bit for bit. The vector kernels round the same
//! operations in the same order as the scalar code: products, then sums, left to right, and no
//! fused multiply-add (Rust never contracts `a * b + c`).
//!
//! On aarch64, NEON is part of the baseline and LLVM uses it for the scalar code, so `scalar`
//! is the only level there.

use crate::error::{Error, Result};

/// A kernel level, lowest first.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Simd {
    /// Portable code: baseline x86-64 (SSE2) or aarch64 (NEON).
    #[default]
    Scalar,
    /// AVX2 kernels, on x86-64 CPUs that have AVX2 and FMA.
    Avx2,
}

/// The environment variable that caps the level: `scalar` or `avx2`.
pub const ENV: &str = "TETRACE_SIMD";

impl Simd {
    /// Every level, lowest first.
    pub const ALL: [Simd; 2] = [Simd::Scalar, Simd::Avx2];

    /// The level's name, as [`ENV`] takes it.
    pub fn name(self) -> &'static str {
        match self {
            Simd::Scalar => "scalar",
            Simd::Avx2 => "avx2",
        }
    }

    /// The level named `name`.
    pub fn parse(name: &str) -> Result<Simd> {
        Simd::ALL
            .into_iter()
            .find(|s| s.name().eq_ignore_ascii_case(name.trim()))
            .ok_or_else(|| {
                Error::InvalidOption(format!(
                    "{ENV}={name:?} names no SIMD level; expected one of: scalar, avx2"
                ))
            })
    }

    /// Whether this CPU runs the level's kernels.
    pub fn supported(self) -> bool {
        match self {
            Simd::Scalar => true,
            #[cfg(target_arch = "x86_64")]
            // The BVH's box test fuses its multiply-adds (`accel::exact_bvh`).
            Simd::Avx2 => {
                std::arch::is_x86_feature_detected!("avx2")
                    && std::arch::is_x86_feature_detected!("fma")
            }
            #[cfg(not(target_arch = "x86_64"))]
            Simd::Avx2 => false,
        }
    }

    /// The highest level this CPU runs.
    pub fn detected() -> Simd {
        Simd::ALL
            .into_iter()
            .rev()
            .find(|s| s.supported())
            .unwrap_or(Simd::Scalar)
    }

    /// The levels this CPU runs, lowest first (what tests compare).
    pub fn supported_levels() -> Vec<Simd> {
        Simd::ALL.into_iter().filter(|s| s.supported()).collect()
    }

    /// [`Simd::detected`], capped by [`ENV`] where it is set (a cap above what the CPU runs
    /// changes nothing); an unknown name is an error, not silently ignored.
    pub fn from_env() -> Result<Simd> {
        let best = Simd::detected();
        match std::env::var(ENV) {
            Ok(name) if !name.trim().is_empty() => Ok(Simd::parse(&name)?.min(best)),
            _ => Ok(best),
        }
    }

    /// `level` when this CPU runs it; an error naming the level when not.
    pub fn checked(level: Simd) -> Result<Simd> {
        if level.supported() {
            Ok(level)
        } else {
            Err(Error::InvalidOption(format!(
                "this CPU cannot run SIMD level {:?}",
                level.name()
            )))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Simd;

    #[test]
    fn names_parse_back_and_unknown_names_are_refused() {
        for s in Simd::ALL {
            assert_eq!(Simd::parse(s.name()).unwrap(), s);
            assert_eq!(Simd::parse(&s.name().to_uppercase()).unwrap(), s);
        }
        let err = Simd::parse("avx9").unwrap_err().to_string();
        assert!(
            err.contains("TETRACE_SIMD") && err.contains("avx9"),
            "{err}"
        );
        assert!(Simd::Scalar.supported());
        assert_eq!(Simd::supported_levels()[0], Simd::Scalar);
        assert!(Simd::detected().supported());
    }
}
