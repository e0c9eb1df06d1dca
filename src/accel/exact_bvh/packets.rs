//! The exact 8-wide BVH walked by packets of up to 64 rays that share their origin (issue 35,
//! item 5: camera rays, shadow rays towards one light).
//!
//! A chunk's rays are put in order of direction along a Morton curve (a radix sort), and a
//! packet is a run of consecutive rays with the same origin bits and the same signs of their
//! direction's components, up to 64: a camera's rays make packets of neighbouring pixels.
//!
//! A packet walks the tree once. At a node, one box test for the packet ([`PacketBoxes`]:
//! per axis the interval of its rays' 1/d, rounded outward) keeps every child that some ray
//! meets within its range, with an entry bound at most each ray's. Where that test keeps a
//! leaf, each unsettled ray also runs its own box test ([`RayBoxes`]) on the node, and a leaf
//! is entered only by the rays whose own test keeps it; there each of them tests the
//! triangles as the one-ray walk does (the leaf filter, then `Line::meets_at`) and offers what
//! it meets to its own query. The leaf filter's terms that depend on the origin and the
//! triangles alone (corners less the origin, their 2×2 minors and magnitudes) are made once
//! per leaf for the packet, and each ray takes only their products with its direction: the
//! same operations in the same order as its own filter, so the same masks. So a ray is offered
//! every triangle it meets within its range (and only triangles its own box test keeps), and
//! its answer, decided exactly by the query whatever the order, is the same bit for bit; only
//! the count of boxes it entered (`steps`: here those the packet entered while the ray was
//! unsettled) differs.
//!
//! A packet of one ray, a ray the float32 box test does not take (see [`RayBoxes::new`]), and
//! the rays of a packet whose directions have a zero component walk alone, as
//! [`ExactBvhAt`] walks them; so does a chunk whose first two rays have their own origins.
//! Not the CPU default: on bunny's camera it counts 18% fewer instructions a ray than the
//! one-ray walk but casts at 0.93× its speed (docs/bvh.md).
use super::{
    above32, below32, beyond_reach, c_bounds, offer_leaf, push_by_entry, Child, ExactBvh,
    ExactBvhAt, Node8, RayBoxes, State, PAD, TINY, WIDTH,
};
use crate::accel::reshetov_bvh::{max32, min32};
use crate::accel::tetwalk::direction_key;
use crate::accel::{trace_each, Accel};
use crate::geom::ray::Ray;
use crate::query::gather::{Gather, Line};
use crate::query::{QueryKind, Sink};
use crate::simd::Simd;

/// A packet holds at most this many rays (one bit each in the masks).
pub const MAX_PACKET: usize = 64;

/// A leaf's blocks of four triangles, at most.
#[cfg(target_arch = "x86_64")]
const MAX_BLOCKS: usize = (super::MAX_LEAF as usize).div_ceil(4);

/// The tree walked by packets at one SIMD level.
pub struct ExactBvhPackets<'a> {
    pub bvh: &'a ExactBvh,
    pub simd: Simd,
}

/// One ray of a packet: its line and box constants, what its query keeps, the boxes it
/// entered, and its index in the chunk.
struct PacketRay<G> {
    line: Line,
    boxes: RayBoxes,
    gather: G,
    visited: u32,
    index: usize,
}

/// What a chunk carries from packet to packet: the one-ray walk's state (for rays walked
/// alone), the packet's stack of (child code, the rays that may enter it, the packet's entry
/// bound), and the chunk's order.
pub struct PacketState {
    one: State,
    stack: Vec<(u32, u64, f32)>,
    /// The chunk's (direction key, ray index), sorted.
    order: Vec<u64>,
}

/// A packet's float32 box constants: its rays share their origin, and on each axis their
/// directions have one sign (none zero). Per axis, `inv[0]` ≤ 1/d ≤ `inv[1]` for every ray's
/// exact 1/d (the float64 quotients' extremes rounded outward by [`below32`] and
/// [`above32`], whose slack covers the quotient's rounding), each end with its `c` bounds
/// made as [`RayBoxes::new`] makes them.
///
/// For a plane b, ray i's slab distance is (b − o)·(1/d_i); over 1/d in `[inv0, inv1]` it is
/// at least min((b − o)·inv0, (b − o)·inv1) and at most the max, whatever the sign of b − o.
/// So the packet's entry per axis is the min of the two ends' entries `fma(b, inv, −c_near)`
/// (each ≤ (b − o)·inv before its rounding, as for one ray), its exit the max of the two
/// exits, and the entry over the axes is their max (the min of the exits): at most every
/// ray's entry, at least every ray's exit, so a box that some ray meets in its range passes,
/// and the packet's entry bounds each ray's from below (then padded as for one ray: the fma's
/// rounding and the pad's own, where one ray's bound counts three).
#[derive(Clone, Copy, Debug)]
struct PacketBoxes {
    near: [usize; 3],
    far: [usize; 3],
    inv: [[f32; 3]; 2],
    neg_c_near: [[f32; 3]; 2],
    neg_c_far: [[f32; 3]; 2],
    /// The rays' least tmin, rounded down (≥ 0).
    t0: f32,
}

impl PacketBoxes {
    /// None where some direction has a zero component, the signs differ on an axis, or a
    /// bound leaves float32's normal range (the packet's rays then walk alone).
    fn new<'a>(lines: impl IntoIterator<Item = &'a Line>) -> Option<PacketBoxes> {
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        let mut tmin = f64::INFINITY;
        let mut origin = None;
        for line in lines {
            origin.get_or_insert(line.o);
            for k in 0..3 {
                let q = 1.0 / line.d[k];
                lo[k] = lo[k].min(q);
                hi[k] = hi[k].max(q);
            }
            tmin = tmin.min(line.tmin);
        }
        let origin = origin?;
        let mut p = PacketBoxes {
            near: [0, 1, 2],
            far: [3, 4, 5],
            inv: [[0.0; 3]; 2],
            neg_c_near: [[0.0; 3]; 2],
            neg_c_far: [[0.0; 3]; 2],
            t0: max32(below32(tmin), 0.0),
        };
        for k in 0..3 {
            let (l, h) = (below32(lo[k]), above32(hi[k]));
            // One sign (a zero d gives an infinite quotient: not finite), normal magnitudes.
            let normal = |x: f32| x.is_finite() && x.abs() >= f32::MIN_POSITIVE;
            if !(normal(l) && normal(h) && (l > 0.0) == (h > 0.0)) {
                return None;
            }
            let o = origin[k];
            if !(o as f32).is_finite() {
                return None;
            }
            for (e, v) in [l, h].into_iter().enumerate() {
                let (cn, cf) = c_bounds(o, v);
                if !(cn.is_finite() && cf.is_finite()) {
                    return None;
                }
                p.inv[e][k] = v;
                p.neg_c_near[e][k] = -cn;
                p.neg_c_far[e][k] = -cf;
            }
            let neg = (l < 0.0) as usize;
            p.near[k] = k + 3 * neg;
            p.far[k] = k + 3 * (1 - neg);
        }
        Some(p)
    }

    /// The packet's test of `node`'s eight boxes within `[t0, t1]` (portable).
    #[inline(always)]
    fn test(&self, node: &Node8, t1: f32) -> (u32, [f32; WIDTH]) {
        let b = &node.bounds;
        let mut mask = 0;
        let mut nears = [0.0; WIDTH];
        for s in 0..WIDTH {
            let (mut near, mut far) = (self.t0, t1);
            for k in 0..3 {
                let tn =
                    |e: usize| b[self.near[k]][s].mul_add(self.inv[e][k], self.neg_c_near[e][k]);
                let tf = |e: usize| b[self.far[k]][s].mul_add(self.inv[e][k], self.neg_c_far[e][k]);
                near = max32(near, min32(tn(0), tn(1)));
                far = min32(far, max32(tf(0), tf(1)));
            }
            let near = near * (1.0 - PAD);
            let far = far.abs().mul_add(PAD, far) + TINY;
            mask |= ((near <= far) as u32) << s;
            nears[s] = near;
        }
        (mask, nears)
    }
}

/// [`PacketBoxes::test`] in AVX2 + FMA, eight children at once (a macro, as
/// `avx2_box_test!`): the same operations, so the same mask and entries.
#[cfg(target_arch = "x86_64")]
macro_rules! avx2_packet_test {
    ($p:expr, $node:expr, $t1:expr) => {{
        use std::arch::x86_64::*;
        let (p, b): (&PacketBoxes, &[[f32; WIDTH]; 6]) = ($p, &$node.bounds);
        // SAFETY: as in `avx2_box_test!`: rows near[k] and far[k] are below six, 32-byte
        // aligned.
        let row = |i: usize| _mm256_load_ps(b.as_ptr().cast::<f32>().add(i * WIDTH));
        let mut near = _mm256_set1_ps(p.t0);
        let mut far = _mm256_set1_ps($t1);
        for k in 0..3 {
            let (n, f) = (row(p.near[k]), row(p.far[k]));
            let inv = |e: usize| _mm256_set1_ps(p.inv[e][k]);
            let tn = |e: usize| _mm256_fmadd_ps(n, inv(e), _mm256_set1_ps(p.neg_c_near[e][k]));
            let tf = |e: usize| _mm256_fmadd_ps(f, inv(e), _mm256_set1_ps(p.neg_c_far[e][k]));
            // max32(near, x) is x unless near > x: _mm256_max_ps(x, near) (b unless a > b).
            near = _mm256_max_ps(_mm256_min_ps(tn(1), tn(0)), near);
            far = _mm256_min_ps(_mm256_max_ps(tf(1), tf(0)), far);
        }
        let near = _mm256_mul_ps(near, _mm256_set1_ps(1.0 - PAD));
        let abs = _mm256_andnot_ps(_mm256_set1_ps(-0.0), far);
        let far = _mm256_add_ps(
            _mm256_fmadd_ps(abs, _mm256_set1_ps(PAD), far),
            _mm256_set1_ps(TINY),
        );
        let hit = _mm256_cmp_ps::<_CMP_LE_OQ>(near, far);
        let mut nears = [0.0f32; WIDTH];
        _mm256_storeu_ps(nears.as_mut_ptr(), near);
        (_mm256_movemask_ps(hit) as u32, nears)
    }};
}

/// The packet walk: `$test` is the packet's box test of `node` within `[t0, t1]`, `$filter`
/// the leaf filter of `line` over `tris` (as `walk_loop!`). A box is entered when its entry
/// bound is within the farthest reach of the packet's unsettled rays; at a leaf, each
/// unsettled ray whose reach the bound is within tests the triangles as its own walk would.
/// A ray's `visited` counts the boxes the packet entered while the ray was unsettled.
macro_rules! packet_loop {
    ($bvh:expr, $rays:expr, $stack:expr,
     |$node:ident, $t1:ident| $test:expr,
     |$r:ident, $rnode:ident, $tmin:ident, $reach:ident| $raytest:expr,
     |$o:ident, $tris:ident| $prepare:expr,
     |$line:ident, $prep:ident| $filter:expr) => {{
        let (bvh, rays, stack): (&ExactBvh, &mut [PacketRay<_>], &mut Vec<(u32, u64, f32)>) =
            ($bvh, $rays, $stack);
        let n = rays.len();
        let mut live: u64 = if n == 64 { u64::MAX } else { (1u64 << n) - 1 };
        let mut entered = 0u32;
        let mut reach = farthest(rays, live);
        let mut $t1 = above32(reach);
        stack.clear();
        stack.push((0u32, live, 0.0f32));
        while let Some((code, who, near)) = stack.pop() {
            if beyond_reach(near, reach) {
                continue;
            }
            match Child::of(code) {
                Child::Node(k) => {
                    entered += (code != 0) as u32;
                    let $node: &Node8 = &bvh.nodes[k as usize];
                    let (mask, nears): (u32, [f32; WIDTH]) = $test;
                    // Leaves are entered only by the rays whose own test takes them: each
                    // unsettled ray tests the node's boxes when the packet's test takes a leaf.
                    let leaves = mask & leaf_slots($node);
                    let mut rays_of = [live; WIDTH];
                    if leaves != 0 {
                        let mut m = leaves;
                        while m != 0 {
                            rays_of[m.trailing_zeros() as usize] = 0;
                            m &= m - 1;
                        }
                        let mut bits = live;
                        while bits != 0 {
                            let i = bits.trailing_zeros() as usize;
                            bits &= bits - 1;
                            let ray = &rays[i];
                            let ($r, $rnode, $tmin, $reach) =
                                (&ray.boxes, $node, ray.line.tmin, ray.gather.reach());
                            let (hit, _): (u32, [f32; WIDTH]) = $raytest;
                            let mut m = hit & leaves;
                            while m != 0 {
                                rays_of[m.trailing_zeros() as usize] |= 1 << i;
                                m &= m - 1;
                            }
                        }
                    }
                    let go = (0..WIDTH).fold(0u32, |m, s| m | ((rays_of[s] != 0) as u32) << s);
                    push_by_entry(
                        stack,
                        mask & go,
                        |s| ($node.child[s], rays_of[s], nears[s]),
                        |e| e.2,
                    );
                }
                Child::Leaf { first, count } => {
                    entered += 1;
                    let range = first as usize..(first + count) as usize;
                    let mut bits = who & live;
                    if bits == 0 {
                        continue;
                    }
                    // What the leaf filter takes from the origin and the triangles alone,
                    // made once for the rays that may enter (they share the origin).
                    let $prep = {
                        let $tris = &bvh.triangles[range.clone()];
                        let $o = &rays[bits.trailing_zeros() as usize].line.o;
                        $prepare
                    };
                    while bits != 0 {
                        let i = bits.trailing_zeros() as usize;
                        bits &= bits - 1;
                        let ray = &mut rays[i];
                        if beyond_reach(near, ray.gather.reach()) {
                            continue;
                        }
                        let $line = &ray.line;
                        let masks: (u32, u32) = $filter;
                        if offer_leaf(bvh, &ray.line, &mut ray.gather, range.clone(), masks) {
                            live &= !(1u64 << i);
                            ray.visited = entered;
                        }
                    }
                    if live == 0 {
                        break;
                    }
                    reach = farthest(rays, live);
                    $t1 = above32(reach);
                }
                Child::Empty => {}
            }
        }
        let mut bits = live;
        while bits != 0 {
            let i = bits.trailing_zeros() as usize;
            bits &= bits - 1;
            rays[i].visited = entered;
        }
    }};
}

/// The slots of `node` that hold leaves (a bit each).
#[inline(always)]
fn leaf_slots(node: &Node8) -> u32 {
    (0..WIDTH).fold(0u32, |m, s| {
        m | (matches!(Child::of(node.child[s]), Child::Leaf { .. }) as u32) << s
    })
}

/// The farthest reach of the rays in `live` (bits of `rays`).
#[inline(always)]
fn farthest<G: Gather>(rays: &[PacketRay<G>], live: u64) -> f64 {
    let (mut reach, mut bits) = (f64::NEG_INFINITY, live);
    while bits != 0 {
        let i = bits.trailing_zeros() as usize;
        bits &= bits - 1;
        reach = reach.max(rays[i].gather.reach());
    }
    reach
}

impl ExactBvhPackets<'_> {
    /// Walks the packet `rays` (2 to [`MAX_PACKET`], one origin, boxes `p`) down the tree.
    fn walk_packet<G: Gather>(
        &self,
        rays: &mut [PacketRay<G>],
        p: &PacketBoxes,
        stack: &mut Vec<(u32, u64, f32)>,
    ) {
        #[cfg(target_arch = "x86_64")]
        if self.simd == Simd::Avx2 {
            // SAFETY: Simd::Avx2 is only chosen where the CPU has AVX2 and FMA.
            return unsafe { self.walk_packet_avx2(rays, p, stack) };
        }
        packet_loop!(
            self.bvh,
            rays,
            stack,
            |node, t1| p.test(node, t1),
            |r, node, tmin, reach| super::BoxTest::test(r, node, tmin, reach),
            |_o, _tris| (),
            |_line, _prep| (u32::MAX, 0)
        )
    }

    /// The packet walk compiled for AVX2 and FMA (the box test and leaf filter inlined, as in
    /// `ExactBvh::walk_avx2`).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn walk_packet_avx2<G: Gather>(
        &self,
        rays: &mut [PacketRay<G>],
        p: &PacketBoxes,
        stack: &mut Vec<(u32, u64, f32)>,
    ) {
        let mut edges = [const { std::mem::MaybeUninit::uninit() }; MAX_BLOCKS];
        packet_loop!(
            self.bvh,
            rays,
            stack,
            |node, t1| avx2_packet_test!(p, node, t1),
            |r, node, tmin, reach| {
                let (t0, t1) = RayBoxes::range(tmin, reach);
                avx2_box_test!(r, node, t0, t1)
            },
            |o, tris| {
                // Per block of four triangles, the edge terms of the shared origin (written
                // into `edges`, made once: a value returned was copied by a library call).
                let ov = o.map(|x| std::arch::x86_64::_mm256_set1_pd(x));
                for (e, four) in edges.iter_mut().zip(tris.chunks(4)) {
                    e.write(leaf_edges_avx2!(&ov, four));
                }
                tris.len().div_ceil(4)
            },
            |line, blocks| {
                let (dv, da) = direction_avx2!(line);
                let (mut may, mut sure) = (0u32, 0u32);
                for (block, e) in edges[..blocks].iter().enumerate() {
                    // SAFETY: the first `blocks` entries were written above.
                    let (out, all) = edge_signs_avx2!(&dv, &da, e.assume_init_ref());
                    may |= (!out & 0xf) << (4 * block);
                    sure |= all << (4 * block);
                }
                (may, sure)
            }
        )
    }
}

impl Accel<f64> for ExactBvhPackets<'_> {
    const NAME: &'static str = "exact_bvh_packets";
    type State = PacketState;

    fn state(&self, chunk: usize) -> PacketState {
        PacketState {
            one: self.alone().state(chunk),
            stack: Vec::with_capacity(8 * 32),
            order: Vec::new(),
        }
    }

    fn trace<K: QueryKind>(&self, query: &K, ray: &Ray, state: &mut PacketState) -> K::Answer {
        self.alone().trace(query, ray, &mut state.one)
    }

    fn trace_chunk<K: QueryKind, S: Sink<K::Answer>>(
        &self,
        query: &K,
        ray_at: impl Fn(usize) -> Ray,
        out: &mut S,
        state: &mut PacketState,
    ) {
        let n = out.len();
        // A chunk whose first two rays have their own origins (random rays, secondary rays)
        // is walked ray by ray, without a packet's cost.
        if n < 2 || ray_at(0).o.map(f64::to_bits) != ray_at(1).o.map(f64::to_bits) {
            return trace_each(self, query, ray_at, out, state);
        }
        // Rays in order of direction along a Morton curve (stable: ties keep ray order), so
        // that consecutive rays fill square-ish tiles of a camera's image rather than rows.
        state.order.clear();
        state
            .order
            .extend((0..n).map(|j| (direction_key(ray_at(j).d) as u64) << 32 | j as u64));
        radsort::sort_by_key(&mut state.order, |k| (k >> 32) as u32);
        let order = std::mem::take(&mut state.order);
        let mut rays: Vec<PacketRay<K::Gather>> = Vec::with_capacity(MAX_PACKET);
        let mut key = None;
        let mut q = 0;
        while q < n || !rays.is_empty() {
            // A packet ends at a new origin, at a direction of other signs, at 64 rays or at
            // the chunk's end.
            let index = order.get(q).map_or(n, |k| *k as u32 as usize);
            let ray = (q < n).then(|| ray_at(index));
            let k = ray.map(|r| packet_key(&r));
            if !rays.is_empty() && (k != key || rays.len() == MAX_PACKET) {
                self.finish(query, &mut rays, out, state);
            }
            let Some(ray) = ray else { break };
            key = k;
            q += 1;
            let line = match Line::new(&ray) {
                Ok(line) => line,
                Err(status) => {
                    out.put(index, query.skipped(status));
                    continue;
                }
            };
            // Written field by field into the Vec's first spare entry: a whole ray pushed was
            // built aside and copied in by a library call (a few hundred bytes).
            rays.reserve(1);
            let slot = rays.spare_capacity_mut()[0].as_mut_ptr();
            // SAFETY: `slot` is valid for writes; every field is written before the length
            // takes it in.
            unsafe {
                if !self.write_boxes(&line, std::ptr::addr_of_mut!((*slot).boxes)) {
                    out.put(index, self.trace(query, &ray, state));
                    continue;
                }
                std::ptr::addr_of_mut!((*slot).gather).write(query.gather(&line));
                std::ptr::addr_of_mut!((*slot).line).write(line);
                std::ptr::addr_of_mut!((*slot).visited).write(0);
                std::ptr::addr_of_mut!((*slot).index).write(index);
                rays.set_len(rays.len() + 1);
            }
        }
        state.order = order;
    }
}

/// What rays of one packet share: the origin's bits and the signs of the direction's
/// components (a zero counted apart).
#[inline(always)]
fn packet_key(ray: &Ray) -> ([u64; 3], u8) {
    let signs = (0..3).fold(0u8, |m, k| {
        m | ((ray.d[k] > 0.0) as u8) << k | ((ray.d[k] == 0.0) as u8) << (3 + k)
    });
    (ray.o.map(f64::to_bits), signs)
}

impl ExactBvhPackets<'_> {
    /// The ray's box constants ([`RayBoxes::at`]) written into `dst`; false: none.
    ///
    /// # Safety
    /// `dst` is valid for a write.
    #[inline(always)]
    unsafe fn write_boxes(&self, line: &Line, dst: *mut RayBoxes) -> bool {
        #[cfg(target_arch = "x86_64")]
        if self.simd == Simd::Avx2 {
            // SAFETY: Simd::Avx2 is only chosen where the CPU has AVX2.
            return RayBoxes::write_avx2(line, self.bvh.infinite, dst);
        }
        match RayBoxes::new(line, self.bvh.infinite) {
            Some(b) => {
                dst.write(b);
                true
            }
            None => false,
        }
    }

    fn alone(&self) -> ExactBvhAt<'_> {
        ExactBvhAt {
            bvh: self.bvh,
            simd: self.simd,
        }
    }

    /// Walks the packet gathered so far (alone when it holds one ray) and stores its answers.
    fn finish<K: QueryKind, S: Sink<K::Answer>>(
        &self,
        query: &K,
        rays: &mut Vec<PacketRay<K::Gather>>,
        out: &mut S,
        state: &mut PacketState,
    ) {
        let packet = match rays.as_slice() {
            [_, _, ..] => PacketBoxes::new(rays.iter().map(|r| &r.line)),
            _ => None,
        };
        match packet {
            Some(p) => self.walk_packet(rays, &p, &mut state.stack),
            None => {
                for r in rays.iter_mut() {
                    r.visited =
                        self.bvh
                            .walk(&r.line, &mut r.gather, self.simd, &mut state.one.stack);
                }
            }
        }
        // Answered where they lie, then dropped in place (moved out, each was a library copy).
        for r in rays.iter_mut() {
            out.put(r.index, query.gathered(&mut r.gather, r.visited));
        }
        rays.clear();
    }
}

/// The packet box test of the rays `lines` (one origin) on `node`, within their joint range,
/// at each SIMD level (what the tests call); None where the packet takes none.
#[cfg(test)]
pub(super) fn packet_box_tests(lines: &[Line], node: &Node8) -> Option<Vec<(u32, [f32; WIDTH])>> {
    let p = PacketBoxes::new(lines)?;
    let reach = lines.iter().fold(f64::NEG_INFINITY, |r, l| r.max(l.tmax));
    let t1 = above32(reach);
    #[allow(unused_mut)]
    let mut out = vec![p.test(node, t1)];
    #[cfg(target_arch = "x86_64")]
    if Simd::Avx2.supported() {
        #[target_feature(enable = "avx2,fma")]
        unsafe fn avx2(p: &PacketBoxes, node: &Node8, t1: f32) -> (u32, [f32; WIDTH]) {
            avx2_packet_test!(p, node, t1)
        }
        // SAFETY: the CPU has AVX2 and FMA (`Simd::supported`).
        out.push(unsafe { avx2(&p, node, t1) });
    }
    Some(out)
}
