//! Exact orientation: the one predicate construction, location and the exact referee of the
//! walk's steps share.

/// Exact orientation with the sign convention used everywhere in tetrace:
/// positive when d lies on the side of plane (a,b,c) that det(b-a, c-a, d-a) > 0 points to.
/// The sign is exact for all finite inputs, and it is all that callers may read: the magnitude
/// is Shewchuk's adaptive estimate where its expansions are exact, else ±1 from exact dyadic
/// arithmetic (either path gives the same sign; the second is much slower).
#[inline]
pub fn orient(a: [f64; 3], b: [f64; 3], c: [f64; 3], d: [f64; 3]) -> f64 {
    let v = [a, b, c, d];
    if !v.iter().flatten().all(|&x| expansion_safe(x)) && v.iter().flatten().all(|x| x.is_finite())
    {
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
#[cold]
#[inline(never)]
fn exact_orient(a: [f64; 3], b: [f64; 3], c: [f64; 3], d: [f64; 3]) -> i8 {
    use super::dyadic::{exact3, rdet, Dyadic};
    let (a, b, c, d) = (exact3(a), exact3(b), exact3(c), exact3(d));
    let sub = |p: &[Dyadic; 3]| [0, 1, 2].map(|k| &p[k] - &a[k]);
    rdet(&sub(&b), &sub(&c), &sub(&d)).signum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use num_rational::BigRational;

    fn sign(x: f64) -> i8 {
        (x > 0.0) as i8 - (x < 0.0) as i8
    }

    /// Tiny and huge coordinates get the sign of the same points scaled by a power of two into
    /// the adaptive predicate's safe range (an exact scaling changes no sign); where both
    /// apply, the rationals' sign is the adaptive one's.
    #[test]
    fn orient_is_exact_for_tiny_and_huge_coordinates() {
        let a = 0.3333333134651184;
        // The walk fuzz's start (seed 7686576272770016265, ray 3873): just above y = 0.
        let (x, y, z) = ([0.0; 3], [a, 0.0, 0.0], [0.0, 0.0, a]);
        assert_eq!(orient(x, y, z, [0.0, 5e-324, 0.0]), -1.0);
        assert_eq!(orient(x, z, y, [0.0, 5e-324, 0.0]), 1.0);
        assert_eq!(orient(x, y, z, [a, 0.0, a]), 0.0);
        let mut s = 0x9e3779b97f4a7c15u64;
        let mut f = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let (mut zeros, mut signs) = (0, 0);
        for i in 0..2000 {
            let mut p = [0; 4].map(|_| [f(), f(), f()]);
            if i % 2 == 0 {
                // On the plane of the first three up to rounding (at times exactly).
                let t = [f(), f()].map(|x| (x * 8.0).round() / 8.0);
                p[3] = [0, 1, 2]
                    .map(|k| p[0][k] + t[0] * (p[1][k] - p[0][k]) + t[1] * (p[2][k] - p[0][k]));
            }
            let want = sign(orient(p[0], p[1], p[2], p[3]));
            let [p0, p1, p2, p3] = p;
            assert_eq!(exact_orient(p0, p1, p2, p3), want, "case {i}");
            // 2^-1000 · 0.5 and 2^1000 · 0.5 are normal: the scaling is exact.
            for e in [-1000, -600, 600, 1000] {
                let [s0, s1, s2, s3] = p.map(|v| v.map(|x| x * 2f64.powi(e)));
                assert_eq!(
                    sign(orient(s0, s1, s2, s3)),
                    want,
                    "case {i} scaled by 2^{e}"
                );
            }
            zeros += (want == 0) as u32;
            signs += (want != 0) as u32;
        }
        assert!(zeros > 10 && signs > 1000, "{zeros} zeros, {signs} signs");
    }

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
        let mut rng = crate::rng::Rng::new(0x9e37_79b9_7f4a_7c15);
        let mut pick = move || rng.pick(&odd);
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
