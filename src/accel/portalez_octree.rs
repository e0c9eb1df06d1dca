//! Portalez & Duguet's neighbour-linked octree (`../shared/seeds/004_*`, specs §(a)): leaves
//! linked to their face neighbours, walked from leaf to leaf by the signs of Plücker products
//! at the exit corner (`outFacesLookup`) and at the exit face's centre
//! (`faceToNeighborIndex`), both tables in `tables.rs`. Building is `build.rs`, the walk
//! `walk.rs`; this file holds the tree's arrays, parameters and statistics.
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

mod build;
mod tables;
mod walk;

pub use build::tri_may_meet_box;
pub use tables::{face_of, face_to_neighbor_index, in_plane, out_faces_lookup};

use super::Accel;
use crate::error::{Error, Result};
use crate::geom::ray::Ray;
use crate::query::gather::{Line, Tri};
use crate::query::QueryKind;
use crate::status::FAILED;

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

impl PortalezOctree {
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
            Walked::Done(visited) => query.gathered(&mut gather, visited),
            Walked::Guard(_) => query.skipped(FAILED),
        }
    }
}

#[cfg(test)]
mod tests;
