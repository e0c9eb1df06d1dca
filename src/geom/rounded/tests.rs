//! `rounded_hit` against rationals (`num_rational`, apart from the dyadic numbers the code
//! falls back to): every value within one ulp of the exact one, across the distances and
//! angles where the old formula lost digits, and where the filter must hand over.

use super::*;
use crate::geom::narrow::{triangle_hit32, triangle_hit32_at, Hit32};
use crate::geom::real::exponent;
use crate::rng::Rng;
use crate::simd::Simd;
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

/// The ray and triangle as rationals: `[o, d, a, w = a − o, e1 = b − a, e2 = c − a]`.
fn frame(o: V3<f64>, d: V3<f64>, tri: &[V3<f64>; 3]) -> [[Q; 3]; 6] {
    let sub = |p: &[Q; 3], r: &[Q; 3]| [0, 1, 2].map(|k| &p[k] - &r[k]);
    let [a, b, c] = tri.map(|p| p.map(q));
    let (o, d) = (o.map(q), d.map(q));
    let (w, e1, e2) = (sub(&a, &o), sub(&b, &a), sub(&c, &a));
    [o, d, a, w, e1, e2]
}

/// The exact t, u, v and point, None when D = 0.
fn exact(o: V3<f64>, d: V3<f64>, tri: &[V3<f64>; 3]) -> Option<(Q, Q, Q, [Q; 3])> {
    let [o, d, a, w, e1, e2] = frame(o, d, tri);
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
    // 2^e ≤ |x| < 2^(e+1); the spacing 2^(e − 52), from its bits (`powi` of a power
    // below 2^-1022 may compute 1 / 2^-k = 1 / inf = 0 where it is not folded).
    let k = e.max(-1022) - 52;
    q(if k >= -1022 {
        f64::from_bits(((k + 1023) as u64) << 52)
    } else {
        f64::from_bits(1 << (k + 1074))
    })
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
            check32(
                o,
                d,
                tri,
                &h,
                &[t, u, v, p[0].clone(), p[1].clone(), p[2].clone()],
                what,
            );
            Some(h)
        }
        (g, w) => panic!("{what}: got {g:?}, exact {:?}", w.map(|x| x.0)),
    }
}

/// The float32 neighbours of a finite float32 y, as float64 (±inf past the range).
fn neighbours32(y: f32) -> (f64, f64) {
    let step = |up: bool| {
        if y == 0.0 {
            let tiny = f32::from_bits(1) as f64;
            return if up { tiny } else { -tiny };
        }
        // Away from zero is bits + 1 on either sign.
        let away = (y > 0.0) == up;
        f32::from_bits(if away {
            y.to_bits() + 1
        } else {
            y.to_bits() - 1
        }) as f64
    };
    (step(false), step(true))
}

/// What a float32 output stores: where `triangle_hit32` answers, its values are the faithful
/// ones' float32 roundings bit for bit (what the slow path stores), and each is the float32
/// nearest the exact value, with the exact value strictly between the rounding boundaries
/// (rationals). True when it answered.
fn check32(
    o: V3<f64>,
    d: V3<f64>,
    tri: &[V3<f64>; 3],
    h: &RoundedHit,
    exact: &[Q; 6],
    what: &str,
) -> bool {
    let Some(n) = hit32_at_every_level(o, d, tri, what) else {
        return false;
    };
    let slow = [h.t, h.u, h.v, h.point[0], h.point[1], h.point[2]];
    let fast = [n.t, n.u, n.v, n.point[0], n.point[1], n.point[2]];
    for (i, ((&f, &s), x)) in fast.iter().zip(&slow).zip(exact).enumerate() {
        assert_eq!(
            f.to_bits(),
            (s as f32).to_bits(),
            "{what}: value {i}: {f} vs {s}"
        );
        let (below, above) = neighbours32(f);
        let y = q(f as f64);
        let two = q(2.0);
        // On a boundary (a flat triangle's coordinate, exact: nothing else answers there)
        // the tie goes to the even float32, as `as f32` rounds.
        let even = f.to_bits() & 1 == 0;
        let low = (q(below) + &y) / &two;
        let high = (&y + q(above)) / &two;
        assert!(
            (low < *x || (even && low == *x))
                && (above.is_infinite() || *x < high || (even && *x == high)),
            "{what}: value {i}: {f} is not the float32 nearest {x}"
        );
    }
    true
}

/// `triangle_hit32`, after checking that every SIMD level this CPU runs gives the same answer
/// bit for bit (declining where it declines).
fn hit32_at_every_level(o: V3<f64>, d: V3<f64>, tri: &[V3<f64>; 3], what: &str) -> Option<Hit32> {
    let bits = |h: Option<Hit32>| {
        h.map(|h| [h.t, h.u, h.v, h.point[0], h.point[1], h.point[2]].map(f32::to_bits))
    };
    let portable = triangle_hit32(o, d, tri);
    for simd in Simd::supported_levels() {
        let kernel = crate::geom::narrow::avx2_hits();
        assert_eq!(
            bits(triangle_hit32_at(simd, o, d, tri)),
            bits(portable),
            "{what}: {simd:?} differs from the portable code"
        );
        // Each level runs its own code (the answers alone could not tell them apart).
        assert_eq!(
            crate::geom::narrow::avx2_hits() - kernel,
            (simd == Simd::Avx2) as u64,
            "{what}: AVX2 kernel runs at {simd:?}"
        );
    }
    portable
}

/// Every SIMD level of `triangle_hit32` answers as the portable code, bit for bit, and
/// declines where it declines: hits at scales from 2^-60 to 2^60 (where the slack decides
/// between answering and declining at random), grazing rays (a denominator within its bound),
/// slivers, rays aimed at corners and edges, and operands whose permanents underflow below
/// TINY or overflow.
#[test]
fn float32_hits_are_the_same_at_every_simd_level() {
    if cfg!(target_arch = "x86_64") && std::env::var_os("CI").is_some() {
        assert!(Simd::Avx2.supported(), "CI must compare the AVX2 level");
    }
    let mut rng = Rng::new(0x5132);
    let (mut answered, mut declined) = (0, 0);
    for i in 0..20_000u64 {
        let scale = 2f64.powi(rng.below(121) as i32 - 60);
        let mut tri = random_triangle(&mut rng, [0.0; 3], scale);
        if rng.chance(0.1) {
            // A sliver: the third corner on (or an ulp from) the first edge.
            tri[2] = [0, 1, 2].map(|k| tri[0][k] + 0.5 * (tri[1][k] - tri[0][k]));
        }
        let kind = rng.below(3) as u64;
        let target = aim(&mut rng, &tri, kind);
        let o = unit(&mut rng).map(|x| x * scale * (0.01 + 100.0 * rng.f()));
        let mut d = [0, 1, 2].map(|k| target[k] - o[k]);
        if rng.chance(0.1) {
            // Grazing: d nearly in the triangle's plane.
            let e = [0, 1, 2].map(|k| tri[1][k] - tri[0][k]);
            d = [0, 1, 2].map(|k| e[k] + d[k] * 1e-12);
        }
        if rng.chance(0.02) {
            // Out of range: permanents below TINY or past float64.
            let f = if rng.chance(0.5) { 1e-200 } else { 1e200 };
            tri = tri.map(|p| p.map(|x| x * f));
        }
        match hit32_at_every_level(o, d, &tri, &format!("case {i}")) {
            Some(_) => answered += 1,
            None => declined += 1,
        }
    }
    // Both branches are compared, each many times.
    assert!(
        answered > 5_000 && declined > 500,
        "{answered} answered, {declined} declined"
    );
}

/// Hits whose permanents lie around `TINY`, where one of the four alone is at or below it
/// (below TINY products may have underflowed and the float32 path's bound no longer holds:
/// every level must decline). The triangle lies in the plane z = 0, so each term of each
/// permanent has exactly one factor from the z column (the origin's height or the
/// direction's z): scaling z by 2^-k scales all four permanents by 2^-k exactly and leaves
/// t, u, v and the point as they were (float32 numbers still). The triangle's stretch, the
/// origin's offset and the direction's length, each over 2^±5, spread the four apart; k
/// puts the least at or below TINY (one time in four just above it). `check` judges each hit
/// by rationals and compares every SIMD level with the portable code, which must decline
/// alike. The counts (from `det_perm`) show that each permanent alone below TINY occurs.
#[test]
fn float32_hits_at_the_permanents_floor_decline_at_every_level_alike() {
    use crate::geom::exact::{det_perm, TINY};
    let mut rng = Rng::new(0x71e4);
    let pow2 = |k: i32| f64::from_bits(((1023 + k) as u64) << 52);
    let perms = |o: V3<f64>, d: V3<f64>, tri: &[V3<f64>; 3]| {
        let [a, b, c] = *tri;
        let w = [0, 1, 2].map(|k| a[k] - o[k]);
        let e1 = [0, 1, 2].map(|k| b[k] - a[k]);
        let e2 = [0, 1, 2].map(|k| c[k] - a[k]);
        [
            det_perm(w, e1, e2).1,
            det_perm(d, e1, e2).1,
            det_perm(d, e2, w).1,
            det_perm(d, w, e1).1,
        ]
    };
    let (mut alone_below, mut all_above) = ([0u32; 4], 0);
    for i in 0..4000u64 {
        let mut tri = random_triangle(&mut rng, [0.0; 3], 1.0);
        let stretch = pow2(rng.below(11) as i32 - 5);
        tri[2] = [0, 1, 2].map(|k| tri[0][k] + (tri[2][k] - tri[0][k]) * stretch);
        for p in &mut tri {
            p[2] = 0.0;
        }
        let target = aim(&mut rng, &tri, i);
        let off = pow2(rng.below(11) as i32 - 5);
        let o = [
            target[0] + off * (2.0 * rng.f() - 1.0),
            target[1] + off * (2.0 * rng.f() - 1.0),
            1.0 + rng.f(),
        ];
        let long = pow2(rng.below(11) as i32 - 5);
        let d = [0, 1, 2].map(|k| (target[k] - o[k]) * long);
        // 2^-k on z scales every permanent by 2^-k: the least k putting the least at or
        // below TINY.
        let least = perms(o, d, &tri).into_iter().fold(f64::INFINITY, f64::min);
        if least <= 0.0 {
            continue;
        }
        let mut k = (least / TINY).log2().floor() as i32;
        while least * pow2(-k) > TINY {
            k += 1;
        }
        if rng.chance(0.25) {
            k -= 1;
        }
        let low = |p: V3<f64>| [p[0], p[1], p[2] * pow2(-k)];
        let (o, d) = (low(o), low(d));
        check(o, d, &tri, &format!("case {i}"));
        let p = perms(o, d, &tri);
        let below: Vec<usize> = (0..4).filter(|&j| p[j] <= TINY).collect();
        match below[..] {
            [] => all_above += 1,
            [j] => alone_below[j] += 1,
            _ => {}
        }
    }
    assert!(
        alone_below.iter().all(|&n| n >= 50) && all_above >= 500,
        "alone below TINY (t, den, u, v): {alone_below:?}; all above: {all_above}"
    );
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
    // A direction of 2^1000 from 1e-9 above the floor: t ≈ 2^-1030 is subnormal, so the
    // filter's t (for the direction scaled to [1, 2)) would be rounded a second time going
    // back: the exact path answers, and `t_err` bounds that rounding.
    let big = 2f64.powi(1000);
    let h = check(
        [0.3, 0.7, 1e-9],
        [0.1 * big, 0.2 * big, -big],
        &floor,
        "subnormal t",
    )
    .unwrap();
    assert!(h.t > 0.0 && !h.t.is_normal(), "{}", h.t);
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
    // The largest binades: quotients from 2^1022 up to f64::MAX are finite (the overflow
    // test is on the exponent of the quotient's leading bit, 1023 at most), and the first
    // past f64::MAX by more than half an ulp is infinite.
    let max = Dyadic::from_f64(f64::MAX);
    for (num, den, want) in [
        (2f64.powi(1023), 1.0, 2f64.powi(1023)),
        (2f64.powi(1022), 1.0, 2f64.powi(1022)),
        (f64::MAX, 1.0, f64::MAX),
        (f64::MAX, 2.0, f64::MAX / 2.0),
        (-3.0 * 2f64.powi(1021), 1.0, -3.0 * 2f64.powi(1021)),
    ] {
        let (n, d) = (Dyadic::from_f64(num), Dyadic::from_f64(den));
        assert_eq!(Dyadic::quotient(&n, &d), want, "{num} / {den}");
    }
    assert_eq!(Dyadic::quotient(&(&max + &max), &one), f64::INFINITY);
    // A subnormal quotient whose bits past float64's 53 decide it: 2^-1075 (1 + 2^-60) lies
    // just above the tie between 0 and 2^-1074. Rounded to 53 bits first, it would be the
    // tie itself, and then rounded to even: 0.
    let num = &Dyadic::from_f64(2f64.powi(-1014)) + &sub;
    let den = Dyadic::from_f64(2f64.powi(61));
    assert_eq!(Dyadic::quotient(&num, &den), 5e-324);
    assert_eq!(Dyadic::quotient(&-&num, &den), -5e-324);
}

/// Rays of every family above through a float32 output: `triangle_hit32` answers most hits
/// (`check` judges each answer), so the slow path is the exception.
#[test]
fn float32_outputs_mostly_skip_the_slow_path() {
    let mut rng = Rng::new(0x3232);
    let (mut fast, mut hits) = (0, 0);
    for i in 0..2000u64 {
        let tri = random_triangle(&mut rng, [0.0; 3], 1.0);
        let target = aim(&mut rng, &tri, 0);
        let o = unit(&mut rng).map(|x| x * (2.0 + 100.0 * rng.f()));
        let d = [0, 1, 2].map(|k| target[k] - o[k]);
        let Some(h) = check(o, d, &tri, &format!("case {i}")) else {
            continue;
        };
        let (t, u, v, p) = exact(o, d, &tri).unwrap();
        hits += 1;
        fast += check32(
            o,
            d,
            &tri,
            &h,
            &[t, u, v, p[0].clone(), p[1].clone(), p[2].clone()],
            "again",
        ) as u32;
    }
    assert!(
        fast * 100 >= hits * 95,
        "{fast} of {hits} hits answered in float64"
    );
}

/// A hit whose exact t lies on a float32 rounding boundary (the midpoint of two float32s) or a
/// few float64 ulps from one: `triangle_hit32` declines where the boundary is within its bound
/// (always, on the boundary itself), and is right wherever it answers. The line from the
/// origin along a direction of powers of two passes the triangle's centroid P = m d at exactly
/// t = m; the cases where a corner is not exact in float64 are skipped (and counted).
#[test]
fn float32_rounding_boundaries_are_left_to_the_slow_path() {
    let mut rng = Rng::new(0xb0da);
    let (mut kept, mut fast, mut on_boundary) = (0, 0, 0);
    for i in 0..4000u64 {
        let y = (1.0 + rng.f()) as f32 * 2f32.powi(rng.below(20) as i32 - 10);
        let mid = (y as f64 + f32::from_bits(y.to_bits() + 1) as f64) / 2.0;
        let k = rng.below(9) as i64 - 4;
        let t = f64::from_bits((mid.to_bits() as i64 + k) as u64);
        let pow = |rng: &mut Rng| {
            2f64.powi(-(rng.below(4) as i32)) * if rng.chance(0.5) { 1.0 } else { -1.0 }
        };
        let mut d = [pow(&mut rng), pow(&mut rng), pow(&mut rng)];
        d.rotate_left(rng.below(3));
        let p = d.map(|x| x * t);
        // Two corners that move p's coordinates towards zero by multiples of 2^-10 of their
        // binades (exact: below |p|/4, on p's grid), the third closing the centroid (exact,
        // or the case is skipped).
        let off = |rng: &mut Rng| {
            p.map(|x| -x.signum() * (1 + rng.below(200)) as f64 * 2f64.powi(exponent(x.abs()) - 10))
        };
        let (oa, ob) = (off(&mut rng), off(&mut rng));
        let a = [0, 1, 2].map(|j| p[j] + oa[j]);
        let b = [0, 1, 2].map(|j| p[j] + ob[j]);
        let c = [0, 1, 2].map(|j| p[j] - oa[j] - ob[j]);
        let tri = [a, b, c];
        let o = [0.0; 3];
        let centred = (0..3).all(|j| q(a[j]) + q(b[j]) + q(c[j]) == q(3.0) * q(p[j]));
        let Some((te, u, v, pt)) = exact(o, d, &tri) else {
            continue;
        };
        if !centred || te != q(t) {
            continue;
        }
        kept += 1;
        let h = rounded_hit(o, d, &tri).unwrap();
        let answered = check32(
            o,
            d,
            &tri,
            &h,
            &[te, u, v, pt[0].clone(), pt[1].clone(), pt[2].clone()],
            &format!("case {i}"),
        );
        fast += answered as u32;
        if k == 0 {
            on_boundary += 1;
            assert!(
                !answered,
                "case {i}: t = {t} is a float32 rounding boundary, yet answered"
            );
        }
    }
    assert!(
        kept >= 1000 && on_boundary >= 100,
        "{kept} cases kept, {on_boundary} on a boundary"
    );
    assert!(fast < kept, "every case answered: no boundary was near");
}

/// A triangle flat in coordinate k (a floor at y = 0, a wall at x = c): the hit's coordinate
/// k is c exactly, and both paths store it as c (+0 for either zero), the float32 path
/// without declining, whatever c's float32 rounding (a float32 midpoint included: c itself,
/// not an interval around it, is rounded). Beside them, triangles with one edge in such a
/// plane, which are not flat. `check` judges every value by rationals and the float32
/// answer against the slow path's bits.
#[test]
fn flat_triangles_answer_in_float32() {
    let mut rng = Rng::new(0xf1a7);
    let midpoint = (1.0f32 as f64 + f32::from_bits(1.0f32.to_bits() + 1) as f64) / 2.0;
    let (mut hits, mut fast) = (0, 0);
    for i in 0..3000u64 {
        let k = rng.below(3);
        let c = [0.0, -0.0, 548.8, midpoint, -3.25e-20][rng.below(5)];
        let mut tri = random_triangle(&mut rng, [0.0; 3], 1.0);
        // One case in four has only an edge in the plane (two corners share c, the third
        // does not): not flat, and its hits' coordinate k is c only on that edge.
        let flat = i % 4 != 0;
        for p in &mut tri[..if flat { 3 } else { 2 }] {
            p[k] = c;
        }
        // Inside, on an edge, at a vertex (u or v zero: the float32 path declines there,
        // and the slow path's sums could have given −0 on the plane x_k = −0).
        let target = aim(&mut rng, &tri, i % 3);
        let o = unit(&mut rng).map(|x| x * (2.0 + 100.0 * rng.f()));
        let d = [0, 1, 2].map(|j| target[j] - o[j]);
        let what = format!("case {i}: plane x{k} = {c:e}");
        let Some(h) = check(o, d, &tri, &what) else {
            continue;
        };
        let answered = hit32_at_every_level(o, d, &tri, &what);
        if !flat {
            continue;
        }
        hits += 1;
        assert_eq!(h.point[k].to_bits(), (c + 0.0).to_bits(), "{what}");
        if let Some(n) = answered {
            fast += 1;
            assert_eq!(n.point[k].to_bits(), (c as f32 + 0.0).to_bits(), "{what}");
        }
    }
    // Only u or v at zero (two thirds of the aims: edges, vertices) and t, u or v near a
    // float32 boundary decline; the flat coordinate never does.
    assert!(
        hits > 2000 && fast * 100 >= hits * 33,
        "{fast} of {hits} hits answered in float32"
    );
}

/// The permanent `Σ |x_i| (|y_j z_k| + |y_k z_j|)` of `det(x, y, z)`, exactly.
fn permanent(x: &[Q; 3], y: &[Q; 3], z: &[Q; 3]) -> Q {
    (0..3)
        .map(|i| {
            let (j, k) = ((i + 1) % 3, (i + 2) % 3);
            x[i].abs() * ((&y[j] * &z[k]).abs() + (&y[k] * &z[j]).abs())
        })
        .fold(Q::zero(), |s, x| s + x)
}

/// Hits whose values are far from cancelling take no exact value: the double-double filter
/// answers them all. Where each determinant is at least 2^-20 of its permanent P, the filter's
/// bound K ε² P is at most 2^(10 − 106 + 20) = 2^-76 of the value, so a quotient's bound
/// (both operands' bounds carried through, plus the remainder's roundings of order ε²) stays
/// below 2^-74 of it. The point's coordinates lie in [4, 6] times the case's scale (corners
/// there, weights at least 0.05), its terms are at most 2 beside them and their roundings of
/// order ε², so its bound is as small. The rounding itself is at most half an ulp, and
/// `faithful` accepts up to a whole one (half, below a power of two: such a value is counted,
/// not judged). So every case kept must answer without the exact values; `check` judges each
/// answer. The scales, 2^-60 to 2^60, leave every value's bound relative to it.
#[test]
fn well_conditioned_hits_never_take_the_exact_path() {
    let mut rng = Rng::new(0x0c0d);
    let (mut kept, mut powers) = (0, 0);
    for i in 0..3000u64 {
        let tri = random_triangle(&mut rng, [5.0; 3], 1.0);
        let (mut wb, mut wc) = (0.05 + 0.9 * rng.f(), 0.05 + 0.9 * rng.f());
        if wb + wc > 0.95 {
            (wb, wc) = (1.0 - wb, 1.0 - wc);
        }
        let [a, b, c] = tri;
        let target = [0, 1, 2].map(|k| a[k] + wb * (b[k] - a[k]) + wc * (c[k] - a[k]));
        let o = unit(&mut rng).map(|x| x * (2.0 + 100.0 * rng.f()));
        let o = [0, 1, 2].map(|k| target[k] + o[k]);
        // Scaled, so that t (near 1 / s) is not 1.
        let s = 0.3 + 3.0 * rng.f();
        let d = [0, 1, 2].map(|k| (target[k] - o[k]) * s);
        // The whole case scaled by 2^j, exactly (every value scales with it, t, u and v not
        // at all): the bounds are relative, so a bound that adds an absolute term shows.
        let j = rng.below(121) as i32 - 60;
        let (tri, o, d) = (
            tri.map(|p| p.map(|x| x * 2f64.powi(j))),
            o.map(|x| x * 2f64.powi(j)),
            d.map(|x| x * 2f64.powi(j)),
        );
        // The condition of the four determinants, by rationals.
        let [_, dq, _, w, e1, e2] = frame(o, d, &tri);
        let bound = q(2f64.powi(-20));
        let conditioned = [
            (&w, &e1, &e2),
            (&dq, &e1, &e2),
            (&dq, &e2, &w),
            (&dq, &w, &e1),
        ]
        .iter()
        .all(|(x, y, z)| det(x, y, z).abs() >= &bound * permanent(x, y, z));
        if !conditioned {
            continue;
        }
        let before = exact_hits();
        let h = check(o, d, &tri, &format!("case {i}")).expect("aimed inside the triangle");
        let took = exact_hits() - before;
        // `check` also runs the Dekker variant: both must answer without the exact values.
        let values = [h.t, h.u, h.v, h.point[0], h.point[1], h.point[2]];
        if values.iter().any(|x| x.to_bits() & ((1 << 52) - 1) == 0) {
            powers += 1;
            continue;
        }
        kept += 1;
        assert_eq!(took, 0, "case {i}: the exact values were computed");
    }
    assert!(
        kept >= 2900,
        "{kept} cases kept ({powers} with a power of two)"
    );
}

/// The filter's own claims, each judged by rationals: every double-double determinant
/// (`hi + lo`) is within its bound `K ε² P` of the exact one, and every quotient `q + c` within
/// its `err` of the exact ratio, for both ways of splitting products. The families: grid
/// points (exact zeros and cancellations), random scales from 2^-20 to 2^20, far origins,
/// and grazing rays (a denominator far below its permanent).
#[test]
fn the_filters_bounds_hold() {
    fn family<const FMA: bool>(rng: &mut Rng, i: u64) -> usize {
        let v = |grid: bool, rng: &mut Rng| {
            if grid {
                (rng.f() * 8.0).floor() / 4.0 - 1.0
            } else {
                (2.0 * rng.f() - 1.0) * 2f64.powi((rng.u64() % 40) as i32 - 20)
            }
        };
        let grid = i.is_multiple_of(4);
        let mut tri = [0, 1, 2].map(|_| [0, 1, 2].map(|_| v(grid, rng)));
        let mut o = [0, 1, 2].map(|_| v(grid, rng));
        let mut d = [0, 1, 2].map(|_| v(grid, rng));
        match i % 4 {
            // Far origins aimed at the triangle.
            2 => {
                tri = random_triangle(rng, [0.0; 3], 1.0);
                let target = aim(rng, &tri, i / 4);
                let r = 2f64.powi(rng.below(30) as i32);
                o = unit(rng).map(|x| x * r);
                d = [0, 1, 2].map(|k| target[k] - o[k]);
            }
            // Grazing: the direction in the plane of the triangle, tilted by 2^-k.
            3 => {
                tri = random_triangle(rng, [0.0; 3], 1.0);
                let [a, b, c] = tri;
                let tilt = 2f64.powi(-(rng.below(50) as i32));
                d = [0, 1, 2].map(|k| (b[k] - a[k]) + tilt * (c[k] - a[k]) * rng.f());
                o = [0, 1, 2].map(|k| a[k] - d[k] + 1e-3 * (c[k] - a[k]));
            }
            _ => {}
        }
        let Some(f) = Filtered::<FMA>::new(o, d, &tri) else {
            return 0;
        };
        let ds = d.map(|x| times_pow2(x, -f.scale));
        let [_, dq, _, w, e1, e2] = frame(o, ds, &tri);
        let want = [
            det(&w, &e1, &e2),
            det(&dq, &e2, &w),
            det(&dq, &w, &e1),
            det(&dq, &e1, &e2),
        ];
        let got = [
            (f.num, f.num_err),
            (f.num_u, f.num_u_err),
            (f.num_v, f.num_v_err),
            (f.den, f.den_err),
        ];
        let what = ["N", "N_u", "N_v", "D"];
        for ((x, err), (want, what)) in got.iter().zip(want.iter().zip(what)) {
            let off = (q(x.hi) + q(x.lo) - want).abs();
            assert!(
                off <= q(*err),
                "case {i} FMA {FMA}: {what} = {} + {} is {off} off, bound {err}",
                x.hi,
                x.lo
            );
        }
        let mut quotients = 0;
        for (n, n_err, want_n) in [
            (f.num, f.num_err, &want[0]),
            (f.num_u, f.num_u_err, &want[1]),
            (f.num_v, f.num_v_err, &want[2]),
        ] {
            if let Some((qv, cv, err)) = f.quotient(n, n_err) {
                let off = (q(qv) + q(cv) - want_n / &want[3]).abs();
                assert!(
                    off <= q(err),
                    "case {i} FMA {FMA}: quotient {qv} + {cv} is {off} off, bound {err}"
                );
                quotients += 1;
            }
        }
        quotients
    }
    let mut quotients = [0; 4];
    for i in 0..4000u64 {
        // The same case for both splittings.
        quotients[(i % 4) as usize] += family::<true>(&mut Rng::new(0xb0b0 + i), i);
        family::<false>(&mut Rng::new(0xb0b0 + i), i);
    }
    assert!(
        quotients.iter().all(|&n| n >= 1000),
        "quotients checked per family: {quotients:?}"
    );
}

/// `quotient`'s range, as its docs give it: a numerator or denominator that is nonzero but
/// below 2^-511 (where the remainder `n − q d` could underflow) is left to the exact path; one
/// of exactly 2^-511, and a zero numerator, are not, and their quotients are within their
/// bound of the exact ratio (rationals). Axis-aligned frames, so that each determinant is one
/// product, exactly: the direction (0, 0, 1), w = (0, 0, z), e1 = (s, 0, 0), e2 = (0, s, 0),
/// so N = z s², D = s², and N_u = 0.
#[test]
fn quotients_below_their_floor_are_left_to_the_exact_path() {
    /// The quotients of N and of the zero N_u, each checked against the exact ratio where
    /// it is taken, and the exact N and D.
    type Quotient = Option<(f64, f64, f64)>;
    fn case<const FMA: bool>(z: f64, s: f64) -> (Quotient, Quotient, Q, Q) {
        let tri = [[0.0, 0.0, z], [s, 0.0, z], [0.0, s, z]];
        let (o, d) = ([0.0; 3], [0.0, 0.0, 1.0]);
        let f = Filtered::<FMA>::new(o, d, &tri).expect("operands within [2^-300, 2^300]");
        let [_, dq, _, w, e1, e2] = frame(o, d, &tri);
        let (num, num_u, den) = (det(&w, &e1, &e2), det(&dq, &e2, &w), det(&dq, &e1, &e2));
        assert!(num_u.is_zero());
        let got = f.quotient(f.num, f.num_err);
        let got_u = f.quotient(f.num_u, f.num_u_err);
        for (g, want) in [(got, &num / &den), (got_u, num_u / &den)] {
            if let Some((qv, cv, err)) = g {
                let off = (q(qv) + q(cv) - want).abs();
                assert!(
                    off <= q(err),
                    "FMA {FMA}: {qv} + {cv} is {off} off, bound {err}"
                );
            }
        }
        (got, got_u, num, den)
    }
    let p = |k: i32| q(2f64.powi(k));
    for fma in [true, false] {
        let run = |z: f64, s: f64| {
            if fma {
                case::<true>(z, s)
            } else {
                case::<false>(z, s)
            }
        };
        let (got, got_u, num, den) = run(2f64.powi(-171), 2f64.powi(-170));
        assert!(num == p(-511) && den == p(-340));
        assert!(got.is_some(), "FMA {fma}: N at the floor, 2^-511, is taken");
        assert!(got_u.is_some(), "FMA {fma}: a zero N_u is taken");
        let (got, got_u, num, den) = run(2f64.powi(-172), 2f64.powi(-170));
        assert!(num == p(-512) && den == p(-340));
        assert!(got.is_none(), "FMA {fma}: N below the floor is left");
        assert!(got_u.is_some(), "FMA {fma}: a zero N_u is taken");
        let (got, _, num, den) = run(2f64.powi(200), 2f64.powi(-256));
        assert!(num == p(-312) && den == p(-512));
        assert!(got.is_none(), "FMA {fma}: D below the floor is left");
    }
}
