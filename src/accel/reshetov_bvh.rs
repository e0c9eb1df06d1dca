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

/// `a.min(b)` and `a.max(b)` as one instruction each: the second operand unless the first is
/// smaller (larger), as `minss`/`_mm256_min_ps` and `maxss`/`_mm256_max_ps` pick, so a
/// portable box test picks what the vector one does (`exact_bvh`) and a NaN first operand
/// gives the second. The build's boxes are outward roundings of finite numbers: the NaN
/// rules of `f32::min` (several instructions) buy nothing there.
#[inline(always)]
pub(crate) fn min32(a: f32, b: f32) -> f32 {
    if a < b {
        a
    } else {
        b
    }
}

#[inline(always)]
pub(crate) fn max32(a: f32, b: f32) -> f32 {
    if a > b {
        a
    } else {
        b
    }
}

/// A box in float32, rounded outward from the float64 triangle's: the union of such boxes is
/// the outward rounding of the float64 union (rounding is monotone), so a node's box is what
/// rounding its float64 box outward gives. Four lanes, so that a union is one `minps` and one
/// `maxps`; lane 3 is no coordinate (a [`Prim`] keeps its id there, a union whatever the
/// minimum of such lanes is) and nothing reads it as one.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(16))]
struct Box32 {
    lo: [f32; 4],
    hi: [f32; 4],
}

impl Box32 {
    const EMPTY: Box32 = Box32 {
        lo: [f32::INFINITY; 4],
        hi: [f32::NEG_INFINITY; 4],
    };

    /// The union (an empty box, whose lo is +inf and hi −inf, adds nothing).
    #[inline(always)]
    fn join(&mut self, b: &Box32) {
        for k in 0..4 {
            self.lo[k] = min32(self.lo[k], b.lo[k]);
            self.hi[k] = max32(self.hi[k], b.hi[k]);
        }
    }

    /// Half the surface area, in float64 (the SAH needs ratios only); 0 when empty.
    fn half_area(&self) -> f64 {
        if self.lo[0] > self.hi[0] {
            return 0.0;
        }
        let e = [0, 1, 2].map(|k| (self.hi[k] as f64 - self.lo[k] as f64).max(0.0));
        e[0] * e[1] + e[1] * e[2] + e[2] * e[0]
    }

    fn to_node(self, first: u32, count: u32) -> BvhNode {
        BvhNode {
            lo: [self.lo[0], self.lo[1], self.lo[2]],
            first,
            hi: [self.hi[0], self.hi[1], self.hi[2]],
            count,
        }
    }
}

/// What the build sorts: a triangle's box, with its id in lane 3 of `lo` ([`ID_TAG`]), 32
/// bytes, in one array that the partitions reorder in place, so every pass of the build reads
/// memory in order (through an index array, each read was a cache miss on a large scene).
#[derive(Clone, Copy, Debug)]
struct Prim(Box32);

/// The bits of lane 3 of a [`Prim`]'s `lo` are `ID_TAG | id`: a normal float32 in [2, 4) for
/// every id below 2^30 (the build refuses more triangles), so the lane's arithmetic in the
/// binning never meets a subnormal (a microcode assist on x86) nor a NaN.
const ID_TAG: u32 = 0x4000_0000;

const _: () = assert!(std::mem::size_of::<Prim>() == 32);

impl Prim {
    fn of(id: usize, tri: &Tri) -> Prim {
        let lo = [0, 1, 2].map(|k| down32(tri[0][k].min(tri[1][k]).min(tri[2][k])));
        let hi = [0, 1, 2].map(|k| up32(tri[0][k].max(tri[1][k]).max(tri[2][k])));
        Prim(Box32 {
            lo: [lo[0], lo[1], lo[2], f32::from_bits(ID_TAG | id as u32)],
            hi: [hi[0], hi[1], hi[2], 0.0],
        })
    }

    /// One per triangle, in the caller's order.
    fn all(triangles: &[Tri]) -> Vec<Prim> {
        triangles
            .iter()
            .enumerate()
            .map(|(k, t)| Prim::of(k, t))
            .collect()
    }

    fn id(&self) -> u32 {
        self.0.lo[3].to_bits() & !ID_TAG
    }
}

/// The binning of the three axes: per axis, keys (the box's centre doubled, `lo + hi`: only
/// their order matters) in [c0, c0 + last / scale] to bins 0..=last. The split's counts and
/// its partition both go through [`Axes::bins`], so they agree on every triangle (a NaN key,
/// from a box infinite both ways, goes to bin 0).
#[derive(Clone, Copy)]
struct Axes {
    c0: [f32; 4],
    scale: [f32; 4],
    last: f32,
}

impl Axes {
    #[inline(always)]
    fn bins(&self, b: &Box32) -> [u32; 4] {
        let mut out = [0; 4];
        for (k, out) in out.iter_mut().enumerate() {
            let x = (b.lo[k] + b.hi[k] - self.c0[k]) * self.scale[k];
            // In [0, last] and not NaN (max32 takes 0 for a NaN), so the conversion is exact
            // and in range: no saturating conversion (a dozen instructions) is needed.
            let x = min32(max32(x, 0.0), self.last);
            // SAFETY: x is finite and in [0, 255] (last < bins ≤ 256).
            *out = unsafe { x.to_int_unchecked::<u32>() };
        }
        out
    }
}

/// What a build reads: the parameters (the triangles' boxes travel in the `Prim` array).
struct Builder {
    params: BvhParams,
    /// Ranges of at most this many triangles are leaves, unsplit (1 for Reshetov's tree; the
    /// 8-wide tree's leaf size, whose collapse makes such a subtree one leaf anyway).
    min_split: usize,
}

/// Subtrees of fewer triangles than this are built on one thread.
const PARALLEL_MIN: usize = 8192;

impl Builder {
    /// The box of `prims`, and where the binned SAH splits them (after partitioning `prims`
    /// so the left part comes first), or None where they stay one leaf.
    fn split(&self, prims: &mut [Prim], bins: &mut Bins) -> (Box32, Option<usize>) {
        let params = self.params;
        let nbins = params.bins as usize;
        let mut bounds = Box32::EMPTY;
        let (mut c_lo, mut c_hi) = ([f32::INFINITY; 4], [f32::NEG_INFINITY; 4]);
        for Prim(b) in prims.iter() {
            bounds.join(b);
            for k in 0..4 {
                c_lo[k] = min32(c_lo[k], b.lo[k] + b.hi[k]);
                c_hi[k] = max32(c_hi[k], b.lo[k] + b.hi[k]);
            }
        }
        let n = prims.len();
        if n <= self.min_split {
            return (bounds, None);
        }
        // Axes whose keys span a range (else every centre lies in one plane across it, and
        // all go to bin 0 of a scale 0, which no cut reads).
        let ranged = [0, 1, 2].map(|a| c_hi[a] > c_lo[a]);
        let mut axes = Axes {
            c0: c_lo,
            scale: [0.0; 4],
            last: (nbins - 1) as f32,
        };
        for a in (0..3).filter(|&a| ranged[a]) {
            axes.scale[a] = nbins as f32 / (c_hi[a] - c_lo[a]);
        }
        // The three axes binned in one pass over the triangles.
        let Bins { count, bbox, right } = bins;
        let (count, bbox) = (&mut count[..3 * nbins], &mut bbox[..3 * nbins]);
        count.fill(0);
        bbox.fill(Box32::EMPTY);
        {
            let (c0, rest) = count.split_at_mut(nbins);
            let (c1, c2) = rest.split_at_mut(nbins);
            let (b0, rest) = bbox.split_at_mut(nbins);
            let (b1, b2) = rest.split_at_mut(nbins);
            for Prim(b) in prims.iter() {
                let k = axes.bins(b).map(|k| k as usize);
                c0[k[0]] += 1;
                c1[k[1]] += 1;
                c2[k[2]] += 1;
                b0[k[0]].join(b);
                b1[k[1]].join(b);
                b2[k[2]].join(b);
            }
        }
        // The cheapest binned split: (cost, axis, bins left of it). An empty bin changes
        // neither side of the cuts around it, so its cut costs what the one before did (not
        // less: not taken) and is not evaluated.
        let mut best: Option<(f64, usize, usize)> = None;
        for a in (0..3).filter(|&a| ranged[a]) {
            let (count, bbox) = (&count[a * nbins..][..nbins], &bbox[a * nbins..][..nbins]);
            // Right-hand sweep, then left-hand with the cost of each cut.
            let (mut acc, mut m, mut area) = (Box32::EMPTY, 0, 0.0);
            for b in (1..nbins).rev() {
                if count[b] != 0 {
                    acc.join(&bbox[b]);
                    m += count[b];
                    area = acc.half_area();
                }
                right[b] = (area, m);
            }
            let (mut acc, mut m) = (Box32::EMPTY, 0);
            for cut in 1..nbins {
                if count[cut - 1] == 0 {
                    continue;
                }
                acc.join(&bbox[cut - 1]);
                m += count[cut - 1];
                let (ra, rn) = right[cut];
                if rn == 0 {
                    continue;
                }
                let cost = acc.half_area() * m as f64 + ra * rn as f64;
                if best.is_none_or(|(c, _, _)| cost < c) {
                    best = Some((cost, a, cut));
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
            Some((_, a, cut)) => {
                // Hoare's partition: the left part, bins below `cut`, first.
                let left = |p: &Prim| (axes.bins(&p.0)[a] as usize) < cut;
                let (mut i, mut j) = (0, n);
                loop {
                    while i < j && left(&prims[i]) {
                        i += 1;
                    }
                    while i < j && !left(&prims[j - 1]) {
                        j -= 1;
                    }
                    if i >= j {
                        break;
                    }
                    prims.swap(i, j - 1);
                    i += 1;
                    j -= 1;
                }
                i
            }
            // Every centre at one point: halve the range.
            None => n / 2,
        };
        (bounds, Some(mid))
    }

    /// The tree over `prims` (whose first entry is `offset` in leaf order) on this thread:
    /// node 0 its root, each inner node's children a pair.
    fn build_range(&self, prims: &mut [Prim], offset: usize) -> Vec<BvhNode> {
        let mut bins = Bins::new(self.params.bins as usize);
        let mut nodes = vec![Box32::EMPTY.to_node(0, 0)];
        // (node, first, end) ranges of `prims` still to split.
        let mut todo = vec![(0usize, 0usize, prims.len())];
        while let Some((node, first, end)) = todo.pop() {
            let (bounds, mid) = self.split(&mut prims[first..end], &mut bins);
            let Some(mid) = mid else {
                nodes[node] = bounds.to_node((offset + first) as u32, (end - first) as u32);
                continue;
            };
            let left = nodes.len();
            nodes.push(Box32::EMPTY.to_node(0, 0));
            nodes.push(Box32::EMPTY.to_node(0, 0));
            nodes[node] = bounds.to_node(left as u32, 0);
            todo.push((left + 1, first + mid, end));
            todo.push((left, first, first + mid));
        }
        nodes
    }

    /// [`Builder::build_range`], the two halves of a large range built side by side (rayon's
    /// join, in the pool it runs in), then laid out as root, the two subtrees' roots (the
    /// pair), the left subtree's other nodes, the right's.
    fn build_par(&self, prims: &mut [Prim], offset: usize, depth: u32) -> Vec<BvhNode> {
        if prims.len() < PARALLEL_MIN || depth >= 6 {
            return self.build_range(prims, offset);
        }
        let (bounds, mid) = self.split(prims, &mut Bins::new(self.params.bins as usize));
        let Some(mid) = mid else {
            return vec![bounds.to_node(offset as u32, prims.len() as u32)];
        };
        let (lo, hi) = prims.split_at_mut(mid);
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

/// A split's bin arrays (three axes' bins side by side), made once per thread and cleared per
/// node.
struct Bins {
    count: Vec<usize>,
    bbox: Vec<Box32>,
    right: Vec<(f64, usize)>,
}

impl Bins {
    fn new(bins: usize) -> Bins {
        Bins {
            count: vec![0; 3 * bins],
            bbox: vec![Box32::EMPTY; 3 * bins],
            right: vec![(0.0, 0); bins],
        }
    }
}

impl ReshetovBvh {
    /// Builds the tree over `triangles` (the caller's, in its numbering; their corners must be
    /// finite).
    pub fn build(triangles: &[Tri], params: BvhParams) -> Result<ReshetovBvh> {
        ReshetovBvh::build_to(triangles, params, 1)
    }

    /// [`ReshetovBvh::build`] with every range of at most `min_split` (≥ 1) triangles left
    /// one leaf (the 8-wide tree's build: what it collapses into one leaf is not split).
    pub(crate) fn build_to(
        triangles: &[Tri],
        params: BvhParams,
        min_split: usize,
    ) -> Result<ReshetovBvh> {
        params.check()?;
        if triangles.len() > ID_TAG as usize {
            return Err(Error::InvalidInput(format!(
                "{} triangles: a BVH holds at most 2^30",
                triangles.len()
            )));
        }
        check_finite(triangles)?;
        let builder = Builder {
            params,
            min_split: min_split.max(1),
        };
        let mut prims = Prim::all(triangles);
        // Large subtrees are built side by side (the splits, and so the tree, are the same
        // whatever the thread count; only where its nodes lie in the array differs).
        let nodes = crate::threads::install(None, || builder.build_par(&mut prims, 0, 0))?;
        let order: Vec<u32> = prims.iter().map(Prim::id).collect();
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
                    if at.is_some_and(|at| gather.offer(self.order[j], &self.triangles[j], at)) {
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
        query.gathered(&mut gather, visited)
    }
}

pub mod nearest;
#[cfg(test)]
mod tests;
