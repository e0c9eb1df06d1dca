//! The constrained-tetrahedralization walk as an acceleration structure (Lagae & Dutré 2008):
//! locate the start tet, then walk with exit method M over layout L in precision R, the query
//! deciding at constrained faces; O observes every step (the exact audit) or nothing.

use super::Accel;
use crate::geom::ray::Ray;
use crate::geom::real::Real;
use crate::layout::Layout;
use crate::locate::{LocateState, Locators, Start};
use crate::query::QueryKind;
use crate::query::{Decision, Query};
use crate::traverse::{
    walk_with, Contact, ExitMethod, Touch, Walk, WalkEnd, WalkObserver, WalkSetup,
};
use std::marker::PhantomData;

pub struct TetWalk<'a, R, L, M, O> {
    pub locators: Locators<'a>,
    pub setup: WalkSetup<'a, R, L>,
    // fn() -> _: the method and observer are types only, so the walk is Sync whatever they are.
    _types: PhantomData<fn() -> (M, O)>,
}

impl<'a, R, L, M, O> TetWalk<'a, R, L, M, O> {
    pub fn new(locators: Locators<'a>, setup: WalkSetup<'a, R, L>) -> Self {
        TetWalk {
            locators,
            setup,
            _types: PhantomData,
        }
    }
}

impl<R: Real, L: Layout, M: ExitMethod<R>, O: WalkObserver<R>> Accel<R>
    for TetWalk<'_, R, L, M, O>
{
    const NAME: &'static str = "tetwalk";
    type State = LocateState;

    fn state(&self, chunk: usize) -> LocateState {
        LocateState::for_chunk(chunk)
    }

    #[inline]
    fn trace<K: QueryKind>(&self, query: &K, ray: &Ray, st: &mut LocateState) -> K::Answer {
        if M::CONTACTS {
            return self.trace_exact(query, ray, st);
        }
        let settle = M::PERTURBED_START.then_some(self.setup.points);
        let s = match self.locators.locate(ray, settle, st) {
            Start::Done(status) => return query.skipped(status),
            Start::Walk(s) => s,
        };
        let mesh = self.locators.mesh;
        let prepared = s.prepare::<R, M>(mesh);
        let mut observer = O::for_ray(s.point, s.dir, &mesh.bounds);
        let mut policy = query.policy(&s);
        let w = walk_with::<R, L, M, _, O>(
            &self.setup,
            &prepared,
            (s.tet, mesh.tets[s.tet as usize]),
            s.entry,
            &mut policy,
            &mut observer,
        );
        query.answer(&s, &w, policy, observer.counts())
    }
}

impl<R: Real, L: Layout, M: ExitMethod<R>, O: WalkObserver<R>> TetWalk<'_, R, L, M, O> {
    /// The exact walk's trace: it starts at the origin (or the exact box entry), and an origin
    /// on one of the caller's triangles is a hit at t = 0 (`Contact::Origin`).
    fn trace_exact<K: QueryKind>(&self, query: &K, ray: &Ray, st: &mut LocateState) -> K::Answer {
        let points = self.setup.points;
        let (s, prepared) = match self.locators.locate_exact::<R, M>(ray, points, st) {
            Ok(x) => x,
            Err(status) => return query.skipped(status),
        };
        let mesh = self.locators.mesh;
        let tet = mesh.tets[s.tet as usize];
        let mut observer = O::for_ray(s.o, s.dir, &mesh.bounds);
        let mut policy = query.policy(&s);
        if s.entry.is_none() && s.tmin == 0.0 {
            let at = Touch {
                tet: s.tet,
                face: [tet[0], tet[1], tet[2]],
                slots: false,
                contact: Contact::Origin,
            };
            if policy.touched(&at) == Decision::Stop {
                let w = Walk {
                    end: WalkEnd::Touched,
                    tet: s.tet,
                    face: at.face,
                    slots: false,
                    steps: 0,
                };
                return query.answer(&s, &w, policy, observer.counts());
            }
        }
        let w = walk_with::<R, L, M, _, O>(
            &self.setup,
            &prepared,
            (s.tet, tet),
            s.entry,
            &mut policy,
            &mut observer,
        );
        query.answer(&s, &w, policy, observer.counts())
    }
}
