//! Exact orientation: the one predicate construction, location and the exact referee of the
//! walk's steps share.

/// Exact orientation with the sign convention used everywhere in tetrace:
/// positive when d lies on the side of plane (a,b,c) that det(b-a, c-a, d-a) > 0 points to.
/// Only the sign is meaningful (off Shewchuk's range, ±1 or 0).
#[inline]
pub fn orient(a: [f64; 3], b: [f64; 3], c: [f64; 3], d: [f64; 3]) -> f64 {
    if ![a, b, c, d].iter().flatten().all(|&v| expansion_safe(v)) {
        // A coordinate such as 5e-324 (an origin a denormal away from a box face) makes
        // the expansions' products underflow, and their sign is then no longer exact (the
        // fuzzer's walk put such origins in the wrong tet): exact dyadic arithmetic instead.
        return exact_orient(a, b, c, d) as f64;
    }
    let p = |v: [f64; 3]| robust::Coord3D {
        x: v[0],
        y: v[1],
        z: v[2],
    };
    // robust::orient3d is positive when d is *below* (a,b,c); ours is the opposite sign.
    -robust::orient3d(p(a), p(b), p(c), p(d))
}

/// Whether Shewchuk's adaptive predicates (`robust`) are exact on a coordinate: zero, or far
/// enough from float64's ends (2^-200..2^200) that no product of their expansions underflows
/// or overflows.
#[inline]
pub fn expansion_safe(v: f64) -> bool {
    const LO: f64 = 6.223015277861142e-61; // 2^-200
    const HI: f64 = 1.6069380442589903e60; // 2^200
    v == 0.0 || (v.abs() >= LO && v.abs() <= HI)
}

/// The sign of det(b − a, c − a, d − a), exactly.
fn exact_orient(a: [f64; 3], b: [f64; 3], c: [f64; 3], d: [f64; 3]) -> i8 {
    let e = super::exact::exact3;
    let (a, b, c, d) = (e(a), e(b), e(c), e(d));
    let sub = |p: &[super::dyadic::Dyadic; 3]| [0, 1, 2].map(|k| &p[k] - &a[k]);
    super::exact::rdet(&sub(&b), &sub(&c), &sub(&d)).signum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use num_rational::BigRational;

    /// The sign is the rationals' also where Shewchuk's expansions would underflow or
    /// overflow (denormal, tiny and huge coordinates beside ordinary ones).
    #[test]
    fn orient_is_exact_off_the_expansions_range() {
        let r = |v: f64| BigRational::from_float(v).unwrap();
        let want = |a: [f64; 3], b: [f64; 3], c: [f64; 3], d: [f64; 3]| {
            let s = |p: [f64; 3]| [0, 1, 2].map(|k| r(p[k]) - r(a[k]));
            let (u, v, w) = (s(b), s(c), s(d));
            let det = &u[0] * (&v[1] * &w[2] - &v[2] * &w[1])
                - &u[1] * (&v[0] * &w[2] - &v[2] * &w[0])
                + &u[2] * (&v[0] * &w[1] - &v[1] * &w[0]);
            det.cmp(&BigRational::from_float(0.0).unwrap()) as i8
        };
        let odd = [
            0.0, 5e-324, -5e-324, 1e-310, 1e-300, 1e-160, 1e160, 1e300, 0.5, 1.0,
        ];
        let mut x = 0x9e37_79b9_7f4a_7c15u64;
        let mut pick = move || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            odd[(x % odd.len() as u64) as usize]
        };
        let mut differs = 0;
        for _ in 0..20_000 {
            let mut p = || [pick(), pick(), pick()];
            let (a, b, c, d) = (p(), p(), p(), p());
            let got = orient(a, b, c, d);
            let w = want(a, b, c, d);
            assert_eq!(
                (got > 0.0) as i8 - (got < 0.0) as i8,
                w,
                "{a:?} {b:?} {c:?} {d:?}"
            );
            let q = |v: [f64; 3]| robust::Coord3D {
                x: v[0],
                y: v[1],
                z: v[2],
            };
            let plain = -robust::orient3d(q(a), q(b), q(c), q(d));
            differs += ((plain > 0.0) as i8 - (plain < 0.0) as i8 != w) as usize;
        }
        // The guard matters: unguarded expansions get some of these wrong.
        assert!(differs > 0, "no case where the expansions alone fail");
    }
}
