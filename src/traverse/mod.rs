//! The walk from tet to tet, written once. An [`ExitMethod`] decides which face a ray leaves a
//! tet by; a [`Layout`] says what lies across it. Every method here works on the same
//! invariant: the ray enters the current tet through face (a, b, c), ordered so that seen along
//! the ray it turns counter-clockwise around the ray; the new vertex d then makes three
//! candidate exit faces (a,b,d), (b,c,d), (c,a,d), each already in that order for the next tet.

pub mod aman2022;
pub mod lagae2008_halfspace;
pub mod lagae2008_plane;
pub mod lagae2008_plucker;
pub mod lagae2008_stp;
pub mod maria2017;
pub mod ms06;
pub mod robust;

use crate::layout::Layout;
use crate::mesh::build::{CONSTRAINED_BIT, OUTWARD_FACES};
use crate::mesh::BOUNDARY;
use crate::real::{Real, V3};

pub use aman2022::Aman2022;
pub use lagae2008_halfspace::Lagae2008Halfspace;
pub use lagae2008_plane::Lagae2008Plane;
pub use lagae2008_plucker::Lagae2008Plucker;
pub use lagae2008_stp::Lagae2008Stp;
pub use maria2017::Maria2017;
pub use ms06::Ms06;
pub use robust::Robust;

/// Which of the three candidate faces a ray leaves by (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Exit {
    /// (a, b, d): the face opposite c.
    Abd,
    /// (b, c, d): the face opposite a.
    Bcd,
    /// (c, a, d): the face opposite b.
    Cad,
}

pub trait ExitMethod<R: Real> {
    const NAME: &'static str;
    /// The walk follows a symbolically perturbed line starting at s + εδ (the robust walk):
    /// the start tet must be the one holding that point (`robust::settle_start`).
    const PERTURBED_START: bool = false;
    /// Per-ray data computed once (e.g. a basis).
    type Ray: Copy;
    /// Per-vertex data computed once per fetched vertex (e.g. its 2D projection).
    type Vert: Copy;

    /// `origin` is the point the walk starts from (inside the start tet); `dir` need not be
    /// normalized; `domain` is the box ([min, max]) holding every vertex the walk will read,
    /// which methods with error bounds (the robust walk) use to bound their rounding.
    fn prepare(origin: V3<f64>, dir: V3<f64>, domain: &[V3<f64>; 2]) -> Self::Ray;
    fn vertex(ray: &Self::Ray, p: V3<R>) -> Self::Vert;
    /// The face (index i of OUTWARD_FACES, opposite vertex i) by which the ray leaves the start
    /// tet, whose four vertices (data `v`, positions `p`) are given in positive orientation.
    fn start_exit(ray: &Self::Ray, v: &[Self::Vert; 4], p: &[V3<R>; 4]) -> usize;
    /// The exit face of a tet entered through (a, b, c) whose fourth vertex is d, or None
    /// when the vertex data cannot decide it (a filter found the float result uncertain): the
    /// walk then reads the positions and calls [`ExitMethod::step_exact`].
    fn step(
        ray: &Self::Ray,
        a: &Self::Vert,
        b: &Self::Vert,
        c: &Self::Vert,
        d: &Self::Vert,
    ) -> Option<Exit>;
    /// The exit face from the positions of a, b, c, d. Only methods whose `step` can return
    /// None need to provide it; for the others it is `step` on the same data.
    fn step_exact(ray: &Self::Ray, p: &[V3<R>; 4]) -> Exit {
        let v = p.map(|x| Self::vertex(ray, x));
        Self::step(ray, &v[0], &v[1], &v[2], &v[3]).unwrap_or(Exit::Bcd)
    }
    /// Whether the method's own tests named the face `step` returns, rather than a fallback
    /// choosing one when rounding made every test fail ("no exit face found"). Decision-tree
    /// methods always name one. Only the audit asks.
    fn exit_found(
        _ray: &Self::Ray,
        _a: &Self::Vert,
        _b: &Self::Vert,
        _c: &Self::Vert,
        _d: &Self::Vert,
    ) -> bool {
        true
    }
}

/// The full decision for one step, as the walk makes it: `step`, else `step_exact`.
#[inline(always)]
pub fn decide<R: Real, M: ExitMethod<R>>(ray: &M::Ray, p: &[V3<R>; 4]) -> Exit {
    let v = p.map(|x| M::vertex(ray, x));
    M::step(ray, &v[0], &v[1], &v[2], &v[3]).unwrap_or_else(|| M::step_exact(ray, p))
}

/// Sees each exit face a walk takes (the audit of `tetrace.stress`); the walk's hot loop calls
/// it only when `ACTIVE`, so the plain walk compiles as if it did not exist.
pub trait WalkObserver<R: Real> {
    const ACTIVE: bool;
    /// The face the walk leaves a tet by, counter-clockwise around the ray, and whether the
    /// method's tests found it (see [`ExitMethod::exit_found`]).
    fn exit(&mut self, face: [V3<R>; 3], found: bool);
}

/// The plain walk's observer: nothing.
pub struct NoObserver;

impl<R: Real> WalkObserver<R> for NoObserver {
    const ACTIVE: bool = false;
    #[inline(always)]
    fn exit(&mut self, _face: [V3<R>; 3], _found: bool) {}
}

/// How a walk ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WalkEnd {
    /// Crossed a constrained face: index into the constrained table.
    Hit { constrained: u32 },
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

/// Walks from `start` (whose vertex ids are `start_tet`, positively oriented) until a
/// constrained face, the domain boundary or `max_steps`. With `entry = Some(i)` the ray comes
/// from outside through the tet's face i (opposite vertex i), which saves finding it.
///
/// Id layouts carry the entry face's vertex ids and their per-vertex data from tet to tet,
/// fetching one new vertex per step; INLINE layouts (Tet80) carry the entry face's local index
/// and read all four vertices from the record, as Maria et al. do. `a`, `b`, `c`, `d` hold
/// ids in the first case and local slots in the second.
#[inline]
pub fn walk<R: Real, L: Layout, M: ExitMethod<R>>(
    layout: &L,
    points: &[[R; 3]],
    ray: &M::Ray,
    start: u32,
    start_tet: [u32; 4],
    entry: Option<usize>,
    max_steps: u32,
) -> Walk {
    walk_observed::<R, L, M, NoObserver>(
        layout,
        points,
        ray,
        start,
        start_tet,
        entry,
        max_steps,
        &mut NoObserver,
    )
}

/// [`walk`], showing `observer` every exit face.
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn walk_observed<R: Real, L: Layout, M: ExitMethod<R>, O: WalkObserver<R>>(
    layout: &L,
    points: &[[R; 3]],
    ray: &M::Ray,
    start: u32,
    start_tet: [u32; 4],
    entry: Option<usize>,
    max_steps: u32,
    observer: &mut O,
) -> Walk {
    let position = |t: u32, v: u32| -> V3<R> {
        if L::INLINE {
            layout.inline_vertices(t)[v as usize].map(R::from_f32)
        } else {
            debug_assert!((v as usize) < points.len());
            // SAFETY: v is a vertex id of a validated tet (ids, and xors of ids, were checked
            // against the point count at build), so it indexes `points`.
            unsafe { *points.get_unchecked(v as usize) }
        }
    };
    // Vertex names in the start tet: ids, or slots 0..4 for INLINE layouts.
    let names = if L::INLINE { [0, 1, 2, 3] } else { start_tet };
    let (mut a, mut b, mut c, mut pa, mut pb, mut pc, mut link, mut t, mut steps);
    // INLINE layouts: the entered tet's face by which the walk came in.
    let mut entry_face = 0usize;
    if let Some(i) = entry {
        // Entering through face i: reversed from its outward order it turns counter-clockwise
        // around the ray, as the loop expects of an entry face.
        let f = OUTWARD_FACES[i];
        (a, b, c) = (names[f[0]], names[f[2]], names[f[1]]);
        (pa, pb, pc) = (
            M::vertex(ray, position(start, a)),
            M::vertex(ray, position(start, b)),
            M::vertex(ray, position(start, c)),
        );
        (link, t, steps, entry_face) = (start, start, 0u32, i);
    } else {
        let ps = names.map(|v| position(start, v));
        let vs = ps.map(|p| M::vertex(ray, p));
        let i = M::start_exit(ray, &vs, &ps);
        let f = OUTWARD_FACES[i];
        (a, b, c) = (names[f[0]], names[f[1]], names[f[2]]);
        (pa, pb, pc) = (vs[f[0]], vs[f[1]], vs[f[2]]);
        if O::ACTIVE {
            observer.exit([ps[f[0]], ps[f[1]], ps[f[2]]], true);
        }
        if L::INLINE {
            (link, entry_face) = layout.inline_face(start, i);
        } else {
            link = layout.link_opposite(start, start_tet[i], [a, b, c]);
        }
        (t, steps) = (start, 1u32);
    }
    loop {
        if link & CONSTRAINED_BIT != 0 {
            let end = if link == BOUNDARY {
                WalkEnd::Boundary
            } else {
                WalkEnd::Hit {
                    constrained: link & !CONSTRAINED_BIT,
                }
            };
            return Walk {
                end,
                tet: t,
                face: [a, b, c],
                slots: L::INLINE,
                steps,
            };
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
                M::vertex(ray, v[f[0]].map(R::from_f32)),
                M::vertex(ray, v[f[2]].map(R::from_f32)),
                M::vertex(ray, v[f[1]].map(R::from_f32)),
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
        if L::INLINE {
            (link, entry_face) = layout.inline_face(t, opposite as usize);
        } else {
            link = layout.link_opposite(t, opposite, [a, b, c]);
        }
    }
}

#[cfg(test)]
pub(crate) mod tests;
