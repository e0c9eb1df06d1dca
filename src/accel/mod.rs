//! Acceleration structures behind one interface: each answers a [`QueryKind`] for one ray at a
//! time, with per-chunk state it may carry between neighbouring rays. The tet walk is the one
//! there is; Portalez's octree and a BVH go beside it (one file each) and are listed in
//! [`ACCELS`], so a cast and the benchmarks drive them all the same way.

pub mod tetwalk;

use crate::geom::ray::Ray;
use crate::geom::real::Real;
use crate::query::QueryKind;

pub use tetwalk::TetWalk;

/// The acceleration structures there are, by name.
pub const ACCELS: [&str; 1] = ["tetwalk"];

pub trait Accel<R: Real>: Sync {
    const NAME: &'static str;
    /// What one chunk of rays carries from ray to ray (hints); made fresh for every chunk from
    /// its index, so answers do not depend on how chunks are scheduled.
    type State;
    fn state(&self, chunk: usize) -> Self::State;
    /// Answers `query` for one ray.
    fn trace<K: QueryKind>(&self, query: &K, ray: &Ray, state: &mut Self::State) -> K::Answer;
}
