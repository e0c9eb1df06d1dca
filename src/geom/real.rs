//! The scalar the walk runs in. f32 and f64 share every line of the traversal through this
//! trait; it holds only what the walk needs, so no numeric crate is pulled in for it.

use std::fmt::Debug;
use std::ops::{Add, Div, Mul, Neg, Sub};

pub trait Real:
    Copy
    + Send
    + Sync
    + Debug
    + PartialOrd
    + Default
    + bytemuck::Zeroable
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + 'static
{
    const ZERO: Self;
    /// Unit roundoff (half the machine epsilon): the relative error of one rounding.
    const UNIT_ROUNDOFF: Self;
    /// The smallest positive normal number: below it products lose relative precision.
    const MIN_NORMAL: Self;
    const NAME: &'static str;
    fn from_f64(x: f64) -> Self;
    fn to_f64(self) -> f64;
    /// Of a point array kept in both precisions, the one in this precision.
    fn pick<'a>(f32s: &'a [[f32; 3]], f64s: &'a [[f64; 3]]) -> &'a [[Self; 3]];
}

impl Real for f32 {
    const ZERO: Self = 0.0;
    const UNIT_ROUNDOFF: Self = f32::EPSILON / 2.0;
    const MIN_NORMAL: Self = f32::MIN_POSITIVE;
    const NAME: &'static str = "f32";
    #[inline(always)]
    fn from_f64(x: f64) -> Self {
        x as f32
    }
    #[inline(always)]
    fn to_f64(self) -> f64 {
        self as f64
    }
    fn pick<'a>(f32s: &'a [[f32; 3]], _: &'a [[f64; 3]]) -> &'a [[f32; 3]] {
        f32s
    }
}

impl Real for f64 {
    const ZERO: Self = 0.0;
    const UNIT_ROUNDOFF: Self = f64::EPSILON / 2.0;
    const MIN_NORMAL: Self = f64::MIN_POSITIVE;
    const NAME: &'static str = "f64";
    #[inline(always)]
    fn from_f64(x: f64) -> Self {
        x
    }
    #[inline(always)]
    fn to_f64(self) -> f64 {
        self
    }
    fn pick<'a>(_: &'a [[f32; 3]], f64s: &'a [[f64; 3]]) -> &'a [[f64; 3]] {
        f64s
    }
}

pub type V3<R> = [R; 3];

#[inline(always)]
pub fn abs<R: Real>(x: R) -> R {
    if x < R::ZERO {
        -x
    } else {
        x
    }
}

#[inline(always)]
pub fn sub3<R: Real>(a: V3<R>, b: V3<R>) -> V3<R> {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

#[inline(always)]
pub fn dot3<R: Real>(a: V3<R>, b: V3<R>) -> R {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// The binary exponent of a positive finite x (x in [2^e, 2^(e+1))).
pub fn exponent(x: f64) -> i32 {
    if x < f64::MIN_POSITIVE {
        return exponent(x * 2f64.powi(64)) - 64;
    }
    ((x.to_bits() >> 52) & 0x7ff) as i32 - 1023
}

/// x · 2^e, exactly (in two steps when 2^e itself is not a normal number), for |e| ≤ 2046
/// (two normal factors; beyond, each is clamped to 2^±1023, right only for x = 0).
#[inline]
pub fn times_pow2(x: f64, e: i32) -> f64 {
    // 2^k for k in the normal range, built from its bits (powi may be a library call).
    let pow2 = |k: i32| f64::from_bits(((k.clamp(-1022, 1023) + 1023) as u64) << 52);
    if (-1022..=1023).contains(&e) {
        // 2^e is a normal number: one product, rounded once. Wherever x · 2^e is a float
        // (no underflow) both ways give it exactly; where it underflows, this one rounds it
        // once (the two steps could round twice). Every walk scales by this one function,
        // and most scalings land here: the two steps cost a scaled t two products and two
        // clamps per triangle tested.
        return x * pow2(e);
    }
    let h = e / 2;
    x * pow2(h) * pow2(e - h)
}

/// `d` scaled by a power of two (exactly, so its direction is unchanged) to a largest
/// component in [1, 2): methods that normalize need neither fear underflow nor overflow.
pub fn unit_scale(d: V3<f64>) -> V3<f64> {
    unit_direction(d).0
}

/// [`unit_scale`] with its exponent: d · 2^-e with its largest component in [1, 2), and e (0
/// for a zero or non-finite d, returned as it is). `geom::exact::plane_t` scales d so, and a
/// caller that keeps e (`query::gather::Line`) need not scale d again per triangle.
#[inline(always)]
pub fn unit_direction(d: V3<f64>) -> (V3<f64>, i32) {
    let m = d.iter().fold(0f64, |m, x| m.max(x.abs()));
    if m == 0.0 || !m.is_finite() {
        return (d, 0);
    }
    let e = exponent(m);
    (d.map(|x| times_pow2(x, -e)), e)
}

/// Whether [`unit_scale`] is exact on `d` (multiplying back gives d). Not where d's components
/// span more than float64's exponent range (f64::MAX beside 0.1): the small ones would become
/// subnormal and lose bits, so the walk would follow another line. Such directions are INVALID
/// ([`crate::geom::ray::checked_range`]).
#[inline(always)]
pub fn unit_scale_is_exact(d: V3<f64>) -> bool {
    let m = d.iter().fold(0f64, |m, x| m.max(x.abs()));
    if m == 0.0 || !m.is_finite() {
        return true;
    }
    // Nearly every direction: components zero or within 2^±500. Scaling by 2^-e, e the
    // largest's exponent (|e| ≤ 500), in two steps of at most 2^250 each, keeps every
    // intermediate and result a normal number (≥ 2^-1001): exact, without trying it.
    const LO: f64 = f64::from_bits((1023 - 500) << 52);
    const HI: f64 = f64::from_bits((1023 + 500) << 52);
    if m <= HI && d.iter().all(|&x| x == 0.0 || x.abs() >= LO) {
        return true;
    }
    scales_back(d, m)
}

/// Whether [`unit_scale`] of `d` (largest magnitude `m`, finite and nonzero) multiplied back
/// gives `d` (out of line: nearly no direction comes here).
#[cold]
fn scales_back(d: V3<f64>, m: f64) -> bool {
    let e = exponent(m);
    unit_scale(d)
        .iter()
        .zip(d)
        .all(|(&s, x)| times_pow2(s, e) == x)
}

/// min(a, b) for numbers that are not NaN, in one instruction (`f64::min` also orders NaN,
/// which costs more; packets and BVH slabs hold none).
#[inline(always)]
pub fn lesser(a: f64, b: f64) -> f64 {
    if b < a {
        b
    } else {
        a
    }
}

/// max(a, b) for numbers that are not NaN (see [`lesser`]).
#[inline(always)]
pub fn greater(a: f64, b: f64) -> f64 {
    if b > a {
        b
    } else {
        a
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    /// The shortcut of [`unit_scale_is_exact`] answers as multiplying back does, on
    /// directions whose components' exponents range over all of float64's (subnormals,
    /// zeros and the shortcut's edges 2^±500 included).
    #[test]
    fn unit_scale_shortcut_is_the_check() {
        let mut rng = Rng::new(17);
        let (mut fast, mut slow) = (0, 0);
        for _ in 0..200_000 {
            let d: V3<f64> = [0, 1, 2].map(|_| {
                let e = match rng.below(4) {
                    0 => 500 - rng.below(3) as i32 + rng.below(3) as i32,
                    1 => -500 - rng.below(3) as i32 + rng.below(3) as i32,
                    _ => rng.below(2098) as i32 - 1075,
                };
                let x = times_pow2(1.0 + rng.f(), e);
                match rng.below(6) {
                    0 => 0.0,
                    1 => -x,
                    _ => x,
                }
            });
            let m = d.iter().fold(0f64, |m, x| m.max(x.abs()));
            if m == 0.0 || !m.is_finite() {
                continue;
            }
            let want = scales_back(d, m);
            assert_eq!(unit_scale_is_exact(d), want, "{d:?}");
            if want {
                fast += 1;
            } else {
                slow += 1;
            }
        }
        assert!(fast > 10_000 && slow > 10_000, "{fast} exact, {slow} not");
    }

    /// `unit_direction` scales a finite nonzero d by 2^-e to a largest component in [1, 2)
    /// (multiplying back gives that component again), and returns a zero or non-finite d as
    /// it is with e = 0, as its docs say: zeros of either sign, infinities, NaN beside zeros
    /// and beside finite components.
    #[test]
    fn unit_direction_scales_finite_directions_and_leaves_the_rest() {
        let mut rng = Rng::new(0x0d1e);
        for _ in 0..20_000 {
            let d: V3<f64> = [0, 1, 2].map(|_| {
                let x = times_pow2(1.0 + rng.f(), rng.below(2098) as i32 - 1075);
                [0.0, -x, x][rng.below(3)]
            });
            let (s, e) = unit_direction(d);
            let k = (0..3)
                .max_by(|&i, &j| d[i].abs().total_cmp(&d[j].abs()))
                .unwrap();
            if d[k] == 0.0 {
                assert_eq!((s.map(f64::to_bits), e), (d.map(f64::to_bits), 0), "{d:?}");
                continue;
            }
            assert!((1.0..2.0).contains(&s[k].abs()), "{d:?}: {s:?}");
            assert_eq!(times_pow2(s[k], e), d[k], "{d:?}: {s:?} · 2^{e}");
        }
        let (inf, nan) = (f64::INFINITY, f64::NAN);
        for d in [
            [0.0, -0.0, 0.0],
            [inf, 1.0, 0.0],
            [0.5, -inf, 3.0],
            [nan, 0.0, 0.0],
            [nan, nan, nan],
            [nan, inf, 1.0],
        ] {
            let (s, e) = unit_direction(d);
            assert_eq!((s.map(f64::to_bits), e), (d.map(f64::to_bits), 0), "{d:?}");
        }
    }

    /// `exponent` of 2^k, of 1.5 · 2^k and of the float just below 2^(k+1) is k, for every k
    /// float64 has (the subnormals' too, whose exponent field reads 0): built from bits.
    #[test]
    fn exponent_is_that_of_every_binade() {
        for k in -1074..=1023 {
            // 2^k, 1.5 · 2^k (2^k itself for the least subnormal) and next_down(2^(k+1)).
            let (low, mid, high) = if k >= -1022 {
                let b = ((k + 1023) as u64) << 52;
                (b, b | 1 << 51, b | ((1 << 52) - 1))
            } else {
                let b = 1u64 << (k + 1074);
                (b, b | b >> 1, 2 * b - 1)
            };
            for bits in [low, mid, high] {
                let x = f64::from_bits(bits);
                assert_eq!(exponent(x), k, "{x:e} ({bits:#x})");
            }
        }
    }

    /// x · 2^e rounded to nearest (ties to even), from x's integer significand and exponent,
    /// and whether it is exact (`None`: beyond float64's range).
    fn scaled_exactly(x: f64, e: i32) -> Option<(f64, bool)> {
        let bits = x.to_bits();
        let (biased, frac) = (((bits >> 52) & 0x7ff) as i32, bits & ((1 << 52) - 1));
        // x = m · 2^q exactly.
        let (m, q) = if biased == 0 {
            (frac, -1074)
        } else {
            (frac | 1 << 52, biased - 1075)
        };
        let sign = if x < 0.0 { -1.0 } else { 1.0 };
        if m == 0 {
            return Some((sign * 0.0, true));
        }
        let q = q + e;
        let lead = 63 - m.leading_zeros() as i32;
        if lead + q > 1023 {
            return None;
        }
        if q >= -1074 {
            // At most 53 significant bits on float64's grid: a float, built from its bits.
            let top = lead + q;
            let exact = if top >= -1022 {
                let frac = (m << (52 - lead)) & ((1 << 52) - 1);
                f64::from_bits(((top + 1023) as u64) << 52 | frac)
            } else {
                f64::from_bits(m << (q + 1074))
            };
            return Some((sign * exact, true));
        }
        // Below the subnormal grid: m · 2^q on multiples of 2^-1074, ties to even.
        let shift = (-1074 - q) as u32;
        let r = if shift >= 64 {
            0
        } else {
            let (kept, rest) = (m >> shift, m & ((1u64 << shift) - 1));
            let half = 1u64 << (shift - 1);
            kept + (rest > half || (rest == half && kept & 1 == 1)) as u64
        };
        Some((sign * f64::from_bits(r), false))
    }

    /// `times_pow2` is exact wherever x · 2^e is a float, and where 2^e is a normal number (its
    /// one-product path) rounds an underflowing product once, to nearest: checked against
    /// integer arithmetic on x's significand, over every exponent of x and every e it takes.
    #[test]
    fn times_pow2_is_exact_or_rounded_once() {
        let mut rng = Rng::new(29);
        let (mut exact, mut rounded) = (0, 0);
        for _ in 0..400_000 {
            // Any sign, exponent (subnormals and zero included) and significand.
            let x = f64::from_bits(rng.u64());
            if !x.is_finite() {
                continue;
            }
            let e = rng.below(4093) as i32 - 2046;
            let got = times_pow2(x, e);
            match scaled_exactly(x, e) {
                None => assert!(got.is_infinite() && got.signum() == x.signum(), "{x:e} {e}"),
                Some((want, representable)) => {
                    if representable || (-1022..=1023).contains(&e) {
                        assert_eq!(got.to_bits(), want.to_bits(), "{x:e} · 2^{e}");
                        if representable {
                            exact += 1;
                        } else {
                            rounded += 1;
                        }
                    }
                }
            }
        }
        assert!(
            exact > 100_000 && rounded > 1_000,
            "{exact} exact, {rounded} rounded"
        );
    }

    /// Where x · 2^e falls below the normal numbers from a subnormal or tiny x, two products
    /// (2^(e/2), then the rest) would round twice: 5 · 2^-1074 · 2^-3 is 0.625 ulp, which
    /// rounds to 1 ulp, but 2.5 ulp rounds to 2 and then 0.5 ulp to 0. For every e with 2^e
    /// normal, `times_pow2` rounds once: checked over the first 4096 subnormals and tiny normal
    /// significands, against integer arithmetic.
    #[test]
    fn times_pow2_rounds_an_underflow_once() {
        let (mut checked, mut twice_differs) = (0, 0);
        for k in 1..4096u64 {
            for base in [0u64, 1 << 52] {
                let x = f64::from_bits(base | k);
                for e in -80..0 {
                    let (want, _) = scaled_exactly(x, e).unwrap();
                    let got = times_pow2(x, e);
                    assert_eq!(got.to_bits(), want.to_bits(), "{x:e} · 2^{e}");
                    let h = e / 2;
                    twice_differs += (x * 2f64.powi(h) * 2f64.powi(e - h) != want) as u32;
                    checked += 1;
                }
            }
        }
        // The sweep holds inputs on which rounding twice goes wrong (else it tests nothing).
        assert!(twice_differs > 1_000, "{twice_differs} of {checked}");
    }
}
