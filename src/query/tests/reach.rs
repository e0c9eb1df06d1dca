//! The reach a closest-hit gatherer keeps after an offer (`Span::above` of the offer's float
//! crossing): an upper bound on that triangle's exact t, judged by the referee, for directions
//! of every scale. A tiny direction makes t and its certified error large (err well above 1);
//! there a reach of t + 2 / err (a survivor of mutation shard 14) falls short of the exact t
//! wherever the float t lies below it by more than 2 / err, and the walk could skip what comes
//! before the true best.

use crate::geom::exact::plane_t;
use crate::geom::ray::Ray;
use crate::query::gather::Line;
use crate::referee;
use crate::rng::Rng;
use std::cmp::Ordering;

#[test]
fn the_reach_after_an_offer_bounds_its_exact_t_from_above() {
    let mut rng = Rng::xorshift(37);
    let (mut checked, mut large_err) = (0, 0);
    for i in 0..5000 {
        let tri = [rng.p3(), rng.p3(), rng.p3()];
        // Aimed at a point of the triangle from anywhere around it, the direction scaled by
        // 2^k: t is about 2^-k.
        let (u, v) = (rng.f(), rng.f());
        let (u, v) = if u + v > 1.0 {
            (1.0 - u, 1.0 - v)
        } else {
            (u, v)
        };
        let p: [f64; 3] = std::array::from_fn(|k| {
            tri[0][k] + u * (tri[1][k] - tri[0][k]) + v * (tri[2][k] - tri[0][k])
        });
        let o = rng.p3().map(|x| 4.0 * x - 1.5);
        let scale = 2f64.powi([0, -20, -40, -60, -80, 30][i % 6]);
        let d: [f64; 3] = std::array::from_fn(|k| (p[k] - o[k]) * scale);
        let Some(exact) = referee::crossing(o, d, &tri) else {
            continue;
        };
        let tmax = [f64::INFINITY, exact.t() * 4.0, exact.t() / 4.0][i % 3];
        let ray = Ray {
            o,
            d,
            tmin: 0.0,
            tmax,
            leaving: None,
        };
        let line = Line::new(&ray).expect("a valid ray");
        let at = plane_t(o, d, &tri);
        let reach = line.above(at);
        assert!(reach <= tmax, "ray {i}: reach {reach} past tmax {tmax}");
        if exact.cmp_t(tmax) != Ordering::Greater {
            assert_ne!(
                exact.cmp_t(reach),
                Ordering::Greater,
                "ray {i}: the exact t {} lies beyond the reach {reach} (float t {}, err {})",
                exact.t(),
                at.0,
                at.1
            );
            checked += 1;
            large_err += usize::from(at.1 > 2.0);
        } else {
            // Beyond tmax the reach is tmax itself (nothing past it is wanted).
            assert_eq!(reach, tmax, "ray {i}");
        }
    }
    // Most rays cross, and the large-t cases (err > 2, where 2 / err < 2 err) are many.
    assert!(
        checked > 2500 && large_err > 1000,
        "{checked} checked, {large_err} with err > 2"
    );
}
