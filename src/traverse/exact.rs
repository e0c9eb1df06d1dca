//! The exact walk (the default): the robust walk's decisions, taken on the ray's own line.
//!
//! The line is (o, d): the caller's origin and direction, exactly (d scaled by a power of two,
//! which changes no sign). The side of an edge p→q is the sign of det(d, p − o, q − o), the
//! Plücker side product the referee uses, evaluated exactly (`geom::exact::side`); the walk's
//! hot loop is the robust walk's (Aman et al.'s 2D determinants with a certified bound) with
//! the projection centred on o. A zero side means the line meets the edge: the walk still
//! needs one exit face, which the symbolic perturbation of the robust walk picks consistently,
//! but the zero itself is kept: the line *touches* that edge (or a vertex, two zeros; or lies in
//! the face's plane, three), and [`Contact`] tells the query, which finds every scene triangle
//! around the vertex or edge (`mesh::Incidence`). So a ray through a vertex hits the triangles
//! there even where the perturbed walk passes beside them, and a ray in a triangle's plane
//! never hits it.
//!
//! The walk starts at o itself (`locate::Locators::locate_exact`) or, from outside the box, at
//! the boundary face the line enters by, decided by the same predicates: no rounded start
//! point. Hits before tmin are skipped by the query.
//!
//! Precision: exact on the points the walk reads, which are the mesh's float64 points (casts of
//! float32 rays walk in float64, see `scene::cast`); on the float32-only tet80 layout it is
//! exact on the mesh rounded to float32, which is not the caller's mesh where the mesher added
//! points.

use super::robust::{certain_side, det2, perturbed_sign, start_delta, FILTER_ULPS};
use super::{Contact, Exit, ExitMethod};
use crate::geom::dyadic::{exact3, Dyadic};
use crate::geom::exact::side;
use crate::geom::real::{abs, dot3, sub3, Real, V3};
use crate::mesh::build::OUTWARD_FACES;

pub struct Exact;

#[derive(Clone, Copy, Debug)]
pub struct ExactRay<R> {
    /// The line: the ray's origin and its direction scaled by a power of two.
    pub o: V3<f64>,
    pub d: V3<f64>,
    /// The perturbation of the start (as the robust walk's, `robust::start_delta`).
    pub delta: V3<f64>,
    /// o in the walk's precision, and the 2D basis perpendicular to d.
    pub or: V3<R>,
    pub u: V3<R>,
    pub w: V3<R>,
    /// The filter's bound per unit of L1 distance from the line (as the robust walk's).
    pub bound_scale: R,
}

impl<R: Real> ExactRay<R> {
    /// The exact side of p→q (0: the line meets the edge's line).
    #[inline]
    fn sign(&self, p: V3<R>, q: V3<R>) -> i8 {
        side(self.d, self.o, p.map(R::to_f64), q.map(R::to_f64))
    }

    /// The side of p→q with zeros decided by the perturbation: the walk's decision.
    #[inline(never)]
    fn perturbed(&self, p: V3<R>, q: V3<R>) -> bool {
        match self.sign(p, q) {
            0 => {
                let (o, d): ([Dyadic; 3], _) = (exact3(self.o), exact3(self.d));
                perturbed_sign(&o, &d, p.map(R::to_f64), q.map(R::to_f64), self.delta)
            }
            s => s > 0,
        }
    }

    /// Whether the (perturbed) line enters a tet through the face (a, b, c) given in its
    /// outward order: then it turns clockwise around the line on every edge.
    pub fn enters(&self, face: &[V3<R>; 3]) -> bool {
        // The walk's filter first (the face lies in the domain, which its bound covers): a
        // certain side is the exact sign, so the perturbation is never needed there.
        let v = face.map(|p| <Exact as ExitMethod<R>>::vertex(self, p));
        let side = |i: usize, j: usize| {
            certain_side(&v[i], &v[j]).unwrap_or_else(|| self.perturbed(face[i], face[j]))
        };
        !side(0, 1) && !side(1, 2) && !side(2, 0)
    }
}

/// The 2D basis perpendicular to `dir`, in the walk's precision.
#[inline(always)]
fn basis<R: Real>(dir: V3<f64>) -> (V3<R>, V3<R>) {
    let inv = 1.0 / (dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]).sqrt();
    let (u, w) = crate::geom::onb::onb(dir.map(|x| x * inv));
    (u.map(R::from_f64), w.map(R::from_f64))
}

impl<R: Real> ExitMethod<R> for Exact {
    const NAME: &'static str = "exact";
    const CONTACTS: bool = true;
    const PACKETS: bool = true;
    type Ray = ExactRay<R>;
    type Vert = [R; 3];

    fn prepare(origin: V3<f64>, dir: V3<f64>, domain: &[V3<f64>; 2]) -> ExactRay<R> {
        let (u, w) = basis(dir);
        let or = origin.map(R::from_f64);
        // The robust walk's bound (see FILTER_ULPS) with the reach measured from o; and where
        // o is not a number of the walk's precision (float32 layouts), the projection's centre
        // is off the line by |o − or|, which moves a determinant by at most that much per unit
        // of the two vertices' distances from the line.
        let reach: f64 = (0..3)
            .map(|k| {
                (domain[0][k] - origin[k])
                    .abs()
                    .max((domain[1][k] - origin[k]).abs())
            })
            .sum();
        let off: f64 = (0..3).map(|k| (origin[k] - or[k].to_f64()).abs()).sum();
        let scale = FILTER_ULPS * R::UNIT_ROUNDOFF.to_f64() * reach * (1.0 + 1e-6) + 2.0 * off;
        ExactRay {
            o: origin,
            d: dir,
            delta: start_delta::<R>(origin, domain),
            or,
            u,
            w,
            bound_scale: R::from_f64(scale) * R::from_f64(1.0 + 1e-6),
        }
    }

    fn line(ray: &ExactRay<R>) -> (V3<f64>, V3<f64>) {
        (ray.o, ray.d)
    }

    #[inline(always)]
    fn redirect(ray: &ExactRay<R>, dir: V3<f64>, _: &[V3<f64>; 2]) -> ExactRay<R> {
        // The origin's parts (delta, or, bound_scale) depend on the origin and domain only.
        let (u, w) = basis(dir);
        ExactRay {
            d: dir,
            u,
            w,
            ..*ray
        }
    }

    #[inline(always)]
    fn vertex(ray: &ExactRay<R>, p: V3<R>) -> [R; 3] {
        let q = sub3(p, ray.or);
        let (x, y) = (dot3(q, ray.u), dot3(q, ray.w));
        [x, y, ray.bound_scale * (abs(x) + abs(y)) + R::MIN_NORMAL]
    }

    fn start_exit(ray: &ExactRay<R>, v: &[[R; 3]; 4], p: &[V3<R>; 4]) -> usize {
        // As the robust walk's: the face turning counter-clockwise on all three edges.
        let side = |i: usize, j: usize| {
            certain_side(&v[i], &v[j]).unwrap_or_else(|| ray.perturbed(p[i], p[j]))
        };
        let mut best = (0usize, 0u32);
        for (i, f) in OUTWARD_FACES.iter().enumerate() {
            let n = side(f[0], f[1]) as u32 + side(f[1], f[2]) as u32 + side(f[2], f[0]) as u32;
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
    fn step(_ray: &ExactRay<R>, a: &[R; 3], b: &[R; 3], c: &[R; 3], d: &[R; 3]) -> Option<Exit> {
        // The robust walk's step (see there).
        let xa = det2(d, a);
        let (exit, x2, e2) = if xa >= R::ZERO {
            let xb = det2(d, b);
            (if xb <= R::ZERO { Exit::Abd } else { Exit::Bcd }, xb, b)
        } else {
            let xc = det2(d, c);
            (if xc >= R::ZERO { Exit::Cad } else { Exit::Bcd }, xc, c)
        };
        if abs(xa) > d[2] + a[2] && abs(x2) > d[2] + e2[2] {
            Some(exit)
        } else {
            None
        }
    }

    #[inline(always)]
    fn step_plain(_: &ExactRay<R>, a: &[R; 3], b: &[R; 3], c: &[R; 3], d: &[R; 3]) -> Option<Exit> {
        // The three sides d→a, d→b, d→c decide `step` the same way; all three certain, each
        // exit face (a, b, d), (b, c, d), (c, a, d) has two certain edges through d and one of
        // the entry face's, certain by the caller's precondition: no touch.
        let (xa, xb, xc) = (det2(d, a), det2(d, b), det2(d, c));
        if !(abs(xa) > d[2] + a[2] && abs(xb) > d[2] + b[2] && abs(xc) > d[2] + c[2]) {
            return None;
        }
        // `step`'s choice, without branches: xa ≥ 0 → Abd unless xb > 0 (Bcd); else Cad
        // unless xc < 0 (Bcd).
        let (sa, sb, sc) = (xa >= R::ZERO, xb <= R::ZERO, xc >= R::ZERO);
        let r = (sa & !sb) as u8 + (!sa) as u8 * (1 + sc as u8);
        Some(Exit::ROTATIONS[r as usize])
    }

    #[inline(never)]
    fn step_exact(ray: &ExactRay<R>, p: &[V3<R>; 4]) -> Exit {
        let [a, b, c, d] = *p;
        if ray.perturbed(d, a) {
            if !ray.perturbed(d, b) {
                Exit::Abd
            } else {
                Exit::Bcd
            }
        } else if ray.perturbed(d, c) {
            Exit::Cad
        } else {
            Exit::Bcd
        }
    }

    fn enters(ray: &ExactRay<R>, face: &[V3<R>; 3]) -> bool {
        ray.enters(face)
    }

    #[inline(always)]
    fn may_touch(_ray: &ExactRay<R>, a: &[R; 3], b: &[R; 3], c: &[R; 3]) -> bool {
        certain_side(a, b).is_none() || certain_side(b, c).is_none() || certain_side(c, a).is_none()
    }

    #[inline(never)]
    fn contact(ray: &ExactRay<R>, face: &[V3<R>; 3], w: V3<R>) -> Contact {
        let [a, b, c] = *face;
        let s = [ray.sign(a, b), ray.sign(b, c), ray.sign(c, a)];
        match s.map(|x| x == 0) {
            [false, false, false] => Contact::Interior,
            [true, false, false] => Contact::Edge(0),
            [false, true, false] => Contact::Edge(1),
            [false, false, true] => Contact::Edge(2),
            // Two zero edges meet at their shared vertex: (ab, bc) at b, (bc, ca) at c, (ca, ab) at a.
            [true, true, false] => Contact::Vertex(1),
            [false, true, true] => Contact::Vertex(2),
            [true, false, true] => Contact::Vertex(0),
            [true, true, true] => {
                // In the face's plane. The plane through the line and w (off the face's plane)
                // cuts the face's plane along the line, so det(d, x − o, w − o) is the side of
                // each vertex x of the line within the face's plane: zero on it.
                let at = [a, b, c].map(|x| ray.sign(x, w));
                let mut vertices = 0u8;
                let mut edges = 0u8;
                for k in 0..3 {
                    if at[k] == 0 {
                        vertices |= 1 << k;
                    }
                    if at[k] * at[(k + 1) % 3] < 0 {
                        edges |= 1 << k;
                    }
                }
                Contact::Coplanar { vertices, edges }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Where the origin lies in the domain box [lo, hi]³.
    #[derive(Clone, Copy, Debug)]
    enum Origin {
        /// Uniform in the box.
        Inside,
        /// At its low corner.
        LowCorner,
    }

    /// Over near-degenerate edges p→q (q nearly in the plane of the line and p) in the domain
    /// box [lo, hi]³, how often the filter (`vertex`'s bounds, `certain_side`) claims a sign
    /// that is not the exact one (`geom::exact::side` on the ray's own line), and how often it
    /// claims one at all; the bound multiplied by `shrink`.
    fn filter_mistakes<R: Real>(lo: f64, hi: f64, origin: Origin, shrink: f64) -> (usize, usize) {
        let mut r = crate::rng::Rng::xorshift(0x2545_f491_4f6c_dd1d);
        let mut f = || r.f();
        let size = hi - lo;
        let domain = [[lo; 3], [hi; 3]];
        let (mut wrong, mut certain) = (0, 0);
        for k in 0..8_000 {
            let pt = |f: &mut dyn FnMut() -> f64| [0, 1, 2].map(|_| lo + size * f());
            let o = match origin {
                Origin::Inside => pt(&mut f),
                Origin::LowCorner => [lo; 3],
            };
            let d = [f() - 0.5, f() - 0.5, f() - 0.5];
            let mut ray: ExactRay<R> = <Exact as ExitMethod<R>>::prepare(o, d, &domain);
            ray.bound_scale = R::from_f64(ray.bound_scale.to_f64() * shrink);
            let p = pt(&mut f).map(R::from_f64);
            let (t, w) = (f(), f());
            let e = (f() - 0.5) * 10f64.powi(-3 - k % 13);
            let pp = p.map(R::to_f64);
            let l = d.iter().fold(0f64, |m, x| m.max(x.abs()));
            let q = [0, 1, 2].map(|i| {
                let x = o[i] + t * size * d[i] / l + w * (pp[i] - o[i]) + e * size;
                R::from_f64(x.clamp(lo, hi))
            });
            if p == q {
                continue;
            }
            let exact = side(d, o, pp, q.map(R::to_f64));
            let (vp, vq) = (
                <Exact as ExitMethod<R>>::vertex(&ray, p),
                <Exact as ExitMethod<R>>::vertex(&ray, q),
            );
            if let Some(s) = certain_side(&vp, &vq) {
                certain += 1;
                wrong += (exact == 0 || s != (exact > 0)) as usize;
            }
        }
        (wrong, certain)
    }

    /// What a family of [`filter_mistakes`] must show beside no mistake: the filter decides
    /// most cases, and a thousandth of its scale makes mistakes (not where determinants
    /// underflow: there the bound's absolute slack decides); or it decides none.
    #[derive(Clone, Copy, Debug, PartialEq)]
    enum Family {
        Decides,
        DecidesUnderflowing,
        DecidesNone,
    }

    /// The exact walk's filter claims only exact signs: origins inside boxes of several sizes
    /// and offsets, and at the low corner of boxes that straddle zero (where the reach must be
    /// measured from the origin to the far corner); boxes so large that the bound's scale
    /// exceeds 1 (its product with a vertex's distance then matters), and so small that the
    /// determinants underflow (where the bound's absolute slack, the least normal number,
    /// matters; in the smallest the filter decides nothing); in float32, origins that are not
    /// float32 numbers (a float64 ray on the tet80 layout), whose rounding the bound must cover.
    #[test]
    fn the_filter_claims_only_exact_signs() {
        use Family::*;
        use Origin::*;
        let f64_cases = [
            (0.0, 1.0, Inside, Decides),
            (-1e5, -1e5 + 1e3, Inside, Decides),
            (-1.0, 1.0, LowCorner, Decides),
            (-1e3, 1.0, LowCorner, Decides),
            (0.0, 1e18, Inside, Decides),
            (0.0, 1e-152, Inside, DecidesUnderflowing),
            (0.0, 1e-156, Inside, DecidesNone),
        ];
        let f32_cases = [
            (0.0, 1.0, Inside, Decides),
            (-1.0, 1.0, LowCorner, Decides),
            (-1e3, 1.0, LowCorner, Decides),
            (0.0, 1e8, Inside, Decides),
            (1e4, 1e4 + 1.0, Inside, Decides),
            (0.0, 1e-18, Inside, DecidesUnderflowing),
            (0.0, 1e-20, Inside, DecidesNone),
        ];
        let run = |r: &dyn Fn(f64) -> (usize, usize), case: String, family: Family| {
            let (wrong, certain) = r(1.0);
            assert_eq!(wrong, 0, "{case}: {wrong} of {certain} certain signs wrong");
            if family == DecidesNone {
                assert_eq!(
                    certain, 0,
                    "{case}: underflowed determinants are never certain"
                );
            } else {
                assert!(
                    certain > 2_000,
                    "{case}: the filter decides most cases ({certain})"
                );
            }
            if family == Decides {
                assert!(
                    r(1e-3).0 > 0,
                    "{case}: a thousandth of the bound makes no mistake"
                );
            }
        };
        for (lo, hi, o, family) in f64_cases {
            let case = format!("f64 [{lo:e}, {hi:e}] {o:?}");
            run(&|s| filter_mistakes::<f64>(lo, hi, o, s), case, family);
        }
        for (lo, hi, o, family) in f32_cases {
            let case = format!("f32 [{lo:e}, {hi:e}] {o:?}");
            run(&|s| filter_mistakes::<f32>(lo, hi, o, s), case, family);
        }
    }
}
