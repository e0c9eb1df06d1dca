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
