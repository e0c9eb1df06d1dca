//! A scene ready to cast: topology, locator, traversal layout, and the caller's triangles for
//! evaluating hits. Casting is a pure function over slices so the bindings stay thin.

use crate::error::{Error, Result};
use crate::layout::Layout;
use crate::locate::{BoundaryLocator, GridLocator, Located};
use crate::mesh::TetMesh;
use crate::real::Real;
use crate::traverse::robust::ExactAudit;
use crate::traverse::{walk_observed, ExitMethod, NoObserver, Walk, WalkEnd, WalkObserver};
use rayon::prelude::*;

/// Per-ray status codes, shared with Python.
pub const MISS: u8 = 0;
pub const HIT: u8 = 1;
/// The walk could not finish (step guard, or no tet found for the start point).
pub const FAILED: u8 = 2;
/// The ray itself is unusable: a non-finite component or a zero-length direction.
pub const INVALID: u8 = 3;

pub struct Scene {
    pub mesh: TetMesh,
    pub locator: GridLocator,
    pub entry: BoundaryLocator,
    /// Traversal layouts, built on first use (see dispatch.rs).
    pub layouts: crate::dispatch::Layouts,
    pub points_f32: Vec<[f32; 3]>,
    /// The caller's triangles (three corners each), indexed by the ids constrained faces carry.
    pub triangles: Vec<[[f64; 3]; 3]>,
    /// Per caller triangle, the triangles a hit on a face naming it may lie on instead (empty
    /// for exact meshers; see [`Scene::set_alternatives`]).
    pub alternatives: Alternatives,
}

/// Triangles that may hold a hit instead of the one a constrained face names, in CSR form:
/// those of triangle `k` are `ids[offsets[k]..offsets[k + 1]]`.
#[derive(Clone, Debug, Default)]
pub struct Alternatives {
    pub offsets: Vec<u32>,
    pub ids: Vec<u32>,
}

impl Alternatives {
    #[inline]
    pub fn of(&self, triangle: u32) -> &[u32] {
        match self.offsets.get(triangle as usize..triangle as usize + 2) {
            Some(&[a, b]) => &self.ids[a as usize..b as usize],
            _ => &[],
        }
    }
}

/// Whether barycentric (u, v) at a finite t lie on the triangle, with a little slack for the
/// rounding of a hit on a shared edge.
#[inline]
fn on_triangle((t, u, v): (f64, f64, f64)) -> bool {
    const SLACK: f64 = 1e-9;
    t.is_finite() && u >= -SLACK && v >= -SLACK && u + v <= 1.0 + SLACK
}

/// Rays as flat slices of length 3N (origins, directions) in the walk's precision.
pub struct Rays<'a, R> {
    pub origins: &'a [R],
    pub directions: &'a [R],
    /// One value for all rays, or one per ray.
    pub tmin: &'a [f64],
    pub tmax: &'a [f64],
}

/// Output slices, one entry per ray (`point` has 3 per ray).
pub struct HitsOut<'a, R> {
    pub t: &'a mut [R],
    pub u: &'a mut [R],
    pub v: &'a mut [R],
    pub point: &'a mut [R],
    pub triangle: &'a mut [i32],
    pub tet: &'a mut [i32],
    pub steps: &'a mut [u32],
    pub status: &'a mut [u8],
    /// Empty, or two per ray to audit every step (see [`ExactAudit`]): exit faces taken that
    /// the exact predicates reject, and steps where the method found no exit face.
    pub audit: &'a mut [u32],
}

impl<'a, R> HitsOut<'a, R> {
    pub fn len(&self) -> usize {
        self.t.len()
    }

    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// Writes ray j's result (ray i of `rays`: the point is o + t d in f64, then rounded).
    #[inline]
    pub(crate) fn set(&mut self, j: usize, r: &RayHit, rays: &Rays<R>, i: usize)
    where
        R: Real,
    {
        self.t[j] = R::from_f64(r.t);
        self.u[j] = R::from_f64(r.u);
        self.v[j] = R::from_f64(r.v);
        for a in 0..3 {
            let (o, d) = (
                rays.origins[3 * i + a].to_f64(),
                rays.directions[3 * i + a].to_f64(),
            );
            self.point[3 * j + a] = R::from_f64(if r.status == HIT {
                o + r.t * d
            } else {
                f64::NAN
            });
        }
        self.triangle[j] = r.triangle;
        self.tet[j] = r.tet;
        self.steps[j] = r.steps;
        self.status[j] = r.status;
    }

    pub(crate) fn split_at(self, n: usize) -> (Self, Self) {
        let (t0, t1) = self.t.split_at_mut(n);
        let (u0, u1) = self.u.split_at_mut(n);
        let (v0, v1) = self.v.split_at_mut(n);
        let (p0, p1) = self.point.split_at_mut(3 * n);
        let (tr0, tr1) = self.triangle.split_at_mut(n);
        let (te0, te1) = self.tet.split_at_mut(n);
        let (s0, s1) = self.steps.split_at_mut(n);
        let (st0, st1) = self.status.split_at_mut(n);
        let (au0, au1) = self
            .audit
            .split_at_mut(if self.audit.is_empty() { 0 } else { 2 * n });
        (
            HitsOut {
                t: t0,
                u: u0,
                v: v0,
                point: p0,
                triangle: tr0,
                tet: te0,
                steps: s0,
                status: st0,
                audit: au0,
            },
            HitsOut {
                t: t1,
                u: u1,
                v: v1,
                point: p1,
                triangle: tr1,
                tet: te1,
                steps: s1,
                status: st1,
                audit: au1,
            },
        )
    }

    pub(crate) fn chunks(self, size: usize) -> Vec<Self> {
        let mut out = Vec::with_capacity(self.len().div_ceil(size.max(1)));
        let mut rest = self;
        while rest.len() > size {
            let (a, b) = rest.split_at(size);
            out.push(a);
            rest = b;
        }
        out.push(rest);
        out
    }
}

#[derive(Clone, Copy, Debug)]
pub struct CastOptions {
    /// None: all cores (rayon's global pool); Some(1): this thread only.
    pub threads: Option<usize>,
    pub max_steps: u32,
}

/// One ray's result before it is written out.
#[derive(Clone, Copy, Debug)]
pub(crate) struct RayHit {
    status: u8,
    t: f64,
    u: f64,
    v: f64,
    triangle: i32,
    tet: i32,
    steps: u32,
    audit: [u32; 2],
}

impl RayHit {
    pub(crate) fn nothing(status: u8) -> RayHit {
        RayHit {
            status,
            t: f64::INFINITY,
            u: f64::NAN,
            v: f64::NAN,
            triangle: -1,
            tet: -1,
            steps: 0,
            audit: [0, 0],
        }
    }
}

/// What a cast records of each walk besides its end: nothing, or the exact audit.
trait RayObserver<R: Real>: WalkObserver<R> {
    fn for_ray(start: [f64; 3], dir: [f64; 3], domain: &[[f64; 3]; 2]) -> Self;
    fn counts(&self) -> [u32; 2];
}

impl<R: Real> RayObserver<R> for NoObserver {
    #[inline(always)]
    fn for_ray(_: [f64; 3], _: [f64; 3], _: &[[f64; 3]; 2]) -> Self {
        NoObserver
    }
    #[inline(always)]
    fn counts(&self) -> [u32; 2] {
        [0, 0]
    }
}

impl<R: Real> RayObserver<R> for ExactAudit {
    fn for_ray(start: [f64; 3], dir: [f64; 3], domain: &[[f64; 3]; 2]) -> Self {
        ExactAudit::new::<R>(start, dir, domain)
    }
    fn counts(&self) -> [u32; 2] {
        [self.wrong_exits, self.no_exit]
    }
}

/// Rays per parallel task: large enough to amortize, small enough to balance, and contiguous
/// so coherent rays (a camera's) share their start-tet hints.
pub(crate) const CHUNK: usize = 4096;

impl Scene {
    /// Builds with points and tets in Hilbert order (see [`Scene::build_with`]).
    pub fn build(
        points: Vec<[f64; 3]>,
        tets: &[[u32; 4]],
        faces: &[[u32; 3]],
        face_triangle: &[u32],
        triangles: Vec<[[f64; 3]; 3]>,
    ) -> Result<Scene> {
        Scene::build_with(points, tets, faces, face_triangle, triangles, true)
    }

    /// `hilbert`: renumber points along a Hilbert curve and tets by region, then along the
    /// curve by centroid, so that the walk's memory accesses are local. Point and tet ids of the
    /// scene are then the new ones.
    pub fn build_with(
        points: Vec<[f64; 3]>,
        tets: &[[u32; 4]],
        faces: &[[u32; 3]],
        face_triangle: &[u32],
        triangles: Vec<[[f64; 3]; 3]>,
        hilbert: bool,
    ) -> Result<Scene> {
        if let Some(k) = face_triangle
            .iter()
            .position(|&t| t as usize >= triangles.len())
        {
            return Err(Error::InvalidInput(format!(
                "constrained face {k} names triangle {} but only {} triangles were given",
                face_triangle[k],
                triangles.len()
            )));
        }
        if let Some(k) = triangles
            .iter()
            .position(|t| !t.iter().flatten().all(|x| x.is_finite()))
        {
            return Err(Error::InvalidInput(format!(
                "triangle {k} has a non-finite corner"
            )));
        }
        let np = points.len() as u64;
        let in_range = tets
            .iter()
            .flatten()
            .chain(faces.iter().flatten())
            .all(|&v| (v as u64) < np);
        let mesh = if hilbert && in_range && points.iter().flatten().all(|x| x.is_finite()) {
            // Build once unordered to find the regions, then again in Hilbert order within
            // regions: construction is cheap next to meshing (bunny: ~0.1 s).
            let unordered = TetMesh::build(points, tets, faces, face_triangle)?;
            let regions = unordered.regions();
            let (p, t, f, _) = crate::sort::hilbert::reorder(
                &unordered.points,
                &unordered.tets,
                faces,
                unordered.bounds,
                Some(&regions),
            );
            TetMesh::build(p, &t, &f, face_triangle)?
        } else {
            // Out-of-range or non-finite input: let build() name the problem.
            TetMesh::build(points, tets, faces, face_triangle)?
        };
        if !mesh.domain_is_box {
            return Err(Error::InvalidMesh(
                "some boundary faces do not lie on the bounding box: the domain must be a box \
                 (tetrace.meshing wraps scenes in one)"
                    .into(),
            ));
        }
        let locator = GridLocator::build(&mesh);
        let entry = BoundaryLocator::build(&mesh);
        let points_f32 = mesh.points.iter().map(|p| p.map(|x| x as f32)).collect();
        let scene = Scene {
            mesh,
            locator,
            entry,
            layouts: Default::default(),
            points_f32,
            triangles,
            alternatives: Alternatives::default(),
        };
        scene
            .layouts
            .prepare(crate::dispatch::DEFAULT_LAYOUT, &scene.mesh)?;
        Ok(scene)
    }

    /// Lets hits name another triangle than the constrained face's own: of `offsets` (one
    /// per caller triangle, plus one) and `ids` (CSR, see [`Alternatives`]). For meshers whose
    /// faces lie near the input rather than on it (fTetWild): a face names the triangle
    /// nearest its centre, but a ray through it may cross a neighbour of that triangle; the
    /// hit then names the alternative the ray crosses nearest the face.
    pub fn set_alternatives(&mut self, offsets: Vec<u32>, ids: Vec<u32>) -> Result<()> {
        let n = self.triangles.len();
        if offsets.len() != n + 1 {
            return Err(Error::InvalidInput(format!(
                "alternatives: {} offsets for {n} triangles (expected {})",
                offsets.len(),
                n + 1
            )));
        }
        if offsets[0] != 0
            || offsets.windows(2).any(|w| w[0] > w[1])
            || offsets[n] as usize != ids.len()
        {
            return Err(Error::InvalidInput(
                "alternatives: offsets must rise from 0 to the number of ids".into(),
            ));
        }
        if let Some(k) = ids.iter().position(|&t| t as usize >= n) {
            return Err(Error::InvalidInput(format!(
                "alternatives: id {k} names triangle {} but only {n} triangles were given",
                ids[k]
            )));
        }
        self.alternatives = Alternatives { offsets, ids };
        Ok(())
    }

    /// The caller's triangle a hit on a constrained face lies on, and (t, u, v) on it: of the
    /// named one and its alternatives, the one the ray crosses nearest the face (the named
    /// one when the ray crosses none of them).
    fn hit_triangle(
        &self,
        s: &WalkStart,
        named: u32,
        face: impl Fn() -> [[f64; 3]; 3],
    ) -> (u32, (f64, f64, f64)) {
        let on_named = intersect_triangle(s.o, s.d, &self.triangles[named as usize], &face);
        let alternatives = self.alternatives.of(named);
        if alternatives.is_empty() {
            return (named, on_named);
        }
        // Of the named triangle and its alternatives, the one the ray crosses nearest to
        // where it crosses the face (the named one may be crossed too, farther away).
        use glam::DVec3;
        let [a, b, c] = face().map(DVec3::from);
        let (o, d) = (DVec3::from(s.o), DVec3::from(s.d));
        let n = (b - a).cross(c - a);
        let t_face = n.dot(a - o) / n.dot(d);
        let mut best = (named, on_named);
        let mut best_gap = if on_triangle(on_named) {
            (on_named.0 - t_face).abs()
        } else {
            f64::INFINITY
        };
        // Crossed within a face's size of the face: the named triangle is the one (most
        // hits; the alternatives are then not tried).
        let size = (b - a).length().max((c - b).length()).max((a - c).length());
        if best_gap * d.length() <= size {
            return best;
        }
        for &alt in alternatives {
            let hit = intersect_triangle(s.o, s.d, &self.triangles[alt as usize], &face);
            let gap = (hit.0 - t_face).abs();
            if on_triangle(hit) && gap < best_gap {
                (best, best_gap) = ((alt, hit), gap);
            }
        }
        best
    }

    /// Bytes of each part: (points, tets of the traversal layout, constrained table, locator).
    /// Bytes of each part: points (both precisions), the constrained-side table, the locator
    /// (seed grid, boundary grid and the topology location walks on), and the records of each
    /// traversal layout built so far (as `tets_<name>`).
    pub fn memory(&self) -> Vec<(String, usize)> {
        let mut m = vec![
            ("points_f64".to_string(), self.mesh.points.len() * 24),
            ("points_f32".to_string(), self.points_f32.len() * 12),
            (
                "constrained".to_string(),
                self.mesh.constrained.len() * 8
                    + (self.alternatives.offsets.len() + self.alternatives.ids.len()) * 4,
            ),
            (
                "locator".to_string(),
                self.locator.bytes() + self.entry.bytes() + self.mesh.tets.len() * 32,
            ),
        ];
        m.extend(
            self.layouts
                .built()
                .into_iter()
                .map(|(n, b)| (format!("tets_{n}"), b)),
        );
        m
    }

    /// Casts with the default method and layout, in the rays' precision R.
    pub fn cast<R: crate::dispatch::Precision>(
        &self,
        rays: &Rays<R>,
        out: HitsOut<R>,
        opts: &CastOptions,
    ) -> Result<()> {
        self.cast_named(
            crate::dispatch::DEFAULT_METHOD,
            crate::dispatch::DEFAULT_LAYOUT,
            rays,
            out,
            opts,
        )
    }

    /// Casts with an explicit precision, layout and exit method (the dispatch of the public
    /// entry points, and what tests of each method call).
    pub fn cast_generic<R: Real, L: Layout, M: ExitMethod<R>>(
        &self,
        points: &[[R; 3]],
        layout: &L,
        rays: &Rays<R>,
        out: HitsOut<R>,
        opts: &CastOptions,
    ) -> Result<()> {
        check_lengths(rays, &out)?;
        if out.audit.is_empty() {
            self.cast_observed::<R, L, M, NoObserver>(points, layout, rays, out, opts)
        } else {
            self.cast_observed::<R, L, M, ExactAudit>(points, layout, rays, out, opts)
        }
    }

    fn cast_observed<R: Real, L: Layout, M: ExitMethod<R>, O: RayObserver<R>>(
        &self,
        points: &[[R; 3]],
        layout: &L,
        rays: &Rays<R>,
        out: HitsOut<R>,
        opts: &CastOptions,
    ) -> Result<()> {
        let run_chunk = |(k, mut chunk): (usize, HitsOut<R>)| {
            let mut hint = None;
            let mut rng = chunk_seed(k);
            let mut camera: Option<([f64; 3], f64, u32)> = None;
            let mut entry_hint = None;
            let base = k * CHUNK;
            for j in 0..chunk.len() {
                let i = base + j;
                let r = self.cast_one::<R, L, M, O>(
                    points,
                    layout,
                    rays,
                    i,
                    opts,
                    &mut hint,
                    &mut camera,
                    &mut entry_hint,
                    &mut rng,
                );
                chunk.set(j, &r, rays, i);
                if O::ACTIVE {
                    chunk.audit[2 * j..2 * j + 2].copy_from_slice(&r.audit);
                }
            }
        };
        let chunks: Vec<_> = out.chunks(CHUNK).into_iter().enumerate().collect();
        match opts.threads {
            Some(1) => chunks.into_iter().for_each(run_chunk),
            None => chunks.into_par_iter().for_each(run_chunk),
            Some(k) => rayon::ThreadPoolBuilder::new()
                .num_threads(k)
                .build()
                .map_err(|e| Error::InvalidOption(format!("cannot start {k} threads: {e}")))?
                .install(|| chunks.into_par_iter().for_each(run_chunk)),
        }
        Ok(())
    }

    #[allow(clippy::too_many_arguments)]
    #[inline]
    fn cast_one<R: Real, L: Layout, M: ExitMethod<R>, O: RayObserver<R>>(
        &self,
        points: &[[R; 3]],
        layout: &L,
        rays: &Rays<R>,
        i: usize,
        opts: &CastOptions,
        hint: &mut Option<u32>,
        camera: &mut Option<([f64; 3], f64, u32)>,
        entry_hint: &mut Option<(usize, usize)>,
        rng: &mut u32,
    ) -> RayHit {
        let settle = M::PERTURBED_START.then_some(points);
        let s = match self.locate_one(rays, i, settle, hint, camera, entry_hint, rng) {
            Start::Done(r) => return r,
            Start::Walk(s) => s,
        };
        let ray = s.prepare::<R, M>(&self.mesh);
        let mut observer = O::for_ray(s.point, s.dir, &self.mesh.bounds);
        let w = walk_observed::<R, L, M, O>(
            layout,
            points,
            &ray,
            s.tet,
            self.mesh.tets[s.tet as usize],
            s.entry,
            opts.max_steps,
            &mut observer,
        );
        RayHit {
            audit: observer.counts(),
            ..self.finish(&s, &w)
        }
    }

    /// Where ray i's walk starts (the first half of a cast; the GPU path walks elsewhere and
    /// comes back to [`Scene::finish`]). The hints carry state between neighbouring rays of a
    /// chunk, as in `cast_generic`. `settle`: the points the walk reads, for a method whose
    /// walk starts at the perturbed start point ([`ExitMethod::PERTURBED_START`]): the start,
    /// inside the box or entering it, then moves to the tet holding that point
    /// (`robust::settle_start`), with no entry face (the method's start exit decides).
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub(crate) fn locate_one<R: Real>(
        &self,
        rays: &Rays<R>,
        i: usize,
        settle: Option<&[[R; 3]]>,
        hint: &mut Option<u32>,
        camera: &mut Option<([f64; 3], f64, u32)>,
        entry_hint: &mut Option<(usize, usize)>,
        rng: &mut u32,
    ) -> Start {
        let o = [0, 1, 2].map(|a| rays.origins[3 * i + a].to_f64());
        let d = [0, 1, 2].map(|a| rays.directions[3 * i + a].to_f64());
        let tmin = rays.tmin[if rays.tmin.len() == 1 { 0 } else { i }];
        let tmax = rays.tmax[if rays.tmax.len() == 1 { 0 } else { i }];
        let finite = o.iter().chain(&d).all(|x| x.is_finite());
        if !finite || d == [0.0; 3] || tmin.is_nan() || tmax.is_nan() {
            return Start::Done(RayHit::nothing(INVALID));
        }
        let tmin = tmin.max(0.0);
        if tmax < tmin {
            return Start::Done(RayHit::nothing(MISS));
        }
        let mesh = &self.mesh;
        // Where the walk starts: o + tmin d if that is inside, else where the ray enters the box.
        let at = |s: f64| [0, 1, 2].map(|a| o[a] + s * d[a]);
        let mut start_point = at(tmin);
        let [lo, hi] = mesh.bounds;
        let inside = (0..3).all(|a| start_point[a] >= lo[a] && start_point[a] <= hi[a]);
        let mut entry_face = None;
        let start = if inside {
            match camera {
                Some((co, ct, t)) if *co == o && *ct == tmin => Located::Inside(*t),
                _ => {
                    let mut l = self.locator.locate(mesh, start_point, *hint, rng);
                    if let (Some(points), Located::Inside(t)) = (settle, l) {
                        // Depends on the start point only: cached with the camera's tet.
                        l = Located::Inside(crate::traverse::robust::settle_start(
                            mesh,
                            points,
                            t,
                            start_point,
                        ));
                    }
                    if let Located::Inside(t) = l {
                        *camera = Some((o, tmin, t));
                    }
                    l
                }
            }
        } else {
            let Some(entry) = clip_box(o, d, lo, hi, tmin, tmax) else {
                return Start::Done(RayHit::nothing(MISS));
            };
            // Clamp: rounding may leave the entry point a hair off the box side.
            start_point = at(entry.t0);
            for a in 0..3 {
                start_point[a] = start_point[a].clamp(lo[a], hi[a]);
            }
            match entry.side {
                Some((axis, high)) => {
                    start_point[axis] = if high { hi[axis] } else { lo[axis] };
                    match self.entry.locate(start_point, axis, high, entry_hint) {
                        Some((t, i)) => {
                            entry_face = Some(i);
                            Located::Inside(t)
                        }
                        None => self.locator.locate(mesh, start_point, *hint, rng),
                    }
                }
                None => self.locator.locate(mesh, start_point, *hint, rng),
            }
        };
        let Located::Inside(mut start) = start else {
            // Inside the box but no tet holds the point: only a broken mesh can do this.
            return Start::Done(RayHit::nothing(if inside { FAILED } else { MISS }));
        };
        *hint = Some(start);
        if let (Some(points), false) = (settle, inside) {
            // Entering through the box: the perturbed start lies just inside it, in the tet
            // settle_start finds; the exit from there is the method's to decide.
            start = crate::traverse::robust::settle_start(mesh, points, start, start_point);
            entry_face = None;
        }
        Start::Walk(WalkStart {
            o,
            d,
            // The walk needs only the direction: scaled exactly, tiny and huge ones behave.
            dir: crate::real::unit_scale(d),
            tmin,
            tmax,
            point: start_point,
            tet: start,
            entry: entry_face,
        })
    }

    /// The second half of a cast: the hit of a finished walk, evaluated in f64 on the
    /// caller's triangle.
    #[inline]
    pub(crate) fn finish(&self, s: &WalkStart, w: &Walk) -> RayHit {
        let mesh = &self.mesh;
        let mut r = RayHit {
            tet: w.tet as i32,
            steps: w.steps,
            ..RayHit::nothing(MISS)
        };
        match w.end {
            WalkEnd::Boundary => {}
            WalkEnd::StepLimit => r.status = FAILED,
            WalkEnd::Hit { constrained } => {
                let named = mesh.constrained[constrained as usize].triangle;
                let ids = if w.slots {
                    w.face.map(|k| mesh.tets[w.tet as usize][k as usize])
                } else {
                    w.face
                };
                let face = || ids.map(|v| mesh.points[v as usize]);
                let (tri, (t, u, v)) = self.hit_triangle(s, named, face);
                if t <= s.tmax {
                    r = RayHit {
                        status: HIT,
                        t: t.max(s.tmin),
                        u,
                        v,
                        triangle: tri as i32,
                        ..r
                    };
                }
            }
        }
        r
    }
}

/// Where a ray's walk starts, once located.
#[derive(Clone, Copy, Debug)]
pub(crate) struct WalkStart {
    /// The ray as given (origin, direction) and its clamped [tmin, tmax].
    pub o: [f64; 3],
    pub d: [f64; 3],
    /// `d` scaled by a power of two (`real::unit_scale`, exact): what the walk is prepared with.
    pub dir: [f64; 3],
    pub tmin: f64,
    pub tmax: f64,
    /// The point the walk starts from (o + tmin d, or the entry point on the box).
    pub point: [f64; 3],
    pub tet: u32,
    /// The face of `tet` the ray enters by, when it comes from outside the box (never for a
    /// method with a perturbed start: its entry is settled like an interior start).
    pub entry: Option<usize>,
}

impl WalkStart {
    /// The ray as method M's walk takes it (the CPU cast's and the GPU kernels' preparation).
    #[inline]
    pub(crate) fn prepare<R: Real, M: ExitMethod<R>>(&self, mesh: &TetMesh) -> M::Ray {
        M::prepare(self.point, self.dir, &mesh.bounds)
    }
}

/// A located ray: either done already (invalid, missing the box, ...) or ready to walk.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Start {
    Done(RayHit),
    Walk(WalkStart),
}

/// The locator's random state for chunk k (a fixed seed per chunk: casts are reproducible).
#[inline]
pub(crate) fn chunk_seed(k: usize) -> u32 {
    0x9E37_79B9u32 ^ (k as u32).wrapping_mul(0x85EB_CA6B) | 1
}

/// Rays and outputs of one cast have matching lengths (the audit: empty or 2 per ray).
pub(crate) fn check_lengths<R>(rays: &Rays<R>, out: &HitsOut<R>) -> Result<()> {
    let n = out.len();
    if rays.origins.len() != 3 * n || rays.directions.len() != 3 * n || out.point.len() != 3 * n {
        return Err(Error::InvalidInput(format!(
            "{} rays expected 3N origin and direction values, got {} and {}",
            n,
            rays.origins.len(),
            rays.directions.len()
        )));
    }
    for (name, b) in [("tmin", rays.tmin), ("tmax", rays.tmax)] {
        if b.len() != 1 && b.len() != n {
            return Err(Error::InvalidInput(format!(
                "{name} needs 1 or {n} values, got {}",
                b.len()
            )));
        }
    }
    if !out.audit.is_empty() && out.audit.len() != 2 * n {
        return Err(Error::InvalidInput(format!(
            "the audit needs 2 values per ray ({}), got {}",
            2 * n,
            out.audit.len()
        )));
    }
    Ok(())
}

/// Where a ray meets the domain box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoxSpan {
    pub t0: f64,
    pub t1: f64,
    /// The side it enters by (axis, high side), or None when it starts inside.
    pub side: Option<(usize, bool)>,
}

/// The parameter range where the ray o + t d is inside the box, within [tmin, tmax].
pub fn clip_box(
    o: [f64; 3],
    d: [f64; 3],
    lo: [f64; 3],
    hi: [f64; 3],
    tmin: f64,
    tmax: f64,
) -> Option<BoxSpan> {
    let (mut t0, mut t1) = (tmin, tmax);
    let mut side = None;
    for a in 0..3 {
        let inv = 1.0 / d[a];
        let (mut n, mut f) = ((lo[a] - o[a]) * inv, (hi[a] - o[a]) * inv);
        if n > f {
            std::mem::swap(&mut n, &mut f);
        }
        // 0 * inf is NaN when the ray is parallel and on a slab plane: treat as inside.
        if !n.is_nan() && n > t0 {
            t0 = n;
            side = Some((a, d[a] < 0.0));
        }
        if !f.is_nan() {
            t1 = t1.min(f);
        }
    }
    (t0 <= t1).then_some(BoxSpan { t0, t1, side })
}

/// t and barycentrics (u, v) of the ray on the caller's triangle (Möller–Trumbore in f64, no
/// culling). The walk already decided that the ray crosses `face`, a piece of that triangle; if
/// the ray lies in the triangle's plane, the face's centroid gives t instead (fetched only
/// then: three point loads per hit are not free).
pub fn intersect_triangle(
    o: [f64; 3],
    d: [f64; 3],
    tri: &[[f64; 3]; 3],
    face: impl FnOnce() -> [[f64; 3]; 3],
) -> (f64, f64, f64) {
    use glam::DVec3;
    let (o, d) = (DVec3::from(o), DVec3::from(d));
    let [p0, p1, p2] = tri.map(DVec3::from);
    let (e1, e2) = (p1 - p0, p2 - p0);
    let pv = d.cross(e2);
    let det = e1.dot(pv);
    // |det| > 1e-14 |e1| |e2| |d|, squared to avoid three square roots per hit.
    let scale2 = e1.length_squared() * e2.length_squared() * d.length_squared();
    if det * det > 1e-28 * scale2 {
        let inv = 1.0 / det;
        let tv = o - p0;
        let u = tv.dot(pv) * inv;
        let qv = tv.cross(e1);
        let v = d.dot(qv) * inv;
        let t = e2.dot(qv) * inv;
        (t, u, v)
    } else {
        let face = face();
        let c = (DVec3::from(face[0]) + DVec3::from(face[1]) + DVec3::from(face[2])) / 3.0;
        let t = (c - o).dot(d) / d.length_squared();
        (t, 1.0 / 3.0, 1.0 / 3.0)
    }
}
