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
//!
//! A chunk of rays that share an origin (a camera) walks in packets instead
//! ([`TetWalk::trace_packets`] in `tetwalk/packets.rs`, `traverse::packet`): sorted along a
//! Morton curve of their directions, 64 at a time, a packet steps once for all its rays while
//! they leave each tet by one face, and splits into groups by exit where they part; each ray
//! finishes alone from where its group left it, so again every answer is the one-ray walk's,
//! bit for bit.

use super::exact_bvh::{ExactBvh, ExactBvhAt};
use super::Accel;
use super::{trace_each, Lanes, Packets};
use crate::geom::ray::Ray;
use crate::geom::real::Real;
use crate::layout::Layout;
use crate::locate::{LocateState, Locators, Start, WalkStart, GRAZES};
use crate::query::{Decision, Query, QueryKind, Sink};
use crate::simd::Simd;
use crate::traverse::{
    plain_step, walk_begin, walk_resume, Contact, ExitMethod, Touch, Walk, WalkEnd, WalkObserver,
    WalkSetup, WalkState,
};
use std::marker::PhantomData;
use std::sync::Arc;

mod packets;

pub(crate) use packets::direction_key;
#[cfg(test)]
pub use packets::{entered_together, packet_steps};

/// Where a walk gets the scene's exact BVH when it needs one (built on first use:
/// `Scene::exact_bvh`).
pub type BvhSource<'a> = dyn Fn() -> crate::Result<Arc<ExactBvh>> + Sync + 'a;

/// Rays walked side by side in one chunk.
pub const LANES: usize = 8;

/// The most rays in one packet, and the fewest worth walking as one (smaller ones walk ray
/// by ray).
pub const PACKET: usize = 64;
const MIN_PACKET: usize = 3;

pub struct TetWalk<'a, R, L, M, O> {
    pub locators: Locators<'a>,
    pub setup: WalkSetup<'a, R, L>,
    pub lanes: Lanes,
    pub packets: Packets,
    /// The level of the packets' per-ray exit kernel (`traverse::packet::exits_of`).
    pub simd: Simd,
    /// The scene's exact BVH (built on first use), which answers the rays whose line may touch
    /// the box without entering it (`locate::GRAZES`); None: such a ray fails.
    pub grazing: Option<&'a BvhSource<'a>>,
    // fn() -> _: the method and observer are types only, so the walk is Sync whatever they are.
    _types: PhantomData<fn() -> (M, O)>,
}

impl<'a, R, L, M, O> TetWalk<'a, R, L, M, O> {
    pub fn new(locators: Locators<'a>, setup: WalkSetup<'a, R, L>) -> Self {
        TetWalk {
            locators,
            setup,
            lanes: Lanes::Auto,
            packets: Packets::Auto,
            simd: Simd::Scalar,
            grazing: None,
            _types: PhantomData,
        }
    }

    /// The walk with `bvh` to answer the rays that graze the box (see [`TetWalk::grazing`]).
    pub fn with_grazing(self, bvh: &'a BvhSource<'a>) -> Self {
        TetWalk {
            grazing: Some(bvh),
            ..self
        }
    }

    pub fn with_lanes(self, lanes: Lanes, packets: Packets) -> Self {
        TetWalk {
            lanes,
            packets,
            ..self
        }
    }

    pub fn with_simd(self, simd: Simd) -> Self {
        TetWalk { simd, ..self }
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

/// Where a walk stands between plain steps, by ids: in tet `t` after `steps` tets, leaving by
/// the face (a, b, c) (counter-clockwise around the ray, certain edges) across which `link`
/// lies. What the GPU's exact kernel takes and gives back ([`TetWalk::begin_elsewhere`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PlainState {
    pub face: [u32; 3],
    pub link: u32,
    pub t: u32,
    pub steps: u32,
}

/// A lane (or a packet's ray): empty, or the index in its chunk, the ray and its walk.
type Lane<R, M, P, O> = Option<(usize, Walking<R, M, P, O>)>;

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
        // Rays sharing an origin (the chunk's first two) are taken as coherent.
        let shared_origin = out.len() >= 2 && ray_at(0).o == ray_at(1).o;
        if shared_origin && self.packets == Packets::Auto && M::PACKETS && !O::ACTIVE && !L::INLINE
        {
            return self.trace_packets(query, ray_at, out, st);
        }
        let lanes = match self.lanes {
            Lanes::On => true,
            Lanes::Off => false,
            Lanes::Auto => !shared_origin,
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
                    if let Some(w) = self.begin_plain(query, j, &ray, out, st) {
                        *slot = Some((j, w));
                        active += 1;
                        break;
                    }
                }
            }
            if active == 0 {
                return;
            }
            for slot in lanes.iter_mut() {
                let Some((_, w)) = slot else { continue };
                if !plain_step::<R, L, M>(&self.setup, &w.prepared, &mut w.state) {
                    let (j, w) = slot.take().expect("an occupied lane");
                    out.put(j, self.finish(query, w));
                    active -= 1;
                }
            }
        }
    }
}

impl<R: Real, L: Layout, M: ExitMethod<R>, O: WalkObserver<R>> TetWalk<'_, R, L, M, O> {
    /// [`TetWalk::begin`] for a lane or a packet, which take only plain steps: the ray's walk
    /// when its exit face has certain edges (`ExitMethod::step_plain`), else None, with ray
    /// j's answer put in `out` (it ended at the start, or finishes with the one-ray walk).
    #[inline(always)]
    fn begin_plain<K: QueryKind, S: Sink<K::Answer>>(
        &self,
        query: &K,
        j: usize,
        ray: &Ray,
        out: &mut S,
        st: &mut LocateState,
    ) -> Option<Walking<R, M, K::Policy, O>> {
        match self.begin(query, ray, st) {
            Err(answer) => out.put(j, answer),
            Ok(w)
                if M::CONTACTS
                    && M::may_touch(&w.prepared, &w.state.pa, &w.state.pb, &w.state.pc) =>
            {
                out.put(j, self.finish(query, w))
            }
            Ok(w) => return Some(w),
        }
        None
    }

    /// Locates the ray and takes its walk's first exit; Err: its answer already (it does not
    /// walk, or its walk ended at the start).
    #[inline(always)]
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
    #[inline(always)]
    fn begin_exact<K: QueryKind>(
        &self,
        query: &K,
        ray: &Ray,
        st: &mut LocateState,
    ) -> Result<Walking<R, M, K::Policy, O>, K::Answer> {
        let points = self.setup.points;
        let (s, prepared) = match self.locators.locate_exact::<R, M>(ray, points, st) {
            Ok(x) => x,
            Err(GRAZES) => return Err(self.answer_grazing(query, ray)),
            Err(status) => return Err(query.skipped(status)),
        };
        let mesh = self.locators.mesh;
        let tet = mesh.tets[s.tet as usize];
        let observer = O::for_ray(s.o, s.dir, &mesh.bounds);
        let mut policy = query.policy(&s);
        // An origin in no caller's triangle's plane touches nothing (asked once per origin).
        if s.entry.is_none()
            && s.tmin == 0.0
            && st.origin_may_touch(s.o, s.tet, || query.origin_may_touch(&s))
        {
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

    /// The answer to a ray whose line may touch the box without entering it
    /// (`locate::GRAZES`): the exact BVH's, which tests the caller's triangles with the walk's
    /// exact predicates and tie rule (the two agree ray for ray, `accel::exact_bvh`'s tests), so
    /// it is the answer the walk owes. FAILED where no BVH is at hand or it cannot be built.
    #[cold]
    pub(crate) fn answer_grazing<K: QueryKind>(&self, query: &K, ray: &Ray) -> K::Answer {
        let Some(bvh) = self.grazing.and_then(|get| get().ok()) else {
            return query.skipped(crate::status::FAILED);
        };
        let at = ExactBvhAt {
            bvh: &bvh,
            simd: self.simd,
        };
        let mut st = at.state(0);
        at.trace(query, ray, &mut st)
    }

    #[inline(always)]
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

    /// The first half of a walk whose plain steps are taken elsewhere (the GPU's exact kernel,
    /// `gpu::cast`): locates the ray and takes its first exit as [`TetWalk::begin_plain`]
    /// does. Err: the ray's answer (it did not walk, its walk ended at the start, or it may
    /// touch the surface where it stands, so it walked to its end here). Ok: where its walk
    /// stands, an exit face with certain edges and a query policy still fresh (as
    /// `K::policy` makes it: no touch was told to it), for [`TetWalk::walk_on_from`].
    #[cfg(feature = "gpu")]
    pub(crate) fn begin_elsewhere<K: QueryKind>(
        &self,
        query: &K,
        ray: &Ray,
        st: &mut LocateState,
    ) -> Result<(WalkStart, PlainState), K::Answer> {
        let w = self.begin(query, ray, st)?;
        let s = &w.start;
        // Rays whose origin may touch were told so (`begin_exact`): their policy is not fresh.
        let told = M::CONTACTS
            && s.entry.is_none()
            && s.tmin == 0.0
            && st.origin_may_touch(s.o, s.tet, || query.origin_may_touch(s));
        if told || (M::CONTACTS && M::may_touch(&w.prepared, &w.state.pa, &w.state.pb, &w.state.pc))
        {
            return Err(self.finish(query, w));
        }
        let st = &w.state;
        let plain = PlainState {
            face: [st.a, st.b, st.c],
            link: st.link,
            t: st.t,
            steps: st.steps,
        };
        Ok((w.start, plain))
    }

    /// The second half: the walk of the ray started at `start`, standing at `at` after plain
    /// steps taken elsewhere (each the one-ray walk's, so `at` is a state this walk reaches),
    /// walked on to its end here, and its answer: the one-ray walk's, bit for bit.
    #[cfg(feature = "gpu")]
    pub(crate) fn walk_on_from<K: QueryKind>(
        &self,
        query: &K,
        start: &WalkStart,
        at: PlainState,
    ) -> K::Answer {
        let mesh = self.locators.mesh;
        let prepared = start.prepare::<R, M>(mesh);
        let observer = O::for_ray(start.o, start.dir, &mesh.bounds);
        let state =
            WalkState::plain::<R, L, M>(&self.setup, &prepared, at.face, at.link, at.t, at.steps);
        self.walk_on(
            query,
            start,
            &prepared,
            query.policy(start),
            observer,
            state,
        )
    }

    /// Walks on from where `w` stands to the walk's end, and answers.
    #[inline]
    fn finish<K: QueryKind>(&self, query: &K, w: Walking<R, M, K::Policy, O>) -> K::Answer {
        let Walking {
            start,
            prepared,
            policy,
            observer,
            state,
        } = w;
        self.walk_on(query, &start, &prepared, policy, observer, state)
    }

    /// [`TetWalk::finish`] from the parts of a walk (none moved into a `Walking`).
    #[inline(always)]
    fn walk_on<K: QueryKind>(
        &self,
        query: &K,
        start: &WalkStart,
        prepared: &M::Ray,
        mut policy: K::Policy,
        mut observer: O,
        state: WalkState<M::Vert>,
    ) -> K::Answer {
        let walk =
            walk_resume::<R, L, M, _, O>(&self.setup, prepared, state, &mut policy, &mut observer);
        query.answer(start, &walk, policy, observer.counts())
    }
}
