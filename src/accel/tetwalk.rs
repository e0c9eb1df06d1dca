//! The constrained-tetrahedralization walk as an acceleration structure (Lagae & Dutré 2008):
//! locate the start tet, then walk with exit method M over layout L in precision R, the query
//! deciding at constrained faces; O observes every step (the exact audit) or nothing.
//!
//! A chunk of rays is walked in [`LANES`] interleaved lanes: one walk waits on memory at every
//! step (the next tet's record, then its new vertex), so walking several independent rays
//! side by side keeps several of those loads in flight. Lanes take only plain steps
//! (`traverse::plain_step`); a ray whose next step is anything else (a constrained face, the
//! boundary, an uncertain or touching exit) leaves its lane and finishes with the one-ray walk
//! from the same state, so every answer is the one-ray walk's, bit for bit.

use super::Accel;
use super::{trace_each, Lanes};
use crate::geom::ray::Ray;
use crate::geom::real::Real;
use crate::layout::Layout;
use crate::locate::{LocateState, Locators, Start, WalkStart};
use crate::query::{Decision, Query, QueryKind, Sink};
use crate::traverse::{
    plain_step, walk_begin, walk_resume, Contact, ExitMethod, Touch, Walk, WalkEnd, WalkObserver,
    WalkSetup, WalkState,
};
use std::marker::PhantomData;

/// Rays walked side by side in one chunk.
pub const LANES: usize = 8;

pub struct TetWalk<'a, R, L, M, O> {
    pub locators: Locators<'a>,
    pub setup: WalkSetup<'a, R, L>,
    pub lanes: Lanes,
    // fn() -> _: the method and observer are types only, so the walk is Sync whatever they are.
    _types: PhantomData<fn() -> (M, O)>,
}

impl<'a, R, L, M, O> TetWalk<'a, R, L, M, O> {
    pub fn new(locators: Locators<'a>, setup: WalkSetup<'a, R, L>) -> Self {
        TetWalk {
            locators,
            setup,
            lanes: Lanes::Auto,
            _types: PhantomData,
        }
    }

    pub fn with_lanes(self, lanes: Lanes) -> Self {
        TetWalk { lanes, ..self }
    }
}

/// A ray between two steps of its walk, with what its answer will need.
struct Walking<R: Real, M: ExitMethod<R>, P, O> {
    start: WalkStart,
    prepared: M::Ray,
    policy: P,
    observer: O,
    state: WalkState<M::Vert>,
}

/// A lane: empty, or the index in its chunk, the ray and its walk.
type Lane<R, M, P, O> = Option<(usize, Ray, Walking<R, M, P, O>)>;

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
        match self.begin(query, ray, st) {
            Ok(w) => self.finish(query, w),
            Err(answer) => answer,
        }
    }

    fn trace_chunk<K: QueryKind, S: Sink<K::Answer>>(
        &self,
        query: &K,
        ray_at: impl Fn(usize) -> Ray,
        out: &mut S,
        st: &mut LocateState,
    ) {
        let lanes = match self.lanes {
            Lanes::On => true,
            Lanes::Off => false,
            // Rays sharing an origin (the chunk's first two) are taken as coherent.
            Lanes::Auto => out.len() < 2 || ray_at(0).o != ray_at(1).o,
        };
        if O::ACTIVE || L::INLINE || !lanes {
            // The audit observes every step, and INLINE layouts name vertices by slot: the
            // one-ray walk (and where lanes are not wanted).
            return trace_each(self, query, ray_at, out, st);
        }
        let mut lanes: [Lane<R, M, K::Policy, O>; LANES] = std::array::from_fn(|_| None);
        let (n, mut next, mut active) = (out.len(), 0usize, 0usize);
        loop {
            // Fill empty lanes in ray order (location carries hints from ray to ray).
            for slot in lanes.iter_mut().filter(|s| s.is_none()) {
                while next < n {
                    let j = next;
                    next += 1;
                    let ray = ray_at(j);
                    match self.begin(query, &ray, st) {
                        Err(answer) => out.put(j, answer, &ray),
                        // A lane's exit faces must have certain edges (`ExitMethod::step_plain`).
                        Ok(w)
                            if M::CONTACTS
                                && M::may_touch(
                                    &w.prepared,
                                    &w.state.pa,
                                    &w.state.pb,
                                    &w.state.pc,
                                ) =>
                        {
                            out.put(j, self.finish(query, w), &ray)
                        }
                        Ok(w) => {
                            *slot = Some((j, ray, w));
                            active += 1;
                            break;
                        }
                    }
                }
            }
            if active == 0 {
                return;
            }
            for slot in lanes.iter_mut() {
                let Some((_, _, w)) = slot else { continue };
                if !plain_step::<R, L, M>(&self.setup, &w.prepared, &mut w.state) {
                    let (j, ray, w) = slot.take().expect("an occupied lane");
                    out.put(j, self.finish(query, w), &ray);
                    active -= 1;
                }
            }
        }
    }
}

impl<R: Real, L: Layout, M: ExitMethod<R>, O: WalkObserver<R>> TetWalk<'_, R, L, M, O> {
    /// Locates the ray and takes its walk's first exit; Err: its answer already (it does not
    /// walk, or its walk ended at the start).
    #[inline]
    fn begin<K: QueryKind>(
        &self,
        query: &K,
        ray: &Ray,
        st: &mut LocateState,
    ) -> Result<Walking<R, M, K::Policy, O>, K::Answer> {
        if M::CONTACTS {
            return self.begin_exact(query, ray, st);
        }
        let settle = M::PERTURBED_START.then_some(self.setup.points);
        let s = match self.locators.locate(ray, settle, st) {
            Start::Done(status) => return Err(query.skipped(status)),
            Start::Walk(s) => s,
        };
        let mesh = self.locators.mesh;
        let prepared = s.prepare::<R, M>(mesh);
        let observer = O::for_ray(s.point, s.dir, &mesh.bounds);
        let policy = query.policy(&s);
        self.first_exit(query, s, prepared, policy, observer)
    }

    /// The exact walk's start: at the origin (or the exact box entry); an origin on one of the
    /// caller's triangles is a hit at t = 0 (`Contact::Origin`).
    fn begin_exact<K: QueryKind>(
        &self,
        query: &K,
        ray: &Ray,
        st: &mut LocateState,
    ) -> Result<Walking<R, M, K::Policy, O>, K::Answer> {
        let points = self.setup.points;
        let (s, prepared) = match self.locators.locate_exact::<R, M>(ray, points, st) {
            Ok(x) => x,
            Err(status) => return Err(query.skipped(status)),
        };
        let mesh = self.locators.mesh;
        let tet = mesh.tets[s.tet as usize];
        let observer = O::for_ray(s.o, s.dir, &mesh.bounds);
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
                return Err(query.answer(&s, &w, policy, observer.counts()));
            }
        }
        self.first_exit(query, s, prepared, policy, observer)
    }

    #[inline]
    fn first_exit<K: QueryKind>(
        &self,
        query: &K,
        start: WalkStart,
        prepared: M::Ray,
        mut policy: K::Policy,
        mut observer: O,
    ) -> Result<Walking<R, M, K::Policy, O>, K::Answer> {
        let tet = self.locators.mesh.tets[start.tet as usize];
        match walk_begin::<R, L, M, _, O>(
            &self.setup,
            &prepared,
            (start.tet, tet),
            start.entry,
            &mut policy,
            &mut observer,
        ) {
            Ok(state) => Ok(Walking {
                start,
                prepared,
                policy,
                observer,
                state,
            }),
            Err(w) => Err(query.answer(&start, &w, policy, observer.counts())),
        }
    }

    /// Walks on from where `w` stands to the walk's end, and answers.
    #[inline]
    fn finish<K: QueryKind>(&self, query: &K, w: Walking<R, M, K::Policy, O>) -> K::Answer {
        let Walking {
            start,
            prepared,
            mut policy,
            mut observer,
            state,
        } = w;
        let walk =
            walk_resume::<R, L, M, _, O>(&self.setup, &prepared, state, &mut policy, &mut observer);
        query.answer(&start, &walk, policy, observer.counts())
    }
}
