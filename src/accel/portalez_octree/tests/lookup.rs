//! The two lookup tables against the paper's published arrays and against exit distances;
//! the exact sign of the Plücker products the walk reads.

use super::*;

const PUBLISHED_OUT_FACES: [[u8; 8]; 8] = [
    [7, 2, 5, 2, 3, 3, 5, 7],
    [5, 7, 1, 1, 5, 2, 7, 2],
    [3, 3, 7, 5, 0, 7, 0, 5],
    [0, 5, 0, 7, 7, 5, 1, 1],
    [2, 4, 2, 7, 7, 4, 3, 3],
    [1, 1, 7, 4, 2, 7, 2, 4],
    [4, 7, 3, 3, 4, 0, 7, 0],
    [7, 0, 4, 0, 1, 1, 4, 7],
];

const PUBLISHED_FACE_TO_NEIGHBOR: [[u8; 8]; 6] = [
    [1, 3, 1, 3, 0, 2, 0, 2],
    [2, 2, 0, 0, 3, 3, 1, 1],
    [2, 0, 2, 0, 3, 1, 3, 1],
    [1, 1, 3, 3, 0, 0, 2, 2],
    [2, 0, 3, 1, 2, 0, 3, 1],
    [1, 3, 0, 2, 1, 3, 0, 2],
];

#[test]
fn tables_are_the_published_ones() {
    assert_eq!(out_faces_lookup(), PUBLISHED_OUT_FACES);
    assert_eq!(face_to_neighbor_index(), PUBLISHED_FACE_TO_NEIGHBOR);
}

/// The tables against geometry: random boxes and rays through them, the exit face from
/// float64 exit distances where they are well apart, the quadrant from the exit point.
#[test]
fn tables_agree_with_exit_distances() {
    let (out, quad) = (out_faces_lookup(), face_to_neighbor_index());
    let mut rng = Rng::xorshift(3);
    let mut checked = 0;
    for _ in 0..20_000 {
        let (lo, hi) = ([0.0; 3], [1.0; 3]);
        let p = rng.p3();
        let d = [0, 1, 2].map(|_| rng.f() - 0.5);
        let o = [0, 1, 2].map(|k| p[k] - d[k]);
        let t = [0, 1, 2].map(|k| ((if d[k] > 0.0 { hi[k] } else { lo[k] }) - p[k]) / d[k]);
        let c = [0, 1, 2].map(|k| if d[k] > 0.0 { hi[k] } else { lo[k] });
        let pi = |q: [f64; 3], k: usize| {
            let (k1, k2) = ((k + 1) % 3, (k + 2) % 3);
            (q[k1] - o[k1]) * d[k2] - (q[k2] - o[k2]) * d[k1]
        };
        let bits = (0..3)
            .map(|k| ((pi(c, k) < 0.0) as usize) << k)
            .sum::<usize>();
        let row = (0..3).map(|k| ((d[k] > 0.0) as usize) << k).sum::<usize>();
        let m = (0..3).min_by(|&a, &b| t[a].total_cmp(&t[b])).unwrap();
        let mut sorted = t;
        sorted.sort_by(f64::total_cmp);
        if sorted[1] - sorted[0] < 1e-9 {
            continue;
        }
        let f = out[row][bits] as usize;
        assert_eq!(f, face_of(m, d[m] > 0.0), "row {row} bits {bits}");
        // The exit point against the face's centre.
        let x = [0, 1, 2].map(|k| p[k] + t[m] * d[k]);
        let (u, w) = in_plane(m);
        let mut centre = c;
        centre[u] = 0.5;
        centre[w] = 0.5;
        if (x[u] - 0.5).abs() < 1e-9 || (x[w] - 0.5).abs() < 1e-9 {
            continue;
        }
        let qb = (0..3)
            .map(|k| ((pi(centre, k) < 0.0) as usize) << k)
            .sum::<usize>();
        let j = (x[u] < 0.5) as u8 + 2 * (x[w] < 0.5) as u8;
        assert_eq!(quad[f][qb], j, "face {f}");
        checked += 1;
    }
    assert!(checked > 15_000);
}

/// The exact 2×2 sign against rationals near zero, at many scales, and where both products
/// underflow an ulp apart, and where differences that round feed products that nearly cancel.
#[test]
fn sign2_is_exact() {
    let r = |v: f64| BigRational::from_float(v).unwrap();
    // sign2 against the exact (a − b) m − (c − e) n.
    let check = |a: f64, b: f64, m: f64, c: f64, e: f64, n: f64| {
        let want = ((r(a) - r(b)) * r(m) - (r(c) - r(e)) * r(n)).cmp(&BigRational::zero());
        let got = sign2(a, b, m, c, e, n).cmp(&0);
        assert_eq!(got, want, "{a:e} {b:e} {m:e} {c:e} {e:e} {n:e}");
    };
    let mut rng = Rng::xorshift(11);
    for k in 0..20_000 {
        let sc = [1.0, 1e-200, 1e200, 1e-310][k % 4];
        let x = |rng: &mut Rng| (rng.f() - 0.5) * sc;
        let (mut a, mut b, mut c, mut e) = (x(&mut rng), x(&mut rng), x(&mut rng), x(&mut rng));
        let mut m = rng.f() - 0.5;
        // n chosen so the products nearly cancel.
        let mut n = if k.is_multiple_of(3) {
            rng.f()
        } else {
            (a - b) * m / (c - e)
        };
        if k % 5 == 4 {
            // Grid numbers whose products cancel exactly (the exact-products stage).
            let q = |rng: &mut Rng| ((rng.f() - 0.5) * 64.0).round() / 8.0 * sc;
            (a, b, c, e) = (q(&mut rng), q(&mut rng), q(&mut rng), q(&mut rng));
            (m, n) = ((c - e) / sc, (a - b) / sc);
            if k % 10 == 9 {
                m += 0.125;
            }
        }
        if !n.is_finite() {
            continue;
        }
        check(a, b, m, c, e, n);
    }
    // Products that underflow near a midpoint of the subnormal grid, (k + 1/2) 2^-1074, one
    // on each side, from differences that round (a, b, c, e near 1e-300): the two round to
    // neighbouring subnormals, one ulp apart, while the exact (a − b) m − (c − e) n, within
    // a rounding of each difference, may have the other sign. The float filter's bound (2ε of
    // a permanent that has underflowed too) cannot see that; below DET2_TINY it must not be
    // used (a filter used there gave the wrong sign on 393 of 9,918 such cases).
    let mut one_ulp = 0;
    for _ in 0..20_000 {
        let x = |rng: &mut Rng, s: f64| (rng.f() * 2.0 - 1.0) * s;
        let (a, b) = (x(&mut rng, 1e-300), x(&mut rng, 3e-301));
        let (c, e) = (x(&mut rng, 1e-300), x(&mut rng, 3e-301));
        let (ab, ce) = (a - b, c - e);
        if ab == 0.0 || ce == 0.0 {
            continue;
        }
        // m ≈ (2k + 1) 2^-1075 / ab (no overflow: |ab| > 1e-302, 2k + 1 < 2^11), scaled in
        // two exact steps; then nudged by an ulp or two either way.
        let odd = (2 * rng.below(1000) + 1) as f64;
        let toward = |v: f64, rng: &mut Rng| {
            let mut v = v * 2f64.powi(-1000) * 2f64.powi(-75);
            for _ in 0..rng.below(3) {
                v = if rng.below(2) == 0 {
                    v.next_up()
                } else {
                    v.next_down()
                };
            }
            v
        };
        let (m, n) = (toward(odd / ab, &mut rng), toward(odd / ce, &mut rng));
        let (p, q) = (ab * m, ce * n);
        one_ulp += usize::from((p - q).abs() == f64::from_bits(1));
        check(a, b, m, c, e, n);
    }
    assert!(one_ulp > 2_000, "{one_ulp} products an ulp apart");
    // Products below 1/2 that nearly cancel, from differences that round (the loop above's
    // numbers at scale 1 are multiples of 2^-53 in (−1/2, 1/2): their differences are
    // exact). There the computed products can be an ulp apart the wrong way, and only a bound
    // on the sum of the products' magnitudes sees it (a bound on their product, smaller
    // below 1, let the filter answer 914 of 31,399 such cases wrongly).
    let mut inexact = 0;
    for _ in 0..20_000 {
        let x = |rng: &mut Rng| {
            let sign = if rng.below(2) == 0 { 1.0 } else { -1.0 };
            sign * rng.f() * 2f64.powi(-(rng.below(7) as i32))
        };
        let (a, b, c, e) = (x(&mut rng), x(&mut rng), x(&mut rng), x(&mut rng));
        let (ab, ce) = (a - b, c - e);
        if ce == 0.0 {
            continue;
        }
        let m = (rng.f() * 2.0 - 1.0) * 10f64.powf(-6.0 * rng.f());
        let mut n = ab * m / ce;
        for _ in 0..rng.below(4) {
            n = if rng.below(2) == 0 {
                n.next_up()
            } else {
                n.next_down()
            };
        }
        inexact += usize::from(r(ab) != r(a) - r(b) || r(ce) != r(c) - r(e));
        check(a, b, m, c, e, n);
    }
    assert!(inexact > 5_000, "{inexact} cases whose differences round");
}
