//! A scene of the triangles alone (`Scene::surface_only`, what `Scene.from_mesh` makes before a
//! query needs the tetrahedralization) answers every triangle-testing accelerator's queries
//! as the tetrahedralized scene does, bit for bit, in every column: those accelerators read the
//! triangles, never the tets or the domain box, even where the boxes differ.

use crate::error::Error;
use crate::query::Listed;
use crate::scene::{HitBuffers, Scene};
use crate::testing::{on, Agreement, ACCEL_KINDS};

fn same_hits<R: crate::geom::real::Real + PartialEq>(
    what: &str,
    a: &HitBuffers<R>,
    b: &HitBuffers<R>,
) {
    let bits = |v: &[R]| v.iter().map(|x| format!("{x:?}")).collect::<Vec<_>>();
    assert_eq!(a.status, b.status, "{what}: status");
    assert_eq!(a.triangle, b.triangle, "{what}: triangle");
    assert_eq!(bits(&a.t), bits(&b.t), "{what}: t");
    assert_eq!(bits(&a.u), bits(&b.u), "{what}: u");
    assert_eq!(bits(&a.v), bits(&b.v), "{what}: v");
    assert_eq!(bits(&a.point), bits(&b.point), "{what}: point");
    assert_eq!(a.tet, b.tet, "{what}: tet");
    assert_eq!(a.steps, b.steps, "{what}: steps");
}

#[test]
fn triangles_alone_answer_as_the_tetrahedralized_scene() {
    let a = Agreement::new(11);
    let full = &a.g.scene;
    let tris = full.surface.triangles.clone();
    // The grid's box, grown unevenly: rays from between the two boxes start inside one
    // domain and outside the other.
    let [lo, hi] = full.mesh.bounds;
    let alone = Scene::surface_only(
        tris,
        [lo[0] - 0.3, lo[1] - 0.01, lo[2] - 2.0],
        [hi[0] + 0.02, hi[1] + 1.0, hi[2] + 0.5],
    )
    .unwrap();
    assert!(alone.mesh.constrained.is_empty() && alone.mesh.tets.len() == 6);
    let n = a.len();
    let mut hits = 0;
    for window in [false, true] {
        let (tmin, tmax) = a.bounds(window);
        for &accel in ACCEL_KINDS.iter().filter(|k| k.tests_triangles()) {
            let what = format!("{accel:?}, window {window}");
            let opts = on(accel);
            let (r64, r32) = (a.r64(&tmin, &tmax), a.r32(&tmin, &tmax));
            let (mut x, mut y) = (HitBuffers::<f64>::new(n, false), HitBuffers::new(n, false));
            full.cast(&r64, x.out(), &opts).unwrap();
            alone.cast(&r64, y.out(), &opts).unwrap();
            same_hits(&format!("{what}, f64"), &x, &y);
            hits += x
                .status
                .iter()
                .filter(|&&s| s == crate::status::HIT)
                .count();
            let (mut x, mut y) = (HitBuffers::<f32>::new(n, false), HitBuffers::new(n, false));
            full.cast(&r32, x.out(), &opts).unwrap();
            alone.cast(&r32, y.out(), &opts).unwrap();
            same_hits(&format!("{what}, f32"), &x, &y);
            let (mut p, mut q) = (vec![0u8; n], vec![0u8; n]);
            let m = crate::traverse::Method::DEFAULT;
            let l = crate::layout::LayoutKind::DEFAULT;
            full.occluded(m, l, &r64, &mut p, &opts).unwrap();
            alone.occluded(m, l, &r64, &mut q, &opts).unwrap();
            assert_eq!(p, q, "{what}: any hit");
            let (mut p, mut q) = (vec![Listed::default(); n], vec![Listed::default(); n]);
            full.intersections(&r64, &mut p, &opts).unwrap();
            alone.intersections(&r64, &mut q, &opts).unwrap();
            // Debug prints every field of every point (t bit for bit, as `{:?}` writes it).
            assert_eq!(format!("{p:?}"), format!("{q:?}"), "{what}: all hits");
        }
    }
    assert!(hits > n, "too few hits to compare: {hits}");
}

#[test]
fn triangles_alone_need_a_box_around_them() {
    let tri = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    assert!(Scene::surface_only(vec![tri], [-1.0; 3], [2.0; 3]).is_ok());
    for (lo, hi) in [
        ([0.0; 3], [2.0; 3]),
        ([-1.0; 3], [1.0; 3]),
        ([1.0; 3], [-1.0; 3]),
    ] {
        match Scene::surface_only(vec![tri], lo, hi) {
            Err(Error::InvalidInput(_)) => {}
            Err(e) => panic!("{lo:?} {hi:?}: {e}"),
            Ok(_) => panic!("{lo:?} {hi:?}: a box not around the triangle was taken"),
        }
    }
    let bad = [[f64::NAN, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    assert!(Scene::surface_only(vec![bad], [-1.0; 3], [2.0; 3]).is_err());
}
