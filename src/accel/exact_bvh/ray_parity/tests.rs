//! Containment by one ray's crossings, judged by analytic geometry: closed boxes (alone,
//! nested, overlapping) at grid points on their faces, edges and corners and at random points;
//! rays through a vertex and along a triangle's plane given up and the next direction taken;
//! a point every direction fails left undecided. Every SIMD level gives the same answers.

use super::*;
use crate::accel::ExactBvhParams;
use crate::testing::Rng;

/// The 12 triangles of the closed box [lo, hi].
fn box_triangles(lo: [f64; 3], hi: [f64; 3]) -> Vec<Tri> {
    let c =
        |i: usize| -> [f64; 3] { [0, 1, 2].map(|a| if i >> a & 1 == 1 { hi[a] } else { lo[a] }) };
    // Each face as two triangles of its four corners (corner bits: x = 1, y = 2, z = 4).
    let faces = [
        [0, 2, 6, 4],
        [1, 5, 7, 3],
        [0, 4, 5, 1],
        [2, 3, 7, 6],
        [0, 1, 3, 2],
        [4, 6, 7, 5],
    ];
    faces
        .iter()
        .flat_map(|f| [[c(f[0]), c(f[1]), c(f[2])], [c(f[0]), c(f[2]), c(f[3])]])
        .collect()
}

fn closed_in(p: [f64; 3], lo: [f64; 3], hi: [f64; 3]) -> bool {
    (0..3).all(|a| lo[a] <= p[a] && p[a] <= hi[a])
}

fn open_in(p: [f64; 3], lo: [f64; 3], hi: [f64; 3]) -> bool {
    (0..3).all(|a| lo[a] < p[a] && p[a] < hi[a])
}

/// Every point's side at every SIMD level, with the directions given up.
fn sides_at_every_level(tris: &[Tri], keep: &[bool], points: &[[f64; 3]]) -> Vec<(u8, usize)> {
    let bvh = ExactBvh::build(tris, ExactBvhParams::default()).unwrap();
    let mut stack = Vec::new();
    let mut first: Option<Vec<(u8, usize)>> = None;
    for simd in Simd::supported_levels() {
        let got: Vec<_> = points
            .iter()
            .map(|&p| side_of(&bvh, tris, keep, p, simd, &mut stack))
            .collect();
        match &first {
            Some(f) => assert_eq!(f, &got, "{simd:?} answers otherwise"),
            None => first = Some(got),
        }
    }
    first.unwrap()
}

#[test]
fn boxes_alone_nested_and_overlapping_answer_as_geometry_says() {
    let mut rng = Rng::xorshift(11);
    let mut points: Vec<[f64; 3]> = Vec::new();
    // A grid of step 1/4 over [-1/2, 7/2]³: on faces, edges and corners of every box below.
    for i in 0..17 {
        for j in 0..17 {
            for k in 0..17 {
                points.push([i, j, k].map(|n| n as f64 * 0.25 - 0.5));
            }
        }
    }
    for _ in 0..3000 {
        points.push([0, 1, 2].map(|_| rng.f() * 4.0 - 0.5));
    }
    type Box3 = ([f64; 3], [f64; 3]);
    let cases: [(&str, Vec<Box3>); 4] = [
        ("one box", vec![([0.0; 3], [1.0; 3])]),
        ("nested", vec![([0.0; 3], [3.0; 3]), ([1.0; 3], [2.0; 3])]),
        (
            "overlapping",
            vec![([0.0; 3], [2.0; 3]), ([1.0, 0.5, 1.0], [3.0, 2.5, 3.0])],
        ),
        (
            "sharing a face",
            vec![([0.0; 3], [1.0; 3]), ([1.0, 0.0, 0.0], [2.0, 1.0, 1.0])],
        ),
    ];
    for (name, boxes) in cases {
        let tris: Vec<Tri> = boxes
            .iter()
            .flat_map(|&(lo, hi)| box_triangles(lo, hi))
            .collect();
        let keep = vec![true; tris.len()];
        let got = sides_at_every_level(&tris, &keep, &points);
        let (mut inside, mut retried) = (0, 0);
        for (p, &(side, tries)) in points.iter().zip(&got) {
            // On a face of any box: inside. Else an odd number of open boxes hold it. (Two
            // boxes sharing a face: the shared face's two copies are both kept here, so points
            // on it are on the surface and points off it see each copy once per crossing.)
            let on = boxes
                .iter()
                .any(|&(lo, hi)| closed_in(*p, lo, hi) && !open_in(*p, lo, hi));
            let odd = boxes
                .iter()
                .filter(|&&(lo, hi)| open_in(*p, lo, hi))
                .count()
                % 2
                == 1;
            let want = if on || odd { INSIDE } else { OUTSIDE };
            assert_eq!(
                side, want,
                "{name}: point {p:?} ({tries} directions given up)"
            );
            inside += (side == INSIDE) as usize;
            retried += (tries > 0) as usize;
        }
        assert!(inside > 100, "{name}: {inside} points inside");
        // Generic directions: grid points and box corners do not line up with them.
        assert!(
            retried * 100 < points.len(),
            "{name}: {retried} points retried"
        );
    }
}

/// `2^e` times direction k: exact (a power of two), so a vertex placed there lies exactly on
/// the ray from the origin along direction k.
fn on_ray(k: usize, e: i32) -> [f64; 3] {
    direction(k).map(|x| x * 2f64.powi(e))
}

/// Whether `v` points into the cone of [`tetra_hit_at_a_corner`]'s corner (+x, -y, +z).
fn in_corner_cone(v: [f64; 3]) -> bool {
    v[0] >= 0.0 && v[1] <= 0.0 && v[2] >= 0.0
}

/// A closed tetrahedron with one corner exactly on direction k's ray from the origin, the
/// others along +x, -y and +z from it. Where that corner's cone holds neither the direction
/// nor its opposite, the ray touches the tetrahedron at the corner alone, in none of its
/// faces' planes.
fn tetra_hit_at_a_corner(k: usize) -> Vec<Tri> {
    let a = on_ray(k, 1);
    let b = [a[0] + 0.5, a[1], a[2]];
    let c = [a[0], a[1] - 0.5, a[2]];
    let d = [a[0], a[1], a[2] + 0.5];
    vec![[a, b, c], [a, c, d], [a, d, b], [b, d, c]]
}

#[test]
fn a_ray_through_a_corner_is_given_up_and_the_next_direction_answers() {
    // Direction 0 touches the corner alone: counting the three faces there as crossings
    // would make the origin inside.
    let dir = direction(0);
    assert!(
        !in_corner_cone(dir) && !in_corner_cone(dir.map(|x| -x)),
        "{dir:?}"
    );
    let tris = tetra_hit_at_a_corner(0);
    let keep = vec![true; tris.len()];
    let corners = [tris[0][0], tris[0][1], tris[0][2], tris[1][2]];
    let centroid = [0, 1, 2].map(|a| corners.iter().map(|c| c[a]).sum::<f64>() / 4.0);
    let got = sides_at_every_level(&tris, &keep, &[[0.0; 3], centroid, on_ray(0, 1)]);
    // The origin's first ray touches the corner alone (three triangles there, each with two
    // side products zero): given up; the second misses the tetrahedron.
    assert_eq!(got[0], (OUTSIDE, 1));
    assert_eq!(got[1].0, INSIDE);
    assert_eq!(got[2].0, INSIDE, "the corner itself is on the surface");
}

#[test]
fn a_ray_in_a_triangles_plane_is_given_up_and_the_next_direction_answers() {
    // The origin lies on the edge (4w, -4w) of this triangle, whose plane holds direction 0:
    // that ray meets no triangle at one point, and counting it would say outside.
    let w = [0.0, 0.0, 1.0];
    let tri: Tri = [
        on_ray(0, 2).map(|x| -x),
        w.map(|x| 4.0 * x),
        w.map(|x| -4.0 * x),
    ];
    let got = sides_at_every_level(&[tri], &[true], &[[0.0; 3]]);
    assert_eq!(got[0], (INSIDE, 1));
    // Not kept: nothing counts, the first ray answers.
    let got = sides_at_every_level(&[tri], &[false], &[[0.0; 3]]);
    assert_eq!(got[0], (OUTSIDE, 0));
}

#[test]
fn a_point_every_direction_fails_is_undecided_and_the_rest_answer() {
    let tris: Vec<Tri> = (0..TRIES).flat_map(tetra_hit_at_a_corner).collect();
    let keep = vec![true; tris.len()];
    let far = [40.0, -35.0, 30.0];
    let got = sides_at_every_level(&tris, &keep, &[[0.0; 3], far, [f64::NAN, 0.0, 0.0]]);
    assert_eq!(got[0], (UNDECIDED, TRIES));
    assert_eq!(got[1].0, OUTSIDE);
    assert_eq!(
        got[2],
        (OUTSIDE, 0),
        "a point that is not finite is outside"
    );
}

#[test]
fn triangles_left_out_do_not_count() {
    let tris = box_triangles([0.0; 3], [1.0; 3]);
    let keep: Vec<bool> = (0..tris.len()).map(|i| i % 2 == 0).collect();
    let p = [0.5, 0.5, 0.5];
    let all = sides_at_every_level(&tris, &vec![true; tris.len()], &[p]);
    assert_eq!(all[0].0, INSIDE);
    let none = sides_at_every_level(&tris, &vec![false; tris.len()], &[p]);
    assert_eq!(none[0], (OUTSIDE, 0));
    // Half the faces' triangles: the ray leaves through one of them or through a hole (or
    // their shared diagonal, given up): never an error, and the parallel driver agrees.
    let bvh = ExactBvh::build(&tris, ExactBvhParams::default()).unwrap();
    let half = sides_at_every_level(&tris, &keep, &[p]);
    let mut out = [9u8];
    sides(&bvh, &tris, &keep, &p, &mut out, Some(1)).unwrap();
    assert_eq!(out[0], half[0].0);
}

#[test]
fn directions_are_distinct_and_off_the_axes() {
    for k in 0..TRIES {
        let d = direction(k);
        assert!(
            d.iter().all(|&x| x != 0.0 && (-1.0..1.0).contains(&x)),
            "{k}: {d:?}"
        );
        for j in 0..k {
            let e = direction(j);
            let cross = [
                d[1] * e[2] - d[2] * e[1],
                d[2] * e[0] - d[0] * e[2],
                d[0] * e[1] - d[1] * e[0],
            ];
            assert!(
                cross.iter().any(|x| x.abs() > 1e-3),
                "{j} and {k} nearly parallel"
            );
        }
    }
}
