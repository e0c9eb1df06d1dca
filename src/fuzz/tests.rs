use super::scenes::walk_scene;
use super::*;
use crate::status::HIT;

fn bounded(target: Target, cases: u64) {
    let r = run(target, 18, 0, cases, |_, _| {});
    assert_eq!(r.cases, cases);
    assert!(
        r.failures.is_empty(),
        "{} fuzz: {} panics, {} violations; first: {:?}",
        target.name(),
        r.panics,
        r.violations,
        r.failures
    );
}

/// The walk case of docs/fuzzing.md's finding (seed 7686576272770016265, ray 957 of a
/// 4097-ray batch): a ray aimed, up to rounding, at a mesh vertex meets an edge of
/// triangles 3, 4, 5 at t = 1 exactly, then triangles 6 and 2 within an ulp after it (their
/// float t, 1 − 2^-51 and 1 − 2^-49, below the edge's 1 + 2^-52). All hits sorted those by
/// float t and listed triangle 2 first; by exact t the closest hit (triangle 3) is first.
/// The case's other rays: 3873 (an origin 5e-324 off the box, `predicates::orient`) and
/// 444 (a direction not scaled exactly by a power of two: INVALID).
#[test]
fn all_hits_first_is_the_closest_hit_at_a_vertex() {
    let seed = 7686576272770016265;
    assert_eq!(walk_case(seed), Ok(()));
}

/// CI's bounded fuzz run of construction (`examples/fuzz.rs` runs long ones).
#[test]
fn fuzz_construct_bounded() {
    bounded(Target::Construct, 30_000);
}

/// CI's bounded fuzz run of the walk.
#[test]
fn fuzz_walk_bounded() {
    bounded(Target::Walk, 20_000);
}

/// A case is a function of its seed.
#[test]
fn cases_are_reproducible() {
    let mut a = Rng::new(7);
    let mut b = Rng::new(7);
    let x = grid_input(&mut a, 2, 0.3, 0.5, true);
    let y = grid_input(&mut b, 2, 0.3, 0.5, true);
    assert_eq!(x.points, y.points);
    assert_eq!(x.faces, y.faces);
    assert_ne!(case_seed(1, 0), case_seed(1, 1));
}

/// Findings of the first 10^6-case walk run (seed 1), each a ray whose origin lies a
/// denormal away from a box side: the exact walk answered HIT where the referee says MISS
/// and the other way round (Shewchuk's expansions underflowed in point location; the box
/// clip rounded a crossing at t = -1e-610 to 0). Every accelerator now gives the
/// referee's answer.
#[test]
fn denormal_origins_match_the_referee() {
    use crate::scene::{CastOptions, HitBuffers, Rays};
    // (seed, origin, direction, tmin, tmax)
    type Finding = (u64, [f64; 3], [f64; 3], f64, f64);
    let cases: &[Finding] = &[
        (
            15170707697638007875,
            [5e-324, 0.20418553539762063, 0.0],
            [0.6666666865348816, 0.12914777806749778, 0.3333333134651184],
            0.046494830382286745,
            f64::INFINITY,
        ),
        (
            9501721720988945446,
            [0.0, 5e-324, -0.0],
            [0.3333333134651184, 0.6666666865348816, 0.3333333134651184],
            0.0,
            f64::INFINITY,
        ),
        (
            7014758399948156850,
            [5e-324, 0.875, 0.0],
            [0.6666666865348816, -0.875, 0.6666666865348816],
            0.0,
            f64::INFINITY,
        ),
        (
            12482544231945107241,
            [-1e-310, 0.6443455634490668, 0.3333333134651184],
            [-1e300, -0.125, -0.0027274804477304126],
            0.0,
            f64::INFINITY,
        ),
        (
            10402791658503384998,
            [5e-324, 0.6666666865348816, 0.3333333134651184],
            [0.2047655792209122, 0.0, 5e-324],
            0.0,
            f64::INFINITY,
        ),
        (
            7422549865166973907,
            [0.583486794418368, 0.3333333134651184, -1e-310],
            [0.16251957019581498, 1e-30, -1.7976931348623157e308],
            0.0,
            f64::INFINITY,
        ),
        (
            2871361342409064747,
            [5e-324, 0.6327969147063446, 0.0],
            [1.0, 0.0, 1.0],
            0.0,
            1.1615369703921898,
        ),
        (
            17536974435068399106,
            [0.0, 5e-324, 0.6209471514633451],
            [0.6666666865348816, 0.6666666865348816, -0.2876138379982267],
            0.0,
            0.8699396193472455,
        ),
    ];
    for &(seed, o, d, lo, hi) in cases {
        let (scene, _) = walk_scene(seed % 48);
        let tris = &scene.surface.triangles;
        let want = crate::referee::first_hit(o, d, lo, hi, tris);
        for &accel in crate::testing::ACCEL_KINDS {
            let rays = Rays {
                origins: &o[..],
                directions: &d[..],
                tmin: &[lo],
                tmax: &[hi],
                leaving: None,
            };
            let mut hb = HitBuffers::<f64>::new(1, false);
            let opts = CastOptions {
                threads: Some(1),
                accel,
                ..Default::default()
            };
            scene.cast(&rays, hb.out(), &opts).unwrap();
            let got = (hb.status[0] == HIT).then(|| (hb.triangle[0] as usize, hb.t[0]));
            match &want {
                None => assert_eq!(got, None, "seed {seed} {}", accel.name()),
                Some(v) => {
                    let (tri, t) = got.unwrap_or_else(|| panic!("seed {seed}: MISS"));
                    assert!(v.ties.contains(&tri), "seed {seed} {}", accel.name());
                    assert_eq!(t, v.t, "seed {seed} {}", accel.name());
                }
            }
        }
    }
}
