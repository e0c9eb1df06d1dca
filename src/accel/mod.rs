//! Acceleration structures behind one interface: each answers a [`QueryKind`] for one ray at a
//! time, with per-chunk state it may carry between neighbouring rays. The tet walk answers
//! through the query's walk policy; Reshetov's BVH (one ray at a time or in culling packets)
//! and Portalez & Duguet's octree test triangles and answer through the query's gatherer
//! (`query::gather`). One file each; all are rows of the accelerator table (`table.rs`:
//! [`AccelKind`], [`ACCELS`], the structures they read and the dispatch), so a cast and the
//! benchmarks drive them all the same way.

pub mod exact_bvh;
pub mod portalez_octree;
pub mod reshetov_bvh;
pub mod reshetov_bvh_packets;
pub mod table;
pub mod tetwalk;

use crate::geom::ray::Ray;
use crate::geom::real::Real;
use crate::query::{QueryKind, Sink};

pub use exact_bvh::{ExactBvh, ExactBvhParams};
pub use portalez_octree::{OctreeParams, PortalezOctree};
pub use reshetov_bvh::{BvhParams, ReshetovBvh};
pub use reshetov_bvh_packets::{BvhPackets, CullCounters};
pub use table::{AccelKind, AccelVisitor, Built, Structure, Structures, ACCELS};
pub use tetwalk::TetWalk;

/// When a chunk of rays is walked in interleaved lanes (`tetwalk`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Lanes {
    /// Lanes for scattered rays, not for rays that share their origin (a camera, rays from one
    /// point): those walk the same tets, which stay in cache, and there the one-ray walk (or
    /// a packet, see [`Packets`]) measured faster; scattered rays wait on memory at every
    /// step, and lanes overlap those waits (`docs/performance.md`).
    #[default]
    Auto,
    Off,
    On,
}

/// Whether rays that share an origin walk as packets (`traverse::packet`, `tetwalk`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Packets {
    /// Packets where a chunk's rays share their origin (its first two do) and the method's
    /// exits are exact sides (the exact walk); elsewhere as [`Lanes`] says.
    #[default]
    Auto,
    /// Never.
    Off,
}

pub trait Accel<R: Real>: Sync {
    const NAME: &'static str;
    /// What one chunk of rays carries from ray to ray (hints); made fresh for every chunk from
    /// its index, so answers do not depend on how chunks are scheduled.
    type State;
    fn state(&self, chunk: usize) -> Self::State;
    /// Answers `query` for one ray.
    fn trace<K: QueryKind>(&self, query: &K, ray: &Ray, state: &mut Self::State) -> K::Answer;
    /// Answers `query` for rays `ray(0..out.len())` into `out` (entry j for `ray(j)`), in any
    /// order, each answer the one [`Accel::trace`] gives with `state` carried from ray to ray
    /// in ray order.
    fn trace_chunk<K: QueryKind, S: Sink<K::Answer>>(
        &self,
        query: &K,
        ray: impl Fn(usize) -> Ray,
        out: &mut S,
        state: &mut Self::State,
    ) {
        trace_each(self, query, ray, out, state)
    }
}

/// [`Accel::trace_chunk`] one ray after the other with [`Accel::trace`] (the default, and what
/// an accelerator falls back to where its batched way does not apply).
pub fn trace_each<R: Real, A: Accel<R> + ?Sized, K: QueryKind, S: Sink<K::Answer>>(
    accel: &A,
    query: &K,
    ray: impl Fn(usize) -> Ray,
    out: &mut S,
    state: &mut A::State,
) {
    for j in 0..out.len() {
        let ray = ray(j);
        let answer = accel.trace(query, &ray, state);
        out.put(j, answer);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every name in ACCELS parses to the kind that names itself so, and nothing else parses.
    #[test]
    fn accel_names_round_trip() {
        for name in ACCELS {
            assert_eq!(AccelKind::from_name(name).unwrap().name(), *name);
        }
        assert!(AccelKind::from_name("kdtree").is_err());
        assert_eq!(ACCELS.len(), AccelKind::ALL.len());
        assert!(!AccelKind::TetWalk.tests_triangles());
        assert!(AccelKind::PortalezOctree.tests_triangles());
    }
}
