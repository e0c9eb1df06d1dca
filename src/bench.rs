//! The exit-face micro-benchmark (after Maria et al. 2017, Table 5): random tetrahedra, random
//! rays stabbing them, nanoseconds per exit-face decision of each method, one thread.
//!
//! A decision is what a walk pays per tet in arithmetic: the new vertex's per-vertex data
//! (`ExitMethod::vertex`) and the choice among three faces (`ExitMethod::step`); the entry
//! face's data are prepared beforehand, as a walk carries them. Memory effects are kept out:
//! all cases sit in one array read in order.

use crate::dispatch::with_method;
use crate::error::{Error, Result};
use crate::mesh::build::{orient, OUTWARD_FACES};
use crate::real::{Real, V3};
use crate::traverse::{Aman2022, Exit, ExitMethod};
use std::hint::black_box;
use std::time::Instant;

/// One ray stabbing one tet: origin inside it, direction, the four corners in the walk's
/// order (entry face a, b, c counter-clockwise around the ray, then d) and the exit face
/// decided in float64 with exact orientation checks.
#[derive(Clone, Copy, Debug)]
pub struct Case {
    pub origin: V3<f64>,
    pub dir: V3<f64>,
    pub corners: [V3<f64>; 4],
    pub exit: Exit,
}

struct Rng(u64);
impl Rng {
    fn f(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// `n_tets` random tets (corners uniform in the unit cube, not too flat) and `rays_per_tet`
/// rays through each, from a uniform point inside in a uniform direction.
pub fn cases(n_tets: usize, rays_per_tet: usize, seed: u64) -> Vec<Case> {
    let mut rng = Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1);
    let mut out = Vec::with_capacity(n_tets * rays_per_tet);
    while out.len() < n_tets * rays_per_tet {
        let mut v = [0; 4].map(|_| [rng.f(), rng.f(), rng.f()]);
        let o = orient(v[0], v[1], v[2], v[3]);
        if o.abs() < 0.01 {
            continue; // keep slivers out: this measures speed, the stability issue measures them
        }
        if o < 0.0 {
            v.swap(2, 3);
        }
        for _ in 0..rays_per_tet {
            // A uniform point inside (sorted uniforms give uniform barycentrics).
            let mut w = [rng.f(), rng.f(), rng.f()];
            w.sort_by(f64::total_cmp);
            let b = [w[0], w[1] - w[0], w[2] - w[1], 1.0 - w[2]];
            let p = [0, 1, 2].map(|k| (0..4).map(|i| b[i] * v[i][k]).sum::<f64>());
            let dir = loop {
                let d = [
                    rng.f() * 2.0 - 1.0,
                    rng.f() * 2.0 - 1.0,
                    rng.f() * 2.0 - 1.0,
                ];
                let l = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
                if l > 1e-6 && l <= 1.0 {
                    break d;
                }
            };
            // The entry face is where the reversed ray leaves; the exit where this one does.
            let back = [-dir[0], -dir[1], -dir[2]];
            let entry = exact_exit(&v, p, back);
            let exit = exact_exit(&v, p, dir);
            if entry == exit {
                continue; // only a ray along a face could do this; not a stab
            }
            let f = OUTWARD_FACES[entry];
            let (a, b2, c) = (f[0], f[2], f[1]);
            // The exit face is the one opposite a (b,c,d), b (c,a,d) or c (a,b,d).
            let e = if exit == c {
                Exit::Abd
            } else if exit == a {
                Exit::Bcd
            } else {
                Exit::Cad
            };
            out.push(Case {
                origin: p,
                dir,
                corners: [v[a], v[b2], v[c], v[entry]],
                exit: e,
            });
        }
    }
    out
}

/// The face (opposite vertex i) a ray from inside leaves by: float64 2D method, a reference
/// that is exact for these well-shaped tets.
fn exact_exit(v: &[V3<f64>; 4], p: V3<f64>, d: V3<f64>) -> usize {
    let ray = <Aman2022 as ExitMethod<f64>>::prepare(p, d, &bounds(v));
    let vs = v.map(|q| <Aman2022 as ExitMethod<f64>>::vertex(&ray, q));
    <Aman2022 as ExitMethod<f64>>::start_exit(&ray, &vs, v)
}

/// The bounding box of a tet's corners (the domain methods' error bounds need).
fn bounds(v: &[V3<f64>; 4]) -> [V3<f64>; 2] {
    let lo = [0, 1, 2].map(|k| v.iter().map(|p| p[k]).fold(f64::INFINITY, f64::min));
    let hi = [0, 1, 2].map(|k| v.iter().map(|p| p[k]).fold(f64::NEG_INFINITY, f64::max));
    [lo, hi]
}

/// Nanoseconds per decision (best of `repeat` passes) and how many decisions differ from
/// the float64 reference.
pub fn time_method<R: Real, M: ExitMethod<R>>(cases: &[Case], repeat: usize) -> (f64, usize) {
    let prepared: Vec<(M::Ray, [M::Vert; 3], [V3<R>; 4])> = cases
        .iter()
        .map(|c| {
            let ray = M::prepare(c.origin, c.dir, &bounds(&c.corners));
            let p = c.corners.map(|q| q.map(R::from_f64));
            (ray, [0, 1, 2].map(|k| M::vertex(&ray, p[k])), p)
        })
        .collect();
    // The walk's decision: `step`, or for a robust method whose filter defers, `step_exact`.
    let decide = |ray: &M::Ray, [a, b, c]: &[M::Vert; 3], p: &[V3<R>; 4]| {
        let vd = M::vertex(ray, black_box(p[3]));
        M::step(ray, a, b, c, &vd).unwrap_or_else(|| M::step_exact(ray, p))
    };
    let mut best = f64::INFINITY;
    let mut wrong = 0;
    for _ in 0..repeat.max(1) {
        let t0 = Instant::now();
        let mut sum = 0u32;
        for (ray, v, p) in &prepared {
            sum = sum.wrapping_add(decide(ray, v, p) as u32);
        }
        black_box(sum);
        best = best.min(t0.elapsed().as_secs_f64());
    }
    for ((ray, v, p), case) in prepared.iter().zip(cases) {
        wrong += (decide(ray, v, p) != case.exit) as usize;
    }
    (best * 1e9 / cases.len() as f64, wrong)
}

/// Runs the benchmark for a method by name and precision ("f32" or "f64").
pub fn exitface(
    method: &str,
    precision: &str,
    cases: &[Case],
    repeat: usize,
) -> Result<(f64, usize)> {
    match precision {
        "f32" => with_method!(method, M => Ok(time_method::<f32, M>(cases, repeat))),
        "f64" => with_method!(method, M => Ok(time_method::<f64, M>(cases, repeat))),
        other => Err(Error::InvalidOption(format!(
            "precision must be f32 or f64, got {other:?}"
        ))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cases_have_the_exit_the_method_finds() {
        let cs = cases(200, 8, 1);
        assert_eq!(cs.len(), 1600);
        let (_, wrong) = time_method::<f64, Aman2022>(&cs, 1);
        assert_eq!(wrong, 0);
        let (ns, wrong32) = time_method::<f32, Aman2022>(&cs, 1);
        assert!(
            ns > 0.0 && wrong32 <= 2,
            "{wrong32} float32 decisions differ"
        );
    }
}
