//! Portalez & Duguet's neighbour-linked octree (`../shared/seeds/004_*`, specs §(a)): leaves
//! linked to their face neighbours, walked from leaf to leaf by the signs of Plücker products
//! at the exit corner (`outFacesLookup`) and at the exit face's centre
//! (`faceToNeighborIndex`), both tables in `tables.rs`.
//!
//! As Reshetov's BVH, the octree decides nothing about hits: every triangle the ray meets in a
//! visited leaf is offered to the query's gatherer (`query::gather`, exact), and a leaf is
//! skipped only when its entry, rounded down, lies beyond the gatherer's reach. The walk
//! itself is exact: every box coordinate is a float64 number (a grid of split planes per axis,
//! so neighbours share their faces bit for bit), and every sign the walk reads is decided by a
//! float filter with an error bound and rationals behind it. Ties (the ray through an edge or
//! a corner, a zero Π) are resolved towards where the ray goes next, so the walk always
//! progresses.
//!
//! Layout (the paper's four arrays): the leaf records `tCount | tOffset | leafIndex | nCount
//! | links…` (nCount: six 4-bit counts, face f at bits 4f; the links of face f follow those of
//! faces < f; four links in faceToNeighborIndex's quadrant order), the triangles copied per
//! leaf with their ids, the boxes (per leaf: its lattice corner and level, 16 bytes, read
//! through the per-axis split grids), and the cube map (per root face R×R texels naming the
//! boundary leaf there). The hierarchy is kept to locate origins inside the root.
//!
//! Without 2:1 balance a face may touch leaves more than one level finer. Its links are then
//! still 0, 1 or 4: the same-size-or-coarser leaf, or the four children of the same-size
//! node touching the face; a child that is not a leaf is linked as a hierarchy node (tagged
//! with `NODE_TAG`), and the walk descends from it by the same centre test, one level at a
//! time, to the leaf holding the exit point.

mod tables;

use tables::{delta_sign, FACE_AXIS, FACE_POSITIVE};
pub use tables::{face_of, face_to_neighbor_index, in_plane, out_faces_lookup};

use super::Accel;
use crate::error::{Error, Result};
use crate::geom::exact::sign2;
use crate::geom::ray::Ray;
use crate::mesh::surface::check_finite;
use crate::query::gather::{Gather, Line, Tri};
use crate::query::QueryKind;
use crate::status::FAILED;
use std::sync::OnceLock;

/// How the octree is built.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct OctreeParams {
    /// Leaves are at most this deep (the root is depth 0).
    pub max_depth: u32,
    /// A node splits while it holds more triangles than this (and is above max_depth).
    pub leaf_size: u32,
    /// Whether face-adjacent leaves may differ by at most one level (2:1).
    pub balance: bool,
}

impl Default for OctreeParams {
    fn default() -> Self {
        OctreeParams {
            max_depth: 8,
            // The bunny at depth 8 (the paper's): 77k leaves unbalanced, 95k balanced (the
            // paper: 69k and 83k), 6.2 triangles per non-empty leaf (the paper: 6).
            leaf_size: 12,
            balance: true,
        }
    }
}

/// Deeper lattices would not fit the tagged u32 links and the per-axis grids stay small.
pub const MAX_DEPTH: u32 = 16;

impl OctreeParams {
    pub fn check(&self) -> Result<()> {
        if self.max_depth > MAX_DEPTH {
            return Err(Error::InvalidOption(format!(
                "max_depth must be in 0..={MAX_DEPTH}, got {}",
                self.max_depth
            )));
        }
        if self.leaf_size == 0 || self.leaf_size > 1 << 16 {
            return Err(Error::InvalidOption(format!(
                "leaf_size must be in 1..=65536, got {}",
                self.leaf_size
            )));
        }
        Ok(())
    }
}

/// A link to a hierarchy node rather than a leaf record (unbalanced trees only).
pub const NODE_TAG: u32 = 1 << 31;
/// The cube map's resolution is 2^min(max_depth, this).
pub const CUBE_MAP_LOG2_MAX: u32 = 10;

/// A node of the kept hierarchy: its lattice corner (in units of the finest cells), its
/// level, its first child (8 in a row, `x + 2y + 4z`; 0 for a leaf) and its leaf index.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct OctNode {
    pub at: [u32; 3],
    pub level: u32,
    pub child: u32,
    pub leaf: u32,
}

/// Bytes per part (Table 4's columns, plus the hierarchy the paper does not keep).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct OctreeMemory {
    pub cube_map: usize,
    pub octree: usize,
    pub triangles: usize,
    pub boxes: usize,
    pub hierarchy: usize,
    pub total: usize,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OctreeStats {
    pub leaves: usize,
    pub empty_leaves: usize,
    /// Links per leaf (a face with four finer neighbours counts four).
    pub neighbours_per_leaf: f64,
    pub triangles_per_leaf: f64,
    /// Over the leaves that hold any.
    pub triangles_per_full_leaf: f64,
    pub max_depth: u32,
    /// Links to hierarchy nodes (unbalanced trees only).
    pub node_links: usize,
}

/// The octree over a scene's triangles.
#[derive(Clone, Debug)]
pub struct PortalezOctree {
    pub params: OctreeParams,
    /// The root box.
    pub lo: [f64; 3],
    pub hi: [f64; 3],
    /// Per axis the 2^max_depth + 1 split planes; a node's sides are grid values.
    pub grid: [Vec<f64>; 3],
    pub nodes: Vec<OctNode>,
    /// The leaf record stream (u32 words).
    pub records: Vec<u32>,
    /// Per leaf, its record's word offset.
    pub leaf_record: Vec<u32>,
    /// Per leaf: lattice corner x, y, z and level.
    pub boxes: Vec<[u32; 4]>,
    /// The triangles copied per leaf, and their caller ids.
    pub triangles: Vec<Tri>,
    pub ids: Vec<u32>,
    /// 6 faces (by face label) of R×R record offsets, row-major over (w, u).
    pub cube_map: Vec<u32>,
    pub cube_res: usize,
}

/// What one chunk's walks count (tests read them).
#[derive(Clone, Debug, Default)]
pub struct OctreeState {
    /// Entries where the cube map's leaf did not hold the exact entry point.
    pub entry_fixes: u64,
    /// Walks the step guard stopped (never, if the walk is right).
    pub guards: u64,
    /// The triangles this ray has offered: a triangle is copied into every leaf it meets, and
    /// offering it again would only repeat the gatherer's exact (and, for the same triangle,
    /// rational) comparison.
    pub offered: Vec<u32>,
}

/// A walk's end: the leaves visited, or the guard fired.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Walked {
    Done(u32),
    Guard(u32),
}

/// Relative error of (x − o) / d in float64: two roundings, padded as in `reshetov_bvh`.
const PAD: f64 = 4.0 * f64::EPSILON;
const TINY: f64 = 4.0 * f64::MIN_POSITIVE;
/// The ray as the walk reads it: the origin, the scaled direction (signs only), its octant.
struct Frame {
    o: [f64; 3],
    d: [f64; 3],
    dir: [f64; 3],
    s: [i32; 3],
    pos: [bool; 3],
    row: usize,
    all_active: bool,
}

impl Frame {
    fn new(line: &Line) -> Frame {
        let dir = line.dir;
        let s = dir.map(|x| (x > 0.0) as i32 - (x < 0.0) as i32);
        let pos = dir.map(|x| x > 0.0);
        Frame {
            o: line.o,
            d: line.d,
            dir,
            s,
            pos,
            row: pos[0] as usize + 2 * pos[1] as usize + 4 * pos[2] as usize,
            all_active: s.iter().all(|&x| x != 0),
        }
    }

    /// The exact sign of Π_k(P) = ((P − o) × d)_k.
    #[inline]
    fn pi(&self, k: usize, p: [f64; 3]) -> i32 {
        let (k1, k2) = ((k + 1) % 3, (k + 2) % 3);
        sign2(
            p[k1],
            self.o[k1],
            self.dir[k2],
            p[k2],
            self.o[k2],
            self.dir[k1],
        )
    }

    /// The sign of t_i(x) − t_j(y), t_i(x) being where the line crosses the plane x_i = x
    /// (both axes active).
    fn cmp_t(&self, i: usize, x: f64, j: usize, y: f64) -> i32 {
        sign2(x, self.o[i], self.dir[j], y, self.o[j], self.dir[i]) * self.s[i] * self.s[j]
    }

    /// The sign of E_a − v, E being where the line crosses the plane x_e = f (e active).
    fn cmp_on_plane(&self, e: usize, f: f64, a: usize, v: f64) -> i32 {
        if self.s[a] == 0 {
            return (self.o[a] > v) as i32 - (self.o[a] < v) as i32;
        }
        // E_a − v = d_a (t_e(f) − t_a(v)).
        self.s[a] * self.cmp_t(e, f, a, v)
    }
}

/// outFacesLookup and faceToNeighborIndex.
type Tables = ([[u8; 8]; 8], [[u8; 8]; 6]);

fn tables() -> &'static Tables {
    static T: OnceLock<Tables> = OnceLock::new();
    T.get_or_init(|| (out_faces_lookup(), face_to_neighbor_index()))
}

/// Whether the closed triangle may meet the closed box: the 13 axes of the separating axis
/// test, each projection bounded by its rounding error, so a triangle is dropped only when
/// an axis separates it with room to spare (a superset of the exact answer; any axis is a
/// valid candidate, so how the axes themselves round does not matter).
pub fn tri_may_meet_box(tri: &Tri, lo: [f64; 3], hi: [f64; 3]) -> bool {
    for k in 0..3 {
        let (a, b) = tri
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
                (a.min(p[k]), b.max(p[k]))
            });
        if a > hi[k] || b < lo[k] {
            return false;
        }
    }
    let e = [0, 1, 2].map(|i| {
        let (p, q) = (tri[i], tri[(i + 1) % 3]);
        [0, 1, 2].map(|k| q[k] - p[k])
    });
    // Scaled by a power of two so the normal neither overflows nor underflows.
    let m = e.iter().flatten().fold(0f64, |m, x| m.max(x.abs()));
    let e = if m > 0.0 && m.is_finite() {
        let sc = crate::geom::real::times_pow2(1.0, -crate::geom::real::exponent(m));
        e.map(|v| v.map(|x| x * sc))
    } else {
        e
    };
    let cross = |a: [f64; 3], b: [f64; 3]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let separates = |ax: [f64; 3]| {
        if ax == [0.0; 3] {
            return false;
        }
        const REL: f64 = 8.0 * f64::EPSILON;
        const ABS: f64 = 8.0 * f64::MIN_POSITIVE;
        let (mut tmin, mut tmax, mut terr) = (f64::INFINITY, f64::NEG_INFINITY, 0f64);
        for p in tri {
            let v = ax[0] * p[0] + ax[1] * p[1] + ax[2] * p[2];
            let mag = (ax[0] * p[0]).abs() + (ax[1] * p[1]).abs() + (ax[2] * p[2]).abs();
            tmin = tmin.min(v);
            tmax = tmax.max(v);
            terr = terr.max(REL * mag + ABS);
        }
        let (mut bmin, mut bmax, mut bmag) = (0.0, 0.0, 0.0);
        for k in 0..3 {
            let (x, y) = (ax[k] * lo[k], ax[k] * hi[k]);
            bmin += x.min(y);
            bmax += x.max(y);
            bmag += x.abs().max(y.abs());
        }
        let err = terr + REL * bmag + ABS;
        // The gaps' own rounding is a relative ε, inside the slack of REL.
        let gap = |g: f64| g * (1.0 - REL) > err * (1.0 + REL);
        gap(bmin - tmax) || gap(tmin - bmax)
    };
    let n = cross(e[0], e[1]);
    if separates(n) {
        return false;
    }
    for ei in &e {
        for k in 0..3 {
            let mut u = [0.0; 3];
            u[k] = 1.0;
            if separates(cross(*ei, u)) {
                return false;
            }
        }
    }
    true
}

/// A link while building: a leaf or a hierarchy node.
#[derive(Clone, Copy)]
enum Link {
    Leaf(u32),
    Node(u32),
}

/// The builder's node: the hierarchy node and its triangles while it is a leaf.
struct Builder<'a> {
    tris: &'a [Tri],
    grid: &'a [Vec<f64>; 3],
    depth: u32,
    nodes: Vec<OctNode>,
    lists: Vec<Vec<u32>>,
}

impl Builder<'_> {
    fn size(&self, level: u32) -> u32 {
        1 << (self.depth - level)
    }

    fn node_box(&self, n: &OctNode) -> ([f64; 3], [f64; 3]) {
        let s = self.size(n.level);
        (
            [0, 1, 2].map(|k| self.grid[k][n.at[k] as usize]),
            [0, 1, 2].map(|k| self.grid[k][(n.at[k] + s) as usize]),
        )
    }

    /// Splits leaf `k` into 8 leaves, each with the parent's triangles that may meet it.
    fn split(&mut self, k: usize) {
        let parent = self.nodes[k];
        let half = self.size(parent.level + 1);
        let first = self.nodes.len();
        let list = std::mem::take(&mut self.lists[k]);
        for c in 0..8u32 {
            let at = [0, 1, 2].map(|a| parent.at[a] + (c >> a & 1) * half);
            let node = OctNode {
                at,
                level: parent.level + 1,
                child: 0,
                leaf: u32::MAX,
            };
            let (lo, hi) = self.node_box(&node);
            let sub = list
                .iter()
                .copied()
                .filter(|&t| tri_may_meet_box(&self.tris[t as usize], lo, hi))
                .collect();
            self.nodes.push(node);
            self.lists.push(sub);
        }
        self.nodes[k].child = first as u32;
    }

    /// The node covering the lattice cell at `at` of size level `level`: the deepest node on
    /// its path no deeper than `level`.
    fn cover(&self, at: [u32; 3], level: u32) -> usize {
        let mut k = 0;
        loop {
            let n = self.nodes[k];
            if n.child == 0 || n.level == level {
                return k;
            }
            let half = self.size(n.level + 1);
            let c: u32 = (0..3).map(|a| ((at[a] - n.at[a]) / half) << a).sum();
            k = (n.child + c) as usize;
        }
    }

    /// The same-size cell across face `f` of node `n`, if inside the root.
    fn across(&self, n: &OctNode, f: usize) -> Option<[u32; 3]> {
        let (a, s) = (FACE_AXIS[f], self.size(n.level));
        let mut at = n.at;
        if FACE_POSITIVE[f] {
            at[a] += s;
            (at[a] < self.size(0)).then_some(at)
        } else {
            (at[a] >= s).then(|| {
                at[a] -= s;
                at
            })
        }
    }

    /// 2:1 balance: every leaf's same-size neighbour cell is covered by a node at most one
    /// level coarser (so face-adjacent leaves differ by at most one level).
    fn balance(&mut self) {
        let mut todo: Vec<usize> = (0..self.nodes.len())
            .filter(|&k| self.nodes[k].child == 0)
            .collect();
        while let Some(k) = todo.pop() {
            let n = self.nodes[k];
            if n.child != 0 {
                continue;
            }
            for f in 0..6 {
                let Some(at) = self.across(&n, f) else {
                    continue;
                };
                loop {
                    let c = self.cover(at, n.level);
                    let cn = self.nodes[c];
                    if cn.child != 0 || cn.level + 1 >= n.level {
                        break;
                    }
                    self.split(c);
                    let first = self.nodes[c].child as usize;
                    todo.extend(first..first + 8);
                }
            }
        }
    }
}

impl PortalezOctree {
    /// Builds the octree over `triangles` (the caller's, in its numbering; corners finite).
    pub fn build(triangles: &[Tri], params: OctreeParams) -> Result<PortalezOctree> {
        params.check()?;
        if triangles.len() >= u32::MAX as usize / 2 {
            return Err(Error::InvalidInput(format!(
                "{} triangles: an octree holds fewer than 2^31",
                triangles.len()
            )));
        }
        check_finite(triangles)?;
        let (lo, hi) = root_box(triangles);
        let depth = params.max_depth;
        let cells = 1usize << depth;
        let grid: [Vec<f64>; 3] = [0, 1, 2].map(|k| {
            let mut g = vec![0.0; cells + 1];
            g[0] = lo[k];
            g[cells] = hi[k];
            let mut step = cells;
            while step > 1 {
                let half = step / 2;
                for i in (half..cells).step_by(step) {
                    let (a, b) = (g[i - half], g[i + half]);
                    g[i] = (0.5 * a + 0.5 * b).clamp(a, b);
                }
                step = half;
            }
            g
        });
        if grid.iter().any(|g| g.windows(2).any(|w| w[0] >= w[1])) {
            return Err(Error::InvalidInput(
                "the scene's box is too thin to split to max_depth".into(),
            ));
        }
        let mut b = Builder {
            tris: triangles,
            grid: &grid,
            depth,
            nodes: vec![OctNode {
                at: [0; 3],
                level: 0,
                child: 0,
                leaf: u32::MAX,
            }],
            lists: vec![(0..triangles.len() as u32).collect()],
        };
        let mut todo = vec![0usize];
        while let Some(k) = todo.pop() {
            if b.lists[k].len() > params.leaf_size as usize && b.nodes[k].level < depth {
                b.split(k);
                let first = b.nodes[k].child as usize;
                todo.extend(first..first + 8);
            }
        }
        if params.balance {
            b.balance();
        }
        // Leaves numbered in depth-first order (neighbouring leaves near in memory).
        let mut leaves = Vec::new();
        let mut stack = vec![0usize];
        while let Some(k) = stack.pop() {
            let n = b.nodes[k];
            if n.child == 0 {
                b.nodes[k].leaf = leaves.len() as u32;
                leaves.push(k);
            } else {
                stack.extend((0..8).rev().map(|c| (n.child + c) as usize));
            }
        }
        // Links per leaf and face.
        let links: Vec<[Vec<Link>; 6]> = leaves
            .iter()
            .map(|&k| {
                let n = b.nodes[k];
                [0, 1, 2, 3, 4, 5].map(|f| {
                    let Some(at) = b.across(&n, f) else {
                        return Vec::new();
                    };
                    let c = b.cover(at, n.level);
                    let cn = b.nodes[c];
                    if cn.child == 0 {
                        return vec![Link::Leaf(cn.leaf)];
                    }
                    let (u, w) = in_plane(FACE_AXIS[f]);
                    let side = (!FACE_POSITIVE[f]) as u32;
                    (0..4u32)
                        .map(|j| {
                            let bits = (side << FACE_AXIS[f])
                                | ((1 - (j & 1)) << u)
                                | ((1 - (j >> 1)) << w);
                            let ch = b.nodes[(cn.child + bits) as usize];
                            if ch.child == 0 {
                                Link::Leaf(ch.leaf)
                            } else {
                                Link::Node(cn.child + bits)
                            }
                        })
                        .collect()
                })
            })
            .collect();
        let mut leaf_record = Vec::with_capacity(leaves.len());
        let mut at = 0usize;
        for l in &links {
            leaf_record.push(at as u32);
            at += 4 + l.iter().map(Vec::len).sum::<usize>();
        }
        if at >= NODE_TAG as usize {
            return Err(Error::InvalidInput(
                "the octree's records exceed 2^31 words".into(),
            ));
        }
        let mut records = Vec::with_capacity(at);
        let (mut tris, mut ids) = (Vec::new(), Vec::new());
        let mut boxes = Vec::with_capacity(leaves.len());
        for (leaf, (&k, l)) in leaves.iter().zip(&links).enumerate() {
            let list = &b.lists[k];
            let n = b.nodes[k];
            records.push(list.len() as u32);
            records.push(ids.len() as u32);
            records.push(leaf as u32);
            records.push(
                l.iter()
                    .enumerate()
                    .map(|(f, v)| (v.len() as u32) << (4 * f))
                    .sum(),
            );
            for link in l.iter().flatten() {
                records.push(match *link {
                    Link::Leaf(m) => leaf_record[m as usize],
                    Link::Node(m) => NODE_TAG | m,
                });
            }
            ids.extend_from_slice(list);
            tris.extend(list.iter().map(|&t| triangles[t as usize]));
            boxes.push([n.at[0], n.at[1], n.at[2], n.level]);
        }
        // The cube map: each texel's centre on a root face, to the leaf touching it there.
        let r_log = depth.min(CUBE_MAP_LOG2_MAX);
        let res = 1usize << r_log;
        let per = cells / res;
        let mut cube_map = vec![0u32; 6 * res * res];
        for f in 0..6 {
            let a = FACE_AXIS[f];
            let (u, w) = in_plane(a);
            for tw in 0..res {
                for tu in 0..res {
                    let mut p = [0u32; 3];
                    p[a] = if FACE_POSITIVE[f] {
                        cells as u32 - 1
                    } else {
                        0
                    };
                    p[u] = (tu * per + per / 2) as u32;
                    p[w] = (tw * per + per / 2) as u32;
                    let k = b.cover(p, depth);
                    cube_map[(f * res + tw) * res + tu] = leaf_record[b.nodes[k].leaf as usize];
                }
            }
        }
        let nodes = b.nodes;
        Ok(PortalezOctree {
            params,
            lo,
            hi,
            grid,
            nodes,
            records,
            leaf_record,
            boxes,
            triangles: tris,
            ids,
            cube_map,
            cube_res: res,
        })
    }

    pub fn leaves(&self) -> usize {
        self.boxes.len()
    }

    /// The closed box of a leaf (by index).
    pub fn leaf_box(&self, leaf: usize) -> ([f64; 3], [f64; 3]) {
        let b = self.boxes[leaf];
        let s = 1u32 << (self.params.max_depth - b[3]);
        (
            [0, 1, 2].map(|k| self.grid[k][b[k] as usize]),
            [0, 1, 2].map(|k| self.grid[k][(b[k] + s) as usize]),
        )
    }

    /// The closed box of a hierarchy node.
    pub fn node_box(&self, k: usize) -> ([f64; 3], [f64; 3]) {
        let n = self.nodes[k];
        let s = 1u32 << (self.params.max_depth - n.level);
        (
            [0, 1, 2].map(|a| self.grid[a][n.at[a] as usize]),
            [0, 1, 2].map(|a| self.grid[a][(n.at[a] + s) as usize]),
        )
    }

    /// The record of the leaf at word offset `addr`: (tCount, tOffset, leafIndex, nCount).
    #[inline]
    pub fn record(&self, addr: usize) -> [u32; 4] {
        [0, 1, 2, 3].map(|i| self.records[addr + i])
    }

    /// The links of face `f` of the record at `addr`.
    pub fn links(&self, addr: usize, f: usize) -> &[u32] {
        let nc = self.records[addr + 3];
        let off: u32 = (0..f).map(|g| nc >> (4 * g) & 15).sum();
        let n = nc >> (4 * f) & 15;
        &self.records[addr + 4 + off as usize..addr + 4 + (off + n) as usize]
    }

    pub fn memory(&self) -> OctreeMemory {
        let cube_map = self.cube_map.len() * 4;
        let octree = self.records.len() * 4;
        let triangles = self.triangles.len() * std::mem::size_of::<Tri>() + self.ids.len() * 4;
        let boxes = self.boxes.len() * 16 + self.grid.iter().map(|g| g.len() * 8).sum::<usize>();
        let hierarchy = self.nodes.len() * std::mem::size_of::<OctNode>();
        OctreeMemory {
            cube_map,
            octree,
            triangles,
            boxes,
            hierarchy,
            total: cube_map + octree + triangles + boxes + hierarchy,
        }
    }

    pub fn stats(&self) -> OctreeStats {
        let leaves = self.leaves();
        let mut links = 0usize;
        let mut node_links = 0usize;
        let mut empty = 0usize;
        for &addr in &self.leaf_record {
            let [tc, _, _, nc] = self.record(addr as usize);
            empty += (tc == 0) as usize;
            let n: u32 = (0..6).map(|f| nc >> (4 * f) & 15).sum();
            links += n as usize;
            let first = addr as usize + 4;
            node_links += self.records[first..first + n as usize]
                .iter()
                .filter(|&&l| l & NODE_TAG != 0)
                .count();
        }
        OctreeStats {
            leaves,
            empty_leaves: empty,
            neighbours_per_leaf: links as f64 / leaves.max(1) as f64,
            triangles_per_leaf: self.ids.len() as f64 / leaves.max(1) as f64,
            triangles_per_full_leaf: self.ids.len() as f64 / (leaves - empty).max(1) as f64,
            max_depth: self.boxes.iter().map(|b| b[3]).max().unwrap_or(0),
            node_links,
        }
    }

    /// The leaf record holding point p (in the root box), by exact comparisons with the split
    /// planes; on a plane, the side `dir` goes to.
    fn locate(&self, fr: &Frame, side: impl Fn(usize, f64) -> i32) -> usize {
        let mut k = 0usize;
        loop {
            let n = self.nodes[k];
            if n.child == 0 {
                return self.leaf_record[n.leaf as usize] as usize;
            }
            let half = 1u32 << (self.params.max_depth - n.level - 1);
            let mut c = 0u32;
            for a in 0..3 {
                let s = side(a, self.grid[a][(n.at[a] + half) as usize]);
                if s > 0 || (s == 0 && fr.pos[a]) {
                    c |= 1 << a;
                }
            }
            k = (n.child + c) as usize;
        }
    }

    /// The first leaf's record and a lower bound on where the ray enters it (in t of d);
    /// None: the ray misses the root box.
    fn start(&self, fr: &Frame, state: &mut OctreeState) -> Option<(usize, f64)> {
        let (lo, hi, o) = (self.lo, self.hi, fr.o);
        if (0..3).all(|k| lo[k] <= o[k] && o[k] <= hi[k]) {
            let at = self.locate(fr, |a, s| (o[a] > s) as i32 - (o[a] < s) as i32);
            return Some((at, f64::NEG_INFINITY));
        }
        let near = [0, 1, 2].map(|k| if fr.pos[k] { lo[k] } else { hi[k] });
        let far = [0, 1, 2].map(|k| if fr.pos[k] { hi[k] } else { lo[k] });
        for k in 0..3 {
            if fr.s[k] == 0 {
                if !(lo[k] <= o[k] && o[k] <= hi[k]) {
                    return None;
                }
            } else if (far[k] - o[k]) * (fr.s[k] as f64) < 0.0 {
                return None; // the box lies behind
            }
        }
        let act: Vec<usize> = (0..3).filter(|&k| fr.s[k] != 0).collect();
        // The entry axis: the latest near plane (exact comparisons; ties: the first).
        let e = *act
            .iter()
            .find(|&&i| {
                act.iter()
                    .all(|&j| j == i || fr.cmp_t(i, near[i], j, near[j]) >= 0)
            })
            .expect("a greatest entry");
        if act
            .iter()
            .any(|&k| k != e && fr.cmp_t(e, near[e], k, far[k]) > 0)
        {
            return None;
        }
        let fe = near[e];
        let face = face_of(e, !fr.pos[e]);
        let (u, w) = in_plane(e);
        // The cube map's guess, from the rounded entry point.
        let t = (fe - o[e]) / fr.dir[e];
        let texel = |a: usize| {
            let x = o[a] + t * fr.dir[a];
            let r = self.cube_res;
            (((x - lo[a]) / (hi[a] - lo[a]) * r as f64) as usize).min(r - 1)
        };
        let guess = self.cube_map[(face * self.cube_res + texel(w)) * self.cube_res + texel(u)];
        let (blo, bhi) = self.leaf_box(self.records[guess as usize + 2] as usize);
        let holds = [u, w].iter().all(|&a| {
            fr.cmp_on_plane(e, fe, a, blo[a]) >= 0 && fr.cmp_on_plane(e, fe, a, bhi[a]) <= 0
        });
        let at = if holds {
            guess as usize
        } else {
            state.entry_fixes += 1;
            self.locate(fr, |a, s| {
                if a == e {
                    // On the entry face: the side inside the root.
                    if fr.pos[e] {
                        -1
                    } else {
                        1
                    }
                } else {
                    fr.cmp_on_plane(e, fe, a, s)
                }
            })
        };
        let te = (fe - o[e]) / fr.d[e];
        Some((at, te - PAD * te.abs() - TINY))
    }

    /// The exit face of the box whose exit corner is `c`: the table where every sign is
    /// non-zero and every axis active, else the least exit distance by exact comparison
    /// (ties: the first axis), which is what the table gives where it applies.
    #[inline]
    fn exit_face(&self, fr: &Frame, c: [f64; 3]) -> usize {
        let pi = [0, 1, 2].map(|k| fr.pi(k, c));
        if fr.all_active && pi.iter().all(|&s| s != 0) {
            let bits =
                (pi[0] < 0) as usize | ((pi[1] < 0) as usize) << 1 | ((pi[2] < 0) as usize) << 2;
            let f = tables().0[fr.row][bits];
            if f != 7 {
                return f as usize;
            }
        }
        // sign(t_i − t_j) from Π_k = d_{k+1} d_{k+2} (t_{k+1} − t_{k+2}).
        let cmp = |i: usize, j: usize| {
            let k = 3 - i - j;
            let (k1, k2) = ((k + 1) % 3, (k + 2) % 3);
            let s = pi[k] * fr.s[k1] * fr.s[k2];
            if i == k1 {
                s
            } else {
                -s
            }
        };
        let act = fr.s.map(|s| s != 0);
        for i in 0..3 {
            if act[i] && (0..3).all(|j| j == i || !act[j] || cmp(i, j) <= 0) {
                return face_of(i, fr.pos[i]);
            }
        }
        unreachable!("exit distances are ordered")
    }

    /// Which of the four finer cells across face `f` (centre `c`) holds the exit point: the
    /// table where both in-plane signs are non-zero; on a dividing line, the side the ray
    /// goes to (so the walk moves on rather than back).
    #[inline]
    fn quadrant(&self, fr: &Frame, f: usize, c: [f64; 3]) -> usize {
        let a = FACE_AXIS[f];
        let (u, w) = in_plane(a);
        let (pu, pw) = (fr.pi(u, c), fr.pi(w, c));
        if pu != 0 && pw != 0 {
            let bits = ((pu < 0) as usize) << u | ((pw < 0) as usize) << w;
            return tables().1[f][bits] as usize;
        }
        let sn = if FACE_POSITIVE[f] { 1 } else { -1 };
        let delta = |m: usize, pi: i32| {
            let s = delta_sign(a, m, pi, sn);
            if s != 0 {
                s
            } else if fr.pos[m] {
                -1 // δ = c − X < 0 just past X: the upper half
            } else {
                1
            }
        };
        (delta(u, pw) > 0) as usize + 2 * (delta(w, pu) > 0) as usize
    }

    /// Offers `gather` every triangle the ray meets in the leaves it passes, in order,
    /// stopping where the next leaf lies beyond its reach.
    pub fn walk<G: Gather>(&self, line: &Line, gather: &mut G, state: &mut OctreeState) -> Walked {
        let fr = Frame::new(line);
        state.offered.clear();
        let Some((mut addr, low)) = self.start(&fr, state) else {
            return Walked::Done(0);
        };
        if low > gather.reach() {
            return Walked::Done(0);
        }
        let cap = self.leaves() as u32 + 8;
        let depth = self.params.max_depth;
        let mut visited = 0u32;
        loop {
            visited += 1;
            if visited > cap {
                state.guards += 1;
                return Walked::Guard(visited);
            }
            let [tc, to, leaf, nc] = self.record(addr);
            for j in to as usize..(to + tc) as usize {
                let id = self.ids[j];
                if line.meets(&self.triangles[j]) && !state.offered.contains(&id) {
                    state.offered.push(id);
                    if gather.offer(id) {
                        return Walked::Done(visited);
                    }
                }
            }
            let (lo, hi) = self.leaf_box(leaf as usize);
            let corner = [0, 1, 2].map(|k| if fr.pos[k] { hi[k] } else { lo[k] });
            let f = self.exit_face(&fr, corner);
            let n = nc >> (4 * f) & 15;
            if n == 0 {
                return Walked::Done(visited);
            }
            let a = FACE_AXIS[f];
            let t = (corner[a] - fr.o[a]) / fr.d[a];
            if t - PAD * t.abs() - TINY > gather.reach() {
                return Walked::Done(visited);
            }
            let off: u32 = (0..f).map(|g| nc >> (4 * g) & 15).sum();
            let j = if n == 4 {
                let b = self.boxes[leaf as usize];
                let half = 1u32 << (depth - b[3] - 1);
                let mut c = corner;
                let (u, w) = in_plane(a);
                for m in [u, w] {
                    c[m] = self.grid[m][(b[m] + half) as usize];
                }
                self.quadrant(&fr, f, c)
            } else {
                0
            };
            let mut link = self.records[addr + 4 + (off as usize) + j];
            // Unbalanced trees: descend from a node to the leaf holding the exit point.
            while link & NODE_TAG != 0 {
                let node = self.nodes[(link & !NODE_TAG) as usize];
                let half = 1u32 << (depth - node.level - 1);
                let mut c = corner;
                let (u, w) = in_plane(a);
                for m in [u, w] {
                    c[m] = self.grid[m][(node.at[m] + half) as usize];
                }
                let q = self.quadrant(&fr, f, c) as u32;
                let bits =
                    ((!FACE_POSITIVE[f]) as u32) << a | (1 - (q & 1)) << u | (1 - (q >> 1)) << w;
                let ch = self.nodes[(node.child + bits) as usize];
                link = if ch.child == 0 {
                    self.leaf_record[ch.leaf as usize]
                } else {
                    NODE_TAG | (node.child + bits)
                };
            }
            addr = link as usize;
        }
    }
}

/// The root box: a cube around the triangles' box (sides never zero: at least 2^-30 of the
/// largest coordinate and 2^-1000, so max_depth ≤ 16 splits stay many ulps apart), clamped
/// to float64's range.
fn root_box(triangles: &[Tri]) -> ([f64; 3], [f64; 3]) {
    if triangles.is_empty() {
        return ([0.0; 3], [1.0; 3]);
    }
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for p in triangles.iter().flatten() {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let big = (0..3).fold(0f64, |m, k| m.max(lo[k].abs()).max(hi[k].abs()));
    let half = (0..3)
        .fold(0f64, |m, k| m.max(0.5 * hi[k] - 0.5 * lo[k]))
        .max(big * 2f64.powi(-30))
        .max(2f64.powi(-1000));
    let c = [0, 1, 2].map(|k| 0.5 * lo[k] + 0.5 * hi[k]);
    (
        [0, 1, 2].map(|k| (c[k] - half).max(-f64::MAX).min(lo[k])),
        [0, 1, 2].map(|k| (c[k] + half).min(f64::MAX).max(hi[k])),
    )
}

impl Accel<f64> for PortalezOctree {
    const NAME: &'static str = "portalez_octree";
    type State = OctreeState;

    fn state(&self, _: usize) -> Self::State {
        OctreeState::default()
    }

    fn trace<K: QueryKind>(&self, query: &K, ray: &Ray, state: &mut Self::State) -> K::Answer {
        let line = match Line::new(ray) {
            Ok(line) => line,
            Err(status) => return query.skipped(status),
        };
        let mut gather = query.gather(&line);
        match self.walk(&line, &mut gather, state) {
            Walked::Done(visited) => query.gathered(gather, visited),
            Walked::Guard(_) => query.skipped(FAILED),
        }
    }
}

#[cfg(test)]
mod tests;
