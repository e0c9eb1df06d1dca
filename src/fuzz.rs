//! Fuzzing on stable Rust (issue 18.5): two targets driven by a seed, each case reproducible
//! from its own seed alone, panics caught per case so a failure names the seed.
//!
//! * [`construct_case`]: `Scene::build` / `Scene::build_with` on random point clouds with
//!   random tets, and on valid Kuhn-grid meshes then mutated (indices out of range or
//!   repeated, flipped, flat and duplicate tets, NaN/inf/huge/denormal coordinates, faces that
//!   are no tet face, triangle ids out of range, empty inputs, non-box domains). Every case
//!   must give `Ok` or an [`Error`]; a scene that builds then casts a few rays.
//! * [`walk_case`]: valid generated scenes, rays with random, NaN, inf, zero, denormal and huge
//!   origins and directions, tmin/tmax scalar or per ray (NaN, negative, inverted), every query
//!   kind (closest, any, all hits), rays started from hits (`leaving`, ids valid and not),
//!   every accelerator, both precisions. Invariants: every status is MISS/HIT/FAILED/INVALID;
//!   a HIT has a finite t in [tmin, tmax] and a triangle in range; any hit agrees with the
//!   closest hit; the all-hits list is sorted, inside [tmin, tmax], and its first t is the
//!   closest hit's; the exact accelerators agree on hit or miss; answers do not depend on the
//!   thread count.
//!
//! `cargo test` runs a bounded number of cases of each (`tests` below); `examples/fuzz.rs`
//! runs long ones (docs/fuzzing.md).

use crate::accel::AccelKind;
use crate::error::Error;
use crate::layout::LayoutKind;
use crate::query::contact::Meet;
use crate::query::Listed;
pub use crate::rng::{mix, Rng};
use crate::scene::buffers::LeavingRays;
use crate::scene::{CastOptions, HitBuffers, Rays, Scene};
use crate::simd::Simd;
use crate::status::{FAILED, HIT, INVALID, MISS};
use crate::traverse::Method;
use std::cell::RefCell;
use std::collections::HashMap;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::Arc;
use std::time::Instant;

/// The seed of case `i` of a run seeded `seed`.
pub fn case_seed(seed: u64, i: u64) -> u64 {
    mix(seed ^ mix(i))
}

/// Odd values a coordinate, direction component or bound may take.
const ODD: [f64; 16] = [
    f64::NAN,
    f64::INFINITY,
    f64::NEG_INFINITY,
    0.0,
    -0.0,
    5e-324,
    -1e-310,
    f64::MIN_POSITIVE,
    1e-300,
    1e300,
    -1e300,
    f64::MAX,
    f64::MIN,
    1e-30,
    1e30,
    3.4e38,
];

/// A coordinate: mostly around the unit box (grid-aligned at times, to meet vertices, edges and
/// faces exactly), sometimes odd.
fn coord(rng: &mut Rng, odd: f64) -> f64 {
    if rng.chance(odd) {
        return rng.pick(&ODD);
    }
    match rng.below(3) {
        0 => -0.5 + 2.0 * rng.f(),
        1 => (rng.below(13) as f64 - 2.0) / 8.0,
        _ => rng.f(),
    }
}

/// An n³ grid of cubes over [0,1]³, each cut into 6 Kuhn tets, interior points jittered by
/// `jitter` (0: every face plane is shared by many faces, `uniform` draws in [0, 1)) and
/// rounded to multiples of 2^-24. The crate's tests build their grids with it too.
pub fn kuhn_grid(
    n: usize,
    jitter: f64,
    mut uniform: impl FnMut() -> f64,
) -> (Vec<[f64; 3]>, Vec<[u32; 4]>) {
    let m = n + 1;
    let id = |x: usize, y: usize, z: usize| (x + m * (y + m * z)) as u32;
    let mut pts = Vec::new();
    for z in 0..m {
        for y in 0..m {
            for x in 0..m {
                let mut p = [x, y, z].map(|c| c as f64 / n as f64);
                for (a, c) in [x, y, z].into_iter().enumerate() {
                    if c > 0 && c < n {
                        p[a] += (uniform() - 0.5) * jitter / n as f64;
                    }
                }
                pts.push(p.map(|x| (x * 16_777_216.0).round() / 16_777_216.0));
            }
        }
    }
    let perms = [
        [0, 1, 2],
        [0, 2, 1],
        [1, 0, 2],
        [1, 2, 0],
        [2, 0, 1],
        [2, 1, 0],
    ];
    let mut tets = Vec::new();
    for z in 0..n {
        for y in 0..n {
            for x in 0..n {
                for p in perms {
                    let mut c = [x, y, z];
                    let mut t = [id(x, y, z), 0, 0, 0];
                    for (k, &a) in p.iter().enumerate() {
                        c[a] += 1;
                        t[k + 1] = id(c[0], c[1], c[2]);
                    }
                    tets.push(t);
                }
            }
        }
    }
    (pts, tets)
}

/// Every face of every tet, each sorted, the list sorted (interior faces appear twice).
pub fn tet_faces(tets: &[[u32; 4]]) -> Vec<[u32; 3]> {
    let mut f: Vec<[u32; 3]> = tets
        .iter()
        .flat_map(|t| {
            [
                [t[1], t[2], t[3]],
                [t[0], t[2], t[3]],
                [t[0], t[1], t[3]],
                [t[0], t[1], t[2]],
            ]
            .map(|mut k| {
                k.sort();
                k
            })
        })
        .collect();
    f.sort();
    f
}

/// Every face of the tets once (sorted triples).
fn faces_of(tets: &[[u32; 4]]) -> Vec<[u32; 3]> {
    let mut f = tet_faces(tets);
    f.dedup();
    f
}

/// The inputs of one `Scene::build_with`.
#[derive(Clone, Debug)]
pub struct BuildInput {
    pub points: Vec<[f64; 3]>,
    pub tets: Vec<[u32; 4]>,
    pub faces: Vec<[u32; 3]>,
    pub face_triangle: Vec<u32>,
    pub triangles: Vec<[[f64; 3]; 3]>,
    pub hilbert: bool,
}

impl BuildInput {
    pub fn build(&self) -> crate::Result<Scene> {
        Scene::build_with(
            self.points.clone(),
            &self.tets,
            &self.faces,
            &self.face_triangle,
            self.triangles.clone(),
            self.hilbert,
        )
    }
}

/// A valid scene's inputs: a Kuhn grid of side `n`, a fraction `frac` of its faces as
/// triangles; with `inside`, none on the box's sides (as meshing builds scenes: the domain box
/// has a margin).
pub fn grid_input(rng: &mut Rng, n: usize, jitter: f64, frac: f64, inside: bool) -> BuildInput {
    let (points, tets) = kuhn_grid(n, jitter, || rng.f());
    let on_side = |v: u32| points[v as usize].iter().any(|&x| x == 0.0 || x == 1.0);
    let faces: Vec<[u32; 3]> = faces_of(&tets)
        .into_iter()
        .filter(|f| !(inside && f.iter().any(|&v| on_side(v))))
        .filter(|_| rng.chance(frac))
        .collect();
    let triangles = faces
        .iter()
        .map(|f| f.map(|v| points[v as usize]))
        .collect();
    let face_triangle = (0..faces.len() as u32).collect();
    BuildInput {
        points,
        tets,
        faces,
        face_triangle,
        triangles,
        hilbert: rng.chance(0.7),
    }
}

/// A random point cloud with random tets, faces and triangles (indices mostly in range).
fn random_input(rng: &mut Rng) -> BuildInput {
    let np = rng.below(12);
    let odd = rng.pick(&[0.0, 0.0, 0.02, 0.2]);
    let points: Vec<[f64; 3]> = (0..np)
        .map(|_| [0, 1, 2].map(|_| coord(rng, odd)))
        .collect();
    let idx = |rng: &mut Rng| {
        if np == 0 || rng.chance(0.02) {
            rng.below(np + 3) as u32
        } else {
            rng.below(np) as u32
        }
    };
    let tets = (0..rng.below(10))
        .map(|_| [0; 4].map(|_| idx(rng)))
        .collect::<Vec<_>>();
    let mut faces: Vec<[u32; 3]> = (0..rng.below(6))
        .map(|_| [0; 3].map(|_| idx(rng)))
        .collect();
    if rng.chance(0.5) && !tets.is_empty() {
        let t: [u32; 4] = tets[rng.below(tets.len())];
        faces.push([t[0], t[1], t[2]]);
    }
    let nt = rng.below(5);
    let triangles: Vec<[[f64; 3]; 3]> = (0..nt)
        .map(|_| [0; 3].map(|_| [0, 1, 2].map(|_| coord(rng, odd))))
        .collect();
    let face_triangle = (0..faces.len())
        .map(|_| {
            let extra = usize::from(rng.chance(0.1));
            rng.below(nt + extra) as u32
        })
        .collect();
    BuildInput {
        points,
        tets,
        faces,
        face_triangle,
        triangles,
        hilbert: rng.chance(0.5),
    }
}

/// One mutation of a (usually valid) input.
fn mutate(rng: &mut Rng, b: &mut BuildInput) {
    let np = b.points.len();
    match rng.below(18) {
        0 if !b.tets.is_empty() => {
            // An index out of range.
            let t = rng.below(b.tets.len());
            b.tets[t][rng.below(4)] = rng.pick(&[np as u32, np as u32 + 1, u32::MAX, u32::MAX - 1]);
        }
        1 if !b.tets.is_empty() => {
            // A repeated index (a flat tet).
            let t = rng.below(b.tets.len());
            b.tets[t][1] = b.tets[t][0];
        }
        2 if !b.tets.is_empty() => {
            // Flipped orientation.
            let t = rng.below(b.tets.len());
            b.tets[t].swap(2, 3);
        }
        3 if !b.tets.is_empty() => {
            // A duplicate tet.
            let t = b.tets[rng.below(b.tets.len())];
            b.tets.push(t);
        }
        4 if !b.tets.is_empty() => {
            // A tet removed (a hole: the domain is no longer a box, or a face dangles).
            let t = rng.below(b.tets.len());
            b.tets.remove(t);
        }
        5 if np > 0 => {
            // An odd coordinate.
            let p = rng.below(np);
            b.points[p][rng.below(3)] = rng.pick(&ODD);
        }
        6 if np > 0 => {
            // A point moved (tets may invert or flatten, the box may change).
            let p = rng.below(np);
            b.points[p] = [0, 1, 2].map(|_| coord(rng, 0.1));
        }
        7 if np > 1 => {
            // Two points made equal.
            let (p, q) = (rng.below(np), rng.below(np));
            b.points[p] = b.points[q];
        }
        8 => {
            // A face that is no tet face.
            b.faces.push([0; 3].map(|_| rng.below(np.max(1)) as u32));
            b.face_triangle.push(0);
        }
        9 if !b.face_triangle.is_empty() => {
            // A triangle id out of range.
            let k = rng.below(b.face_triangle.len());
            b.face_triangle[k] = b.triangles.len() as u32 + rng.below(3) as u32;
        }
        10 if !b.faces.is_empty() => {
            // A face listed twice (with another triangle id).
            let k = rng.below(b.faces.len());
            b.faces.push(b.faces[k]);
            b.face_triangle
                .push(rng.below(b.triangles.len().max(1)) as u32);
        }
        11 => {
            // Lengths that disagree.
            if rng.chance(0.5) {
                b.face_triangle.pop();
            } else {
                b.face_triangle.push(0);
            }
        }
        12 if !b.triangles.is_empty() => {
            // An odd triangle corner.
            let k = rng.below(b.triangles.len());
            b.triangles[k][rng.below(3)][rng.below(3)] = rng.pick(&ODD);
        }
        13 => {
            // Empty inputs.
            match rng.below(4) {
                0 => b.tets.clear(),
                1 => {
                    b.faces.clear();
                    b.face_triangle.clear();
                }
                2 => b.triangles.clear(),
                _ => b.points.clear(),
            }
        }
        14 if np > 0 => {
            // Every point scaled or shifted by a huge or tiny amount.
            let s = rng.pick(&[1e-300, 1e300, 1e-160, 1e160, 2f64.powi(-1070)]);
            let shift = rng.chance(0.5);
            for p in &mut b.points {
                for x in p.iter_mut() {
                    *x = if shift { *x + s } else { *x * s };
                }
            }
        }
        15 if !b.tets.is_empty() => {
            // A tet's corners permuted (any orientation is accepted).
            let t = rng.below(b.tets.len());
            b.tets[t].rotate_left(1 + rng.below(3));
        }
        16 if !b.faces.is_empty() => {
            // A face's corners permuted or a corner repeated.
            let k = rng.below(b.faces.len());
            if rng.chance(0.5) {
                b.faces[k].rotate_left(1);
            } else {
                b.faces[k][2] = b.faces[k][0];
            }
        }
        _ => {
            // An extra point, used by nothing or by a new tet sticking out of the box.
            b.points.push([0, 1, 2].map(|_| coord(rng, 0.05)));
            if rng.chance(0.5) && !b.tets.is_empty() {
                let t = b.tets[rng.below(b.tets.len())];
                b.tets.push([t[0], t[1], t[2], np as u32]);
            }
        }
    }
}

/// One construction case: must return, with `Ok` or an error of the crate; a scene that builds
/// must cast. `Err(message)` when an invariant fails (a panic is caught by [`run`]).
pub fn construct_case(seed: u64) -> Result<(), String> {
    let mut rng = Rng::new(seed);
    let mut input = if rng.chance(0.3) {
        random_input(&mut rng)
    } else {
        let n = 1 + rng.below(2);
        let jitter = rng.pick(&[0.0, 0.3]);
        let frac = rng.pick(&[0.0, 0.2, 1.0]);
        let rng_inside = rng.chance(0.5);
        grid_input(&mut rng, n, jitter, frac, rng_inside)
    };
    for _ in 0..rng.below(4) {
        mutate(&mut rng, &mut input);
    }
    match input.build() {
        Err(
            Error::InvalidInput(_)
            | Error::InvalidMesh(_)
            | Error::TooLarge(_)
            | Error::InvalidOption(_)
            | Error::OutOfMemory { .. },
        ) => Ok(()),
        Err(e) => Err(format!("unexpected error from build: {e}")),
        Ok(scene) => {
            let scene = Arc::new(scene);
            let ntri = input.triangles.len();
            for _ in 0..2 {
                walk_once(&mut rng, &scene, ntri, false, false)?;
            }
            Ok(())
        }
    }
}

thread_local! {
    static SCENES: RefCell<HashMap<u64, (Arc<Scene>, usize)>> = RefCell::new(HashMap::new());
}

/// The walk's scenes: 48 valid ones, a function of `id` alone (cached per thread).
pub(crate) fn walk_scene(id: u64) -> (Arc<Scene>, usize) {
    SCENES.with(|s| {
        s.borrow_mut()
            .entry(id)
            .or_insert_with(|| {
                let mut rng = Rng::new(id ^ 0x5ce4e);
                let n = 1 + rng.below(3);
                let jitter = rng.pick(&[0.0, 0.3]);
                let frac = rng.pick(&[0.05, 0.3, 1.0]);
                let input = grid_input(&mut rng, n, jitter, frac, true);
                let ntri = input.triangles.len();
                let scene = input
                    .build()
                    .unwrap_or_else(|e| panic!("walk scene {id} does not build: {e}"));
                (Arc::new(scene), ntri)
            })
            .clone()
    })
}

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
fn walk_once(
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
        for accel in [
            AccelKind::ReshetovBvh,
            AccelKind::ReshetovBvhPackets(16),
            AccelKind::PortalezOctree,
        ] {
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

/// Which target a run drives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Target {
    Construct,
    Walk,
}

impl Target {
    pub fn name(self) -> &'static str {
        match self {
            Target::Construct => "construct",
            Target::Walk => "walk",
        }
    }
    pub fn case(self, seed: u64) -> Result<(), String> {
        match self {
            Target::Construct => construct_case(seed),
            Target::Walk => walk_case(seed),
        }
    }
}

/// A failed case: its seed (rerun with [`Target::case`]) and what happened.
#[derive(Clone, Debug)]
pub struct Failure {
    pub seed: u64,
    pub panicked: bool,
    pub message: String,
}

/// What a run did.
#[derive(Clone, Debug, Default)]
pub struct Report {
    pub cases: u64,
    pub panics: u64,
    pub violations: u64,
    pub failures: Vec<Failure>,
    pub seconds: f64,
    /// The slowest case: (seconds, seed).
    pub slowest: (f64, u64),
}

/// Runs cases `first..first + cases` of `target` seeded `seed`, catching panics; keeps the first
/// 20 failures. `progress` is called after each case with the case index and its seed (the
/// example's watchdog reads it).
pub fn run(
    target: Target,
    seed: u64,
    first: u64,
    cases: u64,
    mut progress: impl FnMut(u64, u64),
) -> Report {
    let mut r = Report::default();
    let start = Instant::now();
    for i in first..first + cases {
        let s = case_seed(seed, i);
        let t0 = Instant::now();
        let out = catch_unwind(AssertUnwindSafe(|| target.case(s)));
        let dt = t0.elapsed().as_secs_f64();
        if dt > r.slowest.0 {
            r.slowest = (dt, s);
        }
        r.cases += 1;
        let failure = match out {
            Ok(Ok(())) => None,
            Ok(Err(m)) => {
                r.violations += 1;
                Some((false, m))
            }
            Err(p) => {
                r.panics += 1;
                let m = p
                    .downcast_ref::<String>()
                    .cloned()
                    .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                    .unwrap_or_else(|| "a panic".into());
                Some((true, m))
            }
        };
        if let Some((panicked, message)) = failure {
            if r.failures.len() < 20 {
                r.failures.push(Failure {
                    seed: s,
                    panicked,
                    message,
                });
            }
        }
        progress(i, s);
    }
    r.seconds = start.elapsed().as_secs_f64();
    r
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bounded(target: Target, cases: u64) {
        let r = run(target, 18, 0, cases, |_, _| {});
        assert_eq!(r.cases, cases);
        assert!(
            r.failures.is_empty(),
            "{} fuzz: {} panics, {} violations; first: {:?}",
            target.name(),
            r.panics,
            r.violations,
            r.failures
        );
    }

    /// The walk case of docs/fuzzing.md's finding (seed 7686576272770016265, ray 957 of a
    /// 4097-ray batch): a ray aimed, up to rounding, at a mesh vertex meets an edge of
    /// triangles 3, 4, 5 at t = 1 exactly, then triangles 6 and 2 within an ulp after it (their
    /// float t, 1 − 2^-51 and 1 − 2^-49, below the edge's 1 + 2^-52). All hits sorted those by
    /// float t and listed triangle 2 first; by exact t the closest hit (triangle 3) is first.
    /// The case's other rays: 3873 (an origin 5e-324 off the box, `predicates::orient`) and
    /// 444 (a direction not scaled exactly by a power of two: INVALID).
    #[test]
    fn all_hits_first_is_the_closest_hit_at_a_vertex() {
        let seed = 7686576272770016265;
        assert_eq!(walk_case(seed), Ok(()));
    }

    /// CI's bounded fuzz run of construction (`examples/fuzz.rs` runs long ones).
    #[test]
    fn fuzz_construct_bounded() {
        bounded(Target::Construct, 30_000);
    }

    /// CI's bounded fuzz run of the walk.
    #[test]
    fn fuzz_walk_bounded() {
        bounded(Target::Walk, 20_000);
    }

    /// A case is a function of its seed.
    #[test]
    fn cases_are_reproducible() {
        let mut a = Rng::new(7);
        let mut b = Rng::new(7);
        let x = grid_input(&mut a, 2, 0.3, 0.5, true);
        let y = grid_input(&mut b, 2, 0.3, 0.5, true);
        assert_eq!(x.points, y.points);
        assert_eq!(x.faces, y.faces);
        assert_ne!(case_seed(1, 0), case_seed(1, 1));
    }

    /// Findings of the first 10^6-case walk run (seed 1), each a ray whose origin lies a
    /// denormal away from a box side: the exact walk answered HIT where the referee says MISS
    /// and the other way round (Shewchuk's expansions underflowed in point location; the box
    /// clip rounded a crossing at t = -1e-610 to 0). Every accelerator now gives the
    /// referee's answer.
    #[test]
    fn denormal_origins_match_the_referee() {
        use crate::scene::{CastOptions, HitBuffers, Rays};
        // (seed, origin, direction, tmin, tmax)
        type Finding = (u64, [f64; 3], [f64; 3], f64, f64);
        let cases: &[Finding] = &[
            (
                15170707697638007875,
                [5e-324, 0.20418553539762063, 0.0],
                [0.6666666865348816, 0.12914777806749778, 0.3333333134651184],
                0.046494830382286745,
                f64::INFINITY,
            ),
            (
                9501721720988945446,
                [0.0, 5e-324, -0.0],
                [0.3333333134651184, 0.6666666865348816, 0.3333333134651184],
                0.0,
                f64::INFINITY,
            ),
            (
                7014758399948156850,
                [5e-324, 0.875, 0.0],
                [0.6666666865348816, -0.875, 0.6666666865348816],
                0.0,
                f64::INFINITY,
            ),
            (
                12482544231945107241,
                [-1e-310, 0.6443455634490668, 0.3333333134651184],
                [-1e300, -0.125, -0.0027274804477304126],
                0.0,
                f64::INFINITY,
            ),
            (
                10402791658503384998,
                [5e-324, 0.6666666865348816, 0.3333333134651184],
                [0.2047655792209122, 0.0, 5e-324],
                0.0,
                f64::INFINITY,
            ),
            (
                7422549865166973907,
                [0.583486794418368, 0.3333333134651184, -1e-310],
                [0.16251957019581498, 1e-30, -1.7976931348623157e308],
                0.0,
                f64::INFINITY,
            ),
            (
                2871361342409064747,
                [5e-324, 0.6327969147063446, 0.0],
                [1.0, 0.0, 1.0],
                0.0,
                1.1615369703921898,
            ),
            (
                17536974435068399106,
                [0.0, 5e-324, 0.6209471514633451],
                [0.6666666865348816, 0.6666666865348816, -0.2876138379982267],
                0.0,
                0.8699396193472455,
            ),
        ];
        for &(seed, o, d, lo, hi) in cases {
            let (scene, _) = walk_scene(seed % 48);
            let tris = &scene.surface.triangles;
            let want = crate::referee::first_hit(o, d, lo, hi, tris);
            for accel in [
                AccelKind::TetWalk,
                AccelKind::ReshetovBvh,
                AccelKind::PortalezOctree,
            ] {
                let rays = Rays {
                    origins: &o[..],
                    directions: &d[..],
                    tmin: &[lo],
                    tmax: &[hi],
                    leaving: None,
                };
                let mut hb = HitBuffers::<f64>::new(1, false);
                let opts = CastOptions {
                    threads: Some(1),
                    accel,
                    ..Default::default()
                };
                scene.cast(&rays, hb.out(), &opts).unwrap();
                let got = (hb.status[0] == HIT).then(|| (hb.triangle[0] as usize, hb.t[0]));
                match &want {
                    None => assert_eq!(got, None, "seed {seed} {}", accel.name()),
                    Some(v) => {
                        let (tri, t) = got.unwrap_or_else(|| panic!("seed {seed}: MISS"));
                        assert!(v.ties.contains(&tri), "seed {seed} {}", accel.name());
                        assert_eq!(t, v.t, "seed {seed} {}", accel.name());
                    }
                }
            }
        }
    }
}
