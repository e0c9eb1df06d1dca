//! Lagae & Dutré 2008, "plane intersections" (as Garrity 1990): the planes of the tet's faces
//! cut the ray's line at parameters t = n·(p − o) / (n·u); the ray leaves by the face with the
//! smallest such t among the faces it leaves through (outward normal n with n·u > 0). For a
//! convex cell that is "the smallest parameter larger than the entry face's", without having
//! to know the entry parameter. In the start tet, with o inside, it is the paper's "smallest
//! positive parameter"; the n·u > 0 filter also copes with o lying on the tet's boundary (a
//! ray clipped to the domain box), where the entry face's t is 0 give or take rounding.
//!
//! Cost per step: only the three candidate exit planes are intersected. Edges from d (9 ops),
//! three outward normals (27), d − o (3), per plane n·u and n·(d − o) (2 × 5) and one
//! division: 69 operations and 3 divisions, then 2 comparisons of t. The start tet does the
//! same for all four faces.
//!
//! Precision: plain R arithmetic on world coordinates (the normals from vertex differences, the
//! ray origin rounded to R). Near an edge the two adjacent faces' t are nearly equal and their
//! rounding errors decide between them; nothing ties a face's decision in one tet to the same
//! face's in the next, which is why this method loses rays in float32 (Maria et al., Table 4).

use super::lagae2008_plucker::cross;
use super::{Exit, ExitMethod};
use crate::geom::real::{dot3, sub3, Real, V3};
use crate::mesh::build::OUTWARD_FACES;

pub struct Lagae2008Plane;

#[derive(Clone, Copy, Debug)]
pub struct PlaneRay<R> {
    pub o: V3<R>,
    pub u: V3<R>,
}

/// a / b in R.
#[inline(always)]
pub(super) fn div<R: Real>(a: R, b: R) -> R {
    a / b
}

/// Among planes (normal n, point w − o relative to the origin), the one of smallest t with
/// n·u > 0; ties keep the earlier. If rounding leaves none facing along the ray, the one with
/// the largest n·u (deterministic; the paper's method would find no face).
#[inline(always)]
fn nearest_ahead<R: Real, const N: usize>(u: V3<R>, planes: [(V3<R>, V3<R>); N]) -> (usize, bool) {
    let z = R::ZERO;
    let mut best: Option<(usize, R)> = None;
    let mut steepest = (0usize, None::<R>);
    for (k, (n, w)) in planes.into_iter().enumerate() {
        let den = dot3(n, u);
        if den > z {
            let t = div(dot3(n, w), den);
            if best.is_none_or(|(_, bt)| t < bt) {
                best = Some((k, t));
            }
        }
        if steepest.1.is_none_or(|s| den > s) {
            steepest = (k, Some(den));
        }
    }
    match best {
        Some((k, _)) => (k, true),
        None => (steepest.0, false),
    }
}

impl<R: Real> ExitMethod<R> for Lagae2008Plane {
    const NAME: &'static str = "lagae2008_plane";
    type Ray = PlaneRay<R>;
    /// World position.
    type Vert = V3<R>;

    fn prepare(origin: V3<f64>, dir: V3<f64>, _domain: &[V3<f64>; 2]) -> Self::Ray {
        PlaneRay {
            o: origin.map(R::from_f64),
            u: dir.map(R::from_f64),
        }
    }

    #[inline(always)]
    fn vertex(_ray: &Self::Ray, p: V3<R>) -> V3<R> {
        p
    }

    fn start_exit(ray: &Self::Ray, v: &[V3<R>; 4], _p: &[V3<R>; 4]) -> usize {
        let planes = OUTWARD_FACES.map(|f| {
            let n = cross(sub3(v[f[1]], v[f[0]]), sub3(v[f[2]], v[f[0]]));
            (n, sub3(v[f[0]], ray.o))
        });
        nearest_ahead(ray.u, planes).0
    }

    #[inline(always)]
    fn step(ray: &Self::Ray, a: &V3<R>, b: &V3<R>, c: &V3<R>, d: &V3<R>) -> Option<Exit> {
        Some([Exit::Abd, Exit::Bcd, Exit::Cad][candidate_exit(ray, a, b, c, d).0])
    }

    fn exit_found(ray: &Self::Ray, a: &V3<R>, b: &V3<R>, c: &V3<R>, d: &V3<R>) -> bool {
        candidate_exit(ray, a, b, c, d).1
    }
}

/// The nearest of the three candidate planes ahead, and whether any faced along the ray.
#[inline(always)]
fn candidate_exit<R: Real>(
    ray: &PlaneRay<R>,
    a: &V3<R>,
    b: &V3<R>,
    c: &V3<R>,
    d: &V3<R>,
) -> (usize, bool) {
    // The three candidate planes all pass through d; (x − d) × (y − d) is the outward
    // normal of (x, y, d) since the faces come in outward (counter-clockwise) order.
    let (ea, eb, ec) = (sub3(*a, *d), sub3(*b, *d), sub3(*c, *d));
    let w = sub3(*d, ray.o);
    let planes = [(cross(ea, eb), w), (cross(eb, ec), w), (cross(ec, ea), w)];
    nearest_ahead(ray.u, planes)
}
