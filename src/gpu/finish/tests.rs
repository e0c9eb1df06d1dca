//! The device's hit finishing (its CPU twin): every value it certifies is the one the host
//! writes (`geom::rounded`, rounded to float32) and the float32 rounding of the exact value
//! (the referee: dyadic arithmetic), on generic hits, far origins, grazing rays, slivers, and
//! values placed on and beside float32 rounding boundaries.

use super::*;
use crate::geom::dyadic::{rdet, Dyadic};
use crate::geom::rounded::rounded_hit;
use crate::rng::Rng;

/// The direction as the kernel scales it: largest component in [1, 2), and the power of two.
fn kernel_scale(d: [f32; 3]) -> ([f32; 3], i32) {
    let top = d.iter().map(|x| x.to_bits() & 0x7fff_ffff).max().unwrap();
    let k = 127 - (top >> 23) as i32;
    (d.map(|x| x * pow2(k)), k)
}

/// The exact values (the referee): t, u, v and the point rounded to nearest float64 and then
/// to float32 (one rounding where no float32 boundary is within a float64 ulp, which is all a
/// certified value claims).
fn exact(o: [f32; 3], d: [f32; 3], tri: &[[f64; 3]; 3]) -> Option<[f32; 6]> {
    let x = |v: [f32; 3]| v.map(|c| Dyadic::from_f64(c as f64));
    let sub = |p: &[Dyadic; 3], q: &[Dyadic; 3]| [0, 1, 2].map(|k| &p[k] - &q[k]);
    let (o, d) = (x(o), x(d));
    let [a, b, c] = tri.map(|v| v.map(Dyadic::from_f64));
    let (w, e1, e2) = (sub(&a, &o), sub(&b, &a), sub(&c, &a));
    let den = rdet(&d, &e1, &e2);
    if den.is_zero() {
        return None;
    }
    let (nu, nv) = (rdet(&d, &e2, &w), rdet(&d, &w, &e1));
    let q = |n: &Dyadic| Dyadic::quotient(n, &den) as f32;
    let p = |k: usize| q(&(&(&a[k] * &den) + &(&(&nu * &e1[k]) + &(&nv * &e2[k]))));
    Some([q(&rdet(&w, &e1, &e2)), q(&nu), q(&nv), p(0), p(1), p(2)])
}

/// What the host writes for the hit: its float64 values rounded to float32.
fn host(o: [f32; 3], d: [f32; 3], tri: &[[f64; 3]; 3]) -> Option<[f32; 6]> {
    let f = |v: [f32; 3]| v.map(f64::from);
    let h = rounded_hit(f(o), f(d), tri)?;
    let p = h.point.map(|x| x as f32);
    Some([h.t as f32, h.u as f32, h.v as f32, p[0], p[1], p[2]])
}

/// Runs the twin on one hit; every value it gives must be the host's and the referee's, bit
/// for bit. Returns whether it finished the hit.
fn check(o: [f32; 3], d: [f32; 3], tri: &[[f32; 3]; 3]) -> bool {
    check64(o, d, &tri.map(|v| v.map(f64::from)))
}

/// [`check`] on a triangle with float64 corners (the caller's, as a mesh loaded from OBJ
/// text has them).
fn check64(o: [f32; 3], d: [f32; 3], tri: &[[f64; 3]; 3]) -> bool {
    let (ds, k) = kernel_scale(d);
    let Some(words) = tri_words(tri) else {
        return false;
    };
    let Some(f) = finish_hit(o, ds, k, &words) else {
        return false;
    };
    let got = [f.t, f.u, f.v, f.point[0], f.point[1], f.point[2]].map(f32::to_bits);
    let want = exact(o, d, tri).expect("a finished hit has a plane crossing");
    let from_host = host(o, d, tri).expect("the host finds it too");
    assert_eq!(
        got,
        want.map(f32::to_bits),
        "finished hit (t u v point) is not the exact one: o {o:?} d {d:?} tri {tri:?}: {f:?} \
         against {want:?}"
    );
    assert_eq!(
        got,
        from_host.map(f32::to_bits),
        "finished hit is not the host's: o {o:?} d {d:?} tri {tri:?}"
    );
    true
}

fn f3(v: [f64; 3]) -> [f32; 3] {
    v.map(|x| x as f32)
}

/// A ray from `o` to a point inside `tri` (barycentric weights in (0, 1)).
fn toward(rng: &mut Rng, o: [f32; 3], tri: &[[f32; 3]; 3]) -> [f32; 3] {
    let (mut s, mut t) = (rng.f(), rng.f());
    if s + t > 1.0 {
        (s, t) = (1.0 - s, 1.0 - t);
    }
    let p = [0, 1, 2].map(|k| {
        let [a, b, c] = tri.map(|v| v[k] as f64);
        a + s * (b - a) + t * (c - a)
    });
    f3([0, 1, 2].map(|k| p[k] - o[k] as f64))
}

fn random_tri(rng: &mut Rng, centre: [f64; 3], size: f64) -> [[f32; 3]; 3] {
    [0, 1, 2].map(|_| f3([0, 1, 2].map(|k| centre[k] + size * (rng.f() - 0.5))))
}

/// Generic hits at many scales and distances: nearly all are finished (so the checks above
/// are not vacuous), and every finished value is right.
#[test]
fn finished_hits_are_the_hosts_and_the_exact_values() {
    let mut rng = Rng::new(34);
    let (mut n, mut done) = (0, 0);
    for scale in [1e-6, 1e-2, 1.0, 3.0, 1e3, 1e7] {
        for far in [0.5, 4.0, 1e3] {
            for _ in 0..600 {
                let centre = [0, 1, 2].map(|_| scale * (rng.f() - 0.5) * 10.0);
                let tri = random_tri(&mut rng, centre, scale);
                let o = f3([0, 1, 2].map(|k| centre[k] + scale * far * (rng.f() - 0.5) * 4.0));
                let d = toward(&mut rng, o, &tri);
                // The caller's direction at any scale: t scales back exactly.
                let d = d.map(|x| x * [1e-30f32, 1.0, 1e30][n % 3]);
                n += 1;
                done += check(o, d, &tri) as usize;
            }
        }
    }
    eprintln!("finished {done} of {n} generic hits");
    // A sanity floor, not a tolerance: the bound is about 2^-36 relative, so a value is left
    // to the host only within that of a rounding boundary (a chance near 2^-12 a value).
    assert!(
        done * 10 > n * 9,
        "only {done} of {n} generic hits finished"
    );
}

/// Triangles with float64 corners (not float32 numbers), near the coordinate origin and
/// 1,000 away from it: the corner in three words and the edges within 1.01 ε² still give the
/// host's values, and nearly all are finished.
#[test]
fn float64_triangles_are_finished_right() {
    let mut rng = Rng::new(64);
    let (mut n, mut done) = (0, 0);
    for offset in [0.0, 1000.0, -3.3e5] {
        for _ in 0..1500 {
            let centre = [0, 1, 2].map(|_| offset + (rng.f() - 0.5) * 10.0);
            let tri = [0, 1, 2].map(|_| [0, 1, 2].map(|k| centre[k] + rng.f() - 0.5));
            let o = f3([0, 1, 2].map(|k| centre[k] + (rng.f() - 0.5) * 16.0));
            let t32 = tri.map(f3);
            let d = toward(&mut rng, o, &t32);
            n += 1;
            done += check64(o, d, &tri) as usize;
        }
    }
    eprintln!("finished {done} of {n} float64 hits");
    assert!(
        done * 10 > n * 9,
        "only {done} of {n} float64 hits finished"
    );
}

/// Axis-aligned triangles (floors and walls, coordinates on zero): the flat coordinate of the
/// point is the corner's, exactly, and signed zeros come out as the host writes them.
#[test]
fn flat_triangles_keep_their_plane_coordinate() {
    let mut rng = Rng::new(7);
    let mut done = 0;
    for axis in 0..3 {
        for plane in [0.0f32, -0.0, 1.0, -2.5, 1e-3] {
            for _ in 0..100 {
                let mut tri = random_tri(&mut rng, [0.0; 3], 2.0);
                for v in &mut tri {
                    v[axis] = plane;
                }
                let mut o = f3(rng.p3());
                o[axis] = plane + 1.5;
                // Not aimed exactly (t = 1 would put the point on o + d, a sum of two floats:
                // half of those lie on a float32 midpoint, where the host decides).
                let d = toward(&mut rng, o, &tri).map(|x| x * 0.7);
                done += check(o, d, &tri) as usize;
            }
        }
    }
    // −0 planes are left to the host (its sign of zero follows its own products): 300.
    assert!(done > 1100, "only {done} of 1500 flat hits finished");
}

/// Hits where t, u, v or a coordinate lies exactly on a float32 rounding boundary or within
/// a few float64 ulps of one: never finished wrong (the host rounds its float64 value, which
/// may fall on either side).
#[test]
fn values_at_rounding_boundaries_are_never_finished_wrong() {
    let tri = [[1.0f32, -1.0, -1.0], [1.0, 3.0, -1.0], [1.0, -1.0, 3.0]];
    let half = 2f32.powi(-24);
    let mut finished = 0;
    for offset in [
        0.0f32,
        2f32.powi(-40),
        2f32.powi(-45),
        2f32.powi(-49),
        2f32.powi(-52),
    ] {
        for sign in [1.0f32, -1.0] {
            // t = 1 + 2^-24 (+ offset): o.x = −(2^-24 + offset), the plane x = 1, d.x = 1.
            let o = [-(half + sign * offset), 0.25, 0.5];
            finished += check(o, [1.0, 0.0, 0.0], &tri) as usize;
            finished += check(o, [1.0, 0.125, -0.0625], &tri) as usize;
            // A midpoint in y: the point's y = 0.5 + 2^-25 (+ offset).
            let o = [0.0, 0.5 + 2f32.powi(-25), 0.25];
            finished += check(o, [1.0, sign * offset, 0.0], &tri) as usize;
        }
    }
    // Far from every boundary, the same hits are finished.
    assert!(check([0.0, 0.25, 0.625], [1.0, 0.0, 0.0], &tri));
    eprintln!("finished {finished} hits beside rounding boundaries");
}

/// Grazing rays, far origins and slivers: the bound grows with the cancellation, and a value
/// it cannot certify is left to the host; what is finished is right.
#[test]
fn hard_hits_are_right_when_finished() {
    let mut rng = Rng::new(99);
    let mut done = 0;
    for _ in 0..3000 {
        let tri = if rng.chance(0.5) {
            // A sliver: one corner nearly on the opposite edge.
            let a = f3(rng.p3());
            let b = f3(rng.p3());
            let s = rng.f();
            let eps = 10f64.powi(-(rng.below(12) as i32));
            let c = f3([0, 1, 2]
                .map(|k| a[k] as f64 + s * (b[k] as f64 - a[k] as f64) + eps * (rng.f() - 0.5)));
            [a, b, c]
        } else {
            random_tri(&mut rng, [0.0; 3], 1.0)
        };
        let far = 10f64.powi(rng.below(8) as i32);
        let mut o = f3(rng.p3().map(|x| (x - 0.5) * far));
        if rng.chance(0.3) {
            // Nearly in the triangle's plane: the origin pushed along the normal by a little.
            let p = toward(&mut rng, [0.0; 3], &tri);
            let n = normal(&tri);
            let h = 10f64.powi(-(rng.below(10) as i32));
            o = f3([0, 1, 2].map(|k| p[k] as f64 - far * 0.01 * (rng.f() - 0.5) + h * n[k]));
        }
        let d = toward(&mut rng, o, &tri);
        if d.iter().all(|&x| x == 0.0) {
            continue;
        }
        done += check(o, d, &tri) as usize;
    }
    eprintln!("finished {done} of 3000 hard hits");
}

fn normal(t: &[[f32; 3]; 3]) -> [f64; 3] {
    let e = |i: usize, k: usize| t[i][k] as f64 - t[0][k] as f64;
    [
        e(1, 1) * e(2, 2) - e(1, 2) * e(2, 1),
        e(1, 2) * e(2, 0) - e(1, 0) * e(2, 2),
        e(1, 0) * e(2, 1) - e(1, 1) * e(2, 0),
    ]
}

/// The product's bound (10 ε² |ab|, module docs) on products at the edges of its range:
/// mantissas of all ones, powers of two, mixed signs; against the exact product.
#[test]
fn two_prod_is_within_its_bound() {
    let mut rng = Rng::new(1);
    let mut worst = 0.0f64;
    for i in 0..200_000 {
        let pick = |rng: &mut Rng, i: usize| -> f32 {
            match i % 4 {
                0 => f32::from_bits(0x3fff_ffff ^ (rng.u64() as u32 & 0x8000_0000)),
                1 => (rng.f() * 2.0 - 1.0) as f32 * 1e3,
                2 => f32::from_bits(0x3f80_0000 | (rng.u64() as u32 & 0x007f_ffff)),
                _ => (rng.f() as f32 - 0.5) * 2f32.powi(rng.below(60) as i32 - 30),
            }
        };
        let (a, b) = (pick(&mut rng, i), pick(&mut rng, i / 4));
        let (hi, lo) = two_prod(a, b);
        let exact = a as f64 * b as f64; // exact: 48 bits
        let err = ((hi as f64 + lo as f64) - exact).abs();
        if exact != 0.0 {
            worst = worst.max(err / exact.abs());
        }
        assert!(
            err <= 10.0 * (EPS as f64).powi(2) * exact.abs(),
            "two_prod({a:e}, {b:e}): error {err:e} beyond 10 ε² |ab|"
        );
    }
    eprintln!(
        "two_prod: worst relative error {worst:e} (10 ε² = {:e})",
        10.0 * (EPS as f64).powi(2)
    );
}

/// The constants are the powers of two the bounds and the kernel's hex literals say.
#[test]
fn constants_are_their_powers_of_two() {
    for (x, k) in [
        (EPS, -24),
        (K_EPS2, -40),
        (ABS, -110),
        (OPERAND_MIN, -100),
        (OPERAND_MAX, 100),
        (HOST_SLACK, -50),
        (SAFE, -20),
    ] {
        assert_eq!(x as f64, 2f64.powi(k), "2^{k}");
    }
}
