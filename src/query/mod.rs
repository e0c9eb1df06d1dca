//! The question a walk answers. The walk (`traverse::walk`) is written once; at every
//! constrained face it reaches, a [`Query`] policy (declared by the walk) decides whether it stops there or records the
//! crossing and walks on through. A [`QueryKind`] turns a finished walk into one ray's answer,
//! and a [`Sink`] stores answers. Closest hit, any hit, all hits and counts are policies of the
//! same walk (the last two continue through faces; `contact` resolves the exact walk's touches).
//! An accelerator that tests triangles instead of walking (a BVH) answers the same kinds
//! through [`QueryKind::gather`] (`gather`). Containment (`contains`)
//! needs no walk: it locates the point and reads a per-region parity.

pub mod all;
pub mod any;
pub mod closest;
pub mod contact;
pub mod contains;
pub mod gather;

use crate::locate::WalkStart;
use crate::traverse::Walk;
use gather::{Gather, Line};

pub use all::{AllHits, Listed};
pub use any::AnyHit;
pub use closest::{ClosestHit, RayHit};
// The walk declares what it asks at constrained faces; the policies live here.
pub use crate::traverse::walk::{Crossing, Decision, Query, StopAtFirst};

/// A query as a cast answers it for each ray: the walk policy, and the answer made of the walk.
pub trait QueryKind: Sync {
    type Policy: Query;
    type Answer: Send;
    /// The policy for one ray's walk.
    fn policy(&self, start: &WalkStart) -> Self::Policy;
    /// Whether a ray starting at `start`'s origin (in its start tet) may touch the surface
    /// there (`Contact::Origin`), for some direction: false only when it cannot, which depends
    /// on the origin and the start tet alone (the walk then skips asking, once per origin).
    fn origin_may_touch(&self, _start: &WalkStart) -> bool {
        true
    }
    /// The answer for a ray that never walked (invalid, missing the domain, no start tet).
    fn skipped(&self, status: u8) -> Self::Answer;
    /// The answer once the walk ended; `audit`: exit faces the exact predicates reject and
    /// steps with no exit face found (zeros unless the cast audits).
    fn answer(
        &self,
        start: &WalkStart,
        walk: &Walk,
        policy: Self::Policy,
        audit: [u32; 2],
    ) -> Self::Answer;

    /// What the query keeps of the triangles an accelerator that tests triangles offers
    /// (`gather`), for the ray `line`.
    type Gather: Gather;
    fn gather(&self, line: &Line) -> Self::Gather;
    /// The answer of what was gathered; `visited`: the nodes the accelerator visited.
    ///
    /// By reference: an accelerator's gatherer can be a few hundred bytes, and taken by value
    /// it was copied (a library call) for every ray.
    fn gathered(&self, gathered: &mut Self::Gather, visited: u32) -> Self::Answer;
    /// What [`QueryKind::gathered`] answers for a ray offered nothing that entered no box
    /// (`visited` 0), whatever the ray: an accelerator that finds a ray enters none of its
    /// boxes answers it so without making it ready for a walk. A miss, as a skipped ray's, for
    /// every kind so far (checked by `exact_bvh`'s test
    /// `the_outside_answer_is_what_a_walk_that_met_nothing_answers`); a kind whose empty
    /// gatherer answers otherwise overrides it.
    #[inline(always)]
    fn outside(&self) -> Self::Answer {
        self.skipped(crate::status::MISS)
    }
}

/// Where a cast writes answers of type A: split into chunks that threads fill independently.
pub trait Sink<A>: Send + Sized {
    fn len(&self) -> usize;
    fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// The first `n` entries and the rest.
    fn split_at(self, n: usize) -> (Self, Self);
    /// Writes entry j, its ray's answer.
    fn put(&mut self, j: usize, answer: A);
}

/// Splits `sink` into pieces of `size` entries (the last may be shorter).
pub fn chunks<A, S: Sink<A>>(sink: S, size: usize) -> Vec<S> {
    let mut out = Vec::with_capacity(sink.len().div_ceil(size.max(1)));
    let mut rest = sink;
    while rest.len() > size {
        let (a, b) = rest.split_at(size);
        out.push(a);
        rest = b;
    }
    out.push(rest);
    out
}

/// Any-hit answers: one status per ray (HIT: something lies in [tmin, tmax]).
impl Sink<u8> for &mut [u8] {
    fn len(&self) -> usize {
        <[u8]>::len(self)
    }
    fn split_at(self, n: usize) -> (Self, Self) {
        self.split_at_mut(n)
    }
    #[inline]
    fn put(&mut self, j: usize, answer: u8) {
        self[j] = answer;
    }
}

#[cfg(test)]
mod tests;
