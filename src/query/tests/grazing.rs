//! Rays whose line touches the closed domain box without entering it: at a point of one of
//! its edges, at a corner, or along one of its sides' planes, where scene triangles reach the
//! box (margin 0, as these test grids; scenes built by `from_mesh` keep a margin). The contract
//! makes a triangle met there a hit, yet the line enters no boundary face's interior, so the
//! exact walk cannot start; `Locators::locate_exact` tells such a ray apart (`locate::GRAZES`)
//! and the walk answers it with the exact BVH. Found by the GPU exact kernel's test (its rays
//! aimed at mesh vertices).

use super::*;
use crate::accel::{Lanes, Packets};
use crate::scene::AccelKind;
use crate::testing::{grid_scene, GridScene};

/// Closest hit, occlusion and all hits of `o`, `d` (rays in rows) on `scene` with `opts`.
fn answers(
    scene: &Scene,
    o: &[f64],
    d: &[f64],
    opts: &CastOptions,
) -> (HitBuffers<f64>, Vec<u8>, Vec<crate::query::Listed>) {
    let n = o.len() / 3;
    let (tmin, tmax) = (vec![0.0; n], vec![f64::INFINITY; n]);
    let rays = Rays {
        origins: o,
        directions: d,
        tmin: &tmin,
        tmax: &tmax,
        leaving: None,
    };
    let mut hits = HitBuffers::<f64>::new(n, false);
    let (method, layout) = (Method::DEFAULT, LayoutKind::DEFAULT);
    scene
        .cast_with(method, layout, &rays, hits.out(), opts)
        .unwrap();
    let mut occluded = vec![0u8; n];
    scene
        .occluded(method, layout, &rays, &mut occluded, opts)
        .unwrap();
    let mut listed = vec![crate::query::Listed::default(); n];
    scene.intersections(&rays, &mut listed, opts).unwrap();
    (hits, occluded, listed)
}

#[test]
fn a_ray_grazing_the_box_at_a_triangle_vertex_hits_it() {
    // One cube, six Kuhn tets around its diagonal (0,0,0)-(1,1,1); its interior faces (each
    // holding the diagonal, so the corner (1,1,1)) are the scene's triangles.
    let GridScene { scene, tris, .. } = grid_scene(&mut Rng::xorshift(1), 1, 0.0, 1.0);
    // From outside, through the corner (1,1,1) at t = 1, outside the box before and after.
    let (o, d) = ([0.0, 2.0, 1.0], [1.0, -1.0, 0.0]);
    let want = crate::traverse::tests::verdicts(&o, &d, &tris);
    assert!(want[0].is_some(), "the referee: a hit at the corner");
    let rays = Rays {
        origins: &o,
        directions: &d,
        tmin: &[0.0],
        tmax: &[f64::INFINITY],
        leaving: None,
    };
    let mut out = HitBuffers::<f64>::new(1, false);
    scene
        .cast(&rays, out.out(), &CastOptions::default())
        .unwrap();
    assert_eq!((out.status[0], out.t[0]), (HIT, 1.0), "{want:?}");
}

/// Grazing rays of three kinds on a 4³ grid whose interior faces are all triangles (many reach
/// the box along its sides): lines in a side's plane, lines touching an edge of the box at
/// one point (a grid point or not), lines touching a corner. Each kind also from one origin,
/// so that the walk's packets start them. The tet walk (lanes on and off, packets on and off)
/// answers closest hit, occlusion and all hits as the exact BVH does, and the closest hit is
/// the referee's (t exact here: every crossing is at a multiple of 1/4 along a direction of
/// small integers).
#[test]
fn grazing_rays_answer_as_the_exact_bvh_and_the_referee() {
    let GridScene { scene, tris, .. } = grid_scene(&mut Rng::xorshift(7), 4, 0.0, 1.0);
    let mut rays: Vec<([f64; 3], [f64; 3])> = Vec::new();
    let q = |k: i32| k as f64 / 4.0;
    for k in 0..=4 {
        for j in 0..=4 {
            // In the side z = 0 (and z = 1), from beyond x = 0: along +x and slanted.
            for z in [0.0, 1.0] {
                rays.push(([-1.0, q(k), z], [1.0, 0.0, 0.0]));
                rays.push(([-1.0, q(k), z], [4.0, q(j) - q(k), 0.0]));
            }
            // Touching the edge y = 0, z = 0 at x = k/4 (a grid point) or between two, once:
            // along (a, 1, -1) the line is outside the box on both sides of the point.
            for x in [q(k), q(k) + 0.125] {
                let (a, p) = ([-2.0, 0.0, 1.0][(j % 3) as usize], [x, 0.0, 0.0]);
                let d = [a, 1.0, -1.0];
                rays.push(([p[0] - 2.0 * d[0], p[1] - 2.0, p[2] + 2.0], d));
            }
        }
    }
    // Corners, touched once (each direction leaves the box's octant there on both sides).
    for (c, d) in [
        ([1.0, 1.0, 1.0], [1.0, -1.0, -1.0]),
        ([0.0, 0.0, 0.0], [-1.0, 1.0, 1.0]),
        ([1.0, 0.0, 1.0], [1.0, 1.0, -2.0]),
        ([0.0, 1.0, 0.0], [1.0, 1.0, -1.0]),
    ] {
        rays.push(([c[0] - 3.0 * d[0], c[1] - 3.0 * d[1], c[2] - 3.0 * d[2]], d));
    }
    // One origin below the edge y = 0, z = 0: every grid point of the edge, touched once.
    let eye = [0.5, -1.0, 1.0];
    for k in 0..=4 {
        rays.push((eye, [q(k) - 0.5, 1.0, -1.0]));
    }
    let o: Vec<f64> = rays.iter().flat_map(|r| r.0).collect();
    let d: Vec<f64> = rays.iter().flat_map(|r| r.1).collect();

    let bvh = CastOptions {
        accel: AccelKind::ExactBvh,
        ..CastOptions::default()
    };
    let (want, want_occluded, want_listed) = answers(&scene, &o, &d, &bvh);
    let mut hits = 0;
    for (i, (ro, rd)) in rays.iter().enumerate() {
        let verdict = &crate::traverse::tests::verdicts(ro, rd, &tris)[0];
        match verdict {
            Some(v) => {
                hits += 1;
                assert_eq!(
                    (want.status[i], want.t[i], want.triangle[i]),
                    (HIT, v.t, v.ties[0] as i32),
                    "ray {i}: o {ro:?} d {rd:?}"
                );
            }
            None => assert_eq!(want.status[i], MISS, "ray {i}: o {ro:?} d {rd:?}"),
        }
    }
    assert!(hits > rays.len() / 2, "{hits} of {} rays hit", rays.len());

    for (lanes, packets) in [
        (Lanes::Auto, Packets::Auto),
        (Lanes::On, Packets::Off),
        (Lanes::Off, Packets::Off),
    ] {
        let walk = CastOptions {
            accel: AccelKind::TetWalk,
            lanes,
            packets,
            ..CastOptions::default()
        };
        let (got, occluded, listed) = answers(&scene, &o, &d, &walk);
        for i in 0..rays.len() {
            let case = format!("ray {i} ({lanes:?}, {packets:?}): {:?}", rays[i]);
            assert_eq!(
                (got.status[i], got.t[i].to_bits(), got.triangle[i]),
                (want.status[i], want.t[i].to_bits(), want.triangle[i]),
                "{case}"
            );
            assert_eq!(
                (got.u[i].to_bits(), got.v[i].to_bits()),
                (want.u[i].to_bits(), want.v[i].to_bits()),
                "{case}"
            );
            assert_eq!(occluded[i], want_occluded[i], "{case}: occluded");
            assert_eq!(listed[i].status, want_listed[i].status, "{case}: all hits");
            let points = |l: &crate::query::Listed| -> Vec<(u32, u64)> {
                l.meets
                    .iter()
                    .map(|m| (m.triangle, m.t.to_bits()))
                    .collect()
            };
            assert_eq!(
                points(&listed[i]),
                points(&want_listed[i]),
                "{case}: all hits"
            );
        }
    }
}
