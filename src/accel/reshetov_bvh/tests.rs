//! The BVH against the exact referee and the exact walk: on the stress rays (through vertices,
//! along edges, in planes, from the surface, tiny and huge directions), on triangles far
//! outside float32's range, and the tree's own invariants.

use super::*;
use crate::layout::LayoutKind;
use crate::query::gather::Nearest;
use crate::query::Listed;
use crate::referee;
use crate::scene::{AccelKind, CastOptions, HitBuffers};
use crate::status::{HIT, MISS};
use crate::testing::{assert_same_points, on, Agreement, Rng, ACCEL_KINDS};
use crate::traverse::Method;

/// Closest hits, any hits and all hits on the BVH: right by the referee for every ray, and
/// the exact walk's answers ray for ray (the same status; the same triangle and t where no
/// tie decides; the same points, matched by exact t), for float64 and float32 rays, with
/// and without a [tmin, tmax] window.
#[test]
fn bvh_answers_are_the_referees_and_the_walks() {
    for &accel in ACCEL_KINDS {
        if matches!(
            accel,
            AccelKind::ReshetovBvh
                | AccelKind::ReshetovBvhPackets
                | AccelKind::ReshetovBvhPackets8
                | AccelKind::ExactBvh
                | AccelKind::ExactBvhPackets
        ) {
            bvh_agrees(accel);
        }
    }
}

/// [`bvh_answers_are_the_referees_and_the_walks`] for one way of walking the tree; with
/// packets, also that the frustum culled tests (and not all of them: rays hit).
fn bvh_agrees(accel: AccelKind) {
    let bvh_opts = on(accel);
    let walk_opts = CastOptions::default();
    let (mut ties, mut hits, mut points) = (0, 0, 0);
    for seed in [81u64, 82] {
        let case = Agreement::new(seed);
        let (g, n) = (&case.g, case.len());
        for window in [false, true] {
            let (tmin, tmax) = case.bounds(window);
            let r64 = case.r64(&tmin, &tmax);
            let r32 = case.r32(&tmin, &tmax);
            // Closest hits, both precisions.
            for f32_rays in [false, true] {
                let cast = |opts: &CastOptions| {
                    if f32_rays {
                        let mut h = HitBuffers::<f32>::new(n, false);
                        g.scene.cast(&r32, h.out(), opts).unwrap();
                        let wide = |x: &[f32]| x.iter().map(|&x| x as f64).collect::<Vec<_>>();
                        let uvp = [wide(&h.u), wide(&h.v), wide(&h.point)];
                        (h.status, wide(&h.t), h.triangle, uvp)
                    } else {
                        let mut h = HitBuffers::<f64>::new(n, false);
                        g.scene.cast(&r64, h.out(), opts).unwrap();
                        (h.status, h.t, h.triangle, [h.u, h.v, h.point])
                    }
                };
                // The walk rounds each hit by the double-double path; the BVH's float32
                // answers mostly by `triangle_hit32`: the same bits in every column.
                let (bs, bt, btri, buvp) = cast(&bvh_opts);
                let (ws, wt, wtri, wuvp) = cast(&walk_opts);
                for i in 0..n {
                    let ray = if f32_rays { r32.ray(i) } else { r64.ray(i) };
                    let v = referee::first_hit(ray.o, ray.d, ray.tmin.max(0.0), ray.tmax, &g.tris);
                    let precision = if f32_rays {
                        referee::Precision::F32
                    } else {
                        referee::Precision::F64
                    };
                    let got = (bs[i] == HIT).then_some((btri[i] as usize, bt[i]));
                    let outcome = referee::judge(v.as_ref(), false, got, precision);
                    assert_eq!(
                        outcome,
                        referee::Outcome::Right,
                        "seed {seed} ray {i} (f32 {f32_rays}, window {window}): o {:?} d {:?} \
                         bvh {} {} {}, referee {:?}",
                        ray.o,
                        ray.d,
                        bs[i],
                        bt[i],
                        btri[i],
                        v.map(|v| (v.t, v.ties))
                    );
                    assert_eq!(
                        bs[i], ws[i],
                        "seed {seed} ray {i}: status, bvh against walk"
                    );
                    hits += (bs[i] == HIT) as usize;
                    if v.as_ref().is_some_and(|v| v.ties.len() > 1) {
                        ties += 1;
                    } else if bs[i] == HIT {
                        assert_eq!(btri[i], wtri[i], "seed {seed} ray {i}: triangle");
                        assert_eq!(bt[i].to_bits(), wt[i].to_bits(), "seed {seed} ray {i}: t");
                        for (c, (b, w)) in buvp.iter().zip(&wuvp).enumerate() {
                            let k = if c == 2 { 3 * i..3 * i + 3 } else { i..i + 1 };
                            let bits =
                                |x: &[f64]| x.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                            assert_eq!(
                                bits(&b[k.clone()]),
                                bits(&w[k]),
                                "seed {seed} ray {i}: u, v, point ({c})"
                            );
                        }
                    }
                }
            }
            // Any hits and all hits (float64 rays).
            let mut b_any = vec![0u8; n];
            let default = (Method::DEFAULT, LayoutKind::DEFAULT);
            g.scene
                .occluded(default.0, default.1, &r64, &mut b_any, &bvh_opts)
                .unwrap();
            let mut b_all = vec![Listed::default(); n];
            g.scene.intersections(&r64, &mut b_all, &bvh_opts).unwrap();
            let (w_any, w_all) = case.walk_any_all(&r64);
            assert_eq!(b_any, w_any, "seed {seed}: any hits, bvh against walk");
            for i in 0..n {
                let ray = r64.ray(i);
                let (b, w) = (&b_all[i], &w_all[i]);
                assert_eq!(b.status, w.status, "seed {seed} ray {i}: all-hits status");
                assert_eq!(b.status == HIT, b_any[i] == HIT, "ray {i}: all against any");
                points += b.meets.len();
                let what = format!("seed {seed} ray {i} (window {window}): bvh");
                assert_same_points(&what, &ray, &g.tris, &b.meets, &w.meets);
            }
        }
        if matches!(
            accel,
            AccelKind::ReshetovBvhPackets | AccelKind::ReshetovBvhPackets8
        ) {
            let [tests, culled, aperture, _, lone, frusta] =
                g.scene.built_bvh().unwrap().culling.read();
            eprintln!(
                "seed {seed}: {culled} of {tests} tests culled, {frusta} frusta, {lone} lone"
            );
            assert!(
                frusta > 0 && culled > 0 && culled < tests && aperture > 0,
                "{culled} of {tests} culled, {frusta} frusta"
            );
        }
    }
    eprintln!("bvh {accel:?}: {hits} closest hits, {ties} tied, {points} points listed");
    assert!(
        hits > 5000 && ties > 1000 && points > 5000,
        "{hits} hits, {ties} ties, {points} points"
    );
}

/// Triangles far outside float32's range and rays with tiny and huge directions: the float32
/// boxes are rounded outward (to infinity past float32's range) and the slab test is padded,
/// so no triangle the ray meets is skipped. Judged against the referee on every ray, for
/// Reshetov's tree and for the 8-wide one at every SIMD level.
#[test]
fn bvh_is_exact_far_from_float32() {
    use crate::accel::{ExactBvh, ExactBvhParams};
    use crate::simd::Simd;
    far_from_float32("reshetov_bvh", &|tris| {
        let bvh = ReshetovBvh::build(tris, BvhParams::default()).unwrap();
        Box::new(move |line, near| {
            bvh.walk(line, near, &mut Vec::new());
        })
    });
    for simd in Simd::supported_levels() {
        far_from_float32(simd.name(), &move |tris| {
            let bvh = ExactBvh::build(tris, ExactBvhParams::default()).unwrap();
            Box::new(move |line, near| {
                bvh.walk(line, near, simd, &mut Vec::new());
            })
        });
    }
}

/// A tree built over the triangles given, as a walk of one ray.
type Builds = dyn Fn(&[Tri]) -> Box<dyn Fn(&Line, &mut Nearest)>;

fn far_from_float32(what: &str, build: &Builds) {
    let mut rng = Rng::xorshift(7);
    for scale in [1e-300, 1e-30, 1.0, 1e30, 1e300] {
        let at = |rng: &mut Rng| [0, 1, 2].map(|_| (rng.f() * 64.0).round() / 64.0 * scale);
        let tris: Vec<Tri> = (0..120)
            .map(|_| [at(&mut rng), at(&mut rng), at(&mut rng)])
            .collect();
        let walk = build(&tris);
        let mut hits = 0;
        for i in 0..600 {
            let o = at(&mut rng);
            // Aimed at a corner, an edge midpoint or a point inside a triangle.
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
            walk(&line, &mut near);
            let want = referee::first_hit(o, d, 0.0, f64::INFINITY, &tris);
            match (near.meet(), &want) {
                (None, None) => {}
                (Some(m), Some(v)) => {
                    hits += 1;
                    assert!(
                        v.ties.contains(&(m.triangle as usize)),
                        "{what}: scale {scale} ray {i}: triangle {} not tied {:?}",
                        m.triangle,
                        v.ties
                    );
                }
                (got, want) => panic!(
                    "{what}: scale {scale} ray {i}: bvh {:?} referee {:?}",
                    got.map(|m| m.triangle),
                    want.as_ref().map(|v| &v.ties)
                ),
            }
        }
        assert!(hits > 300, "{what}: scale {scale}: {hits} hits");
    }
}

/// Every triangle sits in exactly one leaf, whose float32 box holds its corners; every inner
/// node's box holds its children's; leaves are no larger than max_leaf; for several
/// parameter sets, degenerate triangles included. `shape` and `memory` report what this walk
/// over the nodes counts and the buffers hold.
#[test]
fn bvh_tree_holds_every_triangle_once() {
    // Zero-area triangles, a point, and many copies of one triangle (centres all equal).
    let tris = crate::testing::triangle_soup(&mut Rng::xorshift(5));
    for params in [
        BvhParams::default(),
        BvhParams {
            cost_ratio: 0.0,
            max_leaf: 1,
            bins: 2,
            ..Default::default()
        },
        BvhParams {
            cost_ratio: 8.0,
            max_leaf: 64,
            bins: 32,
            ..Default::default()
        },
    ] {
        let bvh = ReshetovBvh::build(&tris, params).unwrap();
        let mut seen = vec![0u32; tris.len()];
        let inside = |p: [f64; 3], n: &BvhNode| {
            (0..3).all(|k| n.lo[k] as f64 <= p[k] && p[k] <= n.hi[k] as f64)
        };
        let mut stack = vec![(0usize, 1usize)];
        let (mut leaves, mut deepest) = (0, 0);
        while let Some((k, depth)) = stack.pop() {
            let node = bvh.nodes[k];
            deepest = deepest.max(depth);
            if node.count > 0 {
                leaves += 1;
                // 40 copies of one triangle share a centre: a leaf may exceed max_leaf only there.
                let range = node.first as usize..(node.first + node.count) as usize;
                for j in range {
                    let id = bvh.order[j] as usize;
                    seen[id] += 1;
                    assert_eq!(bvh.triangles[j], tris[id]);
                    assert!(
                        tris[id].iter().all(|&p| inside(p, &node)),
                        "leaf {k} holds triangle {id}"
                    );
                }
                assert!(
                    node.count <= params.max_leaf,
                    "{params:?}: leaf of {}",
                    node.count
                );
            } else {
                for c in [node.first as usize, node.first as usize + 1] {
                    let child = bvh.nodes[c];
                    assert!(
                        inside(child.lo.map(|x| x as f64), &node)
                            && inside(child.hi.map(|x| x as f64), &node)
                    );
                    stack.push((c, depth + 1));
                }
            }
        }
        assert!(
            seen.iter().all(|&s| s == 1),
            "{params:?}: every triangle once"
        );
        assert_eq!(bvh.shape(), (leaves, deepest), "{params:?}");
        assert!(
            leaves * params.max_leaf as usize >= tris.len() && deepest < 64,
            "{leaves} leaves, depth {deepest}"
        );
        assert_eq!(
            bvh.memory(),
            std::mem::size_of_val(&bvh.nodes[..])
                + std::mem::size_of_val(&bvh.order[..])
                + std::mem::size_of_val(&bvh.triangles[..]),
            "{params:?}"
        );
    }
    // The empty scene: a root that no ray enters.
    let empty = ReshetovBvh::build(&[], BvhParams::default()).unwrap();
    let line = Line::new(&Ray {
        o: [0.0; 3],
        d: [1.0, 0.0, 0.0],
        tmin: 0.0,
        tmax: 1.0,
        leaving: None,
    })
    .unwrap();
    let mut near = Nearest::new(&line);
    assert_eq!(empty.walk(&line, &mut near, &mut Vec::new()), 0);
    assert!(near.meet().is_none());
}

#[test]
fn bvh_refuses_bad_parameters_and_triangles() {
    let tri = [[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    for params in [
        BvhParams {
            cost_ratio: f64::NAN,
            ..Default::default()
        },
        BvhParams {
            cost_ratio: -1.0,
            ..Default::default()
        },
        BvhParams {
            max_leaf: 0,
            ..Default::default()
        },
        BvhParams {
            bins: 1,
            ..Default::default()
        },
    ] {
        assert!(
            matches!(
                ReshetovBvh::build(&[tri], params),
                Err(Error::InvalidOption(_))
            ),
            "{params:?}"
        );
    }
    let bad = [[0.0; 3], [f64::INFINITY, 0.0, 0.0], [0.0, 1.0, 0.0]];
    assert!(
        matches!(ReshetovBvh::build(&[tri, bad], BvhParams::default()), Err(Error::InvalidInput(m)) if m.contains("triangle 1"))
    );
    let _ = MISS;
}

/// The cost ratio decides where the tree stops, not where it splits (it adds the same cost
/// to every cut): a larger ratio prunes the smaller ratio's tree, so it has no more leaves;
/// ratio 0 splits wherever a cut makes smaller boxes (here, down to single triangles), and a
/// ratio above max_leaf stops at every node that fits in a leaf.
#[test]
fn bvh_cost_ratio_prunes_the_tree() {
    let mut rng = Rng::xorshift(5);
    let tris: Vec<Tri> = (0..5000)
        .map(|_| {
            let c = [0, 1, 2].map(|_| rng.f() * 10.0);
            [0, 1, 2].map(|_| [0, 1, 2].map(|k| c[k] + rng.f() * 0.3))
        })
        .collect();
    let leaves: Vec<usize> = [0.0, 0.5, 1.0, 2.0, 8.0, 100.0]
        .iter()
        .map(|&cost_ratio| {
            let params = BvhParams {
                cost_ratio,
                ..Default::default()
            };
            ReshetovBvh::build(&tris, params).unwrap().shape().0
        })
        .collect();
    assert!(leaves.windows(2).all(|w| w[0] >= w[1]), "{leaves:?}");
    assert_eq!(leaves[0], tris.len(), "{leaves:?}");
    assert!(
        leaves[5] < tris.len() / 4 && leaves[5] * 8 >= tris.len(),
        "{leaves:?}"
    );
    assert_eq!(
        leaves[4], leaves[5],
        "ratio 8 already stops at every fitting node"
    );
}

/// A tree large enough to be built in parallel is the tree built on one thread: the same
/// leaf order, and node for node (by structure, not by index) the same boxes and leaves; and
/// it holds every triangle once.
#[test]
fn parallel_build_is_the_sequential_build() {
    let mut rng = Rng::xorshift(12);
    let tris: Vec<Tri> = (0..6 * PARALLEL_MIN)
        .map(|_| {
            let c = [0, 1, 2].map(|_| rng.f() * 100.0);
            [0, 1, 2].map(|_| [0, 1, 2].map(|k| c[k] + rng.f()))
        })
        .collect();
    let params = BvhParams::default();
    let par = ReshetovBvh::build(&tris, params).unwrap();
    let builder = Builder {
        params,
        min_split: 1,
    };
    let mut prims = Prim::all(&tris);
    let seq = builder.build_range(&mut prims, 0);
    let order: Vec<u32> = prims.iter().map(Prim::id).collect();
    assert_eq!(par.order, order);
    assert_eq!(par.nodes.len(), seq.len());
    let mut stack = vec![(0usize, 0usize)];
    let mut leaves = 0;
    while let Some((a, b)) = stack.pop() {
        let (x, y) = (par.nodes[a], seq[b]);
        assert_eq!(
            (x.lo, x.hi, x.count),
            (y.lo, y.hi, y.count),
            "nodes {a} and {b}"
        );
        if x.count > 0 {
            assert_eq!(x.first, y.first);
            leaves += x.count as usize;
        } else {
            let (i, j) = (x.first as usize, y.first as usize);
            stack.extend([(i, j), (i + 1, j + 1)]);
        }
    }
    assert_eq!(leaves, tris.len());
}
