//! Exact dyadic numbers m·2^e (m an integer of any size): the exact fallback of the predicates.
//!
//! Every float64 is one, and sums, differences and products of them stay dyadic, which is all
//! a determinant needs. `num_rational::BigRational` computes the same values but reduces each
//! result by a gcd; with coordinates far apart in scale (1e-300 beside 1) those gcds run on
//! thousand-bit numbers, and one fuzz case spent 24 s in them. Here nothing is reduced: an
//! addition shifts the operand with the larger exponent, a product adds exponents.

use num_bigint::BigInt;
use num_traits::{float::FloatCore, Signed, Zero};
use std::cmp::Ordering;
use std::ops::{Add, Mul, Neg, Sub};

/// m · 2^e, exactly.
#[derive(Clone, Debug, Default)]
pub struct Dyadic {
    m: BigInt,
    e: i64,
}

impl Dyadic {
    /// The exact value of a finite float (zero for NaN and infinities, which no predicate
    /// reaches with a meaning: callers reject them first).
    pub fn from_f64(x: f64) -> Dyadic {
        if !x.is_finite() || x == 0.0 {
            return Dyadic::default();
        }
        let (mantissa, exponent, sign) = FloatCore::integer_decode(x);
        let m = BigInt::from(mantissa);
        Dyadic {
            m: if sign < 0 { -m } else { m },
            e: exponent as i64,
        }
    }

    pub fn is_zero(&self) -> bool {
        self.m.is_zero()
    }

    pub fn is_positive(&self) -> bool {
        self.m.is_positive()
    }

    /// -1, 0 or 1.
    pub fn signum(&self) -> i8 {
        if self.m.is_zero() {
            0
        } else if self.m.is_positive() {
            1
        } else {
            -1
        }
    }

    /// The order of the exact values. (No `Ord`: the predicates compare by this alone, and
    /// `==` and `<` on dyadics had no reader outside a test.)
    pub fn cmp_exact(&self, other: &Dyadic) -> Ordering {
        (self - other).signum().cmp(&0)
    }

    /// Both mantissas on the smaller exponent.
    fn aligned(&self, other: &Dyadic) -> (BigInt, BigInt, i64) {
        let e = self.e.min(other.e);
        (
            &self.m << (self.e - e) as usize,
            &other.m << (other.e - e) as usize,
            e,
        )
    }
}

impl Add for &Dyadic {
    type Output = Dyadic;
    fn add(self, other: &Dyadic) -> Dyadic {
        if other.m.is_zero() {
            return self.clone();
        }
        if self.m.is_zero() {
            return other.clone();
        }
        let (a, b, e) = self.aligned(other);
        Dyadic { m: a + b, e }
    }
}

impl Sub for &Dyadic {
    type Output = Dyadic;
    fn sub(self, other: &Dyadic) -> Dyadic {
        if other.m.is_zero() {
            return self.clone();
        }
        if self.m.is_zero() {
            return -other;
        }
        let (a, b, e) = self.aligned(other);
        Dyadic { m: a - b, e }
    }
}

impl Mul for &Dyadic {
    type Output = Dyadic;
    fn mul(self, other: &Dyadic) -> Dyadic {
        if self.m.is_zero() || other.m.is_zero() {
            return Dyadic::default();
        }
        Dyadic {
            m: &self.m * &other.m,
            e: self.e + other.e,
        }
    }
}

impl Neg for &Dyadic {
    type Output = Dyadic;
    fn neg(self) -> Dyadic {
        Dyadic {
            m: -&self.m,
            e: self.e,
        }
    }
}

macro_rules! by_value {
    ($($tr:ident $f:ident),*) => {$(
        impl $tr for Dyadic {
            type Output = Dyadic;
            fn $f(self, other: Dyadic) -> Dyadic {
                (&self).$f(&other)
            }
        }
        impl $tr<&Dyadic> for Dyadic {
            type Output = Dyadic;
            fn $f(self, other: &Dyadic) -> Dyadic {
                (&self).$f(other)
            }
        }
        impl $tr<Dyadic> for &Dyadic {
            type Output = Dyadic;
            fn $f(self, other: Dyadic) -> Dyadic {
                self.$f(&other)
            }
        }
    )*};
}
by_value!(Add add, Sub sub, Mul mul);

impl Neg for Dyadic {
    type Output = Dyadic;
    fn neg(self) -> Dyadic {
        -&self
    }
}

impl Dyadic {
    /// a / b rounded to the nearest float64 (ties to even; subnormal and infinite results
    /// included), b nonzero: where a rounded quotient must be faithful and the float
    /// evaluation could not certify it (`geom::rounded`).
    pub fn quotient(a: &Dyadic, b: &Dyadic) -> f64 {
        assert!(!b.is_zero(), "Dyadic::quotient: zero denominator");
        if a.is_zero() {
            return 0.0;
        }
        let negative = a.m.is_negative() != b.m.is_negative();
        let (n, d) = (a.m.magnitude(), b.m.magnitude());
        // q = floor(n 2^k / d) has 55 or 56 bits: two more than float64's 53, and a sticky
        // bit for what the division left.
        let k = d.bits() as i64 - n.bits() as i64 + 55;
        let (nn, dd) = if k >= 0 {
            (n << k as usize, d.clone())
        } else {
            (n.clone(), d << (-k) as usize)
        };
        let q_big = &nn / &dd;
        let sticky = !(&nn - &q_big * &dd).is_zero();
        let q = q_big.iter_u64_digits().next().unwrap_or(0);
        let qb = 64 - q.leading_zeros() as i64;
        // The value is (q + frac) 2^(shift), floor(log2) = qb - 1 + shift.
        let shift = a.e - b.e - k;
        let top = qb - 1 + shift;
        let signed = |x: f64| if negative { -x } else { x };
        if top > 1023 {
            return signed(f64::INFINITY);
        }
        // Significant bits at that exponent (fewer for subnormals), and the bits dropped.
        let p = if top >= -1022 { 53 } else { 53 - (-1022 - top) };
        let drop = qb - p;
        let m = if drop >= 64 {
            0
        } else {
            let m = q >> drop;
            let rest = q & ((1u64 << drop) - 1);
            let half = 1u64 << (drop - 1);
            let up = rest > half || (rest == half && (sticky || m & 1 == 1));
            m + up as u64
        };
        // m 2^(drop + shift) is a float (m fits the bits available there): exact.
        signed(super::real::times_pow2(m as f64, (drop + shift) as i32))
    }
}

/// The comparison of two fractions a/b and c/d with nonzero denominators.
pub fn cmp_fractions(a: &Dyadic, b: &Dyadic, c: &Dyadic, d: &Dyadic) -> Ordering {
    let s = (a * d - c * b).signum() * b.signum() * d.signum();
    s.cmp(&0)
}

/// det(a, b, c), exactly.
pub fn rdet(a: &[Dyadic; 3], b: &[Dyadic; 3], c: &[Dyadic; 3]) -> Dyadic {
    &a[0] * (&b[1] * &c[2] - &b[2] * &c[1]) - &a[1] * (&b[0] * &c[2] - &b[2] * &c[0])
        + &a[2] * (&b[0] * &c[1] - &b[1] * &c[0])
}

/// A float64 point's exact value (for the callers that evaluate a perturbation: the exact
/// walk, exact orientation).
pub fn exact3(v: [f64; 3]) -> [Dyadic; 3] {
    v.map(Dyadic::from_f64)
}

#[cfg(test)]
mod tests {
    use super::*;
    use num_rational::BigRational;

    fn r(x: f64) -> BigRational {
        BigRational::from_float(x).unwrap()
    }

    fn rsign(q: &BigRational) -> i8 {
        q.cmp(&BigRational::zero()) as i8
    }

    /// Sums, differences, products and comparisons are those of the rationals, across
    /// float64's whole range (denormals and 1e±300 beside ordinary values).
    #[test]
    fn agrees_with_rationals() {
        let mut rng = crate::rng::Rng::new(0x2545_f491_4f6c_dd1d);
        let mut next = move || rng.u64();
        let odd = [
            0.0,
            -0.0,
            5e-324,
            -1e-310,
            1e-300,
            1e300,
            -1.5,
            3.0,
            f64::MAX,
            1.0,
        ];
        let mut value = || {
            let k = next();
            if k % 3 == 0 {
                odd[(k / 3 % odd.len() as u64) as usize]
            } else {
                let m = (next() >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
                m * 2f64.powi((k % 1200) as i32 - 600)
            }
        };
        for _ in 0..20_000 {
            let (x, y, z) = (value(), value(), value());
            let (dx, dy, dz) = (
                Dyadic::from_f64(x),
                Dyadic::from_f64(y),
                Dyadic::from_f64(z),
            );
            let want = (r(x) - r(y)) * r(z) + r(x) * r(y);
            let got = (&dx - &dy) * &dz + &dx * &dy;
            assert_eq!(got.signum(), rsign(&want), "{x} {y} {z}");
            assert_eq!(dx.cmp_exact(&dy), r(x).cmp(&r(y)), "{x} vs {y}");
            assert_eq!((-&dx).cmp_exact(&dz), (-r(x)).cmp(&r(z)));
            if y != 0.0 && z != 0.0 {
                assert_eq!(
                    cmp_fractions(&dx, &dy, &dz, &dy),
                    (r(x) / r(y)).cmp(&(r(z) / r(y)))
                );
                assert_eq!(
                    cmp_fractions(&dx, &dy, &dx, &dz),
                    (r(x) / r(y)).cmp(&(r(x) / r(z)))
                );
            }
        }
    }

    /// A determinant of points 1e-300 and 1 apart is exact (the fuzz case that took 24 s in
    /// rationals).
    #[test]
    fn mixed_scales_are_exact() {
        let a = Dyadic::from_f64(1.0);
        let b = Dyadic::from_f64(1e-300);
        let c = &a + &b;
        assert_eq!(c.cmp_exact(&a), Ordering::Greater);
        assert_eq!((&c - &a).cmp_exact(&b), Ordering::Equal);
        assert!((&c * &c - &a).is_positive());
        assert!(Dyadic::from_f64(f64::NAN).is_zero());
    }
}
