//! Lagae & Dutré 2008, "half space classification": the exit face is found by classifying the
//! ray direction against the normals of three planes, each through three points: the ray's
//! entry point p, the vertex d opposite the entry face, and one of the entry face's vertices
//! k ∈ {a, b, c}. The three planes all contain the line p–d and cut the tet into three wedges,
//! one per candidate exit face; the face (x, y, d) is the exit iff u is on the positive side of
//! the plane through x and on the negative side of the one through y. (In 2D the same idea is
//! a single line from the entry point to the opposite vertex.)
//!
//! The entry point is where the ray crosses the entry face's plane. The walk carries no point
//! from tet to tet, so it is computed at the start of each step from (a, b, c): this is the
//! same one ray/plane intersection per tet that an implementation carrying the exit point to
//! the next tet does, just done on arrival.
//!
//! Cost per step: entry point (normal 15, n·(a − o) 8, n·u 5, one division, p = o + t u 6 =
//! 34 ops + 1 division), d − p (3), three classifications u·((d − p) × (k − p)) at 17 each
//! (51): 88 operations and one division, plus the decision. The start tet has no entry point;
//! the origin (inside it) plays that role, and u is classified against the six planes through
//! the origin and each edge, faces tested as in the ray–tet test.
//!
//! Precision: plain R arithmetic on world coordinates. Since p lies on the ray,
//! u·((d − p) × (k − p)) has the sign of the ray's Plücker side product with the edge d→k, but
//! p is recomputed in every tet (with its rounding), so two tets sharing an edge need not agree
//! on the side the ray passes it: no consistency across tets.

use super::lagae2008_plane::div;
use super::lagae2008_plucker::{cross, exit_by_face_tests, found3, min2, pick3};
use super::{Exit, ExitMethod};
use crate::geom::real::{dot3, sub3, Real, V3};

pub struct Lagae2008Halfspace;

#[derive(Clone, Copy, Debug)]
pub struct HalfspaceRay<R> {
    pub o: V3<R>,
    pub u: V3<R>,
}

impl<R: Real> ExitMethod<R> for Lagae2008Halfspace {
    const NAME: &'static str = "lagae2008_halfspace";
    type Ray = HalfspaceRay<R>;
    /// World position.
    type Vert = V3<R>;

    fn prepare(origin: V3<f64>, dir: V3<f64>, _domain: &[V3<f64>; 2]) -> Self::Ray {
        HalfspaceRay {
            o: origin.map(R::from_f64),
            u: dir.map(R::from_f64),
        }
    }

    #[inline(always)]
    fn vertex(_ray: &Self::Ray, p: V3<R>) -> V3<R> {
        p
    }

    fn start_exit(ray: &Self::Ray, v: &[V3<R>; 4], _p: &[V3<R>; 4]) -> usize {
        // Planes through the origin and the edge i–j: u against (v_i − o) × (v_j − o).
        let w = v.map(|p| sub3(p, ray.o));
        exit_by_face_tests(|i, j| dot3(ray.u, cross(w[i], w[j])))
    }

    #[inline(always)]
    fn step(ray: &Self::Ray, a: &V3<R>, b: &V3<R>, c: &V3<R>, d: &V3<R>) -> Option<Exit> {
        Some(pick3(face_margins(ray, a, b, c, d)))
    }

    fn exit_found(ray: &Self::Ray, a: &V3<R>, b: &V3<R>, c: &V3<R>, d: &V3<R>) -> bool {
        found3(face_margins(ray, a, b, c, d))
    }
}

/// The least margin of each candidate face's tests, (a,b,d), (b,c,d), (c,a,d).
#[inline(always)]
fn face_margins<R: Real>(
    ray: &HalfspaceRay<R>,
    a: &V3<R>,
    b: &V3<R>,
    c: &V3<R>,
    d: &V3<R>,
) -> [R; 3] {
    let u = ray.u;
    // Entry point: the ray meets the entry face's plane at o + t u.
    let n = cross(sub3(*b, *a), sub3(*c, *a));
    let t = div(dot3(n, sub3(*a, ray.o)), dot3(n, u));
    let p = [
        ray.o[0] + t * u[0],
        ray.o[1] + t * u[1],
        ray.o[2] + t * u[2],
    ];
    // Classify u against the plane through p, d and k (normal (d − p) × (k − p)).
    let dp = sub3(*d, p);
    let xa = dot3(u, cross(dp, sub3(*a, p)));
    let xb = dot3(u, cross(dp, sub3(*b, p)));
    let xc = dot3(u, cross(dp, sub3(*c, p)));
    // (a,b,d) iff xa ≥ 0 ≥ xb, (b,c,d) iff xb ≥ 0 ≥ xc, (c,a,d) iff xc ≥ 0 ≥ xa. Some face
    // passes unless all three signs agree, which only rounding (of p above all) can cause.
    [min2(xa, -xb), min2(xb, -xc), min2(xc, -xa)]
}
