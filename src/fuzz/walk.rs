//! The walk target: valid generated scenes, odd rays and bounds, every query kind, accelerator
//! and precision, and the invariants every answer must keep.

use super::scenes::walk_scene;
use super::{coord, Rng, ODD};
use crate::accel::AccelKind;
use crate::error::Error;
use crate::layout::LayoutKind;
use crate::query::contact::Meet;
use crate::query::Listed;
use crate::scene::buffers::LeavingRays;
use crate::scene::{CastOptions, HitBuffers, Rays, Scene};
use crate::simd::Simd;
use crate::status::{FAILED, HIT, INVALID, MISS};
use crate::traverse::Method;
use std::sync::Arc;

/// One walk case: a scene, then a batch of rays through every query kind and accelerator.
pub fn walk_case(seed: u64) -> Result<(), String> {
    let mut rng = Rng::new(seed);
    let (scene, ntri) = walk_scene(seed % 48);
    // A batch past one chunk now and then, so the thread count matters.
    let big = rng.chance(1.0 / 400.0);
    walk_once(&mut rng, &scene, ntri, big, true)
}

/// A ray's origin or direction component, `p` the odd-value rate of this batch.
fn ray_value(rng: &mut Rng, scene: &Scene, odd: f64, origin: bool, a: usize) -> f64 {
    if rng.chance(odd) {
        return rng.pick(&ODD);
    }
    if origin && rng.chance(0.2) {
        // A mesh vertex.
        let p = &scene.mesh.points;
        return p[(rng.u64() as usize) % p.len()][a];
    }
    coord(rng, 0.0) - if origin { 0.0 } else { 0.5 }
}

/// Bounds: one for all rays or one per ray.
fn bounds(rng: &mut Rng, n: usize) -> (Vec<f64>, Vec<f64>) {
    let one = |rng: &mut Rng, lo: bool| -> f64 {
        match rng.below(10) {
            0 => rng.pick(&ODD),
            1 => -rng.f(),
            2..=4 => rng.f() * 2.0,
            _ => {
                if lo {
                    0.0
                } else {
                    f64::INFINITY
                }
            }
        }
    };
    let k = if rng.chance(0.5) { 1 } else { n };
    let tmin: Vec<f64> = (0..k).map(|_| one(rng, true)).collect();
    let tmax: Vec<f64> = (0..k).map(|_| one(rng, false)).collect();
    (tmin, tmax)
}

/// One batch of rays on `scene`; `agree`: the scene is a valid one (triangles that are its
/// constrained faces, none on the box's sides), where the accelerators must agree.
pub(super) fn walk_once(
    rng: &mut Rng,
    scene: &Arc<Scene>,
    ntri: usize,
    big: bool,
    agree: bool,
) -> Result<(), String> {
    let n = if big {
        4096 + 1 + rng.below(200)
    } else {
        1 + rng.below(12)
    };
    let odd = rng.pick(&[0.0, 0.0, 0.05, 0.3]);
    let mut o = Vec::with_capacity(3 * n);
    let mut d = Vec::with_capacity(3 * n);
    let shared = rng
        .chance(0.2)
        .then(|| [0, 1, 2].map(|a| ray_value(rng, scene, odd, true, a)));
    for _ in 0..n {
        let orig = shared.unwrap_or_else(|| [0, 1, 2].map(|a| ray_value(rng, scene, odd, true, a)));
        o.extend(orig);
        let dir = match rng.below(8) {
            0 => [0, 1, 2].map(|k| {
                if k == rng.below(3) {
                    rng.pick(&[1.0, -1.0])
                } else {
                    0.0
                }
            }),
            1 => {
                // Towards a vertex (through it).
                let p = scene.mesh.points[rng.below(scene.mesh.points.len())];
                [0, 1, 2].map(|k| p[k] - orig[k])
            }
            _ => [0, 1, 2].map(|a| ray_value(rng, scene, odd, false, a)),
        };
        d.extend(dir);
    }
    let (tmin, tmax) = bounds(rng, n);
    let ntets = scene.mesh.len();
    // Rays started from hits, with ids valid (mostly) or not.
    let leaving = rng.chance(0.25).then(|| {
        let bad = rng.chance(0.1);
        let id = |rng: &mut Rng, limit: usize| -> i32 {
            if bad && rng.chance(0.3) {
                rng.pick(&[-2, limit as i32, i32::MAX, i32::MIN])
            } else {
                rng.below(limit + 1) as i32 - 1
            }
        };
        let tri: Vec<i32> = (0..n).map(|_| id(rng, ntri)).collect();
        let tet: Vec<i32> = (0..n).map(|_| id(rng, ntets)).collect();
        (tri, tet)
    });
    let opts = CastOptions {
        threads: Some(rng.pick(&[1, 1, 2, 3])),
        max_steps: rng.chance(0.1).then(|| rng.below(6) as u32),
        lanes: rng.pick(&[
            crate::accel::Lanes::Auto,
            crate::accel::Lanes::Off,
            crate::accel::Lanes::On,
        ]),
        packets: rng.pick(&[crate::accel::Packets::Auto, crate::accel::Packets::Off]),
        simd: rng.pick(&[None, Some(Simd::Scalar), Some(Simd::Avx2)]),
        accel: AccelKind::TetWalk,
    };
    let f32_rays = rng.chance(0.3);
    let method = if rng.chance(0.8) {
        Method::Exact
    } else {
        rng.pick(Method::ALL)
    };
    let layout = if rng.chance(0.7) {
        LayoutKind::DEFAULT
    } else {
        rng.pick(LayoutKind::ALL)
    };
    let job = Batch {
        scene,
        ntri,
        tmin: &tmin,
        tmax: &tmax,
        leaving: leaving.as_ref().map(|(tri, tet)| LeavingRays {
            triangles: &scene.surface.triangles,
            triangle: tri,
            tet,
        }),
        method,
        layout,
        opts,
        big,
        agree,
    };
    if f32_rays {
        let o32: Vec<f32> = o.iter().map(|&x| x as f32).collect();
        let d32: Vec<f32> = d.iter().map(|&x| x as f32).collect();
        job.check(&o32, &d32)
    } else {
        job.check(&o, &d)
    }
}

/// One batch of rays and how to cast it.
struct Batch<'a> {
    scene: &'a Scene,
    ntri: usize,
    tmin: &'a [f64],
    tmax: &'a [f64],
    leaving: Option<LeavingRays<'a>>,
    method: Method,
    layout: LayoutKind,
    opts: CastOptions,
    big: bool,
    agree: bool,
}

impl Batch<'_> {
    /// Ray `r` cast alone in float64 with the default options: (status, t, triangle).
    fn alone(&self, r: &crate::geom::ray::Ray) -> Option<(u8, f64, i32)> {
        let rays = Rays {
            origins: &r.o,
            directions: &r.d,
            tmin: &[r.tmin],
            tmax: &[r.tmax],
            leaving: None,
        };
        let mut hb = HitBuffers::<f64>::new(1, false);
        let opts = CastOptions {
            threads: Some(1),
            ..Default::default()
        };
        self.scene.cast(&rays, hb.out(), &opts).ok()?;
        Some((hb.status[0], hb.t[0], hb.triangle[0]))
    }
}

fn known(e: &Error) -> bool {
    !matches!(e, Error::Gpu(_) | Error::Interrupted)
}

impl Batch<'_> {
    fn check<R: crate::geom::real::Real>(&self, o: &[R], d: &[R]) -> Result<(), String> {
        let rays = Rays {
            origins: o,
            directions: d,
            tmin: self.tmin,
            tmax: self.tmax,
            leaving: self.leaving,
        };
        let n = rays.len();
        let at = |b: &[f64], i: usize| b[if b.len() == 1 { 0 } else { i }];
        let exact = self.method == Method::Exact;
        let closest = |opts: &CastOptions| -> Result<Option<HitBuffers<R>>, String> {
            let mut hb = HitBuffers::<R>::new(n, false);
            match self
                .scene
                .cast_with(self.method, self.layout, &rays, hb.out(), opts)
            {
                Ok(()) => Ok(Some(hb)),
                Err(e) if known(&e) => Ok(None),
                Err(e) => Err(format!("cast: unexpected error {e}")),
            }
        };
        let Some(hits) = closest(&self.opts)? else {
            return Ok(());
        };
        for i in 0..n {
            let s = hits.status[i];
            if ![MISS, HIT, FAILED, INVALID].contains(&s) {
                return Err(format!("ray {i}: status {s}"));
            }
            if s == HIT {
                let t = hits.t[i].to_f64();
                let tr = hits.triangle[i];
                if tr < 0 || tr as usize >= self.ntri {
                    return Err(format!("ray {i}: HIT on triangle {tr} of {}", self.ntri));
                }
                if exact {
                    let (lo, hi) = (
                        R::from_f64(at(self.tmin, i)).to_f64(),
                        R::from_f64(at(self.tmax, i)).to_f64(),
                    );
                    if !(t.is_finite() && lo <= t && t <= hi) {
                        return Err(format!("ray {i}: HIT at t {t} outside [{lo}, {hi}]"));
                    }
                }
            }
        }
        // Any hit: the same walk, stopped at the first crossing.
        let mut any = vec![0u8; n];
        match self
            .scene
            .occluded(self.method, self.layout, &rays, &mut any, &self.opts)
        {
            Ok(()) => {
                for (i, (&a, &c)) in any.iter().zip(&hits.status).enumerate() {
                    if ![MISS, HIT, FAILED, INVALID].contains(&a) {
                        return Err(format!("ray {i}: any-hit status {a}"));
                    }
                    // A closest hit whose t overflows the rays' precision is INVALID; any hit
                    // reports no t.
                    let overflow = a == HIT && c == INVALID;
                    if self.agree && exact && a != FAILED && c != FAILED && a != c && !overflow {
                        return Err(format!("ray {i}: any hit {a} but closest hit {c}"));
                    }
                }
            }
            Err(e) if known(&e) => {}
            Err(e) => return Err(format!("occluded: unexpected error {e}")),
        }
        // All hits (the exact walk only).
        let mut all = vec![Listed::default(); n];
        match self.scene.intersections(&rays, &mut all, &self.opts) {
            Ok(()) if exact => {
                for (i, l) in all.iter().enumerate() {
                    let c = hits.status[i];
                    if ![MISS, HIT, FAILED, INVALID].contains(&l.status) {
                        return Err(format!("ray {i}: all-hits status {}", l.status));
                    }
                    if l.meets.iter().any(|m| m.t.is_nan()) {
                        return Err(format!("ray {i}: an all-hits t is NaN"));
                    }
                    // Sorted by exact t, each point once: where two neighbours' float t are not
                    // in increasing order (points closer than t's error), the referee must put
                    // them in the listed order (the exact crossings of their triangles). Not
                    // judged: a triangle the referee says the line does not meet (membership
                    // is not this target's check), nor scenes that may disagree (below).
                    let r = rays.ray(i);
                    let tris = &self.scene.surface.triangles;
                    let crossing = |m: &Meet| {
                        tris.get(m.triangle as usize)
                            .and_then(|tri| crate::referee::crossing(r.o, r.d, tri))
                    };
                    if self.agree {
                        for w in l.meets.windows(2).filter(|w| w[0].t >= w[1].t) {
                            let order = crossing(&w[0])
                                .zip(crossing(&w[1]))
                                .map(|(a, b)| a.cmp_t_of(&b));
                            if order.is_none_or(|o| o.is_lt()) {
                                continue;
                            }
                            return Err(format!(
                                "ray {i}: all hits not in order of exact t: t {} (triangle {}) \
                                 then {} (triangle {}), referee {order:?}; o {:?} d {:?}",
                                w[0].t, w[0].triangle, w[1].t, w[1].triangle, r.o, r.d
                            ));
                        }
                    }
                    let (lo, hi) = (at(self.tmin, i), at(self.tmax, i));
                    if let Some(m) = l.meets.iter().find(|m| !(lo <= m.t && m.t <= hi)) {
                        return Err(format!("ray {i}: a hit at t {} outside [{lo}, {hi}]", m.t));
                    }
                    if l.meets.iter().any(|m| m.triangle as usize >= self.ntri) {
                        return Err(format!("ray {i}: all hits name a triangle out of range"));
                    }
                    // Scenes whose triangles are not their faces' (construct's mutations) give
                    // answers that need not agree; they must only not panic. Elsewhere the
                    // first point listed is the closest hit: its triangle, and its t evaluated
                    // by the same function (bit for bit, in the rays' precision).
                    if c == HIT && l.status != FAILED && self.agree {
                        let first = l.meets.first();
                        let c = hits.t[i].to_f64();
                        let same = first.is_some_and(|m| {
                            let t = R::from_f64(m.t).to_f64();
                            m.triangle as i32 == hits.triangle[i] && t.to_bits() == c.to_bits()
                        });
                        if !same {
                            return Err(format!(
                                "ray {i}: closest t {} (triangle {}) but first of all hits \
                                 {:?}; o {:?} d {:?} t in [{}, {}], leaving {:?}, \
                                 {:?} {:?} {:?}; alone with default options: {:?}",
                                hits.t[i].to_f64(),
                                hits.triangle[i],
                                first.map(|m| (m.t, m.triangle, m.key)),
                                r.o,
                                r.d,
                                r.tmin,
                                r.tmax,
                                r.leaving.map(|l| (l.triangle, l.tet)),
                                self.method,
                                self.layout,
                                self.opts,
                                self.alone(&r),
                            ));
                        }
                    }
                    if c == MISS && l.status != FAILED && !l.meets.is_empty() && self.agree {
                        return Err(format!("ray {i}: closest MISS but {} hits", l.meets.len()));
                    }
                }
            }
            Ok(()) => {}
            Err(e) if known(&e) => {}
            Err(e) => return Err(format!("intersections: unexpected error {e}")),
        }
        if !exact || !self.agree {
            return Ok(());
        }
        // The exact accelerators agree on hit or miss, ray by ray.
        for &accel in AccelKind::ALL.iter().filter(|a| a.tests_triangles()) {
            let opts = CastOptions { accel, ..self.opts };
            let Some(other) = closest(&opts)? else {
                continue;
            };
            for i in 0..n {
                let (a, b) = (hits.status[i], other.status[i]);
                if ![MISS, HIT, FAILED, INVALID].contains(&b) {
                    return Err(format!("ray {i}: {} status {b}", accel.name()));
                }
                if a != FAILED && b != FAILED && a != b {
                    let r = rays.ray(i);
                    return Err(format!(
                        "ray {i}: tet walk status {a} but {} status {b} (o {:?} d {:?} t in [{}, \
                         {}], leaving {:?}, triangles {:?})",
                        accel.name(),
                        r.o,
                        r.d,
                        r.tmin,
                        r.tmax,
                        r.leaving.map(|l| (l.triangle, l.tet)),
                        (hits.triangle[i], other.triangle[i]),
                    ));
                }
            }
        }
        // The thread count changes nothing.
        if self.big {
            for threads in [Some(1), Some(4), None] {
                let opts = CastOptions {
                    threads,
                    ..self.opts
                };
                if let Some(other) = closest(&opts)? {
                    let same = other.status == hits.status
                        && other.triangle == hits.triangle
                        && other
                            .t
                            .iter()
                            .zip(&hits.t)
                            .all(|(a, b)| a.to_f64().to_bits() == b.to_f64().to_bits());
                    if !same {
                        return Err(format!("answers differ with threads {threads:?}"));
                    }
                }
            }
        }
        Ok(())
    }
}
