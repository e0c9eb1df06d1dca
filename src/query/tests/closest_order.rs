//! Closest hit on a split triangle (issue 37, the hand-planted survivor): the exact walk keeps a
//! meet found out of walk order, then crosses a constrained face farther on; the answer is the
//! earlier of the two (`ClosestPolicy::crossed`'s `ray.earlier(self.best, meet)`).
//!
//! Where a mesher splits a caller's triangle, its Steiner points sit an ulp off it, so a line
//! in the triangle's plane can pass its neighbour's edge where no mesh edge is, without a
//! touch there. The exact queries then look at the caller's triangles around the faces and
//! touches nearby (`ExactRay::around`): the neighbour met at that edge is found later in the
//! walk, and kept while the walk goes on to the next point in order. If a constrained face is
//! crossed before any ordered stop, the kept, earlier meet must win.
//!
//! The scene: a Kuhn grid of 8³ cubes (grid units of 1/8), a floor T in the plane z = 4 with
//! corners (2,2,4), (2,5,4), (5,5,4), a wall W standing on the floor's edge x = 2 with corners
//! (2,2,4), (2,5,4), (2,5,7), and a wall W2 farther on, one face in the plane x = 6. T and W
//! are each covered by the grid's faces, whose corners are not their corners (split); the
//! grid point (2,3,4) on their shared edge, a Steiner point, sits one ulp above it. The grid
//! points (6,2,4) and (6,3,4) are raised by 1/64 so that the line crosses W2 through its
//! interior, not at a grid edge.
//!
//! The ray lies in the floor's plane: from (0.5, 2.6875, 4) along +x. It meets W at one point,
//! on its edge, (2, 2.6875, 4): t = 1.5 grid units = 0.1875. The mesh edges there are raised
//! by the Steiner point, so the walk passes below them without a touch, and finds W only when
//! it touches the floor's edge (2,2)–(3,3) at x = 2.6875 (`touched`'s `around`). It then walks
//! on and crosses W2 at t = 5.5 grid units. The answer is W at t = 0.1875, computed here by hand
//! and confirmed by the exact referee; keeping the crossing instead (`self.best = Some(meet)`)
//! answers W2 at 0.6875.

use crate::layout::LayoutKind;
use crate::scene::{AccelKind, Lanes, Packets};
use crate::traverse::Method;
use crate::{referee, CastOptions, HitBuffers, Rays, Scene, HIT, MISS};

const N: usize = 8;

fn id(x: usize, y: usize, z: usize) -> u32 {
    (x + (N + 1) * (y + (N + 1) * z)) as u32
}

/// The grid faces covering a right triangle of `len` × `len` cells in the plane
/// `axis = level`, cells from `start` in the plane's two other axes (u, v, in increasing axis
/// order): `upper`, the one with corners (u0, v0), (u0, v0 + len), (u0 + len, v0 + len) (cells
/// above the Kuhn diagonal u − u0 = v − v0, and the upper triangle of each cell on it); else the
/// one with corners (u0, v0), (u0 + len, v0), (u0 + len, v0 + len).
fn cover(axis: usize, level: usize, start: [usize; 2], len: usize, upper: bool) -> Vec<[u32; 3]> {
    let (a, b) = match axis {
        0 => (1, 2),
        1 => (0, 2),
        _ => (0, 1),
    };
    let at = |u: usize, v: usize| {
        let mut c = [0usize; 3];
        c[axis] = level;
        c[a] = u;
        c[b] = v;
        id(c[0], c[1], c[2])
    };
    let mut faces = Vec::new();
    for i in 0..len {
        for j in 0..len {
            let (u, v) = (start[0] + i, start[1] + j);
            // The two Kuhn triangles of cell (u, v): below the diagonal (u,v)-(u+1,v+1) and above.
            let below = [at(u, v), at(u + 1, v), at(u + 1, v + 1)];
            let above = [at(u, v), at(u, v + 1), at(u + 1, v + 1)];
            let keep = |tri_above: bool| {
                if upper {
                    j > i || (j == i && tri_above)
                } else {
                    j < i || (j == i && !tri_above)
                }
            };
            if keep(false) {
                faces.push(below);
            }
            if keep(true) {
                faces.push(above);
            }
        }
    }
    faces
}

/// The scene of the module's notes: the floor T, the wall W and the far wall W2 (caller
/// triangles 0, 1, 2) on the Kuhn grid, the Steiner point (2,3,4) an ulp above the floor's
/// plane, and the grid points `lowered` an ulp below it. With `under`, also the wall U in W's
/// plane below the floor, with corners (2,2,1), (2,2,4), (2,5,4): it shares the floor's edge
/// x = 2 with W, and comes first among the caller's triangles (U, T, W, W2: 0 to 3), its
/// faces last among the constrained faces.
fn floor_and_walls(lowered: &[[usize; 3]], under: bool) -> (Scene, Vec<[[f64; 3]; 3]>) {
    let (mut pts, tets) = crate::mesh::kuhn::kuhn_grid(N, 0.0, || 0.5);
    let h = 1.0 / N as f64;
    let g = |x: f64, y: f64, z: f64| [x * h, y * h, z * h];
    // The Steiner point on the edge T and W share, one ulp above it.
    let s = id(2, 3, 4) as usize;
    assert_eq!(pts[s], g(2.0, 3.0, 4.0));
    pts[s][2] = 0.5 + f64::EPSILON / 2.0;
    assert!(pts[s][2] > 0.5);
    // Below 0.5 the ulp is half as large.
    for &[x, y, z] in lowered {
        let p = &mut pts[id(x, y, z) as usize];
        assert_eq!(*p, g(x as f64, y as f64, z as f64));
        p[2] = 0.5 - f64::EPSILON / 4.0;
        assert!(p[2] < 0.5 && p[2] + f64::EPSILON / 4.0 == 0.5);
    }
    // W2's corners raised off the floor's level.
    for y in [2, 3] {
        pts[id(6, y, 4) as usize][2] = 0.5 + 1.0 / 64.0;
    }

    let floor = [g(2.0, 2.0, 4.0), g(2.0, 5.0, 4.0), g(5.0, 5.0, 4.0)];
    let wall = [g(2.0, 2.0, 4.0), g(2.0, 5.0, 4.0), g(2.0, 5.0, 7.0)];
    let far = [id(6, 2, 3), id(6, 2, 4), id(6, 3, 4)];
    let mut tris = vec![floor, wall, far.map(|v| pts[v as usize])];
    // T: cells x in [2,5], y in [2,5] of the plane z = 4, the half with y ≥ x (above the
    // diagonal). W: cells y in [2,5], z in [4,7] of the plane x = 2, the half with z − 4 ≤ y − 2.
    let t_faces = cover(2, 4, [2, 2], 3, true);
    let w_faces = cover(0, 2, [2, 4], 3, false);
    assert_eq!((t_faces.len(), w_faces.len()), (9, 9));
    let mut covers = vec![t_faces, w_faces, vec![far]];
    if under {
        tris.insert(0, [g(2.0, 2.0, 1.0), g(2.0, 2.0, 4.0), g(2.0, 5.0, 4.0)]);
        // Cells y in [2,5], z in [1,4] of the plane x = 2, the half with z − 1 ≥ y − 2.
        covers.push(cover(0, 2, [2, 1], 3, true));
    }
    let mut faces = Vec::new();
    let mut face_triangle = Vec::new();
    for (k, fs) in covers.into_iter().enumerate() {
        // With U first among the triangles, the others move up by one.
        let triangle = match (under, k) {
            (true, 3) => 0,
            (true, k) => k + 1,
            (false, k) => k,
        };
        for f in fs {
            faces.push(f);
            face_triangle.push(triangle as u32);
        }
    }
    let scene = Scene::build(pts, &tets, &faces, &face_triangle, tris.clone()).unwrap();
    (scene, tris)
}

/// The ray from `o` along `d` over [0, ∞), as a batch of one.
fn one_ray<'a>(o: &'a [f64; 3], d: &'a [f64; 3]) -> Rays<'a, f64> {
    Rays {
        origins: o,
        directions: d,
        tmin: &[0.0],
        tmax: &[f64::INFINITY],
        leaving: None,
    }
}

/// The closest hit (status, t, triangle) of the one ray of `rays` on the exact walk, with
/// lanes and packets as the cast picks them and with both off, each with its lanes setting.
fn closest_both_ways(scene: &Scene, rays: &Rays<f64>) -> Vec<(Lanes, (u8, f64, i32))> {
    [(Lanes::Auto, Packets::Auto), (Lanes::Off, Packets::Off)]
        .into_iter()
        .map(|(lanes, packets)| {
            let opts = CastOptions {
                threads: Some(1),
                lanes,
                packets,
                accel: AccelKind::TetWalk,
                ..CastOptions::default()
            };
            let mut out = HitBuffers::<f64>::new(1, false);
            scene
                .cast_with(Method::DEFAULT, LayoutKind::DEFAULT, rays, out.out(), &opts)
                .unwrap();
            (lanes, (out.status[0], out.t[0], out.triangle[0]))
        })
        .collect()
}

/// All hits of the one ray of `rays` on the exact walk: the status and each point's triangle
/// and t, in order.
fn all_hits(scene: &Scene, rays: &Rays<f64>) -> (u8, Vec<(u32, f64)>) {
    let opts = CastOptions {
        threads: Some(1),
        accel: AccelKind::TetWalk,
        ..CastOptions::default()
    };
    let mut listed = vec![crate::query::Listed::default(); 1];
    scene.intersections(rays, &mut listed, &opts).unwrap();
    let got = listed[0].meets.iter().map(|m| (m.triangle, m.t)).collect();
    (listed[0].status, got)
}

#[test]
fn a_neighbour_met_out_of_order_wins_over_a_later_crossing() {
    let h = 1.0 / N as f64;
    let g = |x: f64, y: f64, z: f64| [x * h, y * h, z * h];
    let (scene, tris) = floor_and_walls(&[], false);

    let o = g(0.5, 2.6875, 4.0);
    let d = [1.0, 0.0, 0.0];
    // By hand: the line y = 2.6875, z = 4 (grid units) lies in T's plane, so T is never hit;
    // it meets W's plane x = 2 at y = 2.6875 ∈ [2, 5], z = 4, on W's edge from (2,2,4) to
    // (2,5,4): W is hit at t = 1.5 / 8. W2 (x = 6) comes later, at t = 5.5 / 8.
    let (t_w, t_far) = (0.1875, 0.6875);
    let verdict = referee::first_hit(o, d, 0.0, f64::INFINITY, &tris).expect("the referee hits");
    assert_eq!((verdict.t, verdict.ties.clone()), (t_w, vec![1]));
    assert_eq!(
        referee::crossing(o, d, &tris[2]).map(|c| c.t()),
        Some(t_far)
    );
    assert!(referee::crossing(o, d, &tris[0]).is_none());

    let rays = one_ray(&o, &d);
    for (lanes, got) in closest_both_ways(&scene, &rays) {
        assert_eq!(
            got,
            (HIT, t_w, 1),
            "lanes {lanes:?}: the wall met at its edge (t = {t_w}) comes \
             before the far wall (t = {t_far})"
        );
    }

    // All hits find the wall the same way (`AllPolicy::touched`'s `around`, at a touch that
    // is not the origin): both walls, in order, each named and placed as the referee finds it.
    let (status, got) = all_hits(&scene, &rays);
    assert_eq!(status, HIT, "all hits: {got:?}");
    assert_eq!(
        got.iter().map(|m| m.0).collect::<Vec<_>>(),
        vec![1, 2],
        "all hits: {got:?}"
    );
    for (k, m) in got {
        let c = referee::crossing(o, d, &tris[k as usize]).expect("the referee meets it");
        assert!(
            c.within_ulp(m, referee::Precision::F64),
            "all hits: triangle {k} at t {m}, the referee's t {}",
            c.t()
        );
    }
}

/// A tie found after the meet it ties with (`ExactRay::earlier`, the same point: the smaller
/// triangle id; issue 37's `contact.rs` survivor, `earlier` keeping the meet recorded first).
/// The module's ray, with the wall U under the floor in W's plane: the line meets W and U at
/// the same point of their shared edge, (2, 2.6875, 4), t = 1.5 grid units. The caller's
/// triangles around the walk's touches find W first (around a grid point of W above the
/// floor) and U after it (around the Steiner point on the shared edge), and the tie goes to
/// U, the smaller id (0). By hand and by the referee: U at t = 0.1875, tied with W.
#[test]
fn a_tie_found_after_the_meet_it_ties_goes_to_the_smaller_id() {
    let h = 1.0 / N as f64;
    let g = |x: f64, y: f64, z: f64| [x * h, y * h, z * h];
    let (scene, tris) = floor_and_walls(&[], true);
    let o = g(0.5, 2.6875, 4.0);
    let d = [1.0, 0.0, 0.0];
    let t_w = 0.1875;
    let verdict = referee::first_hit(o, d, 0.0, f64::INFINITY, &tris).expect("the referee hits");
    assert_eq!((verdict.t, verdict.ties.clone()), (t_w, vec![0, 2]));
    let rays = one_ray(&o, &d);
    for (lanes, got) in closest_both_ways(&scene, &rays) {
        assert_eq!(
            got,
            (HIT, t_w, 0),
            "lanes {lanes:?}: U and W tie, U's id is smaller"
        );
    }
}

/// The in-plane crossing (`ClosestPolicy::crossed` and `AllPolicy::crossed` where `crossing`
/// finds no point: the line lies in the caller's triangle's plane, yet crosses one of its
/// faces through the face's interior). With the floor's grid point (3,4,4) an ulp below its
/// plane beside the Steiner point (2,3,4) an ulp above, the floor's face (2,3), (2,4), (3,4)
/// is tilted across the plane z = 4 along the segment from (2,4) to (2⅔, 3⅔) (z runs from
/// +2^-53 to −2^-54 along the edge from (2,3) to (3,4)). A line in the floor's plane at
/// y = 3.75 crosses that face through its interior at x = 2.5, where the caller's triangles
/// around the face are looked at (`ExactRay::around`), and meets the wall W on its edge at
/// x = 2, under the raised mesh edge (no touch there).
///
/// Along −x from (4.25, 3.75, 4), the face comes first (t = 1.75 grid units = 0.21875), W
/// after (t = 2.25 units = 0.28125). With tmax = 0.25, W lies beyond the range: nothing is hit
/// (the referee agrees), and a policy that kept what `around` finds outside [tmin, tmax]
/// would answer W. Along +x from (0.5, 3.75, 4), W comes first (t = 0.1875); with tmin = 0.2
/// nothing is hit. Without those bounds W is the hit and the only point listed.
#[test]
fn a_face_crossed_in_its_triangles_plane_keeps_only_meets_in_range() {
    let h = 1.0 / N as f64;
    let g = |x: f64, y: f64, z: f64| [x * h, y * h, z * h];
    let (scene, tris) = floor_and_walls(&[[3, 4, 4]], false);
    let inf = f64::INFINITY;
    let cases = [
        (
            g(4.25, 3.75, 4.0),
            [-1.0, 0.0, 0.0],
            0.0,
            inf,
            Some(0.28125),
        ),
        (g(4.25, 3.75, 4.0), [-1.0, 0.0, 0.0], 0.0, 0.25, None),
        (g(0.5, 3.75, 4.0), [1.0, 0.0, 0.0], 0.0, inf, Some(0.1875)),
        (g(0.5, 3.75, 4.0), [1.0, 0.0, 0.0], 0.2, inf, None),
    ];
    for (o, d, tmin, tmax, want) in cases {
        let case = format!("o {o:?} d {d:?} [{tmin}, {tmax}]");
        assert!(referee::crossing(o, d, &tris[0]).is_none());
        assert!(referee::crossing(o, d, &tris[2]).is_none());
        let verdict = referee::first_hit(o, d, tmin, tmax, &tris).map(|v| (v.t, v.ties));
        assert_eq!(verdict, want.map(|t| (t, vec![1])), "the referee, {case}");
        let rays = Rays {
            origins: &o[..],
            directions: &d[..],
            tmin: &[tmin],
            tmax: &[tmax],
            leaving: None,
        };
        for (lanes, got) in closest_both_ways(&scene, &rays) {
            match want {
                Some(t) => assert_eq!(got, (HIT, t, 1), "{case}, lanes {lanes:?}"),
                None => assert_eq!(got.0, MISS, "{case}, lanes {lanes:?}: {got:?}"),
            }
        }
        let (status, got) = all_hits(&scene, &rays);
        let expected: Vec<(u32, f64)> = want.map(|t| (1, t)).into_iter().collect();
        assert_eq!(got, expected, "all hits, {case}");
        assert_eq!(status, if want.is_some() { HIT } else { MISS });
    }
}

/// An origin exactly on a split caller's triangle, strictly inside a tet (`planes_at_origin`
/// on a split mesh). The floor's face (2,2), (2,3), (3,3) has the Steiner point (2,3,4) an ulp
/// above the floor's plane, so the point (2.25, 2.5, 4), on the floor (y ≥ x, inside its
/// corners), lies 2^-55 below that face: strictly inside the Kuhn tet (2,2,3), (2,2,4),
/// (2,3,4), (3,3,4) under it (its barycentric weight on (2,2,3) is 2^-52, the rest about
/// 1/2, 1/4, 1/4), on no face. The ray starts there (tmin = 0) and goes down, away
/// from every face the floor has: the closed floor holds its origin and its line is not in
/// the floor's plane, so it hits the floor at t = 0 (the referee agrees). Only the caller's
/// triangles around the start tet's vertices find it; the shortcut of an unsplit mesh (an
/// origin strictly inside its tet lies on no triangle) would leave it a miss.
#[test]
fn an_origin_on_a_split_triangle_strictly_inside_its_tet_hits_it_at_zero() {
    let h = 1.0 / N as f64;
    let g = |x: f64, y: f64, z: f64| [x * h, y * h, z * h];
    let (scene, tris) = floor_and_walls(&[], false);
    assert!(
        scene.incidence.split,
        "the mesher's Steiner point splits the floor"
    );
    let o = g(2.25, 2.5, 4.0);
    // The start tet holds o strictly: every orientation against its faces is nonzero.
    let tet = [
        g(2.0, 2.0, 3.0),
        g(2.0, 2.0, 4.0),
        g(2.0, 3.0, 4.0),
        g(3.0, 3.0, 4.0),
    ];
    let mut raised = tet;
    raised[2][2] = 0.5 + f64::EPSILON / 2.0;
    for f in [[1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2]] {
        let [a, b, c] = f.map(|k| raised[k]);
        assert_ne!(
            crate::geom::exact::orient_sign(a, b, c, o),
            0,
            "o on the face {f:?}"
        );
    }
    let d = [0.0, 0.0, -1.0];
    let verdict = referee::first_hit(o, d, 0.0, f64::INFINITY, &tris).expect("the referee hits");
    assert_eq!((verdict.t, verdict.ties.clone()), (0.0, vec![0]));
    let rays = one_ray(&o, &d);
    for (lanes, got) in closest_both_ways(&scene, &rays) {
        assert_eq!(got, (HIT, 0.0, 0), "lanes {lanes:?}");
    }
    assert_eq!(all_hits(&scene, &rays), (HIT, vec![(0, 0.0)]));
}

/// Lines in the planes of mesh faces (the grid planes z = 4 and y = 3 of an unjittered Kuhn
/// grid) aimed at a caller's triangle that is one grid face standing across them: (3,3,4),
/// (3,3,5), (3,4,5) in the plane x = 3. Each line meets the triangle only at its corner
/// (3,3,4) or on its edge (3,3,4)–(3,3,5), through grid vertices and along grid edges, where
/// the exact walk decides every exit by its perturbation; lines through points of x = 3
/// beside the triangle miss it. Each ray's answer is the referee's: closest hit with lanes and
/// packets on and off, and all hits. (Written to reach the in-plane touch,
/// `Contact::Coplanar`; instrumented, these walks never leave a tet by a face whose plane
/// holds the line: see docs/testing.md, shard 12's open survivors.)
#[test]
fn lines_in_face_planes_meet_a_standing_triangle_at_its_corner_and_edge() {
    let h = 1.0 / N as f64;
    let (pts, tets) = crate::mesh::kuhn::kuhn_grid(N, 0.0, || 0.5);
    let face = [id(3, 3, 4), id(3, 3, 5), id(3, 4, 5)];
    let tris = vec![face.map(|v| pts[v as usize])];
    let scene = Scene::build(pts, &tets, &[face], &[0], tris.clone()).unwrap();
    // Targets on x = 3 (grid units): the corner, a point of the edge along z, and points
    // beside the triangle in each plane; directions in the target's grid plane (z = 4 or
    // y = 3), each crossing x = 3; origins 0.5, 1 and 1.25 direction lengths back, so every
    // number is a short dyadic and t (back · h) is exact.
    let in_z4 = [
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [1.0, -1.0, 0.0],
        [2.0, 1.0, 0.0],
        [-1.0, 2.0, 0.0],
    ];
    let in_y3 = [
        [1.0, 0.0, 1.0],
        [1.0, 0.0, -1.0],
        [2.0, 0.0, 1.0],
        [-1.0, 0.0, 2.0],
        [-1.0, 0.0, -1.0],
    ];
    let cases: [([f64; 3], &[[f64; 3]]); 5] = [
        ([3.0, 3.0, 4.0], &in_z4),
        ([3.0, 3.0, 4.0], &in_y3),
        ([3.0, 3.0, 4.5], &in_y3),
        ([3.0, 2.5, 4.0], &in_z4),
        ([3.0, 3.0, 3.5], &in_y3),
    ];
    let (mut hits, mut misses) = (0, 0);
    for (target, dirs) in cases {
        for d in dirs {
            for back in [0.5, 1.0, 1.25] {
                let o: [f64; 3] = std::array::from_fn(|k| (target[k] - back * d[k]) * h);
                let d: [f64; 3] = *d;
                let t = back * h;
                let want = referee::first_hit(o, d, 0.0, f64::INFINITY, &tris);
                let case = format!("target {target:?}, d {d:?}, o {o:?}");
                let rays = one_ray(&o, &d);
                for (lanes, got) in closest_both_ways(&scene, &rays) {
                    match &want {
                        Some(v) => {
                            assert_eq!(v.t, t, "{case}: the referee meets it at the target");
                            assert_eq!(got, (HIT, t, 0), "{case}, lanes {lanes:?}");
                        }
                        None => assert_eq!(got.0, MISS, "{case}, lanes {lanes:?}: {got:?}"),
                    }
                }
                let (status, listed) = all_hits(&scene, &rays);
                match want {
                    Some(_) => {
                        hits += 1;
                        assert_eq!((status, listed), (HIT, vec![(0, t)]), "{case}");
                    }
                    None => {
                        misses += 1;
                        assert_eq!((status, listed), (MISS, vec![]), "{case}");
                    }
                }
            }
        }
    }
    // The corner and the edge point are met from every direction, the points beside missed.
    assert_eq!((hits, misses), (45, 30));
}

/// Lines in the domain box's side planes, started on the box's edges (and half a cell and two
/// cells back along the line, outside the box), meeting the grid planes x = 3 and y = 5, each
/// face of which is a caller's triangle standing on the box's sides. A line in a side's plane
/// meets those triangles only on their edges in that plane, at one point each (or not at
/// all: it never hits the side's own triangles, there are none). The origin on the box's
/// boundary is perturbed inwards (`robust::start_delta`), so the walk starts inside and
/// follows the side. Each ray's closest hit, with lanes and packets on and off, is the
/// referee's. (Written to reach the in-plane touch, `Contact::Coplanar`; instrumented, no
/// walk here leaves a tet by a face whose plane holds the line: docs/testing.md.)
#[test]
fn lines_in_the_box_sides_meet_triangles_standing_on_them() {
    let h = 1.0 / N as f64;
    let (pts, tets) = crate::mesh::kuhn::kuhn_grid(N, 0.0, || 0.5);
    let mut faces = Vec::new();
    for (axis, level) in [(0, 3), (1, 5)] {
        faces.extend(cover(axis, level, [0, 0], N, true));
        faces.extend(cover(axis, level, [0, 0], N, false));
    }
    let tris: Vec<[[f64; 3]; 3]> = faces.iter().map(|f| f.map(|v| pts[v as usize])).collect();
    let face_triangle: Vec<u32> = (0..faces.len() as u32).collect();
    let scene = Scene::build(pts, &tets, &faces, &face_triangle, tris.clone()).unwrap();
    let (mut rays, mut hits) = (0, 0);
    let n = N as f64;
    // The side a = la, the edge where it meets the side b = lb, a point c = pc along that
    // edge; the direction leaves the edge into the side (along b) and runs along c by dc.
    for a in 0..3 {
        for b in (0..3).filter(|&b| b != a) {
            let c = 3 - a - b;
            let sides = [0.0, n].into_iter().flat_map(|la| [(la, 0.0), (la, n)]);
            for ((la, lb), pc) in sides.flat_map(|s| [1.5, 3.0, 3.5, 5.0, 6.25].map(|pc| (s, pc))) {
                for dc in [-2.0, -1.0, -0.5, 0.0, 0.5, 1.0, 2.0] {
                    for back in [0.0, 0.5, 2.0] {
                        let (mut p, mut d) = ([0.0; 3], [0.0; 3]);
                        (p[a], p[b], p[c]) = (la, lb, pc);
                        (d[b], d[c]) = (if lb == 0.0 { 1.0 } else { -1.0 }, dc);
                        let o: [f64; 3] = std::array::from_fn(|k| (p[k] - back * d[k]) * h);
                        let want = referee::first_hit(o, d, 0.0, f64::INFINITY, &tris);
                        for (lanes, got) in closest_both_ways(&scene, &one_ray(&o, &d)) {
                            let case = format!("o {o:?}, d {d:?}, lanes {lanes:?}: {got:?}");
                            match &want {
                                Some(v) => {
                                    assert_eq!(got.0, HIT, "{case}");
                                    assert_eq!(got.1, v.t, "{case}");
                                    assert!(v.ties.contains(&(got.2 as usize)), "{case}");
                                }
                                None => assert_eq!(got.0, MISS, "{case}"),
                            }
                        }
                        rays += 1;
                        hits += usize::from(want.is_some());
                    }
                }
            }
        }
    }
    // Both answers occur, so neither branch of the check above is idle.
    assert!(hits > rays / 2 && hits < rays, "{hits} of {rays}");
}
