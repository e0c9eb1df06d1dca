//! What a closest-hit answer holds besides its hit, on every accelerator (mutation testing,
//! docs/testing.md: with a miss's triangle or tet written as 1 instead of -1, every other test
//! still passed). A ray that misses, or that never walked, names no triangle (-1) and has
//! t = ∞ and NaN u, v and point; a ray that never walked (not traceable, or missing the
//! domain box) also names no tet and took no step; a caster that walks no tets names no tet.
//! A BVH's or octree's hit visited a node (a tet walk's hit may take no step: an origin on a
//! triangle meets it before the walk moves).

use super::*;
use crate::accel::AccelKind;
use crate::status::INVALID;
use crate::testing::{on, Agreement, ACCEL_KINDS};

#[test]
fn misses_and_rays_that_never_walked_name_nothing() {
    let a = Agreement::new(7);
    let (mut o, mut d) = (a.o.clone(), a.d.clone());
    let extra: [([f64; 3], [f64; 3], u8); 4] = [
        ([f64::NAN, 0.5, 0.5], [1.0, 0.0, 0.0], INVALID), // not traceable
        ([0.5, 0.5, 0.5], [0.0, 0.0, 0.0], INVALID),      // no direction
        ([5.0, 5.0, 5.0], [1.0, 1.0, 1.0], MISS),         // outside, going away
        ([-3.0, 0.5, 0.5], [0.0, 1.0, 0.0], MISS),        // outside, passing by
    ];
    for (eo, ed, _) in extra {
        o.extend(eo);
        d.extend(ed);
    }
    let n = o.len() / 3;
    let first_extra = n - extra.len();
    let (tmin, tmax) = (vec![0.0; n], vec![f64::INFINITY; n]);
    let rays = Rays {
        origins: &o,
        directions: &d,
        tmin: &tmin,
        tmax: &tmax,
        leaving: None,
    };
    for &accel in ACCEL_KINDS {
        let mut out = HitBuffers::<f64>::new(n, false);
        a.g.scene.cast(&rays, out.out(), &on(accel)).unwrap();
        let walks_tets = accel == AccelKind::TetWalk;
        let mut hits = 0;
        for i in 0..n {
            let what = format!("{accel:?} ray {i} (status {})", out.status[i]);
            if out.status[i] == HIT {
                hits += 1;
                assert!(out.triangle[i] >= 0, "{what}: a hit names a triangle");
                assert_eq!(out.tet[i] >= 0, walks_tets, "{what}: tet {}", out.tet[i]);
                // A hierarchy finds a triangle in a node it visited: at least one step.
                assert!(walks_tets || out.steps[i] >= 1, "{what}: no node visited");
                continue;
            }
            assert_eq!(out.triangle[i], -1, "{what}");
            assert_eq!(out.t[i], f64::INFINITY, "{what}");
            assert!(out.u[i].is_nan() && out.v[i].is_nan(), "{what}");
            assert!(
                out.point[3 * i..3 * i + 3].iter().all(|x| x.is_nan()),
                "{what}"
            );
            if !walks_tets {
                assert_eq!(out.tet[i], -1, "{what}");
            }
        }
        assert!(hits > n / 4, "{accel:?}: only {hits} of {n} rays hit");
        for (k, (_, _, status)) in extra.iter().enumerate() {
            let i = first_extra + k;
            assert_eq!(out.status[i], *status, "{accel:?} extra ray {k}");
            assert_eq!(out.tet[i], -1, "{accel:?} extra ray {k} walked no tet");
            assert_eq!(out.steps[i], 0, "{accel:?} extra ray {k} took no step");
        }
    }
}

/// A hit's tet is where the walk ended: beside the hit. Where the hit is at a corner of the
/// hit triangle (the stress rays aim at the grid's vertices), that tet has the corner as one
/// of its own: only the tets around a vertex come within an ulp of it. Mutation testing
/// (docs/testing.md, `closest.rs:123`, `found || past` as `found && past`): the walk went on
/// past a vertex it had met and ended in a later tet, with the same hit.
#[test]
fn a_hit_at_a_vertex_ends_its_walk_at_that_vertex() {
    let a = Agreement::new(7);
    let n = a.o.len() / 3;
    let rays = Rays {
        origins: &a.o,
        directions: &a.d,
        tmin: &[0.0],
        tmax: &[f64::INFINITY],
        leaving: None,
    };
    let mut out = HitBuffers::<f64>::new(n, false);
    let scene = &a.g.scene;
    scene
        .cast(&rays, out.out(), &on(AccelKind::TetWalk))
        .unwrap();
    let mesh = &scene.mesh;
    let mut at_corner = 0;
    for i in 0..n {
        if out.status[i] != HIT {
            continue;
        }
        let p: [f64; 3] = out.point[3 * i..3 * i + 3].try_into().unwrap();
        if !a.g.tris[out.triangle[i] as usize].contains(&p) {
            continue;
        }
        at_corner += 1;
        let tet = mesh.tets[out.tet[i] as usize];
        assert!(
            tet.iter().any(|&v| mesh.points[v as usize] == p),
            "ray {i}: a hit at {p:?}, a corner of triangle {}, ends in tet {} ({:?})",
            out.triangle[i],
            out.tet[i],
            tet.map(|v| mesh.points[v as usize])
        );
    }
    assert!(at_corner >= 100, "only {at_corner} hits at a corner");
}
