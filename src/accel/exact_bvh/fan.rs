//! Rays that share their origin (a camera, a LiDAR sensor, shadow rays towards one light),
//! answered through a grid over their directions: the fan (issue 35, item 5).
//!
//! Seen from the origin o, each of the six sides of a cube around o holds the directions
//! whose largest component is on its axis a with its sign s: a ray with direction d is on the
//! side of its largest |d_a| (the first such axis), at the point (u, v) = (d_b, d_c) / |d_a|
//! (b, c the other two axes in turn), and every point o + t d, t > 0, of the ray projects
//! there: a point p with w = s (p_a − o_a) > 0 projects to ((p_b − o_b) / w, (p_c − o_c) / w).
//!
//! A triangle whose three corners have w > 0 projects to the triangle of its corners'
//! projections (a central projection keeps segments in the half-space w > 0), so a ray of
//! that side meets it only if the ray's (u, v) lies in the box of those three points. Those
//! boxes, padded by a bound on the roundings of both sides (below), give each triangle the
//! grid cells it may be met from; the cells' lists are the triangles to test, in order of a
//! lower bound on their w, so that a ray stops once that bound, over |d_a|, passes its reach.
//! A triangle with every corner at w < 0 lies behind the side (a ray there meets it at no
//! t ≥ 0). One that straddles (a corner at w ≤ 0, another at w ≥ 0: the floor and walls
//! around an eye inside a room) is met at t > 0 only where w > 0, a region whose projection
//! runs to infinity as w → 0 towards the sign its points' (p_b − o_b) have there: where the
//! three corners' have one sign, it is bounded on the other side by its corners ahead (a
//! quotient of linear functions over a convex polygon takes its extremes at the corners, the
//! ones at w = 0 lying at infinity). So a floor under the eye is listed in the cells below its
//! far corners only. It is listed from w = 0 (t from 0); one that is unbounded along both axes,
//! and one whose closed box holds the origin (a ray may meet it at t = 0, whatever its
//! direction), is tested by every ray of the side.
//!
//! The grid decides nothing: each triangle listed is tested exactly (`Line::meets_at`) and
//! offered to the query, which keeps what it asks for whatever the order. So every answer is
//! the exact BVH's, bit for bit (`steps`, here the triangles tested, aside).
//!
//! **The padding.** A corner's projection is four roundings from its exact value x (two
//! differences, a reciprocal, a product), the ray's (u, v) two (a reciprocal, a product):
//! each within 2^-49 of the value relative (the reciprocal's error stays within 2^-50 where it
//! is subnormal), plus 2^-1074 where a product underflows. A ray that meets the triangle has
//! its exact (u, v) in the exact box, so its computed (u, v) lies within the computed box
//! widened by 2^-48 times the largest magnitude plus 2^-1073; the pad, 10^-300 plus
//! (|lo| + |hi|) · 2^-44, is 16 times that, and its own roundings are within its slack. A
//! corner whose projection is not finite (its w so small that the reciprocal overflows) puts
//! the triangle on the list every ray tests. The cell of a coordinate, `floor((x − x0) · k)`
//! clamped to the grid, is a non-decreasing function of x (each rounded operation is), so the
//! ray's cell lies within the cells of the padded box.
//!
//! **The stop.** A point of the triangle has w at least its corners' least (w is linear), and
//! a ray meets it at t = w / |d_a|. The least w, computed, is within a rounding of the exact;
//! it is kept as a float32 rounded down below it (`wlo`), so the ray meets the triangle at no
//! t below wlo / |d_a|. The lists are sorted by wlo, so once wlo passes reach · |d_a| (the
//! product made a little larger than its roundings can lower it) no later triangle of the
//! cell can be wanted.

use super::{down32, ExactBvh, State};
use crate::accel::Accel;
use crate::geom::ray::{checked_range, Ray};
use crate::query::gather::{Gather, Line};
use crate::query::{QueryKind, Sink};
use std::mem::MaybeUninit;

/// Rays per cell the grid aims at (more cells: fewer triangles tested a ray, more entries).
const RAYS_PER_CELL: usize = 8;
/// At most this many cells along one side's axis.
const MAX_CELLS_AXIS: usize = 4096;
/// A side whose triangles spanning w = 0 (tested by every ray of the side) are more than this
/// declines the fan: its rays are walked by the tree.
const MAX_ALWAYS: usize = 32;
/// The pad of a projected box: relative and absolute (see the module's notes).
const PAD_REL: f64 = 1.0 / (1u64 << 44) as f64;
const PAD_ABS: f64 = 1e-300;
/// What the stop's bound on w is raised by: more than its two roundings (two products).
const STOP_GROW: f64 = 1.0 + 1.0 / (1u64 << 50) as f64;
/// The w bound is kept lowered by this: more than the rounding of the least w.
const W_SHRINK: f64 = 1.0 - 1.0 / (1u64 << 50) as f64;
/// Rays read ahead of their tests ([`Fan::trace_chunk`]).
const AHEAD: usize = 16;

/// A ray's side and its point there: (side 2a + (d_a < 0), u, v), or None for a direction
/// with no component (not traced) or one not finite.
#[inline(always)]
pub fn project(d: [f64; 3]) -> Option<(usize, f64, f64)> {
    let m = d.map(f64::abs);
    // The axis and the other two in turn, each picked whole: indexed by a computed axis, the
    // components went through the stack (about 45 instructions a ray, twice: the build's box
    // and the ray's cell).
    let (a, da, db, dc) = if m[0] >= m[1] && m[0] >= m[2] {
        (0, d[0], d[1], d[2])
    } else if m[1] >= m[2] {
        (1, d[1], d[2], d[0])
    } else {
        (2, d[2], d[0], d[1])
    };
    let ma = da.abs();
    // One division: two roundings from the exact quotient, within the pad (module notes).
    let r = 1.0 / ma;
    let (u, v) = (db * r, dc * r);
    (ma > 0.0 && u.is_finite() && v.is_finite()).then_some((2 * a + (da < 0.0) as usize, u, v))
}

/// The cell of coordinate `x` on an axis of `n` cells from `x0`, `k` cells a unit: clamped to
/// the grid, and non-decreasing in x.
#[inline(always)]
fn cell(x: f64, x0: f64, k: f64, n: usize) -> usize {
    // floor, then clamped: truncation equals floor where it is kept (x ≥ 0; below, 0 either
    // way), and NaN goes to 0. No call to `floor` (baseline x86-64 has no rounding instruction).
    let x = (x - x0) * k;
    // Clamped as a float first, so that the conversion is one truncation: `as usize` alone
    // saturates, about ten instructions on x86-64, twice a ray (and so would `(n − 1) as
    // f64`; n is far below 2^32: MAX_CELLS_AXIS, or a test grid's 2^20).
    debug_assert!(n <= u32::MAX as usize);
    if x >= (n - 1) as u32 as f64 {
        n - 1
    } else if x > 0.0 {
        // SAFETY: 0 < x < n − 1, so its truncation is an integer in range (not NaN: a NaN
        // fails both comparisons and goes to 0).
        unsafe { x.to_int_unchecked::<u32>() as usize }
    } else {
        0
    }
}

/// One side's grid: `nu` × `nv` cells over the box of its rays' (u, v), each cell's
/// triangles (`start`, `items`: float32 lower bound on w, index in the tree's leaf order) in
/// increasing order of the bound, and the triangles every ray of the side tests.
struct Side {
    axes: [usize; 3],
    lo: [f64; 2],
    k: [f64; 2],
    n: [usize; 2],
    start: Vec<u32>,
    items: Vec<(f32, u32)>,
    always: Vec<u32>,
}

/// A triangle's place on a side: listed in cells `c0..=c1` (per axis) with its w bound, tested
/// by every ray, or behind.
enum Place {
    Cells([usize; 2], [usize; 2], f32),
    Always,
    Behind,
}

impl Side {
    /// Where the triangle `tri` lies on side (a, s) seen from `o`, against the rays' box `lo..hi`
    /// on a grid of `n` cells, `k` a unit.
    fn place(
        o: [f64; 3],
        axes: [usize; 3],
        sign: f64,
        tri: &[[f64; 3]; 3],
        (lo, hi): ([f64; 2], [f64; 2]),
        (k, n): ([f64; 2], [usize; 2]),
    ) -> Place {
        let [a, b, c] = axes;
        // The sign of a difference of two floats is exact.
        let w = tri.map(|p| sign * (p[a] - o[a]));
        if w.iter().all(|&x| x < 0.0) {
            return Place::Behind;
        }
        let ahead = w.map(|x| x > 0.0);
        let straddles = !ahead.iter().all(|&x| x);
        if straddles {
            // A ray meets it at t > 0 only where w > 0 (w = t |d_a|), and at t = 0 only at
            // the origin: a triangle whose closed box holds the origin is tested by every ray.
            let holds = (0..3).all(|k| {
                let (l, h) = (
                    tri[0][k].min(tri[1][k]).min(tri[2][k]),
                    tri[0][k].max(tri[1][k]).max(tri[2][k]),
                );
                l <= o[k] && o[k] <= h
            });
            if holds {
                return Place::Always;
            }
            if !ahead.iter().any(|&x| x) {
                return Place::Behind;
            }
        }
        let r = w.map(|w| 1.0 / w);
        let mut c0 = [0usize; 2];
        let mut c1 = [0usize; 2];
        let mut bounded = false;
        for (i, axis) in [b, c].into_iter().enumerate() {
            let q = tri.map(|p| p[axis] - o[axis]);
            // The corners ahead, projected (each checked: min and max pass over a NaN, 0 · ∞
            // where w is so small that its reciprocal overflows).
            let (mut xlo, mut xhi, mut finite) = (f64::INFINITY, f64::NEG_INFINITY, true);
            for j in (0..3).filter(|&j| ahead[j]) {
                let x = q[j] * r[j];
                finite &= x.is_finite();
                (xlo, xhi) = (xlo.min(x), xhi.max(x));
            }
            if !finite && !straddles {
                return Place::Always;
            }
            let (mut plo, mut phi) = (f64::NEG_INFINITY, f64::INFINITY);
            if finite {
                let pad = (xlo.abs() + xhi.abs()) * PAD_REL + PAD_ABS;
                // A triangle that straddles w = 0 projects to a region that runs to infinity
                // as w → 0, towards the sign its points' q have there: it is bounded on the
                // other side (by its corners ahead) only where all three q have one sign.
                if !straddles || q.iter().all(|&x| x > 0.0) {
                    plo = xlo - pad;
                }
                if !straddles || q.iter().all(|&x| x < 0.0) {
                    phi = xhi + pad;
                }
            }
            bounded |= plo > f64::NEG_INFINITY || phi < f64::INFINITY;
            // Every ray's (u, v) lies in lo..hi: a box wholly outside is met by none.
            if phi < lo[i] || plo > hi[i] {
                return Place::Behind;
            }
            c0[i] = cell(plo, lo[i], k[i], n[i]);
            c1[i] = cell(phi, lo[i], k[i], n[i]);
        }
        if !bounded {
            return Place::Always;
        }
        // Straddling: points near the origin's plane, t from 0.
        let wlo = if straddles {
            0.0
        } else {
            down32(w[0].min(w[1]).min(w[2]) * W_SHRINK)
        };
        Place::Cells(c0, c1, wlo)
    }
}

/// The fan over a batch of rays from one origin: the tree's triangles gridded per side.
pub struct Fan<'a> {
    pub bvh: &'a ExactBvh,
    pub simd: crate::simd::Simd,
    o: [f64; 3],
    sides: [Option<Side>; 6],
    /// Per triangle (by leaf order), its edges' terms that depend on the origin alone
    /// ([`edge_terms`]).
    edges: Vec<Edges>,
    /// Triangle entries over all cells (a measure of the build).
    pub entries: usize,
}

/// Of a triangle seen from the fan's origin, per edge k (corners b = k, c = k + 1 less the
/// origin): the three 2×2 minors of `det_perm(d, b, c)` and the three sums of their products'
/// magnitudes, row by row (`[m0, m1, m2, s0, s1, s2]`, each over the edges k = 0, 1, 2 and a
/// fourth lane of zeros, never certain), so that [`edge_signs_avx2`] takes the three edges side
/// by side in vector registers (read edge by edge, its scalar code cost 82 instructions a
/// triangle on bunny's camera). Aligned so that a row is one aligned load.
#[derive(Clone, Copy)]
#[repr(C, align(32))]
struct Edges([[f64; 4]; 6]);

/// Triangle `tri`'s [`Edges`] from `o`, formed as `geom::exact::det_perm` forms them (the leaf
/// filter's `leaf_edges_avx2!`): the rays of a fan share the origin, so each ray takes only
/// their products with its direction.
fn edge_terms(o: [f64; 3], tri: &[[f64; 3]; 3]) -> Edges {
    let p = tri.map(|v| [v[0] - o[0], v[1] - o[1], v[2] - o[2]]);
    let mut rows = [[0.0; 4]; 6];
    for k in 0..3 {
        let (b, c) = (p[k], p[(k + 1) % 3]);
        let terms = [
            b[1] * c[2] - b[2] * c[1],
            b[0] * c[2] - b[2] * c[0],
            b[0] * c[1] - b[1] * c[0],
            (b[1] * c[2]).abs() + (b[2] * c[1]).abs(),
            (b[0] * c[2]).abs() + (b[2] * c[0]).abs(),
            (b[0] * c[1]).abs() + (b[1] * c[0]).abs(),
        ];
        for (row, x) in rows.iter_mut().zip(terms) {
            row[k] = x;
        }
    }
    Edges(rows)
}

/// The signs of the three side products of the line with direction `dir` (the line's scaled
/// direction, as `Line::meets_at` takes it) from the fan's origin, from [`edge_terms`],
/// certified as `geom::exact::triangle_sides` certifies them (the same products and sums in the
/// same order, `|det| > DET_BOUND · perm` with the permanent finite and above TINY): whether
/// the line may meet the triangle (no two of certain opposite signs), and whether all three
/// are certain and of one sign (then it meets the closed triangle at one point). The portable
/// twin of [`edge_signs_avx2`], edge by edge.
#[inline(always)]
fn edge_signs(dir: [f64; 3], e: &Edges) -> (bool, bool) {
    use crate::geom::exact::{DET_BOUND, TINY};
    let a = dir.map(f64::abs);
    let [m0, m1, m2, s0, s1, s2] = &e.0;
    let (mut pos, mut neg) = (0u32, 0u32);
    for k in 0..3 {
        let det = dir[0] * m0[k] - dir[1] * m1[k] + dir[2] * m2[k];
        let perm = a[0] * s0[k] + a[1] * s1[k] + a[2] * s2[k];
        let bound = DET_BOUND * perm;
        let ok = perm.is_finite() && perm > TINY;
        pos += (ok && det > bound) as u32;
        neg += (ok && -det > bound) as u32;
    }
    (pos == 0 || neg == 0, pos == 3 || neg == 3)
}

/// [`edge_signs`] in AVX2, a lane per edge ([`certified_sign_avx2!`], the leaf filter's own
/// operations; the portable code, left scalar by LLVM, cost 72 instructions a triangle).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
unsafe fn edge_signs_avx2(line: &Line, e: &Edges) -> (bool, bool) {
    use std::arch::x86_64::*;
    let r = &e.0;
    let terms = [
        _mm256_load_pd(r[0].as_ptr()),
        _mm256_load_pd(r[1].as_ptr()),
        _mm256_load_pd(r[2].as_ptr()),
        _mm256_load_pd(r[3].as_ptr()),
        _mm256_load_pd(r[4].as_ptr()),
        _mm256_load_pd(r[5].as_ptr()),
    ];
    let (dv, da) = direction_avx2!(line);
    let (p, n) = certified_sign_avx2!(&dv, &da, terms);
    let (pos, neg) = (_mm256_movemask_pd(p), _mm256_movemask_pd(n));
    (pos == 0 || neg == 0, pos == 0b111 || neg == 0b111)
}

/// [`edge_signs`], in AVX2 where the cast runs compiled for it (`AVX2`: only
/// [`Fan::trace_chunk_avx2`] sets it).
#[inline(always)]
fn filter<const AVX2: bool>(line: &Line, e: &Edges) -> (bool, bool) {
    #[cfg(target_arch = "x86_64")]
    if AVX2 {
        // SAFETY: set only inside a function compiled for AVX2 and FMA, which runs only where
        // the CPU has them.
        return unsafe { edge_signs_avx2(line, e) };
    }
    edge_signs(line.dir, e)
}

impl<'a> Fan<'a> {
    /// The fan for `n` rays from `o` whose directions are `dir(0..n)` (the batch's, each as
    /// the cast will read it), built on `threads` (as a cast's), or None where it does not
    /// apply: a side with too many triangles every ray would test (an origin among many
    /// triangles that straddle its planes).
    pub fn build(
        bvh: &'a ExactBvh,
        simd: crate::simd::Simd,
        o: [f64; 3],
        n: usize,
        dir: &(impl Fn(usize) -> [f64; 3] + Sync),
        threads: Option<usize>,
    ) -> Option<Fan<'a>> {
        if !o.iter().all(|x| x.is_finite()) {
            return None;
        }
        crate::threads::install(threads, || Fan::build_here(bvh, simd, o, n, dir))
            .ok()
            .flatten()
    }

    /// [`Fan::build`] inside the cast's pool: every stage split over its threads (a camera
    /// puts most of its rays on one side, so a thread per side left the others idle).
    fn build_here(
        bvh: &'a ExactBvh,
        simd: crate::simd::Simd,
        o: [f64; 3],
        n: usize,
        dir: &(impl Fn(usize) -> [f64; 3] + Sync),
    ) -> Option<Fan<'a>> {
        use rayon::prelude::*;
        // Per side: its rays' count and the box of their (u, v), over pieces of the rays.
        type Boxes = ([usize; 6], [[f64; 2]; 6], [[f64; 2]; 6]);
        let empty: Boxes = ([0; 6], [[f64::INFINITY; 2]; 6], [[f64::NEG_INFINITY; 2]; 6]);
        const PIECE: usize = 1 << 14;
        fn merge(b: &mut Boxes, (s, count, lo, hi): (usize, usize, [f64; 2], [f64; 2])) {
            if s < 6 {
                b.0[s] += count;
                b.1[s] = [b.1[s][0].min(lo[0]), b.1[s][1].min(lo[1])];
                b.2[s] = [b.2[s][0].max(hi[0]), b.2[s][1].max(hi[1])];
            }
        }
        let (count, lo, hi) = (0..n.div_ceil(PIECE))
            .into_par_iter()
            .map(|p| {
                let mut boxes = empty;
                // A run of rays on one side (consecutive rays mostly are) grows its box in
                // registers, merged into the side's where the run ends: indexed by side ray by
                // ray, each update waited for the last one's store.
                let mut run = (usize::MAX, 0, [f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
                for i in p * PIECE..(n.min((p + 1) * PIECE)) {
                    if let Some((s, u, v)) = project(dir(i)) {
                        if s != run.0 {
                            merge(&mut boxes, run);
                            run = (s, 0, [u, v], [u, v]);
                        }
                        run.1 += 1;
                        run.2 = [run.2[0].min(u), run.2[1].min(v)];
                        run.3 = [run.3[0].max(u), run.3[1].max(v)];
                    }
                }
                merge(&mut boxes, run);
                boxes
            })
            .reduce(
                || empty,
                |mut boxes, (c, l, h)| {
                    for s in 0..6 {
                        merge(&mut boxes, (s, c[s], l[s], h[s]));
                    }
                    boxes
                },
            );
        let mut sides: [Option<Side>; 6] = Default::default();
        let mut entries = 0;
        for s in (0..6).filter(|&s| count[s] > 0) {
            let side = Fan::side(bvh, o, s, count[s], (lo[s], hi[s]))?;
            entries += side.items.len();
            sides[s] = Some(side);
        }
        // Every triangle's (one not listed costs a few products, less than finding which are).
        let edges = bvh.triangles.par_iter().map(|t| edge_terms(o, t)).collect();
        Some(Fan {
            bvh,
            simd,
            o,
            sides,
            edges,
            entries,
        })
    }

    /// Triangles tested by every ray of their side, over the sides built.
    pub fn always(&self) -> usize {
        self.sides.iter().flatten().map(|s| s.always.len()).sum()
    }

    /// Side `s`'s grid for its `rays` rays in the box `lo..hi` of their (u, v), built on the
    /// current pool's threads.
    fn side(
        bvh: &ExactBvh,
        o: [f64; 3],
        s: usize,
        rays: usize,
        (lo, hi): ([f64; 2], [f64; 2]),
    ) -> Option<Side> {
        use rayon::prelude::*;
        let a = s / 2;
        let axes = [a, (a + 1) % 3, (a + 2) % 3];
        let sign = if s.is_multiple_of(2) { 1.0 } else { -1.0 };
        let extent = [hi[0] - lo[0], hi[1] - lo[1]];
        // Cells about RAYS_PER_CELL rays each, square in (u, v) where the rays' box allows.
        let cells = (rays / RAYS_PER_CELL).max(1) as f64;
        let mut n = if extent[0] > 0.0 && extent[1] > 0.0 {
            let nu = (cells * extent[0] / extent[1]).sqrt().round().max(1.0);
            [nu, (cells / nu).round().max(1.0)]
        } else if extent[0] > 0.0 {
            [cells, 1.0]
        } else if extent[1] > 0.0 {
            [1.0, cells]
        } else {
            [1.0, 1.0]
        }
        .map(|x| (x as usize).clamp(1, MAX_CELLS_AXIS));
        // Fewer cells where the triangles' boxes cover too many: entries at most a few per ray
        // and per triangle.
        let budget = 8 * rays + 4 * bvh.triangles.len();
        const CHUNK: usize = 1 << 12;
        loop {
            let k = [0, 1].map(|i| {
                if extent[i] > 0.0 {
                    n[i] as f64 / extent[i]
                } else {
                    0.0
                }
            });
            // Placed in chunks of triangles, in parallel, and joined in the triangles' order.
            type Part = (Vec<([usize; 2], [usize; 2], f32, u32)>, Vec<u32>, usize);
            let parts: Vec<Part> = bvh
                .triangles
                .par_chunks(CHUNK)
                .enumerate()
                .map(|(c, tris)| {
                    let (mut placed, mut always, mut total) = (Vec::new(), Vec::new(), 0);
                    for (i, tri) in tris.iter().enumerate() {
                        let j = (c * CHUNK + i) as u32;
                        match Side::place(o, axes, sign, tri, (lo, hi), (k, n)) {
                            Place::Cells(c0, c1, wlo) => {
                                total += (c1[0] - c0[0] + 1) * (c1[1] - c0[1] + 1);
                                placed.push((c0, c1, wlo, j));
                            }
                            Place::Always => always.push(j),
                            Place::Behind => {}
                        }
                    }
                    (placed, always, total)
                })
                .collect();
            let always: Vec<u32> = parts.iter().flat_map(|p| p.1.iter().copied()).collect();
            if always.len() > MAX_ALWAYS {
                return None;
            }
            let total: usize = parts.iter().map(|p| p.2).sum();
            if total > budget && n != [1, 1] {
                n = n.map(|x| x.div_ceil(2));
                continue;
            }
            if total >= u32::MAX as usize {
                return None;
            }
            let mut placed = Vec::with_capacity(parts.iter().map(|p| p.0.len()).sum());
            for p in parts {
                placed.extend(p.0);
            }
            // Nearest bound first: each cell's list, filled in this order, comes out sorted
            // (one sort of the triangles, not one of every cell's entries: those cost more than
            // the rest of the build).
            placed.par_sort_unstable_by(|x, y| x.2.total_cmp(&y.2).then(x.3.cmp(&y.3)));
            // Bands of rows, several a thread: each counts, then fills, its own cells (a band's
            // lists are a part of the side's, so its writes, scattered in the triangles' order,
            // fall in fewer cache lines).
            let rows = n[1].div_ceil(4 * rayon::current_num_threads());
            let bands = n[1].div_ceil(rows);
            let band = |b: usize| {
                let (r0, r1) = (b * rows, ((b + 1) * rows).min(n[1]));
                let over = placed.iter().filter(move |p| p.0[1] < r1 && p.1[1] >= r0);
                (
                    r0,
                    r1,
                    over.map(move |&(c0, c1, wlo, j)| {
                        (c0[0]..=c1[0], c0[1].max(r0)..=c1[1].min(r1 - 1), wlo, j)
                    }),
                )
            };
            let ncells = n[0] * n[1];
            let mut start = vec![0u32; ncells + 1];
            start[1..]
                .par_chunks_mut(rows * n[0])
                .enumerate()
                .for_each(|(b, counts)| {
                    let (r0, _, over) = band(b);
                    for (us, vs, _, _) in over {
                        for cv in vs {
                            for cu in us.clone() {
                                counts[(cv - r0) * n[0] + cu] += 1;
                            }
                        }
                    }
                });
            for i in 0..ncells {
                start[i + 1] += start[i];
            }
            let mut items = vec![(0f32, 0u32); total];
            let mut slices = Vec::with_capacity(bands);
            let mut rest = &mut items[..];
            for b in 0..bands {
                let (r0, r1) = (b * rows, ((b + 1) * rows).min(n[1]));
                let len = (start[r1 * n[0]] - start[r0 * n[0]]) as usize;
                let (here, later) = rest.split_at_mut(len);
                slices.push(here);
                rest = later;
            }
            slices.into_par_iter().enumerate().for_each(|(b, out)| {
                let (r0, r1, over) = band(b);
                let (c0, c1) = (r0 * n[0], r1 * n[0]);
                let base = start[c0];
                let mut fill: Vec<u32> = start[c0..c1].iter().map(|&x| x - base).collect();
                for (us, vs, wlo, j) in over {
                    for cv in vs {
                        for cu in us.clone() {
                            let f = &mut fill[cv * n[0] + cu - c0];
                            out[*f as usize] = (wlo, j);
                            *f += 1;
                        }
                    }
                }
            });
            return Some(Side {
                axes,
                lo,
                k,
                n,
                start,
                items,
                always,
            });
        }
    }

    /// Where the fan holds `ray`: its side's items (the cell's range) and |d_a|; None where
    /// it does not (another origin, a side not built: the tree walks it).
    #[inline(always)]
    fn cell_of(&self, ray: &Ray) -> Option<(usize, std::ops::Range<usize>, f64)> {
        if ray.o != self.o {
            return None;
        }
        let (s, u, v) = project(ray.d)?;
        let side = self.sides[s].as_ref()?;
        let c = cell(v, side.lo[1], side.k[1], side.n[1]) * side.n[0]
            + cell(u, side.lo[0], side.k[0], side.n[0]);
        let items = side.start[c] as usize..side.start[c + 1] as usize;
        Some((s, items, ray.d[side.axes[0]].abs()))
    }

    /// Offers `gather` the triangles side `s` tests for every ray, then its `items`, nearest
    /// bound first, until the bound passes the reach; the triangles tested.
    #[inline(always)]
    fn offer<G: Gather, const AVX2: bool>(
        &self,
        line: &Line,
        gather: &mut G,
        (s, items, da): (usize, std::ops::Range<usize>, f64),
    ) -> u32 {
        let Some(side) = self.sides[s].as_ref() else {
            return 0;
        };
        let mut tested = 0u32;
        for &j in &side.always {
            tested += 1;
            if self.test::<G, AVX2>(line, gather, j as usize) {
                return tested;
            }
        }
        // w beyond this: t beyond the reach (see the module's notes).
        let mut limit = gather.reach() * da * STOP_GROW;
        for &(wlo, j) in &side.items[items] {
            if wlo as f64 > limit {
                break;
            }
            tested += 1;
            if self.test::<G, AVX2>(line, gather, j as usize) {
                break;
            }
            limit = gather.reach() * da * STOP_GROW;
        }
        tested
    }

    /// Offers `gather` triangle `j` (leaf order) if the ray meets it; true: settled. Inlined
    /// into both of [`Fan::offer`]'s loops: as a call, its prologue and epilogue (registers
    /// saved and restored) cost about 16 instructions a triangle.
    #[inline(always)]
    fn test<G: Gather, const AVX2: bool>(&self, line: &Line, gather: &mut G, j: usize) -> bool {
        let bvh = self.bvh;
        let tri = &bvh.triangles[j];
        // The filter first, as a leaf of the tree filters (`offer_leaf`).
        let (may, sure) = filter::<AVX2>(line, &self.edges[j]);
        if !may {
            return false;
        }
        let met = if sure {
            line.crosses_at(tri)
        } else {
            line.meets_at(tri)
        };
        match met {
            Some(at) => gather.offer(bvh.order[j], tri, at),
            None => gather.in_plane(bvh.order[j]),
        }
    }
}

impl Accel<f64> for Fan<'_> {
    const NAME: &'static str = "exact_bvh";
    type State = State;

    fn state(&self, chunk: usize) -> State {
        super::ExactBvhAt {
            bvh: self.bvh,
            simd: self.simd,
        }
        .state(chunk)
    }

    fn trace<K: QueryKind>(&self, query: &K, ray: &Ray, st: &mut State) -> K::Answer {
        let (tmin, tmax) = match checked_range(ray) {
            Ok(range) => range,
            Err(status) => return query.skipped(status),
        };
        let at = self.cell_of(ray);
        self.answer::<K, false>(query, &Line::within(ray, tmin, tmax), at, st)
    }

    /// Through [`Fan::trace_chunk_with`], compiled for the cast's SIMD level.
    fn trace_chunk<K: QueryKind, S: Sink<K::Answer>>(
        &self,
        query: &K,
        ray_at: impl Fn(usize) -> Ray,
        out: &mut S,
        st: &mut State,
    ) {
        #[cfg(target_arch = "x86_64")]
        if self.simd == crate::simd::Simd::Avx2 {
            // SAFETY: Simd::Avx2 is only chosen where the CPU has AVX2 and FMA
            // (`Simd::supported`).
            return unsafe { self.trace_chunk_avx2(query, ray_at, out, st) };
        }
        self.trace_chunk_with::<K, S, false>(query, ray_at, out, st)
    }
}

impl Fan<'_> {
    /// [`Fan::trace_chunk_with`] compiled for AVX2 and FMA, so that [`edge_signs`] takes a
    /// triangle's three edges in one vector register each. Rust never fuses `a * b + c` on
    /// its own, so everything rounds as the portable code does.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn trace_chunk_avx2<K: QueryKind, S: Sink<K::Answer>>(
        &self,
        query: &K,
        ray_at: impl Fn(usize) -> Ray,
        out: &mut S,
        st: &mut State,
    ) {
        self.trace_chunk_with::<K, S, true>(query, ray_at, out, st)
    }

    /// In passes over [`AHEAD`] rays at a time, each writing what the next reads (the rays,
    /// then their ranges and cells, then the tests): made one ray at a time, each ray's parts
    /// were stored in pieces and read back whole at once, and the reads waited for the
    /// stores to retire (as the exact BVH's `make_ready` found). The second pass writes each
    /// ray's `Line` field by field ([`Line::write_within`]): put in the pass's buffer whole, it
    /// was copied by a library call; made in the last pass, it was moved by wide reads of its
    /// pieces just stored.
    #[inline(always)]
    fn trace_chunk_with<K: QueryKind, S: Sink<K::Answer>, const AVX2: bool>(
        &self,
        query: &K,
        ray_at: impl Fn(usize) -> Ray,
        out: &mut S,
        st: &mut State,
    ) {
        type Ready = (usize, Option<(usize, std::ops::Range<usize>, f64)>);
        let mut next = 0;
        while next < out.len() {
            let first = next;
            let read = AHEAD.min(out.len() - first);
            next += read;
            let mut rays = [const { MaybeUninit::<Ray>::uninit() }; AHEAD];
            for (k, ray) in rays[..read].iter_mut().enumerate() {
                ray.write(ray_at(first + k));
            }
            let mut lines = [const { MaybeUninit::<Line>::uninit() }; AHEAD];
            let mut ready = [const { MaybeUninit::<Ready>::uninit() }; AHEAD];
            let mut count = 0;
            for (k, ray) in rays[..read].iter().enumerate() {
                // SAFETY: the first pass wrote rays 0..read.
                let ray = unsafe { ray.assume_init_ref() };
                match checked_range(ray) {
                    Ok((tmin, tmax)) => {
                        Line::write_within(&mut lines[count], ray, tmin, tmax);
                        ready[count].write((first + k, self.cell_of(ray)));
                        count += 1;
                    }
                    Err(status) => out.put(first + k, query.skipped(status)),
                }
            }
            for (line, entry) in lines[..count].iter().zip(&ready[..count]) {
                // SAFETY: the second pass wrote entries 0..count of both.
                let (line, (j, at)) = unsafe { (line.assume_init_ref(), entry.assume_init_ref()) };
                out.put(*j, self.answer::<K, AVX2>(query, line, at.clone(), st));
            }
        }
    }
}

impl Fan<'_> {
    /// The answer for a ray of line `line` held by the fan at `at`, else walked by the tree.
    #[inline(always)]
    fn answer<K: QueryKind, const AVX2: bool>(
        &self,
        query: &K,
        line: &Line,
        at: Option<(usize, std::ops::Range<usize>, f64)>,
        st: &mut State,
    ) -> K::Answer {
        let mut gather = query.gather(line);
        let visited = match at {
            Some(at) => self.offer::<_, AVX2>(line, &mut gather, at),
            None => self.bvh.walk(line, &mut gather, st.simd, &mut st.stack),
        };
        query.gathered(&mut gather, visited)
    }
}

/// For the tests: the side of a ray with direction `d` and its cell on a grid of cells of
/// `fine` around its (u, v) (a million cells each way, the ray near the middle).
#[cfg(test)]
pub(super) fn cell_of_test(d: [f64; 3], fine: f64) -> Option<(usize, [usize; 2], TestGrid)> {
    let (s, u, v) = project(d)?;
    let n = [1 << 20; 2];
    let lo = [u - fine * (1 << 19) as f64, v - fine * (1 << 19) as f64];
    let k = [1.0 / fine; 2];
    let cells = [cell(u, lo[0], k[0], n[0]), cell(v, lo[1], k[1], n[1])];
    Some((s, cells, (lo, k, n)))
}

/// A test grid: its low corner, cells a unit, cells per axis.
#[cfg(test)]
pub(super) type TestGrid = ([f64; 2], [f64; 2], [usize; 2]);

/// For the tests: triangle `tri`'s cells on side `s` of that grid (None: tested by every
/// ray; a triangle placed behind is an empty range), and whether it straddles w = 0.
#[cfg(test)]
pub(super) fn place_test(
    o: [f64; 3],
    s: usize,
    tri: &[[f64; 3]; 3],
    (lo, k, n): TestGrid,
) -> (Option<[[usize; 2]; 2]>, bool) {
    let a = s / 2;
    let axes = [a, (a + 1) % 3, (a + 2) % 3];
    let sign = if s.is_multiple_of(2) { 1.0 } else { -1.0 };
    let hi = [0, 1].map(|i| lo[i] + n[i] as f64 / k[i]);
    let straddles = !tri.iter().all(|p| sign * (p[a] - o[a]) > 0.0);
    let placed = match Side::place(o, axes, sign, tri, (lo, hi), (k, n)) {
        Place::Cells(c0, c1, _) => Some([c0, c1]),
        Place::Always => None,
        Place::Behind => Some([[1, 1], [0, 0]]),
    };
    (placed, straddles)
}
