//! Casting: from the names Python passes (through the method and layout tables) to one
//! monomorphized walk, run over 4096-ray chunks on the threads asked for.

use super::{check_lengths, check_ray_count, HitsOut, Rays, Scene};
use crate::accel::exact_bvh::Fan;
use crate::accel::{Accel, AccelVisitor, ExactBvh, TetWalk};
pub use crate::accel::{AccelKind, Lanes, Packets};
use crate::error::{Error, Result};
use crate::geom::real::Real;
use crate::layout::{Layout, LayoutKind, LayoutVisitor};
use crate::query::{chunks, AllHits, AnyHit, ClosestHit, Listed, QueryKind, Sink};
use crate::simd::Simd;
use crate::threads::run_pieces;
use crate::traverse::robust::ExactAudit;
use crate::traverse::{
    Exact, ExitMethod, Method, MethodVisitor, NoObserver, WalkObserver, WalkSetup,
};

/// How a cast runs; `CastOptions::default()` is what Python's defaults mean.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CastOptions {
    /// None: all cores (tetrace's fork-safe pool, `crate::threads`); Some(1): this thread
    /// only; at most [`crate::threads::max_threads`].
    pub threads: Option<usize>,
    /// The step guard; None: [`default_max_steps`] of the scene.
    pub max_steps: Option<u32>,
    /// Whether to walk rays in interleaved lanes (`accel::tetwalk`): answers are the same
    /// either way, bit for bit; only speed differs.
    pub lanes: Lanes,
    /// Whether rays sharing an origin walk as packets (`accel::Packets`): the same answers,
    /// bit for bit, either way.
    pub packets: Packets,
    /// The level of the kernels that have a vector version; None: the best the CPU runs,
    /// capped by `TETRACE_SIMD` ([`Simd::from_env`]). The same answers, bit for bit, at
    /// every level.
    pub simd: Option<Simd>,
    /// The acceleration structure: the tet walk, or a BVH over the caller's triangles
    /// (exact too; it ignores the layout and takes the exact method only).
    pub accel: AccelKind,
}

impl CastOptions {
    /// Refuses options no cast can run with.
    pub fn check(&self) -> Result<()> {
        crate::threads::check_threads(self.threads)
    }

    /// The SIMD level a cast runs at (see [`CastOptions::simd`]).
    pub fn simd_level(&self) -> Result<Simd> {
        match self.simd {
            Some(level) => Simd::checked(level),
            None => Simd::from_env(),
        }
    }

    /// The step guard for a mesh of `n_tets` tets.
    pub fn max_steps_for(&self, n_tets: usize) -> u32 {
        self.max_steps.unwrap_or_else(|| default_max_steps(n_tets))
    }
}

/// A valid walk visits each tet at most once, so the tet count bounds it; the cap keeps a
/// cycling ray in a huge mesh from costing seconds.
pub fn default_max_steps(n_tets: usize) -> u32 {
    (n_tets as u64 + 1).min(1 << 20) as u32
}

/// Rays per parallel task: large enough to amortize, small enough to balance, and contiguous
/// so coherent rays (a camera's) share their start-tet hints.
pub const CHUNK: usize = 4096;

/// Answers `query` for every ray of `rays` into `out` with `accel`, chunk by chunk on
/// `threads` (see [`CastOptions::threads`]). Each chunk starts from fresh accelerator state, so
/// answers do not depend on the thread count.
pub fn cast_accel<R: Real, W: Real, A: Accel<W>, K: QueryKind, S: Sink<K::Answer>>(
    accel: &A,
    query: &K,
    rays: &Rays<R>,
    out: S,
    threads: Option<usize>,
) -> Result<()> {
    let run_chunk = |(k, mut chunk): (usize, S)| {
        let mut state = accel.state(k);
        let base = k * CHUNK;
        // Inlined into the walk: as a call, the ray came back through memory, written in pieces,
        // and the accelerator's first wide read of it waited for those stores to retire.
        accel.trace_chunk(
            query,
            #[inline(always)]
            |j| rays.ray(base + j),
            &mut chunk,
            &mut state,
        );
    };
    let pieces: Vec<_> = chunks(out, CHUNK).into_iter().enumerate().collect();
    run_pieces(pieces, threads, run_chunk)
}

/// The fewest rays from one origin that the exact BVH's default answers through the fan
/// (`accel::exact_bvh::Fan`) rather than ray by ray.
pub const FAN_MIN_RAYS: usize = 1024;

/// The origin every ray of `rays` starts from, bit for bit, where it is finite (None: some
/// differ, there are none, or they start from hits): the fan's and the GPU's test for a
/// camera's batch.
pub(crate) fn shared_origin<R: Real>(rays: &Rays<R>, threads: Option<usize>) -> Option<[R; 3]> {
    if rays.is_empty() || rays.leaving.is_some() {
        return None;
    }
    let o: [R; 3] = rays.origins[..3].try_into().ok()?;
    (o.iter().all(|x| x.to_f64().is_finite()) && all_at(rays.origins, o, threads)).then_some(o)
}

/// Whether every origin in `origins` (x, y, z per ray) is `o`, bit for bit. A camera's millions
/// of origins are read on every thread of the cast (one thread read 2.8 million in 5.5 ms on
/// the H200's host, a tenth of the whole cast); rays with their own origins usually differ at
/// the second, which the first piece finds before any thread is woken.
pub(crate) fn all_at<R: Real>(origins: &[R], o: [R; 3], threads: Option<usize>) -> bool {
    use rayon::prelude::*;
    const PIECE: usize = 3 * 16_384;
    // Bits of the float64 value: exact from float32, so -0 and 0 differ in either precision.
    let bits = o.map(|x| x.to_f64().to_bits());
    let same = |c: &[R]| {
        c.chunks_exact(3)
            .all(|p| [0, 1, 2].map(|k| p[k].to_f64().to_bits()) == bits)
    };
    let (first, rest) = origins.split_at(origins.len().min(PIECE));
    if !same(first) {
        return false;
    }
    if rest.is_empty() {
        return true;
    }
    match crate::threads::pool(threads) {
        Ok(pool) => pool.install(|| rest.par_chunks(PIECE).all(same)),
        Err(_) => same(rest),
    }
}

/// What a cast writes: closest hits, any-hit statuses, or every hit.
enum Job<'a, R> {
    Closest(HitsOut<'a, R>),
    Any(&'a mut [u8]),
    All(&'a mut [Listed]),
}

impl Scene {
    /// Closest hits with the default method and layout.
    pub fn cast<R: Real>(&self, rays: &Rays<R>, out: HitsOut<R>, opts: &CastOptions) -> Result<()> {
        self.cast_with(Method::DEFAULT, LayoutKind::DEFAULT, rays, out, opts)
    }

    /// Closest hits with the method and layout named (the entry point of the bindings).
    pub fn cast_named<R: Real>(
        &self,
        method: &str,
        layout: &str,
        rays: &Rays<R>,
        out: HitsOut<R>,
        opts: &CastOptions,
    ) -> Result<()> {
        self.cast_with(
            Method::from_name(method)?,
            LayoutKind::from_name(layout)?,
            rays,
            out,
            opts,
        )
    }

    /// Closest hits with an exit method and layout, in the rays' precision R.
    pub fn cast_with<R: Real>(
        &self,
        method: Method,
        layout: LayoutKind,
        rays: &Rays<R>,
        out: HitsOut<R>,
        opts: &CastOptions,
    ) -> Result<()> {
        check_lengths(rays, &out)?;
        self.dispatch(method, layout, rays, Job::Closest(out), opts)
    }

    /// Any hit (occlusion): per ray HIT when a scene triangle lies on it within [tmin, tmax],
    /// else MISS (FAILED, INVALID as for closest hits).
    pub fn occluded<R: Real>(
        &self,
        method: Method,
        layout: LayoutKind,
        rays: &Rays<R>,
        out: &mut [u8],
        opts: &CastOptions,
    ) -> Result<()> {
        check_ray_count(rays, out.len())?;
        self.dispatch(method, layout, rays, Job::Any(out), opts)
    }

    /// Every point where each ray meets the surface in [tmin, tmax], sorted by t, each once
    /// (the exact walk only: the points at vertices and edges are its touches), walking the
    /// default layout.
    pub fn intersections<R: Real>(
        &self,
        rays: &Rays<R>,
        out: &mut [Listed],
        opts: &CastOptions,
    ) -> Result<()> {
        self.intersections_in(LayoutKind::DEFAULT, rays, out, opts)
    }

    /// [`Scene::intersections`] walking `layout` (the same answers on every layout).
    pub fn intersections_in<R: Real>(
        &self,
        layout: LayoutKind,
        rays: &Rays<R>,
        out: &mut [Listed],
        opts: &CastOptions,
    ) -> Result<()> {
        check_ray_count(rays, out.len())?;
        self.dispatch(Method::Exact, layout, rays, Job::All(out), opts)
    }

    fn dispatch<R: Real>(
        &self,
        method: Method,
        layout: LayoutKind,
        rays: &Rays<R>,
        job: Job<R>,
        opts: &CastOptions,
    ) -> Result<()> {
        opts.check()?;
        if let Some(leaving) = &rays.leaving {
            leaving.check(rays.len(), self.mesh.len())?;
            if method != Method::Exact {
                return Err(Error::InvalidOption(format!(
                    "rays started from hits (start=) need the exact method: it decides exactly \
                     that a ray's points lie beyond the triangle it leaves; {} cannot",
                    method.name()
                )));
            }
        }
        if opts.accel.tests_triangles() {
            return self.dispatch_tested(method, rays, job, opts);
        }
        let step = LayoutStep {
            scene: self,
            method,
            rays,
            job,
            opts,
        };
        self.layouts.visit(layout, &self.mesh, step)?
    }

    /// A cast on an accelerator that tests triangles (Reshetov's BVH, one ray at a time or in
    /// packets; Portalez's octree): exact, so only the exact method's name is taken.
    fn dispatch_tested<R: Real>(
        &self,
        method: Method,
        rays: &Rays<R>,
        job: Job<R>,
        opts: &CastOptions,
    ) -> Result<()> {
        if method != Method::Exact {
            return Err(Error::InvalidOption(format!(
                "accel {} tests triangles exactly and has no exit method; method {} is for the \
                 tet walk",
                opts.accel.name(),
                method.name()
            )));
        }
        if opts.accel == AccelKind::ExactBvh
            && opts.packets == Packets::Auto
            && rays.len() >= FAN_MIN_RAYS
        {
            if let Some(o) = shared_origin(rays, opts.threads) {
                let o = o.map(R::to_f64);
                let bvh = self.structures.get::<ExactBvh>(&self.surface.triangles)?;
                // The fan's build reads every triangle once: it pays for batches with more
                // rays than about half the triangles.
                if 2 * rays.len() >= bvh.triangles.len() {
                    let d = rays.directions;
                    let dir = |i: usize| [0, 1, 2].map(|k| d[3 * i + k].to_f64());
                    let simd = opts.simd_level()?;
                    if let Some(fan) = Fan::build(&bvh, simd, o, rays.len(), &dir, opts.threads) {
                        return self.cast_job(&fan, rays, job, opts);
                    }
                }
            }
        }
        let visit = CastOn {
            scene: self,
            rays,
            job,
            opts,
        };
        opts.accel
            .visit(
                &self.structures,
                &self.surface.triangles,
                opts.simd_level()?,
                visit,
            )
            .unwrap_or_else(|| unreachable!("the tet walk tests no triangles"))?
    }

    /// Every query kind on an accelerator that answers in float64 (the BVH's ways).
    fn cast_job<R: Real, A: Accel<f64>>(
        &self,
        accel: &A,
        rays: &Rays<R>,
        job: Job<R>,
        opts: &CastOptions,
    ) -> Result<()> {
        // Float32 answers may be rounded straight to float32 (the same bits).
        let closest = ClosestHit {
            narrow: (R::NAME == "f32").then(|| opts.simd_level()).transpose()?,
            ..self.closest()
        };
        match job {
            Job::Closest(out) => {
                if !out.audit.is_empty() {
                    return Err(Error::InvalidOption(format!(
                        "audit counts the tet walk's exit faces; accel {} has none",
                        A::NAME
                    )));
                }
                cast_accel::<R, f64, _, _, _>(accel, &closest, rays, out, opts.threads)
            }
            Job::Any(out) => {
                cast_accel::<R, f64, _, _, _>(accel, &AnyHit(closest), rays, out, opts.threads)
            }
            Job::All(out) => {
                cast_accel::<R, f64, _, _, _>(accel, &AllHits(closest), rays, out, opts.threads)
            }
        }
    }

    /// Closest hits with an explicit precision, layout and exit method (what the dispatch
    /// reaches, and what tests of one method call): rays in precision R, walked in W.
    pub fn cast_generic<R: Real, W: Real, L: Layout, M: ExitMethod<W>>(
        &self,
        points: &[[W; 3]],
        layout: &L,
        rays: &Rays<R>,
        out: HitsOut<R>,
        opts: &CastOptions,
    ) -> Result<()> {
        check_lengths(rays, &out)?;
        let query = self.closest();
        if out.audit.is_empty() {
            self.run::<R, W, L, M, NoObserver, _, _>(points, layout, &query, rays, out, opts)
        } else {
            self.run::<R, W, L, M, ExactAudit, _, _>(points, layout, &query, rays, out, opts)
        }
    }

    /// The tet walk (method M on layout L, observer O) answering `query` for every ray.
    fn run<R, W, L, M, O, K, S>(
        &self,
        points: &[[W; 3]],
        layout: &L,
        query: &K,
        rays: &Rays<R>,
        out: S,
        opts: &CastOptions,
    ) -> Result<()>
    where
        R: Real,
        W: Real,
        L: Layout,
        M: ExitMethod<W>,
        O: WalkObserver<W>,
        K: QueryKind,
        S: Sink<K::Answer>,
    {
        let setup = WalkSetup {
            layout,
            points,
            sides: &self.mesh.constrained,
            max_steps: opts.max_steps_for(self.mesh.len()),
        };
        let bvh = || self.exact_bvh();
        let walk = TetWalk::<W, L, M, O>::new(self.locators(), setup)
            .with_lanes(opts.lanes, opts.packets)
            .with_simd(opts.simd_level()?)
            .with_grazing(&bvh);
        cast_accel(&walk, query, rays, out, opts.threads)
    }
}

/// A cast on the accelerator the table hands over (`AccelKind::visit`).
struct CastOn<'a, R> {
    scene: &'a Scene,
    rays: &'a Rays<'a, R>,
    job: Job<'a, R>,
    opts: &'a CastOptions,
}

impl<R: Real> AccelVisitor for CastOn<'_, R> {
    type Out = Result<()>;
    fn visit<A: Accel<f64>>(self, accel: &A) -> Result<()> {
        self.scene.cast_job(accel, self.rays, self.job, self.opts)
    }
}

/// The dispatch's first half: the layout is known, now the method.
struct LayoutStep<'a, R> {
    scene: &'a Scene,
    method: Method,
    rays: &'a Rays<'a, R>,
    job: Job<'a, R>,
    opts: &'a CastOptions,
}

impl<R: Real> LayoutVisitor for LayoutStep<'_, R> {
    type Out = Result<()>;
    fn visit<L: Layout>(self, layout: &L) -> Result<()> {
        if L::INLINE && R::NAME != "f32" {
            return Err(Error::InvalidOption(format!(
                "layout {} stores float32 vertices (Maria et al.'s design) and serves precision \
                 f32 only",
                L::NAME
            )));
        }
        let step = MethodStep { step: self, layout };
        if step.step.method == Method::Exact && !L::INLINE {
            // The exact walk reads the mesh's float64 points whatever the rays' precision: the
            // mesh rounded to float32 is not the mesh (Steiner points move, tets may fold).
            return step.run::<f64, Exact>();
        }
        step.step.method.visit::<R, _>(step)
    }
}

/// The dispatch's second half: layout and method known, run the walk.
struct MethodStep<'a, 'b, R, L> {
    step: LayoutStep<'a, R>,
    layout: &'b L,
}

impl<R: Real, L: Layout> MethodVisitor<R> for MethodStep<'_, '_, R, L> {
    type Out = Result<()>;
    fn visit<M: ExitMethod<R>>(self) -> Result<()> {
        self.run::<R, M>()
    }
}

impl<R: Real, L: Layout> MethodStep<'_, '_, R, L> {
    /// Runs method M walking in precision W on rays of precision R.
    fn run<W: Real, M: ExitMethod<W>>(self) -> Result<()> {
        let LayoutStep {
            scene,
            rays,
            job,
            opts,
            ..
        } = self.step;
        let points = scene.points::<W>();
        match job {
            Job::Closest(out) => {
                scene.cast_generic::<R, W, L, M>(points, self.layout, rays, out, opts)
            }
            Job::Any(out) => {
                let query = AnyHit(scene.closest());
                scene.run::<R, W, L, M, NoObserver, _, _>(
                    points,
                    self.layout,
                    &query,
                    rays,
                    out,
                    opts,
                )
            }
            Job::All(out) => {
                if !M::CONTACTS {
                    return Err(Error::InvalidOption(format!(
                        "all hits and counts need the exact method, not {}",
                        M::NAME
                    )));
                }
                let query = AllHits(scene.closest());
                scene.run::<R, W, L, M, NoObserver, _, _>(
                    points,
                    self.layout,
                    &query,
                    rays,
                    out,
                    opts,
                )
            }
        }
    }
}
