//! `rounded_hit` against rationals (`num_rational`, apart from the dyadic numbers the code
//! falls back to): every value within one ulp of the exact one, across the distances and
//! angles where the old formula lost digits, and where the filter must hand over.

use super::*;
use crate::rng::Rng;
use num_bigint::BigInt;
use num_rational::BigRational;
use num_traits::{Signed, Zero};

type Q = BigRational;

fn q(x: f64) -> Q {
    Q::from_float(x).unwrap()
}

fn det(a: &[Q; 3], b: &[Q; 3], c: &[Q; 3]) -> Q {
    &a[0] * (&b[1] * &c[2] - &b[2] * &c[1]) - &a[1] * (&b[0] * &c[2] - &b[2] * &c[0])
        + &a[2] * (&b[0] * &c[1] - &b[1] * &c[0])
}

/// The exact t, u, v and point, None when D = 0.
fn exact(o: V3<f64>, d: V3<f64>, tri: &[V3<f64>; 3]) -> Option<(Q, Q, Q, [Q; 3])> {
    let x = |v: V3<f64>| v.map(q);
    let sub = |p: &[Q; 3], r: &[Q; 3]| [0, 1, 2].map(|k| &p[k] - &r[k]);
    let (o, d) = (x(o), x(d));
    let [a, b, c] = tri.map(x);
    let (w, e1, e2) = (sub(&a, &o), sub(&b, &a), sub(&c, &a));
    let den = det(&d, &e1, &e2);
    if den.is_zero() {
        return None;
    }
    let t = det(&w, &e1, &e2) / &den;
    let u = det(&d, &e2, &w) / &den;
    let v = det(&d, &w, &e1) / &den;
    let p = [0, 1, 2].map(|k| &o[k] + &t * &d[k]);
    // The two forms of the point agree (a check of this judge, not of the code).
    for (k, pk) in p.iter().enumerate() {
        assert_eq!(*pk, &a[k] + &u * &e1[k] + &v * &e2[k]);
    }
    Some((t, u, v, p))
}

/// The float64 spacing in the binade of the exact x (2^-1074 at zero and among subnormals).
fn ulp_of(x: &Q) -> Q {
    let two = Q::from_integer(BigInt::from(2));
    let mut e: i32 = 0;
    let a = x.abs();
    if a.is_zero() {
        return q(f64::from_bits(1));
    }
    let mut p = Q::from_integer(BigInt::from(1));
    while p > a {
        p = &p / &two;
        e -= 1;
    }
    while &p * &two <= a {
        p = &p * &two;
        e += 1;
    }
    // 2^e ≤ |x| < 2^(e+1)
    q(2f64.powi(e.max(-1022) - 52))
}

/// |x − x*| ≤ ulp(x*), exactly.
fn within_ulp(x: f64, exact: &Q) -> bool {
    x.is_finite() && (q(x) - exact).abs() <= ulp_of(exact)
}

fn check(o: V3<f64>, d: V3<f64>, tri: &[V3<f64>; 3], what: &str) -> Option<RoundedHit> {
    let got = rounded_hit(o, d, tri);
    let want = exact(o, d, tri);
    // The two ways of splitting products give the same bits.
    assert_eq!(
        got,
        rounded_hit_with::<false>(o, d, tri),
        "{what}: FMA vs Dekker"
    );
    match (got, want) {
        (None, None) => None,
        (Some(h), Some((t, u, v, p))) => {
            assert!(within_ulp(h.t, &t), "{what}: t {} vs {}", h.t, t);
            assert!(
                q(h.t_err) >= (q(h.t) - &t).abs(),
                "{what}: t_err {} does not bound the error",
                h.t_err
            );
            assert!(within_ulp(h.u, &u), "{what}: u {} vs {}", h.u, u);
            assert!(within_ulp(h.v, &v), "{what}: v {} vs {}", h.v, v);
            for (k, (got, want)) in h.point.iter().zip(&p).enumerate() {
                assert!(within_ulp(*got, want), "{what}: point[{k}] {got} vs {want}");
            }
            Some(h)
        }
        (g, w) => panic!("{what}: got {g:?}, exact {:?}", w.map(|x| x.0)),
    }
}

fn unit(rng: &mut Rng) -> V3<f64> {
    loop {
        let v = [0, 1, 2].map(|_| 2.0 * rng.f() - 1.0);
        let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        if n > 0.1 && n <= 1.0 {
            return v.map(|x| x / n);
        }
    }
}

fn random_triangle(rng: &mut Rng, centre: V3<f64>, size: f64) -> [V3<f64>; 3] {
    [0, 1, 2].map(|_| [0, 1, 2].map(|k| centre[k] + size * (2.0 * rng.f() - 1.0)))
}

/// A point of the triangle: inside (random weights), on an edge or at a vertex, in float64
/// (so the exact hit is near it, not on it, unless the weights are exact).
fn aim(rng: &mut Rng, tri: &[V3<f64>; 3], kind: u64) -> V3<f64> {
    let (mut wb, mut wc) = (rng.f(), rng.f());
    if wb + wc > 1.0 {
        (wb, wc) = (1.0 - wb, 1.0 - wc);
    }
    match kind % 3 {
        1 => wc = 0.0,
        2 => (wb, wc) = (0.0, 0.0),
        _ => {}
    }
    let [a, b, c] = *tri;
    [0, 1, 2].map(|k| a[k] + wb * (b[k] - a[k]) + wc * (c[k] - a[k]))
}

/// Origins at 3 to 1e8 from a unit-sized triangle near the origin, aimed at its inside, its
/// edges and its vertices: where `det(a − o, b − o, c − o)` lost up to 12 digits.
#[test]
fn far_origins_are_faithful() {
    let mut rng = Rng::new(0x5eed_0032);
    for r in [3.0, 1e2, 1e4, 1e6, 1e8] {
        for i in 0..400u64 {
            let tri = random_triangle(&mut rng, [0.0; 3], 1.0);
            let target = aim(&mut rng, &tri, i);
            let o = unit(&mut rng).map(|x| x * r);
            let d = [0, 1, 2].map(|k| target[k] - o[k]);
            check(o, d, &tri, &format!("R={r} case {i}")).expect("aimed at the triangle");
        }
    }
}

/// Tiny triangles (1e-3 to 1e-9 across) from far away, and a mesh far from the origin
/// (offset 1e6) with origins beside it.
#[test]
fn tiny_and_offset_triangles_are_faithful() {
    let mut rng = Rng::new(0x7171);
    for (centre, size, r) in [
        ([0.0; 3], 1e-3, 1e3),
        ([0.0; 3], 1e-9, 1.0),
        ([1e6, -1e6, 1e6], 1.0, 3.0),
        ([1e6, 1e6, 1e6], 1e-3, 10.0),
    ] {
        for i in 0..300u64 {
            let tri = random_triangle(&mut rng, centre, size);
            let target = aim(&mut rng, &tri, i);
            let dir = unit(&mut rng);
            let o = [0, 1, 2].map(|k| target[k] + r * dir[k]);
            let d = [0, 1, 2].map(|k| target[k] - o[k]);
            check(
                o,
                d,
                &tri,
                &format!("centre {centre:?} size {size} case {i}"),
            );
        }
    }
}

/// Grazing rays, exact zeros (a floor at z = 0, edge hits with u = 0), parallel lines, and
/// operands outside the filter's range (the exact path).
#[test]
fn degenerate_and_extreme_inputs_are_exact() {
    let floor = [[0.0, 0.0, 0.0], [4.0, 0.0, 0.0], [0.0, 4.0, 0.0]];
    // A floor at z = 0: the point's z is exactly 0 (anchored at the triangle).
    let h = check([0.3, 0.7, 5.0], [0.1, 0.2, -1.0], &floor, "floor").unwrap();
    assert_eq!(h.point[2], 0.0);
    // On the edge a–b: v = 0 exactly.
    let h = check([1.0, 0.0, 1.0], [0.0, 0.0, -1.0], &floor, "edge").unwrap();
    assert_eq!((h.v, h.t), (0.0, 1.0));
    // Parallel to the plane: no hit.
    assert!(check([0.0, 0.0, 1.0], [1.0, 2.0, 0.0], &floor, "parallel").is_none());
    // Grazing at 1e-12 rad, and from 1e8 away at a grazing angle.
    check([-1.0, 0.5, 1e-12], [1.0, 0.0, -1e-12], &floor, "grazing");
    check([-1e8, 0.5, 1e-4], [1e8, 0.3, -1e-4], &floor, "far grazing");
    // Tiny and huge coordinates and directions.
    let tiny = floor.map(|p| p.map(|x| x * 1e-300));
    check([1e-300, 1e-300, 1e-300], [0.0, 0.0, -1.0], &tiny, "tiny");
    let huge = floor.map(|p| p.map(|x| x * 1e300));
    check([1e299, 1e299, 1e300], [1e299, 0.0, -1e300], &huge, "huge");
    // A t beyond float64 is infinite (the caller marks such a ray INVALID).
    let far = rounded_hit([1e299, 1e299, 1e300], [1e-300, 0.0, -1e-300], &huge).unwrap();
    assert_eq!(far.t, f64::INFINITY);
    check(
        [0.5, 0.5, 1.0],
        [5e-324, 0.0, -1e-300],
        &floor,
        "denormal direction",
    );
    // The origin on the plane: t = 0 exactly.
    let h = check([0.5, 0.5, 0.0], [0.0, 1.0, 1.0], &floor, "origin on plane").unwrap();
    assert_eq!(h.t, 0.0);
}

/// Random rays on grids (many exact zeros and ties) and at random scales.
#[test]
fn random_rays_are_faithful() {
    let mut rng = Rng::new(0xfa17);
    for i in 0..3000u64 {
        let grid = i % 2 == 0;
        let mut v = || {
            if grid {
                (rng.f() * 8.0).floor() / 4.0 - 1.0
            } else {
                (2.0 * rng.f() - 1.0) * 2f64.powi((rng.u64() % 40) as i32 - 20)
            }
        };
        let tri = [[v(), v(), v()], [v(), v(), v()], [v(), v(), v()]];
        let o = [v(), v(), v()];
        let d = [v(), v(), v()];
        if d == [0.0; 3] {
            continue;
        }
        check(o, d, &tri, &format!("case {i}"));
    }
}

/// The exact quotient rounds to nearest, across the range (against rationals).
#[test]
fn dyadic_quotients_round_to_nearest() {
    let mut rng = Rng::new(0xd1d);
    let nearest = |x: &Q| -> f64 {
        // The float nearest x: the candidates around x's float64 approximation.
        let approx = {
            let (n, d) = (x.numer(), x.denom());
            let (nb, db) = (n.bits() as i64, d.bits() as i64);
            let shift = 60 - (nb - db);
            let scaled = if shift >= 0 {
                (n << shift as usize) / d
            } else {
                n / (d << (-shift) as usize)
            };
            let m: f64 = scaled.to_string().parse().unwrap();
            m * 2f64.powi(-shift as i32)
        };
        let mut best = approx;
        let mut c = approx;
        for _ in 0..4 {
            c = c.next_down();
        }
        for _ in 0..9 {
            let better = (q(c) - x).abs() < (q(best) - x).abs()
                || ((q(c) - x).abs() == (q(best) - x).abs() && c.to_bits() % 2 == 0);
            if c.is_finite() && better {
                best = c;
            }
            c = c.next_up();
        }
        best
    };
    for _ in 0..3000 {
        let mut v = || (2.0 * rng.f() - 1.0) * 2f64.powi((rng.u64() % 200) as i32 - 100);
        let (a, b, c) = (v(), v(), v());
        let (da, db, dc) = (
            Dyadic::from_f64(a),
            Dyadic::from_f64(b),
            Dyadic::from_f64(c),
        );
        let num = &da * &db + &dc;
        let got = Dyadic::quotient(&num, &dc);
        let want = nearest(&((q(a) * q(b) + q(c)) / q(c)));
        assert_eq!(got, want, "({a} {b} + {c}) / {c}");
    }
    // Subnormal and overflowing quotients.
    let one = Dyadic::from_f64(1.0);
    let sub = Dyadic::from_f64(5e-324);
    assert_eq!(Dyadic::quotient(&sub, &Dyadic::from_f64(2.0)), 0.0); // a tie: to even
    assert_eq!(Dyadic::quotient(&sub, &Dyadic::from_f64(1.5)), 5e-324);
    assert_eq!(Dyadic::quotient(&one, &sub), f64::INFINITY);
    assert_eq!(Dyadic::quotient(&-&one, &Dyadic::from_f64(3.0)), -1.0 / 3.0);
}
