//! The octree's answers against the exact referee, the exact walk and the BVH: on the stress
//! rays, at every scale, along planes and through corners; bad parameters refused.

use super::*;

/// Closest, any and all hits on the octree: right by the referee for every ray, and the
/// exact walk's answers ray for ray (status; triangle and t where no tie decides; the same
/// points), and the BVH's bit for bit (the same gatherer), with balance on and off, shallow
/// and deep trees (depth 12: the cube map's texels are coarser than leaves, so its guesses
/// are often corrected), float64 and float32 rays, with and without a [tmin, tmax] window.
/// The step guard never fires.
#[test]
fn octree_answers_are_the_referees_and_the_walks() {
    let configs = [
        OctreeParams::default(),
        OctreeParams {
            balance: false,
            ..Default::default()
        },
        OctreeParams {
            max_depth: 6,
            leaf_size: 1,
            balance: true,
        },
        OctreeParams {
            max_depth: 6,
            leaf_size: 1,
            balance: false,
        },
        OctreeParams {
            max_depth: 12,
            leaf_size: 4,
            balance: true,
        },
    ];
    let walk_opts = CastOptions::default();
    let (mut ties, mut hits, mut points, mut fixes, mut node_links) = (0, 0, 0, 0, 0);
    for seed in [81u64, 82] {
        let case = Agreement::new(seed);
        let (g, n) = (&case.g, case.len());
        let bvh = g.scene.bvh().unwrap();
        let closest = g.scene.closest();
        let octs: Vec<PortalezOctree> = configs
            .iter()
            .map(|&p| PortalezOctree::build(&g.tris, p).unwrap())
            .collect();
        node_links += octs.iter().map(|o| o.stats().node_links).sum::<usize>();
        for window in [false, true] {
            let (tmin, tmax) = case.bounds(window);
            let r64 = case.r64(&tmin, &tmax);
            let r32 = case.r32(&tmin, &tmax);
            for f32_rays in [false, true] {
                let (ws, wt, wtri) = if f32_rays {
                    let mut h = HitBuffers::<f32>::new(n, false);
                    g.scene.cast(&r32, h.out(), &walk_opts).unwrap();
                    (h.status, vec![f64::NAN; n], h.triangle)
                } else {
                    let mut h = HitBuffers::<f64>::new(n, false);
                    g.scene.cast(&r64, h.out(), &walk_opts).unwrap();
                    (h.status, h.t, h.triangle)
                };
                for i in 0..n {
                    let ray = if f32_rays { r32.ray(i) } else { r64.ray(i) };
                    let v = referee::first_hit(ray.o, ray.d, ray.tmin.max(0.0), ray.tmax, &g.tris);
                    let b = bvh.trace(&closest, &ray, &mut Vec::new());
                    for (c, oct) in octs.iter().enumerate() {
                        let mut st = OctreeState::default();
                        let h = oct.trace(&closest, &ray, &mut st);
                        assert_eq!(st.guards, 0, "config {c} ray {i}: the guard fired");
                        fixes += st.entry_fixes;
                        let got = (h.status == HIT).then_some((h.triangle as usize, h.t));
                        let outcome =
                            referee::judge(v.as_ref(), false, got, referee::Precision::F64);
                        assert_eq!(
                            outcome,
                            referee::Outcome::Right,
                            "seed {seed} config {c} ray {i} (f32 {f32_rays}, window {window}): \
                             o {:?} d {:?} octree {} {} {}, referee {:?}",
                            ray.o,
                            ray.d,
                            h.status,
                            h.t,
                            h.triangle,
                            v.as_ref().map(|v| (v.t, &v.ties))
                        );
                        assert_eq!(h.status, ws[i], "seed {seed} config {c} ray {i}: status");
                        assert_eq!(
                            (
                                h.status,
                                h.triangle,
                                h.t.to_bits(),
                                h.u.to_bits(),
                                h.v.to_bits()
                            ),
                            (
                                b.status,
                                b.triangle,
                                b.t.to_bits(),
                                b.u.to_bits(),
                                b.v.to_bits()
                            ),
                            "seed {seed} config {c} ray {i}: octree against bvh"
                        );
                        if c == 0 {
                            hits += (h.status == HIT) as usize;
                        }
                        if v.as_ref().is_some_and(|v| v.ties.len() > 1) {
                            ties += (c == 0) as usize;
                        } else if h.status == HIT {
                            assert_eq!(h.triangle, wtri[i], "seed {seed} ray {i}: triangle");
                            if !f32_rays {
                                assert_eq!(h.t.to_bits(), wt[i].to_bits(), "ray {i}: t");
                            }
                        }
                    }
                }
            }
            // Any hits and all hits (float64 rays) against the walk.
            let (w_any, w_all) = case.walk_any_all(&r64);
            for (c, oct) in octs.iter().enumerate() {
                let mut st = OctreeState::default();
                for i in 0..n {
                    let ray = r64.ray(i);
                    let any = oct.trace(&AnyHit(closest), &ray, &mut st);
                    assert_eq!(any, w_any[i], "seed {seed} config {c} ray {i}: any hit");
                    let all = oct.trace(&AllHits(closest), &ray, &mut st);
                    let w = &w_all[i];
                    assert_eq!(all.status, w.status, "config {c} ray {i}: all-hits status");
                    if c == 0 {
                        points += all.meets.len();
                    }
                    let what = format!("seed {seed} config {c} ray {i} (window {window}): octree");
                    assert_same_points(&what, &ray, &g.tris, &all.meets, &w.meets);
                }
                assert_eq!(st.guards, 0);
            }
        }
    }
    eprintln!(
        "octree: {hits} closest hits, {ties} tied, {points} points, {fixes} entry fixes, \
         {node_links} node links"
    );
    assert!(
        hits > 5000 && ties > 1000 && points > 5000,
        "{hits} hits, {ties} ties, {points} points"
    );
    assert!(fixes > 0, "the cube map's guesses were never corrected");
}

/// Triangles from 1e-300 to 1e300 and rays with tiny and huge directions, from inside and
/// outside the root box: judged against the referee on every ray, balance on and off.
#[test]
fn octree_is_exact_at_every_scale() {
    let mut rng = Rng::xorshift(7);
    for scale in [1e-300, 1e-30, 1.0, 1e30, 1e300] {
        let at = |rng: &mut Rng| [0, 1, 2].map(|_| (rng.f() * 64.0).round() / 64.0 * scale);
        let tris: Vec<Tri> = (0..120)
            .map(|_| [at(&mut rng), at(&mut rng), at(&mut rng)])
            .collect();
        for balance in [true, false] {
            let params = OctreeParams {
                max_depth: 6,
                leaf_size: 2,
                balance,
            };
            let oct = PortalezOctree::build(&tris, params).unwrap();
            let mut st = OctreeState::default();
            let mut hits = 0;
            for i in 0..600 {
                let mut o = at(&mut rng);
                if i % 2 == 1 {
                    // Outside the root box (on a multiple of 1/64 too).
                    o[i % 3] = -0.5 * scale;
                }
                let t = &tris[i % tris.len()];
                let aim = match i % 3 {
                    0 => t[0],
                    1 => [0, 1, 2].map(|k| 0.5 * t[0][k] + 0.5 * t[1][k]),
                    _ => [0, 1, 2].map(|k| 0.25 * t[0][k] + 0.25 * t[1][k] + 0.5 * t[2][k]),
                };
                let dscale = [1.0, 1e-200, 1e200][i % 3] / scale;
                let d = [0, 1, 2].map(|k| (aim[k] - o[k]) * dscale);
                let ray = Ray {
                    o,
                    d,
                    tmin: 0.0,
                    tmax: f64::INFINITY,
                    leaving: None,
                };
                let Ok(line) = Line::new(&ray) else { continue };
                let mut near = Nearest::new(&line);
                assert!(matches!(
                    oct.walk(&line, &mut near, &mut st),
                    Walked::Done(_)
                ));
                let want = referee::first_hit(o, d, 0.0, f64::INFINITY, &tris);
                match (near.meet(), &want) {
                    (None, None) => {}
                    (Some(m), Some(v)) => {
                        hits += 1;
                        assert!(
                            v.ties.contains(&(m.triangle as usize)),
                            "scale {scale} ray {i}: triangle {} not tied {:?}",
                            m.triangle,
                            v.ties
                        );
                    }
                    (got, want) => panic!(
                        "scale {scale} balance {balance} ray {i}: octree {:?} referee {:?}",
                        got.map(|m| m.triangle),
                        want.as_ref().map(|v| &v.ties)
                    ),
                }
            }
            assert_eq!(st.guards, 0);
            assert!(hits > 300, "scale {scale}: {hits} hits");
        }
    }
}

/// Rays along the root's faces, edges and split planes, axis-parallel (two zero components)
/// and from corners: the ties the walk resolves towards where the ray goes. Judged by the
/// referee; the guard never fires.
#[test]
fn octree_walks_along_planes_and_through_corners() {
    let mut rng = Rng::xorshift(29);
    let tris = dyadic_scene(&mut rng, 200);
    let mut node_links = 0;
    for balance in [true, false] {
        let oct = PortalezOctree::build(
            &tris,
            OctreeParams {
                max_depth: 5,
                leaf_size: 1,
                balance,
            },
        )
        .unwrap();
        node_links += oct.stats().node_links;
        let mut st = OctreeState::default();
        let mut hits = 0;
        for i in 0..6000usize {
            let q = |rng: &mut Rng| (rng.f() * 40.0).round() / 32.0 - 0.125;
            let o = [q(&mut rng), q(&mut rng), q(&mut rng)];
            let mut d = [0, 1, 2].map(|_| (rng.f() * 4.0).round() - 2.0);
            if i.is_multiple_of(4) {
                d[i / 4 % 3] = 0.0;
            }
            if d == [0.0; 3] {
                continue;
            }
            let ray = Ray {
                o,
                d,
                tmin: 0.0,
                tmax: f64::INFINITY,
                leaving: None,
            };
            let line = Line::new(&ray).unwrap();
            let mut near = Nearest::new(&line);
            assert!(
                matches!(oct.walk(&line, &mut near, &mut st), Walked::Done(_)),
                "ray {i}: o {o:?} d {d:?}"
            );
            let want = referee::first_hit(o, d, 0.0, f64::INFINITY, &tris);
            match (near.meet(), &want) {
                (None, None) => {}
                (Some(m), Some(v)) => {
                    hits += 1;
                    assert!(v.ties.contains(&(m.triangle as usize)), "ray {i}");
                }
                (got, want) => panic!(
                    "balance {balance} ray {i}: o {o:?} d {d:?} octree {:?} referee {:?}",
                    got.map(|m| m.triangle),
                    want.as_ref().map(|v| &v.ties)
                ),
            }
        }
        assert_eq!(st.guards, 0);
        assert!(hits > 1000, "{hits} hits");
    }
    assert!(node_links > 0, "no descent from a node link exercised");
}

#[test]
fn octree_refuses_bad_parameters_and_triangles() {
    let tri = [[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    for params in [
        OctreeParams {
            max_depth: MAX_DEPTH + 1,
            ..Default::default()
        },
        OctreeParams {
            leaf_size: 0,
            ..Default::default()
        },
    ] {
        assert!(
            matches!(
                PortalezOctree::build(&[tri], params),
                Err(Error::InvalidOption(_))
            ),
            "{params:?}"
        );
    }
    let bad = [[0.0; 3], [f64::NAN, 0.0, 0.0], [0.0, 1.0, 0.0]];
    assert!(
        matches!(PortalezOctree::build(&[tri, bad], OctreeParams::default()), Err(Error::InvalidInput(m)) if m.contains("triangle 1"))
    );
    // The empty scene and a scene of one point: a root no ray finds anything in.
    for tris in [vec![], vec![[[2.0; 3]; 3]]] {
        let oct = PortalezOctree::build(&tris, OctreeParams::default()).unwrap();
        let line = Line::new(&Ray {
            o: [-1.0, 2.0, 2.0],
            d: [1.0, 0.0, 0.0],
            tmin: 0.0,
            tmax: f64::INFINITY,
            leaving: None,
        })
        .unwrap();
        let mut near = Nearest::new(&line);
        let mut st = OctreeState::default();
        assert!(matches!(
            oct.walk(&line, &mut near, &mut st),
            Walked::Done(_)
        ));
        assert!(near.meet().is_none());
    }
    let _ = MISS;
}
