//! An exact 8-wide BVH (issue 35): the binned-SAH tree of `reshetov_bvh`, collapsed so that
//! each node holds the boxes of up to eight children, tested for one ray at once in float32
//! (AVX2 + FMA where the CPU has them; the portable code rounds the same operations the same
//! way, so the two visit the same nodes in the same order).
//!
//! The tree decides nothing itself, as Reshetov's does not: a child is skipped only when the
//! ray surely misses its box within [tmin, reach], and a triangle is offered to the query only
//! when the ray meets it exactly (`query::gather::Line::meets`). The float32 box test is made
//! conservative in three places (see [`RayBoxes`] for the bound):
//! - the boxes are rounded outward from the float64 triangles' (`reshetov_bvh`);
//! - the origin's rounding to float32 is folded into the per-axis constant of the fused
//!   multiply-add, `t = fma(plane, 1/d, −c)`, so that `t` is below the exact entry (above the
//!   exact exit) before its one rounding;
//! - the entry and exit over the three axes are padded by a relative bound and an absolute one
//!   for what underflows.
//!
//! A ray whose direction has a component whose float32 reciprocal is not a finite normal
//! number (tiny or huge components) or whose origin is past float32's range is tested in
//! float64 against the same boxes (`reshetov_bvh`'s slab test), as is a ray with a zero
//! component in a tree with an infinite box. So every answer is the exact one, as the exact
//! walk's and Reshetov's BVH's are.

#[cfg(target_arch = "x86_64")]
use std::mem::ManuallyDrop;
use std::mem::MaybeUninit;

use super::reshetov_bvh::{down32, max32, min32, up32, BvhNode, Slab};
use super::{trace_each, Accel, BvhParams, ReshetovBvh};
use crate::error::{Error, Result};
use crate::geom::ray::Ray;
#[cfg(target_arch = "x86_64")]
use crate::geom::ray::{checked_range, valid_range};
use crate::query::gather::{Gather, Line, Tri};
use crate::query::{QueryKind, Sink};
use crate::simd::Simd;

/// Children per node.
pub const WIDTH: usize = 8;

/// One node, 224 bytes: its children's boxes in float32 rounded outward, one row per bound
/// (lo x, lo y, lo z, hi x, hi y, hi z: the row of axis k's lower plane is k, its upper 3 + k),
/// and what each child is ([`Child`]). An unused slot has the empty box (lo = f32::MAX, hi =
/// −f32::MAX), which every ray misses on its first axis with a direction.
#[repr(C, align(32))]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Node8 {
    pub bounds: [[f32; WIDTH]; 6],
    pub child: [u32; WIDTH],
}

const _: () = assert!(std::mem::size_of::<Node8>() == 224);
const _: () = assert!(std::mem::align_of::<Node8>() == 32);

/// A leaf child: this bit, its first triangle (in leaf order) shifted by [`COUNT_BITS`], and
/// its triangle count less one in the low bits.
const LEAF: u32 = 1 << 31;
const COUNT_BITS: u32 = 4;
/// An unused slot.
const EMPTY: u32 = u32::MAX;
/// A leaf holds at most this many triangles.
pub const MAX_LEAF: u32 = 1 << COUNT_BITS;
/// Leaf order holds fewer triangles than this.
const MAX_TRIANGLES: usize = 1 << (31 - COUNT_BITS);

/// What a child code names.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Child {
    Node(u32),
    /// Triangles `first..first + count` in leaf order.
    Leaf {
        first: u32,
        count: u32,
    },
    Empty,
}

impl Child {
    #[inline(always)]
    pub fn of(code: u32) -> Child {
        if code == EMPTY {
            Child::Empty
        } else if code & LEAF != 0 {
            Child::Leaf {
                first: (code & !LEAF) >> COUNT_BITS,
                count: (code & (MAX_LEAF - 1)) + 1,
            }
        } else {
            Child::Node(code)
        }
    }
}

impl Node8 {
    const EMPTY: Node8 = Node8 {
        bounds: [
            [f32::MAX; WIDTH],
            [f32::MAX; WIDTH],
            [f32::MAX; WIDTH],
            [-f32::MAX; WIDTH],
            [-f32::MAX; WIDTH],
            [-f32::MAX; WIDTH],
        ],
        child: [EMPTY; WIDTH],
    };

    fn set(&mut self, slot: usize, b: &BvhNode, code: u32) {
        for k in 0..3 {
            self.bounds[k][slot] = b.lo[k];
            self.bounds[3 + k][slot] = b.hi[k];
        }
        self.child[slot] = code;
    }

    /// Child `slot`'s box as a binary node (what the float64 slab test reads).
    fn slot_box(&self, slot: usize) -> BvhNode {
        BvhNode {
            lo: [0, 1, 2].map(|k| self.bounds[k][slot]),
            first: 0,
            hi: [0, 1, 2].map(|k| self.bounds[3 + k][slot]),
            count: 0,
        }
    }
}

/// How the tree is built: the binary tree's parameters ([`BvhParams`]; its `aperture` is a
/// packet setting and means nothing here), and the size below which a binary subtree becomes
/// one leaf. `max_leaf` and `leaf_size` are at most [`MAX_LEAF`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ExactBvhParams {
    pub cost_ratio: f64,
    pub max_leaf: u32,
    pub bins: u32,
    pub leaf_size: u32,
}

impl Default for ExactBvhParams {
    fn default() -> Self {
        ExactBvhParams {
            cost_ratio: 1.0,
            max_leaf: 8,
            bins: 16,
            leaf_size: 4,
        }
    }
}

impl ExactBvhParams {
    fn binary(&self) -> Result<BvhParams> {
        for (name, v) in [("max_leaf", self.max_leaf), ("leaf_size", self.leaf_size)] {
            if !(1..=MAX_LEAF).contains(&v) {
                return Err(Error::InvalidOption(format!(
                    "{name} must be in 1..={MAX_LEAF} for the 8-wide BVH, got {v}"
                )));
            }
        }
        let p = BvhParams {
            cost_ratio: self.cost_ratio,
            max_leaf: self.max_leaf,
            bins: self.bins,
            aperture: false,
        };
        p.check()?;
        Ok(p)
    }
}

/// The walk, written once: `$test(node, tmin, reach, t0, t1)` is the box test, with the ray's
/// range in float64 and rounded outward to float32 ([`RayBoxes::range`]; `t0` is fixed for the
/// ray, `t1` moves only when a leaf's offers lower the reach, so both are kept rather than
/// rounded at every node). A macro rather than a generic function so that the AVX2 walk's test
/// is written inside the function that has the target features, where LLVM inlines it
/// (through a generic function or a closure it stayed a call per node).
///
/// Children are visited nearest entry first (a stack, pushed farthest first). A node with one
/// child in reach goes straight on to it, without the stack: the same order as pushing and
/// popping it.
macro_rules! walk_loop {
    ($bvh:expr, $line:expr, $gather:expr, $stack:expr, |$node:ident, $tmin:ident, $reach:ident, $t0:ident, $t1:ident| $test:expr) => {
        walk_loop!(
            $bvh,
            $line,
            $gather,
            $stack,
            |$node, $tmin, $reach, $t0, $t1| $test,
            |_tris| (u32::MAX, 0)
        )
    };
    ($bvh:expr, $line:expr, $gather:expr, $stack:expr, |$node:ident, $tmin:ident, $reach:ident, $t0:ident, $t1:ident| $test:expr, |$tris:ident| $filter:expr) => {{
        let (bvh, line, gather, stack) = ($bvh, $line, $gather, $stack);
        stack.clear();
        let mut cursor = Cursor::start(line, gather.reach());
        while walk_step!(
            bvh,
            line,
            &mut *gather,
            &mut *stack,
            &mut cursor,
            |$node, $tmin, $reach, $t0, $t1| $test,
            |$tris| $filter
        ) {}
        cursor.visited
    }};
}

/// Where one ray's walk stands between two steps: the box it enters next (`code`; the root
/// first, which has no box of its own: a ray that misses every box of the scene visited
/// nothing, as on Reshetov's tree), its reach and float32 range, and the boxes entered.
#[derive(Clone, Copy, Debug)]
struct Cursor {
    code: u32,
    reach: f64,
    t0: f32,
    t1: f32,
    visited: u32,
}

impl Cursor {
    #[inline(always)]
    fn start(line: &Line, reach: f64) -> Cursor {
        let (t0, t1) = RayBoxes::range(line.tmin, reach);
        Cursor {
            code: 0,
            reach,
            t0,
            t1,
            visited: 0,
        }
    }
}

/// One step of a ray's walk (`walk_loop!`'s body): the box at the cursor is entered (a node's
/// children tested and the nearest in reach gone on to or the rest pushed; a leaf's triangles
/// offered), then the nearest box left within reach is taken. False: the walk is over (the
/// query settled, or nothing is left). A macro for the same reason as `walk_loop!`; a step at
/// a time, so that two rays' walks can be interleaved (`ExactBvhAt::trace_two_avx2`).
macro_rules! walk_step {
    ($bvh:expr, $line:expr, $gather:expr, $stack:expr, $cursor:expr, |$node:ident, $tmin:ident, $reach:ident, $t0:ident, $t1:ident| $test:expr, |$tris:ident| $filter:expr) => {{
        let (bvh, line, gather, stack, cur): (
            &ExactBvh,
            &Line,
            _,
            &mut Vec<(u32, f32)>,
            &mut Cursor,
        ) = ($bvh, $line, $gather, $stack, $cursor);
        'step: {
            match Child::of(cur.code) {
                Child::Node(k) => {
                    let $node = &bvh.nodes[k as usize];
                    let ($tmin, $reach, $t0, $t1) = (line.tmin, cur.reach, cur.t0, cur.t1);
                    let (mask, nears) = $test;
                    if mask != 0 && mask & (mask - 1) == 0 {
                        let s = mask.trailing_zeros() as usize;
                        if !beyond_reach(nears[s], cur.reach) {
                            cur.code = $node.child[s];
                            cur.visited += 1;
                            prefetch_box(bvh, cur.code);
                            break 'step true;
                        }
                    } else if mask != 0 {
                        push_sorted(stack, $node, mask, &nears);
                    }
                }
                Child::Leaf { first, count } => {
                    let range = first as usize..(first + count) as usize;
                    let $tris = &bvh.triangles[range.clone()];
                    if offer_leaf(bvh, line, gather, range, $filter) {
                        break 'step false;
                    }
                    let reach = gather.reach();
                    if reach != cur.reach {
                        cur.reach = reach;
                        cur.t1 = RayBoxes::range(line.tmin, reach).1;
                    }
                }
                Child::Empty => {}
            }
            // The nearest child left on the stack within reach, a box entered.
            loop {
                let Some((next, near)) = stack.pop() else {
                    break 'step false;
                };
                if !beyond_reach(near, cur.reach) {
                    cur.code = next;
                    cur.visited += 1;
                    prefetch_box(bvh, cur.code);
                    break 'step true;
                }
            }
        }
    }};
}

/// Asks the cache for what the box `code` will be entered with (a node's rows, a leaf's
/// first triangles and its triangles' ids), where the walk goes next: while two rays are
/// walked in turn, the other ray's step runs before this one reads them.
#[inline(always)]
fn prefetch_box(bvh: &ExactBvh, code: u32) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        let (p, lines) = match Child::of(code) {
            Child::Node(k) => (bvh.nodes.as_ptr().wrapping_add(k as usize).cast::<i8>(), 4),
            Child::Leaf { first, .. } => (
                bvh.triangles
                    .as_ptr()
                    .wrapping_add(first as usize)
                    .cast::<i8>(),
                2,
            ),
            Child::Empty => return,
        };
        for l in 0..lines {
            // SAFETY: a prefetch reads nothing and faults on no address.
            unsafe { _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(64 * l)) };
        }
        // A leaf's met triangles are offered under their caller's ids (`bvh.order`), a load
        // the gatherer's compares wait on. Not asked for, on random rays over bunny (Zen 3)
        // it missed the cache where the walk's largest stall sat (8.8% of its samples).
        // Written apart from the match above: folded into its leaf arm (a list of lines),
        // the same prefetches timed no faster than none (docs/bvh.md, stop 71).
        if let Child::Leaf { first, .. } = Child::of(code) {
            let ids = bvh.order.as_ptr().wrapping_add(first as usize).cast::<i8>();
            // SAFETY: as above.
            unsafe { _mm_prefetch::<_MM_HINT_T0>(ids) };
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (bvh, code);
}

/// Whether a box whose entry is bounded below by `near` (less an absolute slack for what
/// underflows) lies beyond the reach: then it is skipped.
#[inline(always)]
fn beyond_reach(near: f32, reach: f64) -> bool {
    (near as f64) - (f32::MIN_POSITIVE as f64) > reach
}

/// The same test in AVX2 + FMA, eight children at once, within the float32 range `[t0, t1]`
/// ([`RayBoxes::range`]): a macro, to be written inside a function compiled with those
/// features (no closures: they do not take the features).
#[cfg(target_arch = "x86_64")]
macro_rules! avx2_box_test {
    ($r:expr, $node:expr, $t0:expr, $t1:expr) => {{
        use std::arch::x86_64::*;
        let (r, b): (&RayBoxes, &[[f32; WIDTH]; 6]) = ($r, &$node.bounds);
        let (t0, t1): (f32, f32) = ($t0, $t1);
        // Rows are 32-byte aligned (Node8 is, and each row is 32 bytes). SAFETY: `near` and
        // `far` hold the offsets of rows k and k + 3 (k < 3) only, as `RayBoxes` builds them:
        // within the six (unchecked: a bounds check per row was a compare and a branch at
        // every node).
        let row = |i: usize| _mm256_load_ps(b.as_ptr().cast::<f32>().add(i));
        let [n0, n1, n2] = r.near.map(|i| row(i));
        let [f0, f1, f2] = r.far.map(|i| row(i));
        let [i0, i1, i2] = r.inv.map(|x| _mm256_set1_ps(x));
        let [cn0, cn1, cn2] = r.neg_c_near.map(|x| _mm256_set1_ps(x));
        let [cf0, cf1, cf2] = r.neg_c_far.map(|x| _mm256_set1_ps(x));
        let (tn0, tn1, tn2) = (
            _mm256_fmadd_ps(n0, i0, cn0),
            _mm256_fmadd_ps(n1, i1, cn1),
            _mm256_fmadd_ps(n2, i2, cn2),
        );
        let (tf0, tf1, tf2) = (
            _mm256_fmadd_ps(f0, i0, cf0),
            _mm256_fmadd_ps(f1, i1, cf1),
            _mm256_fmadd_ps(f2, i2, cf2),
        );
        // max(a, b) is b unless a > b, as `max32`.
        let near = _mm256_max_ps(
            _mm256_max_ps(tn0, tn1),
            _mm256_max_ps(tn2, _mm256_set1_ps(t0)),
        );
        let far = _mm256_min_ps(
            _mm256_min_ps(tf0, tf1),
            _mm256_min_ps(tf2, _mm256_set1_ps(t1)),
        );
        let near = _mm256_mul_ps(near, _mm256_set1_ps(1.0 - PAD));
        let abs = _mm256_andnot_ps(_mm256_set1_ps(-0.0), far);
        let far = _mm256_add_ps(
            _mm256_fmadd_ps(abs, _mm256_set1_ps(PAD), far),
            _mm256_set1_ps(TINY),
        );
        let mut hit = _mm256_cmp_ps::<_CMP_LE_OQ>(near, far);
        if r.zero {
            for k in 0..3 {
                let lo = _mm256_load_ps(b[k].as_ptr());
                let hi = _mm256_load_ps(b[3 + k].as_ptr());
                let lo = _mm256_cmp_ps::<_CMP_LE_OQ>(lo, _mm256_set1_ps(r.o_up[k]));
                let hi = _mm256_cmp_ps::<_CMP_LE_OQ>(_mm256_set1_ps(r.o_down[k]), hi);
                hit = _mm256_and_ps(hit, _mm256_and_ps(lo, hi));
            }
        }
        let mut nears = [0.0f32; WIDTH];
        _mm256_storeu_ps(nears.as_mut_ptr(), near);
        (_mm256_movemask_ps(hit) as u32, nears)
    }};
}

/// [`may_meet_avx2`] as a macro, to be expanded inside a function compiled with AVX2 and FMA
/// (the walk's): as a function it stayed a call per leaf, with the walk's registers saved
/// around it and the ray's constants broadcast again each time. Per block of four triangles,
/// the terms that depend on the origin alone ([`leaf_edges_avx2!`]), then their signs along
/// the direction ([`edge_signs_avx2!`]): a packet, whose rays share their origin, makes the
/// first once per leaf and the second per ray, with the same operations in the same order.
#[cfg(target_arch = "x86_64")]
macro_rules! may_meet_avx2 {
    ($line:expr, $tris:expr) => {{
        use std::arch::x86_64::*;
        let (line, tris): (&crate::query::gather::Line, &[crate::query::gather::Tri]) =
            ($line, $tris);
        let ov = line.o.map(|x| _mm256_set1_pd(x));
        let (dv, da) = direction_avx2!(line);
        debug_assert!(tris.len() <= 32, "a bit per triangle in a u32");
        let (mut may, mut sure) = (0u32, 0u32);
        for (block, four) in tris.chunks(4).enumerate() {
            let edges = leaf_edges_avx2!(&ov, four);
            let (out, all) = edge_signs_avx2!(&dv, &da, &edges);
            may |= (!out & 0xf) << (4 * block);
            sure |= all << (4 * block);
        }
        (may, sure)
    }};
}

/// The line's scaled direction and its magnitudes, broadcast (what [`edge_signs_avx2!`]
/// takes).
#[cfg(target_arch = "x86_64")]
macro_rules! direction_avx2 {
    ($line:expr) => {{
        use std::arch::x86_64::*;
        let d: [f64; 3] = $line.dir;
        (
            d.map(|x| _mm256_set1_pd(x)),
            d.map(|x| _mm256_set1_pd(x.abs())),
        )
    }};
}

/// Of four triangles (a short block repeats its last: those lanes are not read), per edge k
/// (corners b = k, c = k + 1 less the origin `ov`, per lane): the three 2×2 minors of
/// `det_perm(d, b, c)` and the three sums of their products' magnitudes, `[m0, m1, m2, s0,
/// s1, s2]`, as `geom::exact::triangle_sides` forms them.
#[cfg(target_arch = "x86_64")]
macro_rules! leaf_edges_avx2 {
    ($ov:expr, $four:expr) => {{
        use std::arch::x86_64::*;
        let (ov, four): (&[__m256d; 3], &[crate::query::gather::Tri]) = ($ov, $four);
        let last = four.len() - 1;
        let t = [
            &four[0],
            &four[1.min(last)],
            &four[2.min(last)],
            &four[last],
        ];
        // Corner v's coordinate k minus the origin's, per lane.
        let mut p = [[_mm256_setzero_pd(); 3]; 3];
        for v in 0..3 {
            for k in 0..3 {
                let x = _mm256_set_pd(t[3][v][k], t[2][v][k], t[1][v][k], t[0][v][k]);
                p[v][k] = _mm256_sub_pd(x, ov[k]);
            }
        }
        let sign = _mm256_set1_pd(-0.0);
        let mut edges = [[_mm256_setzero_pd(); 6]; 3];
        for k in 0..3 {
            let (b, c) = (&p[k], &p[(k + 1) % 3]);
            // det_perm(d, b, c), term by term.
            let (b1c2, b2c1) = (_mm256_mul_pd(b[1], c[2]), _mm256_mul_pd(b[2], c[1]));
            let (b0c2, b2c0) = (_mm256_mul_pd(b[0], c[2]), _mm256_mul_pd(b[2], c[0]));
            let (b0c1, b1c0) = (_mm256_mul_pd(b[0], c[1]), _mm256_mul_pd(b[1], c[0]));
            let (a12, a21) = (_mm256_andnot_pd(sign, b1c2), _mm256_andnot_pd(sign, b2c1));
            let (a02, a20) = (_mm256_andnot_pd(sign, b0c2), _mm256_andnot_pd(sign, b2c0));
            let (a01, a10) = (_mm256_andnot_pd(sign, b0c1), _mm256_andnot_pd(sign, b1c0));
            edges[k] = [
                _mm256_sub_pd(b1c2, b2c1),
                _mm256_sub_pd(b0c2, b2c0),
                _mm256_sub_pd(b0c1, b1c0),
                _mm256_add_pd(a12, a21),
                _mm256_add_pd(a02, a20),
                _mm256_add_pd(a01, a10),
            ];
        }
        edges
    }};
}

/// Per lane, the sign of one side product along the direction `(dv, da)` ([`direction_avx2!`])
/// from its terms `[m0, m1, m2, s0, s1, s2]` ([`leaf_edges_avx2!`]), certified as
/// `triangle_sides` certifies it (`|det| > DET_BOUND · perm`, the permanent finite and above
/// TINY): the masks of lanes certified positive and certified negative. The one place these
/// operations are written for AVX2: the leaf filter takes a lane per triangle, the fan's
/// filter a lane per edge.
#[cfg(target_arch = "x86_64")]
macro_rules! certified_sign_avx2 {
    ($dv:expr, $da:expr, $terms:expr) => {{
        use crate::geom::exact::{DET_BOUND, TINY};
        use std::arch::x86_64::*;
        let (dv, da): (&[__m256d; 3], &[__m256d; 3]) = ($dv, $da);
        let [m0, m1, m2, s0, s1, s2]: [__m256d; 6] = $terms;
        let det = _mm256_add_pd(
            _mm256_sub_pd(_mm256_mul_pd(dv[0], m0), _mm256_mul_pd(dv[1], m1)),
            _mm256_mul_pd(dv[2], m2),
        );
        let perm = _mm256_add_pd(
            _mm256_add_pd(_mm256_mul_pd(da[0], s0), _mm256_mul_pd(da[1], s1)),
            _mm256_mul_pd(da[2], s2),
        );
        let bound = _mm256_mul_pd(_mm256_set1_pd(DET_BOUND), perm);
        let ok = _mm256_and_pd(
            _mm256_cmp_pd::<_CMP_GT_OQ>(perm, _mm256_set1_pd(TINY)),
            _mm256_cmp_pd::<_CMP_LT_OQ>(perm, _mm256_set1_pd(f64::INFINITY)),
        );
        let neg_det = _mm256_xor_pd(det, _mm256_set1_pd(-0.0));
        (
            _mm256_and_pd(ok, _mm256_cmp_pd::<_CMP_GT_OQ>(det, bound)),
            _mm256_and_pd(ok, _mm256_cmp_pd::<_CMP_GT_OQ>(neg_det, bound)),
        )
    }};
}

/// The signs of a block's three side products along the direction `(dv, da)`
/// ([`direction_avx2!`]) from its [`leaf_edges_avx2!`] terms ([`certified_sign_avx2!`]): four
/// bits of triangles with two of certain opposite signs (surely missed), and four of those
/// whose three it certified of one sign.
#[cfg(target_arch = "x86_64")]
macro_rules! edge_signs_avx2 {
    ($dv:expr, $da:expr, $edges:expr) => {{
        use std::arch::x86_64::*;
        let (dv, da, edges): (&[__m256d; 3], &[__m256d; 3], &[[__m256d; 6]; 3]) =
            ($dv, $da, $edges);
        let all = _mm256_castsi256_pd(_mm256_set1_epi64x(-1));
        let (mut pos, mut neg) = (_mm256_setzero_pd(), _mm256_setzero_pd());
        let (mut pos_all, mut neg_all) = (all, all);
        for terms in *edges {
            let (p, n) = certified_sign_avx2!(dv, da, terms);
            (pos, neg) = (_mm256_or_pd(pos, p), _mm256_or_pd(neg, n));
            (pos_all, neg_all) = (_mm256_and_pd(pos_all, p), _mm256_and_pd(neg_all, n));
        }
        (
            _mm256_movemask_pd(_mm256_and_pd(pos, neg)) as u32,
            _mm256_movemask_pd(_mm256_or_pd(pos_all, neg_all)) as u32,
        )
    }};
}

/// The tree over a scene's triangles.
#[derive(Clone, Debug)]
pub struct ExactBvh {
    /// Node 0 is the root.
    pub nodes: Vec<Node8>,
    /// The caller's triangle ids in leaf order.
    pub order: Vec<u32>,
    /// The triangles in leaf order (a leaf's are contiguous).
    pub triangles: Vec<Tri>,
    pub params: ExactBvhParams,
    /// Whether some box has an infinite bound (a triangle past float32's range): then a ray
    /// with a zero direction component is tested in float64 (0 × ∞ would be NaN).
    infinite: bool,
}

impl ExactBvh {
    /// Builds the tree over `triangles` (the caller's, in its numbering; their corners must be
    /// finite).
    pub fn build(triangles: &[Tri], params: ExactBvhParams) -> Result<ExactBvh> {
        if triangles.len() >= MAX_TRIANGLES {
            return Err(Error::InvalidInput(format!(
                "{} triangles: the 8-wide BVH holds fewer than 2^{}",
                triangles.len(),
                31 - COUNT_BITS
            )));
        }
        let binary = ReshetovBvh::build_to(triangles, params.binary()?, params.leaf_size as usize)?;
        let nodes = collapse(&binary.nodes, params.leaf_size);
        let infinite = nodes
            .iter()
            .flat_map(|n| n.bounds.iter().flatten())
            .any(|x| x.is_infinite());
        Ok(ExactBvh {
            nodes,
            order: binary.order,
            triangles: binary.triangles,
            params,
            infinite,
        })
    }

    /// Bytes of the tree: nodes, the id order and the triangles in leaf order.
    pub fn memory(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<Node8>()
            + self.order.len() * 4
            + self.triangles.len() * std::mem::size_of::<Tri>()
    }

    /// The number of leaves, the mean children per node, and the depth of the deepest leaf
    /// (the root's children at depth 1).
    pub fn shape(&self) -> (usize, f64, usize) {
        let (mut leaves, mut children, mut depth) = (0, 0, 0);
        let mut stack = vec![(0u32, 1usize)];
        while let Some((k, d)) = stack.pop() {
            for &code in &self.nodes[k as usize].child {
                match Child::of(code) {
                    Child::Node(c) => stack.push((c, d + 1)),
                    Child::Leaf { .. } => {
                        leaves += 1;
                        depth = depth.max(d);
                    }
                    Child::Empty => continue,
                }
                children += 1;
            }
        }
        (leaves, children as f64 / self.nodes.len() as f64, depth)
    }

    /// Offers `gather` every triangle the ray meets in range, nearest boxes first, skipping
    /// boxes beyond its reach; the boxes entered (of inner nodes and leaves).
    pub fn walk<G: Gather>(
        &self,
        line: &Line,
        gather: &mut G,
        simd: Simd,
        stack: &mut Vec<(u32, f32)>,
    ) -> u32 {
        match RayBoxes::at(simd, line, self.infinite) {
            Some(r) => {
                #[cfg(target_arch = "x86_64")]
                if simd == Simd::Avx2 {
                    // SAFETY: Simd::Avx2 is only chosen where the CPU has AVX2 and FMA
                    // (`Simd::supported`).
                    return unsafe { self.walk_avx2(line, gather, stack, r) };
                }
                self.walk_with(line, gather, stack, &r)
            }
            None => self.walk_with(line, gather, stack, &Wide64(Slab::new(line))),
        }
    }

    /// The walk compiled for AVX2 and FMA, so that the box test is inlined into it (a
    /// function with other target features cannot inline it). Rust never fuses `a * b + c` on
    /// its own, so the rest of the walk rounds as the portable one does.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn walk_avx2<G: Gather>(
        &self,
        line: &Line,
        gather: &mut G,
        stack: &mut Vec<(u32, f32)>,
        r: RayBoxes,
    ) -> u32 {
        walk_loop!(
            self,
            line,
            gather,
            stack,
            |node, _tmin, _reach, t0, t1| avx2_box_test!(&r, node, t0, t1),
            |tris| may_meet_avx2!(line, tris)
        )
    }

    #[inline(always)]
    fn walk_with<G: Gather, T: BoxTest>(
        &self,
        line: &Line,
        gather: &mut G,
        stack: &mut Vec<(u32, f32)>,
        test: &T,
    ) -> u32 {
        walk_loop!(self, line, gather, stack, |node, tmin, reach, _t0, _t1| {
            test.test(node, tmin, reach)
        })
    }
}

/// Offers `gather` the triangles of the leaf `range` that the ray meets at one point in
/// range, in leaf order; true: the answer is settled. `(may, sure)` are the leaf filter's
/// masks (a bit per triangle): a triangle not in `may` surely misses (side products of certain
/// opposite signs) and is skipped; one in `sure` has its three side products certified of one
/// sign, so only its crossing's range is left to decide ([`Line::crosses_at`]); the rest take
/// the exact test ([`Line::meets_at`]). A triangle tested and not met is told to a gatherer
/// that asks ([`Gather::in_plane`]). One ray's walk and each ray of a packet go through it.
#[inline(always)]
fn offer_leaf<G: Gather>(
    bvh: &ExactBvh,
    line: &Line,
    gather: &mut G,
    range: std::ops::Range<usize>,
    (may, sure): (u32, u32),
) -> bool {
    // The leaf's bits of `may` (a filter's short block sets bits past the leaf), visited set
    // bit by set bit: most triangles are left out.
    debug_assert!((1..=MAX_LEAF as usize).contains(&range.len()));
    let mut left = may & (u32::MAX >> (32 - range.len()));
    while left != 0 {
        let i = left.trailing_zeros();
        left &= left - 1;
        let j = range.start + i as usize;
        let tri = &bvh.triangles[j];
        let met = if sure >> i & 1 != 0 {
            line.crosses_at(tri)
        } else {
            line.meets_at(tri)
        };
        let settled = match met {
            Some(at) => gather.offer(bvh.order[j], tri, at),
            None => gather.in_plane(bvh.order[j]),
        };
        if settled {
            return true;
        }
    }
    false
}

/// Pushes the children in `mask`, farthest first (the nearest is popped first); of equal
/// entries the later slot is popped first, so the order is the same at every level.
#[inline(always)]
fn push_sorted(stack: &mut Vec<(u32, f32)>, node: &Node8, mask: u32, nears: &[f32; WIDTH]) {
    push_by_entry(stack, mask, |s| (node.child[s], nears[s]), |e| e.1);
}

/// Pushes `item(slot)` for each slot in `mask` (one bit per child) in decreasing order of
/// `entry`, so that the nearest is popped first; of equal entries the later slot is popped
/// first. Entries are ordered as `f32::total_cmp` orders them (−0 below +0, NaN at the ends),
/// so the places are a permutation whatever they hold. One ray's walk and the packets' push
/// through it.
///
/// Each item's place is counted, not found by insertion: the insertion's compares branched on
/// the entries, which random rays make unpredictable (rays that enter a box walked 4% faster
/// counted, docs/bvh.md). Room for a node's children is reserved once and the items are written
/// in place: `Vec`'s push and indexing cost a capacity check and a bounds check per child.
#[inline(always)]
fn push_by_entry<T: Copy>(
    stack: &mut Vec<T>,
    mask: u32,
    item: impl Fn(usize) -> T,
    entry: impl Fn(&T) -> f32,
) {
    stack.reserve(WIDTH);
    let base = stack.len();
    let p = stack.as_mut_ptr();
    // The items, and their entries as integers in `total_cmp`'s order.
    let mut keys = [0i32; WIDTH];
    let mut items = [const { MaybeUninit::<T>::uninit() }; WIDTH];
    let mut m = mask & ((1 << WIDTH) - 1);
    let mut count = 0;
    while m != 0 {
        let slot = m.trailing_zeros() as usize;
        m &= m - 1;
        let it = item(slot);
        let bits = entry(&it).to_bits() as i32;
        keys[count] = bits ^ ((((bits >> 31) as u32) >> 1) as i32);
        items[count].write(it);
        count += 1;
    }
    for i in 0..count {
        // Below item i: the farther entries, and the equal ones of earlier slots.
        let mut place = 0;
        for j in 0..count {
            place += ((keys[j] > keys[i]) | ((keys[j] == keys[i]) & (j < i))) as usize;
        }
        // SAFETY: the places of items 0..count (written above) are a permutation of 0..count
        // (the keys are totally ordered, ties broken by slot), count ≤ WIDTH, within the
        // capacity reserved.
        unsafe { p.add(base + place).write(items[i].assume_init()) };
    }
    // SAFETY: base..base + count were written above.
    unsafe { stack.set_len(base + count) };
}

/// Of a leaf's triangles (at most [`MAX_LEAF`]), those the ray may meet (bit j for `tris[j]`): a triangle is left out
/// only when two of its side products have certain opposite signs, decided as
/// `geom::exact::triangle_sides` decides them (the same float64 products and sums in the same
/// order, four triangles at once, the same certification `|det| > DET_BOUND · perm` with the
/// permanent finite and above TINY), so `Line::meets` would say no. Rust's scalar code and
/// these intrinsics round each operation once (nothing is fused), so each lane's numbers are
/// the scalar ones. The rest is decided exactly by `Line::meets_at`. On camera rays most
/// triangles of a leaf are left out here, in about a sixth of the scalar test's instructions.
///
/// Second, those whose three side products it certified of one sign (bit j of the second
/// mask): `triangle_sides` would give the same three signs, so the line meets the closed
/// triangle at one point and `Line::crosses_at` decides the rest without them.
///
/// The walks expand it as the macro [`may_meet_avx2!`]; this function is what the tests call.
#[cfg(all(test, target_arch = "x86_64"))]
#[target_feature(enable = "avx2,fma")]
unsafe fn may_meet_avx2(line: &Line, tris: &[Tri]) -> (u32, u32) {
    may_meet_avx2!(line, tris)
}

/// Collapses the binary tree (node 0 its root) into 8-wide nodes. A binary subtree of at
/// most `leaf_size` triangles becomes one leaf (its triangles are contiguous in leaf order: the
/// build splits ranges); an inner node's children are found by opening, among the binary
/// nodes gathered so far, the inner one with the largest surface until there are eight or
/// only leaves.
fn collapse(binary: &[BvhNode], leaf_size: u32) -> Vec<Node8> {
    let mut nodes = vec![Node8::EMPTY];
    let root = &binary[0];
    if root.count == 0 && root.first == 0 {
        return nodes; // no triangles
    }
    // Each binary node's first triangle and count, children before parents.
    let mut range = vec![(0u32, 0u32); binary.len()];
    let mut order = vec![0usize];
    let mut i = 0;
    while i < order.len() {
        let b = &binary[order[i]];
        if b.count == 0 {
            order.extend([b.first as usize, b.first as usize + 1]);
        }
        i += 1;
    }
    for &k in order.iter().rev() {
        let b = &binary[k];
        range[k] = if b.count > 0 {
            (b.first, b.count)
        } else {
            let (l, r) = (range[b.first as usize], range[b.first as usize + 1]);
            (l.0, l.1 + r.1)
        };
    }
    let is_leaf = |k: usize| binary[k].count > 0 || range[k].1 <= leaf_size;
    let half_area = |b: &BvhNode| {
        let e = [0, 1, 2].map(|k| (b.hi[k] as f64 - b.lo[k] as f64).max(0.0));
        e[0] * e[1] + e[1] * e[2] + e[2] * e[0]
    };
    let mut todo = vec![(0usize, 0usize)];
    while let Some((w, b)) = todo.pop() {
        let mut kids: Vec<usize> = if is_leaf(b) {
            vec![b]
        } else {
            let f = binary[b].first as usize;
            vec![f, f + 1]
        };
        while kids.len() < WIDTH {
            let open = kids
                .iter()
                .enumerate()
                .filter(|(_, &k)| !is_leaf(k))
                .max_by(|(_, &a), (_, &c)| half_area(&binary[a]).total_cmp(&half_area(&binary[c])))
                .map(|(i, _)| i);
            let Some(i) = open else { break };
            let f = binary[kids[i]].first as usize;
            kids[i] = f;
            kids.insert(i + 1, f + 1);
        }
        for (slot, &k) in kids.iter().enumerate() {
            let code = if is_leaf(k) {
                let (first, count) = range[k];
                debug_assert!((1..=MAX_LEAF).contains(&count));
                LEAF | (first << COUNT_BITS) | (count - 1)
            } else {
                let idx = nodes.len();
                nodes.push(Node8::EMPTY);
                todo.push((idx, k));
                idx as u32
            };
            nodes[w].set(slot, &binary[k], code);
        }
    }
    nodes
}

/// A box test of the eight children of a node: the mask of those the ray may meet within
/// [tmin, reach] and, per child, a lower bound on where it enters.
trait BoxTest {
    fn test(&self, node: &Node8, tmin: f64, reach: f64) -> (u32, [f32; WIDTH]);
}

/// A closure as a box test (the tests' AVX2 test; the walk expands that one in place).
#[cfg(test)]
impl<F: Fn(&Node8, f64, f64) -> (u32, [f32; WIDTH])> BoxTest for F {
    #[inline(always)]
    fn test(&self, node: &Node8, tmin: f64, reach: f64) -> (u32, [f32; WIDTH]) {
        self(node, tmin, reach)
    }
}

/// The float32 unit roundoff.
const U32: f32 = f32::EPSILON / 2.0;
/// The entry is scaled down by (1 − PAD), the exit up by (1 + PAD): eight roundings, where
/// the bound below needs three (the reciprocal's, the product's and the pad's own).
const PAD: f32 = 8.0 * U32;
/// Absolute slack for results that underflow (a subnormal's rounding is absolute).
const TINY: f32 = f32::MIN_POSITIVE;

/// One ray's float32 constants for the box test.
///
/// Per axis k with a direction: `inv` = 1/d rounded to float32 (1/d in float64, then to
/// float32), and the entry and exit at plane b are `fma(b, inv, −c_near)` and
/// `fma(b, inv, −c_far)`, where `c = o32 · inv` is exact in float64 (two 24-bit
/// significands) and `c_near ≥ c + |o − o32| |inv|`, `c_far ≤ c − |o − o32| |inv|` (rounded
/// outward to float32). Then `b · inv − c_near ≤ (b − o) · inv = t (1 + η)` with t the exact
/// slab distance (b − o)/d and |η| ≤ u (the reciprocal's rounding), and the fma rounds once
/// more; the max over the axes and tmin (≥ 0) is padded by its relative error once, as the
/// min is (x − γ|x| is increasing, so padding the max is the max of the padded).
///
/// An axis with d = 0 bounds nothing in t (inv = 0, c_near = +∞, c_far = −∞: t = −∞ and +∞)
/// and instead asks lo ≤ o ≤ hi, with o rounded down and up to float32.
#[derive(Clone, Copy, Debug)]
pub struct RayBoxes {
    /// Per axis, where the bound row of the plane it enters by and of the one it leaves by
    /// start among the node's bounds (row × [`WIDTH`] floats: the box test adds it to the
    /// node's address as it is, where a row index cost a shift per row and node).
    near: [usize; 3],
    far: [usize; 3],
    inv: [f32; 3],
    neg_c_near: [f32; 3],
    neg_c_far: [f32; 3],
    /// Per axis with d = 0: o rounded down and up (else −inf, +inf: no condition).
    o_down: [f32; 3],
    o_up: [f32; 3],
    zero: bool,
}

/// Relative and absolute slack of [`above32`] and [`below32`]: 2^-22 is four times the
/// float32 rounding (2^-24) plus what the float64 sums round (2^-53 each); 2^-149 is the
/// float32 rounding where it is absolute (subnormal results).
const REL32: f64 = 1.0 / (1u64 << 22) as f64;
const ABS32: f64 = f32::MIN_POSITIVE as f64 / (1u64 << 23) as f64;

/// A float32 at least x (rounded to nearest after raising x by more than that rounding can
/// take off; without branches, which the signs of random rays would mispredict). +inf stays.
#[inline(always)]
fn above32(x: f64) -> f32 {
    (x + (x.abs() * REL32 + ABS32)) as f32
}

/// A float32 at most x, as [`above32`].
#[inline(always)]
fn below32(x: f64) -> f32 {
    (x - (x.abs() * REL32 + ABS32)) as f32
}

/// `(c_near, c_far)` for the origin coordinate `o` and the float32 factor `inv`: float32s with
/// `c_near ≥ o·inv ≥ c_far` exactly (infinite where they leave float32's range). With o32 the
/// nearest float32 to o, `c = o32·inv` is exact in float64 (two 24-bit significands) and
/// |o − o32| is exact; the pad's product is rounded up by its factor, the sums by `above32`
/// and `below32`. One ray's box constants and a packet's make them so.
#[inline(always)]
fn c_bounds(o: f64, inv: f32) -> (f32, f32) {
    let o32 = o as f32;
    let c = o32 as f64 * inv as f64;
    let pad = ((o - o32 as f64).abs() * (inv as f64).abs()) * (1.0 + f64::EPSILON);
    let (cn, cf) = (above32(c + pad), below32(c - pad));
    debug_assert!(
        !(cn.is_finite() && cf.is_finite()) || (cn as f64 >= c + pad && (cf as f64) <= c - pad)
    );
    (cn, cf)
}

impl RayBoxes {
    /// [`RayBoxes::new`], in AVX2 at that level (the same constants).
    #[inline(always)]
    pub fn at(simd: Simd, line: &Line, infinite: bool) -> Option<RayBoxes> {
        #[cfg(target_arch = "x86_64")]
        if simd == Simd::Avx2 {
            // SAFETY: Simd::Avx2 is only chosen where the CPU has AVX2.
            return unsafe { RayBoxes::new_avx2(line, infinite) };
        }
        let _ = simd;
        RayBoxes::new(line, infinite)
    }

    /// None where the float32 test does not apply (see the module's notes).
    #[inline]
    pub fn new(line: &Line, infinite: bool) -> Option<RayBoxes> {
        let mut r = RayBoxes {
            near: [0, WIDTH, 2 * WIDTH],
            far: [3 * WIDTH, 4 * WIDTH, 5 * WIDTH],
            inv: [0.0; 3],
            neg_c_near: [f32::NEG_INFINITY; 3],
            neg_c_far: [f32::INFINITY; 3],
            o_down: [f32::NEG_INFINITY; 3],
            o_up: [f32::INFINITY; 3],
            zero: line.d.contains(&0.0),
        };
        if r.zero {
            if infinite {
                return None;
            }
            for k in 0..3 {
                if line.d[k] == 0.0 {
                    r.o_down[k] = down32(line.o[k]);
                    r.o_up[k] = up32(line.o[k]);
                }
            }
        }
        let mut fine = true;
        for k in 0..3 {
            let (o, d) = (line.o[k], line.d[k]);
            let o32 = o as f32;
            fine &= o32.is_finite();
            if d == 0.0 {
                continue;
            }
            let inv = (1.0 / d) as f32;
            fine &= inv.is_finite() && inv.abs() >= f32::MIN_POSITIVE;
            let (cn, cf) = c_bounds(o, inv);
            fine &= cn.is_finite() && cf.is_finite();
            r.inv[k] = inv;
            r.neg_c_near[k] = -cn;
            r.neg_c_far[k] = -cf;
            // The plane entered by: the lower where 1/d > 0, else the upper.
            let neg = (inv < 0.0) as usize;
            r.near[k] = (k + 3 * neg) * WIDTH;
            r.far[k] = (k + 3 * (1 - neg)) * WIDTH;
        }
        fine.then_some(r)
    }

    /// [`RayBoxes::new`] in AVX2 for a direction with no zero component (the three axes in
    /// three lanes of float64; else the portable code): the same operations in the same order,
    /// each rounded once as the scalar code rounds it (no fused multiply-add, conversions to
    /// float32 to nearest), so the same constants bit for bit and the same None.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn new_avx2(line: &Line, infinite: bool) -> Option<RayBoxes> {
        let mut boxes = MaybeUninit::uninit();
        RayBoxes::write_avx2(line, infinite, boxes.as_mut_ptr()).then(|| boxes.assume_init())
    }

    /// [`RayBoxes::at`] at the AVX2 level, written into `dst` (false: none, `dst` left as it
    /// is). Written in place: a `RayBoxes` returned was stored in pieces and copied on whole,
    /// and the copy waited for those stores to retire.
    ///
    /// # Safety
    /// AVX2 is there; `dst` is valid for a write.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn write_avx2(line: &Line, infinite: bool, dst: *mut RayBoxes) -> bool {
        use std::arch::x86_64::*;
        let (o, d) = (line.o, line.d);
        if d.contains(&0.0) {
            return match RayBoxes::new(line, infinite) {
                Some(b) => {
                    dst.write(b);
                    true
                }
                None => false,
            };
        }
        // Lane 3 is a harmless axis (o = 0, d = 1) whose answers are not read.
        let dv = _mm256_set_pd(1.0, d[2], d[1], d[0]);
        let ov = _mm256_set_pd(0.0, o[2], o[1], o[0]);
        let sign = _mm256_set1_pd(-0.0);
        let abs = |x: __m256d| _mm256_andnot_pd(sign, x);
        let o32 = _mm256_cvtpd_ps(ov);
        let inv = _mm256_cvtpd_ps(_mm256_div_pd(_mm256_set1_pd(1.0), dv));
        let (o32d, invd) = (_mm256_cvtps_pd(o32), _mm256_cvtps_pd(inv));
        let c = _mm256_mul_pd(o32d, invd);
        let pad = _mm256_mul_pd(
            _mm256_mul_pd(abs(_mm256_sub_pd(ov, o32d)), abs(invd)),
            _mm256_set1_pd(1.0 + f64::EPSILON),
        );
        // above32 and below32: x ± (|x| · REL32 + ABS32), then to float32.
        let slack = |x: __m256d| {
            _mm256_add_pd(
                _mm256_mul_pd(abs(x), _mm256_set1_pd(REL32)),
                _mm256_set1_pd(ABS32),
            )
        };
        let up = _mm256_add_pd(c, pad);
        let down = _mm256_sub_pd(c, pad);
        let cn = _mm256_cvtpd_ps(_mm256_add_pd(up, slack(up)));
        let cf = _mm256_cvtpd_ps(_mm256_sub_pd(down, slack(down)));
        // Finite float32s (|x| < inf; NaN fails), and reciprocals not below the normals.
        let abs32 = |x: __m128| _mm_andnot_ps(_mm_set1_ps(-0.0), x);
        let below = |x: __m128, bound: f32| _mm_cmplt_ps(abs32(x), _mm_set1_ps(bound));
        let fine = _mm_and_ps(
            _mm_and_ps(below(o32, f32::INFINITY), below(inv, f32::INFINITY)),
            _mm_and_ps(below(cn, f32::INFINITY), below(cf, f32::INFINITY)),
        );
        let normal = _mm_cmpge_ps(abs32(inv), _mm_set1_ps(f32::MIN_POSITIVE));
        if _mm_movemask_ps(_mm_and_ps(fine, normal)) & 0b111 != 0b111 {
            return false;
        }
        let mut lanes = [[0f32; 4]; 3];
        _mm_storeu_ps(lanes[0].as_mut_ptr(), inv);
        _mm_storeu_ps(lanes[1].as_mut_ptr(), cn);
        _mm_storeu_ps(lanes[2].as_mut_ptr(), cf);
        let [inv, cn, cf] = lanes;
        let neg = |k: usize| (inv[k] < 0.0) as usize;
        dst.write(RayBoxes {
            near: [0, 1, 2].map(|k| (k + 3 * neg(k)) * WIDTH),
            far: [0, 1, 2].map(|k| (k + 3 * (1 - neg(k))) * WIDTH),
            inv: [inv[0], inv[1], inv[2]],
            neg_c_near: [-cn[0], -cn[1], -cn[2]],
            neg_c_far: [-cf[0], -cf[1], -cf[2]],
            o_down: [f32::NEG_INFINITY; 3],
            o_up: [f32::INFINITY; 3],
            zero: false,
        });
        true
    }

    /// The ray's range in float32, rounded outward (tmin ≥ 0).
    #[inline(always)]
    fn range(tmin: f64, reach: f64) -> (f32, f32) {
        (max32(below32(tmin), 0.0), above32(reach))
    }
}

impl BoxTest for RayBoxes {
    #[inline(always)]
    fn test(&self, node: &Node8, tmin: f64, reach: f64) -> (u32, [f32; WIDTH]) {
        let (t0, t1) = RayBoxes::range(tmin, reach);
        let (b, flat) = (&node.bounds, node.bounds.as_flattened());
        let mut mask = 0;
        let mut nears = [0.0; WIDTH];
        for s in 0..WIDTH {
            let tn = |k: usize| flat[self.near[k] + s].mul_add(self.inv[k], self.neg_c_near[k]);
            let tf = |k: usize| flat[self.far[k] + s].mul_add(self.inv[k], self.neg_c_far[k]);
            let near = max32(max32(tn(0), tn(1)), max32(tn(2), t0));
            let far = min32(min32(tf(0), tf(1)), min32(tf(2), t1));
            let near = near * (1.0 - PAD);
            let far = far.abs().mul_add(PAD, far) + TINY;
            let mut hit = near <= far;
            if self.zero {
                for k in 0..3 {
                    hit &= b[k][s] <= self.o_up[k] && self.o_down[k] <= b[3 + k][s];
                }
            }
            mask |= (hit as u32) << s;
            nears[s] = near;
        }
        (mask, nears)
    }
}

/// The AVX2 test as a function (what the tests call).
#[cfg(all(test, target_arch = "x86_64"))]
#[target_feature(enable = "avx2,fma")]
#[inline]
unsafe fn avx2_test(r: &RayBoxes, node: &Node8, tmin: f64, reach: f64) -> (u32, [f32; WIDTH]) {
    let (t0, t1) = RayBoxes::range(tmin, reach);
    avx2_box_test!(r, node, t0, t1)
}

/// Reshetov's float64 slab test on each child (rays the float32 test does not take).
struct Wide64(Slab);

impl BoxTest for Wide64 {
    fn test(&self, node: &Node8, tmin: f64, reach: f64) -> (u32, [f32; WIDTH]) {
        let mut mask = 0;
        let mut nears = [0.0; WIDTH];
        for (s, near) in nears.iter_mut().enumerate() {
            if node.child[s] == EMPTY {
                continue;
            }
            if let Some(t) = self.0.enter(&node.slot_box(s), tmin, reach) {
                mask |= 1 << s;
                // NaN (an entry past float64's range) prunes nothing.
                *near = if t.is_nan() { 0.0 } else { down32(t.max(0.0)) };
            }
        }
        (mask, nears)
    }
}

/// The walk's state: the SIMD level and the traversal stacks (one per ray walked at once),
/// kept from ray to ray.
pub struct State {
    simd: Simd,
    stack: Vec<(u32, f32)>,
    // Only the two-ray walk, an x86-64 level, reads these (aarch64 walks one ray at a time).
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    second: Vec<(u32, f32)>,
    /// The stack of a ray walked alone while two are walked in turn.
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    alone: Vec<(u32, f32)>,
}

/// How many rays [`ExactBvhAt::make_ready`] makes ready at once: enough for their setups to
/// overlap, few enough that they stay in the first-level cache (a few hundred bytes each).
// Tests size their batches by it on every target.
#[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
const READY: usize = 16;

/// Where `make_ready` stands in a chunk: the next ray to read, and the root's box for the
/// pre-pass ([`outside_avx2`]; None: every ray is made ready).
#[cfg(target_arch = "x86_64")]
struct Feed {
    next: usize,
    root: Option<Outside>,
}

/// A ray being walked beside another ([`ExactBvhAt::trace_two_avx2`]).
#[cfg(target_arch = "x86_64")]
struct Slot<G> {
    line: Line,
    gather: G,
    boxes: RayBoxes,
    cursor: Cursor,
    index: usize,
}

/// The tree walked at one SIMD level (what the accelerator table hands a cast).
pub struct ExactBvhAt<'a> {
    pub bvh: &'a ExactBvh,
    pub simd: Simd,
}

impl Accel<f64> for ExactBvhAt<'_> {
    const NAME: &'static str = "exact_bvh";
    type State = State;

    fn state(&self, _: usize) -> State {
        State {
            simd: self.simd,
            stack: Vec::with_capacity(8 * 32),
            second: Vec::with_capacity(8 * 32),
            alone: Vec::new(),
        }
    }

    fn trace<K: QueryKind>(&self, query: &K, ray: &Ray, st: &mut State) -> K::Answer {
        let line = match Line::new(ray) {
            Ok(line) => line,
            Err(status) => return query.skipped(status),
        };
        let mut gather = query.gather(&line);
        let visited = self.bvh.walk(&line, &mut gather, st.simd, &mut st.stack);
        query.gathered(&mut gather, visited)
    }

    fn trace_chunk<K: QueryKind, S: Sink<K::Answer>>(
        &self,
        query: &K,
        ray_at: impl Fn(usize) -> Ray,
        out: &mut S,
        st: &mut State,
    ) {
        #[cfg(target_arch = "x86_64")]
        if st.simd == Simd::Avx2 {
            // SAFETY: Simd::Avx2 is only chosen where the CPU has AVX2 and FMA.
            return unsafe { self.trace_two_avx2(query, ray_at, out, st) };
        }
        trace_each(self, query, ray_at, out, st)
    }
}

impl ExactBvhAt<'_> {
    /// The chunk's rays walked two at a time, a step of one and a step of the other in turn,
    /// each starting the next ray when it is done: one ray's walk is a chain of dependent
    /// loads and compares longer than the core's reorder window, and the other's steps fill
    /// its waits. Each ray takes the same steps as walked alone, so the same answer, bit for
    /// bit, `steps` included. The rays are made ready for their walks [`READY`] at a time
    /// ([`ExactBvhAt::make_ready`]).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn trace_two_avx2<K: QueryKind, S: Sink<K::Answer>>(
        &self,
        query: &K,
        ray_at: impl Fn(usize) -> Ray,
        out: &mut S,
        st: &mut State,
    ) {
        let bvh = self.bvh;
        let mut feed = Feed {
            next: 0,
            root: bvh.outside_box(),
        };
        // The rays made ready, walked where they lie: moved into slots, a ray's few hundred
        // bytes cost two library copies each.
        let mut ready: Vec<ManuallyDrop<Slot<K::Gather>>> = Vec::with_capacity(READY);
        let State {
            stack,
            second,
            alone,
            ..
        } = st;
        let (stack, second) = (stack as *mut Vec<_>, second as *mut Vec<_>);
        loop {
            // Every entry of the last batch has been read out: its gatherers were dropped
            // one by one, so the entries are cleared without drops.
            ready.clear();
            self.make_ready(query, &ray_at, out, alone, &mut feed, &mut ready);
            let n = ready.len();
            if n == 0 {
                break;
            }
            // The entry walked now and the one walked next, with their stacks, swapped after
            // each step (pointers: an index into `ready` and an `Option` per slot were a
            // bounds check, a multiply and two tests a step). When no entry is left to start,
            // both name the last ray walking, which then walks alone.
            let base = ready.as_mut_ptr().cast::<Slot<K::Gather>>();
            (*stack).clear();
            (*second).clear();
            let mut cur = (base, stack);
            let mut other = if n > 1 { (base.add(1), second) } else { cur };
            let (mut taken, mut live) = (n.min(2), n.min(2));
            loop {
                // SAFETY: `cur` names an entry below n (written by make_ready, its gatherer
                // not yet dropped) and one of the two stacks; the other slot names another
                // entry and the other stack, or the same ones.
                let (s, walk_stack) = (&mut *cur.0, &mut *cur.1);
                let (r, line) = (&s.boxes, &s.line);
                let going = walk_step!(
                    bvh,
                    line,
                    &mut s.gather,
                    walk_stack,
                    &mut s.cursor,
                    |node, _tmin, _reach, t0, t1| avx2_box_test!(r, node, t0, t1),
                    |tris| may_meet_avx2!(line, tris)
                );
                if !going {
                    out.put(s.index, query.gathered(&mut s.gather, s.cursor.visited));
                    // SAFETY: the entry is walked no more, and `ready` is cleared without
                    // drops: its gatherer is dropped here, once.
                    std::ptr::drop_in_place(&mut s.gather);
                    if taken < n {
                        cur.0 = base.add(taken);
                        taken += 1;
                        walk_stack.clear();
                    } else {
                        live -= 1;
                        if live == 0 {
                            break;
                        }
                        cur = other;
                    }
                }
                std::mem::swap(&mut cur, &mut other);
            }
        }
    }

    /// Makes up to [`READY`] of the chunk's rays, from ray `feed.next` on, ready to be walked in
    /// turn (their lines, float32 box constants, gatherers and cursors), and answers the rays
    /// met on the way that are not: those no query traces at once, those whose walk would
    /// enter no box of `feed.root` ([`outside_avx2`]), and those the float32 box test does not
    /// take by a walk alone on `alone`.
    ///
    /// In three passes over the batch, each writing what the next reads: made one ray at a
    /// time as each walk began, each ray's parts were stored in pieces and read back whole
    /// at once (the ray, its line, the line's copy in the gatherer, the box constants), and
    /// each such read waited for the stores to retire (store forwarding fails on it), several
    /// times a ray. A pass later, they have.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn make_ready<K: QueryKind, S: Sink<K::Answer>>(
        &self,
        query: &K,
        ray_at: &impl Fn(usize) -> Ray,
        out: &mut S,
        alone: &mut Vec<(u32, f32)>,
        feed: &mut Feed,
        ready: &mut Vec<ManuallyDrop<Slot<K::Gather>>>,
    ) {
        // Until some ray is ready or none is left (a batch may hold only rays answered on
        // the way).
        while ready.is_empty() && feed.next < out.len() {
            // First pass: the next READY rays (`ray_at`, inlined by the cast, builds each in place).
            let mut rays = [const { MaybeUninit::<Ray>::uninit() }; READY];
            let first = feed.next;
            let read = READY.min(out.len() - first);
            for (k, ray) in rays[..read].iter_mut().enumerate() {
                ray.write(ray_at(first + k));
            }
            feed.next += read;
            // The rays whose walk would enter no box, answered without one ([`outside_avx2`]).
            // Each pass visits the set bits of its mask: no branch per ray on which kind it is.
            let (mut outside, mut fits) = (0u32, 0u32);
            if let Some(b) = &feed.root {
                for (k, ray) in rays[..read].iter().enumerate() {
                    // SAFETY: the first pass wrote rays 0..read.
                    let (fit, out) = outside_avx2(b, &*ray.as_ptr());
                    outside |= (out as u32) << k;
                    fits |= (fit as u32) << k;
                }
                let mut m = outside;
                while m != 0 {
                    let k = m.trailing_zeros() as usize;
                    m &= m - 1;
                    out.put(first + k, query.outside());
                }
            }
            // Second pass: the lines of those that are traced.
            let mut lines = [const { MaybeUninit::<(Line, usize)>::uninit() }; READY];
            let mut count = 0;
            let mut rest = (u32::MAX >> (32 - read)) & !outside;
            while rest != 0 {
                let k = rest.trailing_zeros() as usize;
                rest &= rest - 1;
                // SAFETY: the first pass wrote rays 0..read.
                let ray = &*rays[k].as_ptr();
                // A ray within `outside_avx2`'s magnitudes, its bounds not NaN, passes every
                // INVALID check of `checked_range` (finite numbers; direction components from
                // 2^-60 to 2^60 scale exactly): only its range is left to check. Checking it
                // all again cost a traced ray about 50 instructions.
                let range = if fits >> k & 1 != 0 {
                    valid_range(ray.tmin, ray.tmax)
                } else {
                    checked_range(ray)
                };
                debug_assert_eq!(range, checked_range(ray));
                match range {
                    Ok((tmin, tmax)) => {
                        lines[count].write((Line::within(ray, tmin, tmax), first + k));
                        count += 1;
                    }
                    Err(status) => out.put(first + k, query.skipped(status)),
                }
            }
            // Third pass: their gatherers, box constants and cursors, written field by field
            // into the entries (a whole slot pushed was built aside and copied in by a library
            // call).
            for entry in &lines[..count] {
                // SAFETY: the second pass wrote entries 0..count.
                let (line, j) = &*entry.as_ptr();
                let n = ready.len();
                // SAFETY: `slot` is the Vec's first spare entry (n < READY ≤ its capacity); every
                // field is written before the length takes it in.
                let slot = ready.spare_capacity_mut()[0]
                    .as_mut_ptr()
                    .cast::<Slot<K::Gather>>();
                if !RayBoxes::write_avx2(
                    line,
                    self.bvh.infinite,
                    std::ptr::addr_of_mut!((*slot).boxes),
                ) {
                    let mut gather = query.gather(line);
                    let visited = self.bvh.walk(line, &mut gather, Simd::Avx2, alone);
                    out.put(*j, query.gathered(&mut gather, visited));
                    continue;
                }
                let gather = query.gather(line);
                std::ptr::addr_of_mut!((*slot).cursor).write(Cursor::start(line, gather.reach()));
                std::ptr::addr_of_mut!((*slot).gather).write(gather);
                std::ptr::addr_of_mut!((*slot).line).write(*line);
                std::ptr::addr_of_mut!((*slot).index).write(*j);
                ready.set_len(n + 1);
            }
        }
    }
}

/// The box of the root's children in float64 (lane 3: all of space, which no ray leaves), and
/// per axis the larger magnitude of its bounds (lane 3: 0): what [`outside_avx2`] tests a ray
/// against before making it ready for a walk.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy, Debug)]
struct Outside {
    lo: [f64; 4],
    hi: [f64; 4],
    bmax: [f64; 4],
}

/// The magnitudes [`outside_avx2`] takes: origins and bounds up to 2^60, direction components
/// from 2^-60 to 2^60. Within them every number of the ray's float32 box test ([`RayBoxes`])
/// is a finite normal float32 (1/d ≤ 2^60, o·(1/d) ≤ 2^120, planes times 1/d ≤ 2^120), so
/// the walk takes every such ray with that test, and its bound below holds.
#[cfg(target_arch = "x86_64")]
const OUTSIDE_BIG: f64 = (1u64 << 60) as f64;
#[cfg(target_arch = "x86_64")]
const OUTSIDE_SMALL: f64 = 1.0 / OUTSIDE_BIG;
/// The pre-pass answers a ray only when the gap between its entry and exit of the root's box
/// exceeds `OUTSIDE_GAP · S + OUTSIDE_ABS` (see [`outside_avx2`]).
#[cfg(target_arch = "x86_64")]
const OUTSIDE_GAP: f64 = 1.0 / (1u64 << 15) as f64;
#[cfg(target_arch = "x86_64")]
const OUTSIDE_ABS: f64 = 1e-30;

impl ExactBvh {
    /// The root's box for the pre-pass, or None where it does not apply: an empty tree, a
    /// tree with an infinite bound (its rays may take the float64 test), or bounds past
    /// [`OUTSIDE_BIG`]. Read from the nodes at each chunk, so it follows a refit.
    #[cfg(target_arch = "x86_64")]
    fn outside_box(&self) -> Option<Outside> {
        if self.infinite {
            return None;
        }
        let root = &self.nodes[0];
        let slots = (0..WIDTH).filter(|&s| root.child[s] != EMPTY);
        let bound = |row: usize| slots.clone().map(move |s| root.bounds[row][s] as f64);
        // Lane 3 is all of space, with no magnitude.
        let lo = [0, 1, 2, 3].map(|k| match k {
            3 => f64::NEG_INFINITY,
            _ => bound(k).fold(f64::INFINITY, f64::min),
        });
        let hi = [0, 1, 2, 3].map(|k| match k {
            3 => f64::INFINITY,
            _ => bound(3 + k).fold(f64::NEG_INFINITY, f64::max),
        });
        let bmax = [0, 1, 2, 3].map(|k| match k {
            3 => 0.0,
            _ => lo[k].abs().max(hi[k].abs()),
        });
        // No children (the bounds stay infinite) or bounds too large; NaN fails too.
        if !bmax.iter().all(|&b| b <= OUTSIDE_BIG) {
            return None;
        }
        Some(Outside { lo, hi, bmax })
    }
}

/// Whether `ray` lies within the magnitudes below with bounds that are not NaN (`fits`; the
/// pre-pass decides only those), and true in the second only when the walk of `ray` would
/// enter none of the root's children: the float32 box test ([`RayBoxes`], [`avx2_box_test!`])
/// misses each of them over the widest range, [0, ∞). Then the walk offers nothing and its
/// answer is [`QueryKind::outside`] (`steps` 0), which `make_ready` gives without making the
/// ray ready: random rays miss the whole scene half the time, and making one ready (its line,
/// box constants, gatherer) cost more than its walk.
///
/// Why the float32 test misses. Write t_k = (b − o_k)/d_k for an exact slab distance, and
/// S = max_k (bmax_k + |o_k|)/|d_k|, which bounds every |t_k| of the root's children. Per
/// [`RayBoxes`], the test's entry at plane b is fl32(b·inv − c_near), with inv = 1/d (1 + η),
/// |η| ≤ 2^-23, and c_near within 2^-20·|o|·|inv| + 2^-148 of o32·inv; so it is within
/// 2^-19·S + 2^-148 of t_k before its rounding and within 2^-18·S + 2^-147 after (the exit
/// alike). The entry's max with t0 ≥ 0, scaled by (1 − PAD), and the exit's min, raised by
/// PAD·|exit| + TINY, move each by at most 2^-20·S + 2^-125 more. So a child the test keeps has
/// exact entry max(0, max_k t_near) and exit min_k t_far within 2^-16·S + 2^-124 of each
/// other. A child lies in the root's box, so its entry is at least the box's and its exit at
/// most the box's: a ray whose exact entry into the box exceeds its exit by more than
/// 2^-16·S + 2^-124 is kept by no child.
///
/// Here that gap is computed in float64 (each t_k within 2^-50·S of exact, the gap within
/// 2^-49·S) and compared with 2^-15·S + 10^-30 ([`OUTSIDE_GAP`], [`OUTSIDE_ABS`]), so a ray
/// answered here has an exact gap above 2^-16·S + 2^-124. Rays outside the magnitudes of
/// [`OUTSIDE_BIG`] (a zero direction component among them) and NaN ranges go on to the walk,
/// as do rays the margin leaves in doubt; the answer is the same either way, `steps` included.
/// `exact_bvh::tests::outside_rays_miss_every_root_box_in_the_float32_test` checks the
/// implication on rays that pass the box closer than the test's padding.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn outside_avx2(b: &Outside, ray: &Ray) -> (bool, bool) {
    use std::arch::x86_64::*;
    // Lane 3: o = 0, d = 1 against all of space (entry −∞, exit +∞, S term 0).
    let o = _mm256_set_pd(0.0, ray.o[2], ray.o[1], ray.o[0]);
    let d = _mm256_set_pd(1.0, ray.d[2], ray.d[1], ray.d[0]);
    let sign = _mm256_set1_pd(-0.0);
    let (ao, ad) = (_mm256_andnot_pd(sign, o), _mm256_andnot_pd(sign, d));
    let big = _mm256_set1_pd(OUTSIDE_BIG);
    // NaN fails every compare.
    let ok = _mm256_and_pd(
        _mm256_and_pd(
            _mm256_cmp_pd::<_CMP_GE_OQ>(ad, _mm256_set1_pd(OUTSIDE_SMALL)),
            _mm256_cmp_pd::<_CMP_LE_OQ>(ad, big),
        ),
        _mm256_cmp_pd::<_CMP_LE_OQ>(ao, big),
    );
    let r = _mm256_div_pd(_mm256_set1_pd(1.0), d);
    let lo = _mm256_mul_pd(_mm256_sub_pd(_mm256_loadu_pd(b.lo.as_ptr()), o), r);
    let hi = _mm256_mul_pd(_mm256_sub_pd(_mm256_loadu_pd(b.hi.as_ptr()), o), r);
    let (entry, exit) = (_mm256_min_pd(lo, hi), _mm256_max_pd(lo, hi));
    let s = _mm256_mul_pd(
        _mm256_add_pd(_mm256_loadu_pd(b.bmax.as_ptr()), ao),
        _mm256_andnot_pd(sign, r),
    );
    // The largest and smallest of four lanes.
    let hmax = |v: __m256d| {
        let m = _mm_max_pd(_mm256_castpd256_pd128(v), _mm256_extractf128_pd::<1>(v));
        _mm_cvtsd_f64(_mm_max_sd(m, _mm_unpackhi_pd(m, m)))
    };
    let hmin = |v: __m256d| {
        let m = _mm_min_pd(_mm256_castpd256_pd128(v), _mm256_extractf128_pd::<1>(v));
        _mm_cvtsd_f64(_mm_min_sd(m, _mm_unpackhi_pd(m, m)))
    };
    let (entry, exit) = (hmax(entry).max(0.0), hmin(exit));
    let margin = hmax(s) * OUTSIDE_GAP + OUTSIDE_ABS;
    // Without branches: which rays miss is as unpredictable as a coin.
    let fits = (_mm256_movemask_pd(ok) == 0b1111) & !(ray.tmin.is_nan() | ray.tmax.is_nan());
    (fits, fits & (entry - exit > margin))
}

mod fan;
mod packets;
pub mod ray_parity;
pub use fan::Fan;
pub use packets::{ExactBvhPackets, PacketState};

#[cfg(test)]
mod tests;
