//! Any hit (occlusion): is there a scene triangle on the ray within [tmin, tmax]? The walk stops
//! at the first constrained face; the ray is occluded when that crossing lies within tmax.

use super::closest::ClosestPolicy;
use super::gather::{Found, Line};
use super::{ClosestHit, QueryKind};
use crate::locate::WalkStart;
use crate::status::{HIT, MISS};
use crate::traverse::Walk;

/// The any-hit query; its answer is a status per ray (HIT: occluded, MISS, FAILED, INVALID).
#[derive(Clone, Copy)]
pub struct AnyHit<'a>(pub ClosestHit<'a>);

impl<'a> QueryKind for AnyHit<'a> {
    type Policy = ClosestPolicy<'a>;
    type Answer = u8;
    type Gather = Found;

    fn gather(&self, line: &Line) -> Found {
        Found {
            found: false,
            tmax: line.tmax,
        }
    }

    fn gathered(&self, g: &mut Found, _: u32) -> u8 {
        if g.found {
            HIT
        } else {
            MISS
        }
    }

    #[inline(always)]
    fn policy(&self, s: &WalkStart) -> ClosestPolicy<'a> {
        self.0.policy(s)
    }

    fn origin_may_touch(&self, s: &WalkStart) -> bool {
        self.0.origin_may_touch(s)
    }

    #[inline]
    fn skipped(&self, status: u8) -> u8 {
        status
    }

    /// The first face the walk meets is the nearest, so the ray is occluded exactly when the
    /// closest hit lies within [tmin, tmax]: the same evaluation decides both.
    #[inline]
    fn answer(&self, s: &WalkStart, w: &Walk, p: ClosestPolicy<'a>, audit: [u32; 2]) -> u8 {
        let hit = self.0.answer(s, w, p, audit);
        debug_assert!(hit.status != HIT || hit.t <= s.tmax);
        hit.status
    }
}
