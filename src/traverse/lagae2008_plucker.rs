//! Lagae & Dutré 2008, "Plücker coordinates": the ray is the Plücker line {u : v} (direction u,
//! moment v = o × u) and each edge p→q of the tet the line {q − p : p × q}, both in world
//! coordinates. The sign of the permuted inner product (side product) u·(p × q) + v·(q − p)
//! says on which side of the edge the ray passes; a ray leaves by a face iff it turns the same
//! way (here: counter-clockwise seen along the ray, side ≥ 0) around its three outward-ordered
//! edges. A ray–tet test is four ray–triangle tests (12 products), of which 6 are negations of
//! the other 6 (Platis & Theoharis 2003), so each tet costs all **six** side products, the entry
//! face's three included: Lagae does not exploit the entry face, and neither does this code
//! (it only skips testing the entry face itself).
//!
//! Cost per step: 6 side products × 23 operations (edge direction 3, moment 9, product 11) =
//! 138 operations, plus the sign tests. The start tet uses the same six.
//!
//! Precision: everything runs in R on world coordinates, moment included: u·(p×q) and v·(q−p)
//! are each of size |u||p||q| and cancel down to |u| × (distance ray–edge) × |q − p|, so
//! in float32 the relative error of a product grows with the distance of the scene from the
//! world origin — the fragility Maria et al. (Table 4) measured. The one consistency this
//! formula does keep: side(q→p) is the exact IEEE negation of side(p→q) (no FMA is emitted),
//! so tets sharing an edge agree on its sign.
//!
//! The helpers at the end (cross product, the ray–tet face test for the start tet, the pick of
//! a face from three "worst signs") are shared with the other Lagae methods and MS06.

use super::{Exit, ExitMethod};
use crate::geom::real::{dot3, sub3, Real, V3};
use crate::mesh::build::OUTWARD_FACES;

pub struct Lagae2008Plucker;

/// A ray in Plücker coordinates, in precision R.
#[derive(Clone, Copy, Debug)]
pub struct PluckerRay<R> {
    /// Direction (not normalized).
    pub u: V3<R>,
    /// Moment o × u, computed in R from the rounded o and u, as an R implementation would.
    pub v: V3<R>,
}

impl<R: Real> PluckerRay<R> {
    pub fn new(origin: V3<f64>, dir: V3<f64>) -> Self {
        let o = origin.map(R::from_f64);
        let u = dir.map(R::from_f64);
        PluckerRay { u, v: cross(o, u) }
    }
}

#[inline(always)]
pub(super) fn cross<R: Real>(a: V3<R>, b: V3<R>) -> V3<R> {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Side product of the ray with the edge line p→q, from world coordinates (23 operations).
/// Positive: the ray turns counter-clockwise around p→q seen along the ray, i.e. it has the
/// sign of det(p − o, q − o, u). Swapping p and q negates it exactly.
#[inline(always)]
pub(super) fn side_world<R: Real>(ray: &PluckerRay<R>, p: V3<R>, q: V3<R>) -> R {
    dot3(ray.u, cross(p, q)) + dot3(ray.v, sub3(q, p))
}

#[inline(always)]
pub(super) fn min2<R: Real>(x: R, y: R) -> R {
    if y < x {
        y
    } else {
        x
    }
}

#[inline(always)]
pub(super) fn min3<R: Real>(x: R, y: R, z: R) -> R {
    min2(min2(x, y), z)
}

/// The exit among (a,b,d), (b,c,d), (c,a,d) given, for each, the smallest of the signed tests
/// that must all be ≥ 0 for the ray to leave by it. The first passing face wins (ties on an
/// edge are settled by this fixed order); if rounding made every face fail, the one failing
/// by the least, so the walk always goes on deterministically (the papers' methods would report
/// "no face"; NaN keeps the first).
#[inline(always)]
/// Whether some face passed its tests (see [`pick3`]).
pub(super) fn found3<R: Real>(m: [R; 3]) -> bool {
    m.iter().any(|&x| x >= R::ZERO)
}

/// The least margin of each candidate face's three edge tests, (a,b,d), (b,c,d), (c,a,d).
#[inline(always)]
fn face_margins<R: Real>(
    ray: &PluckerRay<R>,
    a: &V3<R>,
    b: &V3<R>,
    c: &V3<R>,
    d: &V3<R>,
) -> [R; 3] {
    // The six edges of the tet, recomputed here even for the entry face (Lagae does not
    // carry them from the previous tet).
    let ab = side_world(ray, *a, *b);
    let bc = side_world(ray, *b, *c);
    let ca = side_world(ray, *c, *a);
    let ad = side_world(ray, *a, *d);
    let bd = side_world(ray, *b, *d);
    let cd = side_world(ray, *c, *d);
    // Face (x, y, d) is left iff s(x→y), s(y→d), s(d→x) ≥ 0; s(d→x) = −s(x→d) exactly.
    [min3(ab, bd, -ad), min3(bc, cd, -bd), min3(ca, ad, -cd)]
}

pub(super) fn pick3<R: Real>(m: [R; 3]) -> Exit {
    const EXITS: [Exit; 3] = [Exit::Abd, Exit::Bcd, Exit::Cad];
    let z = R::ZERO;
    if m[0] >= z {
        Exit::Abd
    } else if m[1] >= z {
        Exit::Bcd
    } else if m[2] >= z {
        Exit::Cad
    } else {
        let mut k = 0;
        if m[1] > m[k] {
            k = 1;
        }
        if m[2] > m[k] {
            k = 2;
        }
        EXITS[k]
    }
}

/// Index 0..6 of the edge {lo, hi} (lo < hi) of a tet with vertices 0..4.
#[inline(always)]
fn edge_index(lo: usize, hi: usize) -> usize {
    if lo == 0 {
        hi - 1
    } else {
        lo + hi
    }
}

/// The exit face of a start tet (vertices 0..4, positively oriented) by ray–triangle tests on its
/// faces in OUTWARD_FACES order, as in Platis & Theoharis's ray–tet test: face f is left iff
/// `side(i, j) ≥ 0` on its three outward-ordered edges i→j. `side` is asked only for i < j,
/// lazily and at most once per edge (a reversed edge is the exact negation), so a test stops at
/// the first negative sign. If rounding leaves no face with three non-negative signs, the face
/// whose worst sign is least negative.
pub(super) fn exit_by_face_tests<R: Real>(mut side: impl FnMut(usize, usize) -> R) -> usize {
    let mut cache = [None::<R>; 6];
    let mut s = |i: usize, j: usize| -> R {
        let (lo, hi) = if i < j { (i, j) } else { (j, i) };
        let k = edge_index(lo, hi);
        let x = match cache[k] {
            Some(x) => x,
            None => {
                let x = side(lo, hi);
                cache[k] = Some(x);
                x
            }
        };
        if i < j {
            x
        } else {
            -x
        }
    };
    let z = R::ZERO;
    for (f, g) in OUTWARD_FACES.iter().enumerate() {
        if s(g[0], g[1]) >= z && s(g[1], g[2]) >= z && s(g[2], g[0]) >= z {
            return f;
        }
    }
    let mut best = (0usize, None::<R>);
    for (f, g) in OUTWARD_FACES.iter().enumerate() {
        let m = min3(s(g[0], g[1]), s(g[1], g[2]), s(g[2], g[0]));
        if best.1.is_none_or(|b| m > b) {
            best = (f, Some(m));
        }
    }
    best.0
}

impl<R: Real> ExitMethod<R> for Lagae2008Plucker {
    const NAME: &'static str = "lagae2008_plucker";
    type Ray = PluckerRay<R>;
    /// World position: the edges' Plücker coordinates are built from it in every tet.
    type Vert = V3<R>;

    fn prepare(origin: V3<f64>, dir: V3<f64>, _domain: &[V3<f64>; 2]) -> Self::Ray {
        PluckerRay::new(origin, dir)
    }

    #[inline(always)]
    fn vertex(_ray: &Self::Ray, p: V3<R>) -> V3<R> {
        p
    }

    fn start_exit(ray: &Self::Ray, v: &[V3<R>; 4], _p: &[V3<R>; 4]) -> usize {
        // All six permuted inner products up front, as Lagae does, then the four face tests.
        let mut t = [R::ZERO; 6];
        for lo in 0..4 {
            for hi in lo + 1..4 {
                t[edge_index(lo, hi)] = side_world(ray, v[lo], v[hi]);
            }
        }
        exit_by_face_tests(|i, j| t[edge_index(i, j)])
    }

    #[inline(always)]
    fn step(ray: &Self::Ray, a: &V3<R>, b: &V3<R>, c: &V3<R>, d: &V3<R>) -> Option<Exit> {
        Some(pick3(face_margins(ray, a, b, c, d)))
    }

    fn exit_found(ray: &Self::Ray, a: &V3<R>, b: &V3<R>, c: &V3<R>, d: &V3<R>) -> bool {
        found3(face_margins(ray, a, b, c, d))
    }
}
