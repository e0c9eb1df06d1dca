//! The octree against the exact referee, the exact walk and the BVH (the same gatherer: the
//! same answers bit for bit) on the stress rays, with and without 2:1 balance; its tables
//! against the published arrays; its build against brute force (every triangle that meets a
//! leaf listed, by exact rational clipping; every face-adjacent pair linked both ways).
//!
//! Mutations tried, each caught: reading the sign bit the other way (b = 1 ⇔ Π > 0) in
//! `exit_face` fails the answers, every-scale and along-planes tests on their first rays
//! (hits leaked); trusting the cube map's guess without the exact check (`start`) fails the
//! answers test on the depth-12 tree (another triangle than the BVH's).

use super::tables::{FACE_AXIS, FACE_POSITIVE};
use super::*;
use crate::geom::exact::sign2;
use crate::layout::LayoutKind;
use crate::query::gather::Nearest;
use crate::query::{AllHits, AnyHit, Listed};
use crate::referee;
use crate::scene::{CastOptions, HitBuffers, Rays};
use crate::status::{HIT, MISS};
use crate::testing::{exact_case_rays, grid_scene_inside, Rng};
use crate::traverse::Method;
use num_rational::BigRational;
use num_traits::{Signed, Zero};
use std::cmp::Ordering;

const PUBLISHED_OUT_FACES: [[u8; 8]; 8] = [
    [7, 2, 5, 2, 3, 3, 5, 7],
    [5, 7, 1, 1, 5, 2, 7, 2],
    [3, 3, 7, 5, 0, 7, 0, 5],
    [0, 5, 0, 7, 7, 5, 1, 1],
    [2, 4, 2, 7, 7, 4, 3, 3],
    [1, 1, 7, 4, 2, 7, 2, 4],
    [4, 7, 3, 3, 4, 0, 7, 0],
    [7, 0, 4, 0, 1, 1, 4, 7],
];

const PUBLISHED_FACE_TO_NEIGHBOR: [[u8; 8]; 6] = [
    [1, 3, 1, 3, 0, 2, 0, 2],
    [2, 2, 0, 0, 3, 3, 1, 1],
    [2, 0, 2, 0, 3, 1, 3, 1],
    [1, 1, 3, 3, 0, 0, 2, 2],
    [2, 0, 3, 1, 2, 0, 3, 1],
    [1, 3, 0, 2, 1, 3, 0, 2],
];

#[test]
fn tables_are_the_published_ones() {
    assert_eq!(out_faces_lookup(), PUBLISHED_OUT_FACES);
    assert_eq!(face_to_neighbor_index(), PUBLISHED_FACE_TO_NEIGHBOR);
}

/// The tables against geometry: random boxes and rays through them, the exit face from
/// float64 exit distances where they are well apart, the quadrant from the exit point.
#[test]
fn tables_agree_with_exit_distances() {
    let (out, quad) = (out_faces_lookup(), face_to_neighbor_index());
    let mut rng = Rng::xorshift(3);
    let mut checked = 0;
    for _ in 0..20_000 {
        let (lo, hi) = ([0.0; 3], [1.0; 3]);
        let p = rng.p3();
        let d = [0, 1, 2].map(|_| rng.f() - 0.5);
        let o = [0, 1, 2].map(|k| p[k] - d[k]);
        let t = [0, 1, 2].map(|k| ((if d[k] > 0.0 { hi[k] } else { lo[k] }) - p[k]) / d[k]);
        let c = [0, 1, 2].map(|k| if d[k] > 0.0 { hi[k] } else { lo[k] });
        let pi = |q: [f64; 3], k: usize| {
            let (k1, k2) = ((k + 1) % 3, (k + 2) % 3);
            (q[k1] - o[k1]) * d[k2] - (q[k2] - o[k2]) * d[k1]
        };
        let bits = (0..3)
            .map(|k| ((pi(c, k) < 0.0) as usize) << k)
            .sum::<usize>();
        let row = (0..3).map(|k| ((d[k] > 0.0) as usize) << k).sum::<usize>();
        let m = (0..3).min_by(|&a, &b| t[a].total_cmp(&t[b])).unwrap();
        let mut sorted = t;
        sorted.sort_by(f64::total_cmp);
        if sorted[1] - sorted[0] < 1e-9 {
            continue;
        }
        let f = out[row][bits] as usize;
        assert_eq!(f, face_of(m, d[m] > 0.0), "row {row} bits {bits}");
        // The exit point against the face's centre.
        let x = [0, 1, 2].map(|k| p[k] + t[m] * d[k]);
        let (u, w) = in_plane(m);
        let mut centre = c;
        centre[u] = 0.5;
        centre[w] = 0.5;
        if (x[u] - 0.5).abs() < 1e-9 || (x[w] - 0.5).abs() < 1e-9 {
            continue;
        }
        let qb = (0..3)
            .map(|k| ((pi(centre, k) < 0.0) as usize) << k)
            .sum::<usize>();
        let j = (x[u] < 0.5) as u8 + 2 * (x[w] < 0.5) as u8;
        assert_eq!(quad[f][qb], j, "face {f}");
        checked += 1;
    }
    assert!(checked > 15_000);
}

/// The exact 2×2 sign against rationals near zero, at many scales.
#[test]
fn sign2_is_exact() {
    let mut rng = Rng::xorshift(11);
    for k in 0..20_000 {
        let sc = [1.0, 1e-200, 1e200, 1e-310][k % 4];
        let x = |rng: &mut Rng| (rng.f() - 0.5) * sc;
        let (mut a, mut b, mut c, mut e) = (x(&mut rng), x(&mut rng), x(&mut rng), x(&mut rng));
        let mut m = rng.f() - 0.5;
        // n chosen so the products nearly cancel.
        let mut n = if k.is_multiple_of(3) {
            rng.f()
        } else {
            (a - b) * m / (c - e)
        };
        if k % 5 == 4 {
            // Grid numbers whose products cancel exactly (the exact-products stage).
            let q = |rng: &mut Rng| ((rng.f() - 0.5) * 64.0).round() / 8.0 * sc;
            (a, b, c, e) = (q(&mut rng), q(&mut rng), q(&mut rng), q(&mut rng));
            (m, n) = ((c - e) / sc, (a - b) / sc);
            if k % 10 == 9 {
                m += 0.125;
            }
        }
        if !n.is_finite() {
            continue;
        }
        let r = |v: f64| BigRational::from_float(v).unwrap();
        let want = ((r(a) - r(b)) * r(m) - (r(c) - r(e)) * r(n)).cmp(&BigRational::zero());
        let got = sign2(a, b, m, c, e, n).cmp(&0);
        assert_eq!(got, want, "{a} {b} {m} {c} {e} {n}");
    }
}

/// Exactly whether the closed triangle meets the closed box: the triangle clipped by the
/// box's six half-spaces in rationals (Sutherland–Hodgman), non-empty.
fn exact_meets(tri: &Tri, lo: [f64; 3], hi: [f64; 3]) -> bool {
    let r = |v: f64| BigRational::from_float(v).unwrap();
    let mut poly: Vec<[BigRational; 3]> = tri.iter().map(|p| p.map(r)).collect();
    for k in 0..3 {
        for (bound, upper) in [(r(lo[k]), false), (r(hi[k]), true)] {
            // Signed distance inside (≥ 0 keeps).
            let f = |p: &[BigRational; 3]| {
                if upper {
                    &bound - &p[k]
                } else {
                    &p[k] - &bound
                }
            };
            let mut out = Vec::new();
            for i in 0..poly.len() {
                let (p, q) = (&poly[i], &poly[(i + 1) % poly.len()]);
                let (fp, fq) = (f(p), f(q));
                if !fp.is_negative() {
                    out.push(p.clone());
                }
                if (fp.is_positive() && fq.is_negative()) || (fp.is_negative() && fq.is_positive())
                {
                    let s = &fp / (&fp - &fq);
                    out.push([0, 1, 2].map(|a| &p[a] + &s * (&q[a] - &p[a])));
                }
            }
            poly = out;
            if poly.is_empty() {
                return false;
            }
        }
    }
    true
}

/// Small scenes in [0, 1]³ whose corners lie on split planes (multiples of 1/16 and 1/64),
/// with edge-on, face-on and corner-on contacts with leaf boxes, and slivers.
fn dyadic_scene(rng: &mut Rng, n: usize) -> Vec<Tri> {
    let mut tris: Vec<Tri> = vec![
        [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        [[1.0, 1.0, 1.0], [0.0, 1.0, 1.0], [1.0, 0.0, 1.0]],
    ];
    let at = |rng: &mut Rng, q: f64| [0, 1, 2].map(|_| (rng.f() * q).round() / q);
    while tris.len() < n {
        let c = at(rng, 16.0);
        let s = [1.0 / 16.0, 1.0 / 64.0, 1.0 / 4.0][tris.len() % 3];
        let p = |rng: &mut Rng| {
            [0, 1, 2].map(|k| (c[k] + ((rng.f() * 4.0).round() - 2.0) * s).clamp(0.0, 1.0))
        };
        let (a, b) = (p(rng), p(rng));
        let c3 = if tris.len().is_multiple_of(7) {
            [0, 1, 2].map(|k| 0.5 * a[k] + 0.5 * b[k]) // zero area
        } else {
            p(rng)
        };
        tris.push([a, b, c3]);
    }
    tris
}

/// All leaves (by index) reached through face `f` of the leaf at record `addr`: links, and
/// below node links every leaf of the node touching the face's plane.
fn reached(oct: &PortalezOctree, addr: usize, f: usize) -> Vec<u32> {
    let mut out = Vec::new();
    let mut stack: Vec<u32> = oct.links(addr, f).to_vec();
    while let Some(l) = stack.pop() {
        if l & NODE_TAG == 0 {
            out.push(oct.records[l as usize + 2]);
            continue;
        }
        let n = oct.nodes[(l & !NODE_TAG) as usize];
        let a = FACE_AXIS[f];
        for c in 0..8u32 {
            if (c >> a & 1 == 1) == FACE_POSITIVE[f] {
                continue; // the far half
            }
            let ch = oct.nodes[(n.child + c) as usize];
            stack.push(if ch.child == 0 {
                oct.leaf_record[ch.leaf as usize]
            } else {
                NODE_TAG | (n.child + c)
            });
        }
    }
    out.sort();
    out
}

/// Every triangle meeting a leaf's closed box is listed in it (exact rational clipping);
/// every pair of face-adjacent leaves (sharing a face patch of positive area) is linked both
/// ways and no other pair; counts 0, 1 or 4; balanced trees have no node links and levels
/// one apart at most; the records, boxes and cube map agree with the hierarchy.
#[test]
fn octree_build_invariants() {
    let mut rng = Rng::xorshift(17);
    let mut node_links = 0;
    for round in 0..3 {
        let tris = dyadic_scene(&mut rng, 40 + 30 * round);
        for params in [
            OctreeParams {
                max_depth: 5,
                leaf_size: 2,
                balance: true,
            },
            OctreeParams {
                max_depth: 5,
                leaf_size: 2,
                balance: false,
            },
            OctreeParams {
                max_depth: 3,
                leaf_size: 1,
                balance: false,
            },
        ] {
            let oct = PortalezOctree::build(&tris, params).unwrap();
            assert_eq!((oct.lo, oct.hi), ([0.0; 3], [1.0; 3]));
            let cells = 1u32 << params.max_depth;
            let nl = oct.leaves();
            // Lattice boxes.
            let lat = |l: usize| {
                let b = oct.boxes[l];
                let s = cells >> b[3];
                ([b[0], b[1], b[2]], [b[0] + s, b[1] + s, b[2] + s], b[3])
            };
            // Leaves tile the root: their volumes sum to the root's.
            let vol: u64 = (0..nl)
                .map(|l| (cells as u64 >> oct.boxes[l][3]).pow(3))
                .sum();
            assert_eq!(vol, (cells as u64).pow(3));
            for l in 0..nl {
                let addr = oct.leaf_record[l] as usize;
                let [tc, to, li, nc] = oct.record(addr);
                assert_eq!(li as usize, l);
                let listed = &oct.ids[to as usize..(to + tc) as usize];
                for (j, &id) in listed.iter().enumerate() {
                    assert_eq!(oct.triangles[to as usize + j], tris[id as usize]);
                }
                let (lo, hi) = oct.leaf_box(l);
                for (id, tri) in tris.iter().enumerate() {
                    let aabb = (0..3).all(|k| {
                        tri.iter().any(|p| p[k] >= lo[k]) && tri.iter().any(|p| p[k] <= hi[k])
                    });
                    if aabb && exact_meets(tri, lo, hi) {
                        assert!(
                            listed.contains(&(id as u32)),
                            "{params:?}: leaf {l} {lo:?} {hi:?} misses triangle {id} {tri:?}"
                        );
                    }
                }
                let (a0, a1, level) = lat(l);
                for f in 0..6 {
                    let n = nc >> (4 * f) & 15;
                    assert!(matches!(n, 0 | 1 | 4), "count {n}");
                    let got = reached(&oct, addr, f);
                    let ax = FACE_AXIS[f];
                    let (u, w) = in_plane(ax);
                    let want: Vec<u32> = (0..nl as u32)
                        .filter(|&m| {
                            let (b0, b1, _) = lat(m as usize);
                            let touch = if FACE_POSITIVE[f] {
                                b0[ax] == a1[ax]
                            } else {
                                b1[ax] == a0[ax]
                            };
                            touch && [u, w].iter().all(|&k| b0[k] < a1[k] && a0[k] < b1[k])
                        })
                        .collect();
                    assert_eq!(got, want, "{params:?}: leaf {l} face {f}");
                    if n == 4 {
                        // Quadrant order: j = [X_u < c_u] + 2 [X_w < c_w].
                        for (j, &link) in oct.links(addr, f).iter().enumerate() {
                            let at = if link & NODE_TAG == 0 {
                                lat(oct.records[link as usize + 2] as usize).0
                            } else {
                                oct.nodes[(link & !NODE_TAG) as usize].at
                            };
                            let half = cells >> (level + 1);
                            assert_eq!(at[u] == a0[u] + half, j & 1 == 0);
                            assert_eq!(at[w] == a0[w] + half, j & 2 == 0);
                        }
                    }
                    for m in got {
                        let other = face_of(ax, !FACE_POSITIVE[f]);
                        let back = reached(&oct, oct.leaf_record[m as usize] as usize, other);
                        assert!(back.contains(&(l as u32)), "link {l} -> {m} one way");
                        if params.balance {
                            assert!(lat(m as usize).2.abs_diff(level) <= 1);
                        }
                    }
                }
            }
            let st = oct.stats();
            node_links += st.node_links;
            if params.balance {
                assert_eq!(st.node_links, 0);
            }
            assert!(st.leaves > 0 && (0.0..=24.0).contains(&st.neighbours_per_leaf));
            // The cube map: each texel's leaf touches its face and holds the texel's centre.
            let r = oct.cube_res;
            for f in 0..6 {
                let a = FACE_AXIS[f];
                let (u, w) = in_plane(a);
                for tw in 0..r {
                    for tu in 0..r {
                        let addr = oct.cube_map[(f * r + tw) * r + tu] as usize;
                        let (b0, b1, _) = lat(oct.records[addr + 2] as usize);
                        let per = cells as usize / r;
                        let cu = (tu * per) as u32;
                        let cw = (tw * per) as u32;
                        assert!(b0[u] <= cu && cu < b1[u] && b0[w] <= cw && cw < b1[w]);
                        assert!(if FACE_POSITIVE[f] {
                            b1[a] == cells
                        } else {
                            b0[a] == 0
                        });
                    }
                }
            }
        }
    }
    assert!(node_links > 0, "the unbalanced trees link nodes somewhere");
}

/// Balance adds leaves; the stats are in range; memory parts add up.
#[test]
fn octree_stats_and_memory() {
    let mut rng = Rng::xorshift(23);
    let tris = dyadic_scene(&mut rng, 300);
    let on = PortalezOctree::build(&tris, OctreeParams::default()).unwrap();
    let off = PortalezOctree::build(
        &tris,
        OctreeParams {
            balance: false,
            ..Default::default()
        },
    )
    .unwrap();
    let (a, b) = (on.stats(), off.stats());
    assert!(b.leaves > 0 && a.leaves >= b.leaves, "{a:?} {b:?}");
    for s in [a, b] {
        assert!((0.0..=24.0).contains(&s.neighbours_per_leaf), "{s:?}");
        assert!(s.triangles_per_leaf > 0.0 && s.triangles_per_full_leaf >= s.triangles_per_leaf);
        assert!(s.max_depth <= 8);
    }
    let m = on.memory();
    assert_eq!(m.cube_map, 6 * 256 * 256 * 4);
    assert_eq!(
        m.total,
        m.cube_map + m.octree + m.triangles + m.boxes + m.hierarchy
    );
    assert_eq!(m.octree, on.records.len() * 4);
}

fn flat(rays: &[([f64; 3], [f64; 3])]) -> (Vec<f64>, Vec<f64>) {
    (
        rays.iter().flat_map(|r| r.0).collect(),
        rays.iter().flat_map(|r| r.1).collect(),
    )
}

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
        let mut rng = Rng::xorshift(seed);
        let g = grid_scene_inside(&mut rng, 4, 0.0, 0.35);
        let mut rays = exact_case_rays(&mut rng, &g.pts, &g.faces, 2500);
        let eye = [-0.75, 0.3125, 0.4375];
        rays.extend((0..1024).map(|k| {
            let (x, y) = ((k % 32) as f64 / 32.0, (k / 32) as f64 / 32.0);
            (eye, [1.0, x - 0.5, y - 0.5])
        }));
        let n = rays.len();
        let (o, d) = flat(&rays);
        let o32: Vec<f32> = o.iter().map(|&x| x as f32).collect();
        let d32: Vec<f32> = d.iter().map(|&x| x as f32).collect();
        let bvh = g.scene.bvh().unwrap();
        let closest = g.scene.closest();
        let octs: Vec<PortalezOctree> = configs
            .iter()
            .map(|&p| PortalezOctree::build(&g.tris, p).unwrap())
            .collect();
        node_links += octs.iter().map(|o| o.stats().node_links).sum::<usize>();
        for window in [false, true] {
            let (tmin, tmax): (Vec<f64>, Vec<f64>) = if window {
                crate::testing::windows(&rays, 0.25)
            } else {
                (vec![0.0; n], vec![f64::INFINITY; n])
            };
            let r64 = Rays {
                origins: &o[..],
                directions: &d[..],
                tmin: &tmin,
                tmax: &tmax,
                leaving: None,
            };
            let r32 = Rays {
                origins: &o32[..],
                directions: &d32[..],
                tmin: &tmin,
                tmax: &tmax,
                leaving: None,
            };
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
            let mut w_any = vec![0u8; n];
            let default = (Method::DEFAULT, LayoutKind::DEFAULT);
            g.scene
                .occluded(default.0, default.1, &r64, &mut w_any, &walk_opts)
                .unwrap();
            let mut w_all = vec![Listed::default(); n];
            g.scene.intersections(&r64, &mut w_all, &walk_opts).unwrap();
            for (c, oct) in octs.iter().enumerate() {
                let mut st = OctreeState::default();
                for i in 0..n {
                    let ray = r64.ray(i);
                    let any = oct.trace(&AnyHit(closest), &ray, &mut st);
                    assert_eq!(any, w_any[i], "seed {seed} config {c} ray {i}: any hit");
                    let all = oct.trace(&AllHits(closest), &ray, &mut st);
                    let w = &w_all[i];
                    assert_eq!(all.status, w.status, "config {c} ray {i}: all-hits status");
                    assert_eq!(
                        all.meets.len(),
                        w.meets.len(),
                        "seed {seed} config {c} ray {i} (window {window}): o {:?} d {:?}",
                        ray.o,
                        ray.d
                    );
                    if c == 0 {
                        points += all.meets.len();
                    }
                    let crossing = |tri: u32| {
                        referee::crossing(ray.o, ray.d, &g.tris[tri as usize])
                            .expect("a met triangle")
                    };
                    let mut used = vec![false; w.meets.len()];
                    for m in &all.meets {
                        let cm = crossing(m.triangle);
                        let k = (0..w.meets.len()).find(|&k| {
                            !used[k]
                                && crossing(w.meets[k].triangle).cmp_t_of(&cm) == Ordering::Equal
                        });
                        let k = k.unwrap_or_else(|| {
                            panic!("seed {seed} config {c} ray {i}: point {m:?} not the walk's")
                        });
                        used[k] = true;
                        if w.meets[k].triangle == m.triangle {
                            assert_eq!(w.meets[k].t.to_bits(), m.t.to_bits());
                        }
                    }
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
                let mut near = Nearest::new(&line, &tris);
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
            let mut near = Nearest::new(&line, &tris);
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
        let mut near = Nearest::new(&line, &tris);
        let mut st = OctreeState::default();
        assert!(matches!(
            oct.walk(&line, &mut near, &mut st),
            Walked::Done(_)
        ));
        assert!(near.meet().is_none());
    }
    let _ = MISS;
}
