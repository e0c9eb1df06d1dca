//! The float64 filter: signs and crossings decided in float64 with Shewchuk's certified error
//! bound; what it cannot certify goes to `exact.rs`.

use super::*;

pub(super) fn sub(a: P3, b: P3) -> P3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

pub(super) fn cross(a: P3, b: P3) -> P3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

pub(super) fn dot(a: P3, b: P3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// The permanent of `d · (u × v)`: the same sum with every term's magnitude.
pub(super) fn perm(d: P3, u: P3, v: P3) -> f64 {
    let (d, u, v) = (d.map(f64::abs), u.map(f64::abs), v.map(f64::abs));
    d[0] * (u[1] * v[2] + u[2] * v[1])
        + d[1] * (u[2] * v[0] + u[0] * v[2])
        + d[2] * (u[0] * v[1] + u[1] * v[0])
}

pub(super) fn operands_ok(vs: &[P3]) -> bool {
    vs.iter()
        .flatten()
        .all(|&x| x == 0.0 || (OPERAND_MIN..=OPERAND_MAX).contains(&x.abs()))
}

pub(super) fn finite(o: P3, d: P3, tri: &Tri) -> bool {
    o.iter()
        .chain(&d)
        .chain(tri.iter().flatten())
        .all(|x| x.is_finite())
}

pub(super) enum Filtered {
    /// Two side products of certified opposite signs.
    Miss,
    /// Three certified side products of one sign, and an interval surely holding `t`.
    Meets { lo: f64, hi: f64 },
    /// Undecided: evaluate exactly.
    Unsure,
}

pub(super) fn filter(o: P3, d: P3, tri: &Tri) -> Filtered {
    let [a, b, c] = *tri;
    let (u, v, w) = (sub(a, o), sub(b, o), sub(c, o));
    if !operands_ok(&[d, u, v, w]) {
        return Filtered::Unsure;
    }
    let s = [
        dot(d, cross(u, v)),
        dot(d, cross(v, w)),
        dot(d, cross(w, u)),
    ];
    let p = [perm(d, u, v), perm(d, v, w), perm(d, w, u)];
    let sign = |k: usize| {
        if s[k] > FILTER * p[k] {
            1
        } else if s[k] < -FILTER * p[k] {
            -1
        } else {
            0
        }
    };
    let g = [sign(0), sign(1), sign(2)];
    if g.contains(&1) && g.contains(&-1) {
        return Filtered::Miss;
    }
    if g[0] == 0 || g[0] != g[1] || g[1] != g[2] {
        return Filtered::Unsure;
    }
    // t = num / den with certified errors: |Δnum| ≤ en (the determinant's bound), |Δden| ≤ ed
    // (three bounds, plus the two additions' rounding). Then
    // |t − num~/den~| ≤ (en + |num~/den~| ed) / (|den~| − ed), and the quotient rounds once.
    let num = dot(u, cross(v, w));
    let en = FILTER * perm(u, v, w);
    let den = s[0] + s[1] + s[2];
    let ed = FILTER * (p[0] + p[1] + p[2]) + 3.0 * EPS * (s[0].abs() + s[1].abs() + s[2].abs());
    if den.abs().partial_cmp(&ed) != Some(Ordering::Greater) {
        return Filtered::Unsure;
    }
    let tf = num / den;
    // The float evaluation of dt itself rounds a few times: inflate it by far more.
    let dt = (en + tf.abs() * ed) / (den.abs() - ed) * (1.0 + 1e-9)
        + 4.0 * EPS * tf.abs()
        + 2.0 * f64::from_bits(1); // a subnormal quotient's absolute rounding
    if !dt.is_finite() || !tf.is_finite() {
        return Filtered::Unsure;
    }
    Filtered::Meets {
        lo: (tf - dt).next_down(),
        hi: (tf + dt).next_up(),
    }
}
