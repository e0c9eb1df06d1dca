//! Reshetov 2007's tree (`../shared/seeds/003_*`, specs §(b)): a bounding volume hierarchy
//! built by binned SAH whose leaves store their box, traversed here one ray at a time. The
//! paper's packets with frustum vertex culling go on top of this tree.
//!
//! The tree only ever skips what cannot matter, and it decides nothing itself: a box is
//! skipped when its slab interval, rounded outward by the error bound of its evaluation, lies
//! outside [tmin, the query's reach]; a triangle is offered to the query when the ray meets it
//! exactly (`query::gather::Line::meets`), and the query keeps the exact nearest, any, or all.
//! So a BVH answer is what exact arithmetic gives, as the exact walk's is.

use super::Accel;
use crate::error::{Error, Result};
use crate::geom::ray::Ray;
use crate::geom::real::{greater, lesser};
use crate::mesh::surface::check_finite;
use crate::query::gather::{Gather, Line, Tri};
use crate::query::QueryKind;
use std::sync::atomic::{AtomicU64, Ordering::Relaxed};

/// How many ray–triangle tests packets reached at leaves, and how many of them the frustum
/// culled (the paper's "> 90% culled"), summed over every packet cast on one tree.
#[derive(Debug, Default)]
pub struct CullCounters {
    pub tests: AtomicU64,
    /// Culled by the frustum or the aperture test.
    pub culled: AtomicU64,
    /// Of those, culled by the aperture test (what the frustum left).
    pub aperture: AtomicU64,
    /// Leaves where the packet had no prevalent axis (some active ray's direction is zero
    /// or not finite on every axis's reciprocal): tested ray by ray, uncut.
    pub no_axis: AtomicU64,
    /// Leaves reached with one active ray (tested as the one-ray tree does).
    pub lone: AtomicU64,
    /// Leaves reached with two or more active rays (a frustum built).
    pub frusta: AtomicU64,
}

impl Clone for CullCounters {
    fn clone(&self) -> Self {
        let c = |a: &AtomicU64| AtomicU64::new(a.load(Relaxed));
        CullCounters {
            tests: c(&self.tests),
            culled: c(&self.culled),
            aperture: c(&self.aperture),
            no_axis: c(&self.no_axis),
            lone: c(&self.lone),
            frusta: c(&self.frusta),
        }
    }
}

impl CullCounters {
    /// (tests, culled, aperture, no_axis, lone, frusta) so far.
    pub fn read(&self) -> [u64; 6] {
        [
            &self.tests,
            &self.culled,
            &self.aperture,
            &self.no_axis,
            &self.lone,
            &self.frusta,
        ]
        .map(|a| a.load(Relaxed))
    }
}

/// One node, 32 bytes: its box in float32 rounded outward (it holds the float64 box), and
/// either its two children (`count == 0`: `first` and `first + 1`) or its triangles
/// (`count > 0`: `order[first..first + count]`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BvhNode {
    pub lo: [f32; 3],
    pub first: u32,
    pub hi: [f32; 3],
    pub count: u32,
}

const _: () = assert!(std::mem::size_of::<BvhNode>() == 32);

/// How the tree is built.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BvhParams {
    /// The SAH's cost of visiting a node over the cost of testing a triangle (Reshetov's
    /// sweep varies it: larger makes larger leaves and smaller trees).
    pub cost_ratio: f64,
    /// A leaf holds at most this many triangles (more are split even where SAH would not).
    pub max_leaf: u32,
    /// Bins per axis of the binned SAH.
    pub bins: u32,
    /// Whether packets (`reshetov_bvh_packets`) whose rays share an origin also run the
    /// paper's optional aperture test on what the frustum leaves (a walk setting, not the
    /// tree's: kept here so that a sweep sets it with the tree).
    pub aperture: bool,
}

impl Default for BvhParams {
    fn default() -> Self {
        BvhParams {
            cost_ratio: 1.0,
            max_leaf: 8,
            bins: 16,
            aperture: true,
        }
    }
}

impl BvhParams {
    pub fn check(&self) -> Result<()> {
        if !(self.cost_ratio.is_finite() && self.cost_ratio >= 0.0) {
            return Err(Error::InvalidOption(format!(
                "cost_ratio must be a finite number >= 0, got {}",
                self.cost_ratio
            )));
        }
        if self.max_leaf == 0 || self.max_leaf > 1 << 16 {
            return Err(Error::InvalidOption(format!(
                "max_leaf must be in 1..=65536, got {}",
                self.max_leaf
            )));
        }
        if !(2..=256).contains(&self.bins) {
            return Err(Error::InvalidOption(format!(
                "bins must be in 2..=256, got {}",
                self.bins
            )));
        }
        Ok(())
    }
}

/// The tree over a scene's triangles.
#[derive(Clone, Debug)]
pub struct ReshetovBvh {
    pub nodes: Vec<BvhNode>,
    /// The caller's triangle ids in leaf order.
    pub order: Vec<u32>,
    /// The triangles in leaf order (a leaf's are contiguous).
    pub triangles: Vec<Tri>,
    pub params: BvhParams,
    /// What packets' frustum culling did on this tree (`reshetov_bvh_packets`).
    pub culling: CullCounters,
}

/// The smallest float32 ≥ x (NaN stays NaN).
pub(crate) fn up32(x: f64) -> f32 {
    let f = x as f32;
    if (f as f64) < x {
        f.next_up()
    } else {
        f
    }
}

/// The largest float32 ≤ x.
pub(crate) fn down32(x: f64) -> f32 {
    let f = x as f32;
    if (f as f64) > x {
        f.next_down()
    } else {
        f
    }
}

/// A float64 box.
#[derive(Clone, Copy, Debug)]
struct Aabb {
    lo: [f64; 3],
    hi: [f64; 3],
}

impl Aabb {
    const EMPTY: Aabb = Aabb {
        lo: [f64::INFINITY; 3],
        hi: [f64::NEG_INFINITY; 3],
    };

    fn add(&mut self, p: [f64; 3]) {
        self.lo = [0, 1, 2].map(|k| self.lo[k].min(p[k]));
        self.hi = [0, 1, 2].map(|k| self.hi[k].max(p[k]));
    }

    /// The union (an empty box, whose lo is +inf and hi −inf, adds nothing).
    fn join(&mut self, b: &Aabb) {
        self.lo = [0, 1, 2].map(|k| self.lo[k].min(b.lo[k]));
        self.hi = [0, 1, 2].map(|k| self.hi[k].max(b.hi[k]));
    }

    fn of(tri: &Tri) -> Aabb {
        let mut b = Aabb::EMPTY;
        tri.iter().for_each(|&p| b.add(p));
        b
    }

    /// Half the surface area (the SAH needs ratios only); 0 when empty.
    fn half_area(&self) -> f64 {
        let e = [0, 1, 2].map(|k| (self.hi[k] - self.lo[k]).max(0.0));
        if self.lo[0] > self.hi[0] {
            return 0.0;
        }
        e[0] * e[1] + e[1] * e[2] + e[2] * e[0]
    }

    /// In float32, rounded outward: every point of the float64 box is in it.
    fn to_node(self, first: u32, count: u32) -> BvhNode {
        BvhNode {
            lo: self.lo.map(down32),
            first,
            hi: self.hi.map(up32),
            count,
        }
    }
}

/// What a build reads: the triangles' boxes and centres, and the parameters.
struct Builder {
    boxes: Vec<Aabb>,
    /// Each box's centre, once (the binning reads it per axis at every level).
    centres: Vec<[f64; 3]>,
    params: BvhParams,
}

/// Subtrees of fewer triangles than this are built on one thread.
const PARALLEL_MIN: usize = 8192;

impl Builder {
    fn new(triangles: &[Tri], params: BvhParams) -> Builder {
        let boxes: Vec<Aabb> = triangles.iter().map(Aabb::of).collect();
        let centres = boxes
            .iter()
            .map(|b| [0, 1, 2].map(|a| 0.5 * b.lo[a] + 0.5 * b.hi[a]))
            .collect();
        Builder {
            boxes,
            centres,
            params,
        }
    }

    /// The box of the triangles `order` names, and where the binned SAH splits them (after
    /// partitioning `order` so the left part comes first), or None where they stay one leaf.
    fn split(&self, order: &mut [u32], bins: &mut Bins) -> (Aabb, Option<usize>) {
        let (boxes, params) = (&self.boxes, self.params);
        let centre = |k: u32| self.centres[k as usize];
        let nbins = params.bins as usize;
        let mut bounds = Aabb::EMPTY;
        let mut centres = Aabb::EMPTY;
        for &k in order.iter() {
            bounds.join(&boxes[k as usize]);
            centres.add(centre(k));
        }
        let n = order.len();
        if n <= 1 {
            return (bounds, None);
        }
        // The cheapest binned split: (cost, axis, bins left of it).
        let mut best: Option<(f64, usize, usize)> = None;
        let Bins { count, bbox, right } = bins;
        for axis in 0..3 {
            let (c0, c1) = (centres.lo[axis], centres.hi[axis]);
            if c1 <= c0 {
                continue; // every centre in one plane across this axis
            }
            let scale = nbins as f64 / (c1 - c0);
            let bin_of = |k: u32| (((centre(k)[axis] - c0) * scale) as usize).min(nbins - 1);
            count.fill(0);
            bbox.fill(Aabb::EMPTY);
            for &k in order.iter() {
                let b = bin_of(k);
                count[b] += 1;
                bbox[b].join(&boxes[k as usize]);
            }
            // Right-hand sweep, then left-hand with the cost of each cut.
            right.fill((0.0, 0));
            let (mut acc, mut m) = (Aabb::EMPTY, 0);
            for b in (1..nbins).rev() {
                acc.join(&bbox[b]);
                m += count[b];
                right[b] = (acc.half_area(), m);
            }
            let (mut acc, mut m) = (Aabb::EMPTY, 0);
            for cut in 1..nbins {
                acc.join(&bbox[cut - 1]);
                m += count[cut - 1];
                let (ra, rn) = right[cut];
                if m == 0 || rn == 0 {
                    continue;
                }
                let cost = acc.half_area() * m as f64 + ra * rn as f64;
                if best.is_none_or(|(c, _, _)| cost < c) {
                    best = Some((cost, axis, cut));
                }
            }
        }
        let area = bounds.half_area();
        // SAH in units of one triangle test: visiting costs cost_ratio.
        let split_cost =
            best.map(|(c, _, _)| params.cost_ratio + if area > 0.0 { c / area } else { n as f64 });
        let fits = n <= params.max_leaf as usize;
        if fits && split_cost.is_none_or(|c| c >= n as f64) {
            return (bounds, None);
        }
        let mid = match best {
            Some((_, axis, cut)) => {
                let (c0, c1) = (centres.lo[axis], centres.hi[axis]);
                let scale = nbins as f64 / (c1 - c0);
                let mut m = 0;
                for k in 0..order.len() {
                    let b = (((centre(order[k])[axis] - c0) * scale) as usize).min(nbins - 1);
                    if b < cut {
                        order.swap(k, m);
                        m += 1;
                    }
                }
                m
            }
            // Every centre at one point: halve the range.
            None => n / 2,
        };
        (bounds, Some(mid))
    }

    /// The tree over `order` (whose first entry is `offset` in leaf order) on this thread:
    /// node 0 its root, each inner node's children a pair.
    fn build_range(&self, order: &mut [u32], offset: usize) -> Vec<BvhNode> {
        let mut bins = Bins::new(self.params.bins as usize);
        let mut nodes = vec![Aabb::EMPTY.to_node(0, 0)];
        // (node, first, end) ranges of `order` still to split.
        let mut todo = vec![(0usize, 0usize, order.len())];
        while let Some((node, first, end)) = todo.pop() {
            let (bounds, mid) = self.split(&mut order[first..end], &mut bins);
            let Some(mid) = mid else {
                nodes[node] = bounds.to_node((offset + first) as u32, (end - first) as u32);
                continue;
            };
            let left = nodes.len();
            nodes.push(Aabb::EMPTY.to_node(0, 0));
            nodes.push(Aabb::EMPTY.to_node(0, 0));
            nodes[node] = bounds.to_node(left as u32, 0);
            todo.push((left + 1, first + mid, end));
            todo.push((left, first, first + mid));
        }
        nodes
    }

    /// [`Builder::build_range`], the two halves of a large range built side by side (rayon's
    /// join, in the pool it runs in), then laid out as root, the two subtrees' roots (the
    /// pair), the left subtree's other nodes, the right's.
    fn build_par(&self, order: &mut [u32], offset: usize, depth: u32) -> Vec<BvhNode> {
        if order.len() < PARALLEL_MIN || depth >= 6 {
            return self.build_range(order, offset);
        }
        let (bounds, mid) = self.split(order, &mut Bins::new(self.params.bins as usize));
        let Some(mid) = mid else {
            return vec![bounds.to_node(offset as u32, order.len() as u32)];
        };
        let (lo, hi) = order.split_at_mut(mid);
        let (l, r) = rayon::join(
            || self.build_par(lo, offset, depth + 1),
            || self.build_par(hi, offset + mid, depth + 1),
        );
        // Local index i ≥ 1 of the left subtree goes to i + 2; of the right, past the left's.
        let (lbase, rbase) = (2, 2 + l.len() - 1);
        let moved = |n: &BvhNode, base: usize| {
            let mut n = *n;
            if n.count == 0 && n.first != 0 {
                n.first += base as u32;
            }
            n
        };
        let mut nodes = Vec::with_capacity(1 + l.len() + r.len());
        nodes.push(bounds.to_node(1, 0));
        nodes.push(moved(&l[0], lbase));
        nodes.push(moved(&r[0], rbase));
        nodes.extend(l[1..].iter().map(|n| moved(n, lbase)));
        nodes.extend(r[1..].iter().map(|n| moved(n, rbase)));
        nodes
    }
}

/// A split's bin arrays, made once per thread and cleared per node and axis.
struct Bins {
    count: Vec<usize>,
    bbox: Vec<Aabb>,
    right: Vec<(f64, usize)>,
}

impl Bins {
    fn new(bins: usize) -> Bins {
        Bins {
            count: vec![0; bins],
            bbox: vec![Aabb::EMPTY; bins],
            right: vec![(0.0, 0); bins],
        }
    }
}

impl ReshetovBvh {
    /// Builds the tree over `triangles` (the caller's, in its numbering; their corners must be
    /// finite).
    pub fn build(triangles: &[Tri], params: BvhParams) -> Result<ReshetovBvh> {
        params.check()?;
        if triangles.len() >= u32::MAX as usize / 2 {
            return Err(Error::InvalidInput(format!(
                "{} triangles: a BVH holds fewer than 2^31",
                triangles.len()
            )));
        }
        check_finite(triangles)?;
        let builder = Builder::new(triangles, params);
        let mut order: Vec<u32> = (0..triangles.len() as u32).collect();
        // Large subtrees are built side by side (the splits, and so the tree, are the same
        // whatever the thread count; only where its nodes lie in the array differs).
        let nodes = crate::threads::install(None, || builder.build_par(&mut order, 0, 0))?;
        let tris = order.iter().map(|&k| triangles[k as usize]).collect();
        Ok(ReshetovBvh {
            nodes,
            order,
            triangles: tris,
            params,
            culling: CullCounters::default(),
        })
    }

    /// Bytes of the tree: nodes, the id order and the triangles in leaf order.
    pub fn memory(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<BvhNode>()
            + self.order.len() * 4
            + self.triangles.len() * std::mem::size_of::<Tri>()
    }

    /// The number of leaves, and the depth of the deepest.
    pub fn shape(&self) -> (usize, usize) {
        let mut leaves = 0;
        let mut depth = 0;
        let mut stack = vec![(0usize, 1usize)];
        while let Some((k, d)) = stack.pop() {
            let node = &self.nodes[k];
            depth = depth.max(d);
            if node.count > 0 || node.first == 0 {
                leaves += 1;
            } else {
                stack.push((node.first as usize, d + 1));
                stack.push((node.first as usize + 1, d + 1));
            }
        }
        (leaves, depth)
    }

    /// Offers `gather` every triangle the ray meets in range, nearest boxes first, skipping
    /// boxes beyond its reach; the nodes visited.
    pub fn walk<G: Gather>(&self, line: &Line, gather: &mut G, stack: &mut Vec<(u32, f64)>) -> u32 {
        let slab = Slab::new(line);
        stack.clear();
        let mut visited = 0;
        if let Some(near) = slab.enter(&self.nodes[0], line.tmin, gather.reach()) {
            stack.push((0, near));
        }
        while let Some((k, near)) = stack.pop() {
            if near > gather.reach() {
                continue;
            }
            visited += 1;
            let node = &self.nodes[k as usize];
            if node.count > 0 {
                let range = node.first as usize..(node.first + node.count) as usize;
                for j in range {
                    let at = line.meets_at(&self.triangles[j]);
                    if at.is_some_and(|at| gather.offer_at(self.order[j], at)) {
                        return visited;
                    }
                }
                continue;
            }
            if node.first == 0 {
                continue; // the empty tree's root
            }
            let (a, b) = (node.first, node.first + 1);
            let reach = gather.reach();
            let na = slab.enter(&self.nodes[a as usize], line.tmin, reach);
            let nb = slab.enter(&self.nodes[b as usize], line.tmin, reach);
            match (na, nb) {
                (Some(ta), Some(tb)) => {
                    // The nearer on top.
                    if ta <= tb {
                        stack.push((b, tb));
                        stack.push((a, ta));
                    } else {
                        stack.push((a, ta));
                        stack.push((b, tb));
                    }
                }
                (Some(ta), None) => stack.push((a, ta)),
                (None, Some(tb)) => stack.push((b, tb)),
                (None, None) => {}
            }
        }
        visited
    }
}

/// The ray against boxes: per axis the reciprocal of d. Where every component of d has a
/// normal, finite reciprocal (nearly every ray) the test is branch-free; otherwise an axis
/// where d is zero bounds nothing but the origin's slab, and one whose reciprocal is not
/// normal bounds nothing (slabs are conservative, not tight).
pub(crate) struct Slab {
    o: [f64; 3],
    inv: [f64; 3],
    /// Per axis: 0: the slab; 1: d is zero (inside the slab or never); 2: no bound.
    kind: [u8; 3],
    plain: bool,
}

/// Relative error of (b − o) · (1 / d) in float64 is below 3 roundings; twice that, plus the
/// padding's own rounding.
const PAD: f64 = 4.0 * f64::EPSILON;
/// Absolute slack for results that underflow (below the smallest normal, rounding is absolute).
const TINY: f64 = 4.0 * f64::MIN_POSITIVE;

impl Slab {
    pub(crate) fn new(line: &Line) -> Slab {
        let mut kind = [0u8; 3];
        let mut inv = [0.0; 3];
        for k in 0..3 {
            let d = line.d[k];
            if d == 0.0 {
                kind[k] = 1;
                continue;
            }
            inv[k] = 1.0 / d;
            if !(inv[k].is_finite() && inv[k].abs() >= f64::MIN_POSITIVE) {
                kind[k] = 2;
            }
        }
        Slab {
            o: line.o,
            inv,
            kind,
            plain: kind == [0; 3],
        }
    }

    /// A lower bound on where the ray enters the node's box within [tmin, reach]; None when
    /// it surely does not meet the box there. The entry and exit are padded once, after the
    /// max and min over the axes: x − PAD |x| − TINY rises with x, so padding the max is
    /// the max of the padded (and the same for the min).
    #[inline(always)]
    pub(crate) fn enter(&self, node: &BvhNode, tmin: f64, reach: f64) -> Option<f64> {
        let (mut near, mut far) = (tmin, reach);
        for k in 0..3 {
            let (lo, hi) = (node.lo[k] as f64, node.hi[k] as f64);
            if self.plain || self.kind[k] == 0 {
                // inv is finite and non-zero: no NaN (an infinite box side gives ±inf).
                let t0 = (lo - self.o[k]) * self.inv[k];
                let t1 = (hi - self.o[k]) * self.inv[k];
                near = greater(near, lesser(t0, t1));
                far = lesser(far, greater(t0, t1));
            } else if self.kind[k] == 1 && !(self.o[k] >= lo && self.o[k] <= hi) {
                return None;
            }
        }
        let near = near - PAD * near.abs() - TINY;
        let far = far + PAD * far.abs() + TINY;
        // NaN (an entry at +inf: a box past float64's range, as t = |b − o| / |d| may be
        // when d is tiny) skips nothing.
        (near.partial_cmp(&far) != Some(std::cmp::Ordering::Greater)).then_some(near)
    }
}

impl Accel<f64> for ReshetovBvh {
    const NAME: &'static str = "reshetov_bvh";
    /// The traversal stack (node, entry bound), kept from ray to ray.
    type State = Vec<(u32, f64)>;

    fn state(&self, _: usize) -> Self::State {
        Vec::with_capacity(64)
    }

    fn trace<K: QueryKind>(&self, query: &K, ray: &Ray, stack: &mut Self::State) -> K::Answer {
        let line = match Line::new(ray) {
            Ok(line) => line,
            Err(status) => return query.skipped(status),
        };
        let mut gather = query.gather(&line);
        let visited = self.walk(&line, &mut gather, stack);
        query.gathered(gather, visited)
    }
}

pub mod nearest;
#[cfg(test)]
mod tests;
