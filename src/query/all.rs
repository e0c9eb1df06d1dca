//! All hits and counts: every point where the ray meets the surface within [tmin, tmax], in
//! order of exact t, each point once (a ray through a shared edge or vertex meets the surface
//! once there, however many triangles share it). The exact walk's policy: it walks on through
//! constrained faces and collects what `contact` reports, skipping points it already has.

use super::contact::{ExactRay, Meet, Range};
use super::gather::{Every, Line};
use super::{ClosestHit, Crossing, Decision, Query, QueryKind, Sink};
use crate::locate::WalkStart;
use crate::status::{FAILED, HIT, INVALID, MISS};
use crate::traverse::{Contact, Touch, Walk, WalkEnd};

/// One ray's points, sorted by exact t (each point once), and its status (HIT when there is
/// one).
#[derive(Clone, Debug, Default)]
pub struct Listed {
    pub status: u8,
    pub meets: Vec<Meet>,
}

/// The all-hits query (needs the exact walk: its policy reads the touches).
#[derive(Clone, Copy)]
pub struct AllHits<'a>(pub ClosestHit<'a>);

pub struct AllPolicy<'a> {
    exact: Option<ExactRay<'a>>,
    meets: Vec<Meet>,
}

impl AllPolicy<'_> {
    /// Adds a point unless it is listed: the same feature (`key`), or the same exact t (the
    /// same point of the ray, however it was reported: the origin as such or as the vertex
    /// or edge it is on, a point found around an in-plane face, ...). Of the triangles met at
    /// one point, the smallest id names it (as the closest hit's `earlier`).
    fn add(&mut self, meet: Meet) {
        let Some(ray) = &self.exact else {
            return;
        };
        let same = |m: &Meet| m.key == meet.key || ray.cmp_meets(m, &meet).is_eq();
        match self.meets.iter_mut().find(|m| same(m)) {
            Some(m) if meet.triangle < m.triangle => *m = meet,
            Some(_) => {}
            None => self.meets.push(meet),
        }
    }
}

impl Query for AllPolicy<'_> {
    fn crossed(&mut self, at: &Crossing) -> Decision {
        let Some(ray) = self.exact else {
            return Decision::Stop;
        };
        if at.contact != Contact::Interior {
            return Decision::Continue;
        }
        let ids = ray.ids(at.tet, at.face, at.slots);
        let Some((meet, range)) = ray.crossing(at.constrained, ids) else {
            let mut found = Vec::new();
            ray.around(ids, |m, range| {
                if range == Range::In {
                    found.push(m);
                }
            });
            for m in found {
                self.add(m);
            }
            return Decision::Continue;
        };
        match range {
            Range::Before => Decision::Continue,
            Range::In => {
                self.add(meet);
                Decision::Continue
            }
            Range::After => Decision::Stop,
        }
    }

    fn touched(&mut self, at: &Touch) -> Decision {
        let Some(ray) = self.exact else {
            return Decision::Continue;
        };
        let mut past = false;
        let mut found = Vec::new();
        let ordered = ray.touch(at, |meet, range| match range {
            Range::In => found.push(meet),
            Range::After => past = true,
            Range::Before => {}
        });
        if at.contact != Contact::Origin {
            ray.around(ray.ids(at.tet, at.face, at.slots), |m, range| {
                if range == Range::In {
                    found.push(m);
                }
            });
        }
        for m in found {
            self.add(m);
        }
        if ordered && past {
            Decision::Stop
        } else {
            Decision::Continue
        }
    }
}

impl<'a> QueryKind for AllHits<'a> {
    type Policy = AllPolicy<'a>;
    type Answer = Listed;
    type Gather = Every<'a>;

    fn gather(&self, line: &Line) -> Every<'a> {
        Every::new(line, &self.0.surface.triangles)
    }

    fn gathered(&self, g: &mut Every<'a>, _: u32) -> Listed {
        let meets = g.meets();
        let status = if meets.is_empty() { MISS } else { HIT };
        Listed { status, meets }
    }

    fn policy(&self, s: &WalkStart) -> AllPolicy<'a> {
        let c = &self.0;
        AllPolicy {
            exact: s
                .exact
                .then(|| ExactRay::new(c.mesh, c.incidence, c.surface, s)),
            meets: Vec::new(),
        }
    }

    fn origin_may_touch(&self, s: &WalkStart) -> bool {
        self.0.origin_may_touch(s)
    }

    fn skipped(&self, status: u8) -> Listed {
        Listed {
            status,
            meets: Vec::new(),
        }
    }

    fn answer(&self, _: &WalkStart, w: &Walk, p: AllPolicy<'a>, _: [u32; 2]) -> Listed {
        let mut meets = p.meets;
        // In-plane touches arrive out of order, and points whose exact t are closer than t's
        // rounding error may arrive in either order: sort by exact t (`cmp_meets`; no two are
        // the same point, `add`). Their float t may then be out of order by that error.
        if let Some(ray) = &p.exact {
            meets.sort_by(|a, b| ray.cmp_meets(a, b).then(a.triangle.cmp(&b.triangle)));
        }
        let status = if w.end == WalkEnd::StepLimit {
            FAILED
        } else if meets.is_empty() {
            MISS
        } else {
            HIT
        };
        Listed { status, meets }
    }
}

impl Sink<Listed> for &mut [Listed] {
    fn len(&self) -> usize {
        <[Listed]>::len(self)
    }
    fn split_at(self, n: usize) -> (Self, Self) {
        self.split_at_mut(n)
    }
    #[inline]
    fn put(&mut self, j: usize, mut answer: Listed) {
        // As a closest hit (`HitsOut::set`): a point whose t overflows float64 (a direction so
        // short that t is beyond it) has no true t to report, so the ray is INVALID.
        if answer.status == HIT && answer.meets.iter().any(|m| !m.t.is_finite()) {
            answer = Listed {
                status: INVALID,
                meets: Vec::new(),
            };
        }
        self[j] = answer;
    }
}
