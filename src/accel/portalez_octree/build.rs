//! Building the octree: the triangles' conservative box test, the subdivision, the 2:1
//! balance, the face links, the cube map, and the root box.

use super::tables::{in_plane, FACE_AXIS, FACE_POSITIVE};
use super::{OctNode, OctreeParams, PortalezOctree, CUBE_MAP_LOG2_MAX, NODE_TAG};
use crate::error::{Error, Result};
use crate::mesh::surface::check_finite;
use crate::query::gather::Tri;

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
