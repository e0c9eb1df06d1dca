//! The exact 8-wide BVH walked by packets of up to 64 rays that share their origin (issue 35,
//! item 5: camera rays, shadow rays towards one light).
//!
//! A packet walks the tree once: at a node, each of its active rays runs its own box test on
//! the eight children (the one-ray walk's test, [`RayBoxes`], at the same SIMD level), and a
//! child is pushed with the rays that may meet it; at a leaf, each of those rays tests the
//! triangles as the one-ray walk does (the leaf filter, then `Line::meets_at`), and offers
//! what it meets to its own query. So a ray is offered exactly the triangles it meets within
//! its range, as it alone would be, and its answer, decided exactly by the query whatever the
//! order, is the same bit for bit; only the count of boxes it entered (`steps`) may differ,
//! since the packet visits children in the order of the nearest entry among its rays.
//!
//! What is shared is the walk's bookkeeping: one stack pop, child decoding, sort and push per
//! node for the packet rather than per ray. Rays are grouped as they come (consecutive rays
//! of a chunk with the same origin bits, up to 64): a camera's rays in image order make
//! packets of neighbouring pixels, with no sort. A chunk whose first two rays have their own
//! origins, a ray the float32 box test does not take (see [`RayBoxes::new`]) and a packet of
//! one walk alone, as [`ExactBvhAt`] walks them. Not the CPU default: on the bench
//! scenes it was 0.64–1.16× the one-ray walk's speed on camera rays (docs/bvh.md).

use super::{push_by_entry, Child, ExactBvh, ExactBvhAt, Node8, RayBoxes, State, WIDTH};
#[cfg(target_arch = "x86_64")]
use super::{PAD, TINY};
use crate::accel::{trace_each, Accel};
use crate::geom::ray::Ray;
use crate::query::gather::{Gather, Line};
use crate::query::{QueryKind, Sink};
use crate::simd::Simd;

/// A packet holds at most this many rays (one bit each in the masks).
pub const MAX_PACKET: usize = 64;

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
/// alone) and the packet stack of (child code, rays, nearest entry among them).
pub struct PacketState {
    one: State,
    stack: Vec<(u32, u64, f32)>,
}

/// The packet walk, with `$test` the box test of one ray (`r: &RayBoxes`) on `node` within
/// `[tmin, reach]` and `$filter` the leaf filter of `line` over `tris` (as `walk_loop!`).
macro_rules! packet_loop {
    ($bvh:expr, $rays:expr, $stack:expr,
     |$r:ident, $node:ident, $tmin:ident, $reach:ident| $test:expr,
     |$line:ident, $tris:ident| $filter:expr) => {{
        let (bvh, rays, stack) = ($bvh, $rays, $stack);
        let n = rays.len();
        let mut live: u64 = if n == 64 { u64::MAX } else { (1u64 << n) - 1 };
        stack.clear();
        stack.push((0u32, live, 0.0f32));
        while let Some((code, mask, near)) = stack.pop() {
            // The rays still unsettled whose reach the packet's nearest entry is within (as
            // the one-ray walk skips a box entered beyond its reach).
            let mut active = 0u64;
            let mut bits = mask & live;
            while bits != 0 {
                let i = bits.trailing_zeros() as usize;
                bits &= bits - 1;
                let ray = &mut rays[i];
                if (near as f64) - (f32::MIN_POSITIVE as f64) <= ray.gather.reach() {
                    active |= 1 << i;
                    ray.visited += (code != 0) as u32;
                }
            }
            if active == 0 {
                continue;
            }
            match Child::of(code) {
                Child::Node(k) => {
                    let $node: &Node8 = &bvh.nodes[k as usize];
                    let mut who = [0u64; WIDTH];
                    let mut nearest = [f32::INFINITY; WIDTH];
                    let mut bits = active;
                    while bits != 0 {
                        let i = bits.trailing_zeros() as usize;
                        bits &= bits - 1;
                        let ray = &rays[i];
                        let ($r, $tmin, $reach) = (&ray.boxes, ray.line.tmin, ray.gather.reach());
                        let (hit, nears): (u32, [f32; WIDTH]) = $test;
                        let mut m = hit;
                        while m != 0 {
                            let s = m.trailing_zeros() as usize;
                            m &= m - 1;
                            who[s] |= 1 << i;
                            nearest[s] = nearest[s].min(nears[s]);
                        }
                    }
                    let children = (0..WIDTH).fold(0u32, |m, s| m | ((who[s] != 0) as u32) << s);
                    // Farthest first, as one ray's walk pushes them.
                    push_by_entry(
                        stack,
                        children,
                        |s| ($node.child[s], who[s], nearest[s]),
                        |e| e.2,
                    );
                }
                Child::Leaf { first, count } => {
                    let range = first as usize..(first + count) as usize;
                    let $tris = &bvh.triangles[range.clone()];
                    let mut bits = active;
                    while bits != 0 {
                        let i = bits.trailing_zeros() as usize;
                        bits &= bits - 1;
                        let ray = &mut rays[i];
                        let $line = &ray.line;
                        let masks: (u32, u32) = $filter;
                        if super::offer_leaf(bvh, &ray.line, &mut ray.gather, range.clone(), masks)
                        {
                            live &= !(1u64 << i);
                        }
                    }
                    if live == 0 {
                        break;
                    }
                }
                Child::Empty => {}
            }
        }
    }};
}

impl ExactBvhPackets<'_> {
    /// Walks the packet `rays` (2 to [`MAX_PACKET`], one origin) down the tree.
    fn walk_packet<G: Gather>(&self, rays: &mut [PacketRay<G>], stack: &mut Vec<(u32, u64, f32)>) {
        #[cfg(target_arch = "x86_64")]
        if self.simd == Simd::Avx2 {
            // SAFETY: Simd::Avx2 is only chosen where the CPU has AVX2 and FMA.
            return unsafe { self.walk_packet_avx2(rays, stack) };
        }
        packet_loop!(
            self.bvh,
            rays,
            stack,
            |r, node, tmin, reach| super::BoxTest::test(r, node, tmin, reach),
            |_line, _tris| (u32::MAX, 0)
        )
    }

    /// The packet walk compiled for AVX2 and FMA (the box test and leaf filter inlined, as in
    /// `ExactBvh::walk_avx2`).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn walk_packet_avx2<G: Gather>(
        &self,
        rays: &mut [PacketRay<G>],
        stack: &mut Vec<(u32, u64, f32)>,
    ) {
        packet_loop!(
            self.bvh,
            rays,
            stack,
            |r, node, tmin, reach| {
                let (t0, t1) = RayBoxes::range(tmin, reach);
                avx2_box_test!(r, node, t0, t1)
            },
            |line, tris| may_meet_avx2!(line, tris)
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
        let mut rays: Vec<PacketRay<K::Gather>> = Vec::with_capacity(MAX_PACKET);
        let mut origin = None;
        let mut j = 0;
        while j < n || !rays.is_empty() {
            // A packet ends at a new origin, at 64 rays or at the chunk's end.
            let ray = (j < n).then(|| ray_at(j));
            let same = ray.is_some_and(|r| origin == Some(r.o.map(f64::to_bits)));
            if !rays.is_empty() && (!same || rays.len() == MAX_PACKET) {
                self.finish(query, &mut rays, out, state);
            }
            let Some(ray) = ray else { break };
            origin = Some(ray.o.map(f64::to_bits));
            let index = j;
            j += 1;
            let line = match Line::new(&ray) {
                Ok(line) => line,
                Err(status) => {
                    out.put(index, query.skipped(status));
                    continue;
                }
            };
            match RayBoxes::at(self.simd, &line, self.bvh.infinite) {
                Some(boxes) => rays.push(PacketRay {
                    gather: query.gather(&line),
                    line,
                    boxes,
                    visited: 0,
                    index,
                }),
                None => out.put(index, self.trace(query, &ray, state)),
            }
        }
    }
}

impl ExactBvhPackets<'_> {
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
        if let [one] = rays.as_mut_slice() {
            one.visited =
                self.bvh
                    .walk(&one.line, &mut one.gather, self.simd, &mut state.one.stack);
        } else {
            self.walk_packet(rays, &mut state.stack);
        }
        for mut r in rays.drain(..) {
            out.put(r.index, query.gathered(&mut r.gather, r.visited));
        }
    }
}
