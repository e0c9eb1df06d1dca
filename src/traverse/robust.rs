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
//! Exact zeros (the line meets the edge) are broken by a rule that depends only on the edge:
//! p→q counts as positive when p precedes q lexicographically. The rule is antisymmetric, so
//! the two tets sharing an edge still agree. Why the walk then cannot leak or loop is argued
//! in docs/robust_walk.md.
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
/// otherwise Shewchuk's adaptive predicate. Exact zeros (the line meets the edge) are broken by
/// the edge alone: p→q counts as positive when p precedes q lexicographically, which is
/// antisymmetric, so the two tets sharing the edge agree.
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

/// The exact sign with its tie-break, out of line: a few rays in a million need it.
#[inline(never)]
fn exact_side<R: Real>(ray: &LineRay<R>, p: &LineVert<R>, q: &LineVert<R>) -> bool {
    let (pp, qq) = (p.p.map(R::to_f64), q.p.map(R::to_f64));
    let c = |v: V3<f64>| robust::Coord3D { x: v[0], y: v[1], z: v[2] };
    let det = robust::orient3d(c(ray.b), c(pp), c(qq), c(ray.s));
    if det != 0.0 {
        det > 0.0
    } else {
        pp.iter().zip(&qq).map(|(x, y)| x.total_cmp(y)).find(|o| o.is_ne()) == Some(std::cmp::Ordering::Less)
    }
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
        LineRay { s: origin, b, sr: origin.map(R::from_f64), u: u.map(R::from_f64), w: w.map(R::from_f64) }
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
    fn step(ray: &LineRay<R>, a: &LineVert<R>, b: &LineVert<R>, c: &LineVert<R>, d: &LineVert<R>) -> Exit {
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
            assert_eq!(side(&ray32, &vp32, &vq32), exact_side(&ray32, &vp32, &vq32), "f32 case {k}");
            assert_ne!(side(&ray, &vp, &vq), side(&ray, &vq, &vp), "antisymmetric, case {k}");
        }
    }
}
