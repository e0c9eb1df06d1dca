//! Exact evaluation in `BigInt`s: the inputs of one ray–triangle pair scaled by one power of
//! two are integers, so signs and ratios keep their values.

use super::*;

/// A finite f64 as `m · 2^e` (m odd, or 0).
pub(super) fn decode(x: f64) -> (i64, i64) {
    debug_assert!(x.is_finite());
    let bits = x.to_bits();
    let exp = ((bits >> 52) & 0x7ff) as i64;
    let frac = (bits & ((1u64 << 52) - 1)) as i64;
    let (m, e) = if exp == 0 {
        (frac, -1074)
    } else {
        (frac | (1 << 52), exp - 1075)
    };
    if m == 0 {
        return (0, 0);
    }
    let tz = m.trailing_zeros() as i64;
    let m = m >> tz;
    (if bits >> 63 == 1 { -m } else { m }, e + tz)
}

/// Points scaled by one power of two into integers: `v[i][k] = p[i][k] · 2^-low`.
pub(super) struct Scaled {
    pub(super) v: Vec<[BigInt; 3]>,
    /// The power of two taken out: inputs are `v · 2^low`.
    pub(super) low: i64,
}

impl Scaled {
    pub(super) fn new(points: &[P3]) -> Scaled {
        let dec: Vec<[(i64, i64); 3]> = points.iter().map(|p| p.map(decode)).collect();
        let low = dec
            .iter()
            .flatten()
            .filter(|(m, _)| *m != 0)
            .map(|(_, e)| *e)
            .min()
            .unwrap_or(0);
        let v = dec
            .iter()
            .map(|p| p.map(|(m, e)| BigInt::from(m) << (e - low) as usize))
            .collect();
        Scaled { v, low }
    }
}

type B3 = [BigInt; 3];

pub(super) fn bsub(a: &B3, b: &B3) -> B3 {
    [&a[0] - &b[0], &a[1] - &b[1], &a[2] - &b[2]]
}

pub(super) fn bcross(a: &B3, b: &B3) -> B3 {
    [
        &a[1] * &b[2] - &a[2] * &b[1],
        &a[2] * &b[0] - &a[0] * &b[2],
        &a[0] * &b[1] - &a[1] * &b[0],
    ]
}

pub(super) fn bdot(a: &B3, b: &B3) -> BigInt {
    &a[0] * &b[0] + &a[1] * &b[1] + &a[2] * &b[2]
}

pub(super) trait SignOrd {
    fn sign_ord(&self) -> Ordering;
}

impl SignOrd for BigInt {
    fn sign_ord(&self) -> Ordering {
        match self.sign() {
            Sign::Minus => Ordering::Less,
            Sign::NoSign => Ordering::Equal,
            Sign::Plus => Ordering::Greater,
        }
    }
}

/// A pair's exact side products and `t = num / den` (scaled alike).
pub(super) struct Exact {
    pub(super) signs: [Ordering; 3],
    pub(super) num: BigInt,
    pub(super) den: BigInt,
}

impl Exact {
    pub(super) fn crossing(self) -> Option<Crossing> {
        let pos = self.signs.iter().all(|s| s.is_ge());
        let neg = self.signs.iter().all(|s| s.is_le());
        let zero_signs = self.signs.iter().filter(|s| s.is_eq()).count() as u8;
        if !(pos || neg) || zero_signs == 3 {
            return None;
        }
        // Not all zero and of one sign: den is their sum, nonzero.
        let (num, den) = if self.den.sign() == Sign::Minus {
            (-self.num, -self.den)
        } else {
            (self.num, self.den)
        };
        Some(Crossing {
            num,
            den,
            zero_signs,
        })
    }
}

#[cfg(test)]
thread_local! {
    /// Exact evaluations on this thread (tests check which path decided).
    pub(super) static EXACT_CALLS: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
}

pub(super) fn count_exact() {
    #[cfg(test)]
    EXACT_CALLS.with(|c| c.set(c.get() + 1));
}

pub(super) fn exact(o: P3, d: P3, tri: &Tri) -> Exact {
    count_exact();
    let x = Scaled::new(&[o, d, tri[0], tri[1], tri[2]]);
    let [o, d, a, b, c] = [0, 1, 2, 3, 4].map(|i| &x.v[i]);
    let (u, v, w) = (bsub(a, o), bsub(b, o), bsub(c, o));
    let (uv, vw, wu) = (bcross(&u, &v), bcross(&v, &w), bcross(&w, &u));
    let s = [bdot(d, &uv), bdot(d, &vw), bdot(d, &wu)];
    let num = bdot(&u, &vw);
    let den = &s[0] + &s[1] + &s[2];
    Exact {
        signs: [s[0].sign_ord(), s[1].sign_ord(), s[2].sign_ord()],
        num,
        den,
    }
}

/// `|d · ((b − a) × (c − a))|`, exactly, rounded to the nearest float64 (this feeds an error
/// bound).
pub(super) fn exact_den_abs(o: P3, d: P3, tri: &Tri) -> f64 {
    let x = Scaled::new(&[o, d, tri[0], tri[1], tri[2]]);
    let [d, a, b, c] = [1, 2, 3, 4].map(|i| &x.v[i]);
    let den = bdot(d, &bcross(&bsub(b, a), &bsub(c, a)));
    // den is of degree 3 in the scaled inputs: the true value is den · 2^(3 low), rounded once.
    // Not den rounded, then scaled: where one input is tiny (an origin component of 1e-300)
    // the scaled integers are huge and den alone overflows float64 (a bound of 2ε|t| then).
    let e = 3 * x.low;
    let one = BigInt::from(1);
    if e >= 0 {
        round_quotient(&(den << e as usize), &one).abs()
    } else {
        round_quotient(&den, &(one << (-e) as usize)).abs()
    }
}

/// `x · 2^e` (exact whenever the result is representable).
pub(super) fn ldexp(mut x: f64, mut e: i64) -> f64 {
    let pow2 = |k: i64| f64::from_bits(((k + 1023) as u64) << 52);
    while e > 1000 {
        x *= pow2(1000);
        e -= 1000;
        if x.is_infinite() || x == 0.0 {
            return x;
        }
    }
    while e < -1000 {
        x *= pow2(-1000);
        e += 1000;
        if x == 0.0 {
            return x;
        }
    }
    x * pow2(e)
}

/// `num / den` rounded to the nearest float64, ties to even (`±inf` beyond the range, signed
/// zero below it). `den` must not be zero.
pub fn round_quotient(num: &BigInt, den: &BigInt) -> f64 {
    assert!(!den.is_zero(), "round_quotient: zero denominator");
    let negative = (num.sign() == Sign::Minus) != (den.sign() == Sign::Minus);
    let signed = |x: f64| if negative { -x } else { x };
    if num.is_zero() {
        return 0.0;
    }
    let (n, d): (&BigUint, &BigUint) = (num.magnitude(), den.magnitude());
    // q = floor(n 2^k / d) has 55 or 56 bits: two more than float64's 53 and a sticky bit.
    let k = d.bits() as i64 - n.bits() as i64 + 55;
    let (nn, dd) = if k >= 0 {
        (n << k as usize, d.clone())
    } else {
        (n.clone(), d << (-k) as usize)
    };
    let q_big = &nn / &dd;
    let sticky = !(&nn - &q_big * &dd).is_zero();
    let q = q_big.to_u64().expect("56 bits at most");
    let qb = 64 - q.leading_zeros() as i64;
    // The value is (q + frac) 2^-k, with floor(log2) = qb - 1 - k.
    let e = qb - 1 - k;
    if e > 1023 {
        return signed(f64::INFINITY);
    }
    // Significant bits available at that exponent (fewer for subnormals).
    let p = if e >= -1022 { 53 } else { 53 - (-1022 - e) };
    let drop = qb - p; // ≥ 2
    let m = if drop >= 64 {
        0 // q < 2^56 ≤ half an ulp: rounds to zero
    } else {
        let m = q >> drop;
        let rest = q & ((1u64 << drop) - 1);
        let half = 1u64 << (drop - 1);
        let up = rest > half || (rest == half && (sticky || m & 1 == 1));
        m + up as u64
    };
    signed(ldexp(m as f64, drop - k))
}
