//! Aman, Demirci & Güdükbay 2022: project vertices into a 2D basis perpendicular to the ray
//! (Duff et al. 2017), where the ray is the origin; the exit face follows from the signs of 2D
//! determinants (Algorithm 1). Each new vertex is projected once and its two coordinates are
//! carried along while it stays on the entry face.
//!
//! Consistency: the determinant of two projected vertices is computed from the same bits
//! whichever tet asks, and `cross(p, q) == -cross(q, p)` exactly in IEEE arithmetic (no fused
//! multiply-add is emitted here), so two tets sharing an edge agree on which side of it the ray
//! passes. The 2D decision uses exactly two determinants per step, as Maria et al. 2017 do with
//! Plücker side products, to which these determinants are proportional.

use super::{Exit, ExitMethod};
use crate::geom::onb::onb;
use crate::geom::real::{sub3, Real, V3};
use crate::mesh::build::OUTWARD_FACES;

pub struct Aman2022;

#[derive(Clone, Copy, Debug)]
pub struct BasisRay<R> {
    pub origin: V3<R>,
    pub u: V3<R>,
    pub w: V3<R>,
}

#[inline(always)]
fn cross2<R: Real>(p: &[R; 2], q: &[R; 2]) -> R {
    p[0] * q[1] - p[1] * q[0]
}

impl<R: Real> ExitMethod<R> for Aman2022 {
    const NAME: &'static str = "aman2022";
    type Ray = BasisRay<R>;
    type Vert = [R; 2];

    fn prepare(origin: V3<f64>, dir: V3<f64>, _domain: &[V3<f64>; 2]) -> Self::Ray {
        let inv_len = 1.0 / (dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]).sqrt();
        let n = dir.map(|x| x * inv_len);
        let (u, w) = onb(n);
        BasisRay {
            origin: origin.map(R::from_f64),
            u: u.map(R::from_f64),
            w: w.map(R::from_f64),
        }
    }

    #[inline(always)]
    fn vertex(ray: &Self::Ray, p: V3<R>) -> [R; 2] {
        // Translate first: coordinates near the ray keep their precision far from the origin.
        let q = sub3(p, ray.origin);
        [
            q[0] * ray.u[0] + q[1] * ray.u[1] + q[2] * ray.u[2],
            q[0] * ray.w[0] + q[1] * ray.w[1] + q[2] * ray.w[2],
        ]
    }

    fn start_exit(_ray: &Self::Ray, v: &[[R; 2]; 4], _p: &[V3<R>; 4]) -> usize {
        // The exit face projects counter-clockwise around the ray (its outward normal is along
        // the ray). With rounding, the ray may seem to pass just outside every face when it
        // starts on the tet's boundary: take the face it misses by the least.
        let mut best = (0usize, None::<R>);
        for (i, f) in OUTWARD_FACES.iter().enumerate() {
            let (p, q, r) = (&v[f[0]], &v[f[1]], &v[f[2]]);
            let (x, y, z) = (cross2(p, q), cross2(q, r), cross2(r, p));
            let m = if x < y { x } else { y };
            let m = if m < z { m } else { z };
            if m >= R::ZERO {
                return i;
            }
            if best.1.is_none_or(|b| m > b) {
                best = (i, Some(m));
            }
        }
        best.0
    }

    #[inline(always)]
    fn step(_ray: &Self::Ray, a: &[R; 2], b: &[R; 2], c: &[R; 2], d: &[R; 2]) -> Option<Exit> {
        Some(if cross2(d, a) >= R::ZERO {
            if cross2(d, b) <= R::ZERO {
                Exit::Abd
            } else {
                Exit::Bcd
            }
        } else if cross2(d, c) >= R::ZERO {
            Exit::Cad
        } else {
            Exit::Bcd
        })
    }
}
