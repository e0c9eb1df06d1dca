//! The distance queries on the BVH (issue 16, after Open3D's `compute_closest_points` and
//! `compute_distance`): the caller's triangle nearest a point, the nearest point on it and its
//! barycentrics. A best-first descent: a node is skipped when the distance from the point to
//! its box, rounded down, exceeds the best found. Distances are float64 evaluations (Ericson,
//! *Real-Time Collision Detection* §5.1.5); which triangle is nearest is decided on them (two
//! triangles as near as rounding can tell apart: the smaller id).

use super::{BvhNode, ReshetovBvh};
use crate::geom::real::{exponent, times_pow2};
use crate::query::gather::Tri;

/// The nearest point of the scene to a query point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NearestPoint {
    /// The caller's triangle (-1 when the scene has none).
    pub triangle: i32,
    /// The point on it, `a + u (b − a) + v (c − a)`.
    pub point: [f64; 3],
    pub u: f64,
    pub v: f64,
    /// Euclidean distance to the query point.
    pub distance: f64,
}

impl NearestPoint {
    pub const NONE: NearestPoint = NearestPoint {
        triangle: -1,
        point: [f64::NAN; 3],
        u: f64::NAN,
        v: f64::NAN,
        distance: f64::INFINITY,
    };
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Largest components of the edges and of the offsets that [`closest_on_triangle`] takes as
/// they are, 2^-200 to 2^200: its products of four (2^±800, times a few) neither overflow
/// nor leave the normal numbers.
const IN_RANGE: std::ops::RangeInclusive<f64> =
    f64::from_bits((1023 - 200) << 52)..=f64::from_bits((1023 + 200) << 52);

/// The point of triangle `tri` nearest `p` as barycentrics (u, v) of b and c (Ericson's
/// Voronoi-region test). A triangle without area (its face region empty) gives the nearest
/// point of its three edges, an edge of no length skipped.
pub fn closest_on_triangle(p: [f64; 3], tri: &Tri) -> (f64, f64) {
    let [a, b, c] = *tri;
    // The region tests multiply two products of an edge and a point's offset (v = d d), the
    // fourth power of the scale: from about 1e77 on they overflowed (inf − inf, NaN), and a
    // point over a face of a mesh that large was given the nearest point of an edge. Every
    // d is an edge times an offset, so scaling the edges by one power of two and the offsets
    // by another (exactly) scales all d alike and leaves every test and quotient unchanged.
    let (mut ab, mut ac) = (sub(b, a), sub(c, a));
    let (mut ap, mut bp, mut cp) = (sub(p, a), sub(p, b), sub(p, c));
    let largest = |vs: &[[f64; 3]]| vs.iter().flatten().fold(0f64, |m, x| m.max(x.abs()));
    let (edges, offsets) = (largest(&[ab, ac]), largest(&[ap, bp, cp]));
    if !(IN_RANGE.contains(&edges) && IN_RANGE.contains(&offsets)) {
        let e = [edges, offsets].map(|m| if m > 0.0 { exponent(m) } else { 0 });
        [ab, ac] = [ab, ac].map(|v| v.map(|x| times_pow2(x, -e[0])));
        [ap, bp, cp] = [ap, bp, cp].map(|v| v.map(|x| times_pow2(x, -e[1])));
    }
    let (d1, d2) = (dot(ab, ap), dot(ac, ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return (0.0, 0.0); // vertex a
    }
    let (d3, d4) = (dot(ab, bp), dot(ac, bp));
    if d3 >= 0.0 && d4 <= d3 {
        return (1.0, 0.0); // vertex b
    }
    // Each edge region's quotient divides by a difference the region's signs keep at or
    // above zero; it is zero only where the edge has no length (two corners at one point:
    // 0/0, NaN, made the triangle lose to every other), and then the region is skipped.
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 && d1 - d3 > 0.0 {
        return (d1 / (d1 - d3), 0.0); // edge ab
    }
    let (d5, d6) = (dot(ab, cp), dot(ac, cp));
    if d6 >= 0.0 && d5 <= d6 {
        return (0.0, 1.0); // vertex c
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 && d2 - d6 > 0.0 {
        return (0.0, d2 / (d2 - d6)); // edge ac
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 && (d4 - d3) + (d5 - d6) > 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (1.0 - w, w); // edge bc
    }
    let denom = va + vb + vc;
    if denom > 0.0 && denom.is_finite() {
        return (vb / denom, vc / denom); // inside the face
    }
    // No area (or a region test that rounding left undecided): the nearest of the edges, in
    // the caller's coordinates (each quotient below is of one scale's squares).
    let (ab, ac, bp) = (sub(b, a), sub(c, a), sub(p, b));
    let (d1, d2) = (dot(ab, sub(p, a)), dot(ac, sub(p, a)));
    let seg = |s: f64| s.clamp(0.0, 1.0);
    let on_ab = seg(if dot(ab, ab) > 0.0 {
        d1 / dot(ab, ab)
    } else {
        0.0
    });
    let on_ac = seg(if dot(ac, ac) > 0.0 {
        d2 / dot(ac, ac)
    } else {
        0.0
    });
    let bc = sub(c, b);
    let on_bc = seg(if dot(bc, bc) > 0.0 {
        dot(bc, bp) / dot(bc, bc)
    } else {
        0.0
    });
    [(on_ab, 0.0), (0.0, on_ac), (1.0 - on_bc, on_bc)]
        .into_iter()
        .min_by(|x, y| dist2(p, tri, *x).total_cmp(&dist2(p, tri, *y)))
        .expect("three edges")
}

/// `a + u (b − a) + v (c − a)`.
pub fn point_at(tri: &Tri, (u, v): (f64, f64)) -> [f64; 3] {
    let [a, b, c] = *tri;
    [0, 1, 2].map(|k| a[k] + u * (b[k] - a[k]) + v * (c[k] - a[k]))
}

fn dist2(p: [f64; 3], tri: &Tri, uv: (f64, f64)) -> f64 {
    let q = sub(point_at(tri, uv), p);
    dot(q, q)
}

/// Squared distance from `p` to the node's box, rounded down (the box holds its triangles, so
/// none is nearer).
fn box_dist2(p: [f64; 3], node: &BvhNode) -> f64 {
    let mut s = 0.0;
    for (k, &x) in p.iter().enumerate() {
        let (lo, hi) = (node.lo[k] as f64, node.hi[k] as f64);
        let e = if x < lo {
            lo - x
        } else if x > hi {
            x - hi
        } else {
            0.0
        };
        s += e * e;
    }
    // Five roundings at most (a difference, a square and a sum per axis): pad below.
    s * (1.0 - 8.0 * f64::EPSILON)
}

impl ReshetovBvh {
    /// The scene's point nearest `p` (finite coordinates); `stack` is scratch.
    pub fn nearest(&self, p: [f64; 3], stack: &mut Vec<(u32, f64)>) -> NearestPoint {
        let mut best = NearestPoint::NONE;
        let mut best2 = f64::INFINITY;
        stack.clear();
        if self.triangles.is_empty() {
            return best;
        }
        stack.push((0, box_dist2(p, &self.nodes[0])));
        while let Some((k, bound)) = stack.pop() {
            if bound > best2 {
                continue;
            }
            let node = &self.nodes[k as usize];
            if node.count > 0 {
                for j in node.first as usize..(node.first + node.count) as usize {
                    let tri = &self.triangles[j];
                    let uv = closest_on_triangle(p, tri);
                    let d2 = dist2(p, tri, uv);
                    let id = self.order[j] as i32;
                    if d2 < best2 || (d2 == best2 && id < best.triangle) {
                        best2 = d2;
                        best = NearestPoint {
                            triangle: id,
                            point: point_at(tri, uv),
                            u: uv.0,
                            v: uv.1,
                            distance: d2.sqrt(),
                        };
                    }
                }
                continue;
            }
            let (a, b) = (node.first, node.first + 1);
            let (da, db) = (
                box_dist2(p, &self.nodes[a as usize]),
                box_dist2(p, &self.nodes[b as usize]),
            );
            // The nearer on top.
            if da <= db {
                stack.push((b, db));
                stack.push((a, da));
            } else {
                stack.push((a, da));
                stack.push((b, db));
            }
        }
        best
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::BvhParams;
    use crate::testing::Rng;

    /// The BVH finds the brute force's nearest distance (the same float64 evaluation on every
    /// triangle: the search may only skip what cannot be nearer), on clustered triangles,
    /// degenerate ones and points inside the tree's boxes and far away.
    #[test]
    fn nearest_is_the_brute_forces() {
        let mut rng = Rng::xorshift(17);
        let mut tris: Vec<Tri> = (0..2000)
            .map(|_| {
                let c = [0, 1, 2].map(|_| rng.f() * 4.0);
                [0, 1, 2].map(|_| [0, 1, 2].map(|k| c[k] + (rng.f() - 0.5) * 0.2))
            })
            .collect();
        tris.push([[1.0, 1.0, 1.0]; 3]);
        tris.push([[0.0; 3], [1.0, 2.0, 3.0], [2.0, 4.0, 6.0]]);
        let bvh = ReshetovBvh::build(&tris, BvhParams::default()).unwrap();
        let mut stack = Vec::new();
        for i in 0..3000 {
            let spread = [1.0, 3.0, 30.0][i % 3];
            let p = [0, 1, 2].map(|_| 2.0 + (rng.f() - 0.5) * spread);
            let got = bvh.nearest(p, &mut stack);
            let want = tris
                .iter()
                .map(|t| dist2(p, t, closest_on_triangle(p, t)))
                .fold(f64::INFINITY, f64::min);
            assert_eq!(got.distance, want.sqrt(), "point {i} {p:?}");
            let t = &tris[got.triangle as usize];
            assert_eq!(got.point, point_at(t, (got.u, got.v)));
            assert!(got.u >= 0.0 && got.v >= 0.0 && got.u + got.v <= 1.0 + 2.0 * f64::EPSILON);
        }
        let empty = ReshetovBvh::build(&[], BvhParams::default()).unwrap();
        assert_eq!(empty.nearest([0.0; 3], &mut stack).triangle, -1);
    }

    /// On a right triangle with dyadic corners the regions are exact: each vertex, each edge
    /// and the face region give the analytic nearest point, at every scale a mesh may have
    /// (powers of two from 2^-500 to 2^300 ≈ 2e90, so the scaled answer is exact too; from
    /// about 1e77 on the region tests' products overflowed, and below about 1e-77 they
    /// underflowed), on the triangle alone and found by the BVH beside a farther one.
    #[test]
    fn closest_point_regions_are_the_analytic_ones() {
        let tri = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        let cases = [
            ([-1.0, -1.0, 0.5], [0.0, 0.0, 0.0]),
            ([2.0, -0.5, 0.0], [1.0, 0.0, 0.0]),
            ([-0.5, 3.0, -1.0], [0.0, 1.0, 0.0]),
            ([0.25, -2.0, 1.0], [0.25, 0.0, 0.0]),
            ([-3.0, 0.75, 0.0], [0.0, 0.75, 0.0]),
            ([1.0, 1.0, 2.0], [0.5, 0.5, 0.0]),
            ([0.25, 0.5, -4.0], [0.25, 0.5, 0.0]),
        ];
        let mut stack = Vec::new();
        for e in [-500, -300, -200, -100, 0, 100, 200, 260, 300] {
            let s = |v: [f64; 3]| v.map(|x| times_pow2(x, e));
            let tri = tri.map(s);
            let far = [[8.0, 8.0, 8.0], [9.0, 8.0, 8.0], [8.0, 9.0, 8.0]].map(s);
            let bvh = ReshetovBvh::build(&[tri, far], BvhParams::default()).unwrap();
            for (p, want) in cases {
                let (p, want) = (s(p), s(want));
                let uv = closest_on_triangle(p, &tri);
                assert_eq!(point_at(&tri, uv), want, "2^{e}: {p:?}");
                let got = bvh.nearest(p, &mut stack);
                assert_eq!((got.triangle, got.point), (0, want), "2^{e}: {p:?}");
            }
        }
        // Zero area: the nearest point of its edges (a segment from 0 to (2, 0, 0)).
        let flat = [[0.0; 3], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]];
        assert_eq!(
            point_at(&flat, closest_on_triangle([1.5, 1.0, 0.0], &flat)),
            [1.5, 0.0, 0.0]
        );
        assert_eq!(
            point_at(&flat, closest_on_triangle([3.0, 1.0, 0.0], &flat)),
            [2.0, 0.0, 0.0]
        );
    }

    /// Triangles without area, two corners at one point (in each of the three places) or
    /// three on a line or at one point, on each axis: the nearest point is the analytic
    /// nearest point of the segment they span (its coordinate along the axis clamped to the
    /// segment; every number dyadic and every edge a power of two long, so each step is exact), and the BVH finds that triangle
    /// before a farther one. With two corners at one point, Ericson's edge region divided 0
    /// by 0 there, and the BVH answered the farther triangle.
    #[test]
    fn triangles_without_area_give_their_segments_nearest_point() {
        let far: Tri = [[50.0, 50.0, 50.0], [51.0, 50.0, 50.0], [50.0, 51.0, 50.0]];
        let mut stack = Vec::new();
        let mut rng = Rng::xorshift(5);
        let mut checked = 0;
        for axis in 0..3 {
            // Points along `axis` at s (the rest of the coordinates 0).
            let at =
                |s: f64| -> [f64; 3] { std::array::from_fn(|k| if k == axis { s } else { 0.0 }) };
            // Corners at -1, 1 and 3: every edge a power of two long, so the quotients are exact.
            let (lo, mid, hi) = (-1.0, 1.0, 3.0);
            let shapes: [[f64; 3]; 7] = [
                [lo, lo, hi],
                [lo, hi, lo],
                [hi, lo, lo],
                [lo, mid, hi],
                [hi, lo, mid],
                [mid, hi, lo],
                [mid, mid, mid],
            ];
            for shape in shapes {
                let tri: Tri = shape.map(at);
                let (lo, hi) = (
                    shape.iter().copied().fold(f64::INFINITY, f64::min),
                    shape.iter().copied().fold(f64::NEG_INFINITY, f64::max),
                );
                let bvh = ReshetovBvh::build(&[tri, far], BvhParams::default()).unwrap();
                for _ in 0..200 {
                    // Dyadic points within a few units: along the axis before, on and past the
                    // segment, off it by up to 3 on the other axes.
                    let p: [f64; 3] = std::array::from_fn(|_| (rng.f() * 64.0).floor() / 8.0 - 3.0);
                    let want: [f64; 3] =
                        std::array::from_fn(|k| if k == axis { p[k].clamp(lo, hi) } else { 0.0 });
                    let uv = closest_on_triangle(p, &tri);
                    assert_eq!(point_at(&tri, uv), want, "{tri:?}, point {p:?}: {uv:?}");
                    let got = bvh.nearest(p, &mut stack);
                    let d2: f64 = (0..3).map(|k| (p[k] - want[k]) * (p[k] - want[k])).sum();
                    assert_eq!(got.triangle, 0, "{tri:?}, point {p:?}: {got:?}");
                    assert_eq!(
                        (got.point, got.distance),
                        (want, d2.sqrt()),
                        "{tri:?}, {p:?}"
                    );
                    checked += 1;
                }
            }
        }
        assert_eq!(checked, 3 * 7 * 200);
    }
}
