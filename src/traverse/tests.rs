//! Walk tests on synthetic tetrahedralizations, judged by the exact referee
//! (`crate::referee`, docs/referee.md), which shares no code with the walk.
//!
//! Over 500 lines on purpose: every method's tests use the scenes and the referee-judged
//! assertions defined here (the GPU tests too); split per method they would import each other.

use super::*;
use crate::geom::predicates::orient;
use crate::mesh::build::OUTWARD_FACES;
use crate::referee::{self, Outcome, Verdict};
use crate::scene::{CastOptions, HitsOut, Rays, Scene};
use crate::status::{FAILED, HIT, MISS};

pub(crate) use crate::testing::{all_faces, grid_scene, kuhn_grid, random_scene, GridScene, Rng};

/// The referee's verdicts for rays given flat (`3 k ..`), over `[0, ∞)` as [`cast`] casts them.
pub(crate) fn verdicts(o: &[f64], d: &[f64], tris: &[[[f64; 3]; 3]]) -> Vec<Option<Verdict>> {
    use rayon::prelude::*;
    (0..o.len() / 3)
        .into_par_iter()
        .map(|k| {
            let p = |v: &[f64]| [v[3 * k], v[3 * k + 1], v[3 * k + 2]];
            referee::first_hit(p(o), p(d), 0.0, f64::INFINITY, tris)
        })
        .collect()
}

/// How many rays of a cast the referee finds right, and how each other one went
/// (docs/referee.md's outcomes).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Tally {
    pub right: usize,
    pub failed: usize,
    pub leaked: usize,
    pub late: usize,
    pub wrong: usize,
    /// Of `wrong`: a tied triangle, with `t` outside `ulp(t*) + B`.
    pub t_off: usize,
}

impl Tally {
    pub fn bad(&self) -> usize {
        self.failed + self.leaked + self.late + self.wrong
    }
}

/// Judges a cast (status, triangle and `t` per ray; `t` of the output type `R`) against the
/// verdicts, printing the first few rays that are not right under `name`.
pub(crate) fn tally<R: Real>(
    name: &str,
    verdicts: &[Option<Verdict>],
    status: &[u8],
    tri: &[i32],
    t: &[R],
) -> Tally {
    let precision = if R::NAME == "f32" {
        referee::Precision::F32
    } else {
        referee::Precision::F64
    };
    let mut c = Tally::default();
    for (k, v) in verdicts.iter().enumerate() {
        let hit = (status[k] == HIT).then(|| (tri[k] as usize, t[k].to_f64()));
        let out = referee::judge(v.as_ref(), status[k] == FAILED, hit, precision);
        match out {
            Outcome::Right => c.right += 1,
            Outcome::Failed => c.failed += 1,
            Outcome::Leaked => c.leaked += 1,
            Outcome::Late => c.late += 1,
            Outcome::Wrong => {
                c.wrong += 1;
                let tied = v.as_ref().zip(hit).is_some_and(|(v, h)| v.ties_with(h.0));
                c.t_off += tied as usize;
            }
        }
        if out != Outcome::Right && c.bad() <= 5 {
            eprintln!(
                "{name}: ray {k} {out:?}: referee {v:?}, cast status {} triangle {} t {:?}",
                status[k], tri[k], t[k]
            );
        }
    }
    c
}

struct Cast<R> {
    t: Vec<R>,
    tri: Vec<i32>,
    status: Vec<u8>,
    steps: Vec<u32>,
}

fn cast<R: Real>(
    scene: &Scene,
    o: &[R],
    d: &[R],
    f: impl Fn(&Scene, &Rays<R>, HitsOut<R>) -> crate::Result<()>,
) -> Cast<R> {
    let n = o.len() / 3;
    let (mut t, mut u, mut v, mut p) = (
        vec![R::ZERO; n],
        vec![R::ZERO; n],
        vec![R::ZERO; n],
        vec![R::ZERO; 3 * n],
    );
    let (mut tri, mut tet, mut steps, mut status) =
        (vec![0; n], vec![0; n], vec![0; n], vec![0; n]);
    let rays = Rays {
        origins: o,
        directions: d,
        tmin: &[0.0],
        tmax: &[f64::INFINITY],
        leaving: None,
    };
    let out = HitsOut {
        t: &mut t,
        u: &mut u,
        v: &mut v,
        point: &mut p,
        triangle: &mut tri,
        tet: &mut tet,
        steps: &mut steps,
        status: &mut status,
        audit: &mut [],
    };
    f(scene, &rays, out).unwrap();
    Cast {
        t,
        tri,
        status,
        steps,
    }
}

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

#[test]
fn robust_exact_faces_and_agreement() {
    check_exact_exit_faces::<f32, Robust>();
    check_exact_exit_faces::<f64, Robust>();
    check_agreement::<Robust>(700);
}

/// Degenerate on purpose: an unjittered grid (all coordinates multiples of 1/4, many
/// coplanar faces) and axis-aligned rays through its vertices, along its edges and in its
/// face planes. The robust walk must end every ray in the exact bracket of
/// [`assert_between_touch_and_inside`]; the others are only required to terminate.
///
/// Finding, recorded (printed) rather than asserted: under docs/referee.md's contract
/// (closed triangles: a ray through a vertex or an edge hits every triangle there) robust is
/// `leaked` or `late` on many of these rays. Its symbolic perturbation follows a nearby
/// line, which passes a touched vertex or edge on one side and may cross only non-scene
/// faces there; it never reports a hit the contract forbids (0 `wrong`), but it does not
/// honour touches. The stricter contract would need a change to the walk, not to this test.
#[test]
fn robust_survives_rays_through_vertices_and_edges() {
    use crate::scene::CastOptions;
    use crate::status::FAILED;
    let mut rng = Rng::xorshift(99);
    let GridScene { scene, tris, .. } = grid_scene(&mut rng, 4, 0.0, 0.15);
    let (mut o, mut d) = (Vec::new(), Vec::new());
    let g = |k: usize| k as f64 / 4.0;
    for i in 0..5 {
        for j in 0..5 {
            for axis in 0..3 {
                for dir in [1.0, -1.0] {
                    // Through grid vertices, along grid edges: exactly on the lines of the mesh.
                    let mut p = [g(i), g(j), 0.0];
                    p.rotate_right(axis);
                    p[axis] = if dir > 0.0 { -0.5 } else { 1.5 };
                    let mut v = [0.0; 3];
                    v[axis] = dir;
                    o.extend(p);
                    d.extend(v);
                    // Diagonal in a grid plane, through vertices.
                    let mut q = [g(i), 0.0, 0.0];
                    q.rotate_right(axis);
                    let mut w = [0.0, 1.0, 1.0];
                    w.rotate_right(axis);
                    o.extend([0, 1, 2].map(|k| q[k] - 0.5 * w[k] * dir));
                    d.extend(w.map(|x| x * dir));
                }
            }
        }
    }
    let n = o.len() / 3;
    let want = verdicts(&o, &d, &tris);
    for &method in crate::traverse::METHODS {
        let res = cast::<f64>(&scene, &o, &d, |s, r, out| {
            s.cast_named(
                method,
                "tet32",
                r,
                out,
                &CastOptions {
                    threads: Some(1),
                    max_steps: Some(10_000),
                    ..Default::default()
                },
            )
        });
        let failed = res.status.iter().filter(|&&s| s == FAILED).count();
        let name = format!("degenerate rays {method}");
        let c = tally(&name, &want, &res.status, &res.tri, &res.t);
        // Recorded, not asserted (see above; the stability issue reports the others').
        eprintln!("{name}: {failed} of {n} FAILED; referee {c:?}");
        if method != "robust" {
            continue;
        }
        assert_eq!(failed, 0, "robust: {failed} of {n} degenerate rays FAILED");
        assert_eq!(
            c.wrong, 0,
            "robust: a hit the referee rules out (or off its t)"
        );
        for k in 0..n {
            let ok = [0, 1, 2].map(|a| o[3 * k + a]);
            let dk = [0, 1, 2].map(|a| d[3 * k + a]);
            let (status, tri, t) = (res.status[k], res.tri[k], res.t[k]);
            assert_between_touch_and_inside(
                k,
                status,
                tri,
                Some(t),
                ok,
                dk,
                &tris,
                want[k].as_ref(),
            );
        }
    }
}

/// Where a ray touches a triangle only on its boundary, hit and miss are both right (a line
/// nudged either way does one or the other); a hit strictly inside a triangle is not
/// optional. So a hit lies at t_touch <= t <= t_inside, and a miss has no t_inside: t_touch
/// is the referee's first hit (closed triangles; `touch`, the ray's verdict), t_inside its
/// first crossing strictly inside a triangle (no zero side product), both exact. The hit's
/// triangle must be one the ray's line crosses, at `t` (of the output type R; `None`: not
/// checked) within ulp_R + B of the crossing (as [`agreement`]).
#[allow(clippy::too_many_arguments)] // one ray's fields, as the tests hold them; a struct would only rename them
pub(crate) fn assert_between_touch_and_inside<R: Real>(
    k: usize,
    status: u8,
    tri: i32,
    t: Option<R>,
    o: [f64; 3],
    d: [f64; 3],
    tris: &[[[f64; 3]; 3]],
    touch: Option<&Verdict>,
) {
    let inside = referee::first_hit_by(o, d, 0.0, f64::INFINITY, tris, |zeros| zeros == 0);
    if status == HIT {
        let tri = tris[tri as usize];
        let c = referee::crossing(o, d, &tri)
            .unwrap_or_else(|| panic!("ray {k}: its line does not cross triangle {tri:?}"));
        let tc = c.t();
        if let Some(t) = t.map(R::to_f64) {
            let precision = if R::NAME == "f32" {
                referee::Precision::F32
            } else {
                referee::Precision::F64
            };
            assert!(
                c.within_ulp(t, precision),
                "ray {k}: t {t} vs crossing {tc}"
            );
        }
        let touch = touch.unwrap_or_else(|| panic!("ray {k}: hit at {tc}, no triangle touched"));
        assert!(
            c.cmp_t_of(&touch.exact).is_ge(),
            "ray {k}: crossing at {tc} before any triangle {touch:?}"
        );
        assert!(
            inside.as_ref().is_none_or(|b| c.cmp_t_of(&b.exact).is_le()),
            "ray {k}: crossing at {tc} after a sure hit {inside:?}"
        );
    } else {
        assert_eq!(status, MISS, "ray {k}");
        assert!(inside.is_none(), "ray {k} missed a sure hit at {inside:?}");
    }
}

/// Rays starting at every point of a jittered grid, box-side points included (their start
/// lies on the domain's boundary), and rays from outside aimed at box-side points: the
/// perturbed start must be inside the mesh (`robust::start_delta`), else the walk starts in a
/// tet its line does not cross and can cycle. Robust: no FAILED ray in either precision, and
/// in float64 every ray bracketed by the referee.
#[test]
fn robust_rays_from_the_domain_boundary() {
    use crate::scene::CastOptions;
    use crate::status::FAILED;
    let mut rng = Rng::xorshift(31);
    let GridScene {
        scene,
        tris,
        pts,
        faces,
    } = grid_scene(&mut rng, 6, 0.3, 0.05);
    let (mut o, mut d) = (Vec::new(), Vec::new());
    for p in &pts {
        for _ in 0..4 {
            // Multiples of 2^-20: with the grid's multiples of 2^-24, `p − 3 v` is exact, so
            // every ray's line passes exactly through its grid point.
            let v = [0; 3].map(|_| ((rng.f() - 0.5) * 1_048_576.0).round() / 1_048_576.0);
            o.extend(*p);
            d.extend(v);
            // From outside, through this point.
            o.extend([0, 1, 2].map(|k| p[k] - 3.0 * v[k]));
            d.extend(v);
        }
    }
    let n = o.len() / 3;
    let opts = CastOptions {
        threads: Some(1),
        max_steps: Some(100_000),
        ..Default::default()
    };
    let res = cast::<f64>(&scene, &o, &d, |s, r, out| {
        s.cast_named("robust", "tet32", r, out, &opts)
    });
    let o32: Vec<f32> = o.iter().map(|&x| x as f32).collect();
    let d32: Vec<f32> = d.iter().map(|&x| x as f32).collect();
    let res32 = cast::<f32>(&scene, &o32, &d32, |s, r, out| {
        s.cast_named("robust", "tet32", r, out, &opts)
    });
    for (name, status) in [("f64", &res.status), ("f32", &res32.status)] {
        let failed = status.iter().filter(|&&s| s == FAILED).count();
        assert_eq!(failed, 0, "robust {name}: {failed} of {n} rays FAILED");
    }
    // The referee's outcomes, recorded (the finding of the test above): a ray through a
    // vertex meets every triangle there (closed triangles), which robust's perturbed line
    // need not hit; the bracket below is what robust guarantees, and it never reports a hit
    // the contract rules out (0 `wrong` in float64). The float32 rays are the float64 ones
    // rounded: they need not pass through the grid points, so only recorded.
    let want64 = verdicts(&o, &d, &tris);
    let c64 = tally(
        "boundary robust f64",
        &want64,
        &res.status,
        &res.tri,
        &res.t,
    );
    let back = |x: &[f32]| x.iter().map(|&x| x as f64).collect::<Vec<f64>>();
    let want32 = verdicts(&back(&o32), &back(&d32), &tris);
    let c32 = tally(
        "boundary robust f32",
        &want32,
        &res32.status,
        &res32.tri,
        &res32.t,
    );
    eprintln!("boundary robust of {n} rays: f64 {c64:?}, f32 {c32:?}");
    assert_eq!(
        c64.wrong, 0,
        "robust f64: a hit the referee rules out (or off its t)"
    );
    let on_scene: std::collections::HashSet<u32> = faces.iter().flatten().copied().collect();
    let mut from_scene = 0;
    for k in 0..n {
        let ok = [0, 1, 2].map(|a| o[3 * k + a]);
        let dk = [0, 1, 2].map(|a| d[3 * k + a]);
        // Starts on a scene triangle's vertex: a hit at t = 0 and none are both right, as the
        // bracket allows (t_touch = 0).
        from_scene += (k % 2 == 0 && on_scene.contains(&((k / 8) as u32))) as usize;
        let (status, tri, t) = (res.status[k], res.tri[k], res.t[k]);
        assert_between_touch_and_inside(k, status, tri, Some(t), ok, dk, &tris, want64[k].as_ref());
    }
    assert!(from_scene > 0, "no ray starts on a scene triangle");
}

/// A mesher whose faces only lie near the input (fTetWild) names, for each face, a nearby
/// triangle that a ray through the face may miss; with alternatives, the hit names the
/// triangle the ray does cross. Here every face names the wrong triangle on purpose, and
/// the right one is among the named triangle's alternatives.
#[test]
fn hits_name_the_alternative_the_ray_crosses() {
    let mut rng = Rng::xorshift(91);
    let (pts, tets) = kuhn_grid(5, 0.3, &mut rng);
    let faces: Vec<[u32; 3]> = all_faces(&tets)
        .into_iter()
        .filter(|_| rng.f() < 0.08)
        .collect();
    let tris: Vec<[[f64; 3]; 3]> = faces.iter().map(|f| f.map(|v| pts[v as usize])).collect();
    let n_tri = tris.len() as u32;
    // Face k names the triangle whose centre is farthest from its own (so the ray cannot
    // cross it near the face); the alternatives of a triangle are the faces naming it.
    let centre = |t: &[[f64; 3]; 3]| t.map(glam::DVec3::from).into_iter().sum::<glam::DVec3>();
    let named: Vec<u32> = (0..tris.len())
        .map(|k| {
            let far = |j: &usize| centre(&tris[*j]).distance_squared(centre(&tris[k]));
            (0..tris.len())
                .max_by(|a, b| far(a).total_cmp(&far(b)))
                .unwrap() as u32
        })
        .collect();
    let mut offsets = vec![0u32; tris.len() + 1];
    for &j in &named {
        offsets[j as usize + 1] += 1;
    }
    for k in 0..tris.len() {
        offsets[k + 1] += offsets[k];
    }
    let mut ids = vec![0u32; tris.len()];
    let mut next = offsets.clone();
    for (k, &j) in named.iter().enumerate() {
        ids[next[j as usize] as usize] = k as u32;
        next[j as usize] += 1;
    }
    let mut scene = Scene::build(pts, &tets, &faces, &named, tris.clone()).unwrap();

    let n = 2000;
    let (mut o, mut d) = (Vec::new(), Vec::new());
    for _ in 0..n {
        o.extend((0..3).map(|_| rng.f()));
        d.extend((0..3).map(|_| rng.f() - 0.5));
    }
    let opts = CastOptions {
        threads: None,
        max_steps: Some(100_000),
        ..Default::default()
    };
    let want = verdicts(&o, &d, &tris);
    let hits = want.iter().flatten().count();
    assert!(hits > 500, "{hits} hits");
    // A face and the triangle it names share no vertex: in a conforming mesh the two are then
    // disjoint, so a ray's first hit on the face is never a point of the named triangle.
    for (k, &j) in named.iter().enumerate() {
        assert!(
            faces[k].iter().all(|v| !faces[j as usize].contains(v)),
            "face {k}"
        );
    }
    let score = |scene: &Scene, method: &str, when: &str| {
        let res = cast::<f64>(scene, &o, &d, |s, r, out| {
            s.cast_named(
                method,
                crate::layout::LayoutKind::DEFAULT.name(),
                r,
                out,
                &opts,
            )
        });
        let name = format!("alternatives {method}, {when}");
        let c = tally(&name, &want, &res.status, &res.tri, &res.t);
        eprintln!("{name}: {c:?} ({hits} hits of {n} rays)");
        c
    };
    let methods = ["robust", crate::traverse::Method::DEFAULT.name()];
    let before = methods.map(|m| score(&scene, m, "without"));
    scene
        .set_alternatives(offsets.clone(), ids.clone())
        .unwrap();
    let after = methods.map(|m| score(&scene, m, "with"));
    // Robust ends each hit on a face the ray crosses at t* (its exit faces are exact), so
    // without alternatives the named triangle, disjoint from that face, is never tied: no
    // hit is right (only the misses are). With them, every ray is right. The default
    // method's float exit faces can err: recorded above.
    assert_eq!(before[0].right, n - hits, "robust without alternatives");
    assert_eq!(after[0].bad(), 0, "robust with alternatives");
    assert!(after[1].right > before[1].right);

    // Malformed tables are refused with the reason.
    let n = n_tri as usize;
    let mut err = |o: Vec<u32>, i: Vec<u32>| scene.set_alternatives(o, i).unwrap_err().to_string();
    assert!(err(vec![0; n], vec![]).contains("offsets"));
    let mut falling = offsets.clone();
    falling[0] = 1;
    assert!(err(falling, ids.clone()).contains("must rise"));
    assert!(err(offsets, vec![n_tri; n]).contains(&format!("names triangle {n_tri}")));
}

/// The method table names each method by its type's `NAME`, and a name not in it is refused
/// with the known ones listed.
#[test]
fn method_names_are_the_types_names() {
    struct Name;
    impl<R: Real> MethodVisitor<R> for Name {
        type Out = &'static str;
        fn visit<M: ExitMethod<R>>(self) -> &'static str {
            M::NAME
        }
    }
    assert_eq!(Method::ALL.len(), METHODS.len());
    for (&m, &name) in Method::ALL.iter().zip(METHODS) {
        assert_eq!(m.visit::<f32, _>(Name), name);
        assert_eq!(m.visit::<f64, _>(Name), name);
        assert_eq!(Method::from_name(name).unwrap(), m);
    }
    let e = Method::from_name("nope").unwrap_err();
    assert!(matches!(e, crate::Error::InvalidOption(m) if m.contains("aman2022")));
    let e = crate::layout::LayoutKind::from_name("tet99").unwrap_err();
    assert!(matches!(e, crate::Error::InvalidOption(m) if m.contains("tet20")));
}
