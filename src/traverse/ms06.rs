//! Marmitt & Slusallek 2006 ("MS06"), as Maria et al. 2017 describe it: Plücker side products
//! (Platis & Theoharis's ray–tet test) that use the entry face. The ray entered through
//! (a, b, c), so it already turns counter-clockwise around those edges; each candidate exit
//! face (x, y, d) then needs only its two edges through d: s(y→d) ≥ 0 and s(d→x) ≥ 0
//! (s = side product, ≥ 0 when the ray turns counter-clockwise around the edge). The faces
//! are tested in turn: (a,b,d) with two new side products, (b,c,d) with one more (d→b is
//! shared), and (c,a,d) is what is left. Exit (a,b,d) costs 2 products, (b,c,d) or (c,a,d)
//! 3: 2.67 on average when the three exits are equally likely, the figure Maria et al. quote,
//! and a data-dependent count (divergence on SIMD/GPU).
//!
//! Cost per step: 2 or 3 side products at 23 operations each (edge direction 3, moment 9,
//! product 11) in world coordinates: 46 or 69 operations, 61.3 on average. MS06 enters the mesh
//! from its boundary; for a start tet containing the origin this uses the ray–tet face test
//! (up to six products) that MS06 extends.
//!
//! Precision: R arithmetic in world coordinates, the same side product as Lagae's Plücker
//! method (see `lagae2008_plucker`): side(x→d) is the exact negation of side(d→x), so
//! neighbouring tets agree on an edge's sign, but the products cancel badly in float32 far from
//! the world origin. Because the entry face's signs are not recomputed, a tet cannot find
//! "no face"; the last face is taken by elimination.

use super::lagae2008_plucker::{exit_by_face_tests, side_world, PluckerRay};
use super::{Exit, ExitMethod};
use crate::geom::real::{Real, V3};

pub struct Ms06;

impl<R: Real> ExitMethod<R> for Ms06 {
    const NAME: &'static str = "ms06";
    type Ray = PluckerRay<R>;
    /// World position.
    type Vert = V3<R>;

    fn prepare(origin: V3<f64>, dir: V3<f64>, _domain: &[V3<f64>; 2]) -> Self::Ray {
        PluckerRay::new(origin, dir)
    }

    #[inline(always)]
    fn vertex(_ray: &Self::Ray, p: V3<R>) -> V3<R> {
        p
    }

    fn start_exit(ray: &Self::Ray, v: &[V3<R>; 4], _p: &[V3<R>; 4]) -> usize {
        exit_by_face_tests(|i, j| side_world(ray, v[i], v[j]))
    }

    #[inline(always)]
    fn step(ray: &Self::Ray, a: &V3<R>, b: &V3<R>, c: &V3<R>, d: &V3<R>) -> Option<Exit> {
        let z = R::ZERO;
        // (a,b,d): a→b is an entry edge (known ≥ 0); b→d ≥ 0 and d→a ≥ 0 remain.
        let xa = side_world(ray, *d, *a);
        let xb = side_world(ray, *d, *b);
        if xa >= z && xb <= z {
            return Some(Exit::Abd);
        }
        // (b,c,d): b→c is an entry edge; d→b ≥ 0 (known now) and c→d ≥ 0.
        let xc = side_world(ray, *d, *c);
        Some(if xb >= z && xc <= z {
            Exit::Bcd
        } else {
            Exit::Cad
        })
    }
}
