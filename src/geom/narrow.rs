//! A hit's values as a float32 output stores them, found without the double-double evaluation
//! where a float64 one shows what they are.
//!
//! A cast of float32 rays stores `t`, `u`, `v` and the point as float32: each is
//! [`super::rounded::rounded_hit`]'s faithful float64 value rounded to nearest float32. That
//! evaluation costs about 2,000 instructions a hit (double-double determinants, four
//! quotients, three anchored sums), most of a camera ray's cost on the BVH. But its float32
//! rounding is known without it wherever a float64 evaluation with a certified error bound
//! leaves no float32 rounding boundary within reach: every value in the interval rounds to the
//! same float32, and the faithful value lies in it. So [`triangle_hit32`] returns the same bits
//! the slow path stores, or None (a value near a rounding boundary, near zero, a grazing ray,
//! operands out of range), and the caller then takes the slow path. Nothing is decided from
//! the floats that the exact values could contradict. Tested beside the slow path
//! (`rounded/tests.rs`): every case there is checked through this too, against rationals.

use super::exact::{det_perm, DET_BOUND, EPS, TINY};
use super::real::V3;

/// A hit's values rounded to float32.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit32 {
    pub t: f32,
    pub u: f32,
    pub v: f32,
    pub point: [f32; 3],
}

/// Relative slack of [`settled`]: the faithful float64 value is within an ulp of the exact
/// one (≤ 2^-52 of its magnitude), and the interval's ends are rounded once each (≤ 2^-53);
/// 2^-50 of the estimate covers both where the interval is narrower than the estimate (else
/// it reaches zero, which [`settled`] refuses).
const SLACK: f64 = 1.0 / (1u64 << 50) as f64;

/// The float32 that every number within `r` of `x` rounds to, widened by [`SLACK`]; None
/// where two differ, where the interval reaches zero (a zero's sign would be the faithful
/// value's), or where it is not finite.
#[inline(always)]
fn settled(x: f64, r: f64) -> Option<f32> {
    let r = r + SLACK * x.abs();
    let (lo, hi) = ((x - r) as f32, (x + r) as f32);
    // Equal bits and nonzero: both ends on one side of zero (a NaN is not finite).
    (lo.to_bits() == hi.to_bits() && lo != 0.0 && lo.is_finite()).then_some(lo)
}

/// The point's coordinate where the triangle's three corners share it (`a`): exact, so its
/// float32 is the rounding of a_k itself, a zero as +0 (as the exact path rounds one); None
/// where that overflows.
#[inline(always)]
fn flat_coordinate(a: f64) -> Option<f32> {
    let x = (a + 0.0) as f32;
    x.is_finite().then_some(x)
}

/// The hit of the line `o + t d` on the plane of `tri` (which the caller knows it meets at
/// one point), rounded to float32 as the slow path's values round (see the module docs), or
/// None where the float64 evaluation cannot show it.
///
/// With `w = a − o`, `e1 = b − a`, `e2 = c − a`, each one rounded difference of inputs:
/// `t = det(w, e1, e2) / D`, `u = det(d, e2, w) / D`, `v = det(d, w, e1) / D`,
/// `D = det(d, e1, e2)`, and the point `a + u e1 + v e2`. Each determinant is within
/// `DET_BOUND` of its permanent (Shewchuk's bound for rows that are rounded differences or
/// inputs; `plane_t` and `triangle_sides` filter with the same). A quotient `n / D` is then
/// within `(δn + |q| δD) / |D|` of the exact one, where |q| is the exact quotient's; asking
/// `δD ≤ |D| / 8` lets the computed quotient stand for it (the 1/(1 − 1/8) this costs is
/// inside `DET_BOUND`'s margin over Shewchuk's 7ε), and `4ε|q|` covers the division's
/// rounding and the bound's own.
pub fn triangle_hit32(o: V3<f64>, d: V3<f64>, tri: &[V3<f64>; 3]) -> Option<Hit32> {
    let [a, b, c] = *tri;
    let w = [0, 1, 2].map(|k| a[k] - o[k]);
    let e1 = [0, 1, 2].map(|k| b[k] - a[k]);
    let e2 = [0, 1, 2].map(|k| c[k] - a[k]);
    let (num, p_num) = det_perm(w, e1, e2);
    let (den, p_den) = det_perm(d, e1, e2);
    let (num_u, p_u) = det_perm(d, e2, w);
    let (num_v, p_v) = det_perm(d, w, e1);
    // Below TINY a product may have underflowed, and the bound is relative; NaN fails too.
    let fine = |p: f64| p > TINY && p.is_finite();
    let den_err = DET_BOUND * p_den;
    if !(fine(p_num) && fine(p_den) && fine(p_u) && fine(p_v) && 8.0 * den_err <= den.abs()) {
        return None;
    }
    let quotient = |n: f64, p: f64| {
        let q = n / den;
        (
            q,
            (DET_BOUND * p + q.abs() * den_err) / den.abs() + 4.0 * EPS * q.abs(),
        )
    };
    let (t, t_err) = quotient(num, p_num);
    let (u, u_err) = quotient(num_u, p_u);
    let (v, v_err) = quotient(num_v, p_v);
    // The point anchored at the triangle: |u e1 − u* e1*| ≤ u_err |e1| + (|u| + u_err) ε |e1|
    // (e1 is one rounding from b − a), and the two products and two sums round once each:
    // 8ε on the terms' magnitudes covers those.
    let (mu, mv) = (u.abs() + u_err, v.abs() + v_err);
    let mut point = [0f32; 3];
    for k in 0..3 {
        if e1[k] == 0.0 && e2[k] == 0.0 {
            // The triangle lies in the plane x_k = a_k (a floor, a wall): the coordinate is
            // a_k exactly, zero included, which `settled` refuses for its sign. The slow
            // path's sum a_k + u·0 + v·0 is a_k too, and +0 for a zero wherever this answers
            // (u, v > 0: zeros decline).
            point[k] = flat_coordinate(a[k])?;
            continue;
        }
        let p = a[k] + u * e1[k] + v * e2[k];
        let (s1, s2) = (e1[k].abs(), e2[k].abs());
        let err = u_err * s1 + v_err * s2 + 8.0 * EPS * (a[k].abs() + mu * s1 + mv * s2);
        point[k] = settled(p, err)?;
    }
    Some(Hit32 {
        t: settled(t, t_err)?,
        u: settled(u, u_err)?,
        v: settled(v, v_err)?,
        point,
    })
}

/// [`triangle_hit32`] at a SIMD level: the same answer, bit for bit, at every level.
#[inline]
pub fn triangle_hit32_at(
    simd: crate::simd::Simd,
    o: V3<f64>,
    d: V3<f64>,
    tri: &[V3<f64>; 3],
) -> Option<Hit32> {
    #[cfg(target_arch = "x86_64")]
    if simd == crate::simd::Simd::Avx2 {
        // SAFETY: Simd::Avx2 is only chosen where the CPU has AVX2 (`Simd::supported`).
        return unsafe { triangle_hit32_avx2(o, d, tri) };
    }
    let _ = simd;
    triangle_hit32(o, d, tri)
}

/// [`triangle_hit32`] in AVX2: the four determinants in four float64 lanes, the three
/// quotients and their bounds in three, the point's coordinates in three, and the six
/// roundings to float32 checked two vectors at a time. Each lane makes the scalar code's
/// operations in its order, each rounded once (no fused multiply-add; the conversions to
/// float32 round to nearest, as `as f32` does), so the same numbers and the same answer. The
/// scalar code spent about 400 instructions a hit, most of them on the four determinants and
/// the six `settled` checks one at a time.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn triangle_hit32_avx2(o: V3<f64>, d: V3<f64>, tri: &[V3<f64>; 3]) -> Option<Hit32> {
    use std::arch::x86_64::*;
    test_count!(AVX2_HITS += 1);
    let [a, b, c] = *tri;
    // w, e1 and e2 in one subtraction each (the same differences), each stored whole: built
    // one component at a time, they were spilled in pieces and reloaded wider, and each
    // reload waited for its stores to retire.
    let v3 = |p: V3<f64>| _mm256_set_pd(0.0, p[2], p[1], p[0]);
    let whole = |x: __m256d| {
        let mut out = [0f64; 4];
        _mm256_storeu_pd(out.as_mut_ptr(), x);
        out
    };
    let av = v3(a);
    let w = whole(_mm256_sub_pd(av, v3(o)));
    let (e1v, e2v) = (_mm256_sub_pd(v3(b), av), _mm256_sub_pd(v3(c), av));
    let (e1, e2) = (whole(e1v), whole(e2v));
    // Lanes: det(w, e1, e2) (t's numerator), det(d, e1, e2) (the denominator),
    // det(d, e2, w) (u's), det(d, w, e1) (v's): rows A, B, C per lane.
    let lanes = |l0: f64, l1: f64, l2: f64, l3: f64| _mm256_set_pd(l3, l2, l1, l0);
    let ra = [0, 1, 2].map(|k| lanes(w[k], d[k], d[k], d[k]));
    let rb = [0, 1, 2].map(|k| lanes(e1[k], e1[k], e2[k], w[k]));
    let rc = [0, 1, 2].map(|k| lanes(e2[k], e2[k], w[k], e1[k]));
    let sign = _mm256_set1_pd(-0.0);
    let abs = |x: __m256d| _mm256_andnot_pd(sign, x);
    let (mul, add, sub) = (
        |x, y| _mm256_mul_pd(x, y),
        |x, y| _mm256_add_pd(x, y),
        |x, y| _mm256_sub_pd(x, y),
    );
    // det_perm, term by term.
    let (b1c2, b2c1) = (mul(rb[1], rc[2]), mul(rb[2], rc[1]));
    let (b0c2, b2c0) = (mul(rb[0], rc[2]), mul(rb[2], rc[0]));
    let (b0c1, b1c0) = (mul(rb[0], rc[1]), mul(rb[1], rc[0]));
    let (m0, m1, m2) = (sub(b1c2, b2c1), sub(b0c2, b2c0), sub(b0c1, b1c0));
    let det = add(sub(mul(ra[0], m0), mul(ra[1], m1)), mul(ra[2], m2));
    let perm = add(
        add(
            mul(abs(ra[0]), add(abs(b1c2), abs(b2c1))),
            mul(abs(ra[1]), add(abs(b0c2), abs(b2c0))),
        ),
        mul(abs(ra[2]), add(abs(b0c1), abs(b1c0))),
    );
    // Every permanent above TINY and finite (NaN fails both).
    let fine = _mm256_and_pd(
        _mm256_cmp_pd::<_CMP_GT_OQ>(perm, _mm256_set1_pd(TINY)),
        _mm256_cmp_pd::<_CMP_LT_OQ>(perm, _mm256_set1_pd(f64::INFINITY)),
    );
    let mut dets = [0f64; 4];
    let mut perms = [0f64; 4];
    _mm256_storeu_pd(dets.as_mut_ptr(), det);
    _mm256_storeu_pd(perms.as_mut_ptr(), perm);
    let (den, p_den) = (dets[1], perms[1]);
    let den_err = DET_BOUND * p_den;
    // As the portable code: a NaN fails.
    let den_certain = 8.0 * den_err <= den.abs();
    if _mm256_movemask_pd(fine) != 0b1111 || !den_certain {
        return None;
    }
    // Quotients of lanes 0, 2 and 3 (t, u, v), moved to lanes 0, 1, 2 (lane 3: den / den,
    // not read).
    let pick = |x: __m256d| _mm256_permute4x64_pd::<0b01_11_10_00>(x);
    let (num, p) = (pick(det), pick(perm));
    let den_v = _mm256_set1_pd(den);
    let q = _mm256_div_pd(num, den_v);
    let err = add(
        _mm256_div_pd(
            add(
                mul(_mm256_set1_pd(DET_BOUND), p),
                mul(abs(q), _mm256_set1_pd(den_err)),
            ),
            _mm256_set1_pd(den.abs()),
        ),
        mul(_mm256_set1_pd(4.0 * EPS), abs(q)),
    );
    let mut qs = [0f64; 4];
    let mut errs = [0f64; 4];
    _mm256_storeu_pd(qs.as_mut_ptr(), q);
    _mm256_storeu_pd(errs.as_mut_ptr(), err);
    let ([_, u, v, _], [_, u_err, v_err, _]) = (qs, errs);
    // The point, coordinate k in lane k (lane 3: 1, settled; not read).
    let (mu, mv) = (u.abs() + u_err, v.abs() + v_err);
    let av = _mm256_set_pd(1.0, a[2], a[1], a[0]);
    let (s1, s2) = (abs(e1v), abs(e2v));
    let (uv, vv) = (_mm256_set1_pd(u), _mm256_set1_pd(v));
    let point = add(add(av, mul(uv, e1v)), mul(vv, e2v));
    let point_err = add(
        add(
            mul(_mm256_set1_pd(u_err), s1),
            mul(_mm256_set1_pd(v_err), s2),
        ),
        mul(
            _mm256_set1_pd(8.0 * EPS),
            add(
                add(abs(av), mul(_mm256_set1_pd(mu), s1)),
                mul(_mm256_set1_pd(mv), s2),
            ),
        ),
    );
    // Coordinates where the triangle is flat (e1 and e2 zero there): a_k + 0 exactly, as
    // the portable code's `flat_coordinate`.
    let zero = _mm256_setzero_pd();
    let flat = _mm256_and_pd(
        _mm256_cmp_pd::<_CMP_EQ_OQ>(e1v, zero),
        _mm256_cmp_pd::<_CMP_EQ_OQ>(e2v, zero),
    );
    let point = _mm256_blendv_pd(point, add(av, zero), flat);
    // `settled` on four lanes: the float32s of x ∓ (r + SLACK |x|), equal bits, nonzero and
    // finite; in the lanes of `exact` (x is the exact value) the float32 of x, finite.
    let settled4 = |x: __m256d, r: __m256d, exact: __m256d| {
        let r = _mm256_andnot_pd(exact, add(r, mul(_mm256_set1_pd(SLACK), abs(x))));
        let (lo, hi) = (_mm256_cvtpd_ps(sub(x, r)), _mm256_cvtpd_ps(add(x, r)));
        let same = _mm_castsi128_ps(_mm_cmpeq_epi32(_mm_castps_si128(lo), _mm_castps_si128(hi)));
        let nonzero = _mm_cmpneq_ps(lo, _mm_setzero_ps());
        let finite = _mm_cmplt_ps(
            _mm_andnot_ps(_mm_set1_ps(-0.0), lo),
            _mm_set1_ps(f32::INFINITY),
        );
        let ok = _mm_movemask_ps(_mm_and_ps(same, _mm_and_ps(nonzero, finite)))
            | (_mm256_movemask_pd(exact) & _mm_movemask_ps(finite));
        let mut out = [0f32; 4];
        _mm_storeu_ps(out.as_mut_ptr(), lo);
        (ok & 0b111 == 0b111, out)
    };
    let (ok_tuv, tuv) = settled4(q, err, zero);
    let (ok_p, p) = settled4(point, point_err, flat);
    (ok_tuv && ok_p).then_some(Hit32 {
        t: tuv[0],
        u: tuv[1],
        v: tuv[2],
        point: [p[0], p[1], p[2]],
    })
}

test_count!(
    /// Hits the AVX2 kernel evaluated on this thread (tests: which level's code ran).
    AVX2_HITS,
    avx2_hits
);

#[cfg(test)]
mod tests {
    use super::*;

    /// `settled` widens the interval by [`SLACK`] (2^-50 of |x|, four to eight float64 ulps)
    /// before it asks whether both ends round alike: the faithful value and the bound's own
    /// roundings may lie that far out. Around the float32 midpoint m = 1 + 2^-24 (float64 ulp
    /// u = 2^-52 there), with r = 3u: x = m + 6u has m within r + SLACK·x (7u and a little)
    /// and is declined, though m lies outside x ± r; x = m + 8u is not within reach of m and
    /// settles to 1 + 2^-23. The same below m, where the answer is 1.
    #[test]
    fn settled_reaches_its_slack_beyond_the_bound() {
        let u = 2f64.powi(-52);
        let m = 1.0 + 2f64.powi(-24);
        assert_eq!(settled(m + 6.0 * u, 3.0 * u), None);
        assert_eq!(settled(m + 8.0 * u, 3.0 * u), Some(1.0 + 2f32.powi(-23)));
        assert_eq!(settled(m - 6.0 * u, 3.0 * u), None);
        assert_eq!(settled(m - 8.0 * u, 3.0 * u), Some(1.0));
        // Without a bound, the slack alone: within four ulps of m, declined.
        assert_eq!(settled(m + 3.0 * u, 0.0), None);
        assert_eq!(settled(m + 5.0 * u, 0.0), Some(1.0 + 2f32.powi(-23)));
    }
}
