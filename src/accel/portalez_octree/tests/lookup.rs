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

/// The exact 2×2 sign against rationals near zero, at many scales.
#[test]
fn sign2_is_exact() {
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
        let r = |v: f64| BigRational::from_float(v).unwrap();
        let want = ((r(a) - r(b)) * r(m) - (r(c) - r(e)) * r(n)).cmp(&BigRational::zero());
        let got = sign2(a, b, m, c, e, n).cmp(&0);
        assert_eq!(got, want, "{a} {b} {m} {c} {e} {n}");
    }
}
