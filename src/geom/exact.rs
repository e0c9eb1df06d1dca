//! Exact predicates on a ray given as numbers: the sign of the Plücker side product of the ray
//! (o, d) with an edge, and where the ray crosses a plane, decided exactly for the float64
//! numbers passed in. Each is a float64 evaluation with a certified error bound first, and
//! exact arithmetic (dyadic numbers, `geom::dyadic`) only when the bound cannot decide
//! (near-degenerate cases).

use super::dyadic::{cmp_fractions, exact3, rdet, Dyadic};
use super::predicates::expansion_safe;
pub use super::real::unit_direction;
use super::real::{times_pow2, V3};
use super::rounded::{rounded_hit, RoundedHit};
use std::cmp::Ordering;

pub(super) const EPS: f64 = f64::EPSILON * 0.5;
/// Shewchuk's bound for a 3×3 determinant whose rows are differences of inputs, relative to
/// its permanent: (7 + 56ε)ε. Rounded up.
pub(crate) const DET_BOUND: f64 = 8.0 * EPS;
/// `plane_t`'s bound on t relative to (pnum + |t| pden) / |den| (derived there).
const T_BOUND: f64 = 9.0 * EPS;
/// Below this permanent, products may underflow and the bound no longer holds: exact.
pub(crate) const TINY: f64 = 1e-250;

fn rat(x: f64) -> Dyadic {
    Dyadic::from_f64(x)
}

fn rsub(a: &[Dyadic; 3], b: &[Dyadic; 3]) -> [Dyadic; 3] {
    [0, 1, 2].map(|k| &a[k] - &b[k])
}

fn sign_of(x: &Dyadic) -> i8 {
    x.signum()
}

#[inline(always)]
pub(super) fn det_perm(a: V3<f64>, b: V3<f64>, c: V3<f64>) -> (f64, f64) {
    let m0 = b[1] * c[2] - b[2] * c[1];
    let m1 = b[0] * c[2] - b[2] * c[0];
    let m2 = b[0] * c[1] - b[1] * c[0];
    let det = a[0] * m0 - a[1] * m1 + a[2] * m2;
    let perm = a[0].abs() * ((b[1] * c[2]).abs() + (b[2] * c[1]).abs())
        + a[1].abs() * ((b[0] * c[2]).abs() + (b[2] * c[0]).abs())
        + a[2].abs() * ((b[0] * c[1]).abs() + (b[1] * c[0]).abs());
    (det, perm)
}

/// The sign of det(d, p − s, q − s): the side of edge p→q seen along the line through s with
/// direction d (positive: counter-clockwise). Zero when the line and the edge's line are
/// coplanar (they meet, or are parallel). Exact.
pub fn side(d: V3<f64>, s: V3<f64>, p: V3<f64>, q: V3<f64>) -> i8 {
    let pv = [0, 1, 2].map(|k| p[k] - s[k]);
    let qv = [0, 1, 2].map(|k| q[k] - s[k]);
    let (det, perm) = det_perm(d, pv, qv);
    let bound = DET_BOUND * perm;
    if perm.is_finite() && perm > TINY {
        if det > bound {
            return 1;
        }
        if -det > bound {
            return -1;
        }
    }
    let (d, s, p, q) = (exact3(d), exact3(s), exact3(p), exact3(q));
    sign_of(&rdet(&d, &rsub(&p, &s), &rsub(&q, &s)))
}

/// The signs of the side products of the line (o, d) with the edges ab, bc, ca of `tri`:
/// `side(d, o, a, b)`, `side(d, o, b, c)`, `side(d, o, c, a)`, each exact and evaluated as
/// [`side`] does, with the differences formed once. Stops early (the third left 0) when the
/// first two have opposite signs: the line then passes beside the triangle whatever the third.
pub fn triangle_sides(d: V3<f64>, o: V3<f64>, tri: &[V3<f64>; 3]) -> [i8; 3] {
    let sub = |p: V3<f64>| [p[0] - o[0], p[1] - o[1], p[2] - o[2]];
    let v = [sub(tri[0]), sub(tri[1]), sub(tri[2])];
    let mut out = [0i8; 3];
    for k in 0..3 {
        let (det, perm) = det_perm(d, v[k], v[(k + 1) % 3]);
        let bound = DET_BOUND * perm;
        out[k] = if perm.is_finite() && perm > TINY && det > bound {
            1
        } else if perm.is_finite() && perm > TINY && -det > bound {
            -1
        } else {
            side(d, o, tri[k], tri[(k + 1) % 3])
        };
        if k == 1 && out[0] * out[1] < 0 {
            break;
        }
    }
    out
}

/// Whether the line (s, d) lies in the plane of triangle (a, b, c), for a line known to meet
/// that plane at a point of the triangle: then it lies in the plane iff d is parallel to it.
pub fn in_plane(d: V3<f64>, a: V3<f64>, b: V3<f64>, c: V3<f64>) -> bool {
    side(d, a, b, c) == 0
}

/// Where the line o + t d crosses the plane of (a, b, c): t = num / den with
/// num = det(a − o, b − a, c − a) and den = d · ((b − a) × (c − a)), evaluated in float64,
/// and a certified bound on its error (what the exact comparisons filter with; the t a query
/// reports is [`triangle_hit`]'s, faithfully rounded).
///
/// d is first scaled by a power of two to a largest component in [1, 2) (exact, and t scales
/// back exactly), so that a tiny or huge direction (1e-300, a denormal, 1e300) neither
/// underflows den to 0 nor overflows it: t is then right, or ±inf where the true t is beyond
/// float64. For other directions the result is the same, bit for bit, as without scaling.
pub fn plane_t(o: V3<f64>, d: V3<f64>, tri: &[V3<f64>; 3]) -> (f64, f64) {
    let (d, e) = unit_direction(d);
    plane_t_unit(o, d, e, tri)
}

/// [`plane_t`] for a direction already scaled: `unit` is d · 2^-e with its largest component
/// in [1, 2) (as [`crate::geom::real::unit_scale`] and [`unit_direction`] scale it; `e` 0
/// where d is zero or not finite). The same bits as `plane_t(o, d, tri)`, without scaling d
/// again for each triangle a ray is tested against.
#[inline]
pub fn plane_t_unit(o: V3<f64>, unit: V3<f64>, e: i32, tri: &[V3<f64>; 3]) -> (f64, f64) {
    // t = num / den and den is linear in d: with d scaled by 2^-e, t comes out scaled by 2^e.
    let (t, err) = plane_t_scaled(o, unit, tri);
    (times_pow2(t, -e), times_pow2(err, -e))
}

/// [`plane_t`] without the scaling. Anchored at the triangle: num = det(a − o, b − a, c − a),
/// whose permanent is |a − o| |edges|², not |a − o|³ as for det(a − o, b − o, c − o), so an
/// origin far from a small triangle leaves the bound (relative to t) near ε over the cosine of
/// the ray's angle to the plane, instead of growing as the distance squared. Each row is one
/// rounded difference of inputs, as in Shewchuk's orient3d: the same bound holds.
// Inlined: as a call from the triangle tests (`Line::crosses_at`), its arguments and
// result went through memory, 6% of the fan's time on bunny's camera (`perf`).
#[inline(always)]
fn plane_t_scaled(o: V3<f64>, d: V3<f64>, tri: &[V3<f64>; 3]) -> (f64, f64) {
    let [a, b, c] = *tri;
    let (w, e1, e2) = (
        [0, 1, 2].map(|k| a[k] - o[k]),
        [0, 1, 2].map(|k| b[k] - a[k]),
        [0, 1, 2].map(|k| c[k] - a[k]),
    );
    let (num, pnum) = det_perm(w, e1, e2);
    let (den, pden) = det_perm(d, e1, e2);
    let t = num / den;
    // The bound, derived (ε = 2^-53; num*, den*, t* the exact values; q = num / den before
    // its rounding to t). Shewchuk's bound gives |num − num*| ≤ δ pnum and |den − den*| ≤
    // δ pden with δ = (7 + 56ε)ε. Then q − t* = (num − num*) / den − t* (den − den*) / den, so
    // |q − t*| (1 − δ pden / |den|) ≤ δ (pnum + |q| pden) / |den|. Asking 64ε pden ≤ |den|
    // (as `narrow::triangle_hit32` asks) keeps δ pden / |den| ≤ 7/64 + O(ε), so |q − t*| ≤
    // 7.86ε (pnum + |q| pden) / |den|. The division's rounding, |t − q| ≤ ε|q|, is at most
    // 0.5ε (pnum + |q| pden) / |den| (a permanent is at least its determinant: the sum is at
    // least 2|q| |den|), so |t − t*| ≤ 8.4ε (pnum + |t| pden) / |den| (|q| ≤ |t| (1 + ε)).
    // `T_BOUND` is 9ε, and the bound's own four roundings (ε each) stay within that margin,
    // so no term is added for them: every part of the formula is needed for it to hold.
    // Without the ask, a line grazing the plane (den a few ε of its permanent: a direction
    // computed to lie along the plane, a ray leaving a hit along its surface) had its t off by
    // up to 53 times the bound then used.
    if !(pnum > TINY && pden > TINY && 8.0 * DET_BOUND * pden <= den.abs()) {
        // Products may have underflowed (or the origin sits on a vertex), or den is too
        // uncertain to divide by: no bound holds.
        return (t, f64::INFINITY);
    }
    let err = T_BOUND * (pnum + t.abs() * pden) / den.abs();
    (t, err)
}

/// The exact t of the line o + t d on the plane of (a, b, c) compared with x: Less when the
/// crossing comes before x. The plane must not be parallel to d.
pub fn cmp_t(o: V3<f64>, d: V3<f64>, tri: &[V3<f64>; 3], x: f64) -> Ordering {
    cmp_t_at(o, d, tri, x, plane_t(o, d, tri))
}

/// [`cmp_t`] given `plane_t(o, d, tri)` (one evaluation for several comparisons).
pub fn cmp_t_at(
    o: V3<f64>,
    d: V3<f64>,
    tri: &[V3<f64>; 3],
    x: f64,
    (t, err): (f64, f64),
) -> Ordering {
    if x == f64::INFINITY {
        return Ordering::Less;
    }
    if x == f64::NEG_INFINITY {
        return Ordering::Greater;
    }
    if err.is_finite() && t.is_finite() {
        if t + err < x {
            return Ordering::Less;
        }
        if t - err > x {
            return Ordering::Greater;
        }
    }
    let [a, b, c] = *tri;
    if x == 0.0 && [a, b, c, o].iter().flatten().all(|&v| expansion_safe(v)) {
        // The sign of t = num / den from two adaptive predicates, not rationals: an origin on
        // the plane (a ray started from a hit, a touch at the origin) is the common case here.
        // num = det(a − o, b − o, c − o) = −orient(a, b, c, o); den = side(d, a, b, c).
        let den = side(d, a, b, c);
        if den == 0 {
            return Ordering::Greater;
        }
        return (-(orient_sign(a, b, c, o) as i32) * den as i32).cmp(&0);
    }
    let (o, d) = (exact3(o), exact3(d));
    let [a, b, c] = tri.map(exact3);
    let num = rdet(&rsub(&a, &o), &rsub(&b, &o), &rsub(&c, &o));
    let den = rdet(&d, &rsub(&b, &a), &rsub(&c, &a));
    if den.is_zero() {
        return Ordering::Greater;
    }
    cmp_fractions(&num, &den, &rat(x), &rat(1.0))
}

/// Which of two triangles' planes the line o + t d crosses first: the sign of t1 − t2,
/// exactly. Neither plane may be parallel to d (a triangle met at one point is not).
pub fn cmp_plane_t(o: V3<f64>, d: V3<f64>, tri1: &[V3<f64>; 3], tri2: &[V3<f64>; 3]) -> Ordering {
    cmp_plane_t_at(o, d, tri1, tri2, plane_t(o, d, tri1), plane_t(o, d, tri2))
}

/// [`cmp_plane_t`] given `plane_t` of both triangles (computed once for several comparisons).
pub fn cmp_plane_t_at(
    o: V3<f64>,
    d: V3<f64>,
    tri1: &[V3<f64>; 3],
    tri2: &[V3<f64>; 3],
    (t1, e1): (f64, f64),
    (t2, e2): (f64, f64),
) -> Ordering {
    if [t1, e1, t2, e2].iter().all(|x| x.is_finite()) {
        if t1 + e1 < t2 - e2 {
            return Ordering::Less;
        }
        if t1 - e1 > t2 + e2 {
            return Ordering::Greater;
        }
    }
    if one_flat_plane(tri1, tri2) {
        // Both in the plane x_k = c, which the line crosses at one point (not parallel to
        // it): t1 = t2 exactly. Coplanar pieces (a box standing on a floor, a rug on it) tie
        // wherever a ray meets both, and each tie cost the rationals ~5,000 instructions.
        return Ordering::Equal;
    }
    test_count!(PLANE_T_RATIONALS += 1);
    let (o, d) = (exact3(o), exact3(d));
    let exact_t = |tri: &[V3<f64>; 3]| {
        let [a, b, c] = tri.map(exact3);
        let num = rdet(&rsub(&a, &o), &rsub(&b, &o), &rsub(&c, &o));
        let den = rdet(&d, &rsub(&b, &a), &rsub(&c, &a));
        (num, den)
    };
    let ((n1, d1), (n2, d2)) = (exact_t(tri1), exact_t(tri2));
    cmp_fractions(&n1, &d1, &n2, &d2)
}

test_count!(
    /// Orders of two crossings that `cmp_plane_t_at` left to the rationals on this thread.
    PLANE_T_RATIONALS,
    plane_t_rationals
);

/// Whether the six corners share one coordinate exactly (both triangles lie in one plane
/// x_k = c).
#[inline]
fn one_flat_plane(tri1: &[V3<f64>; 3], tri2: &[V3<f64>; 3]) -> bool {
    (0..3).any(|k| {
        let c = tri1[0][k];
        tri1.iter().chain(tri2).all(|p| p[k] == c)
    })
}

/// Whether the line o + t d crosses the plane of `tri` (which it meets at one point)
/// strictly beyond where it crosses the plane of `from`, the triangle a ray started from a
/// hit leaves ([`crate::geom::ray::Leaving`]); when the line is parallel to `from`'s plane,
/// strictly beyond its origin (t > 0). `dir` is d scaled by a power of two (for the sign of
/// the parallel test). Exact.
pub fn beyond(
    o: V3<f64>,
    d: V3<f64>,
    dir: V3<f64>,
    from: &[V3<f64>; 3],
    tri: &[V3<f64>; 3],
) -> bool {
    if tri == from {
        // The same plane: crossed at the same point, not beyond it (and no rationals).
        return false;
    }
    if in_plane(dir, from[0], from[1], from[2]) {
        cmp_t(o, d, tri, 0.0) == Ordering::Greater
    } else {
        cmp_plane_t(o, d, tri, from) == Ordering::Greater
    }
}

/// The ray's hit on one of the caller's triangles, which its line meets at one point: t, u, v
/// and the point, each within one ulp of the exact value ([`super::rounded`]). NaN everywhere
/// should the line be parallel to the triangle's plane after all (no caller reaches that).
pub fn triangle_hit(o: V3<f64>, d: V3<f64>, tri: &[V3<f64>; 3]) -> RoundedHit {
    rounded_hit(o, d, tri).unwrap_or(RoundedHit {
        t: f64::NAN,
        t_err: f64::INFINITY,
        u: f64::NAN,
        v: f64::NAN,
        point: [f64::NAN; 3],
    })
}

/// Where point x lies against the plane of (a, b, c): the exact sign of orient (tetrace's
/// convention, `predicates::orient`).
pub fn orient_sign(a: V3<f64>, b: V3<f64>, c: V3<f64>, x: V3<f64>) -> i8 {
    let o = super::predicates::orient(a, b, c, x);
    if o > 0.0 {
        1
    } else if o < 0.0 {
        -1
    } else {
        0
    }
}

/// The 2×2 filter: (a − b) m − (c − e) n has error below 3 ε (|p| + |q|) (ε = 2^-53).
const DET2_BOUND: f64 = 2.0 * f64::EPSILON;
/// Below this permanent the products' underflow (3 · 2^-1075 at most) could exceed the bound.
const DET2_TINY: f64 = 1e-304;

/// The exact sign of (a − b)·m − (c − e)·n: the float filter; then, where every operation
/// was exact (grid-aligned rays: the zeros of rays through edges and corners), the exact
/// products compared; else rationals.
#[inline]
pub fn sign2(a: f64, b: f64, m: f64, c: f64, e: f64, n: f64) -> i32 {
    let (ab, ce) = (a - b, c - e);
    let (p, q) = (ab * m, ce * n);
    let det = p - q;
    let perm = p.abs() + q.abs();
    if perm.is_finite() && perm > DET2_TINY {
        let bound = DET2_BOUND * perm;
        if det > bound {
            return 1;
        }
        if -det > bound {
            return -1;
        }
    }
    if let (Some(p), Some(q)) = (exact_product(a, b, ab, m), exact_product(c, e, ce, n)) {
        return (p > q) as i32 - (p < q) as i32;
    }
    sign_of(&((rat(a) - rat(b)) * rat(m) - (rat(c) - rat(e)) * rat(n))) as i32
}

/// (a − b)·m when both the difference `ab` and the product round nothing (TwoSum's error
/// and the fused product's error are exact, the latter while the factors are far from
/// underflow); None otherwise.
#[inline]
fn exact_product(a: f64, b: f64, ab: f64, m: f64) -> Option<f64> {
    let nb = -b;
    let bv = ab - a;
    let av = ab - bv;
    let err = (a - av) + (nb - bv);
    let p = ab * m;
    let far = |x: f64| x == 0.0 || x.abs() >= FAR_FROM_UNDERFLOW;
    (err == 0.0 && p.is_finite() && far(ab) && far(m) && ab.mul_add(m, -p) == 0.0).then_some(p)
}

/// Factors at least this large have a product whose rounding error is a float (not lost
/// below the subnormals): 2^-480.
const FAR_FROM_UNDERFLOW: f64 = 3.2e-145;

#[cfg(test)]
mod tests {
    use super::*;
    use num_rational::BigRational;
    use num_traits::{Signed, ToPrimitive, Zero};

    // The tests' judge: rationals, apart from the dyadic numbers the code uses.
    fn rat(x: f64) -> BigRational {
        BigRational::from_float(x).unwrap()
    }

    fn rat3(v: V3<f64>) -> [BigRational; 3] {
        v.map(rat)
    }

    fn rsub(a: &[BigRational; 3], b: &[BigRational; 3]) -> [BigRational; 3] {
        [0, 1, 2].map(|k| &a[k] - &b[k])
    }

    fn rdet(a: &[BigRational; 3], b: &[BigRational; 3], c: &[BigRational; 3]) -> BigRational {
        &a[0] * (&b[1] * &c[2] - &b[2] * &c[1]) - &a[1] * (&b[0] * &c[2] - &b[2] * &c[0])
            + &a[2] * (&b[0] * &c[1] - &b[1] * &c[0])
    }

    /// The exact t where the line o + t d crosses the plane of `tri`; None where d is
    /// parallel to it.
    fn exact_plane_t(o: V3<f64>, d: V3<f64>, tri: &[V3<f64>; 3]) -> Option<BigRational> {
        let (ro, rd) = (rat3(o), rat3(d));
        let [a, b, c] = tri.map(rat3);
        let den = rdet(&rd, &rsub(&b, &a), &rsub(&c, &a));
        (!den.is_zero()).then(|| rdet(&rsub(&a, &ro), &rsub(&b, &a), &rsub(&c, &a)) / den)
    }

    /// A triangle's edges from its first corner, e1 and e2, and their cross product (its
    /// normal, not of unit length), each rounded as written.
    fn edges_and_normal(tri: &[V3<f64>; 3]) -> (V3<f64>, V3<f64>, V3<f64>) {
        let e1 = [0, 1, 2].map(|k| tri[1][k] - tri[0][k]);
        let e2 = [0, 1, 2].map(|k| tri[2][k] - tri[0][k]);
        let n = [
            e1[1] * e2[2] - e1[2] * e2[1],
            e1[2] * e2[0] - e1[0] * e2[2],
            e1[0] * e2[1] - e1[1] * e2[0],
        ];
        (e1, e2, n)
    }

    fn sign_of(x: &BigRational) -> i8 {
        if x.is_zero() {
            0
        } else if x.is_positive() {
            1
        } else {
            -1
        }
    }

    /// The filtered sign equals the rational one, on near-degenerate edges at many scales.
    #[test]
    fn side_is_exact() {
        let mut x = 0x9e37_79b9_7f4a_7c15u64;
        let mut f = move || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut zeros = 0;
        for k in 0..20_000 {
            let scale = [1.0, 1e-20, 1e7, 1e30][k % 4];
            let off = [0.0, 1e4, -1e7, 3.0][k / 4 % 4];
            let pt = |f: &mut dyn FnMut() -> f64| [0, 1, 2].map(|_| off + scale * (f() - 0.5));
            let (s, p) = (pt(&mut f), pt(&mut f));
            let d = [f() - 0.5, f() - 0.5, f() - 0.5];
            // q on the plane through the line and p (often exactly: dyadic combinations).
            let (a, b) = ((f() * 8.0).floor() / 4.0, (f() * 8.0).floor() / 4.0);
            let q = if k % 3 == 0 {
                pt(&mut f)
            } else {
                [0, 1, 2].map(|i| s[i] + a * (p[i] - s[i]) + b * d[i] * scale)
            };
            let exact = {
                let (dr, sr, pr, qr) = (rat3(d), rat3(s), rat3(p), rat3(q));
                sign_of(&rdet(&dr, &rsub(&pr, &sr), &rsub(&qr, &sr)))
            };
            zeros += (exact == 0) as usize;
            assert_eq!(side(d, s, p, q), exact, "case {k}");
            assert_eq!(side(d, s, q, p), -exact, "case {k}");
        }
        assert!(zeros > 100, "the cases include exact zeros ({zeros})");
    }

    /// Below `TINY` the float64 products underflow, their roundings are no longer relative,
    /// and the filter's bound (itself 0 there) says nothing: the sign must come from the exact
    /// arithmetic. Built so that the float64 determinant has the wrong sign: with the
    /// smallest subnormal q as every component of d and the minors (9/16, 9/16, -11/8)
    /// (exact in float64), each product of the determinant rounds to a whole multiple of q:
    /// q + q - q = q > 0, where the true value is (9/16 + 9/16 - 22/16) q = -q/4.
    #[test]
    fn side_is_exact_where_its_products_underflow() {
        let q = f64::from_bits(1);
        let d = [q, q, q];
        let (s, p, r) = ([0.0; 3], [1.0, -1.0, 0.0], [0.0, -1.375, -0.5625]);
        let exact = |d: V3<f64>, s: V3<f64>, p: V3<f64>, r: V3<f64>| {
            sign_of(&rdet(
                &rat3(d),
                &rsub(&rat3(p), &rat3(s)),
                &rsub(&rat3(r), &rat3(s)),
            ))
        };
        // The case keeps its teeth: the float64 determinant is positive, its permanent below
        // TINY and finite, the bound 0, and the true sign negative.
        let (det, perm) = det_perm(d, p, r);
        assert!(det > 0.0 && perm.is_finite() && perm < TINY && DET_BOUND * perm == 0.0);
        assert_eq!(exact(d, s, p, r), -1);
        assert_eq!(side(d, s, p, r), -1);
        assert_eq!(side(d, s, r, p), 1);
        // triangle_sides, whose own filter shares the guard, on a triangle with that edge
        // first: each edge's sign is the exact one (the third is 0 after an early stop).
        let sides_are_exact = |d: V3<f64>, s: V3<f64>, tri: &[V3<f64>; 3], case: usize| {
            let sides = triangle_sides(d, s, tri);
            for e in 0..3 {
                let want = exact(d, s, tri[e], tri[(e + 1) % 3]);
                let stopped = e == 2 && sides[0] * sides[1] < 0 && sides[2] == 0;
                assert!(sides[e] == want || stopped, "case {case} edge {e}");
            }
            sides
        };
        assert_eq!(sides_are_exact(d, s, &[p, r, [2.0, 0.5, 1.0]], 0)[0], -1);
        // The same at random: directions of one to three times q against points on a 1/16
        // grid near 1, so that each product's rounding (up to q/2) is often as large as the
        // determinant; every sign judged by rationals.
        let mut x = 0x6c07_8965_d2b4_1f3bu64;
        let mut f = move || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x
        };
        let mut wrong_float_signs = 0;
        for k in 0..5_000 {
            let small =
                |bits: u64| f64::from_bits(bits % 3 + 1) * if bits & 64 == 0 { 1.0 } else { -1.0 };
            let d = [small(f()), small(f()), small(f())];
            let near = |bits: u64| ((bits % 33) as f64 - 16.0) / 16.0;
            let (s, p, r) = (
                [near(f()), near(f()), near(f())],
                [near(f()), near(f()), near(f())],
                [near(f()), near(f()), near(f())],
            );
            let want = exact(d, s, p, r);
            assert_eq!(side(d, s, p, r), want, "case {k}");
            let (det, _) = det_perm(
                d,
                [0, 1, 2].map(|i| p[i] - s[i]),
                [0, 1, 2].map(|i| r[i] - s[i]),
            );
            wrong_float_signs += (det.signum() * want as f64 <= 0.0 && det != 0.0) as usize;
            sides_are_exact(d, s, &[p, r, s.map(|c| c + 0.5)], k);
        }
        // Where the float64 sign is wrong, only the guard keeps the filter from answering:
        // the random cases must include such signs, or they test no more than the one above.
        assert!(
            wrong_float_signs > 0,
            "{wrong_float_signs} float64 signs were wrong"
        );
    }

    /// `triangle_sides` is `side` on the three edges (up to its early stop), on triangles near
    /// the line and on it, and `cmp_plane_t` orders two planes' crossings as rationals do.
    #[test]
    fn triangle_sides_and_plane_order_are_exact() {
        let mut x = 0x2545_f491_4f6c_dd1du64;
        let mut f = move || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            ((x >> 11) as f64 / (1u64 << 53) as f64 * 16.0).round() / 16.0
        };
        let (mut zeros, mut ties) = (0, 0);
        for k in 0..20_000 {
            let scale = [1.0, 1e-200, 1e200][k % 3];
            let o = [f(), f(), f()].map(|v| v * scale);
            let d = [f() - 0.5, f() - 0.5, f() - 0.5];
            if d == [0.0; 3] {
                continue;
            }
            // Corners on the line, on lines through it, or anywhere: many exact zeros.
            let on = |f: &mut dyn FnMut() -> f64| {
                let t = f();
                [0, 1, 2].map(|i| o[i] + t * d[i] * scale)
            };
            let any = |f: &mut dyn FnMut() -> f64| [f(), f(), f()].map(|v| v * scale);
            let tri = [
                if k % 4 == 0 { on(&mut f) } else { any(&mut f) },
                any(&mut f),
                if k % 5 == 0 { on(&mut f) } else { any(&mut f) },
            ];
            let want = [0, 1, 2].map(|e| side(d, o, tri[e], tri[(e + 1) % 3]));
            let got = triangle_sides(d, o, &tri);
            zeros += want.contains(&0) as usize;
            if want[0] * want[1] < 0 {
                assert_eq!(&got[..2], &want[..2], "case {k}");
            } else {
                assert_eq!(got, want, "case {k}");
            }
            // Two planes: the other one through the same crossing half the time.
            let tri2 = [
                tri[0],
                any(&mut f),
                if k % 2 == 0 { tri[2] } else { any(&mut f) },
            ];
            let parallel = |t: &[V3<f64>; 3]| {
                let (r, e1, e2) = (rat3(d), rat3(t[0]), rat3(t[1]));
                rdet(&r, &rsub(&e2, &e1), &rsub(&rat3(t[2]), &e1)).is_zero()
            };
            if parallel(&tri) || parallel(&tri2) {
                continue;
            }
            let exact_t = |t: &[V3<f64>; 3]| exact_plane_t(o, d, t).expect("not parallel");
            let order = exact_t(&tri).cmp(&exact_t(&tri2));
            ties += order.is_eq() as usize;
            assert_eq!(cmp_plane_t(o, d, &tri, &tri2), order, "case {k}");
        }
        assert!(
            zeros > 1000 && ties > 100,
            "{zeros} zero sides, {ties} equal crossings"
        );
    }

    /// Two triangles in one plane x_k = c (a box on a floor) tie wherever the line crosses
    /// them, and `cmp_plane_t` says so without the rationals; lift one corner of the second by
    /// an ulp and the rationals decide, as they order the crossings. Judged by BigRational.
    #[test]
    fn flat_planes_tie_without_rationals() {
        let mut rng = crate::rng::Rng::new(0xf1a7);
        let (mut ties, mut lifted, mut rationals_for_lifted) = (0, 0, 0);
        for i in 0..4000 {
            let k = rng.below(3);
            let c = [0.0, -0.0, 548.8, -1e-3, 1e30][rng.below(5)];
            let corner = |rng: &mut crate::rng::Rng| {
                let mut p = [0, 1, 2].map(|_| (rng.f() - 0.5) * 1000.0);
                p[k] = c;
                p
            };
            let tri1 = [corner(&mut rng), corner(&mut rng), corner(&mut rng)];
            let mut tri2 = [corner(&mut rng), corner(&mut rng), corner(&mut rng)];
            let lift = i % 2 == 1;
            if lift {
                // Off the plane by an ulp: near the shared line the two crossings' intervals
                // overlap, and only exact arithmetic orders them.
                let x = tri2[0][k];
                tri2[0][k] = if x == 0.0 {
                    1e-300
                } else {
                    f64::from_bits(x.to_bits() + 1)
                };
            }
            let o = [0, 1, 2].map(|_| (rng.f() - 0.5) * 4000.0);
            // Through a point of the plane x_k = c: where a lifted plane lies within an ulp of
            // it, so the float crossings cannot be told apart.
            let target = corner(&mut rng);
            let d = [0, 1, 2].map(|j| target[j] - o[j]);
            let (Some(t1), Some(t2)) = (exact_plane_t(o, d, &tri1), exact_plane_t(o, d, &tri2))
            else {
                continue;
            };
            let before = plane_t_rationals();
            assert_eq!(
                cmp_plane_t(o, d, &tri1, &tri2),
                t1.cmp(&t2),
                "case {i}: {tri1:?} {tri2:?} {o:?} {d:?}"
            );
            let used = plane_t_rationals() - before;
            if lift {
                lifted += 1;
                rationals_for_lifted += used;
            } else {
                assert_eq!(t1, t2, "case {i}: one plane, one crossing");
                assert_eq!(used, 0, "case {i}: a flat tie went to the rationals");
                ties += 1;
            }
        }
        // Ties on every constant, and lifted pairs that the float intervals could not order
        // (the ones that tell an exact tie from a near one).
        assert!(
            ties > 1500 && rationals_for_lifted > 100,
            "{ties} ties, {rationals_for_lifted} of {lifted} lifted pairs ordered exactly"
        );
    }

    #[test]
    fn t_comparison_is_exact() {
        let tri = [[1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [1.0, 0.0, 1.0]];
        let o = [0.0, 0.25, 0.25];
        let d = [3.0, 0.0, 0.0];
        // t = 1/3 exactly: not a float.
        let third = 1.0 / 3.0;
        let big = BigRational::new(1.into(), 3.into());
        let expect = big.cmp(&rat(third));
        assert_eq!(cmp_t(o, d, &tri, third), expect);
        assert_eq!(cmp_t(o, d, &tri, 0.5), Ordering::Less);
        assert_eq!(cmp_t(o, d, &tri, 0.2), Ordering::Greater);
        // 1/3 rounded either way is faithful; u = v = 1/4 and the point are floats: exact.
        let h = triangle_hit(o, d, &tri);
        assert!(h.t == third || h.t == third.next_down() || h.t == third.next_up());
        assert!(h.t_err <= third.next_up() - third);
        assert_eq!((h.u, h.v, h.point), (0.25, 0.25, [1.0, 0.25, 0.25]));
    }

    /// `plane_t`'s error bound holds, judged by BigRational: |t − t*| ≤ err wherever err is
    /// finite (and `cmp_t` orders t* against points within it exactly), where its two terms
    /// are largest: the origin a hair off the plane far from the triangle (num cancels),
    /// directions that graze the plane (den cancels), both, and ordinary rays, at scales from
    /// 2^-40 to 2^40 with the triangle away from the origin (every difference rounds). Cases whose error reaches a sixteenth of the bound are
    /// counted, and some must be: a bound cut by that much (a term dropped, a sign flipped)
    /// fails there, and one grown past 16 times the errors it bounds (a term replaced by a
    /// constant, a permanent added instead of multiplied) no longer filters.
    #[test]
    fn plane_t_error_is_within_its_bound() {
        let mut rng = crate::rng::Rng::new(0xb0b0_5eed);
        let (mut checked, mut tight, mut worst) = (0, 0, 0f64);
        for case in 0..20_000 {
            let family = case % 4;
            let s = 2f64.powi(rng.below(81) as i32 - 40);
            let off = [0, 1, 2].map(|_| (rng.f() - 0.5) * 1000.0 * s);
            let p = |rng: &mut crate::rng::Rng| [0, 1, 2].map(|k| off[k] + (rng.f() - 0.5) * s);
            let tri = [p(&mut rng), p(&mut rng), p(&mut rng)];
            let (e1, e2, n) = edges_and_normal(&tri);
            let len = n.iter().map(|x| x * x).sum::<f64>().sqrt();
            if len == 0.0 {
                continue;
            }
            let n = n.map(|x| x / len);
            // A point near the plane, then a hair off it (num cancels) or far off it.
            let (u, v) = (rng.f() * 4.0 - 2.0, rng.f() * 4.0 - 2.0);
            let q = [0, 1, 2].map(|k| tri[0][k] + u * e1[k] + v * e2[k]);
            let hair = s * 2f64.powi(-(rng.below(40) as i32) - 10);
            let away = if family % 2 == 0 {
                hair
            } else {
                s * (1.0 + rng.f())
            };
            let o = [0, 1, 2].map(|k| q[k] + n[k] * away);
            // Along the plane with a little of the normal (den cancels), or anywhere.
            let along = [0, 1, 2].map(|k| e1[k] * (rng.f() - 0.5) + e2[k] * (rng.f() - 0.5));
            let tilt = 2f64.powi(-(rng.below(40) as i32) - 4);
            let d = if family >= 2 {
                [0, 1, 2].map(|k| along[k] / s - n[k] * tilt)
            } else {
                [0, 1, 2].map(|_| rng.f() - 0.5)
            };
            let (t, err) = plane_t(o, d, &tri);
            if !err.is_finite() {
                continue;
            }
            let exact = exact_plane_t(o, d, &tri)
                .unwrap_or_else(|| panic!("case {case}: a finite bound on a parallel plane"));
            let error = (rat(t) - &exact).abs();
            assert!(
                error <= rat(err),
                "family {family}, case {case}: t {t:e} is {} from the exact t, bound {err:e}",
                error
            );
            // Within the bound the filter cannot answer: cmp_t must take the exact path.
            for x in [t - err / 2.0, t, t + err / 2.0] {
                assert_eq!(
                    cmp_t(o, d, &tri, x),
                    exact.cmp(&rat(x)),
                    "family {family}, case {case}: t {t:e} ± {err:e} against {x:e}"
                );
            }
            checked += 1;
            if err > 0.0 {
                let share = (&error / rat(err)).to_f64().unwrap_or(0.0);
                worst = worst.max(share);
                tight += usize::from(share * 16.0 >= 1.0);
            }
        }
        assert!(
            checked > 15_000 && tight > 0,
            "{checked} checked, {tight} within 16x of the bound (worst {worst})"
        );
    }

    /// `plane_t`'s bound holds on lines that lie along the plane up to rounding: a direction
    /// computed to lie in it (a random vector less its normal component, rounded) tilted by a
    /// normal component of 10^-18 to 10^-12 of its length, from a point of the triangle
    /// computed as a + u e1 + v e2 (a ray leaving a hit along the surface) or from far along
    /// the line. There den is within a few ε of its permanent, and the computed den can be
    /// several times the exact one: a bound that divides by it without asking it to be
    /// certain (`8 DET_BOUND pden ≤ |den|`) was exceeded on 27 of these 20,000 lines, by up
    /// to 53 times. Judged by BigRational, with `cmp_t` at t ± 2 err (where the bound alone
    /// decides); enough of the lines tilted the most must keep a finite bound.
    #[test]
    fn plane_t_bound_holds_on_lines_along_the_plane() {
        let mut rng = crate::rng::Rng::new(0x91a2_e5ed);
        let (mut finite, mut infinite, mut exceeded) = (0, 0, vec![]);
        for case in 0..20_000 {
            let mut p = || [0, 1, 2].map(|_| rng.f() * 2.0 - 1.0);
            let tri = [p(), p(), p()];
            let [a, b, c] = tri;
            let (e1, e2, n) = edges_and_normal(&tri);
            let nn: f64 = n.iter().map(|x| x * x).sum();
            if nn == 0.0 {
                continue;
            }
            let w = p();
            let along = (0..3).map(|k| w[k] * n[k]).sum::<f64>() / nn;
            let tilt =
                10f64.powf(-12.0 - 6.0 * rng.f()) * if rng.below(2) == 0 { 1.0 } else { -1.0 };
            let d = [0, 1, 2].map(|k| w[k] - along * n[k] + tilt * n[k]);
            let o = if case % 2 == 0 {
                let (u, v) = (rng.f() * 0.5, rng.f() * 0.5);
                [0, 1, 2].map(|k| a[k] + u * e1[k] + v * e2[k])
            } else {
                let far = 10f64.powf(6.0 * rng.f() - 3.0);
                [0, 1, 2].map(|k| (a[k] + b[k] + c[k]) / 3.0 - far * d[k])
            };
            let Some(exact) = exact_plane_t(o, d, &tri) else {
                continue;
            };
            let (t, err) = plane_t(o, d, &tri);
            if !err.is_finite() {
                infinite += 1;
                continue;
            }
            finite += usize::from(tilt.abs() > 1e-14);
            // Counted, not asserted at once, so that a failure says how many and how far.
            let share = ((rat(t) - &exact).abs() / rat(err))
                .to_f64()
                .unwrap_or(f64::INFINITY);
            let wrong = [t - 2.0 * err, t + 2.0 * err]
                .iter()
                .any(|&x| cmp_t(o, d, &tri, x) != exact.cmp(&rat(x)));
            if share > 1.0 || wrong {
                exceeded.push((case, share));
            }
        }
        assert!(
            exceeded.is_empty(),
            "{} lines with t beyond its bound or misordered (case, error / bound), the worst {:?}, the first {:?}",
            exceeded.len(),
            exceeded.iter().map(|e| e.1).fold(0f64, f64::max),
            &exceeded[..exceeded.len().min(5)]
        );
        assert!(
            finite > 3_000 && infinite > 0,
            "{finite} finite bounds on lines tilted by more than 1e-14, {infinite} infinite"
        );
    }

    /// A crossing just below float64's largest t, with a tiny direction: `plane_t` finds t
    /// on the direction scaled to unit size and scales it back, where a float64 t a few ulps
    /// above the exact one can overflow to ∞ while its bound stays finite. Against x = MAX
    /// (a ray's tmax), `cmp_t` must then decide exactly (the exact t is below x); read as a
    /// number, the overflowed t would put the crossing beyond x. Rays from 0 along d 2^-1022
    /// to a point 4 d (1 − j 2^-54) of a random triangle's plane, judged by BigRational;
    /// cases where the float t overflowed and the exact one did not are counted.
    #[test]
    fn crossings_whose_float_t_overflows_are_compared_exactly() {
        let mut rng = crate::rng::Rng::new(0x7a11_0f10);
        let (mut overflowed, mut below_max) = (0, 0);
        for case in 0..20_000 {
            let unit = [0, 1, 2].map(|_| (rng.f() - 0.5) * 2.0);
            let m = unit.iter().fold(0f64, |m, x| m.max(x.abs()));
            if m == 0.0 {
                continue;
            }
            // Largest component in [1, 2), as plane_t scales it (exactly: a power of two).
            let d = unit.map(|x| x * 2f64.powi(-crate::geom::real::exponent(m)));
            let j = 1 + rng.below(16) as i32;
            let p = d.map(|x| 4.0 * x * (1.0 - j as f64 * 2f64.powi(-54)));
            let spread = |rng: &mut crate::rng::Rng| [0, 1, 2].map(|k| p[k] + rng.f() - 0.5);
            let (b, c) = (spread(&mut rng), spread(&mut rng));
            // The triangle has p as a corner, so the exact t is p's: about 4 (1 − j 2^-54)
            // along d, 2^1022 times that along the tiny direction.
            let tri = [p, b, c];
            let tiny = d.map(|x| x * 2f64.powi(-1022));
            let o = [0.0; 3];
            let Some(exact) = exact_plane_t(o, tiny, &tri) else {
                continue;
            };
            let (t, err) = plane_t(o, tiny, &tri);
            let max = rat(f64::MAX);
            if t == f64::INFINITY && err.is_finite() && exact < max {
                overflowed += 1;
            }
            below_max += usize::from(exact < max);
            assert_eq!(
                cmp_t(o, tiny, &tri, f64::MAX),
                exact.cmp(&max),
                "case {case}: float t {t:e}, bound {err:e}"
            );
        }
        assert!(
            overflowed > 0 && below_max > 1000,
            "{overflowed} float t overflowed below MAX, {below_max} exact t below MAX"
        );
    }

    /// `plane_t`'s bound is relative to its permanents, and below `TINY` their products may
    /// have underflowed: its guard then gives no bound (an infinite one), and `cmp_t` decides
    /// with rationals. Three families where the float64 t is off by far more than the
    /// unguarded formula would claim: a triangle 2^-528 across seen from 1 away (both
    /// permanents below TINY), the same seen from 2^300 away (only the denominator's), and an
    /// ordinary triangle whose corner a is a few subnormals from the origin (only the
    /// numerator's). Each t is compared with points just either side of the float64 one,
    /// judged by BigRational.
    #[test]
    fn plane_t_is_exact_where_its_products_underflow() {
        let mut rng = crate::rng::Rng::new(0x00f1_00d5);
        let mut misleading = [0usize; 3];
        for case in 0..6000 {
            let family = case % 3;
            let unit = |rng: &mut crate::rng::Rng| [0, 1, 2].map(|_| 1.0 + rng.f());
            let d = unit(&mut rng).map(|x| if rng.chance(0.5) { x } else { -x } * 0.75);
            let tiny =
                |rng: &mut crate::rng::Rng| [0, 1, 2].map(|_| (rng.f() - 0.5) * 2f64.powi(-528));
            let far = if family == 1 { 2f64.powi(300) } else { 1.0 };
            let o = if family == 2 {
                [0.0; 3]
            } else {
                [0, 1, 2].map(|_| (rng.f() - 0.5) * far)
            };
            let tri = if family < 2 {
                // Near 0, seen from o.
                [tiny(&mut rng), tiny(&mut rng), tiny(&mut rng)]
            } else {
                // Corner a a few subnormals from the origin (at 0); b and c ordinary.
                let off = |rng: &mut crate::rng::Rng| {
                    f64::from_bits(rng.below(6) as u64) * if rng.chance(0.5) { 1.0 } else { -1.0 }
                };
                let a = [0, 1, 2].map(|k| o[k] + off(&mut rng));
                let (b, c) = (unit(&mut rng), unit(&mut rng).map(|x| -x));
                [a, b, c]
            };
            let Some(exact_t) = exact_plane_t(o, d, &tri) else {
                continue;
            };
            let (t, _) = plane_t(o, d, &tri);
            // What the bound would be without the guard: the formula, evaluated anyway.
            let w = [0, 1, 2].map(|k| tri[0][k] - o[k]);
            let e1 = [0, 1, 2].map(|k| tri[1][k] - tri[0][k]);
            let e2 = [0, 1, 2].map(|k| tri[2][k] - tri[0][k]);
            let ((_, pnum), (den_f, pden)) = (det_perm(w, e1, e2), det_perm(d, e1, e2));
            let unguarded = T_BOUND * (pnum + t.abs() * pden) / den_f.abs();
            if t.is_finite() && (rat(t) - &exact_t).abs() > rat(unguarded) {
                misleading[family] += 1;
            }
            for k in [2, 6, 12, 24, 40] {
                for x in [t * (1.0 + 2f64.powi(-k)), t * (1.0 - 2f64.powi(-k)), t] {
                    if x == 0.0 || !x.is_finite() {
                        continue;
                    }
                    assert_eq!(
                        cmp_t(o, d, &tri, x),
                        exact_t.cmp(&rat(x)),
                        "family {family}, case {case}: t {t:e} against {x:e}"
                    );
                }
            }
        }
        // Every family has cases where the unguarded bound would have been wrong.
        assert!(
            misleading.iter().all(|&m| m > 100),
            "cases whose float t lies outside the unguarded bound: {misleading:?}"
        );
    }

    /// `cmp_t` against 0 (its predicate path) and `beyond` agree with rationals where the
    /// origin lies on the plane, near it, or the line is parallel to the plane left.
    #[test]
    fn zero_crossings_and_beyond_are_exact() {
        let mut x = 0x853c_49e6_748f_ea9bu64;
        let mut f = move || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            ((x >> 11) as f64 / (1u64 << 53) as f64 * 8.0).round() / 8.0 - 0.5
        };
        let (mut on_plane, mut parallel) = (0, 0);
        for k in 0..20_000 {
            // Powers of two keep every relation exact; the tiny and huge scales are where the
            // adaptive predicates would underflow or overflow (the rationals must take over).
            let scale = [1.0, f64::powi(2.0, -1000), f64::powi(2.0, 900)][k % 3];
            let p = |f: &mut dyn FnMut() -> f64| [f() * scale, f() * scale, f() * scale];
            let tri = [p(&mut f), p(&mut f), p(&mut f)];
            // The origin on the triangle's plane (dyadic weights: exactly), or anywhere.
            let (a, b) = (f(), f());
            let o = if k % 2 == 0 {
                [0, 1, 2]
                    .map(|i| tri[0][i] + a * (tri[1][i] - tri[0][i]) + b * (tri[2][i] - tri[0][i]))
            } else {
                p(&mut f)
            };
            // Some directions along an edge of the plane left (parallel to it).
            let d = if k % 7 == 0 {
                [0, 1, 2].map(|i| tri[1][i] - tri[0][i])
            } else {
                [f(), f(), f()]
            };
            let other = [p(&mut f), p(&mut f), p(&mut f)];
            if d == [0.0; 3] {
                continue;
            }
            let Some(t_other) = exact_plane_t(o, d, &other) else {
                continue;
            };
            let zero = BigRational::zero();
            if let Some(t) = exact_plane_t(o, d, &tri) {
                on_plane += t.is_zero() as usize;
                assert_eq!(cmp_t(o, d, &tri, 0.0), t.cmp(&zero), "case {k}");
                assert_eq!(beyond(o, d, d, &tri, &other), t_other > t, "case {k}");
            } else {
                parallel += 1;
                assert_eq!(beyond(o, d, d, &tri, &other), t_other > zero, "case {k}");
            }
            assert!(!beyond(o, d, d, &tri, &tri), "case {k}");
        }
        assert!(
            on_plane > 1000 && parallel > 500,
            "{on_plane} on the plane, {parallel} parallel"
        );
    }

    /// `sign2` where both factors of a product are small (below `FAR_FROM_UNDERFLOW`): the
    /// product lands among the subnormals, and its rounding error, below half of 2^-1074, is
    /// lost too, so the fused product's zero error no longer proves the product exact. Two
    /// products that differ only below the subnormal grid round to one value; the sign must
    /// come from rationals. Differences exact (integers times 2^-520), factors near 2^-530,
    /// products near 2^-1030, the second made to cancel the first and nudged an ulp or two.
    #[test]
    fn sign2_is_exact_where_both_factors_are_tiny() {
        let mut x = 0x2545_f491_4f6c_dd1du64;
        let mut f = move || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 11) as f64 / (1u64 << 53) as f64
        };
        let grid =
            |f: &mut dyn FnMut() -> f64| ((f() - 0.5) * 2f64.powi(21)).round() * 2f64.powi(-520);
        let mut lost = 0;
        for _ in 0..20_000 {
            let (a, b, c, e) = (grid(&mut f), grid(&mut f), grid(&mut f), grid(&mut f));
            let (ab, ce) = (a - b, c - e);
            if ce == 0.0 {
                continue;
            }
            let m = (f() + 0.5) * 2f64.powi(-530);
            let mut n = ab * 2f64.powi(500) * m / ce * 2f64.powi(-500);
            for _ in 0..(f() * 3.0) as usize {
                n = if f() < 0.5 {
                    n.next_up()
                } else {
                    n.next_down()
                };
            }
            let exact = sign_of(&((rat(a) - rat(b)) * rat(m) - (rat(c) - rat(e)) * rat(n)));
            lost += usize::from(ab * m == ce * n && exact != 0);
            assert_eq!(
                sign2(a, b, m, c, e, n),
                i32::from(exact),
                "{a:e} {b:e} {m:e} {c:e} {e:e} {n:e}"
            );
        }
        assert!(lost > 1000, "{lost} products equal as floats, not exactly");
    }

    /// `sign2`'s stage between the filter and rationals: where both differences and both
    /// products are exact, the sign is the products' order. Products a few units apart out
    /// of 2^51 to 2^53 (the filter, 2ε of their sum, cannot tell them apart), at scales moved
    /// by powers of two; and differences that round, whose exact sign is only that of the
    /// rounding error ((a − b)·1 against fl(a − b)·1: equal as floats), which only TwoSum's
    /// error tells from an exact difference.
    #[test]
    fn sign2_is_exact_where_the_float_products_are_close() {
        let mut x = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = move |n: u64| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x % n
        };
        let exact = |a: f64, b: f64, m: f64, c: f64, e: f64, n: f64| {
            sign_of(&((rat(a) - rat(b)) * rat(m) - (rat(c) - rat(e)) * rat(n))) as i32
        };
        let (mut close, mut rounded) = (0, 0);
        for k in 0..20_000 {
            // X Y against X Y + d, d in -4..=4, each a float (checked exactly).
            let (big, y) = ((1u64 << 25) + next(1 << 25), (1u64 << 26) + next(1 << 26));
            let d = next(9) as i64 - 4;
            let prod = (big * y) as i64 + d;
            let (s, t) = (next(60) as i32 - 30, next(60) as i32 - 30);
            let scaled = |v: f64, e: i32| v * 2f64.powi(e);
            let (a, b, m) = (scaled(big as f64, s), scaled(0.0, s), scaled(y as f64, t));
            let (c, e, n) = (scaled(prod as f64, s), scaled(0.0, s), scaled(1.0, t));
            if prod as f64 as i64 != prod {
                continue;
            }
            let (a, b, m, c, e, n) = if k % 2 == 0 {
                (a, b, m, c, e, n)
            } else {
                (c, e, n, a, b, m)
            };
            let want = exact(a, b, m, c, e, n);
            close += usize::from(want != 0);
            assert_eq!(
                sign2(a, b, m, c, e, n),
                want,
                "{a:e} {b:e} {m:e} {c:e} {e:e} {n:e}"
            );
            assert_eq!(sign2(-a, -b, m, -c, -e, n), -want, "negated, case {k}");
        }
        for k in 0..30_000 {
            // a with bits down to 2^-22, b with bits below a's last: a − b rounds. Every third
            // a − b lies halfway between two floats (a = 2^j − its ulp, b = −2 ulps: rounded
            // to even, 2^j, with each of TwoSum's terms a half-ulp); every third b ≈ a/(1 − a),
            // so that fl(a − b)/fl(fl(a − b) − a) comes back near a. A planted `s + bv` for
            // `s − bv` (and `/`) made TwoSum's error 0 there (found by an exhaustive search
            // of 8-bit floats, then built in float64).
            let (a, b) = match k % 3 {
                0 => {
                    let a = ((1u64 << 30) + next(1 << 30)) as f64
                        + next(1 << 22) as f64 / (1u64 << 22) as f64;
                    let b = (next(1 << 40) as f64 + 1.0) / (1u64 << 62) as f64;
                    (a, b * [1.0, -1.0][k % 2])
                }
                1 => {
                    let j = next(40) as i32 - 20;
                    let ulp = 2f64.powi(j - 53);
                    (2f64.powi(j) - ulp, -2.0 * ulp)
                }
                _ => {
                    let a = 0.05 + 0.9 * next(1 << 53) as f64 / (1u64 << 53) as f64;
                    let mut b = a / (1.0 - a);
                    for _ in 0..next(7) {
                        b = if next(2) == 0 {
                            b.next_up()
                        } else {
                            b.next_down()
                        };
                    }
                    (a, b)
                }
            };
            let ab = a - b;
            let (m, c, e, n) = (1.0, ab, 0.0, 1.0);
            let want = exact(a, b, m, c, e, n);
            rounded += usize::from(want != 0);
            assert_eq!(
                sign2(a, b, m, c, e, n),
                want,
                "{a:e} {b:e} {m:e} {c:e} {e:e} {n:e}"
            );
            assert_eq!(sign2(c, e, n, a, b, m), -want, "swapped, case {k}");
            // The same against (1/2 − 1)·(−2 fl(a − b)): a difference of two numbers whose
            // TwoSum steps divide without remainder too (a planted `s / bv` takes the first
            // for exact as well, where fl(a − b) − 0 gave up dividing by 0).
            assert_eq!(
                sign2(a, b, m, 0.5, 1.0, -2.0 * ab),
                want,
                "halves, case {k}"
            );
        }
        assert!(
            close > 5_000 && rounded > 15_000,
            "{close} close, {rounded} rounded"
        );
    }
}
