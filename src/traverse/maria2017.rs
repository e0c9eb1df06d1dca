//! Maria, Horna & Aveneau 2017: exactly two Plücker side products per tet. The entry face's
//! complement (the vertex d opposite it) and its three edges Λ_k = V_k→d make a decision tree
//! of depth 2 (Algorithm 1, Figure 4): the sign of r⊙Λ2 rules out one of the three candidate
//! faces, the sign of r⊙Λ0 or r⊙Λ1 picks between the two left; written without branches
//! (`id = (side ≥ 0)`, `id += (side < 0)`, then a 3-entry table, their Table 1 in our labels).
//! The start tet (Algorithm 2) takes one side product with the edge V2V3, shared by faces F0
//! and F1, to rule one of them out, then runs Algorithm 1 with the ruled-out face as a fake
//! entry face: three products in all.
//!
//! Efficient side product (their Section 3.4): translate to the complement vertex V_f = d. There
//! every Λ_k passes through the origin, so its moment is zero and r⊙Λ_k is a 3D dot product,
//! once the ray's moment is moved to the new frame: v' = v − V_f × u (12 operations, once per
//! tet). Each side product is then v'·(V_k − V_f) (3 subtractions + 5 = 8 operations), so a step
//! costs 12 + 2 × 8 = 28 operations instead of 2 × 23 = 46. Here x_k = v'·(V_k − d) is the side
//! product with the line d→V_k, i.e. −r⊙Λ_k, so Maria's tests `side ≥ 0` / `side < 0` read
//! `x ≤ 0` / `x > 0`.
//!
//! Precision: R arithmetic on world coordinates: v = o × u is formed once per ray from the
//! rounded o and u, and v' = v − d × u is a difference of two world-sized moments, so its
//! absolute error grows with |o| and |d| in float32. The sign of an edge is recomputed in each
//! tet's own frame, so neighbours need not agree bit for bit; Maria et al. report no failures
//! in practice (Table 4), crediting the small operation count. Both test outcomes always name
//! a face: the walk can never find "no face".

use super::lagae2008_plucker::{cross, PluckerRay};
use super::{Exit, ExitMethod};
use crate::geom::real::{dot3, sub3, Real, V3};
use crate::mesh::build::OUTWARD_FACES;

pub struct Maria2017;

/// Maria's exit labels 0, 1, 2 (face 0 bounded by Λ0 and Λ2, face 1 by Λ1 and Λ0, face 2 by
/// Λ2 and Λ1, with Λ0, Λ1, Λ2 = a→d, b→d, c→d) as exits of the walk.
const LEAVES: [Exit; 3] = [Exit::Cad, Exit::Abd, Exit::Bcd];

/// Algorithm 1 with d the complement vertex of the (possibly fake) entry face (a, b, c).
#[inline(always)]
fn exit_tetra<R: Real>(ray: &PluckerRay<R>, a: &V3<R>, b: &V3<R>, c: &V3<R>, d: &V3<R>) -> Exit {
    let z = R::ZERO;
    // Ray moment in the frame translated to d.
    let w = sub3(ray.v, cross(*d, ray.u));
    // side ← r⊙Λ2; id ← (side ≥ 0)
    let mut id = (dot3(w, sub3(*c, *d)) <= z) as usize;
    // side ← r⊙Λ_id; id ← id + (side < 0)
    let k = if id == 0 { a } else { b };
    id += (dot3(w, sub3(*k, *d)) > z) as usize;
    LEAVES[id]
}

impl<R: Real> ExitMethod<R> for Maria2017 {
    const NAME: &'static str = "maria2017";
    type Ray = PluckerRay<R>;
    /// World position (the tet's vertices, as their 80-byte tetrahedron stores them).
    type Vert = V3<R>;

    fn prepare(origin: V3<f64>, dir: V3<f64>, _domain: &[V3<f64>; 2]) -> Self::Ray {
        PluckerRay::new(origin, dir)
    }

    #[inline(always)]
    fn vertex(_ray: &Self::Ray, p: V3<R>) -> V3<R> {
        p
    }

    fn start_exit(ray: &Self::Ray, v: &[V3<R>; 4], _p: &[V3<R>; 4]) -> usize {
        // Algorithm 2: side ← r⊙(V3→V2) in the frame translated to V3. The outward faces are
        // F0 = (1,2,3), which needs the ray to turn counter-clockwise around V2→V3, and
        // F1 = (0,3,2), around V3→V2. side < 0 rules out F1 (f = 1), side ≥ 0 rules out F0
        // (f = 0); then Algorithm 1 with F_f as the entry face.
        let w3 = sub3(ray.v, cross(v[3], ray.u));
        let side = dot3(w3, sub3(v[2], v[3]));
        let f = (side < R::ZERO) as usize;
        // F_f seen as an entry face: its outward order reversed, complement vertex f.
        let g = OUTWARD_FACES[f];
        let (ia, ib, ic) = (g[0], g[2], g[1]);
        match exit_tetra(ray, &v[ia], &v[ib], &v[ic], &v[f]) {
            Exit::Abd => ic,
            Exit::Bcd => ia,
            Exit::Cad => ib,
        }
    }

    #[inline(always)]
    fn step(ray: &Self::Ray, a: &V3<R>, b: &V3<R>, c: &V3<R>, d: &V3<R>) -> Option<Exit> {
        Some(exit_tetra(ray, a, b, c, d))
    }
}
