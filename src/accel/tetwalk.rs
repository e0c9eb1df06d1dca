//! The constrained-tetrahedralization walk as an acceleration structure (Lagae & Dutré 2008):
//! locate the start tet, then walk with exit method M over layout L in precision R, the query
//! deciding at constrained faces; O observes every step (the exact audit) or nothing.

use super::Accel;
use crate::geom::exact::orient_sign;
use crate::geom::ray::Ray;
use crate::geom::real::Real;
use crate::layout::Layout;
use crate::locate::{LocateState, Locators, Start};
use crate::mesh::build::OUTWARD_FACES;
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
    /// lying on a face, edge or vertex of its start tet is a touch at t = 0.
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
            if let Some(at) = origin_touch(s.tet, tet, points, s.o) {
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

/// Where the origin o lies on the boundary of the tet holding it (ids `tet`), exactly: on a
/// face (one zero orientation), an edge (two) or a vertex (three), as a touch at t = 0.
fn origin_touch<R: Real>(t: u32, tet: [u32; 4], points: &[[R; 3]], o: [f64; 3]) -> Option<Touch> {
    let p = tet.map(|v| points[v as usize].map(R::to_f64));
    let zero = OUTWARD_FACES.map(|f| orient_sign(p[f[0]], p[f[1]], p[f[2]], o) == 0);
    // Face i is opposite vertex i: the vertices on every zero face span the feature.
    let on: Vec<usize> = (0..4).filter(|&v| !zero[v]).collect();
    let (face, contact) = match on.as_slice() {
        [a, b, c] => ([tet[*a], tet[*b], tet[*c]], Contact::Face),
        [a, b] => ([tet[*a], tet[*b], tet[*a]], Contact::Edge(0)),
        [a] => ([tet[*a], tet[*a], tet[*a]], Contact::Vertex(0)),
        _ => return None,
    };
    Some(Touch {
        tet: t,
        face,
        slots: false,
        contact,
    })
}
