//! Every method's exit faces on single tets and its agreement with brute force on Kuhn grids,
//! in both precisions; degenerate inputs.

use super::*;

#[test]
fn kuhn_grid_is_valid() {
    let mut rng = Rng::xorshift(7);
    let (pts, tets) = kuhn_grid(4, 0.3, &mut rng);
    let m = crate::mesh::TetMesh::build(pts, &tets, &[], &[]).unwrap();
    let vol: f64 = m
        .tets
        .iter()
        .map(|t| {
            let [a, b, c, d] = t.map(|v| glam::DVec3::from(m.points[v as usize]));
            (b - a).cross(c - a).dot(d - a) / 6.0
        })
        .sum();
    assert!((vol - 1.0).abs() < 1e-12, "volume {vol}");
    assert!(m.domain_is_box);
    assert_eq!(m.boundary_faces, 6 * 4 * 4 * 2);
}

#[test]
fn onb_is_right_handed() {
    let mut rng = Rng::xorshift(3);
    for _ in 0..1000 {
        let mut n = [rng.f() - 0.5, rng.f() - 0.5, rng.f() - 0.5];
        if rng.f() < 0.1 {
            n = [0.0, 0.0, if rng.f() < 0.5 { -1.0 } else { 1.0 }];
        }
        let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        let n = n.map(|x| x / l);
        let (u, w) = crate::geom::onb::onb(n);
        let (u, w, n) = (
            glam::DVec3::from(u),
            glam::DVec3::from(w),
            glam::DVec3::from(n),
        );
        assert!((u.cross(w) - n).length() < 1e-12);
        assert!(u.dot(n).abs() < 1e-12 && w.dot(n).abs() < 1e-12);
    }
}

/// A box holding every point of the single-tet tests (the domain methods' bounds use).
const TEST_DOMAIN: [[f64; 3]; 2] = [[-4.0; 3], [4.0; 3]];

/// For a single tet and rays through chosen faces, method M names that face: from inside
/// (the start tet) and entering through each face and leaving by each of the three others.
pub(crate) fn check_exact_exit_faces<R: Real, M: ExitMethod<R>>() {
    // A generic tet, positively oriented, with no face parallel to an axis.
    let v = [
        [0.1, 0.05, 0.0],
        [1.2, 0.1, 0.15],
        [0.2, 1.1, -0.1],
        [0.3, 0.2, 0.9],
    ];
    assert!(orient(v[0], v[1], v[2], v[3]) > 0.0);
    let centroid = |f: [usize; 3]| [0, 1, 2].map(|a| (v[f[0]][a] + v[f[1]][a] + v[f[2]][a]) / 3.0);
    let to_r = |p: [f64; 3]| p.map(R::from_f64);
    let inside = [0.0, 1.0, 2.0].map(|k| (0..4).map(|i| v[i][k as usize]).sum::<f64>() / 4.0);
    for (i, f) in OUTWARD_FACES.iter().enumerate() {
        let c = centroid(*f);
        let d = [0, 1, 2].map(|a| c[a] - inside[a]);
        let ray = M::prepare(inside, d, &TEST_DOMAIN);
        let ps = v.map(to_r);
        let vs = ps.map(|p| M::vertex(&ray, p));
        assert_eq!(
            M::start_exit(&ray, &vs, &ps),
            i,
            "{} {}: start tet, ray to face {i}",
            M::NAME,
            R::NAME
        );
    }
    // Enter through face e (its outward order reversed is counter-clockwise around the ray),
    // leave through each other face x.
    for (e, &f) in OUTWARD_FACES.iter().enumerate() {
        let (a, b, c, d) = (f[0], f[2], f[1], e);
        let entry = centroid(f);
        for (target, want) in [
            ([a, b, d], Exit::Abd),
            ([b, c, d], Exit::Bcd),
            ([c, a, d], Exit::Cad),
        ] {
            // Aim from a point near the entry face's centroid to a point near the target's.
            let g = centroid(target);
            let en = [0, 1, 2].map(|k| 0.9 * entry[k] + 0.1 * inside[k]);
            let dir = [0, 1, 2].map(|k| g[k] - en[k]);
            let o = [0, 1, 2].map(|k| en[k] - 0.5 * dir[k]);
            let ray = M::prepare(o, dir, &TEST_DOMAIN);
            let p = [a, b, c, d].map(|q| to_r(v[q]));
            assert_eq!(
                super::decide::<R, M>(&ray, &p),
                want,
                "{} {}: entering by face {e}",
                M::NAME,
                R::NAME
            );
        }
    }
}

#[test]
fn exact_exit_faces_aman2022() {
    check_exact_exit_faces::<f32, Aman2022>();
    check_exact_exit_faces::<f64, Aman2022>();
}

/// Random rays (half from inside the box, half from around it) on a random scene, cast by `f`
/// (method `method`), judged by the referee on the rays as the walk saw them (rounded to R).
///
/// What is asserted, for every method: no ray FAILED and every walk ends within 1000 steps;
/// and a hit on a tied triangle has `|t − t*| ≤ ulp_R(t*) + B` (0 `t_off`): `t` is the
/// float64 Möller–Trumbore quotient on the caller's triangle (`scene::intersect_triangle`,
/// anchored at its first vertex) rounded to R, whose error docs/referee.md's `B` bounds and
/// the output's rounding adds at most `ulp_R(t*)` to. And every ray right, for every method:
/// `robust` decides exit faces by exact predicates; the others decide them in floating point
/// and can leave a tet by a wrong face only on a ray within their rounding of an edge, which
/// these random rays do not come near (all of them were right when the referee replaced the
/// float brute force, where the old test allowed 3 wrong). The bound is 0: a method that now
/// answers one of these rays wrong has changed, and the stress families are where rays near
/// edges are counted.
pub(crate) fn agreement<R: Real>(
    seed: u64,
    method: &str,
    f: impl Fn(&Scene, &Rays<R>, HitsOut<R>) -> crate::Result<()> + Copy,
) -> Tally {
    let mut rng = Rng::xorshift(seed);
    let (scene, tris) = random_scene(&mut rng, 5, 0.08);
    let n = 3000;
    let mut o = Vec::new();
    let mut d = Vec::new();
    for k in 0..n {
        // Half the rays start inside, half outside the unit box.
        let g = if k % 2 == 0 { 0.0 } else { 1.0 };
        for _ in 0..3 {
            o.push(rng.f() * (1.0 + 2.0 * g) - g);
        }
        for _ in 0..3 {
            d.push(rng.f() - 0.5);
        }
    }
    let to_r = |x: &Vec<f64>| x.iter().map(|&x| R::from_f64(x)).collect::<Vec<R>>();
    let (or, dr) = (to_r(&o), to_r(&d));
    let res = cast(&scene, &or, &dr, f);
    for k in 0..n {
        assert!(
            res.status[k] == HIT || res.status[k] == MISS,
            "ray {k}: status {}",
            res.status[k]
        );
        assert!(res.steps[k] < 1000);
    }
    // Judge the rounded rays the walk saw.
    let back = |x: &Vec<R>| x.iter().map(|x| x.to_f64()).collect::<Vec<f64>>();
    let want = verdicts(&back(&or), &back(&dr), &tris);
    let name = format!("agreement {method} {} seed {seed}", R::NAME);
    let c = tally(&name, &want, &res.status, &res.tri, &res.t);
    eprintln!("{name}: {c:?} of {n} rays");
    assert_eq!(c.t_off, 0, "{name}: t outside ulp + B on a tied triangle");
    assert_eq!(c.bad(), 0, "{name}: every ray must be right");
    c
}

/// Method M on every layout (Tet80 in f32 only), both precisions, judged by the referee on
/// random scenes.
pub(crate) fn check_agreement<M: ExitMethod<f32> + ExitMethod<f64>>(seed: u64) {
    use crate::layout::{Layout, Plain, Tet16, Tet20, Tet32, Tet80};
    fn on<L: Layout, M: ExitMethod<f32> + ExitMethod<f64>>(seed: u64, f64_too: bool) {
        let opts = CastOptions {
            threads: None,
            max_steps: Some(100_000),
            ..Default::default()
        };
        // agreement() casts once per scene: the layout is built there, for that scene.
        let name = format!("{}/{}", <M as ExitMethod<f32>>::NAME, L::NAME);
        if f64_too {
            agreement::<f64>(seed, &name, |s, r, o| {
                s.cast_generic::<f64, f64, L, M>(&s.mesh.points, &L::build(&s.mesh)?, r, o, &opts)
            });
        }
        agreement::<f32>(seed + 1, &name, |s, r, o| {
            s.cast_generic::<f32, f32, L, M>(&s.points_f32, &L::build(&s.mesh)?, r, o, &opts)
        });
    }
    on::<Plain, M>(seed, true);
    on::<Tet80, M>(seed + 10, false);
    on::<Tet32, M>(seed + 20, true);
    on::<Tet20, M>(seed + 30, true);
    on::<Tet16, M>(seed + 40, true);
}

#[test]
fn aman2022_agrees_with_brute_force() {
    check_agreement::<Aman2022>(21);
}

#[test]
fn agrees_with_brute_force_f64() {
    agreement::<f64>(11, crate::traverse::Method::DEFAULT.name(), |s, r, o| {
        s.cast(
            r,
            o,
            &CastOptions {
                threads: Some(1),
                max_steps: Some(100_000),
                ..Default::default()
            },
        )
    });
}

#[test]
fn agrees_with_brute_force_f32() {
    agreement::<f32>(12, crate::traverse::Method::DEFAULT.name(), |s, r, o| {
        s.cast(
            r,
            o,
            &CastOptions {
                threads: None,
                max_steps: Some(100_000),
                ..Default::default()
            },
        )
    });
}

#[test]
fn empty_scene_misses_and_counts_steps() {
    let mut rng = Rng::xorshift(5);
    let (scene, _) = random_scene(&mut rng, 3, 0.0);
    let o = [-1.0, 0.5, 0.5, 0.5, 0.5, 0.5, 2.0, 2.0, 2.0];
    let d = [1.0, 0.01, 0.02, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0];
    let res = cast::<f64>(&scene, &o, &d, |s, r, o| {
        s.cast(
            r,
            o,
            &CastOptions {
                threads: Some(1),
                max_steps: Some(1000),
                ..Default::default()
            },
        )
    });
    assert_eq!(res.status, vec![MISS, MISS, MISS]);
    assert!(res.steps[0] >= 3 && res.steps[1] >= 1);
    assert_eq!(res.steps[2], 0); // misses the domain
    assert!(res.t.iter().all(|t| t.is_infinite()));
}

#[test]
fn lagae2008_plane_exit_faces_and_agreement() {
    check_exact_exit_faces::<f32, Lagae2008Plane>();
    check_exact_exit_faces::<f64, Lagae2008Plane>();
    check_agreement::<Lagae2008Plane>(100);
}

#[test]
fn lagae2008_halfspace_exit_faces_and_agreement() {
    check_exact_exit_faces::<f32, Lagae2008Halfspace>();
    check_exact_exit_faces::<f64, Lagae2008Halfspace>();
    check_agreement::<Lagae2008Halfspace>(200);
}

#[test]
fn lagae2008_plucker_exit_faces_and_agreement() {
    check_exact_exit_faces::<f32, Lagae2008Plucker>();
    check_exact_exit_faces::<f64, Lagae2008Plucker>();
    check_agreement::<Lagae2008Plucker>(300);
}

#[test]
fn lagae2008_stp_exit_faces_and_agreement() {
    check_exact_exit_faces::<f32, Lagae2008Stp>();
    check_exact_exit_faces::<f64, Lagae2008Stp>();
    check_agreement::<Lagae2008Stp>(400);
}

#[test]
fn ms06_exit_faces_and_agreement() {
    check_exact_exit_faces::<f32, Ms06>();
    check_exact_exit_faces::<f64, Ms06>();
    check_agreement::<Ms06>(500);
}

#[test]
fn maria2017_exit_faces_and_agreement() {
    check_exact_exit_faces::<f32, Maria2017>();
    check_exact_exit_faces::<f64, Maria2017>();
    check_agreement::<Maria2017>(600);
}

/// Exact ties and junk (rays through a vertex or along an edge, a flat tet, NaN) still name a
/// face, and the same one every time, for every method added with the Lagae/MS06/Maria set.
fn check_degenerate_inputs<R: Real, M: ExitMethod<R>>() {
    // Integer tet: rays along the axes through its vertices give exact zero side products.
    let v = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
    ];
    let flat = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [1.0, 1.0, 0.0],
    ];
    let rays = [
        ([0.0, 0.0, -1.0], [0.0, 0.0, 1.0]),
        ([0.25, 0.25, 0.25], [0.0, 0.0, 1.0]),
        ([0.0, 0.0, 0.0], [1.0, 1.0, 1.0]),
        ([0.5, 0.0, -1.0], [0.0, 0.0, 1.0]),
        ([0.25, 0.25, 0.25], [1.0, 0.0, 0.0]),
        ([f64::NAN, 0.0, 0.0], [1.0, 0.0, 0.0]),
    ];
    for (o, d) in rays {
        let ray = M::prepare(o, d, &TEST_DOMAIN);
        for tet in [v, flat] {
            let ps = tet.map(|q| q.map(R::from_f64));
            let p = ps.map(|q| M::vertex(&ray, q));
            let i = M::start_exit(&ray, &p, &ps);
            assert!(
                i < 4 && i == M::start_exit(&ray, &p, &ps),
                "{} {}",
                M::NAME,
                R::NAME
            );
            for e in [[0, 1, 2, 3], [1, 0, 3, 2], [3, 2, 1, 0], [0, 0, 0, 0]] {
                let q = e.map(|k| ps[k]);
                let x = super::decide::<R, M>(&ray, &q);
                assert_eq!(
                    x,
                    super::decide::<R, M>(&ray, &q),
                    "{} {}",
                    M::NAME,
                    R::NAME
                );
            }
        }
    }
}

#[test]
fn paper_methods_survive_degenerate_inputs() {
    fn both<M: ExitMethod<f32> + ExitMethod<f64>>() {
        check_degenerate_inputs::<f32, M>();
        check_degenerate_inputs::<f64, M>();
    }
    both::<Lagae2008Plane>();
    both::<Lagae2008Halfspace>();
    both::<Lagae2008Plucker>();
    both::<Lagae2008Stp>();
    both::<Ms06>();
    both::<Maria2017>();
}
