//! Fuzz cases replayed on the fuzzer's scenes (they need the `fuzz` feature, which `make test`
//! turns on).

use super::*;
use crate::status::INVALID;
use crate::testing::{on, ACCEL_KINDS};

/// docs/fuzzing.md's finding (walk seed 7686576272770016265): a ray aimed, up to rounding, at
/// a mesh vertex meets an edge of triangles 3, 4, 5 at t = 1 exactly, then the interiors of
/// triangles 6 and 2 less than an ulp later, whose float t (1 − 2^-51 and 1 − 2^-49, each
/// certified to about 5e-14) fall below the edge's (1 + 2^-52). Judged by the referee: all
/// hits list its points in order of exact t, every accelerator's alike, each named by a
/// triangle met there with t within the referee's bound; the first is the closest hit.
#[test]
fn all_hits_in_exact_order_just_past_a_vertex() {
    let (scene, _) = crate::fuzz::walk_scene(7686576272770016265 % 48);
    let o = [-0.43561294676897977, 1e-300, -0.24631735765479013];
    let d = [0.7689462602340982, 0.3333333134651184, 0.5796506711199085];
    let tris = &scene.surface.triangles;
    // The referee's points: crossings grouped by exact t, in order.
    let mut crossings: Vec<(referee::Crossing, usize)> = tris
        .iter()
        .enumerate()
        .filter_map(|(k, t)| referee::crossing(o, d, t).map(|c| (c, k)))
        .filter(|(c, _)| c.cmp_t(0.0) != Ordering::Less)
        .collect();
    crossings.sort_by(|a, b| a.0.cmp_t_of(&b.0).then(a.1.cmp(&b.1)));
    let mut groups: Vec<Vec<(referee::Crossing, usize)>> = Vec::new();
    for c in crossings {
        match groups.last_mut() {
            Some(g) if g[0].0.cmp_t_of(&c.0) == Ordering::Equal => g.push(c),
            _ => groups.push(vec![c]),
        }
    }
    let ids: Vec<Vec<usize>> = groups
        .iter()
        .map(|g| g.iter().map(|c| c.1).collect())
        .collect();
    // The finding's shape: the edge at t = 1, then 6 and 2 whose exact t round to 1.
    assert_eq!(ids[..3], [vec![3, 4, 5], vec![6], vec![2]]);
    assert_eq!(groups[0][0].0.cmp_t(1.0), Ordering::Equal);
    assert!(groups[1..3].iter().all(|g| g[0].0.t() == 1.0));

    let rays = Rays {
        origins: &o[..],
        directions: &d[..],
        tmin: &[0.0],
        tmax: &[f64::INFINITY],
        leaving: None,
    };
    let verdict = referee::first_hit(o, d, 0.0, f64::INFINITY, tris);
    for &accel in ACCEL_KINDS {
        let opts = on(accel);
        let mut closest = HitBuffers::<f64>::new(1, false);
        scene.cast(&rays, closest.out(), &opts).unwrap();
        let (t, triangle) = (closest.t[0], closest.triangle[0]);
        let got = (closest.status[0] == HIT).then_some((triangle as usize, t));
        assert_eq!(
            referee::judge(verdict.as_ref(), false, got, referee::Precision::F64),
            referee::Outcome::Right,
            "{accel:?}: closest hit {got:?}"
        );
        let mut listed = vec![crate::query::Listed::default(); 1];
        scene.intersections(&rays, &mut listed, &opts).unwrap();
        let meets = &listed[0].meets;
        let shown: Vec<_> = meets.iter().map(|m| (m.t, m.triangle)).collect();
        assert_eq!(
            meets.len(),
            groups.len(),
            "{accel:?}: {shown:?}, referee {ids:?}"
        );
        for (m, g) in meets.iter().zip(&groups) {
            let k = m.triangle as usize;
            let c = &g
                .iter()
                .find(|c| c.1 == k)
                .unwrap_or_else(|| {
                    panic!("{accel:?}: {shown:?} out of the referee's order {ids:?}")
                })
                .0;
            assert!(
                c.within_ulp(m.t, referee::Precision::F64),
                "{accel:?}: triangle {k} at t {} exact {}",
                m.t,
                c.t()
            );
        }
        // The first point is the closest hit, evaluated by the same function.
        assert_eq!(
            (meets[0].triangle as i32, meets[0].t.to_bits()),
            (triangle, t.to_bits())
        );
    }
}

/// A direction whose components span more than float64's exponent range (fuzz seed
/// 7686576272770016265, ray 444: f64::MAX beside 0.1) cannot be scaled by a power of two
/// exactly, and the walk answered for a nearby line (a hit where the referee sees none): every
/// query and accelerator now marks it INVALID, as a NaN direction.
#[test]
fn direction_beyond_the_exponent_range_is_invalid() {
    let (scene, _) = crate::fuzz::walk_scene(7686576272770016265 % 48);
    let o = [0.7675335441786291, 0.531478913863028, -f64::MAX];
    let d = [-0.10086685764374748, -0.19814560039790963, f64::MAX];
    assert!(!crate::geom::real::unit_scale_is_exact(d));
    assert!(crate::geom::real::unit_scale_is_exact([0.1, 1e300, 3.0]));
    let rays = Rays {
        origins: &o[..],
        directions: &d[..],
        tmin: &[0.0],
        tmax: &[f64::INFINITY],
        leaving: None,
    };
    for &accel in ACCEL_KINDS {
        let opts = on(accel);
        let mut closest = HitBuffers::<f64>::new(1, false);
        scene.cast(&rays, closest.out(), &opts).unwrap();
        assert_eq!(closest.status[0], INVALID, "{}", accel.name());
        let mut any = vec![0u8; 1];
        scene
            .occluded(Method::Exact, LayoutKind::DEFAULT, &rays, &mut any, &opts)
            .unwrap();
        assert_eq!(any[0], INVALID, "{}", accel.name());
        let mut all = vec![Listed::default(); 1];
        scene.intersections(&rays, &mut all, &opts).unwrap();
        assert_eq!(all[0].status, INVALID, "{}", accel.name());
    }
}
