//! The constrained-tetrahedralization walk as an acceleration structure (Lagae & Dutré 2008):
//! locate the start tet, then walk with exit method M over layout L in precision R, the query
//! deciding at constrained faces; O observes every step (the exact audit) or nothing.

use super::Accel;
use crate::geom::ray::Ray;
use crate::geom::real::Real;
use crate::layout::Layout;
use crate::locate::{LocateState, Locators, Start};
use crate::query::QueryKind;
use crate::traverse::{walk_with, ExitMethod, WalkObserver, WalkSetup};
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
