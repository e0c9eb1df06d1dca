//! Lagae & Dutré 2008, "scalar triple products" (the method their renderer uses): the sign of
//! the ray's side product with an edge p→q equals that of the scalar triple product
//! [u, P, Q] = u·(P × Q) with P = p − o, Q = q − o (vertices relative to the ray origin, as in
//! Platis & Theoharis's STP ray–tet test). The candidate exit faces are tested in turn, each
//! needing [u, X, Y] ≥ 0 on its three outward-ordered edges, stopping at the first negative
//! sign; a product once computed is reused, negated, by the next face that shares its edge.
//! The entry face itself is not tested, but its edges are not taken from the previous tet
//! either: "given the entry face, 3 to 6 scalar triple products".
//!
//! Cost per step: 3 products when the first face tested, (a,b,d), is the exit, up to all 6
//! otherwise (every edge of the tet once); each is a cross and a dot product, 14 operations
//! (42–84), plus 3 subtractions per fetched vertex to translate it. The count varies, so SIMD
//! lanes or GPU threads diverge. The start tet: the four faces tested in turn, 3–6 products.
//!
//! Precision: R arithmetic relative to the ray origin o (rounded to R), the vertices translated
//! once when fetched. [u, Q, P] is the exact IEEE negation of [u, P, Q] (u is the first factor,
//! the cross product is antisymmetric bit for bit), so tets sharing an edge agree on its sign;
//! the cost of accuracy is that |P|, |Q| grow with the distance from the ray origin.

use super::lagae2008_plucker::{cross, exit_by_face_tests, found3, min3, pick3};
use super::{Exit, ExitMethod};
use crate::geom::real::{dot3, sub3, Real, V3};

pub struct Lagae2008Stp;

#[derive(Clone, Copy, Debug)]
pub struct StpRay<R> {
    pub o: V3<R>,
    pub u: V3<R>,
}

/// [u, P, Q] = u · (P × Q): 14 operations.
#[inline(always)]
fn stp<R: Real>(u: V3<R>, p: &V3<R>, q: &V3<R>) -> R {
    dot3(u, cross(*p, *q))
}

impl<R: Real> ExitMethod<R> for Lagae2008Stp {
    const NAME: &'static str = "lagae2008_stp";
    type Ray = StpRay<R>;
    /// The vertex relative to the ray origin.
    type Vert = V3<R>;

    fn prepare(origin: V3<f64>, dir: V3<f64>, _domain: &[V3<f64>; 2]) -> Self::Ray {
        StpRay {
            o: origin.map(R::from_f64),
            u: dir.map(R::from_f64),
        }
    }

    #[inline(always)]
    fn vertex(ray: &Self::Ray, p: V3<R>) -> V3<R> {
        sub3(p, ray.o)
    }

    fn start_exit(ray: &Self::Ray, v: &[V3<R>; 4], _p: &[V3<R>; 4]) -> usize {
        exit_by_face_tests(|i, j| stp(ray.u, &v[i], &v[j]))
    }

    #[inline(always)]
    fn step(ray: &Self::Ray, a: &V3<R>, b: &V3<R>, c: &V3<R>, d: &V3<R>) -> Option<Exit> {
        let u = ray.u;
        let z = R::ZERO;
        // Each edge's product computed at most once, on first use; d→x is −[u, X, D].
        let (mut ab, mut bc, mut ca, mut ad, mut bd, mut cd) = (None, None, None, None, None, None);
        macro_rules! s {
            ($slot:ident, $p:expr, $q:expr) => {
                match $slot {
                    Some(x) => x,
                    None => {
                        let x = stp(u, $p, $q);
                        $slot = Some(x);
                        x
                    }
                }
            };
        }
        // (a,b,d): edges a→b, b→d, d→a.
        if s!(ab, a, b) >= z && s!(bd, b, d) >= z && -s!(ad, a, d) >= z {
            return Some(Exit::Abd);
        }
        // (b,c,d): edges b→c, c→d, d→b.
        if s!(bc, b, c) >= z && s!(cd, c, d) >= z && -s!(bd, b, d) >= z {
            return Some(Exit::Bcd);
        }
        // (c,a,d): edges c→a, a→d, d→c.
        if s!(ca, c, a) >= z && s!(ad, a, d) >= z && -s!(cd, c, d) >= z {
            return Some(Exit::Cad);
        }
        // Rounding made every test fail: the face failing by the least (all six products).
        let all = |slot: Option<R>, p, q| slot.unwrap_or_else(|| stp(u, p, q));
        let (ab, bc, ca) = (all(ab, a, b), all(bc, b, c), all(ca, c, a));
        let (ad, bd, cd) = (all(ad, a, d), all(bd, b, d), all(cd, c, d));
        Some(pick3([
            min3(ab, bd, -ad),
            min3(bc, cd, -bd),
            min3(ca, ad, -cd),
        ]))
    }

    fn exit_found(ray: &Self::Ray, a: &V3<R>, b: &V3<R>, c: &V3<R>, d: &V3<R>) -> bool {
        let s = |p, q| stp(ray.u, p, q);
        let (ab, bc, ca, ad, bd, cd) = (s(a, b), s(b, c), s(c, a), s(a, d), s(b, d), s(c, d));
        found3([min3(ab, bd, -ad), min3(bc, cd, -bd), min3(ca, ad, -cd)])
    }
}
