//! The walk from tet to tet, written once. An [`ExitMethod`] decides which face a ray leaves a
//! tet by; a [`Layout`] says what lies across it. Every method here works on the same
//! invariant: the ray enters the current tet through face (a, b, c), ordered so that seen along
//! the ray it turns counter-clockwise around the ray; the new vertex d then makes three
//! candidate exit faces (a,b,d), (b,c,d), (c,a,d), each already in that order for the next tet.

pub mod aman2022;

use crate::layout::Layout;
use crate::mesh::build::{CONSTRAINED_BIT, OUTWARD_FACES};
use crate::mesh::BOUNDARY;
use crate::real::{Real, V3};

pub use aman2022::Aman2022;

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
    /// Per-ray data computed once (e.g. a basis).
    type Ray: Copy;
    /// Per-vertex data computed once per fetched vertex (e.g. its 2D projection).
    type Vert: Copy;

    /// `origin` is the point the walk starts from (inside the start tet); `dir` need not be
    /// normalized.
    fn prepare(origin: V3<f64>, dir: V3<f64>) -> Self::Ray;
    fn vertex(ray: &Self::Ray, p: V3<R>) -> Self::Vert;
    /// The face (index i of OUTWARD_FACES, opposite vertex i) by which the ray leaves the start
    /// tet, whose four vertices are given in positive orientation.
    fn start_exit(ray: &Self::Ray, v: &[Self::Vert; 4]) -> usize;
    /// The exit face of a tet entered through (a, b, c) whose fourth vertex is d.
    fn step(ray: &Self::Ray, a: &Self::Vert, b: &Self::Vert, c: &Self::Vert, d: &Self::Vert) -> Exit;
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
    /// The face it left by (point ids, ordered counter-clockwise around the ray).
    pub face: [u32; 3],
    /// Tets visited, the start tet included.
    pub steps: u32,
}

/// Walks from `start` (whose vertex ids are `start_tet`, positively oriented) until a
/// constrained face, the domain boundary or `max_steps`. With `entry = Some(i)` the ray comes
/// from outside through the tet's face i (opposite vertex i), which saves finding it.
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
    let (mut a, mut b, mut c, mut pa, mut pb, mut pc, mut link, mut t, mut steps);
    if let Some(i) = entry {
        // Entering through face i: reversed from its outward order it turns counter-clockwise
        // around the ray, as the loop expects of an entry face.
        let f = OUTWARD_FACES[i];
        (a, b, c) = (start_tet[f[0]], start_tet[f[2]], start_tet[f[1]]);
        (pa, pb, pc) = (M::vertex(ray, points[a as usize]), M::vertex(ray, points[b as usize]), M::vertex(ray, points[c as usize]));
        (link, t, steps) = (start, start, 0u32);
    } else {
        let vs = start_tet.map(|v| M::vertex(ray, points[v as usize]));
        let i = M::start_exit(ray, &vs);
        let f = OUTWARD_FACES[i];
        (a, b, c) = (start_tet[f[0]], start_tet[f[1]], start_tet[f[2]]);
        (pa, pb, pc) = (vs[f[0]], vs[f[1]], vs[f[2]]);
        link = layout.link_opposite(start, start_tet[i], [a, b, c]);
        (t, steps) = (start, 1u32);
    }
    loop {
        if link & CONSTRAINED_BIT != 0 {
            let end = if link == BOUNDARY {
                WalkEnd::Boundary
            } else {
                WalkEnd::Hit { constrained: link & !CONSTRAINED_BIT }
            };
            return Walk { end, tet: t, face: [a, b, c], steps };
        }
        if steps >= max_steps {
            return Walk { end: WalkEnd::StepLimit, tet: t, face: [a, b, c], steps };
        }
        t = link;
        steps += 1;
        let d = layout.new_vertex(t, a, b, c);
        debug_assert!((d as usize) < points.len());
        // SAFETY: d is a vertex id of a validated tet (xor of ids checked against the point
        // count at build), so it indexes `points`.
        let pd = M::vertex(ray, unsafe { *points.get_unchecked(d as usize) });
        let opposite = match M::step(ray, &pa, &pb, &pc, &pd) {
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
        link = layout.link_opposite(t, opposite, [a, b, c]);
    }
}

#[cfg(test)]
mod tests;
