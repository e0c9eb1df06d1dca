//! The robust walk: every decision is the exact sign of an orientation predicate, so it is the
//! same decision from every tet that asks, and the walk is the exact walk along one line.
//!
//! The ray is the line through two floating-point points, its start s and b = s + d (b rounded
//! once, per ray). The side of an edge p→q is orient3d(s, b, p, q) — Shewchuk's adaptive
//! predicate (the `robust` crate): a float evaluation with a proven error bound, refined
//! exactly only when the bound says the float sign is uncertain. Its sign is the sign of
//! Aman et al.'s 2D determinant without its rounding, so the decision tree is theirs (two
//! predicates per tet, three in the start tet's search).
//!
//! Exact zeros (the line meets the edge) are broken by a symbolic perturbation of the line
//! (`perturbed_side`): the sign a slightly moved line would give, which is antisymmetric and
//! the same for every tet. Why the walk then cannot leak or loop is argued in
//! docs/robust_walk.md.
//!
//! Precision: the predicates are exact on the points the walk is given: float64 points, or
//! float32 points widened exactly (the mesh rounded to float32, which the f32 walk walks).

use super::{Exit, ExitMethod};
use crate::mesh::build::OUTWARD_FACES;
use crate::real::{abs, dot3, sub3, Real, V3};

pub struct Robust;

#[derive(Clone, Copy, Debug)]
pub struct LineRay<R> {
    /// The exact line: through s and b = s + d (b rounded once).
    pub s: V3<f64>,
    pub b: V3<f64>,
    /// s in the walk's precision, and the 2D basis built from b − s.
    pub sr: V3<R>,
    pub u: V3<R>,
    pub w: V3<R>,
}

/// A vertex: its position, its 2D projection (as Aman et al.) and the L1 norm of its offset
/// from s, which scales the projection's error bound.
#[derive(Clone, Copy, Debug)]
pub struct LineVert<R> {
    pub p: V3<R>,
    pub xy: [R; 2],
    pub norm: R,
}

/// The filter's constant, in unit roundoffs. The 2D determinant of two projected vertices
/// differs from det(n, p − s, q − s) (n the exact unit direction of b − s) by the roundings of
/// p − s (2 per product), of the projections (3 each), of the basis (Duff et al.'s formulas
/// deviate from orthonormal by a few ulps) and of the determinant (2): about 30 u |p−s|₁ |q−s|₁
/// in all. 128 leaves a wide margin; a false "certain" would break consistency, a false
/// "uncertain" only costs an exact evaluation.
const FILTER_ULPS: f64 = 128.0;

/// The side of edge p→q seen along the ray, exactly: the sign of orient3d(b, p, q, s) =
/// det(b − s, p − s, q − s). The 2D determinant decides when it exceeds its error bound;
/// otherwise Shewchuk's adaptive predicate; exact zeros by the symbolic perturbation.
#[inline(always)]
pub fn side<R: Real>(ray: &LineRay<R>, p: &LineVert<R>, q: &LineVert<R>) -> bool {
    let det = p.xy[0] * q.xy[1] - p.xy[1] * q.xy[0];
    let bound = R::from_f64(FILTER_ULPS) * R::UNIT_ROUNDOFF * p.norm * q.norm;
    if det > bound {
        true
    } else if -det > bound {
        false
    } else {
        exact_side(ray, p, q)
    }
}

/// The exact sign, out of line: a few rays in a million need it.
#[inline(never)]
fn exact_side<R: Real>(ray: &LineRay<R>, p: &LineVert<R>, q: &LineVert<R>) -> bool {
    let (pp, qq) = (p.p.map(R::to_f64), q.p.map(R::to_f64));
    let c = |v: V3<f64>| robust::Coord3D {
        x: v[0],
        y: v[1],
        z: v[2],
    };
    let det = robust::orient3d(c(ray.b), c(pp), c(qq), c(ray.s));
    if det != 0.0 {
        det > 0.0
    } else {
        perturbed_side(ray.s, ray.b, pp, qq)
    }
}

/// Directions of the symbolic perturbation: the line's start moves by ε·DELTA and its second
/// point by ε·DELTA + ε²·DELTA2. Any vectors do that no mesh edge is parallel to; these have
/// no simple ratios between their components.
const DELTA: V3<f64> = [0.5717136585712, 0.3313491758381, 0.7527361949209];
const DELTA2: V3<f64> = [-0.2915382917263, 0.8419846213571, 0.4503218740313];

/// The side of p→q for the line perturbed as above, as ε → 0⁺ (simulation of simplicity):
/// with D = b − s, P = p − s, Q = q − s, V = q − p, the orientation becomes
///     det(D,P,Q) − ε det(D,δ,V) + ε² det(δ₂,P,Q) − ε³ det(δ₂,δ,V) + …
/// and its sign is that of the first nonzero term, evaluated exactly in rationals. Every term
/// changes sign with p ↔ q, and each is the orientation of a real nearby line, so the signs of
/// all edges are those of one line in general position: the walk is that line's exact walk.
fn perturbed_side(s: V3<f64>, b: V3<f64>, p: V3<f64>, q: V3<f64>) -> bool {
    use num_rational::BigRational;
    use num_traits::{Signed, Zero};
    let r = |x: f64| BigRational::from_float(x).unwrap_or_else(BigRational::zero);
    let v3 = |a: V3<f64>| a.map(r);
    let sub = |a: &[BigRational; 3], b: &[BigRational; 3]| [0, 1, 2].map(|k| &a[k] - &b[k]);
    let det = |a: &[BigRational; 3], b: &[BigRational; 3], c: &[BigRational; 3]| {
        &a[0] * (&b[1] * &c[2] - &b[2] * &c[1]) - &a[1] * (&b[0] * &c[2] - &b[2] * &c[0])
            + &a[2] * (&b[0] * &c[1] - &b[1] * &c[0])
    };
    let (s, b, p, q) = (v3(s), v3(b), v3(p), v3(q));
    let (dl, dl2) = (v3(DELTA), v3(DELTA2));
    let d = sub(&b, &s);
    let (pv, qv, v) = (sub(&p, &s), sub(&q, &s), sub(&q, &p));
    let terms = [-det(&d, &dl, &v), det(&dl2, &pv, &qv), -det(&dl2, &dl, &v)];
    for t in terms {
        if !t.is_zero() {
            return t.is_positive();
        }
    }
    // Only an edge parallel to DELTA gets here: fall back to an order of the endpoints, which is
    // still antisymmetric.
    p.iter().zip(&q).map(|(x, y)| x.cmp(y)).find(|o| o.is_ne()) == Some(std::cmp::Ordering::Less)
}

impl<R: Real> ExitMethod<R> for Robust {
    const NAME: &'static str = "robust";
    type Ray = LineRay<R>;
    type Vert = LineVert<R>;

    fn prepare(origin: V3<f64>, dir: V3<f64>) -> LineRay<R> {
        let b = [0, 1, 2].map(|k| origin[k] + dir[k]);
        // The basis follows b − s (rounded: relative error u per component), the direction of
        // the exact line, not d, which can differ from it by u |s|.
        let bs = [0, 1, 2].map(|k| b[k] - origin[k]);
        let inv = 1.0 / (bs[0] * bs[0] + bs[1] * bs[1] + bs[2] * bs[2]).sqrt();
        let (u, w) = super::aman2022::onb(bs.map(|x| x * inv));
        LineRay {
            s: origin,
            b,
            sr: origin.map(R::from_f64),
            u: u.map(R::from_f64),
            w: w.map(R::from_f64),
        }
    }

    #[inline(always)]
    fn vertex(ray: &LineRay<R>, p: V3<R>) -> LineVert<R> {
        let q = sub3(p, ray.sr);
        LineVert {
            p,
            xy: [dot3(q, ray.u), dot3(q, ray.w)],
            norm: abs(q[0]) + abs(q[1]) + abs(q[2]),
        }
    }

    fn start_exit(ray: &LineRay<R>, v: &[LineVert<R>; 4]) -> usize {
        // The exit face turns counter-clockwise around the ray on all three edges. With exact,
        // consistent signs exactly one face does when the line crosses the tet; if the start
        // point's tet is only touched by the line (start on an edge, say), take the face with
        // the most edges agreeing, the first on ties: deterministic.
        let mut best = (0usize, 0u32);
        for (i, f) in OUTWARD_FACES.iter().enumerate() {
            let (p, q, r) = (&v[f[0]], &v[f[1]], &v[f[2]]);
            let n = side(ray, p, q) as u32 + side(ray, q, r) as u32 + side(ray, r, p) as u32;
            if n == 3 {
                return i;
            }
            if n > best.1 {
                best = (i, n);
            }
        }
        best.0
    }

    #[inline(always)]
    fn step(
        ray: &LineRay<R>,
        a: &LineVert<R>,
        b: &LineVert<R>,
        c: &LineVert<R>,
        d: &LineVert<R>,
    ) -> Exit {
        // Aman et al.'s tree on exact signs: side(d, a) >= 0: (a,b,d) if side(d, b) <= 0,
        // else (b,c,d); otherwise (c,a,d) if side(d, c) >= 0, else (b,c,d). Signs are never
        // zero here, so the tree's ties do not arise.
        if side(ray, d, a) {
            if !side(ray, d, b) {
                Exit::Abd
            } else {
                Exit::Bcd
            }
        } else if side(ray, d, c) {
            Exit::Cad
        } else {
            Exit::Bcd
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The filtered sign equals the exact one, also on near-degenerate inputs.
    #[test]
    fn filter_agrees_with_exact_predicate() {
        let mut x = 0x1234_5678_9abc_def1u64;
        let mut f = || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 11) as f64 / (1u64 << 53) as f64
        };
        for k in 0..20_000 {
            let s = [f(), f(), f()];
            let d = [f() - 0.5, f() - 0.5, f() - 0.5];
            let ray: LineRay<f64> = <Robust as ExitMethod<f64>>::prepare(s, d);
            let p = [f(), f(), f()];
            // Every other q nearly on the plane through the line and p: the filter must defer.
            // (In f32 both points are rounded first; the exact sign is that of the rounded ones.)
            let q = if k % 2 == 0 {
                [f(), f(), f()]
            } else {
                let t = f();
                let u = f();
                [0, 1, 2].map(|i| s[i] + t * d[i] + u * (p[i] - s[i]))
            };
            let vp = <Robust as ExitMethod<f64>>::vertex(&ray, p);
            let vq = <Robust as ExitMethod<f64>>::vertex(&ray, q);
            assert_eq!(side(&ray, &vp, &vq), exact_side(&ray, &vp, &vq), "case {k}");
            let ray32: LineRay<f32> = <Robust as ExitMethod<f32>>::prepare(s, d);
            let (vp32, vq32) = (
                <Robust as ExitMethod<f32>>::vertex(&ray32, p.map(|x| x as f32)),
                <Robust as ExitMethod<f32>>::vertex(&ray32, q.map(|x| x as f32)),
            );
            assert_eq!(
                side(&ray32, &vp32, &vq32),
                exact_side(&ray32, &vp32, &vq32),
                "f32 case {k}"
            );
            assert_ne!(
                side(&ray, &vp, &vq),
                side(&ray, &vq, &vp),
                "antisymmetric, case {k}"
            );
        }
    }
}
