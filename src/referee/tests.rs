//! Hand-made cases with known answers, and a plain-rational brute force (no filter, no
//! scaling: `BigRational` straight from the floats) on random and near-degenerate rays. (Just
//! over 500 lines: one case per function, sharing the brute force at the end.)

use super::*;
use num_rational::BigRational;
use num_traits::Signed;

fn exact_calls() -> usize {
    EXACT_CALLS.with(|c| c.get())
}

/// Runs `f`, returning its result and how many exact evaluations it made.
fn counting<T>(f: impl FnOnce() -> T) -> (T, usize) {
    let before = exact_calls();
    let r = f();
    (r, exact_calls() - before)
}

const UNIT: Tri = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
const DOWN: P3 = [0.0, 0.0, -1.0];

fn hit(o: P3, d: P3, tris: &[Tri]) -> Option<Verdict> {
    first_hit(o, d, 0.0, f64::INFINITY, tris)
}

#[test]
fn interior_hit() {
    let v = hit([0.25, 0.25, 1.0], DOWN, &[UNIT]).unwrap();
    assert_eq!((v.t, v.ties.clone(), v.zero_signs), (1.0, vec![0], 0));
    // Facing does not matter, and the crossing is exact.
    let v = hit([0.25, 0.25, -2.0], [0.0, 0.0, 1.0], &[UNIT]).unwrap();
    assert_eq!((v.t, v.zero_signs), (2.0, 0));
    let c = crossing([0.25, 0.25, 1.0], DOWN, &UNIT).unwrap();
    assert_eq!(c.zero_signs, 0);
    assert_eq!(c.cmp_t(1.0), Ordering::Equal);
    // Behind the origin: the line meets it, the ray (t ≥ 0) does not.
    assert!(crossing([0.25, 0.25, -1.0], DOWN, &UNIT).is_some());
    assert!(hit([0.25, 0.25, -1.0], DOWN, &[UNIT]).is_none());
    // Outside the triangle.
    assert!(crossing([0.75, 0.75, 1.0], DOWN, &UNIT).is_none());
}

#[test]
fn through_an_edge_two_ties() {
    let upper: Tri = [[1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]];
    let v = hit([0.5, 0.5, 1.0], DOWN, &[upper, UNIT]).unwrap();
    assert_eq!((v.t, v.ties.clone(), v.zero_signs), (1.0, vec![0, 1], 1));
    // An ulp off the shared edge: one triangle only.
    let v = hit([0.5, 0.5f64.next_up(), 1.0], DOWN, &[upper, UNIT]).unwrap();
    assert_eq!((v.ties.clone(), v.zero_signs), (vec![0], 0));
    let v = hit([0.5, 0.5f64.next_down(), 1.0], DOWN, &[upper, UNIT]).unwrap();
    assert_eq!((v.ties.clone(), v.zero_signs), (vec![1], 0));
    // Through an outer edge: one triangle, on its edge.
    let v = hit([0.5, 0.0, 1.0], DOWN, &[UNIT]).unwrap();
    assert_eq!((v.ties.clone(), v.zero_signs), (vec![0], 1));
}

#[test]
fn through_a_vertex_all_incident_tie() {
    // A fan of six triangles around the origin in z = 0, a triangle elsewhere in that plane
    // and one farther along the ray.
    let ring: Vec<P3> = [
        [1.0, 0.0],
        [0.5, 1.0],
        [-0.5, 1.0],
        [-1.0, 0.0],
        [-0.5, -1.0],
        [0.5, -1.0],
    ]
    .iter()
    .map(|p| [p[0], p[1], 0.0])
    .collect();
    let mut tris: Vec<Tri> = vec![[[5.0, 5.0, 0.0], [6.0, 5.0, 0.0], [5.0, 6.0, 0.0]]];
    for k in 0..6 {
        tris.push([[0.0; 3], ring[k], ring[(k + 1) % 6]]);
    }
    tris.push([[-1.0, -1.0, -1.0], [2.0, -1.0, -1.0], [-1.0, 2.0, -1.0]]);
    let o = [0.25, 0.125, 2.0];
    let d = [-0.125, -0.0625, -1.0]; // through the origin at t = 2
    let v = hit(o, d, &tris).unwrap();
    assert_eq!(v.t, 2.0);
    assert_eq!(v.ties, (1..=6).collect::<Vec<_>>());
    assert_eq!(v.zero_signs, 2);
    // Without the fan, the far triangle.
    let v = hit(o, d, &[tris[0], tris[7]]).unwrap();
    assert_eq!((v.t, v.ties.clone()), (3.0, vec![1]));
}

#[test]
fn lines_in_the_plane_parallel_or_degenerate_never_hit() {
    // In the plane (through the interior, along an edge, through a vertex).
    for (o, d) in [
        ([-1.0, 0.25, 0.0], [1.0, 0.0, 0.0]),
        ([-1.0, 0.0, 0.0], [1.0, 0.0, 0.0]),
        ([-1.0, -1.0, 0.0], [1.0, 1.0, 0.0]),
    ] {
        assert!(crossing(o, d, &UNIT).is_none(), "{o:?} {d:?}");
        assert!(hit(o, d, &[UNIT]).is_none());
    }
    // Parallel to the plane, off it.
    assert!(crossing([0.0, 0.0, 1.0], [1.0, 0.5, 0.0], &UNIT).is_none());
    // Triangles without area: collinear, and a repeated vertex.
    let flat: Tri = [[0.0, 0.0, 0.0], [1.0, 1.0, 0.0], [2.0, 2.0, 0.0]];
    let pinched: Tri = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 0.0, 0.0]];
    for t in [flat, pinched] {
        assert!(crossing([1.0, 1.0, 1.0], DOWN, &t).is_none());
        assert!(crossing([0.5, 0.0, 1.0], [0.1, 0.2, -1.0], &t).is_none());
    }
    // d = 0, and refused rays.
    assert!(crossing([0.25, 0.25, 1.0], [0.0; 3], &UNIT).is_none());
    assert!(hit([0.25, 0.25, 1.0], [0.0; 3], &[UNIT]).is_none());
    assert!(hit([f64::NAN, 0.25, 1.0], DOWN, &[UNIT]).is_none());
    assert!(hit([0.25, 0.25, 1.0], [0.0, 0.0, f64::NEG_INFINITY], &[UNIT]).is_none());
    assert!(first_hit([0.25, 0.25, 1.0], DOWN, f64::NAN, 2.0, &[UNIT]).is_none());
}

#[test]
fn bounds_are_inclusive_and_exact() {
    let o = [0.25, 0.25, 1.0];
    assert!(first_hit(o, DOWN, 1.0, 1.0, &[UNIT]).is_some());
    assert!(first_hit(o, DOWN, 0.0, 1.0, &[UNIT]).is_some());
    assert!(first_hit(o, DOWN, 1.0, f64::INFINITY, &[UNIT]).is_some());
    assert!(first_hit(o, DOWN, 1f64.next_up(), 2.0, &[UNIT]).is_none());
    assert!(first_hit(o, DOWN, 0.0, 1f64.next_down(), &[UNIT]).is_none());
    // t = 1/3 exactly (not a float): the float below it is a tmin that keeps the hit, the one
    // above it one that drops it; as tmax the other way round.
    let o = [0.25, 0.25, 1.0];
    let d = [0.0, 0.0, -3.0];
    let third = 1.0f64 / 3.0;
    assert!(crossing(o, d, &UNIT).unwrap().cmp_t(third).is_gt()); // the float is below 1/3
    let v = first_hit(o, d, third, 1.0, &[UNIT]).unwrap();
    assert_eq!(v.t, third);
    assert!(first_hit(o, d, third.next_up(), 1.0, &[UNIT]).is_none());
    assert!(first_hit(o, d, 0.0, third, &[UNIT]).is_none());
    assert!(first_hit(o, d, 0.0, third.next_up(), &[UNIT]).is_some());
    // A hit exactly at t = tmin = 0: the origin on the triangle.
    let v = first_hit([0.25, 0.25, 0.0], DOWN, 0.0, 1.0, &[UNIT]).unwrap();
    assert_eq!((v.t, v.zero_signs), (0.0, 0));
    // tmin past the first hit: the next one.
    let far: Tri = [[0.0, 0.0, -2.0], [1.0, 0.0, -2.0], [0.0, 1.0, -2.0]];
    let v = first_hit([0.25, 0.25, 1.0], DOWN, 1f64.next_up(), 10.0, &[UNIT, far]).unwrap();
    assert_eq!((v.t, v.ties.clone()), (3.0, vec![1]));
}

#[test]
fn t_is_correctly_rounded() {
    let b = |x: i64| BigInt::from(x);
    assert_eq!(round_quotient(&b(1), &b(3)), 1.0 / 3.0);
    assert_eq!(round_quotient(&b(-2), &b(3)), -2.0 / 3.0);
    assert_eq!(round_quotient(&b(2), &b(-7)), -2.0 / 7.0);
    assert_eq!(round_quotient(&b(0), &b(5)), 0.0);
    // Ties to even: 2^53 + 1 lies halfway between 2^53 and 2^53 + 2 (even mantissa: 2^53);
    // 2^53 + 3 between 2^53 + 2 and 2^53 + 4 (even: 2^53 + 4).
    let p53 = 1i64 << 53;
    assert_eq!(round_quotient(&b(p53 + 1), &b(1)), p53 as f64);
    assert_eq!(round_quotient(&b(p53 + 3), &b(1)), (p53 + 4) as f64);
    assert_eq!(round_quotient(&b(2 * p53 + 2), &b(2)), p53 as f64);
    // Just above a tie rounds up (the sticky bit): (2^53 + 1 + 1/3).
    assert_eq!(round_quotient(&b(3 * p53 + 4), &b(3)), (p53 + 2) as f64);
    // Huge and tiny: overflow, subnormals, underflow.
    let one = BigInt::from(1);
    assert_eq!(round_quotient(&(&one << 1024usize), &one), f64::INFINITY);
    assert_eq!(round_quotient(&(&one << 1023usize), &one), 2f64.powi(1023));
    let tiny = |k: usize, n: i64| round_quotient(&b(n), &(&one << k));
    assert_eq!(tiny(1074, 1), f64::from_bits(1));
    assert_eq!(tiny(1074, 3), f64::from_bits(3));
    assert_eq!(tiny(1075, 1), 0.0); // half the smallest subnormal: ties to even (zero)
    assert_eq!(tiny(1075, 3), f64::from_bits(2)); // 1.5 → 2
    assert_eq!(tiny(1076, 3), f64::from_bits(1)); // 0.75 → 1
    assert_eq!(tiny(2000, 1), 0.0);
    assert_eq!(
        round_quotient(&b(2), &(b(3) << 1074usize)),
        f64::from_bits(1)
    );
    assert_eq!(round_quotient(&b(1), &(b(3) << 1074usize)), 0.0);
    assert_eq!(tiny(1022, 1), f64::MIN_POSITIVE);
    // Against float division of exactly representable integers (correctly rounded).
    let mut x = 0x2545_f491_4f6c_dd1du64;
    for _ in 0..20_000 {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        let n = (x >> 11) as i64 >> (x % 40);
        let d = ((x.rotate_left(17) >> 11) as i64 >> (x % 47)).max(1);
        let s = if x & 1 == 0 { 1 } else { -1 };
        assert_eq!(
            round_quotient(&b(s * n), &b(d)),
            (s * n) as f64 / d as f64,
            "{n}/{d}"
        );
    }
}

#[test]
fn filter_defers_what_it_cannot_certify() {
    // S = a_x b_y − a_y b_x = (1 + 2^-51) − (1 + 2^-52)² = −2^-104: float64 rounds it to 0.
    let e = f64::EPSILON;
    let a = [1.0, 1.0 + e, 0.0];
    let b = [1.0 + e, 1.0 + 2.0 * e, 0.0];
    let o = [0.0, 0.0, 1.0];
    assert_eq!(a[0] * b[1] - a[1] * b[0], 0.0);
    let (s, n) = counting(|| side(o, DOWN, a, b));
    assert_eq!((s, n), (Ordering::Greater, 1)); // d = −z flips the sign
    assert_eq!(side(o, [0.0, 0.0, 1.0], a, b), Ordering::Less);
    // A clear case needs no exact evaluation.
    let (s, n) = counting(|| side(o, DOWN, [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]));
    assert_eq!((s, n), (Ordering::Less, 0));
    let (v, n) = counting(|| hit([0.25, 0.25, 1.0], DOWN, &[UNIT]));
    assert_eq!((v.unwrap().t, n), (1.0, 1)); // one exact evaluation: the winner's t
}

#[test]
fn far_offsets_exact_through_an_edge() {
    // Two triangles sharing the edge AB far from the origin; the ray from near the origin
    // passes exactly through AB's midpoint M at t = 1 (d = M − o is exact). Float64 side
    // products are of size 1e21 and cancel to 0 exactly: the filter defers, the exact path
    // finds the edge (one zero sign) on both triangles.
    let f = 1e7;
    let a = [f + 0.25, f, f];
    let b = [f, f + 0.25, f + 0.5];
    let m = [f + 0.125, f + 0.125, f + 0.25];
    let c0 = [f + 1.0, f + 1.0, f - 3.0];
    let c1 = [f - 1.0, f - 1.5, f + 2.0];
    let o = [0.5, 0.25, 0.75];
    let d = sub(m, o);
    assert_eq!(d, [f - 0.375, f - 0.125, f - 0.5]);
    let tris = [[a, b, c0], [c1, b, a], UNIT];
    let (v, n) = counting(|| hit(o, d, &tris));
    let v = v.unwrap();
    assert_eq!((v.t, v.ties.clone(), v.zero_signs), (1.0, vec![0, 1], 1));
    assert!(n >= 2, "{n} exact evaluations");
    // Nudging the direction by an ulp picks one side, as the rationals say.
    for k in 0..3 {
        for up in [false, true] {
            let mut dd = d;
            dd[k] = if up {
                dd[k].next_up()
            } else {
                dd[k].next_down()
            };
            assert_eq!(
                hit(o, dd, &tris).map(|v| v.ties),
                oracle(o, dd, 0.0, f64::INFINITY, &tris).map(|(_, t)| t),
                "{dd:?}"
            );
        }
    }
}

#[test]
fn tiny_and_huge_scales_skip_the_filter() {
    // The upper/lower pair through its shared edge, scaled by 2^±664 (about 1e±200): the
    // float64 products would underflow or overflow; the guard sends them to the exact path.
    let upper: Tri = [[1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]];
    for k in [-664, 664] {
        let s = |p: P3| p.map(|x| ldexp(x, k));
        let tris = [upper.map(s), UNIT.map(s)];
        let (v, n) = counting(|| hit(s([0.5, 0.5, 1.0]), DOWN, &tris));
        let v = v.unwrap();
        assert_eq!(
            (v.t, v.ties.clone(), v.zero_signs),
            (ldexp(1.0, k), vec![0, 1], 1)
        );
        assert!(n >= 2);
        // Scaling d too leaves t unchanged.
        let v = hit(s([0.75, 0.75, 1.0]), s(DOWN), &tris).unwrap();
        assert_eq!((v.t, v.ties), (1.0, vec![0]));
    }
    // Decimal scales (not powers of two): against the rationals.
    let mut rng = Rng::xorshift(77);
    for scale in [1e-200, 1e-160, 1e160, 1e200] {
        for _ in 0..200 {
            let tris: Vec<Tri> = (0..4)
                .map(|_| [0; 3].map(|_| rng.p3().map(|x| x * scale)))
                .collect();
            let o = rng.p3().map(|x| x * scale);
            let d = rng.p3();
            let _ = check(o, d, -f64::INFINITY, f64::INFINITY, &tris);
        }
    }
}

/// With operands around 2^-540 the float64 products underflow: an unguarded filter would
/// certify the wrong sign here (it is worked out by hand), the guard defers it.
#[test]
fn underflow_guard_bites() {
    let p = |k: i32| 2f64.powi(k);
    let o = [0.0; 3];
    let d = [p(600), 1.0, 0.0];
    let a = [0.0, 3.0 * p(-540), p(-540)];
    let b = [-p(63), p(-538), p(-537)];
    // Exactly: d_x (a_y b_z − a_z b_y) + d_y (a_z b_x − a_x b_z)
    //        = 2^600 (3·2^-1077 − 2^-1078) − 2^-477 = 5·2^-478 − 4·2^-478 = 2^-478 > 0.
    let s = dot(d, cross(a, b));
    let bound = FILTER * perm(d, a, b);
    assert!(
        s < -bound,
        "the unguarded filter certifies a negative sign: {s:e} {bound:e}"
    );
    let (sign, n) = counting(|| side(o, d, a, b));
    assert_eq!((sign, n), (Ordering::Greater, 1));
}

#[test]
fn judge_precedence() {
    let v = Verdict {
        t: 2.0,
        ties: vec![3, 5],
        zero_signs: 1,
        bound: 1e-15,
        exact: Crossing {
            num: BigInt::from(2),
            den: BigInt::from(1),
            zero_signs: 1,
        },
    };
    let u = ulp_f64(2.0);
    let j = |failed, h| judge(Some(&v), failed, h, Precision::F64);
    assert_eq!(j(false, Some((5, 2.0))), Outcome::Right);
    assert_eq!(j(false, Some((3, 2.0 + u))), Outcome::Right);
    // One ulp below 2 is half of one above: two of those are still within ulp(2).
    assert_eq!(j(false, Some((3, 2.0 - u))), Outcome::Right);
    assert_eq!(j(false, Some((3, 2.0 + 2.0 * u))), Outcome::Wrong); // two ulps off
    assert_eq!(j(false, Some((3, 2.0 + 1e-12))), Outcome::Wrong);
    // In float32, 2 + a float32 ulp is right, 2 + two is not.
    let u32 = ulp_f32(2.0);
    let j32 = |h| judge(Some(&v), false, h, Precision::F32);
    assert_eq!(j32(Some((3, 2.0 + u32))), Outcome::Right);
    assert_eq!(j32(Some((3, 2.0 + 2.0 * u32))), Outcome::Wrong);
    assert_eq!(j(true, Some((3, 2.0))), Outcome::Failed);
    assert_eq!(j(true, None), Outcome::Failed);
    assert_eq!(j(false, None), Outcome::Leaked);
    assert_eq!(j(false, Some((4, 2.5))), Outcome::Late);
    assert_eq!(j(false, Some((4, 1.5))), Outcome::Wrong); // another triangle before t*
    assert_eq!(j(false, Some((4, 2.0))), Outcome::Wrong); // another triangle at t*
    assert_eq!(j(false, Some((3, f64::NAN))), Outcome::Wrong);
    assert_eq!(judge(None, false, None, Precision::F64), Outcome::Right);
    assert_eq!(
        judge(None, false, Some((0, 1.0)), Precision::F64),
        Outcome::Wrong
    );
    assert_eq!(judge(None, true, None, Precision::F64), Outcome::Failed);
    assert_eq!(ulp_f32(1.0), f32::EPSILON as f64);
    assert_eq!(ulp_f64(1.0), f64::EPSILON);
    assert_eq!(ulp_f64(0.0), f64::from_bits(1));
}

/// `B` covers a float64 Möller–Trumbore evaluation of t (anchored at the first vertex, as
/// docs/referee.md's second anchor), at healthy angles and grazing ones, and is a few ulps
/// at healthy angles.
#[test]
fn t_bound_covers_float_evaluation() {
    let mut rng = Rng::xorshift(5);
    let mut checked = 0;
    for i in 0..20_000 {
        let offset = [0.0, 1e3, 1e7][i % 3];
        let tri: Tri = [0; 3].map(|_| rng.p3().map(|x| x + offset));
        let target = [0, 1, 2].map(|k| (tri[0][k] + tri[1][k] + tri[2][k]) / 3.0);
        let mut o = rng.p3().map(|x| x * 4.0 + offset);
        let mut d = sub(target, o);
        if i % 4 == 0 {
            // Grazing: d nearly in the plane, from an origin behind the target along it.
            let n = cross(sub(tri[1], tri[0]), sub(tri[2], tri[0]));
            let k = dot(d, n) / dot(n, n) * (1.0 - 1e-6);
            d = [0, 1, 2].map(|a| d[a] - k * n[a]);
            o = [0, 1, 2].map(|a| target[a] - d[a]);
        }
        let Some(c) = crossing(o, d, &tri) else {
            continue;
        };
        let t = c.t();
        let b = t_bound(o, d, &tri, t);
        // Möller–Trumbore in float64.
        let (e1, e2) = (sub(tri[1], tri[0]), sub(tri[2], tri[0]));
        let pv = cross(d, e2);
        let inv = 1.0 / dot(e1, pv);
        let tf = dot(e2, cross(sub(o, tri[0]), e1)) * inv;
        // Against the exact t (not its rounding): the rounded t* is within half an ulp.
        let err = (BigRational::from_float(tf).unwrap()
            - BigRational::new(c.num.clone(), c.den.clone()))
        .abs();
        assert!(
            err <= BigRational::from_float(b).unwrap(),
            "case {i}: float t {tf} exact {t} bound {b:e}"
        );
        // Not absurdly loose where nothing is ill-conditioned: a fat triangle crossed at a
        // healthy angle from nearby (the permanents anchored at o grow with |o − a|³).
        let n = cross(sub(tri[1], tri[0]), sub(tri[2], tri[0]));
        let len = |v: P3| dot(v, v).sqrt();
        let healthy = dot(d, n).abs() > 0.3 * len(d) * len(n)
            && len(n) > 0.3 * len(sub(tri[1], tri[0])) * len(sub(tri[2], tri[0]));
        if i % 4 != 0 && offset == 0.0 && healthy {
            assert!(b <= 1e6 * f64::EPSILON * t.abs(), "case {i}: B {b:e} t {t}");
        }
        checked += 1;
    }
    assert!(checked > 15_000, "{checked}");
}

/// `B` does not collapse to 2ε|t| when one input is tiny: with an origin component of 1e-300
/// the pair's inputs scale to integers near 2^1050, whose den alone overflows float64 (the walk
/// fuzz's seed 7686576272770016265: a bound of 2.2e-16 where t's evaluation may be 6e-14 off).
/// It is the bound of the same ray from an origin moved by 1e-300 (to 0, an exactly equal den).
#[test]
fn t_bound_with_a_tiny_origin_component() {
    let tri: Tri = [
        [0.3333333134651184; 3],
        [0.6666666865348816, 0.3333333134651184, 0.3333333134651184],
        [0.6666666865348816, 0.6666666865348816, 0.6666666865348816],
    ];
    let o = [-0.43561294676897977, 1e-300, -0.24631735765479013];
    let d = [0.7689462602340982, 0.3333333134651184, 0.5796506711199085];
    let t = crossing(o, d, &tri)
        .expect("the ray crosses the triangle")
        .t();
    let den = exact::exact_den_abs(o, d, &tri);
    let plain = exact::exact_den_abs([o[0], 0.0, o[2]], d, &tri);
    assert!(den.is_finite() && den > 0.01, "den {den:e}");
    assert_eq!(den, plain);
    let b = t_bound(o, d, &tri, t);
    assert_eq!(b, t_bound([o[0], 0.0, o[2]], d, &tri, t));
    assert!(b > 1e-14 && b < 1e-12, "B {b:e}");
}

/// Random scenes, random and near-degenerate rays (through vertices and edge points, nudged
/// by ulps, far from the origin), random bounds: the referee against plain rationals.
#[test]
fn agrees_with_plain_rationals() {
    let mut rng = Rng::xorshift(11);
    let (mut hits, mut on_edges, mut at_vertices, mut tied) = (0, 0, 0, 0);
    for i in 0..3000 {
        let offset = [0.0, 1.0, 1e7, 1e-3][i % 4];
        let mut tris: Vec<Tri> = (0..6)
            .map(|_| [0; 3].map(|_| rng.p3().map(|x| x + offset)))
            .collect();
        // Some shared edges and vertices.
        tris[1][0] = tris[0][0];
        tris[1][1] = tris[0][1];
        tris[2][2] = tris[0][2];
        let o = rng.p3().map(|x| 3.0 * x - 1.0 + offset);
        // Aim at a vertex, an edge's midpoint or a random point; rounding of d nudges it.
        let tri = tris[(rng.f() * 6.0) as usize];
        let target = match i % 3 {
            0 => tri[0],
            1 => [0, 1, 2].map(|k| (tri[1][k] + tri[2][k]) * 0.5),
            _ => rng.p3().map(|x| x + offset),
        };
        let mut d = sub(target, o);
        if rng.f() < 0.3 {
            let k = (rng.f() * 3.0) as usize;
            d[k] = if rng.f() < 0.5 {
                d[k].next_up()
            } else {
                d[k].next_down()
            };
        }
        let (tmin, tmax) = match i % 5 {
            0 => (0.0, f64::INFINITY),
            1 => (f64::NEG_INFINITY, f64::INFINITY),
            2 => (1.0, 1.0), // exactly at the target when d was not nudged
            _ => (rng.f() * 0.5, 0.5 + rng.f()),
        };
        if let Some(v) = check(o, d, tmin, tmax, &tris) {
            hits += 1;
            on_edges += (v.zero_signs == 1) as usize;
            at_vertices += (v.zero_signs == 2) as usize;
            tied += (v.ties.len() > 1) as usize;
        }
    }
    eprintln!("{hits} hits, {on_edges} on edges, {at_vertices} at vertices, {tied} tied");
    // The degenerate cases are exercised (deterministic seed; a floor, not a fitted count).
    assert!(hits > 1000 && on_edges > 20 && at_vertices > 100 && tied > 50);
}

/// The referee against the rational brute force, with t's rounding checked.
fn check(o: P3, d: P3, tmin: f64, tmax: f64, tris: &[Tri]) -> Option<Verdict> {
    let got = first_hit(o, d, tmin, tmax, tris);
    let want = oracle(o, d, tmin, tmax, tris);
    match (&got, &want) {
        (None, None) => {}
        (Some(v), Some((t, ties))) => {
            assert_eq!(&v.ties, ties, "o={o:?} d={d:?} tris={tris:?}");
            // v.t is a nearest float: no neighbour is closer to t.
            let dist = |x: f64| (BigRational::from_float(x).unwrap() - t).abs();
            let here = dist(v.t);
            assert!(here <= dist(v.t.next_up()) && here <= dist(v.t.next_down()));
            for k in &v.ties {
                let c = crossing(o, d, &tris[*k]).unwrap();
                assert_eq!(&BigRational::new(c.num, c.den), t);
            }
            let zeros = rational_signs(o, d, &tris[v.ties[0]])
                .iter()
                .filter(|s| s.is_zero())
                .count();
            assert_eq!(v.zero_signs as usize, zeros);
        }
        _ => panic!("o={o:?} d={d:?}: referee {got:?}, rationals {want:?}"),
    }
    got
}

fn q3(p: P3) -> [BigRational; 3] {
    p.map(|x| BigRational::from_float(x).unwrap())
}

fn qsub(a: &[BigRational; 3], b: &[BigRational; 3]) -> [BigRational; 3] {
    [&a[0] - &b[0], &a[1] - &b[1], &a[2] - &b[2]]
}

fn qdet(a: &[BigRational; 3], b: &[BigRational; 3], c: &[BigRational; 3]) -> BigRational {
    &a[0] * (&b[1] * &c[2] - &b[2] * &c[1]) - &a[1] * (&b[0] * &c[2] - &b[2] * &c[0])
        + &a[2] * (&b[0] * &c[1] - &b[1] * &c[0])
}

fn rational_signs(o: P3, d: P3, tri: &Tri) -> [BigRational; 3] {
    let (o, d) = (q3(o), q3(d));
    let [a, b, c] = tri.map(q3);
    let (u, v, w) = (qsub(&a, &o), qsub(&b, &o), qsub(&c, &o));
    [qdet(&d, &u, &v), qdet(&d, &v, &w), qdet(&d, &w, &u)]
}

/// Brute force in plain rationals, straight from docs/referee.md.
fn oracle(o: P3, d: P3, tmin: f64, tmax: f64, tris: &[Tri]) -> Option<(BigRational, Vec<usize>)> {
    let mut best: Option<(BigRational, Vec<usize>)> = None;
    for (k, tri) in tris.iter().enumerate() {
        let s = rational_signs(o, d, tri);
        let meets = (s.iter().all(|x| !x.is_negative()) || s.iter().all(|x| !x.is_positive()))
            && s.iter().any(|x| !x.is_zero());
        if !meets {
            continue;
        }
        let (oq, [a, b, c]) = (q3(o), tri.map(q3));
        let num = qdet(&qsub(&a, &oq), &qsub(&b, &oq), &qsub(&c, &oq));
        let t = num / (&s[0] + &s[1] + &s[2]);
        let lo_ok = tmin == f64::NEG_INFINITY || t >= BigRational::from_float(tmin).unwrap();
        let hi_ok = tmax == f64::INFINITY || t <= BigRational::from_float(tmax).unwrap();
        if !(lo_ok && hi_ok) {
            continue;
        }
        match &mut best {
            Some((bt, ties)) if *bt == t => ties.push(k),
            Some((bt, _)) if *bt < t => {}
            _ => best = Some((t, vec![k])),
        }
    }
    best
}

use crate::rng::Rng;
