//! The walk from tet to tet, written once for every method, layout, precision and question.
//! An [`ExitMethod`] decides which face a ray leaves a tet by, a [`Layout`] says what lies across
//! it, and a [`Query`] decides at each constrained face whether the walk stops there or records
//! it and walks on through (closest hit stops at the first; all hits and counts go on).

use super::{Contact, Exit, ExitMethod, WalkObserver};
use crate::geom::real::{Real, V3};
use crate::layout::Layout;
use crate::mesh::build::{ConstrainedSide, CONSTRAINED_BIT, OUTWARD_FACES};
use crate::mesh::BOUNDARY;
use crate::traverse::NoObserver;

/// What the walk does at a constrained face.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Decision {
    /// End the walk here (`WalkEnd::Hit`).
    Stop,
    /// Walk on into the tet beyond the face.
    Continue,
}

/// A constrained face the walk reached.
#[derive(Clone, Copy, Debug)]
pub struct Crossing {
    /// Index into the mesh's constrained-side table (which names the caller's triangle).
    pub constrained: u32,
    /// The tet the walk leaves, and the face it leaves by, counter-clockwise around the ray:
    /// point ids, or with `slots` the vertices' local indices in the tet.
    pub tet: u32,
    pub face: [u32; 3],
    pub slots: bool,
    /// Where the line meets the face, for methods with exact contacts (else `Interior`):
    /// `Coplanar` (the line lies in its plane: never a hit) or a vertex or edge, which the
    /// query has already been told of through [`Query::touched`].
    pub contact: Contact,
}

/// The exact line touches a vertex or an edge of the face it leaves a tet by, lies in its
/// plane, or (at the start) has its origin on a face, edge or vertex of the start tet: every
/// scene triangle around that vertex or edge is met there, whichever tets the walk goes on
/// through, so the query must look them up.
#[derive(Clone, Copy, Debug)]
pub struct Touch {
    pub tet: u32,
    /// The face's vertices (as for [`Crossing::face`]); `contact` indexes them.
    pub face: [u32; 3],
    pub slots: bool,
    pub contact: Contact,
}

/// A walk policy (the query kinds in `crate::query` implement it): called at every
/// constrained face the walk reaches, in order along the ray.
pub trait Query {
    fn crossed(&mut self, at: &Crossing) -> Decision;
    /// Called, in order along the walk, where a method with exact contacts touches a vertex
    /// or an edge (see [`Touch`]); before `crossed` when that face is constrained.
    fn touched(&mut self, _at: &Touch) -> Decision {
        Decision::Continue
    }
}

/// Stops at the first constrained face: closest hit and any hit (the first face a walk meets
/// is the nearest one, so both stop there).
#[derive(Clone, Copy, Debug, Default)]
pub struct StopAtFirst;

impl Query for StopAtFirst {
    #[inline(always)]
    fn crossed(&mut self, _: &Crossing) -> Decision {
        Decision::Stop
    }
}

/// How a walk ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WalkEnd {
    /// Stopped at a constrained face (the query said so): index into the constrained table.
    Hit { constrained: u32 },
    /// Stopped at a touch (the query said so, and holds the answer).
    Touched,
    /// Left the domain.
    Boundary,
    /// The step guard fired (a cycle or a degenerate mesh): the ray is reported as FAILED.
    StepLimit,
}

#[derive(Clone, Copy, Debug)]
pub struct Walk {
    pub end: WalkEnd,
    /// The tet the walk was in when it ended.
    pub tet: u32,
    /// The face it left by, ordered counter-clockwise around the ray: point ids, or with
    /// `slots` the vertices' local indices in the tet (INLINE layouts know no ids).
    pub face: [u32; 3],
    pub slots: bool,
    /// Tets visited, the start tet included.
    pub steps: u32,
}

/// What a walk reads besides the ray: the layout's records, the points in the walk's precision,
/// the constrained-side table (to walk on through a constrained face) and the step guard.
pub struct WalkSetup<'a, R, L> {
    pub layout: &'a L,
    pub points: &'a [[R; 3]],
    /// Read only when a query continues through a constrained face.
    pub sides: &'a [ConstrainedSide],
    pub max_steps: u32,
}

/// The closest-hit walk with no observer: from `start` (whose vertex ids are `start_tet`,
/// positively oriented) to the first constrained face, the domain boundary or `max_steps`.
#[inline]
pub fn walk<R: Real, L: Layout, M: ExitMethod<R>>(
    layout: &L,
    points: &[[R; 3]],
    ray: &M::Ray,
    start: (u32, [u32; 4]),
    entry: Option<usize>,
    max_steps: u32,
) -> Walk {
    let setup = WalkSetup {
        layout,
        points,
        sides: &[],
        max_steps,
    };
    walk_with::<R, L, M, _, _>(&setup, ray, start, entry, &mut StopAtFirst, &mut NoObserver)
}

/// A walk between two steps: in tet `t`, having chosen the face (a, b, c) it leaves by
/// (counter-clockwise around the ray), with `link` what lies across it. The loop of
/// [`walk_resume`] starts from here; [`plain_step`] advances it one tet when nothing there
/// needs more than the vertex data (the lanes of `accel::tetwalk`).
#[derive(Clone, Copy, Debug)]
pub struct WalkState<V> {
    pub a: u32,
    pub b: u32,
    pub c: u32,
    pub pa: V,
    pub pb: V,
    pub pc: V,
    pub link: u32,
    pub t: u32,
    pub steps: u32,
    /// INLINE layouts: the entered tet's face by which the walk came in.
    entry_face: usize,
    /// Where the line meets the current exit face (methods with exact contacts).
    contact: Contact,
}

impl<V> WalkState<V> {
    /// A ray's walk standing in tet `t`, leaving by the face (a, b, c) (ids, counter-clockwise
    /// around the ray, no touch there), `link` across it: where a packet of rays leaves the
    /// ray (`traverse::packet`). Id layouts only.
    pub fn plain<R: Real, L: Layout, M: ExitMethod<R, Vert = V>>(
        setup: &WalkSetup<R, L>,
        ray: &M::Ray,
        [a, b, c]: [u32; 3],
        link: u32,
        t: u32,
        steps: u32,
    ) -> Self {
        debug_assert!(!L::INLINE);
        let vertex = |v: u32| M::vertex(ray, position(setup.layout, setup.points, t, v));
        WalkState {
            a,
            b,
            c,
            pa: vertex(a),
            pb: vertex(b),
            pc: vertex(c),
            link,
            t,
            steps,
            entry_face: 0,
            contact: Contact::Interior,
        }
    }
}

/// Walks from tet `start.0` (vertex ids `start.1`, positively oriented) until `query` stops at a
/// constrained face, the walk leaves the domain, or `max_steps`; `observer` sees every exit
/// face. With `entry = Some(i)` the ray comes from outside through the tet's face i (opposite
/// vertex i), which saves finding it.
///
/// Id layouts carry the entry face's vertex ids and their per-vertex data from tet to tet,
/// fetching one new vertex per step; INLINE layouts (Tet80) carry the entry face's local index
/// and read all four vertices from the record, as Maria et al. do. `a`, `b`, `c`, `d` hold
/// ids in the first case and local slots in the second.
#[inline]
pub fn walk_with<R: Real, L: Layout, M: ExitMethod<R>, Q: Query, O: WalkObserver<R>>(
    setup: &WalkSetup<R, L>,
    ray: &M::Ray,
    start: (u32, [u32; 4]),
    entry: Option<usize>,
    query: &mut Q,
    observer: &mut O,
) -> Walk {
    match walk_begin::<R, L, M, Q, O>(setup, ray, start, entry, query, observer) {
        Ok(state) => walk_resume::<R, L, M, Q, O>(setup, ray, state, query, observer),
        Err(done) => done,
    }
}

/// A record's float32 coordinate in the walk's precision. INLINE layouts serve float32 walks
/// only (`scene::cast` refuses float64 ones), so where it runs this is the identity (both
/// conversions are exact and the compiler folds them), and `Real` needs no float32
/// conversion that only a refused cast would call.
#[inline(always)]
fn widen<R: Real>(x: f32) -> R {
    R::from_f64(f64::from(x))
}

/// A vertex's position: from the points, or for INLINE layouts from the record of tet t.
#[inline(always)]
fn position<R: Real, L: Layout>(layout: &L, points: &[[R; 3]], t: u32, v: u32) -> V3<R> {
    if L::INLINE {
        layout.inline_vertices(t)[v as usize].map(widen)
    } else {
        debug_assert!((v as usize) < points.len());
        // SAFETY: v is a vertex id of a validated tet (ids, and xors of ids, were checked
        // against the point count at build), so it indexes `points`.
        unsafe { *points.get_unchecked(v as usize) }
    }
}

/// Tells the query of a touch at the exit face; the finished walk when it stops there.
#[inline(always)]
fn touch<L: Layout, Q: Query>(
    query: &mut Q,
    t: u32,
    face: [u32; 3],
    contact: Contact,
    steps: u32,
) -> Option<Walk> {
    if contact == Contact::Interior {
        return None;
    }
    let at = Touch {
        tet: t,
        face,
        slots: L::INLINE,
        contact,
    };
    (query.touched(&at) == Decision::Stop).then_some(Walk {
        end: WalkEnd::Touched,
        tet: t,
        face,
        slots: L::INLINE,
        steps,
    })
}

/// Face i of a tet (vertex names `names`) as a ray entering through it sees it: reversed from
/// its outward order it turns counter-clockwise around the ray, as the loop expects of the face
/// a walk stands at ([`walk_begin`]'s state when the ray comes from outside).
#[inline(always)]
pub fn entry_face(names: [u32; 4], i: usize) -> [u32; 3] {
    let f = OUTWARD_FACES[i];
    [names[f[0]], names[f[2]], names[f[1]]]
}

/// The walk's first exit: the start tet's exit face (or, entering from outside, the entry
/// face as the one to cross), with its touches told to the query. Err: the walk ended there.
#[inline]
pub fn walk_begin<R: Real, L: Layout, M: ExitMethod<R>, Q: Query, O: WalkObserver<R>>(
    setup: &WalkSetup<R, L>,
    ray: &M::Ray,
    (start, start_tet): (u32, [u32; 4]),
    entry: Option<usize>,
    query: &mut Q,
    observer: &mut O,
) -> Result<WalkState<M::Vert>, Walk> {
    let (layout, points) = (setup.layout, setup.points);
    let position = |t: u32, v: u32| position(layout, points, t, v);
    // Vertex names in the start tet: ids, or slots 0..4 for INLINE layouts.
    let names = if L::INLINE { [0, 1, 2, 3] } else { start_tet };
    let mut contact = Contact::Interior;
    if let Some(i) = entry {
        let [a, b, c] = entry_face(names, i);
        let (pa, pb, pc) = (
            M::vertex(ray, position(start, a)),
            M::vertex(ray, position(start, b)),
            M::vertex(ray, position(start, c)),
        );
        if M::CONTACTS && M::may_touch(ray, &pa, &pb, &pc) {
            // Entering from outside: the entry point may be a vertex or on an edge where
            // scene triangles meet the box.
            let face = [position(start, a), position(start, b), position(start, c)];
            contact = M::contact(ray, &face, position(start, names[i]));
            if let Some(w) = touch::<L, Q>(query, start, [a, b, c], contact, 0) {
                return Err(w);
            }
            contact = Contact::Interior;
        }
        return Ok(WalkState {
            a,
            b,
            c,
            pa,
            pb,
            pc,
            link: start,
            t: start,
            steps: 0,
            entry_face: i,
            contact,
        });
    }
    let ps = names.map(|v| position(start, v));
    let vs = ps.map(|p| M::vertex(ray, p));
    let i = M::start_exit(ray, &vs, &ps);
    let f = OUTWARD_FACES[i];
    let (a, b, c) = (names[f[0]], names[f[1]], names[f[2]]);
    let (pa, pb, pc) = (vs[f[0]], vs[f[1]], vs[f[2]]);
    if O::ACTIVE {
        observer.exit([ps[f[0]], ps[f[1]], ps[f[2]]], true);
    }
    let (link, entry_face) = if L::INLINE {
        layout.inline_face(start, i)
    } else {
        (layout.link_opposite(start, start_tet[i], [a, b, c]), 0)
    };
    if M::CONTACTS && M::may_touch(ray, &pa, &pb, &pc) {
        let face = [ps[f[0]], ps[f[1]], ps[f[2]]];
        contact = M::contact(ray, &face, ps[i]);
        if let Some(w) = touch::<L, Q>(query, start, [a, b, c], contact, 1) {
            return Err(w);
        }
    }
    Ok(WalkState {
        a,
        b,
        c,
        pa,
        pb,
        pc,
        link,
        t: start,
        steps: 1,
        entry_face,
        contact,
    })
}

/// One step of the walk when it is plain: the next tet is not across a constrained face or
/// the boundary, the step guard is far, and [`ExitMethod::step_plain`] decides the exit from
/// the vertex data (for methods with contacts: no touch at the new exit face). Then `state`
/// moves on exactly as [`walk_resume`]'s loop would move it, and true; else false, with
/// `state` unchanged, for the loop to take that step. Id layouts only.
#[inline(always)]
pub fn plain_step<R: Real, L: Layout, M: ExitMethod<R>>(
    setup: &WalkSetup<R, L>,
    ray: &M::Ray,
    st: &mut WalkState<M::Vert>,
) -> bool {
    debug_assert!(!L::INLINE);
    if st.link & CONSTRAINED_BIT != 0 || st.steps >= setup.max_steps {
        return false;
    }
    let t = st.link;
    let d = setup.layout.new_vertex(t, st.a, st.b, st.c);
    let pd = M::vertex(ray, position(setup.layout, setup.points, t, d));
    let Some(exit) = M::step_plain(ray, &st.pa, &st.pb, &st.pc, &pd) else {
        return false;
    };
    let opposite = match exit {
        Exit::Abd => {
            let o = st.c;
            (st.c, st.pc) = (d, pd);
            o
        }
        Exit::Bcd => {
            let o = st.a;
            (st.a, st.pa, st.b, st.pb, st.c, st.pc) = (st.b, st.pb, st.c, st.pc, d, pd);
            o
        }
        Exit::Cad => {
            let o = st.b;
            (st.a, st.pa, st.b, st.pb, st.c, st.pc) = (st.c, st.pc, st.a, st.pa, d, pd);
            o
        }
    };
    st.t = t;
    st.steps += 1;
    st.contact = Contact::Interior;
    st.link = setup.layout.link_opposite(t, opposite, [st.a, st.b, st.c]);
    setup.layout.prefetch(st.link);
    true
}

/// The walk's loop from `state` on (see [`walk_with`]).
#[inline]
pub fn walk_resume<R: Real, L: Layout, M: ExitMethod<R>, Q: Query, O: WalkObserver<R>>(
    setup: &WalkSetup<R, L>,
    ray: &M::Ray,
    state: WalkState<M::Vert>,
    query: &mut Q,
    observer: &mut O,
) -> Walk {
    let (layout, points, max_steps) = (setup.layout, setup.points, setup.max_steps);
    let position = |t: u32, v: u32| position(layout, points, t, v);
    let WalkState {
        mut a,
        mut b,
        mut c,
        mut pa,
        mut pb,
        mut pc,
        mut link,
        mut t,
        mut steps,
        mut entry_face,
        mut contact,
    } = state;
    loop {
        if link & CONSTRAINED_BIT != 0 {
            let end = if link == BOUNDARY {
                Some(WalkEnd::Boundary)
            } else {
                let constrained = link & !CONSTRAINED_BIT;
                let at = Crossing {
                    constrained,
                    tet: t,
                    face: [a, b, c],
                    slots: L::INLINE,
                    contact,
                };
                match query.crossed(&at) {
                    Decision::Stop => Some(WalkEnd::Hit { constrained }),
                    // Walk on into the tet beyond; the entry face (and for INLINE layouts its
                    // index there, which `inline_face` gave with the link) stays as it is.
                    Decision::Continue => match setup.sides[constrained as usize].beyond {
                        BOUNDARY => Some(WalkEnd::Boundary),
                        beyond => {
                            link = beyond;
                            None
                        }
                    },
                }
            };
            if let Some(end) = end {
                return Walk {
                    end,
                    tet: t,
                    face: [a, b, c],
                    slots: L::INLINE,
                    steps,
                };
            }
        }
        if steps >= max_steps {
            return Walk {
                end: WalkEnd::StepLimit,
                tet: t,
                face: [a, b, c],
                slots: L::INLINE,
                steps,
            };
        }
        t = link;
        steps += 1;
        let d = if L::INLINE {
            // Names are local to each tet: rename the entry face in this one and recompute
            // its vertices' data from the record.
            let f = OUTWARD_FACES[entry_face];
            (a, b, c) = (f[0] as u32, f[2] as u32, f[1] as u32);
            let v = layout.inline_vertices(t);
            (pa, pb, pc) = (
                M::vertex(ray, v[f[0]].map(widen)),
                M::vertex(ray, v[f[2]].map(widen)),
                M::vertex(ray, v[f[1]].map(widen)),
            );
            entry_face as u32
        } else {
            layout.new_vertex(t, a, b, c)
        };
        let pd = M::vertex(ray, position(t, d));
        let exit = match M::step(ray, &pa, &pb, &pc, &pd) {
            Some(e) => e,
            // Cold: the filter of a robust method was uncertain. Names are ids, or slots of
            // tet t for INLINE layouts, so `position` finds the four vertices either way.
            None => M::step_exact(
                ray,
                &[
                    position(t, a),
                    position(t, b),
                    position(t, c),
                    position(t, d),
                ],
            ),
        };
        let found = O::ACTIVE && M::exit_found(ray, &pa, &pb, &pc, &pd);
        let opposite = match exit {
            Exit::Abd => {
                let o = c;
                (c, pc) = (d, pd);
                o
            }
            Exit::Bcd => {
                let o = a;
                (a, pa, b, pb, c, pc) = (b, pb, c, pc, d, pd);
                o
            }
            Exit::Cad => {
                let o = b;
                (a, pa, b, pb, c, pc) = (c, pc, a, pa, d, pd);
                o
            }
        };
        if O::ACTIVE {
            observer.exit([position(t, a), position(t, b), position(t, c)], found);
        }
        if M::CONTACTS {
            contact = Contact::Interior;
            if M::may_touch(ray, &pa, &pb, &pc) {
                let face = [position(t, a), position(t, b), position(t, c)];
                contact = M::contact(ray, &face, position(t, opposite));
                if let Some(w) = touch::<L, Q>(query, t, [a, b, c], contact, steps) {
                    return w;
                }
            }
        }
        if L::INLINE {
            (link, entry_face) = layout.inline_face(t, opposite as usize);
        } else {
            link = layout.link_opposite(t, opposite, [a, b, c]);
        }
    }
}
