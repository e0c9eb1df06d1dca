//! Exact orientation: the one predicate construction, location and the exact referee of the
//! walk's steps share.

use num_traits::{Signed, Zero};

/// Exact orientation with the sign convention used everywhere in tetrace:
/// positive when d lies on the side of plane (a,b,c) that det(b-a, c-a, d-a) > 0 points to.
/// The sign is exact for all finite inputs; the magnitude is Shewchuk's adaptive evaluation's
/// where that is exact, else ±1.
#[inline]
pub fn orient(a: [f64; 3], b: [f64; 3], c: [f64; 3], d: [f64; 3]) -> f64 {
    let v = [a, b, c, d];
    if !v.iter().flatten().all(|&x| expansion_safe(x)) && v.iter().flatten().all(|x| x.is_finite())
    {
        return orient_rational(a, b, c, d);
    }
    let p = |v: [f64; 3]| robust::Coord3D {
        x: v[0],
        y: v[1],
        z: v[2],
    };
    // robust::orient3d is positive when d is *below* (a,b,c); ours is the opposite sign.
    -robust::orient3d(p(a), p(b), p(c), p(d))
}

/// Whether Shewchuk's adaptive orientation is exact on a coordinate: zero, or far enough from
/// float64's ends that no product of its expansions underflows or overflows. A coordinate of
/// 5e-324 next to ones near 1 makes its products subnormal: they round to 0 and it answers 0
/// for a point off the plane (a walk started at o = (0, 5e-324, 0) on the box's side y = 0
/// settled in the wrong tet).
#[inline(always)]
fn expansion_safe(v: f64) -> bool {
    const LO: f64 = 6.223015277861142e-61; // 2^-200
    const HI: f64 = 1.6069380442589903e60; // 2^200
    v == 0.0 || (LO..=HI).contains(&v.abs())
}

/// [`orient`]'s sign in rationals (tiny or huge coordinates): ±1 or 0.
#[cold]
#[inline(never)]
fn orient_rational(a: [f64; 3], b: [f64; 3], c: [f64; 3], d: [f64; 3]) -> f64 {
    use super::exact::{rationals, rdet};
    let [a, b, c, d] = [a, b, c, d].map(rationals);
    let sub = |p: &[_; 3]| [0, 1, 2].map(|k| &p[k] - &a[k]);
    let det = rdet(&sub(&b), &sub(&c), &sub(&d));
    if det.is_zero() {
        0.0
    } else if det.is_positive() {
        1.0
    } else {
        -1.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
            assert_eq!(sign(orient_rational(p0, p1, p2, p3)), want, "case {i}");
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
}
