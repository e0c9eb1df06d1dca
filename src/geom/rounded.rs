//! A ray's hit on a triangle, rounded faithfully: `t`, the barycentrics `(u, v)` and the point,
//! each within one float64 ulp of its exact value for the numbers passed in.
//!
//! With `e1 = b − a`, `e2 = c − a` and `w = a − o`, the exact values are
//!
//! * `t* = N / D`, `N = det(w, e1, e2)`, `D = det(d, e1, e2)`;
//! * `u* = det(d, e2, w) / D` (the weight of `b`), `v* = det(d, w, e1) / D` (the weight of `c`);
//! * `p* = a + u* e1 + v* e2` (= `o + t* d`).
//!
//! Anchored at the triangle, the one large vector (`w`, when the origin is far away) meets
//! only the small edges. The float64 form `det(a − o, b − o, c − o)` that the walk used before
//! cancels products of size `|w|³` down to a value of size `|w| |e|²`: at a distance of 10⁶ it
//! lost twelve digits (`t` 995,081.39 where the exact value is 1,000,000.07).
//!
//! Each numerator and `D` is evaluated in double-double arithmetic: the differences are held
//! exactly as `hi + lo` (TwoSum), products are split exactly (TwoProduct, by FMA where the CPU
//! has it, else Dekker's splitting: the same bits either way), and only terms of order `ε²` are
//! rounded or dropped, so each value is within `K ε² P` of the exact one (`P` its permanent,
//! [`K`] derived below). The quotients are formed to double-double accuracy and rounded once;
//! the rounding's own error is measured exactly (TwoSum). When the two together are within an
//! ulp of the rounded value, that value is faithful and returned: nearly every hit. Otherwise
//! (a `u` or `v` that is exactly or nearly zero, a grazing ray, operands outside
//! `[2^-300, 2^300]`) the value is evaluated exactly in dyadic numbers and rounded to nearest.

use super::dyadic::Dyadic;
use super::real::{exponent, times_pow2, V3};

/// Unit roundoff of float64.
const EPS: f64 = f64::EPSILON * 0.5;

/// The double-double evaluation of a determinant (`cross` then `dot`) is within `K ε² P` of
/// the exact value. Each component of a cross product of exact double-doubles drops two
/// `lo·lo` products (≤ ε² each, relative to its two products' sum of magnitudes) and rounds a
/// sum of seven terms each ≤ ε (≤ 7 · 7 ε² with the products' own roundings): ≤ 60 ε². The dot
/// product of an exact double-double with it adds its own dropped `lo·lo` terms and a rounded
/// sum of nine terms each ≤ 2ε (≤ 30 ε²), and the cross product's error times `|w|` is inside
/// the permanent: ≤ 100 ε² P in all. K = 1024 leaves a margin of ten.
const K: f64 = 1024.0;

/// Operands (coordinates, their differences, the scaled direction) must be zero or have a
/// magnitude in `[2^-300, 2^300]`: every product of three then lies in `[2^-1000, 2^900]`,
/// and so does each TwoProduct's error term, so no product underflows or overflows and every
/// error bound is relative. Outside, the exact path.
const OPERAND_MIN: f64 = 4.909093465297727e-91; // 2^-300
const OPERAND_MAX: f64 = 2.037035976334486e90; // 2^300
/// A quotient's numerator and denominator smaller than this (but nonzero) could underflow in
/// the remainder `n − q d`: the exact path.
const QUOTIENT_MIN: f64 = f64::from_bits((1023 - 511) << 52); // 2^-511

/// A ray's hit on a triangle, each value within one ulp of the exact one.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RoundedHit {
    pub t: f64,
    /// A bound on `|t − t*|` (at most an ulp of `t`; the ordering of nearby hits uses it).
    pub t_err: f64,
    /// The weight of the triangle's second vertex.
    pub u: f64,
    /// The weight of the triangle's third vertex.
    pub v: f64,
    pub point: [f64; 3],
}

/// The hit of the line `o + t d` on the plane of `tri`, faithfully rounded (see the module
/// docs); `None` when the line is parallel to that plane (`D = 0` exactly), where it has none.
pub fn rounded_hit(o: V3<f64>, d: V3<f64>, tri: &[V3<f64>; 3]) -> Option<RoundedHit> {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("fma") {
        // SAFETY: the CPU has FMA, checked just above.
        return unsafe { rounded_hit_fma(o, d, tri) };
    }
    rounded_hit_with::<false>(o, d, tri)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "fma")]
unsafe fn rounded_hit_fma(o: V3<f64>, d: V3<f64>, tri: &[V3<f64>; 3]) -> Option<RoundedHit> {
    rounded_hit_with::<true>(o, d, tri)
}

/// [`rounded_hit`], with products split by FMA (`FMA`) or by Dekker's splitting: the same
/// exact error terms, so the same answer bit for bit.
#[inline(always)]
pub fn rounded_hit_with<const FMA: bool>(
    o: V3<f64>,
    d: V3<f64>,
    tri: &[V3<f64>; 3],
) -> Option<RoundedHit> {
    let mut exact = Exact::new(o, d, tri);
    let Some(f) = Filtered::<FMA>::new(o, d, tri) else {
        return exact.all();
    };
    // D's sign is certain, else D may be 0: decide it exactly.
    if !exceeds(f.den.hi.abs(), 2.0 * f.den_err) && exact.den().is_zero() {
        return None;
    }
    let t = match f.quotient(f.num, f.num_err) {
        Some((q, c, err)) => match faithful(q, c, err) {
            // Back to the caller's direction: exact unless the result leaves the normal range.
            Some((t, t_err)) => {
                let (t, t_err) = (times_pow2(t, -f.scale), times_pow2(t_err, -f.scale));
                if t == 0.0 || t.is_normal() {
                    Some((t, t_err))
                } else {
                    None
                }
            }
            None => None,
        },
        None => None,
    };
    let (t, t_err) = t.unwrap_or_else(|| exact.t());
    let u = f.quotient(f.num_u, f.num_u_err);
    let v = f.quotient(f.num_v, f.num_v_err);
    let u_val = u.and_then(|(q, c, e)| faithful(q, c, e)).map(|x| x.0);
    let v_val = v.and_then(|(q, c, e)| faithful(q, c, e)).map(|x| x.0);
    let u_val = u_val.unwrap_or_else(|| exact.u());
    let v_val = v_val.unwrap_or_else(|| exact.v());
    let point = [0, 1, 2].map(|k| {
        let anchored = match (u, v) {
            (Some(u), Some(v)) => f.point(k, u, v),
            _ => None,
        };
        anchored.unwrap_or_else(|| exact.point(k))
    });
    Some(RoundedHit {
        t,
        t_err,
        u: u_val,
        v: v_val,
        point,
    })
}

/// Whether `x > bound`: false for a NaN, so a value that is not a number is never taken as
/// certainly nonzero.
#[inline(always)]
fn exceeds(x: f64, bound: f64) -> bool {
    x > bound
}

/// `q + c` rounded to float64, when the rounding's error plus `err` (a bound on
/// `|q + c − x*|`) is within an ulp of the result below it (then also within `ulp(x*)`):
/// the value and that total bound.
#[inline(always)]
fn faithful(q: f64, c: f64, err: f64) -> Option<(f64, f64)> {
    let (x, r) = two_sum(q, c);
    let total = (r.abs() + err) * (1.0 + 4.0 * EPS);
    (total <= ulp_below(x)).then_some((x, total))
}

/// The spacing of float64 just below `|x|` (toward zero): the smaller of the two at a power
/// of two. `|x − x*| ≤ ulp_below(x)` puts `x*` between x's neighbours, whose spacing there is
/// at least this: so `|x − x*| ≤ ulp(x*)`.
#[inline(always)]
fn ulp_below(x: f64) -> f64 {
    let a = x.abs();
    if a == 0.0 {
        return f64::from_bits(1);
    }
    if !a.is_finite() {
        return 0.0;
    }
    a - f64::from_bits(a.to_bits() - 1)
}

/// An exact double-double `hi + lo`, or (after rounded operations) an approximation of one.
#[derive(Clone, Copy, Debug)]
struct Dd {
    hi: f64,
    lo: f64,
}

impl Dd {
    #[inline(always)]
    fn of(x: f64) -> Dd {
        Dd { hi: x, lo: 0.0 }
    }

    /// a − b, exactly.
    #[inline(always)]
    fn diff(a: f64, b: f64) -> Dd {
        let (hi, lo) = two_sum(a, -b);
        Dd { hi, lo }
    }

    /// The same value with `|lo| ≤ ulp(hi) / 2`.
    #[inline(always)]
    fn normalized(self) -> Dd {
        let (hi, lo) = two_sum(self.hi, self.lo);
        Dd { hi, lo }
    }
}

/// s + e = a + b exactly, s = fl(a + b) (Knuth's TwoSum: no branch, any order of magnitude).
#[inline(always)]
fn two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    let bv = s - a;
    let av = s - bv;
    (s, (a - av) + (b - bv))
}

/// p + e = a · b exactly, p = fl(a · b), for products far from underflow and overflow.
#[inline(always)]
fn two_prod<const FMA: bool>(a: f64, b: f64) -> (f64, f64) {
    let p = a * b;
    if FMA {
        (p, a.mul_add(b, -p))
    } else {
        // Dekker: a and b split into halves of 26 bits, whose products are exact.
        let (ah, al) = split(a);
        let (bh, bl) = split(b);
        (p, ((ah * bh - p) + ah * bl + al * bh) + al * bl)
    }
}

/// Veltkamp's splitting: a = h + l with h, l of at most 26 significant bits.
#[inline(always)]
fn split(a: f64) -> (f64, f64) {
    const FACTOR: f64 = 134_217_729.0; // 2^27 + 1
    let c = FACTOR * a;
    let h = c - (c - a);
    (h, a - h)
}

/// x × y for exact double-doubles x, y; and the sums of magnitudes of the products that make
/// each component (`|x_j y_k| + |x_k y_j|`), which bound its error as K ε² times them.
#[inline(always)]
fn cross_dd<const FMA: bool>(x: &[Dd; 3], y: &[Dd; 3]) -> ([Dd; 3], [f64; 3]) {
    let mut out = [Dd::of(0.0); 3];
    let mut mag = [0.0; 3];
    for i in 0..3 {
        let (j, k) = ((i + 1) % 3, (i + 2) % 3);
        let (p, pe) = two_prod::<FMA>(x[j].hi, y[k].hi);
        let (m, me) = two_prod::<FMA>(x[k].hi, y[j].hi);
        let (s, se) = two_sum(p, -m);
        let lo = se
            + (pe - me)
            + ((x[j].hi * y[k].lo + x[j].lo * y[k].hi) - (x[k].hi * y[j].lo + x[k].lo * y[j].hi));
        out[i] = Dd { hi: s, lo };
        mag[i] = p.abs() + m.abs();
    }
    (out, mag)
}

/// x · y for an exact double-double x and a double-double y (a [`cross_dd`]), with its
/// permanent `Σ |x_i| mag_i` (mag: the cross product's magnitudes).
#[inline(always)]
fn dot_dd<const FMA: bool>(x: &[Dd; 3], y: &[Dd; 3], mag: &[f64; 3]) -> (Dd, f64) {
    let (p0, e0) = two_prod::<FMA>(x[0].hi, y[0].hi);
    let (p1, e1) = two_prod::<FMA>(x[1].hi, y[1].hi);
    let (p2, e2) = two_prod::<FMA>(x[2].hi, y[2].hi);
    let (s, s1) = two_sum(p0, p1);
    let (s, s2) = two_sum(s, p2);
    let lo = (s1 + s2)
        + (e0 + e1 + e2)
        + (x[0].hi * y[0].lo + x[1].hi * y[1].lo + x[2].hi * y[2].lo)
        + (x[0].lo * y[0].hi + x[1].lo * y[1].hi + x[2].lo * y[2].hi);
    let perm = x[0].hi.abs() * mag[0] + x[1].hi.abs() * mag[1] + x[2].hi.abs() * mag[2];
    (Dd { hi: s, lo }.normalized(), perm)
}

/// The double-double values: numerators of t, u, v and the denominator, each with its error
/// bound, for the direction scaled by `2^-scale` (largest component in [1, 2)).
struct Filtered<const FMA: bool> {
    a: V3<f64>,
    e1: [Dd; 3],
    e2: [Dd; 3],
    num: Dd,
    num_err: f64,
    num_u: Dd,
    num_u_err: f64,
    num_v: Dd,
    num_v_err: f64,
    den: Dd,
    den_err: f64,
    scale: i32,
}

impl<const FMA: bool> Filtered<FMA> {
    /// None when an operand is outside the range where every bound holds.
    #[inline(always)]
    fn new(o: V3<f64>, d: V3<f64>, tri: &[V3<f64>; 3]) -> Option<Self> {
        let m = d.iter().fold(0f64, |m, x| m.max(x.abs()));
        if m == 0.0 || !m.is_finite() {
            return None;
        }
        let scale = exponent(m);
        let d = d.map(|x| times_pow2(x, -scale));
        let [a, b, c] = *tri;
        let w = [0, 1, 2].map(|k| Dd::diff(a[k], o[k]));
        let e1 = [0, 1, 2].map(|k| Dd::diff(b[k], a[k]));
        let e2 = [0, 1, 2].map(|k| Dd::diff(c[k], a[k]));
        let ok = |x: f64| x == 0.0 || (x.abs() >= OPERAND_MIN && x.abs() <= OPERAND_MAX);
        let in_range = o
            .iter()
            .chain(&a)
            .chain(&b)
            .chain(&c)
            .chain(&d)
            .all(|&x| ok(x))
            && w.iter().chain(&e1).chain(&e2).all(|x| ok(x.hi));
        if !in_range {
            return None;
        }
        let dd = d.map(Dd::of);
        let (n, n_mag) = cross_dd::<FMA>(&e1, &e2);
        let (m2, m2_mag) = cross_dd::<FMA>(&dd, &e2);
        let (m1, m1_mag) = cross_dd::<FMA>(&e1, &dd);
        let bound = |perm: f64| K * EPS * EPS * perm;
        let (num, p) = dot_dd::<FMA>(&w, &n, &n_mag);
        let (den, pd) = dot_dd::<FMA>(&dd, &n, &n_mag);
        let (num_u, pu) = dot_dd::<FMA>(&w, &m2, &m2_mag);
        let (num_v, pv) = dot_dd::<FMA>(&w, &m1, &m1_mag);
        Some(Filtered {
            a,
            e1,
            e2,
            num,
            num_err: bound(p),
            num_u,
            num_u_err: bound(pu),
            num_v,
            num_v_err: bound(pv),
            den,
            den_err: bound(pd),
            scale,
        })
    }

    /// n / D for a numerator n within `n_err` of its exact value: `(q, c, err)` with
    /// `|q + c − n*/D*| ≤ err`; None when D is not certainly nonzero or a value is so small
    /// that the remainder could underflow.
    #[inline(always)]
    fn quotient(&self, n: Dd, n_err: f64) -> Option<(f64, f64, f64)> {
        let (d, d_err) = (self.den, self.den_err);
        let small = |x: f64| x != 0.0 && x.abs() < QUOTIENT_MIN;
        if !exceeds(d.hi.abs(), 2.0 * d_err) || small(d.hi) || small(n.hi) {
            return None;
        }
        let q = n.hi / d.hi;
        // n.hi − q d.hi is a float (the remainder of a rounded quotient), computed exactly.
        let (p, pe) = two_prod::<FMA>(q, d.hi);
        let r = (n.hi - p) - pe;
        let ql = q * d.lo;
        let c = ((r + n.lo) - ql) / d.hi;
        // |c − (n − q d)/d|: the roundings of (r + lo − q·dlo) and of the division, and the
        // dropped d.lo in the divisor (|d.lo| ≤ ε |d.hi|, normalized): each ≤ ε of its term.
        let div = 8.0 * EPS * (c.abs() + (r.abs() + n.lo.abs() + ql.abs()) / d.hi.abs());
        // The errors of n and D, carried through the quotient.
        let prop = (n_err + (q.abs() * (1.0 + 4.0 * EPS) + c.abs()) * d_err)
            / (d.hi.abs() * (1.0 - 4.0 * EPS) - d_err);
        Some((q, c, (div + prop) * (1.0 + 8.0 * EPS)))
    }

    /// Coordinate k of `a + u e1 + v e2` for u, v as [`Self::quotient`] gives them, faithful.
    #[inline(always)]
    fn point(&self, k: usize, u: (f64, f64, f64), v: (f64, f64, f64)) -> Option<f64> {
        let (e1, e2) = (self.e1[k], self.e2[k]);
        let (p1, p1e) = two_prod::<FMA>(u.0, e1.hi);
        let (p2, p2e) = two_prod::<FMA>(v.0, e2.hi);
        let (s1, s1e) = two_sum(self.a[k], p1);
        let (s2, s2e) = two_sum(s1, p2);
        let terms = [
            p1e,
            p2e,
            s1e,
            s2e,
            u.0 * e1.lo,
            u.1 * e1.hi,
            v.0 * e2.lo,
            v.1 * e2.hi,
        ];
        let rest = terms.iter().sum::<f64>();
        let size: f64 = terms.iter().map(|x| x.abs()).sum();
        let (x, r) = two_sum(s2, rest);
        // The sum's rounding (eight terms), the dropped c·lo products (≤ ε |c| |hi|), and the
        // errors of u and v times the edges.
        let dropped = EPS * (u.1.abs() * e1.hi.abs() + v.1.abs() * e2.hi.abs());
        let err = 8.0 * EPS * size
            + dropped
            + u.2 * (e1.hi.abs() + e1.lo.abs())
            + v.2 * (e2.hi.abs() + e2.lo.abs());
        let total = (r.abs() + err) * (1.0 + 4.0 * EPS);
        (total <= ulp_below(x)).then_some(x)
    }
}

/// The exact values, each computed once when first asked for.
struct Exact {
    o: V3<f64>,
    d: V3<f64>,
    tri: [V3<f64>; 3],
    e: Option<ExactValues>,
}

struct ExactValues {
    num: Dyadic,
    num_u: Dyadic,
    num_v: Dyadic,
    den: Dyadic,
    a: [Dyadic; 3],
    e1: [Dyadic; 3],
    e2: [Dyadic; 3],
}

test_count!(
    /// Hits on this thread whose exact (dyadic) values were computed: tests learn that the
    /// double-double filter answered (its answers and the exact path's are alike within an ulp).
    EXACT_HITS,
    exact_hits
);

fn exact_det(a: &[Dyadic; 3], b: &[Dyadic; 3], c: &[Dyadic; 3]) -> Dyadic {
    super::dyadic::rdet(a, b, c)
}

impl Exact {
    fn new(o: V3<f64>, d: V3<f64>, tri: &[V3<f64>; 3]) -> Exact {
        Exact {
            o,
            d,
            tri: *tri,
            e: None,
        }
    }

    fn values(&mut self) -> &ExactValues {
        self.e.get_or_insert_with(|| {
            test_count!(EXACT_HITS += 1);
            let x = |v: V3<f64>| v.map(Dyadic::from_f64);
            let sub = |p: &[Dyadic; 3], q: &[Dyadic; 3]| [0, 1, 2].map(|k| &p[k] - &q[k]);
            let (o, d) = (x(self.o), x(self.d));
            let [a, b, c] = self.tri.map(x);
            let (w, e1, e2) = (sub(&a, &o), sub(&b, &a), sub(&c, &a));
            ExactValues {
                num: exact_det(&w, &e1, &e2),
                num_u: exact_det(&d, &e2, &w),
                num_v: exact_det(&d, &w, &e1),
                den: exact_det(&d, &e1, &e2),
                a,
                e1,
                e2,
            }
        })
    }

    fn den(&mut self) -> &Dyadic {
        &self.values().den
    }

    /// t rounded to nearest, and a bound on its error (half the larger spacing beside it,
    /// rounded up to the whole spacing).
    fn t(&mut self) -> (f64, f64) {
        let e = self.values();
        let t = Dyadic::quotient(&e.num, &e.den);
        let a = t.abs();
        (t, if a.is_finite() { a.next_up() - a } else { a })
    }

    fn u(&mut self) -> f64 {
        let e = self.values();
        Dyadic::quotient(&e.num_u, &e.den)
    }

    fn v(&mut self) -> f64 {
        let e = self.values();
        Dyadic::quotient(&e.num_v, &e.den)
    }

    /// Coordinate k of the point: (a D + Nu e1 + Nv e2) / D, rounded to nearest.
    fn point(&mut self, k: usize) -> f64 {
        let e = self.values();
        let n = &e.a[k] * &e.den + &e.num_u * &e.e1[k] + &e.num_v * &e.e2[k];
        Dyadic::quotient(&n, &e.den)
    }

    /// Everything exactly (operands outside the filter's range); None when D = 0.
    fn all(&mut self) -> Option<RoundedHit> {
        if self.den().is_zero() {
            return None;
        }
        let (t, t_err) = self.t();
        Some(RoundedHit {
            t,
            t_err,
            u: self.u(),
            v: self.v(),
            point: [0, 1, 2].map(|k| self.point(k)),
        })
    }
}

#[cfg(test)]
mod tests;
