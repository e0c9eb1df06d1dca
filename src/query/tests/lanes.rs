//! Lanes and packets answer as the one-ray walk, field for field and bit for bit.

use super::*;

/// Closest hits of `rays` cast with options `a` and `b`: every field, bit for bit.
fn same_closest<R: crate::geom::real::Real>(
    scene: &Scene,
    method: Method,
    rays: &Rays<R>,
    what: &str,
    [a, b]: [CastOptions; 2],
) {
    let closest = |opts: CastOptions| {
        let mut b = HitBuffers::<R>::new(rays.len(), false);
        scene
            .cast_with(method, LayoutKind::DEFAULT, rays, b.out(), &opts)
            .unwrap();
        b
    };
    let (on, off) = (closest(a), closest(b));
    let what = format!("{method:?} {} {what}", R::NAME);
    assert_eq!(on.status, off.status, "{what}");
    assert_eq!(on.triangle, off.triangle, "{what}");
    assert_eq!(on.tet, off.tet, "{what}");
    assert_eq!(on.steps, off.steps, "{what}");
    for (a, b) in [
        (&on.t, &off.t),
        (&on.u, &off.u),
        (&on.v, &off.v),
        (&on.point, &off.point),
    ] {
        let bits = |x: &R| x.to_f64().to_bits();
        assert!(a.iter().map(bits).eq(b.iter().map(bits)), "{what}");
    }
}

/// Any hits and all hits of `rays` (float64) cast with options `a` and `b`, bit for bit.
fn same_lists(
    scene: &Scene,
    method: Method,
    rays: &Rays<f64>,
    what: &str,
    [a, b]: [CastOptions; 2],
) {
    let n = rays.len();
    let occluded = |opts: CastOptions| {
        let mut out = vec![0u8; n];
        scene
            .occluded(method, LayoutKind::DEFAULT, rays, &mut out, &opts)
            .unwrap();
        out
    };
    assert_eq!(occluded(a), occluded(b), "{method:?} any hit {what}");
    if method != Method::Exact {
        return;
    }
    let listed = |opts: CastOptions| {
        let mut out = vec![crate::query::Listed::default(); n];
        scene.intersections(rays, &mut out, &opts).unwrap();
        out
    };
    let bits = |x: f64| x.to_bits();
    for (i, (x, y)) in listed(a).iter().zip(&listed(b)).enumerate() {
        assert_eq!(x.status, y.status, "ray {i}: {what}");
        let key = |l: &crate::query::Listed| {
            l.meets
                .iter()
                .map(|m| (bits(m.t), bits(m.u), bits(m.v), m.triangle, m.key))
                .collect::<Vec<_>>()
        };
        assert_eq!(key(x), key(y), "ray {i}: all hits {what}");
    }
}

/// Every method's closest hits (float64 rays and the same rays rounded to float32), any hits
/// and all hits of the rays `o`, `d` cast with options `a` and `b`: bit for bit.
fn same_answers(
    scene: &Scene,
    [o, d]: [&[f64]; 2],
    [tmin, tmax]: [&[f64]; 2],
    what: &str,
    ab: [CastOptions; 2],
) {
    let o32: Vec<f32> = o.iter().map(|&x| x as f32).collect();
    let d32: Vec<f32> = d.iter().map(|&x| x as f32).collect();
    let r64 = Rays {
        origins: o,
        directions: d,
        tmin,
        tmax,
        leaving: None,
    };
    let r32 = Rays {
        origins: &o32[..],
        directions: &d32[..],
        tmin,
        tmax,
        leaving: None,
    };
    for &method in Method::ALL {
        same_closest(scene, method, &r64, what, ab);
        same_closest(scene, method, &r32, what, ab);
        same_lists(scene, method, &r64, what, ab);
    }
}

/// Walking in interleaved lanes changes no answer: every query, both precisions, every method
/// on the default layout, a tmin/tmax window, on the exact stress rays (vertices, edges, planes,
/// origins on the surface, tiny and huge directions), random rays and a camera (shared origin),
/// bit for bit against the one-ray walk.
#[test]
fn lanes_answer_as_the_one_ray_walk() {
    use crate::scene::Lanes;
    let mut rng = Rng::xorshift(73);
    let g = crate::testing::grid_scene_inside(&mut rng, 4, 0.0, 0.35);
    let mut rays = exact_case_rays(&mut rng, &g.pts, &g.faces, 1500);
    let (ro, rd) = random_rays(&mut rng, 1000);
    rays.extend((0..1000).map(|i| {
        (
            [ro[3 * i], ro[3 * i + 1], ro[3 * i + 2]],
            [rd[3 * i], rd[3 * i + 1], rd[3 * i + 2]],
        )
    }));
    let eye = [-0.75, 0.3125, 0.4375];
    rays.extend((0..1024).map(|k| {
        let (x, y) = ((k % 32) as f64 / 32.0, (k / 32) as f64 / 32.0);
        (eye, [1.0, x - 0.5, y - 0.5])
    }));
    let o: Vec<f64> = rays.iter().flat_map(|r| r.0).collect();
    let d: Vec<f64> = rays.iter().flat_map(|r| r.1).collect();
    // Also under step guards short enough to stop most walks, the shortest before the lanes'
    // first plain step (a walk begins with one step): a lane must stop where the one-ray walk
    // stops, FAILED, never step past the guard to a hit.
    for max_steps in [None, Some(1), Some(2), Some(5)] {
        let lanes = |lanes| CastOptions {
            lanes,
            max_steps,
            ..Default::default()
        };
        let (on, off) = (lanes(Lanes::On), lanes(Lanes::Off));
        for window in [false, true] {
            let (tmin, tmax): (Vec<f64>, Vec<f64>) = if window {
                crate::testing::windows(&rays, 0.125)
            } else {
                (vec![0.0], vec![f64::INFINITY])
            };
            let what = format!("lanes, window {window}, max_steps {max_steps:?}");
            same_answers(&g.scene, [&o, &d], [&tmin, &tmax], &what, [on, off]);
        }
    }
}

/// Rays that share an origin walked as packets (`traverse::packet`) get the one-ray walk's
/// answers, bit for bit: every query, both precisions, every method, from eyes outside the
/// box, inside a tet and on a scene vertex, aimed at every vertex, along edges and through
/// faces' points (the lines meet vertices and edges exactly: grid coordinates) and over a
/// pixel fan; at every SIMD level this CPU runs (`simd`); and packets did take steps, runs
/// did start together (but from the vertex) and the AVX2 kernel did decide exits, so the
/// comparison is not vacuous.
#[test]
fn packets_answer_as_the_one_ray_walk() {
    use crate::scene::{Lanes, Packets};
    use crate::simd::Simd;
    let mut rng = Rng::xorshift(91);
    let g = crate::testing::grid_scene_inside(&mut rng, 4, 0.0, 0.35);
    let eyes = [
        [-0.75, 0.3125, 0.4375],
        [1.5, 1.25, -0.5],
        [0.3125, 0.4375, 0.5625],
        [0.5, 0.5, 0.5],
        [0.3, 0.41, 0.53],
    ];
    // Whether an eye lies in the plane of a scene triangle (there rays may touch the surface
    // at their origin, and start alone).
    let on_a_plane = |eye: [f64; 3]| {
        g.faces.iter().any(|f| {
            let [a, b, c] = f.map(|v| g.pts[v as usize]);
            crate::geom::exact::orient_sign(a, b, c, eye) == 0
        })
    };
    assert!(!on_a_plane(eyes[4]), "the last eye is off every plane");
    let opts = |packets, simd| CastOptions {
        lanes: Lanes::Off,
        packets,
        threads: Some(1),
        simd: Some(simd),
        ..Default::default()
    };
    let levels = Simd::supported_levels();
    let avx2_before = crate::traverse::packet::avx2_rays();
    for eye in eyes {
        let mut targets: Vec<[f64; 3]> = g.pts.clone();
        for f in &g.faces {
            let p = f.map(|v| g.pts[v as usize]);
            for k in 0..3 {
                let (a, b) = (p[k], p[(k + 1) % 3]);
                targets.push([0, 1, 2].map(|i| (a[i] + b[i]) * 0.5));
            }
            targets.push([0, 1, 2].map(|i| (p[0][i] + p[1][i] + 2.0 * p[2][i]) * 0.25));
        }
        for k in 0..64 * 64 {
            let (x, y) = ((k % 64) as f64 / 64.0, (k / 64) as f64 / 64.0);
            targets.push([
                0.5 + (x - 0.5) * 1.25,
                0.5 + (y - 0.5) * 1.25,
                0.5 + (x - y) * 0.5,
            ]);
        }
        // A narrow fan, whose runs of rays fit within one boundary face.
        for k in 0..32 * 32 {
            let (x, y) = ((k % 32) as f64 / 32.0, (k / 32) as f64 / 32.0);
            targets.push([0.5 + x * 0.0625, 0.4375 + y * 0.0625, 0.46875 + x * 0.03125]);
        }
        targets.retain(|t| t != &eye);
        let n = targets.len();
        let o: Vec<f64> = (0..n).flat_map(|_| eye).collect();
        // Every 101st direction zero: invalid rays inside runs that start together.
        let d: Vec<f64> = targets
            .iter()
            .enumerate()
            .flat_map(|(i, t)| [0, 1, 2].map(|k| if i % 101 == 7 { 0.0 } else { t[k] - eye[k] }))
            .collect();
        let before = crate::accel::tetwalk::packet_steps();
        let together = crate::accel::tetwalk::entered_together();
        let [lo, hi] = g.scene.mesh.bounds;
        let outside = (0..3).any(|k| eye[k] < lo[k] || eye[k] > hi[k]);
        let may_touch_at_origin = !outside && on_a_plane(eye);
        // The window matters where runs start together (`Locators::exact_line` decides it
        // for those rays).
        for window in [false, true]
            .into_iter()
            .filter(|&w| !may_touch_at_origin || !w)
        {
            // A window: some rays end before the box or before their first tets, others
            // start past the surface.
            let (tmin, tmax): (Vec<f64>, Vec<f64>) = if window {
                (0..n)
                    .map(|i| ((i % 3) as f64 * 0.25, 0.25 + (i % 5) as f64 * 0.25))
                    .unzip()
            } else {
                (vec![0.0], vec![f64::INFINITY])
            };
            // Packets at every SIMD level against the one-ray walk.
            for &level in &levels {
                let what = format!("packets from {eye:?}, window {window}, {level:?}");
                let both = [opts(Packets::Auto, level), opts(Packets::Off, Simd::Scalar)];
                same_answers(&g.scene, [&o, &d], [&tmin, &tmax], &what, both);
            }
        }
        // From a vertex every ray touches it at the start and walks alone.
        let taken = crate::accel::tetwalk::packet_steps() - before;
        assert!(
            g.pts.contains(&eye) || taken > 100,
            "from {eye:?}: only {taken} packet steps"
        );
        // Runs of rays start together: from outside the box by one entry face, from inside
        // by one exit face of the start tet (where no ray can touch the surface at its origin).
        let together = crate::accel::tetwalk::entered_together() - together;
        assert!(
            may_touch_at_origin || together > 1000,
            "from {eye:?}: only {together} rays started together"
        );
    }
    if levels.contains(&Simd::Avx2) {
        let avx2 = crate::traverse::packet::avx2_rays() - avx2_before;
        assert!(
            avx2 > 10_000,
            "the AVX2 exit kernel decided only {avx2} rays' exits"
        );
    }
}

/// A chunk taken for packets (its first two rays share an origin) that holds rays with NaN
/// origins ends, and marks them INVALID; the valid rays get the one-ray walk's answers.
#[test]
fn packets_end_on_invalid_origins() {
    use crate::scene::Packets;
    use crate::status::INVALID;
    let mut rng = Rng::xorshift(5);
    let g = crate::testing::grid_scene_inside(&mut rng, 3, 0.0, 0.5);
    let eye = [-0.5, 0.3, 0.4];
    let mut o: Vec<f64> = Vec::new();
    let mut d: Vec<f64> = Vec::new();
    for k in 0..200 {
        let bad = k % 7 == 3;
        o.extend(if bad { [f64::NAN, 0.0, 0.0] } else { eye });
        d.extend([
            1.0,
            (k % 10) as f64 / 10.0 - 0.5,
            (k / 10) as f64 / 20.0 - 0.5,
        ]);
    }
    let (tmin, tmax) = (vec![0.0], vec![f64::INFINITY]);
    let rays = Rays {
        origins: &o[..],
        directions: &d[..],
        tmin: &tmin,
        tmax: &tmax,
        leaving: None,
    };
    let cast = |packets| {
        let mut b = HitBuffers::<f64>::new(200, false);
        let opts = CastOptions {
            packets,
            ..Default::default()
        };
        g.scene
            .cast_with(Method::Exact, LayoutKind::DEFAULT, &rays, b.out(), &opts)
            .unwrap();
        b
    };
    let (on, off) = (cast(Packets::Auto), cast(Packets::Off));
    for k in 0..200 {
        assert_eq!(on.status[k] == INVALID, k % 7 == 3, "ray {k}");
    }
    assert_eq!(on.status, off.status);
    assert_eq!(on.triangle, off.triangle);
}
