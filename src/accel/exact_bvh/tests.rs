//! The 8-wide tree's own invariants, and its box test against rays that touch a box exactly.
//! Its answers are judged with the other accelerators': against the referee, the exact walk
//! and Reshetov's BVH (`reshetov_bvh/tests.rs`, `query/tests`, the fuzz targets).

use super::packets::packet_box_tests;
use super::*;
#[cfg(target_arch = "x86_64")]
use crate::geom::exact::triangle_sides;
use crate::layout::LayoutKind;
use crate::query::gather::Nearest;
use crate::query::Listed;
use crate::scene::{AccelKind, CastOptions, HitBuffers, Packets, Rays};
use crate::testing::{triangle_soup, Agreement, Rng};
use crate::traverse::Method;

/// Every triangle sits in exactly one leaf, of at most max_leaf triangles, and the box of the
/// slot naming the leaf holds its corners; every inner node's slot box holds its children's
/// boxes; unused slots have the empty box; for several parameter sets, and for no triangles.
/// `shape` and `memory` report what this walk over the nodes counts and the buffers hold.
#[test]
fn wide_tree_holds_every_triangle_once() {
    let tris = triangle_soup(&mut Rng::xorshift(5));
    for params in [
        ExactBvhParams::default(),
        ExactBvhParams {
            cost_ratio: 0.0,
            max_leaf: 1,
            bins: 2,
            leaf_size: 1,
        },
        ExactBvhParams {
            cost_ratio: 8.0,
            max_leaf: 16,
            bins: 32,
            leaf_size: 16,
        },
    ] {
        let bvh = ExactBvh::build(&tris, params).unwrap();
        let mut seen = vec![0u32; tris.len()];
        let inside = |p: [f64; 3], node: &Node8, s: usize| {
            (0..3).all(|k| node.bounds[k][s] as f64 <= p[k] && p[k] <= node.bounds[3 + k][s] as f64)
        };
        let (mut inner, mut stack) = (0, vec![(0usize, 1usize)]);
        let (mut leaves, mut children, mut deepest) = (0, 0, 0);
        while let Some((k, depth)) = stack.pop() {
            inner += 1;
            let node = &bvh.nodes[k];
            for s in 0..WIDTH {
                children += usize::from(node.child[s] != EMPTY);
                match Child::of(node.child[s]) {
                    Child::Empty => {
                        assert_eq!(node.bounds[0][s], f32::MAX, "node {k} slot {s}");
                        assert_eq!(node.bounds[3][s], -f32::MAX, "node {k} slot {s}");
                    }
                    Child::Leaf { first, count } => {
                        leaves += 1;
                        deepest = deepest.max(depth);
                        let most = params.max_leaf.max(params.leaf_size);
                        assert!(count <= most, "{params:?}: leaf of {count}");
                        for j in first as usize..(first + count) as usize {
                            let id = bvh.order[j] as usize;
                            seen[id] += 1;
                            assert_eq!(bvh.triangles[j], tris[id]);
                            assert!(
                                tris[id].iter().all(|&p| inside(p, node, s)),
                                "node {k} slot {s} holds triangle {id}"
                            );
                        }
                    }
                    Child::Node(c) => {
                        let child = &bvh.nodes[c as usize];
                        for cs in 0..WIDTH {
                            if child.child[cs] == EMPTY {
                                continue;
                            }
                            let lo = [0, 1, 2].map(|a| child.bounds[a][cs] as f64);
                            let hi = [0, 1, 2].map(|a| child.bounds[3 + a][cs] as f64);
                            assert!(inside(lo, node, s) && inside(hi, node, s));
                        }
                        stack.push((c as usize, depth + 1));
                    }
                }
            }
        }
        assert_eq!(inner, bvh.nodes.len(), "every node reached once");
        let mean = children as f64 / inner as f64;
        assert_eq!(bvh.shape(), (leaves, mean, deepest), "{params:?}");
        assert!(
            leaves
                >= tris
                    .len()
                    .div_ceil(params.max_leaf.max(params.leaf_size) as usize)
        );
        assert_eq!(
            bvh.memory(),
            std::mem::size_of_val(&bvh.nodes[..])
                + std::mem::size_of_val(&bvh.order[..])
                + std::mem::size_of_val(&bvh.triangles[..]),
            "{params:?}"
        );
        assert!(
            seen.iter().all(|&n| n == 1),
            "{params:?}: a triangle not in one leaf"
        );
        // Every node but the root has two children or more (a binary node opened).
        for (k, node) in bvh.nodes.iter().enumerate().skip(1) {
            let used = node.child.iter().filter(|&&c| c != EMPTY).count();
            assert!(used >= 2, "{params:?}: node {k} has {used} children");
        }
    }
    let empty = ExactBvh::build(&[], ExactBvhParams::default()).unwrap();
    assert_eq!(empty.nodes.len(), 1);
    assert!(empty.nodes[0].child.iter().all(|&c| c == EMPTY));
    assert_eq!(empty.shape(), (0, 0.0, 0));
    assert_eq!(empty.memory(), std::mem::size_of::<Node8>());
    let too_big = ExactBvhParams {
        max_leaf: MAX_LEAF + 1,
        ..Default::default()
    };
    assert!(ExactBvh::build(&tris, too_big).is_err());
}

/// a − b where float64 holds it exactly (TwoSum's error is zero), per axis.
fn exact_sub(a: [f64; 3], b: [f64; 3]) -> Option<[f64; 3]> {
    let mut out = [0.0; 3];
    for k in 0..3 {
        let (x, y) = (a[k], -b[k]);
        let s = x + y;
        let bb = s - x;
        let err = (x - (s - bb)) + (y - bb);
        if err != 0.0 || !s.is_finite() || (b[k] != 0.0 && (b[k] / 2.0) * 2.0 != b[k]) {
            return None;
        }
        out[k] = s;
    }
    Some(out)
}

/// The box tests a ray may take: the float32 one (portable and AVX2) where it applies, and
/// the float64 one always.
fn box_tests(line: &Line, infinite: bool) -> Vec<(&'static str, Box<dyn BoxTest>)> {
    let mut out: Vec<(&'static str, Box<dyn BoxTest>)> =
        vec![("float64", Box::new(Wide64(Slab::new(line))))];
    if let Some(r) = RayBoxes::new(line, infinite) {
        out.push(("float32", Box::new(r)));
        #[cfg(target_arch = "x86_64")]
        if Simd::Avx2.supported() {
            // SAFETY: the CPU has AVX2 and FMA (`Simd::supported`).
            let test = move |n: &Node8, a: f64, b: f64| unsafe { avx2_test(&r, n, a, b) };
            out.push(("avx2", Box::new(test)));
        }
    }
    out
}

/// A ray that meets a box exactly at one point of its boundary (a corner, an edge or a face:
/// o + t·d = p exactly, with t a power of two), with tmin or tmax at that t or not, from
/// origins that float32 cannot hold and directions with zero components: every box test
/// keeps the box. Its entry bound is at most t. So does the packet test of that ray with
/// others from its origin. A box the ray passes an ulp beside is dropped by the float32 test
/// (and the packet test of that ray alone) often enough to show the test culls at all.
#[test]
fn box_tests_keep_every_box_a_ray_touches() {
    let mut rng = Rng::xorshift(11);
    let (mut kept, mut tested, mut culled_beside) = (0, 0, 0);
    let (mut packets, mut packets_culled_beside) = (0, 0);
    for i in 0..20_000 {
        let scale = [1.0, 1e-3, 1e4, 1e-30, 1e30][i % 5];
        let f32at = |rng: &mut Rng| ((rng.f() - 0.5) * scale) as f32;
        let mut node = Node8::EMPTY;
        let mut boxes = [[[0f32; 3]; 2]; WIDTH];
        for (s, b) in boxes.iter_mut().enumerate() {
            let [lo, hi] = b;
            for (l, h) in lo.iter_mut().zip(hi.iter_mut()) {
                let (a, c) = (f32at(&mut rng), f32at(&mut rng));
                // Some flat boxes (a triangle in an axis plane).
                let c = if rng.below(6) == 0 { a } else { c };
                (*l, *h) = (a.min(c), a.max(c));
            }
            let bn = BvhNode {
                lo: b[0],
                first: 0,
                hi: b[1],
                count: 0,
            };
            node.set(s, &bn, LEAF | (s as u32) << COUNT_BITS);
        }
        let s = rng.below(WIDTH);
        // A boundary point of box s: per axis lo, hi or (for at most two axes) inside.
        let kinds = [0, 1, 2].map(|_| rng.below(3));
        let inside_axes = kinds.iter().filter(|&&x| x == 2).count();
        let p: [f64; 3] = [0, 1, 2].map(|k| {
            let (lo, hi) = (boxes[s][0][k] as f64, boxes[s][1][k] as f64);
            match (kinds[k], inside_axes) {
                (0, _) | (2, 3) => lo,
                (1, _) => hi,
                _ => lo + (hi - lo) * 0.5,
            }
        });
        // t = 2^e, and either d with few bits (o = p − t·d exact in float64, often a float32)
        // or an origin of 53 bits within a factor of two of p per axis (p − o exact by
        // Sterbenz's lemma, d = (p − o)/t exact), which float32 cannot hold, or the origin 0
        // (d = p/t). Some components of d zero.
        let e = rng.below(40) as i32 - 20;
        let t = 2f64.powi(e);
        let mode = rng.below(3);
        let (o, d) = if mode == 2 {
            // From the origin itself (o = 0: no slack from the origin's rounding).
            ([0.0; 3], p.map(|x| x / t))
        } else if mode == 0 {
            let d: [f64; 3] = [0, 1, 2].map(|_| {
                if rng.below(5) == 0 {
                    0.0
                } else {
                    ((rng.f() - 0.5) * 64.0).round() / 16.0 * scale
                }
            });
            let Some(o) = exact_sub(p, d.map(|x| t * x)) else {
                continue; // not exact at this scale
            };
            (o, d)
        } else {
            let o: [f64; 3] = [0, 1, 2].map(|k| {
                if rng.below(5) == 0 {
                    p[k]
                } else {
                    p[k] * (0.5 + 1.5 * rng.f())
                }
            });
            let Some(diff) = exact_sub(p, o) else {
                continue;
            };
            (o, diff.map(|x| x / t))
        };
        if d == [0.0; 3] || (0..3).any(|k| o[k] + t * d[k] != p[k]) {
            continue;
        }
        let (tmin, tmax) = match rng.below(4) {
            0 => (0.0, f64::INFINITY),
            1 => (t, t),
            2 => (0.0, t),
            _ => (t, f64::INFINITY),
        };
        let line = Line::new(&Ray {
            o,
            d,
            tmin,
            tmax,
            leaving: None,
        })
        .unwrap();
        for (name, test) in box_tests(&line, false) {
            tested += 1;
            let (mask, nears) = test.test(&node, line.tmin, line.tmax);
            assert!(
                mask & (1 << s) != 0,
                "{name}: ray {i} o {o:?} d {d:?} [{tmin}, {tmax}] touches box {:?} at t = {t}",
                boxes[s]
            );
            assert!(
                nears[s] as f64 <= t,
                "{name}: ray {i}: entry bound {} > {t}",
                nears[s]
            );
            kept += 1;
        }
        // A packet of that ray and up to three more from its origin, whose directions scale
        // its components (signs kept; the packet test takes no zero component): the packet's
        // test keeps the box too, its entry bound at most t.
        if !d.contains(&0.0) {
            let mut lines = vec![line];
            for _ in 0..rng.below(4) {
                let d2 = d.map(|x| x * (0.5 + rng.f()));
                let ray = Ray {
                    o,
                    d: d2,
                    tmin,
                    tmax,
                    leaving: None,
                };
                lines.push(Line::new(&ray).unwrap());
            }
            let last = lines.len() - 1;
            lines.swap(0, rng.below(last + 1));
            for (mask, nears) in packet_box_tests(&lines, &node).into_iter().flatten() {
                packets += 1;
                assert!(
                    mask & (1 << s) != 0 && nears[s] as f64 <= t,
                    "packet of ray {i} o {o:?} d {d:?} [{tmin}, {tmax}] touching box {:?} at \
                     t = {t}: mask {mask:b}, entry bound {}",
                    boxes[s],
                    nears[s]
                );
            }
        }
        // The same ray moved off the box by far more than the padding on an axis where p is
        // on a bound and d is not zero: it misses; the float32 test sees that mostly.
        if let Some(k) = (0..3).find(|&k| kinds[k] < 2 && d[k] != 0.0) {
            let mut o2 = o;
            let away = if kinds[k] == 0 { -1.0 } else { 1.0 };
            o2[k] += away * (1e-3 * scale).max(p[k].abs() * 1e-3);
            let line2 = Line::new(&Ray {
                o: o2,
                d,
                tmin: t,
                tmax: t,
                leaving: None,
            })
            .unwrap();
            if let Some(r) = RayBoxes::new(&line2, false) {
                culled_beside += (r.test(&node, t, t).0 & (1 << s) == 0) as usize;
            }
            for (mask, _) in packet_box_tests(&[line2], &node).into_iter().flatten() {
                packets_culled_beside += (mask & (1 << s) == 0) as usize;
            }
        }
    }
    eprintln!(
        "{kept} of {tested} kept, {culled_beside} culled beside; {packets} packet tests, \
         {packets_culled_beside} culled beside"
    );
    assert!(tested > 30_000, "{tested} tests");
    assert!(
        culled_beside > 5_000,
        "{culled_beside}: the float32 test culls too little"
    );
    assert!(packets > 5_000, "{packets} packet tests");
    assert!(
        packets_culled_beside > 2_000,
        "{packets_culled_beside}: the packet test culls too little"
    );
}

/// A ray from the origin 0 with a direction of 53 random bits enters a box by its lower face
/// on axis k at the exact t* = lo/d, crossing the other axes well inside: every box test (one
/// ray's, and the packet test of that ray with others from 0) keeps the box with an entry
/// bound at most t*, decided exactly (`near·d ≤ lo` by a product and its fma residue). Here
/// the products round either way (the touching rays above are dyadic and round benignly), so
/// the packet test without the outward rounding of its 1/d interval and without its pad
/// fails.
#[test]
fn box_tests_keep_boxes_entered_where_the_products_round() {
    let mut rng = Rng::xorshift(12);
    let (mut tested, mut packets) = (0, 0);
    // near ≤ lo/d exactly, for d > 0: near·d = p + e exactly (e the fma's residue).
    let at_most = |near: f32, lo: f64, d: f64| {
        let p = near as f64 * d;
        let e = (near as f64).mul_add(d, -p);
        p < lo || (p == lo && e <= 0.0)
    };
    for i in 0..20_000 {
        let scale = [1.0, 1e-3, 1e4][i % 3];
        // d > 0 on every axis: its signs do not matter to the rounding, and the packet takes
        // one sign per axis.
        let d: [f64; 3] = [0, 1, 2].map(|_| (0.05 + rng.f()) * scale);
        let k = rng.below(3);
        let t = 0.5 + rng.f() * 4.0;
        // The plane lo on axis k (a float32 near t·d_k), so the exact entry is t* = lo/d_k.
        let lo_k = (t * d[k]) as f32;
        let t_star = lo_k as f64 / d[k];
        let mut node = Node8::EMPTY;
        let mut lo = [0f32; 3];
        let mut hi = [0f32; 3];
        for a in 0..3 {
            let x = t_star * d[a];
            if a == k {
                (lo[a], hi[a]) = (lo_k, (x * 1.5) as f32);
            } else {
                // Well inside: the ray crosses these slabs long before and after t*.
                (lo[a], hi[a]) = ((x * 0.5) as f32, (x * 1.5) as f32);
            }
        }
        let s = rng.below(WIDTH);
        let bn = BvhNode {
            lo,
            first: 0,
            hi,
            count: 0,
        };
        node.set(s, &bn, LEAF | (s as u32) << COUNT_BITS);
        let ray = |d: [f64; 3]| Ray {
            o: [0.0; 3],
            d,
            tmin: 0.0,
            tmax: f64::INFINITY,
            leaving: None,
        };
        let line = Line::new(&ray(d)).unwrap();
        for (name, test) in box_tests(&line, false) {
            tested += 1;
            let (mask, nears) = test.test(&node, line.tmin, line.tmax);
            assert!(
                mask & (1 << s) != 0 && at_most(nears[s], lo_k as f64, d[k]),
                "{name}: ray {i} d {d:?} enters {bn:?} at t* = {t_star}: mask {mask:b}, entry \
                 bound {}",
                nears[s]
            );
        }
        let mut lines = vec![line];
        for _ in 0..rng.below(4) {
            lines.push(Line::new(&ray(d.map(|x| x * (0.5 + rng.f())))).unwrap());
        }
        let last = lines.len() - 1;
        lines.swap(0, rng.below(last + 1));
        for (mask, nears) in packet_box_tests(&lines, &node).into_iter().flatten() {
            packets += 1;
            assert!(
                mask & (1 << s) != 0 && at_most(nears[s], lo_k as f64, d[k]),
                "packet of ray {i} d {d:?} entering {bn:?} at t* = {t_star}: mask {mask:b}, \
                 entry bound {}",
                nears[s]
            );
        }
    }
    assert!(tested >= 20_000 && packets >= 20_000, "{tested}, {packets}");
}

/// The portable and AVX2 walks visit the same nodes and give the same answers, bit for bit
/// (steps included), on the agreement rays; the answers are also Reshetov's BVH's.
#[test]
fn every_simd_level_walks_the_same_nodes() {
    let case = Agreement::new(83);
    let (g, n) = (&case.g, case.len());
    let (tmin, tmax) = case.bounds(false);
    let r64 = case.r64(&tmin, &tmax);
    let cast = |accel, simd| {
        let opts = CastOptions {
            accel,
            simd: Some(simd),
            ..Default::default()
        };
        let mut h = HitBuffers::<f64>::new(n, false);
        g.scene.cast(&r64, h.out(), &opts).unwrap();
        h
    };
    let base = cast(AccelKind::ExactBvh, Simd::Scalar);
    let reshetov = cast(AccelKind::ReshetovBvh, Simd::Scalar);
    assert!(
        base.status
            .iter()
            .filter(|&&s| s == crate::status::HIT)
            .count()
            > 1000
    );
    assert_eq!(base.status, reshetov.status);
    assert_eq!(base.triangle, reshetov.triangle);
    assert!(base
        .t
        .iter()
        .zip(&reshetov.t)
        .all(|(a, b)| a.to_bits() == b.to_bits()));
    for simd in Simd::supported_levels() {
        let h = cast(AccelKind::ExactBvh, simd);
        assert_eq!(h.status, base.status, "{simd:?}");
        assert_eq!(h.triangle, base.triangle, "{simd:?}");
        assert_eq!(h.steps, base.steps, "{simd:?}: nodes visited");
        assert!(h
            .t
            .iter()
            .zip(&base.t)
            .all(|(a, b)| a.to_bits() == b.to_bits()));
    }
    // Reached at all: the nodes visited are fewer than the binary tree's on average.
    let wide: u64 = base.steps.iter().map(|&s| s as u64).sum();
    let binary: u64 = reshetov.steps.iter().map(|&s| s as u64).sum();
    eprintln!("nodes visited: 8-wide {wide}, binary {binary}");
    assert!(wide < binary, "8-wide {wide}, binary {binary}");
}

/// A tree with an infinite box (a triangle past float32's range) and a ray with a zero
/// direction component takes the float64 test, and still finds the hit.
#[test]
fn zero_components_in_an_infinite_tree_take_the_float64_test() {
    let tris: Vec<Tri> = vec![
        [[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, 1.0, 1.0]],
        [[1e300, 0.0, 5.0], [1e300, 1.0, 5.0], [-1e300, 0.0, 5.0]],
    ];
    let bvh = ExactBvh::build(&tris, ExactBvhParams::default()).unwrap();
    assert!(bvh.infinite);
    let ray = Ray {
        o: [0.25, 0.25, 0.0],
        d: [0.0, 0.0, 1.0],
        tmin: 0.0,
        tmax: f64::INFINITY,
        leaving: None,
    };
    let line = Line::new(&ray).unwrap();
    assert!(RayBoxes::new(&line, true).is_none());
    for simd in Simd::supported_levels() {
        let mut near = Nearest::new(&line);
        bvh.walk(&line, &mut near, simd, &mut Vec::new());
        assert_eq!(near.best, Some(0), "{simd:?}");
    }
}

/// The AVX2 leaf filter leaves out only triangles the ray misses (`Line::meets`, exact): on
/// leaves of 1 to 16 triangles around a shared vertex and shared edges (a fan), with rays
/// aimed at the shared vertex, at points of the shared edges and inside, from grid origins
/// (side products exactly zero) and random ones at scales 1e-6 to 1e6. It must also leave
/// out most of the triangles missed, or it would be no filter. The triangles it certifies met
/// have the three exact side signs alike and nonzero.
#[cfg(target_arch = "x86_64")]
#[test]
fn the_leaf_filter_leaves_out_only_triangles_the_ray_misses() {
    if !Simd::Avx2.supported() {
        eprintln!("no AVX2 on this CPU: the filter never runs here");
        return;
    }
    let mut rng = Rng::xorshift(23);
    let (mut met, mut missed, mut left_out, mut certified) = (0, 0, 0, 0);
    for i in 0..20_000u64 {
        let grid = i % 2 == 0;
        let scale = [1.0, 1e-6, 1e6][(i / 2 % 3) as usize];
        let x = |rng: &mut Rng| {
            if grid {
                ((rng.f() * 8.0).floor() - 4.0) * scale
            } else {
                (rng.f() * 2.0 - 1.0) * scale
            }
        };
        // A fan of n triangles around a centre: consecutive ones share an edge.
        let n = 1 + rng.below(16);
        let centre = [x(&mut rng), x(&mut rng), x(&mut rng)];
        let rim: Vec<[f64; 3]> = (0..=n)
            .map(|_| [x(&mut rng), x(&mut rng), x(&mut rng)])
            .collect();
        let tris: Vec<Tri> = (0..n).map(|j| [centre, rim[j], rim[j + 1]]).collect();
        // Aim at the centre, a rim vertex, the midpoint of a spoke (exact on the grid), or
        // inside a triangle.
        let j = rng.below(n);
        let target = match rng.below(4) {
            0 => centre,
            1 => rim[j],
            2 => [0, 1, 2].map(|k| 0.5 * centre[k] + 0.5 * rim[j][k]),
            _ => [0, 1, 2].map(|k| (centre[k] + rim[j][k] + rim[j + 1][k]) / 3.0),
        };
        let o = [x(&mut rng), x(&mut rng), x(&mut rng)];
        let d = [0, 1, 2].map(|k| target[k] - o[k]);
        let Ok(line) = Line::new(&Ray::new(o, d, 0.0, f64::INFINITY)) else {
            continue;
        };
        // SAFETY: the CPU has AVX2 and FMA (checked above).
        let (may, sure) = unsafe { may_meet_avx2(&line, &tris) };
        for (k, tri) in tris.iter().enumerate() {
            let kept = may >> k & 1 != 0;
            // A triangle certified met has three exact side signs alike and nonzero, as the
            // exact test finds them (so `crosses_at` may skip them).
            if sure >> k & 1 != 0 {
                let s = triangle_sides(line.dir, line.o, tri);
                assert!(
                    kept && s[0] != 0 && s[0] == s[1] && s[1] == s[2],
                    "case {i}: triangle {k} of {n} is certified met, sides {s:?}: o {o:?} d {d:?}"
                );
                certified += 1;
            }
            if line.meets(tri) {
                met += 1;
                assert!(
                    kept,
                    "case {i}: triangle {k} of {n} is met but left out: o {o:?} d {d:?}"
                );
            } else {
                missed += 1;
                left_out += !kept as u32;
            }
        }
    }
    assert!(met > 10_000, "{met} triangles met");
    assert!(
        left_out * 10 >= missed * 6,
        "{left_out} of {missed} missed triangles left out"
    );
    // Certified ones occur: a quarter of the rays aim inside a triangle, which they meet
    // away from its edges (the others aim at shared vertices and edges, where the triangles
    // met there have a zero side product and are not certified).
    assert!(
        certified * 8 >= met,
        "{certified} of {met} met triangles certified"
    );
}

/// Packets answer as one ray walks, bit for bit: rays from shared origins (every grid point:
/// inside, on the surface, on triangles' vertices) towards every grid point and the midpoints
/// of grid steps (through vertices, along edges, in the faces' planes, exactly: the grid is
/// dyadic), with and without windows. Every column of closest hits but `steps` in both
/// precisions, any hits and all hits equal those of the one-ray walk at every SIMD level.
#[test]
fn packets_answer_as_one_ray_walks() {
    use crate::testing::grid_scene_inside;
    let mut rng = Rng::xorshift(84);
    let g = grid_scene_inside(&mut rng, 4, 0.0, 0.35);
    let mut rays = Vec::new();
    for (k, &o) in g.pts.iter().enumerate() {
        // A few origins' rays at all, to keep it short; packets of up to 64, then a rest.
        if k % 7 != 3 {
            continue;
        }
        for q in &g.pts {
            let mid = [0, 1, 2].map(|a| q[a] + 0.125);
            for target in [*q, mid] {
                let d = [0, 1, 2].map(|a| target[a] - o[a]);
                if d != [0.0; 3] {
                    rays.push((o, d));
                }
            }
        }
    }
    let set = RaySet::new(&rays);
    let n = rays.len();
    // The one-ray walk with packets off (whatever the default does with shared origins).
    let opts = |accel, simd| CastOptions {
        accel,
        simd: Some(simd),
        packets: if accel == AccelKind::ExactBvh {
            Packets::Off
        } else {
            Packets::Auto
        },
        ..Default::default()
    };
    let mut hits = 0;
    for window in [false, true] {
        let (tmin, tmax) = window_or_all(&rays, window);
        let (r64, r32) = set.rays(&tmin, &tmax);
        let cast = |opts: &CastOptions| Answers::of(&g.scene, &r64, &r32, opts);
        let one = cast(&opts(AccelKind::ExactBvh, Simd::Scalar));
        hits += one.hits();
        for simd in Simd::supported_levels() {
            // Every column but `steps` (a packet visits children in its own order).
            let packets = cast(&opts(AccelKind::ExactBvhPackets, simd));
            one.assert_same(&packets, false, &format!("{simd:?} window {window}"));
        }
    }
    assert!(hits > n / 2, "{hits} hits of {} rays", 2 * n);
}

/// The AVX2 `RayBoxes` constants are the portable ones, bit for bit, and None for the same
/// rays: directions and origins of every magnitude (float32's normals, subnormals and beyond
/// its range on both sides), signs, and zero components (which take the portable code).
#[test]
fn ray_boxes_are_the_same_at_every_simd_level() {
    let mut rng = Rng::xorshift(85);
    let scales = [
        1e-300, 1e-45, 1e-39, 1e-30, 1e-8, 1.0, 3.0, 1e8, 1e30, 3.5e38, 1e300,
    ];
    let (mut some, mut none) = (0, 0);
    for k in 0..20_000 {
        let pick = |rng: &mut Rng| {
            let s = scales[rng.below(scales.len())];
            let x = (rng.f() * 2.0 - 1.0) * s;
            if rng.chance(0.05) {
                0.0
            } else {
                x
            }
        };
        let o = [0, 1, 2].map(|_| pick(&mut rng));
        let d = [0, 1, 2].map(|_| pick(&mut rng));
        let Ok(line) = Line::new(&Ray::new(o, d, 0.0, f64::INFINITY)) else {
            continue;
        };
        let infinite = k % 2 == 0;
        let want = RayBoxes::new(&line, infinite);
        let bits = |r: &RayBoxes| {
            let f = |x: &[f32; 3]| x.map(f32::to_bits);
            (
                r.near,
                r.far,
                f(&r.inv),
                f(&r.neg_c_near),
                f(&r.neg_c_far),
                f(&r.o_down),
                f(&r.o_up),
                r.zero,
            )
        };
        for simd in Simd::supported_levels() {
            let got = RayBoxes::at(simd, &line, infinite);
            assert_eq!(
                got.as_ref().map(bits),
                want.as_ref().map(bits),
                "{simd:?}: o {o:?} d {d:?}"
            );
        }
        if want.is_some() {
            some += 1;
        } else {
            none += 1;
        }
    }
    assert!(some > 1500 && none > 1000, "{some} taken, {none} refused");
}

/// Two rays walked in turn (`ExactBvhAt::trace_two_avx2`, what a chunk takes at the AVX2
/// level) answer as each walked alone (the portable level walks one ray after the other), bit
/// for bit and with the same `steps`: rays from shared and from scattered origins, through
/// grid vertices and along edges, mixed with rays that are never walked (a NaN, a zero
/// direction, tmax below tmin) and rays the float32 box test does not take (a direction
/// component of 1e-40, a tiny or huge direction), so that a slot is refilled past them; with
/// and without windows; closest hits in both precisions, any hits and all hits. Then casts of
/// one, two, three and `READY + 1` rays that hit.
#[test]
fn two_rays_walked_in_turn_answer_as_one_ray_walks() {
    use crate::testing::grid_scene_inside;
    if cfg!(target_arch = "x86_64") && std::env::var_os("CI").is_some() {
        assert!(Simd::Avx2.supported(), "CI must compare the AVX2 level");
    }
    let mut rng = Rng::xorshift(86);
    let g = grid_scene_inside(&mut rng, 4, 0.0, 0.35);
    let (mut rays, mut pairs) = (Vec::new(), 0usize);
    for (k, &o) in g.pts.iter().enumerate() {
        for (m, q) in g.pts.iter().enumerate() {
            if (k * 31 + m) % 5 != 0 {
                continue;
            }
            let mid = [0, 1, 2].map(|a| q[a] + 0.125);
            for target in [*q, mid] {
                let d = [0, 1, 2].map(|a| target[a] - o[a]);
                rays.push((o, d));
            }
            // Every 20th pair: one of the rays a slot skips or walks alone, in turn.
            pairs += 1;
            if pairs % 20 == 0 {
                let odd = match pairs / 20 % 5 {
                    0 => ([f64::NAN, 0.0, 0.0], [1.0, 0.0, 0.0]),
                    1 => (o, [0.0; 3]),
                    2 => (o, [1.0, 1e-40, 0.5]),
                    3 => (o, [1e-300, 2e-300, 3e-300]),
                    _ => (o, [1e300, -1e300, 2e300]),
                };
                rays.push(odd);
            }
        }
    }
    // Runs longer than a batch of rays made ready at once (`READY`) of rays that are never
    // walked, and of rays walked alone, amid the others: a batch may make no ray ready, and
    // the walk must go on past it.
    let (o0, far) = (g.pts[0], g.pts[g.pts.len() - 1]);
    for (at, odd) in [
        (rays.len() / 3, ([f64::NAN, 0.0, 0.0], [1.0, 0.0, 0.0])),
        (
            2 * rays.len() / 3,
            (o0, [far[0] - o0[0], 1e-40, far[2] - o0[2]]),
        ),
    ] {
        rays.splice(at..at, std::iter::repeat_n(odd, 2 * super::READY + 3));
    }
    let set = RaySet::new(&rays);
    let n = rays.len();
    let opts = |simd| CastOptions {
        accel: AccelKind::ExactBvh,
        simd: Some(simd),
        packets: Packets::Off,
        ..Default::default()
    };
    let mut hits = 0;
    for window in [false, true] {
        // A window that leaves some rays out before they start (tmax < tmin).
        let (tmin, tmax): (Vec<f64>, Vec<f64>) = (0..n)
            .map(|j| match (window, j % 9) {
                (false, _) => (0.0, f64::INFINITY),
                (true, 0) => (0.5, 0.25),
                (true, k) => (0.05 * k as f64, 0.3 + 0.1 * k as f64),
            })
            .unzip();
        let (r64, r32) = set.rays(&tmin, &tmax);
        let cast = |opts: &CastOptions| Answers::of(&g.scene, &r64, &r32, opts);
        let one = cast(&opts(Simd::Scalar));
        let status = &one.closest.0;
        hits += one.hits();
        // The odd rays are there: invalid ones, and ones the float32 box test does not take
        // that are answered (the tiny and huge directions are unscaled exactly, so hit).
        assert!(status.contains(&crate::status::INVALID), "window {window}");
        let alone = (0..n).filter(|&j| {
            let l = Line::new(&r64.ray(j));
            l.is_ok_and(|l| RayBoxes::at(Simd::Scalar, &l, false).is_none())
        });
        assert!(alone.count() > 20, "window {window}: rays walked alone");
        for simd in Simd::supported_levels() {
            let two = cast(&opts(simd));
            one.assert_same(&two, true, &format!("{simd:?} window {window}"));
        }
    }
    assert!(hits > n / 3, "{hits} hits of {} rays", 2 * n);
    // Casts of a few rays that all hit: a batch that makes one ray ready (it walks alone from
    // its start), two, three (the third starts in the slot the first leaves), and one past a
    // whole batch.
    let (tmin, tmax) = (vec![0.0; n], vec![f64::INFINITY; n]);
    let (r64, r32) = set.rays(&tmin, &tmax);
    let one = Answers::of(&g.scene, &r64, &r32, &opts(Simd::Scalar));
    let hitting: Vec<_> = (0..n)
        .filter(|&j| one.closest.0[j] == crate::status::HIT)
        .map(|j| rays[j])
        .collect();
    for len in [1, 2, 3, super::READY + 1] {
        let few = RaySet::new(&hitting[..len]);
        let (tmin, tmax) = (vec![0.0; len], vec![f64::INFINITY; len]);
        let (r64, r32) = few.rays(&tmin, &tmax);
        let one = Answers::of(&g.scene, &r64, &r32, &opts(Simd::Scalar));
        assert_eq!(one.hits(), len, "{len} rays that hit");
        for simd in Simd::supported_levels() {
            let two = Answers::of(&g.scene, &r64, &r32, &opts(simd));
            one.assert_same(&two, true, &format!("{simd:?}, {len} rays"));
        }
    }
}

/// The fan (a batch from one origin answered through a grid over its directions,
/// `fan.rs`) answers as the one-ray walk, bit for bit: on the unjittered grid scene (every
/// plane an axis or diagonal plane: rays through vertices, along edges, in faces' planes,
/// exactly), from origins inside (on a vertex, an edge, a face), outside and far from the
/// box, towards every grid point and eight dyadic offsets of it, some directions scaled by
/// 1e-30 and 1e30, with and without windows; and from inside, rays whose directions all lie
/// in one plane or are one direction; closest hits in both precisions, any hits and all hits. The default (packets on) takes the fan wherever it builds; the batches are sized
/// so that it is offered.
#[test]
fn the_fan_answers_as_one_ray_walks() {
    use crate::scene::cast::FAN_MIN_RAYS;
    use crate::testing::grid_scene_inside;
    let mut rng = Rng::xorshift(87);
    let g = grid_scene_inside(&mut rng, 4, 0.0, 0.35);
    let bvh = g
        .scene
        .structures
        .get::<ExactBvh>(&g.scene.surface.triangles)
        .unwrap();
    let t = &g.tris[g.tris.len() / 2];
    let mid = |a: [f64; 3], b: [f64; 3]| [0, 1, 2].map(|k| (a[k] + b[k]) * 0.5);
    let origins = [
        g.pts[31],
        g.pts[62],
        mid(t[0], t[1]),
        [0, 1, 2].map(|k| (t[0][k] + t[1][k] + 2.0 * t[2][k]) * 0.25),
        [0.375, 0.625, 0.4375],
        [-0.5, 0.3, 0.6],
        [0.5, 0.5, 3.0],
        [1.75, -0.25, 1.25],
        [1e6, 2e6 + 0.5, -3e6],
    ];
    let e = 0.125;
    let offsets = [
        [0.0; 3],
        [e, 0.0, 0.0],
        [0.0, e, 0.0],
        [0.0, 0.0, e],
        [e, e, 0.0],
        [0.0, e, e],
        [e, 0.0, e],
        [e, e, e],
        [-e / 2.0, e / 4.0, 3.0 * e / 8.0],
    ];
    let mut sets: Vec<([f64; 3], Vec<crate::testing::Ray6>)> = origins
        .into_iter()
        .map(|o| {
            let mut rays = Vec::new();
            for q in &g.pts {
                for off in offsets {
                    let d = [0, 1, 2].map(|k| q[k] + off[k] - o[k]);
                    let scale = [1.0, 1e-30, 1.0, 1e30, 1.0][rays.len() % 5];
                    if d != [0.0; 3] {
                        rays.push((o, d.map(|x| x * scale)));
                    }
                }
            }
            (o, rays)
        })
        .collect();
    // Directions that span no area on a side of the fan's cube (`Fan::side`'s cells along
    // one axis or none): all in the plane z = 0.5 through the origin (on the x and y sides a
    // segment, along u on one and v on the other), and one direction repeated (a point).
    let o = [0.375, 0.625, 0.5];
    let flat = (0..1600)
        .map(|k| {
            let a = k as f64 * 0.0039;
            (o, [a.cos(), a.sin(), 0.0])
        })
        .collect();
    sets.push((o, flat));
    sets.push((o, vec![(o, [0.3125, -0.25, 0.125]); 1600]));
    let (mut built, mut always, mut hits) = (0, 0, 0);
    for (o, rays) in sets {
        let n = rays.len();
        assert!(
            n >= FAN_MIN_RAYS && 2 * n >= bvh.triangles.len(),
            "{n} rays"
        );
        if let Some(fan) = Fan::build(&bvh, Simd::Scalar, o, n, &|i| rays[i].1, None) {
            built += 1;
            always += fan.always();
        }
        let set = RaySet::new(&rays);
        // The fan built on one thread and on three (its stages split over them), and cast at
        // every SIMD level (its edge filter has an AVX2 twin).
        let opts = |packets, threads, simd| CastOptions {
            accel: AccelKind::ExactBvh,
            packets,
            threads: Some(threads),
            simd: Some(simd),
            ..Default::default()
        };
        for window in [false, true] {
            let (tmin, tmax) = window_or_all(&rays, window);
            let (r64, r32) = set.rays(&tmin, &tmax);
            let one = Answers::of(&g.scene, &r64, &r32, &opts(Packets::Off, 1, Simd::Scalar));
            hits += one.hits();
            for (threads, simd) in [1, 3]
                .into_iter()
                .flat_map(|t| Simd::supported_levels().into_iter().map(move |s| (t, s)))
            {
                let fan = Answers::of(&g.scene, &r64, &r32, &opts(Packets::Auto, threads, simd));
                one.assert_same(
                    &fan,
                    false,
                    &format!("origin {o:?} window {window} threads {threads} {simd:?}"),
                );
            }
        }
    }
    // The fan was built from most origins, some of them with triangles every ray tests.
    assert!(
        built >= 6 && always > 0,
        "fan built from {built} origins, {always} always"
    );
    assert!(hits > 2000, "{hits} hits");
}

/// The fan's placement holds every ray that meets a triangle: on grids so fine (cells of
/// 2^-40 and 2^-52 of the rays' spread) that a rounding of either side moves a cell, the cell
/// a ray from the origin falls in (as the cast finds it) lies in the cells listed for every
/// triangle the ray meets (`Line::meets`, exact). Triangles with two corners on one line
/// through the origin (an edge that projects to a point, ahead of the origin or across it),
/// straddling w = 0 or not; rays aimed at their corners, at points of their
/// edges, and inside, with directions scaled by odd factors so that their roundings differ
/// from the corners'.
#[test]
fn the_fan_lists_every_triangle_a_ray_meets() {
    use super::fan::{cell_of_test, place_test};
    let mut rng = Rng::xorshift(88);
    let o = [0.3, -0.2, 0.1];
    let (mut met, mut straddling) = (0, 0);
    for _ in 0..4000 {
        // A corner ahead of o, one on its line from o, and one anywhere near.
        let p0 = [0, 1, 2].map(|k| o[k] + rng.f() * 2.0 - 1.0);
        // On the line, ahead of o or behind it.
        let s = [-1.5, -0.4, 0.25, 0.5, 2.0, 3.0][(rng.f() * 6.0) as usize] + rng.f() * 0.1;
        let p1 = [0, 1, 2].map(|k| o[k] + (p0[k] - o[k]) * s);
        let spread = [0.25, 2.0][(rng.f() * 2.0) as usize];
        let p2 = [0, 1, 2].map(|k| p0[k] + (rng.f() - 0.5) * spread);
        let mut tri = [p0, p1, p2];
        tri.swap(0, (rng.f() * 3.0) as usize);
        let w = [rng.f(), rng.f(), rng.f()];
        let sum = w[0] + w[1] + w[2];
        let aims = [
            tri[0],
            tri[1],
            [0, 1, 2].map(|k| (tri[0][k] + tri[1][k]) * 0.5),
            [0, 1, 2].map(|k| (tri[1][k] + tri[2][k]) * 0.5),
            [0, 1, 2].map(|k| (w[0] * tri[0][k] + w[1] * tri[1][k] + w[2] * tri[2][k]) / sum),
        ];
        for aim in aims {
            let scale = [1.0, 3.0, 0.7, 1e-3, 12345.678][(rng.f() * 5.0) as usize];
            let d = [0, 1, 2].map(|k| (aim[k] - o[k]) * scale);
            let ray = Ray::new(o, d, 0.0, f64::INFINITY);
            let Ok(line) = Line::new(&ray) else { continue };
            if !line.meets(&tri) {
                continue;
            }
            met += 1;
            for fine in [2f64.powi(-40), 2f64.powi(-52)] {
                let Some((side, cells, grid)) = cell_of_test(d, fine) else {
                    continue;
                };
                let (placed, straddles) = place_test(o, side, &tri, grid);
                straddling += straddles as usize;
                match placed {
                    None => {} // tested by every ray of the side
                    Some([c0, c1]) => assert!(
                        (0..2).all(|i| c0[i] <= cells[i] && cells[i] <= c1[i]),
                        "triangle {tri:?}, ray {d:?}: cell {cells:?} not in {c0:?}..={c1:?}"
                    ),
                }
            }
        }
    }
    assert!(
        met > 5000 && straddling > 500,
        "{met} rays met, {straddling} straddling"
    );
}

/// The rays' ranges: each its window (`testing::windows`, from a quarter) or [0, ∞).
fn window_or_all(rays: &[crate::testing::Ray6], window: bool) -> (Vec<f64>, Vec<f64>) {
    if window {
        crate::testing::windows(rays, 0.25)
    } else {
        (vec![0.0; rays.len()], vec![f64::INFINITY; rays.len()])
    }
}

/// Float64 values as bits (NaN and -0 compared exactly).
fn bits(x: &[f64]) -> Vec<u64> {
    x.iter().map(|x| x.to_bits()).collect()
}

/// Closest hits of float64 rays: status, triangle, tet, steps and the bits of t, u, v and the
/// point.
type Closest64 = (Vec<u8>, Vec<i32>, Vec<i32>, Vec<u32>, [Vec<u64>; 4]);
/// The same of float32 rays (values widened to float64).
type Closest32 = (Vec<u8>, Vec<i32>, Vec<u32>, [Vec<u64>; 4]);
/// All hits: status and each point's t bits, triangle and point bits.
type AllHits = Vec<(u8, Vec<(u64, u32, Vec<u64>)>)>;

/// Rays in float64 and the same rays rounded to float32, cast by [`Answers::of`].
struct RaySet {
    o: Vec<f64>,
    d: Vec<f64>,
    o32: Vec<f32>,
    d32: Vec<f32>,
}

impl RaySet {
    fn new(rays: &[([f64; 3], [f64; 3])]) -> RaySet {
        let o: Vec<f64> = rays.iter().flat_map(|r| r.0).collect();
        let d: Vec<f64> = rays.iter().flat_map(|r| r.1).collect();
        let round = |x: &[f64]| x.iter().map(|&x| x as f32).collect();
        RaySet {
            o32: round(&o),
            d32: round(&d),
            o,
            d,
        }
    }

    /// Both precisions' rays over the windows [tmin, tmax].
    fn rays<'a>(&'a self, tmin: &'a [f64], tmax: &'a [f64]) -> (Rays<'a, f64>, Rays<'a, f32>) {
        let r64 = Rays {
            origins: &self.o,
            directions: &self.d,
            tmin,
            tmax,
            leaving: None,
        };
        let r32 = Rays {
            origins: &self.o32,
            directions: &self.d32,
            tmin,
            tmax,
            leaving: None,
        };
        (r64, r32)
    }
}

/// Every answer a cast gives, in a form compared bit for bit: closest hits of float64 and
/// float32 rays, any hits and all hits (the two accelerator tests above compare these).
struct Answers {
    closest: Closest64,
    closest32: Closest32,
    any: Vec<u8>,
    all: AllHits,
}

impl Answers {
    fn of(scene: &crate::Scene, r64: &Rays<f64>, r32: &Rays<f32>, opts: &CastOptions) -> Answers {
        let n = r64.len();
        let mut h = HitBuffers::<f64>::new(n, false);
        scene.cast(r64, h.out(), opts).unwrap();
        let mut h32 = HitBuffers::<f32>::new(n, false);
        scene.cast(r32, h32.out(), opts).unwrap();
        let wide = |x: &[f32]| x.iter().map(|&x| x as f64).collect::<Vec<_>>();
        let cols = [&h.t, &h.u, &h.v, &h.point].map(|c| bits(c));
        let cols32 = [&h32.t, &h32.u, &h32.v, &h32.point].map(|c| bits(&wide(c)));
        let mut any = vec![0u8; n];
        let m = (Method::DEFAULT, LayoutKind::DEFAULT);
        scene.occluded(m.0, m.1, r64, &mut any, opts).unwrap();
        let mut lists = vec![Listed::default(); n];
        scene.intersections(r64, &mut lists, opts).unwrap();
        let all = lists
            .iter()
            .map(|l| {
                let m = l
                    .meets
                    .iter()
                    .map(|m| (m.t.to_bits(), m.triangle, bits(&m.point)));
                (l.status, m.collect::<Vec<_>>())
            })
            .collect();
        Answers {
            closest: (h.status, h.triangle, h.tet, h.steps, cols),
            closest32: (h32.status, h32.triangle, h32.steps, cols32),
            any,
            all,
        }
    }

    /// Closest hits of the float64 rays.
    fn hits(&self) -> usize {
        let status = &self.closest.0;
        status.iter().filter(|&&s| s == crate::status::HIT).count()
    }

    /// Asserts that `other` gives the same answers (`steps` too, where `steps`).
    fn assert_same(&self, other: &Answers, steps: bool, what: &str) {
        let (a, b) = (&self.closest, &other.closest);
        assert!(
            a.0 == b.0 && a.1 == b.1 && a.2 == b.2 && a.4 == b.4,
            "{what}: closest hits"
        );
        let (a32, b32) = (&self.closest32, &other.closest32);
        assert!(
            a32.0 == b32.0 && a32.1 == b32.1 && a32.3 == b32.3,
            "{what}: closest hits of float32 rays"
        );
        if steps {
            assert!(a.3 == b.3 && a32.2 == b32.2, "{what}: steps");
        }
        assert_eq!(self.any, other.any, "{what}: any hits");
        assert!(self.all == other.all, "{what}: all hits");
    }
}

/// The four faces of the tetrahedron on alternate corners of [0, 1]³, scaled by `scale` (a
/// power of two) and moved by `shift`: one leaf, so the root's one child has the box the
/// pre-pass ([`outside_avx2`]) tests, every face of it touched.
fn cube_tetrahedron(scale: f64, shift: [f64; 3]) -> Vec<Tri> {
    let c = [
        [0.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [1.0, 0.0, 1.0],
        [0.0, 1.0, 1.0],
    ]
    .map(|p: [f64; 3]| [0, 1, 2].map(|k| p[k] * scale + shift[k]));
    vec![
        [c[0], c[1], c[2]],
        [c[0], c[1], c[3]],
        [c[0], c[2], c[3]],
        [c[1], c[2], c[3]],
    ]
}

/// Rays around the box [lo, hi]: lines that pass outside each of its twelve edges at gaps
/// from a sixteenth of its size down to 2^-46 of it (closer than the float32 box test's
/// padding, which keeps a box it passes that close), from near and far, with directions
/// scaled by 2^-20 to 2^20; and rays from anywhere in and around the box in any direction.
fn rays_around(rng: &mut Rng, lo: [f64; 3], hi: [f64; 3]) -> Vec<([f64; 3], [f64; 3])> {
    let w = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
    let mut rays = Vec::new();
    for a in 0..3 {
        let (b, c) = ((a + 1) % 3, (a + 2) % 3);
        for (sa, sb) in [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)] {
            for k in (4..=46).step_by(3) {
                let h = w * 2f64.powi(-k);
                // A point of the edge (sa, sb), moved off it by h along (sa, sb): the line
                // through it across that diagonal stays h·√2 outside the box.
                let mut q = [0.0; 3];
                q[a] = if sa > 0.0 { hi[a] } else { lo[a] } + sa * h;
                q[b] = if sb > 0.0 { hi[b] } else { lo[b] } + sb * h;
                q[c] = lo[c] + rng.f() * (hi[c] - lo[c]);
                let scale = rng.pick(&[2f64.powi(-20), 1.0, 2f64.powi(20)]);
                let mut d = [0.0; 3];
                (d[a], d[b], d[c]) = (sb * scale, -sa * scale, (2.0 * rng.f() - 1.0) * scale);
                let back = rng.pick(&[0.5, 2.0, 100.0]) * w / scale;
                rays.push(([0, 1, 2].map(|m| q[m] - back * d[m]), d));
            }
        }
    }
    for _ in 0..2000 {
        let o = [0, 1, 2].map(|k| lo[k] + (3.0 * rng.f() - 1.0) * (hi[k] - lo[k]));
        let d = [0, 1, 2].map(|_| 2.0 * rng.f() - 1.0);
        rays.push((o, d));
    }
    rays
}

/// The gap between where the line of `(o, d)` enters the box [lo, hi] (at t ≥ 0) and where
/// it leaves, over S = max_k (max(|lo_k|, |hi_k|) + |o_k|) / |d_k| (the scale of
/// [`outside_avx2`]'s margin), in float64: within 2^-49 of the exact ratio.
#[cfg(target_arch = "x86_64")]
fn gap_over_scale(o: [f64; 3], d: [f64; 3], lo: [f64; 3], hi: [f64; 3]) -> f64 {
    let (mut entry, mut exit, mut s) = (0.0f64, f64::INFINITY, 0.0f64);
    for k in 0..3 {
        let (a, b) = ((lo[k] - o[k]) / d[k], (hi[k] - o[k]) / d[k]);
        (entry, exit) = (entry.max(a.min(b)), exit.min(a.max(b)));
        s = s.max((lo[k].abs().max(hi[k].abs()) + o[k].abs()) / d[k].abs());
    }
    (entry - exit) / s
}

/// A ray the pre-pass answers would enter none of the root's boxes: the float32 box test
/// (portable and AVX2) keeps none of the root's children over [0, ∞), so the walk's answer is
/// the pre-pass's, `steps` 0 included. On rays that pass the box closer than that test's
/// padding: some of them the test keeps although they miss the box, which a pre-pass without
/// its margin would answer wrongly. Trees of one leaf (the box itself) scaled by 2^-40 to
/// 2^40 and moved where float32 cannot hold the origins, and a tree of many triangles.
#[test]
#[cfg(target_arch = "x86_64")]
fn outside_rays_miss_every_root_box_in_the_float32_test() {
    if !Simd::Avx2.supported() {
        assert!(
            std::env::var_os("CI").is_none(),
            "CI must run the AVX2 pre-pass"
        );
        return;
    }
    let mut rng = Rng::xorshift(61);
    let mut trees = Vec::new();
    for (scale, shift) in [
        (1.0, [0.0; 3]),
        (2f64.powi(-40), [0.3, -1e-9, 7.0]),
        (2f64.powi(40), [-3e15, 1.0 / 3.0, 2e12]),
        (1.0, [1e6 + 1.0 / 3.0, -2e5, 0.1]),
    ] {
        trees.push(cube_tetrahedron(scale, shift));
    }
    trees.push(triangle_soup(&mut rng));
    let (mut answered, mut close, mut kept_outside) = (0usize, 0usize, 0usize);
    for tris in &trees {
        let bvh = ExactBvh::build(tris, ExactBvhParams::default()).unwrap();
        let root = bvh
            .outside_box()
            .expect("a finite tree has the pre-pass's box");
        let (lo, hi) = ([0, 1, 2].map(|k| root.lo[k]), [0, 1, 2].map(|k| root.hi[k]));
        let one_leaf = tris.len() == 4;
        for (o, d) in rays_around(&mut rng, lo, hi) {
            let ray = Ray::new(o, d, 0.0, f64::INFINITY);
            let line = Line::new(&ray).unwrap();
            // SAFETY: the CPU has AVX2 (checked above).
            let outside = unsafe { outside_avx2(&root, &ray) }.1;
            let r = RayBoxes::new(&line, bvh.infinite);
            let kept = |r: &RayBoxes| {
                let portable = r.test(&bvh.nodes[0], line.tmin, line.tmax).0;
                // SAFETY: as above (FMA comes with AVX2 in `Simd::supported`).
                let avx2 = unsafe { avx2_test(r, &bvh.nodes[0], line.tmin, line.tmax) }.0;
                assert_eq!(portable, avx2, "ray {o:?} {d:?}: the two float32 tests");
                portable
            };
            if outside {
                answered += 1;
                let r = r.expect("the pre-pass answers only rays the float32 test takes");
                assert_eq!(
                    kept(&r),
                    0,
                    "ray {o:?} {d:?}: answered, but a root box is kept"
                );
                let gap = gap_over_scale(o, d, lo, hi);
                assert!(gap > 2f64.powi(-16), "ray {o:?} {d:?}: gap {gap:e}");
                close += (gap < 2f64.powi(-12)) as usize;
            } else if one_leaf {
                // Outside the box by more than float64 can mistake, kept by the test.
                let gap = gap_over_scale(o, d, lo, hi);
                if gap > 2f64.powi(-44) && r.is_some_and(|r| kept(&r) != 0) {
                    kept_outside += 1;
                }
            }
        }
    }
    assert!(answered > 2000, "{answered} rays answered by the pre-pass");
    assert!(
        close > 20,
        "{close} answered rays within 2^-12 of the margin's scale"
    );
    assert!(
        kept_outside > 20,
        "{kept_outside} rays outside that the test keeps"
    );
}

/// Casts whose rays the pre-pass answers give the answers of the portable level, which has
/// none, bit for bit, `steps` included: closest hits of float64 and float32 rays, any hits and
/// all hits, with and without windows (a window that ends before it starts: MISS either way),
/// rays with NaN bounds or zero and tiny direction components among them.
#[test]
fn rays_the_pre_pass_answers_answer_as_the_portable_walk() {
    let mut rng = Rng::xorshift(62);
    let mut tris = cube_tetrahedron(1.0, [0.0; 3]);
    // A second part away from the first: the root's box holds empty space between them.
    tris.extend(cube_tetrahedron(0.25, [3.0, 0.5, -1.0]));
    let scene = crate::Scene::surface_only(tris, [-1.0, -1.0, -2.0], [4.5, 2.0, 2.0]).unwrap();
    let [lo, hi] = [[0.0, 0.0, -1.0], [3.25, 1.0, 1.0]];
    let mut rays = rays_around(&mut rng, lo, hi);
    // Rays aimed at points of the triangles, from around the box: hits.
    for _ in 0..500 {
        let t = rng.pick(&scene.surface.triangles);
        let (a, b) = (rng.f(), rng.f());
        let (a, b) = if a + b > 1.0 {
            (1.0 - a, 1.0 - b)
        } else {
            (a, b)
        };
        let p = [0, 1, 2].map(|k| t[0][k] + a * (t[1][k] - t[0][k]) + b * (t[2][k] - t[0][k]));
        let o = [0, 1, 2].map(|k| lo[k] + (3.0 * rng.f() - 1.0) * (hi[k] - lo[k]));
        rays.push((o, [0, 1, 2].map(|k| p[k] - o[k])));
    }
    let o = [0.5, 0.5, 5.0];
    rays.extend([
        (o, [0.0, 0.0, 1.0]),
        (o, [1e-300, 0.0, 1.0]),
        (o, [0.0; 3]),
        ([f64::NAN, 0.0, 0.0], [1.0, 0.0, 0.0]),
    ]);
    let set = RaySet::new(&rays);
    let n = rays.len();
    let opts = |simd| CastOptions {
        accel: AccelKind::ExactBvh,
        simd: Some(simd),
        packets: Packets::Off,
        ..Default::default()
    };
    for window in [false, true] {
        let (tmin, tmax): (Vec<f64>, Vec<f64>) = (0..n)
            .map(|j| match (window, j % 7) {
                (false, _) => (0.0, f64::INFINITY),
                (true, 0) => (2.0, 1.0),
                (true, 1) => (f64::NAN, 1.0),
                (true, k) => (0.1 * k as f64, 10.0 * k as f64),
            })
            .unzip();
        let (r64, r32) = set.rays(&tmin, &tmax);
        #[cfg(target_arch = "x86_64")]
        if Simd::Avx2.supported() {
            let root = scene.exact_bvh().unwrap().outside_box().unwrap();
            // SAFETY: the CPU has AVX2.
            let answered = (0..n).filter(|&j| unsafe { outside_avx2(&root, &r64.ray(j)) }.1);
            let answered = answered.count();
            assert!(
                answered > n / 4,
                "window {window}: {answered} answered by the pre-pass"
            );
        }
        let one = Answers::of(&scene, &r64, &r32, &opts(Simd::Scalar));
        assert!(one.hits() > n / 20, "window {window}: {} hits", one.hits());
        for simd in Simd::supported_levels() {
            let other = Answers::of(&scene, &r64, &r32, &opts(simd));
            one.assert_same(&other, true, &format!("{simd:?} window {window}"));
        }
    }
}

/// What a query answers for a ray that entered no box and was offered nothing (a fresh
/// gatherer, `visited` 0) is its `outside` answer, whatever the ray: closest hits (with and
/// without the float32 hit's rounding), any hits and all hits.
#[test]
fn the_outside_answer_is_what_a_walk_that_met_nothing_answers() {
    use crate::query::{AllHits, AnyHit, QueryKind};
    let scene =
        crate::Scene::surface_only(cube_tetrahedron(1.0, [0.0; 3]), [-1.0; 3], [2.0; 3]).unwrap();
    let mut rng = Rng::xorshift(63);
    let hit_bits = |h: &crate::query::RayHit| {
        let f = [h.t, h.u, h.v, h.point[0], h.point[1], h.point[2]].map(f64::to_bits);
        (h.status, f, h.triangle, h.tet, h.steps, h.audit)
    };
    let mut checked = 0;
    for (o, d) in rays_around(&mut rng, [0.0; 3], [1.0; 3])
        .into_iter()
        .step_by(7)
    {
        for (tmin, tmax) in [(0.0, f64::INFINITY), (0.5, 0.75)] {
            let line = Line::new(&Ray::new(o, d, tmin, tmax)).unwrap();
            for narrow in [None, Some(Simd::Scalar)] {
                let closest = crate::query::ClosestHit {
                    narrow,
                    ..scene.closest()
                };
                let got = closest.gathered(&mut closest.gather(&line), 0);
                assert_eq!(
                    hit_bits(&got),
                    hit_bits(&closest.outside()),
                    "closest {o:?} {d:?}"
                );
                let any = AnyHit(closest);
                assert_eq!(any.gathered(&mut any.gather(&line), 0), any.outside());
                let all = AllHits(closest);
                let (got, want) = (all.gathered(&mut all.gather(&line), 0), all.outside());
                assert!(got.status == want.status && got.meets.is_empty() && want.meets.is_empty());
                checked += 1;
            }
        }
    }
    assert!(checked > 100, "{checked} lines");
}

/// The children a node pushes are popped nearest first, and of equal entries the later slot
/// first, as a sort by `total_cmp` orders them (−0 below +0): every mask of eight slots, on
/// entries drawn from a few values so that ties are common, above items already on the stack.
#[test]
fn pushed_children_pop_nearest_first_and_later_slots_first_among_equals() {
    let mut rng = Rng::xorshift(64);
    let values = [0.0f32, -0.0, 1.0, 1.5, 2.0, f32::MIN_POSITIVE, 1e30];
    for mask in 0..256u32 {
        for _ in 0..4 {
            let entries: [f32; WIDTH] = std::array::from_fn(|_| rng.pick(&values));
            let mut stack = vec![(99u32, -1.0f32); rng.below(3)];
            let below = stack.len();
            push_by_entry(&mut stack, mask, |s| (s as u32, entries[s]), |e| e.1);
            let mut want: Vec<(u32, f32)> = (0..WIDTH as u32)
                .filter(|&s| mask >> s & 1 == 1)
                .map(|s| (s, entries[s as usize]))
                .collect();
            // Bottom to top: farthest first; of equal entries, the earlier slot lower.
            want.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
            let got: Vec<(u32, u32)> = stack[below..]
                .iter()
                .map(|e| (e.0, e.1.to_bits()))
                .collect();
            let want: Vec<(u32, u32)> = want.iter().map(|e| (e.0, e.1.to_bits())).collect();
            assert_eq!(got, want, "mask {mask:08b} entries {entries:?}");
            assert!(stack[..below].iter().all(|e| e.0 == 99));
        }
    }
}
