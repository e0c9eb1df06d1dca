//! The octree's build against brute force (every triangle meeting a leaf listed, by exact
//! clipping; every face-adjacent pair linked both ways), its statistics and memory.

use super::*;

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
