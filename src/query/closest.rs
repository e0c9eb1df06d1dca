//! Closest hit: stop at the first constrained face and evaluate the hit in float64 on the
//! caller's triangle it lies on.

use super::contact::{ExactRay, Meet, Range};
use super::gather::{Line, Nearest};
use super::{Crossing, Decision, Query, QueryKind};
use crate::geom::narrow::triangle_hit32_at;
use crate::geom::rounded::RoundedHit;
use crate::geom::triangle::{intersect_triangle, on_triangle};
use crate::locate::WalkStart;
use crate::mesh::{Incidence, Surface, TetMesh};
use crate::simd::Simd;
use crate::status::{FAILED, HIT, MISS};
use crate::traverse::{Contact, Touch, Walk, WalkEnd};

/// One ray's closest hit before it is written out.
#[derive(Clone, Copy, Debug)]
pub struct RayHit {
    pub status: u8,
    pub t: f64,
    pub u: f64,
    pub v: f64,
    /// The hit point, each coordinate within one ulp of the exact point's.
    pub point: [f64; 3],
    pub triangle: i32,
    pub tet: i32,
    pub steps: u32,
    pub audit: [u32; 2],
}

impl RayHit {
    pub fn nothing(status: u8) -> RayHit {
        RayHit {
            status,
            t: f64::INFINITY,
            u: f64::NAN,
            v: f64::NAN,
            point: [f64::NAN; 3],
            triangle: -1,
            tet: -1,
            steps: 0,
            audit: [0, 0],
        }
    }
}

/// The closest-hit query over a mesh and the caller's triangles.
#[derive(Clone, Copy)]
pub struct ClosestHit<'a> {
    pub mesh: &'a TetMesh,
    pub surface: &'a Surface,
    pub incidence: &'a Incidence,
    /// Some: the answers are stored in float32, and an accelerator that tests triangles rounds
    /// the hit straight to float32 where a float64 evaluation shows those bits
    /// (`geom::narrow::triangle_hit32`, at this SIMD level: the same bits at every level), the
    /// same the faithful values round to.
    pub narrow: Option<Simd>,
}

/// The closest-hit walk policy. A float method's walk stops at the first constrained face
/// (`exact` is None). The exact walk's stops at the first point, in order along the ray, where
/// it meets the surface within [tmin, tmax]: a constrained face crossed through its interior or
/// a touched vertex or edge; a face whose plane holds the line is walked through. The points a
/// line in a face's plane meets on that face's boundary are not in walk order: they are kept
/// (`best`) and the walk goes on to the next point in order, the answer being the earlier.
pub struct ClosestPolicy<'a> {
    pub exact: Option<ExactRay<'a>>,
    pub best: Option<Meet>,
}

impl Query for ClosestPolicy<'_> {
    #[inline(always)]
    fn crossed(&mut self, at: &Crossing) -> Decision {
        let Some(ray) = &self.exact else {
            return Decision::Stop;
        };
        if at.contact != Contact::Interior {
            // In the face's plane: not a hit. Through its boundary: `touched` decided.
            return Decision::Continue;
        }
        let ids = ray.ids(at.tet, at.face, at.slots);
        let Some((meet, range)) = ray.crossing(at.constrained, ids) else {
            let mut best = self.best;
            ray.around(ids, |m, range| {
                if range == Range::In {
                    best = Some(ray.earlier(best, m));
                }
            });
            self.best = best;
            return Decision::Continue;
        };
        match range {
            Range::Before => Decision::Continue,
            Range::In => {
                self.best = Some(ray.earlier(self.best, meet));
                Decision::Stop
            }
            Range::After => Decision::Stop,
        }
    }

    fn touched(&mut self, at: &Touch) -> Decision {
        let Some(ray) = &self.exact else {
            return Decision::Continue;
        };
        let (mut best, mut found, mut past) = (self.best, false, false);
        let ordered = ray.touch(at, |meet, range| match range {
            Range::In => {
                best = Some(ray.earlier(best, meet));
                found = true;
            }
            Range::After => past = true,
            Range::Before => {}
        });
        if at.contact != Contact::Origin {
            ray.around(ray.ids(at.tet, at.face, at.slots), |m, range| {
                if range == Range::In {
                    best = Some(ray.earlier(best, m));
                }
            });
        }
        self.best = best;
        if ordered && (found || past) {
            Decision::Stop
        } else {
            Decision::Continue
        }
    }
}

impl<'a> QueryKind for ClosestHit<'a> {
    type Policy = ClosestPolicy<'a>;
    type Answer = RayHit;
    type Gather = Nearest;

    #[inline(always)]
    fn gather(&self, line: &Line) -> Nearest {
        Nearest::new(line)
    }

    // Inlined into the walk: as a call (and `HitsOut::set` another), each ray's answer went
    // through memory between the two, and both calls saved the walk's registers at every
    // ray's end. Inlined: bunny's camera rays +13%, random +5-11% (docs/performance.md).
    #[inline(always)]
    fn gathered(&self, g: &mut Nearest, visited: u32) -> RayHit {
        let mut r = RayHit {
            steps: visited,
            ..RayHit::nothing(MISS)
        };
        let Some(id) = g.best else {
            return r;
        };
        let line = &g.line;
        let fast = self
            .narrow
            .and_then(|simd| triangle_hit32_at(simd, line.o, line.d, &g.best_tri));
        r.status = HIT;
        r.triangle = id as i32;
        match fast {
            Some(h) => {
                (r.t, r.u, r.v) = (h.t.into(), h.u.into(), h.v.into());
                r.point = h.point.map(f64::from);
            }
            None => {
                let m = line.meet(&g.best_tri, id);
                (r.t, r.u, r.v, r.point) = (m.t, m.u, m.v, m.point);
            }
        }
        r
    }

    #[inline(always)]
    fn policy(&self, s: &WalkStart) -> ClosestPolicy<'a> {
        ClosestPolicy {
            exact: s
                .exact
                .then(|| ExactRay::new(self.mesh, self.incidence, self.surface, s)),
            best: None,
        }
    }

    fn origin_may_touch(&self, s: &WalkStart) -> bool {
        ExactRay::new(self.mesh, self.incidence, self.surface, s).origin_on_a_plane(s.tet)
    }

    #[inline]
    fn skipped(&self, status: u8) -> RayHit {
        RayHit::nothing(status)
    }

    #[inline]
    fn answer(&self, s: &WalkStart, w: &Walk, p: ClosestPolicy<'a>, audit: [u32; 2]) -> RayHit {
        let hit = if p.exact.is_some() {
            self.exact_answer(w, p.best)
        } else {
            self.finish(s, w)
        };
        RayHit { audit, ..hit }
    }
}

impl ClosestHit<'_> {
    /// The exact walk's answer: the point its policy kept, else a miss (or FAILED when the step
    /// guard ended the walk first).
    fn exact_answer(&self, w: &Walk, best: Option<Meet>) -> RayHit {
        let mut r = RayHit {
            tet: w.tet as i32,
            steps: w.steps,
            ..RayHit::nothing(MISS)
        };
        match best {
            Some(m) => {
                r.status = HIT;
                (r.t, r.u, r.v, r.point, r.triangle) = (m.t, m.u, m.v, m.point, m.triangle as i32);
            }
            None if w.end == WalkEnd::StepLimit => r.status = FAILED,
            None => {}
        }
        r
    }

    /// The hit of a finished walk, evaluated in f64 on the caller's triangle (the CPU cast's
    /// and the GPU's second half).
    #[inline]
    pub fn finish(&self, s: &WalkStart, w: &Walk) -> RayHit {
        let mesh = self.mesh;
        let mut r = RayHit {
            tet: w.tet as i32,
            steps: w.steps,
            ..RayHit::nothing(MISS)
        };
        match w.end {
            WalkEnd::Boundary | WalkEnd::Touched => {}
            WalkEnd::StepLimit => r.status = FAILED,
            WalkEnd::Hit { constrained } => {
                let named = mesh.constrained[constrained as usize].triangle;
                let ids = if w.slots {
                    w.face.map(|k| mesh.tets[w.tet as usize][k as usize])
                } else {
                    w.face
                };
                let face = || ids.map(|v| mesh.points[v as usize]);
                let (tri, h) = self.hit_triangle(s, named, face);
                if h.t <= s.tmax {
                    r = RayHit {
                        status: HIT,
                        t: h.t.max(s.tmin),
                        u: h.u,
                        v: h.v,
                        point: h.point,
                        triangle: tri as i32,
                        ..r
                    };
                }
            }
        }
        r
    }

    /// The caller's triangle a hit on a constrained face lies on, and (t, u, v) on it: of the
    /// named one and its alternatives, the one the ray crosses nearest the face (the named
    /// one when the ray crosses none of them).
    fn hit_triangle(
        &self,
        s: &WalkStart,
        named: u32,
        face: impl Fn() -> [[f64; 3]; 3],
    ) -> (u32, RoundedHit) {
        let triangles = &self.surface.triangles;
        let on_named = intersect_triangle(s.o, s.d, &triangles[named as usize], &face);
        let alternatives = self.surface.alternatives.of(named);
        if alternatives.is_empty() {
            return (named, on_named);
        }
        // Of the named triangle and its alternatives, the one the ray crosses nearest to
        // where it crosses the face (the named one may be crossed too, farther away).
        use glam::DVec3;
        let [a, b, c] = face().map(DVec3::from);
        let (o, d) = (DVec3::from(s.o), DVec3::from(s.d));
        let n = (b - a).cross(c - a);
        let t_face = n.dot(a - o) / n.dot(d);
        let mut best = (named, on_named);
        let mut best_gap = if on_triangle(&on_named) {
            (on_named.t - t_face).abs()
        } else {
            f64::INFINITY
        };
        // Crossed within a face's size of the face: the named triangle is the one (most
        // hits; the alternatives are then not tried).
        let size = (b - a).length().max((c - b).length()).max((a - c).length());
        if best_gap * d.length() <= size {
            return best;
        }
        for &alt in alternatives {
            let hit = intersect_triangle(s.o, s.d, &triangles[alt as usize], &face);
            let gap = (hit.t - t_face).abs();
            if on_triangle(&hit) && gap < best_gap {
                (best, best_gap) = ((alt, hit), gap);
            }
        }
        best
    }
}
