//! Reshetov 2007's packets with vertex culling (`../shared/seeds/003_*`, specs §(b)) on the
//! BVH of `reshetov_bvh`: rays walk the tree 16 (4×4) or 64 (8×8) at a time, and when a
//! packet reaches a leaf, a frustum around its active rays is built on the prevalent axis and
//! a triangle whose three corners lie outside one of its four side planes is culled for the
//! whole packet (one multiply and two adds per corner, four planes at once).
//!
//! Culling only ever removes triangles no ray of the packet can meet, so the answers stay the
//! exact ones of the one-ray tree: the frustum's rectangles are rounded outward by the error
//! bound of their evaluation, a corner is outside a plane only when its computed distance is
//! below minus the error bound of that evaluation, and NaN or infinite bounds cull nothing.
//! A BVH leaf's box holds its triangles, so every point of a triangle lies within the slab
//! [X0, X1] where the frustum bounds every ray (specs: "exact for ray segments inside the
//! X0..X1 slab"). Surviving triangles are tested ray by ray, exactly (`Line::meets`).

use super::reshetov_bvh::{BvhNode, ReshetovBvh, Slab};
// The counters live with the tree that holds them; this path is `accel`'s re-export.
pub use super::reshetov_bvh::CullCounters;
use super::{trace_each, Accel};
use crate::geom::ray::Ray;
use crate::query::gather::{Gather, Line, Tri};
use crate::query::{QueryKind, Sink};
use crate::traverse::packet::{DirBox, Edge};
use std::sync::atomic::Ordering::Relaxed;

/// The BVH walked in packets of `size` rays (16: the paper's 4×4 for real scenes; 64: its
/// 8×8 for synthetic ones).
pub struct BvhPackets<'a> {
    pub bvh: &'a ReshetovBvh,
    pub size: usize,
}

/// A packet holds at most this many rays (one bit each in the active masks).
pub const MAX_PACKET: usize = 64;

/// A packet's ray: its line, its slab test, what its query keeps, and its index in the chunk.
struct PacketRay<G> {
    line: Line,
    slab: Slab,
    gather: G,
    index: usize,
}

/// Float64 rounding unit (half of EPSILON).
const U: f64 = f64::EPSILON / 2.0;
/// Absolute slack for what underflows.
const TINY: f64 = 4.0 * f64::MIN_POSITIVE;

/// The packet's frustum over one leaf: on the prevalent axis k, between X0 and X1, each
/// active ray's (u, v) coordinates lie within lo + (x − X0)·slope ≤ (u, v) ≤ hi + … (u, v
/// the axes after k). Lanes: [v ≥ vmin, u ≤ umax, v ≤ vmax, u ≥ umin], as the paper's
/// D = [vz, −vy, −vz, vy] + vx·q1 + q0 orders them.
struct Frustum {
    k: usize,
    x0: f64,
    /// Per lane: the sign the corner's coordinate enters with, its axis, the bound at X0 and
    /// the bound's slope along k.
    sign: [f64; 4],
    axis: [usize; 4],
    at0: [f64; 4],
    slope: [f64; 4],
}

impl Frustum {
    /// The frustum of the rays `active` (bits of `rays`) over `node`'s slab on the axis where
    /// every active direction is non-zero, largest on the first ray; None where there is none.
    fn new<G>(rays: &[PacketRay<G>], active: u64, node: &BvhNode) -> Option<Frustum> {
        let first = &rays[active.trailing_zeros() as usize];
        let mut axes = [0usize, 1, 2];
        axes.sort_by(|&a, &b| first.line.d[b].abs().total_cmp(&first.line.d[a].abs()));
        let k = axes.into_iter().find(|&k| {
            let sign = first.line.d[k] > 0.0;
            each(active, |i| {
                let d = rays[i].line.d[k];
                d != 0.0 && (d > 0.0) == sign && d.is_finite()
            })
        })?;
        let (u, v) = ((k + 1) % 3, (k + 2) % 3);
        let (x0, x1) = (node.lo[k] as f64, node.hi[k] as f64);
        // [min, max] of u and v at X0 and at X1 over the active rays, each rounded outward
        // by the error bound of o_j + (X − o_k)·(d_j / d_k): four roundings, each relative
        // to |o_j| + |(X − o_k)·(d_j / d_k)|; twice that for the bound's own rounding.
        let mut lo = [[f64::INFINITY; 2]; 2];
        let mut hi = [[f64::NEG_INFINITY; 2]; 2];
        let mut bits = active;
        while bits != 0 {
            let line = &rays[bits.trailing_zeros() as usize].line;
            bits &= bits - 1;
            for (side, x) in [x0, x1].into_iter().enumerate() {
                let w = x - line.o[k];
                for (slot, j) in [u, v].into_iter().enumerate() {
                    let step = w * (line.d[j] / line.d[k]);
                    let at = line.o[j] + step;
                    let pad = 8.0 * U * (line.o[j].abs() + step.abs()) + TINY;
                    // NaN (0 · inf, a ray nearly parallel to the planes) bounds nothing:
                    // f64::min would skip it.
                    let (l, h) = (at - pad, at + pad);
                    lo[side][slot] = if l.is_nan() {
                        f64::NEG_INFINITY
                    } else {
                        lo[side][slot].min(l)
                    };
                    hi[side][slot] = if h.is_nan() {
                        f64::INFINITY
                    } else {
                        hi[side][slot].max(h)
                    };
                }
            }
        }
        let dx = x1 - x0;
        let slope = |b0: f64, b1: f64| if dx > 0.0 { (b1 - b0) / dx } else { 0.0 };
        // Lanes: v − vmin, umax − u, vmax − v, u − umin.
        Some(Frustum {
            k,
            x0,
            sign: [1.0, -1.0, -1.0, 1.0],
            axis: [v, u, v, u],
            at0: [lo[0][1], hi[0][0], hi[0][1], lo[0][0]],
            slope: [
                slope(lo[0][1], lo[1][1]),
                slope(hi[0][0], hi[1][0]),
                slope(hi[0][1], hi[1][1]),
                slope(lo[0][0], lo[1][0]),
            ],
        })
    }

    /// Bit p set: the corner `c` lies surely outside plane p (beyond every active ray).
    #[inline(always)]
    fn outside(&self, c: &[f64; 3]) -> u8 {
        let w = c[self.k] - self.x0;
        let mut mask = 0u8;
        for p in 0..4 {
            let bound = self.at0[p] + w * self.slope[p];
            let dist = self.sign[p] * (c[self.axis[p]] - bound);
            // Five roundings over |c_j| + |at0| + |w·slope|, doubled; NaN culls nothing.
            let err =
                10.0 * U * (c[self.axis[p]].abs() + self.at0[p].abs() + (w * self.slope[p]).abs())
                    + TINY;
            mask |= ((dist + err < 0.0) as u8) << p;
        }
        mask
    }

    /// Whether no active ray can meet `tri` (whose corners lie in the slab [X0, X1]): all
    /// three corners beyond one plane.
    #[inline(always)]
    fn culls(&self, tri: &Tri) -> bool {
        self.outside(&tri[0]) & self.outside(&tri[1]) & self.outside(&tri[2]) != 0
    }
}

/// Whether `f` holds for every set bit of `bits`.
fn each(mut bits: u64, f: impl Fn(usize) -> bool) -> bool {
    while bits != 0 {
        if !f(bits.trailing_zeros() as usize) {
            return false;
        }
        bits &= bits - 1;
    }
    true
}

/// The counts one packet adds to the tree's [`CullCounters`].
#[derive(Default)]
struct Counts {
    tests: u64,
    culled: u64,
    aperture: u64,
    no_axis: u64,
    lone: u64,
    frusta: u64,
}

impl BvhPackets<'_> {
    /// Walks the packet `rays` (at most [`MAX_PACKET`]) down the tree: a node is visited by
    /// the rays whose padded slab interval meets its box within [tmin, their reach]; leaves
    /// are culled against the frustum of those rays, and what survives is tested ray by ray.
    ///
    /// `shared`: every ray has the same origin; then what the frustum leaves goes through the
    /// aperture test too (when the tree's parameters ask for it): over the box of the active
    /// rays' directions, a triangle two of whose edges have certain, opposite sides for every
    /// direction (`traverse::packet::Edge::side`, the tet-walk packets' exact bound) is met
    /// by none of them. This is the paper's corner-ray test with the direction box's corners
    /// for the corner rays: the side of a line from a shared origin is linear in its
    /// direction, so the box's corners bound every ray's.
    fn walk_packet<G: Gather>(
        &self,
        rays: &mut [PacketRay<G>],
        shared: bool,
        stack: &mut Vec<(u32, u64)>,
        visited: &mut [u32],
        counts: &mut Counts,
    ) {
        let bvh = self.bvh;
        let mut live: u64 = if rays.len() == 64 {
            u64::MAX
        } else {
            (1u64 << rays.len()) - 1
        };
        stack.clear();
        stack.push((0, live));
        while let Some((k, mask)) = stack.pop() {
            let node = &bvh.nodes[k as usize];
            // The rays still unsettled that enter this node's box before their reach.
            let mut active = 0u64;
            let mut bits = mask & live;
            while bits != 0 {
                let i = bits.trailing_zeros() as usize;
                bits &= bits - 1;
                let r = &rays[i];
                if r.slab.enter(node, r.line.tmin, r.gather.reach()).is_some() {
                    active |= 1 << i;
                    visited[i] += 1;
                }
            }
            if active == 0 {
                continue;
            }
            if node.count == 0 {
                if node.first == 0 {
                    continue; // the empty tree's root
                }
                // The child nearer along the first active ray's direction on top.
                let (a, b) = (node.first, node.first + 1);
                let d = rays[active.trailing_zeros() as usize].line.d;
                let (na, nb) = (&bvh.nodes[a as usize], &bvh.nodes[b as usize]);
                let ahead: f64 = (0..3)
                    .map(|j| {
                        d[j] * ((nb.lo[j] as f64 + nb.hi[j] as f64)
                            - (na.lo[j] as f64 + na.hi[j] as f64))
                    })
                    .sum();
                if ahead >= 0.0 {
                    stack.push((b, active));
                    stack.push((a, active));
                } else {
                    stack.push((a, active));
                    stack.push((b, active));
                }
                continue;
            }
            let range = node.first as usize..(node.first + node.count) as usize;
            let m = active.count_ones() as u64;
            counts.tests += m * node.count as u64;
            let frustum = if m == 1 {
                counts.lone += 1;
                None
            } else {
                let f = Frustum::new(rays, active, node);
                if f.is_some() {
                    counts.frusta += 1;
                } else {
                    counts.no_axis += 1;
                }
                f
            };
            let aperture = shared && m > 1 && bvh.params.aperture;
            let mut dirs: Option<DirBox> = None;
            for j in range {
                let tri = &bvh.triangles[j];
                if frustum.as_ref().is_some_and(|f| f.culls(tri)) {
                    counts.culled += m;
                    continue;
                }
                if aperture {
                    let b = dirs.get_or_insert_with(|| {
                        let mut bits = active;
                        DirBox::of(std::iter::from_fn(|| {
                            (bits != 0).then(|| {
                                let i = bits.trailing_zeros() as usize;
                                bits &= bits - 1;
                                &rays[i].line.dir
                            })
                        }))
                    });
                    let o = rays[active.trailing_zeros() as usize].line.o;
                    let seen = tri.map(|c| [c[0] - o[0], c[1] - o[1], c[2] - o[2]]);
                    let sides = Edge::around(seen[0], seen[1], seen[2]).map(|e| e.side(b));
                    if sides.contains(&1) && sides.contains(&-1) {
                        counts.culled += m;
                        counts.aperture += m;
                        continue;
                    }
                }
                let mut bits = active;
                while bits != 0 {
                    let i = bits.trailing_zeros() as usize;
                    bits &= bits - 1;
                    let r = &mut rays[i];
                    let settled = r
                        .line
                        .meets_at(tri)
                        .is_some_and(|at| r.gather.offer(bvh.order[j], tri, at));
                    if settled {
                        live &= !(1 << i);
                        active &= !(1 << i);
                    }
                }
                if active == 0 {
                    break;
                }
            }
        }
    }
}

impl Accel<f64> for BvhPackets<'_> {
    const NAME: &'static str = "reshetov_bvh_packets";
    /// The traversal stacks (the one-ray tree's and the packets'), kept from ray to ray.
    type State = (Vec<(u32, f64)>, Vec<(u32, u64)>);

    fn state(&self, _: usize) -> Self::State {
        (Vec::with_capacity(64), Vec::with_capacity(64))
    }

    fn trace<K: QueryKind>(&self, query: &K, ray: &Ray, state: &mut Self::State) -> K::Answer {
        self.bvh.trace(query, ray, &mut state.0)
    }

    /// Rays in order of origin, then of direction along a Morton curve (so that a camera's
    /// consecutive rays fill square-ish tiles of the image: 16 rays a 4×4 tile, 64 an 8×8),
    /// walked `size` at a time.
    fn trace_chunk<K: QueryKind, S: Sink<K::Answer>>(
        &self,
        query: &K,
        ray_at: impl Fn(usize) -> Ray,
        out: &mut S,
        state: &mut Self::State,
    ) {
        let n = out.len();
        let size = self.size.clamp(1, MAX_PACKET);
        if size == 1 {
            return trace_each(self, query, ray_at, out, state);
        }
        let mut order: Vec<(([u64; 3], u32), u32)> = (0..n)
            .map(|j| {
                let ray = ray_at(j);
                (
                    (
                        ray.o.map(f64::to_bits),
                        super::tetwalk::direction_key(ray.d),
                    ),
                    j as u32,
                )
            })
            .collect();
        order.sort_unstable();
        let mut rays: Vec<PacketRay<K::Gather>> = Vec::with_capacity(size);
        let mut visited = vec![0u32; size];
        let mut counts = Counts::default();
        for group in order.chunks(size) {
            rays.clear();
            for &(_, j) in group {
                let ray = ray_at(j as usize);
                match Line::new(&ray) {
                    Ok(line) => rays.push(PacketRay {
                        slab: Slab::new(&line),
                        gather: query.gather(&line),
                        line,
                        index: j as usize,
                    }),
                    Err(status) => out.put(j as usize, query.skipped(status)),
                }
            }
            if rays.is_empty() {
                continue;
            }
            visited[..rays.len()].fill(0);
            let o = rays[0].line.o.map(f64::to_bits);
            let shared = rays.iter().all(|r| r.line.o.map(f64::to_bits) == o);
            self.walk_packet(&mut rays, shared, &mut state.1, &mut visited, &mut counts);
            for (mut r, &v) in rays.drain(..).zip(visited.iter()) {
                out.put(r.index, query.gathered(&mut r.gather, v));
            }
        }
        let c = &self.bvh.culling;
        c.tests.fetch_add(counts.tests, Relaxed);
        c.culled.fetch_add(counts.culled, Relaxed);
        c.aperture.fetch_add(counts.aperture, Relaxed);
        c.no_axis.fetch_add(counts.no_axis, Relaxed);
        c.lone.fetch_add(counts.lone, Relaxed);
        c.frusta.fetch_add(counts.frusta, Relaxed);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    fn packet(rays: &[([f64; 3], [f64; 3])]) -> Vec<PacketRay<()>> {
        rays.iter()
            .enumerate()
            .map(|(index, &(o, d))| {
                let ray = Ray {
                    o,
                    d,
                    tmin: 0.0,
                    tmax: f64::INFINITY,
                    leaving: None,
                };
                let line = Line::new(&ray).unwrap();
                PacketRay {
                    slab: Slab::new(&line),
                    gather: (),
                    line,
                    index,
                }
            })
            .collect()
    }

    fn leaf_of(tri: &Tri) -> BvhNode {
        let lo = [0, 1, 2].map(|k| tri.iter().map(|c| c[k]).fold(f64::INFINITY, f64::min));
        let hi = [0, 1, 2].map(|k| tri.iter().map(|c| c[k]).fold(f64::NEG_INFINITY, f64::max));
        BvhNode {
            lo: lo.map(|x| (x as f32).next_down()),
            first: 0,
            hi: hi.map(|x| (x as f32).next_up()),
            count: 1,
        }
    }

    /// The frustum culls a triangle only when no ray of the packet meets it (judged by the
    /// exact `Line::meets`), on packets that hug a corner of the triangle (one ray through
    /// the corner, the others fanning out beyond it: the corner sits on the frustum's side,
    /// where a bound without its rounding error culls a triangle a ray meets), and on narrow
    /// packets aimed anywhere near the triangle; and it does cull (most of those miss). The
    /// same for the aperture test. Removing the frustum's error bounds (the rectangles' pad
    /// and the corners' err) fails this test at trial 2.
    #[test]
    fn frustum_culls_only_what_no_ray_meets() {
        let mut rng = Rng::xorshift(7);
        let (mut culled, mut met, mut by_aperture) = (0, 0, 0);
        for trial in 0..20_000 {
            let tri: Tri = [rng.p3(), rng.p3(), rng.p3()];
            let o = [-2.0 - rng.f(), rng.f(), rng.f()];
            let hug = trial % 2 == 0;
            let c = tri[trial % 3];
            let centre = [0, 1, 2].map(|k| (tri[0][k] + tri[1][k] + tri[2][k]) / 3.0);
            let target = [0, 1, 2].map(|_| 1.5 * rng.f() - 0.25);
            let rays: Vec<_> = (0..16)
                .map(|i| {
                    let aim = if !hug {
                        [0, 1, 2].map(|k| target[k] + 0.05 * rng.f())
                    } else if i == 0 {
                        c
                    } else {
                        let r = 0.3 * rng.f();
                        [0, 1, 2].map(|k| c[k] + r * (c[k] - centre[k]) + 1e-3 * (rng.f() - 0.5))
                    };
                    (o, [0, 1, 2].map(|k| aim[k] - o[k]))
                })
                .collect();
            let rays = packet(&rays);
            let f = Frustum::new(&rays, 0xffff, &leaf_of(&tri)).expect("x is prevalent");
            let meets = rays.iter().any(|r| r.line.meets(&tri));
            met += meets as usize;
            if f.culls(&tri) {
                culled += 1;
                assert!(
                    !meets,
                    "trial {trial}: culled a triangle a ray meets: {tri:?} from {o:?}"
                );
            }
            // The aperture test (the rays share their origin).
            let b = DirBox::of(rays.iter().map(|r| &r.line.dir));
            let seen = tri.map(|c| [0, 1, 2].map(|k| c[k] - o[k]));
            let sides = Edge::around(seen[0], seen[1], seen[2]).map(|e| e.side(&b));
            if sides.contains(&1) && sides.contains(&-1) {
                by_aperture += 1;
                assert!(
                    !meets,
                    "trial {trial}: aperture culled a met triangle: {tri:?} from {o:?}"
                );
            }
        }
        assert!(
            culled > 2000 && met > 2000 && by_aperture > 2000,
            "{culled} culled, {by_aperture} by the aperture test, {met} met"
        );
    }
}
