//! Casting on the device: the CPU locates each ray's start (`Scene::locate_one`, the same code
//! and the same chunks as the CPU cast), prepares it as the kernel's CPU twin would
//! (`KernelSpec::prepare`), the GPU walks batches of rays (`launch.rs`), and the CPU finishes
//! each hit on the caller's triangle (`Scene::finish`). Rays a kernel defers (the robust
//! filter's) are walked again on the CPU from the same start.
//!
//! The exact kernel (the default) splits the CPU exact walk instead: the CPU begins each walk
//! (`TetWalk::begin_elsewhere`: location, the origin's touch, the first exit), the GPU takes
//! the plain steps it can certify, and the CPU walks on from where the GPU stopped
//! (`TetWalk::walk_on_from`): at the face its query decides, or at a step the GPU could not
//! certify. Every answer is the CPU exact walk's. Batches from one origin take the
//! shared-origin kernel (`cast_shared`), which also begins the walks and finishes the hits it
//! can certify (`gpu::finish`): the host walks on only the rest.

use super::context::{gpu, Gpu};
use super::device_scene::DeviceScene;
use super::kernels::{KernelSpec, OWN_ORIGINS, SHARED_ORIGIN};
use super::launch::{Batching, Launch, RunBuffers};
use super::origin::finished_hit;
use super::origin::{boundary_miss, own_origins, plain_state, shared_at, shared_origin};
use super::structs::{
    RayIn, RayOut, Shared, END_BOUNDARY, END_DEFERRED, END_FINISHED, END_HIT, END_MISS_BOX,
    END_UNBEGUN,
};
use super::timings::GpuTimings;
use super::upload::LayoutBuffers;
use crate::accel::TetWalk;
use crate::camera::CameraF32;
use crate::error::{Error, Result};
use crate::geom::ray::{checked_range, Ray};
use crate::layout::Tet20;
use crate::locate::{LocateState, Start, WalkStart, GRAZES};
use crate::query::{Listed, QueryKind, RayHit, Sink};
use crate::scene::CastOptions;
use crate::scene::{check_lengths, check_ray_count, HitsOut, Rays, Scene, CHUNK};
use crate::threads::run_pieces;
use crate::traverse::{Exact, NoObserver, Walk, WalkEnd, WalkSetup};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

/// A chunk's rays that walk: their index in the chunk and start, and as the kernel takes them.
type Located = (Vec<(u32, WalkStart)>, Vec<RayIn>);

impl DeviceScene {
    /// Casts float32 rays through `scene` on the GPU with the kernel for `method` and `layout`
    /// (None: the default kernel, Aman et al. 2022 on Tet20), uploading the scene's buffers
    /// for that layout on first use. Fills `out` exactly as [`Scene::cast_named`] does;
    /// `opts.threads` applies to the CPU's parts (location, finishing).
    pub fn cast(
        &self,
        scene: &Scene,
        method: Option<&str>,
        layout: Option<&str>,
        rays: &Rays<f32>,
        out: HitsOut<f32>,
        opts: &CastOptions,
    ) -> Result<GpuTimings> {
        let kernel = KernelSpec::find(method, layout)?;
        self.cast_with(scene, kernel, rays, out, opts, Batching::default())
    }

    /// [`DeviceScene::cast`] of a camera's rays with the exact kernel (the default), with no
    /// rays on the host: the camera `cam` at `eye`, every ray in `[tmin, tmax]`. Where the
    /// shared-origin kernel takes the eye and the camera kernel the camera
    /// ([`CameraF32::fits_device`]), the directions are made on the device and the host
    /// makes only those of the rays the device hands back (the twin's, one at a time);
    /// otherwise it makes every ray and casts them as any rays. The same answers either way.
    pub fn cast_camera_at(
        &self,
        scene: &Scene,
        cam: &CameraF32,
        eye: [f32; 3],
        range: (f64, f64),
        out: HitsOut<f32>,
        opts: &CastOptions,
    ) -> Result<GpuTimings> {
        self.cast_camera_at_with(scene, cam, eye, range, out, opts, Batching::default())
    }

    /// [`DeviceScene::cast_camera_at`] with a given batching.
    #[allow(clippy::too_many_arguments)] // a camera cast's parts, and the batching tests set
    pub(crate) fn cast_camera_at_with(
        &self,
        scene: &Scene,
        cam: &CameraF32,
        eye: [f32; 3],
        (tmin, tmax): (f64, f64),
        out: HitsOut<f32>,
        opts: &CastOptions,
        batching: Batching,
    ) -> Result<GpuTimings> {
        cam.check()?;
        let n = cam.n_rays();
        if out.len() != n || out.point.len() != 3 * n || !out.audit.is_empty() {
            return Err(Error::InvalidInput(format!(
                "a camera of {n} pixels needs {n} answers and no audit"
            )));
        }
        let rays = HostRays::Camera {
            cam,
            eye,
            tmin,
            tmax,
        };
        let kernel = KernelSpec::find(None, None)?;
        let t0 = Instant::now();
        let mut out = Some(out);
        let timings = self.on_device(scene, kernel, opts, batching, |device, timings| {
            let slack = device.scene.points_slack;
            let shared = cam
                .fits_device()
                .then(|| shared_at(scene, eye.map(f64::from), &scene.closest(), slack))
                .flatten();
            match (shared, out.take()) {
                (Some(shared), Some(o)) => self.cast_shared(
                    scene,
                    &scene.closest(),
                    device,
                    (&SHARED_ORIGIN, shared, t0),
                    rays,
                    o,
                    opts,
                    timings,
                ),
                (_, o) => {
                    out = o; // not taken: made on the host below
                    Ok(())
                }
            }
        })?;
        let Some(out) = out else {
            return Ok(timings);
        };
        let directions = crate::camera::directions(cam, opts.threads)?;
        let mut origins = crate::error::try_with_capacity(3 * n, "the camera's origins")?;
        for _ in 0..n {
            origins.extend(eye);
        }
        let given = Rays {
            origins: &origins,
            directions: &directions,
            tmin: &[tmin],
            tmax: &[tmax],
            leaving: None,
        };
        self.cast_with(scene, kernel, &given, out, opts, batching)
    }

    /// [`DeviceScene::cast`] with a given kernel and batching.
    pub(crate) fn cast_with(
        &self,
        scene: &Scene,
        kernel: &KernelSpec,
        rays: &Rays<f32>,
        out: HitsOut<f32>,
        opts: &CastOptions,
        batching: Batching,
    ) -> Result<GpuTimings> {
        check_lengths(rays, &out)?;
        if rays.leaving.is_some() && !kernel.resumes {
            return Err(Error::InvalidOption(format!(
                "start=hits on the GPU takes the exact kernel (the default), which begins each \
                 ray where the CPU exact walk does; the {}/{} kernel has no such start",
                kernel.method, kernel.layout.name
            )));
        }
        if !out.audit.is_empty() {
            return Err(Error::InvalidOption(
                "the exact audit observes the CPU walk: cast with device=\"cpu\" to audit".into(),
            ));
        }
        self.on_device(scene, kernel, opts, batching, |device, timings| {
            if kernel.resumes {
                let query = scene.closest();
                return self.exact(scene, &query, kernel, device, rays, out, opts, timings);
            }
            // Rays the kernel defers (the robust filter's) walk again on the CPU from their
            // start.
            let cpu_walk = kernel.deferred_to.map(|f| f(scene)).transpose()?;
            device.cast(
                out,
                opts,
                timings,
                |k, chunk| locate_chunk(scene, kernel, rays, k, chunk),
                |s, o| {
                    let w = if o.end == END_DEFERRED {
                        let cpu_walk = cpu_walk
                            .as_ref()
                            .expect("only kernels with a CPU walk defer rays");
                        cpu_walk(s, device.max_steps)
                    } else {
                        gpu_walk(kernel, o)
                    };
                    scene.finish(s, &w)
                },
            )
        })
    }

    /// Occlusion of float32 rays on the GPU (shadow rays, `Scene.occluded`): `out[i]` is HIT
    /// when a scene triangle lies on ray i in [tmin, tmax], else MISS (or the status of a ray
    /// that did not walk). The exact kernel with the any-hit query, as the closest hit's
    /// cast takes it ([`DeviceScene::exact`]): rays from one origin or with their own begin on
    /// the device, which answers the rays whose first meet it certifies; the CPU exact walk
    /// answers the others from where the device handed them back (or begins them: rays from
    /// hits, and rays the device could not begin). Every status is the CPU exact walk's.
    pub fn occluded(
        &self,
        scene: &Scene,
        rays: &Rays<f32>,
        out: &mut [u8],
        opts: &CastOptions,
    ) -> Result<GpuTimings> {
        check_ray_count(rays, out.len())?;
        let query = crate::query::AnyHit(scene.closest());
        self.exact_query(scene, &query, rays, out, opts)
    }

    /// Every point where each float32 ray meets the surface in [tmin, tmax]
    /// (`Scene.intersections`, and `count_intersections` counts them): the exact kernels
    /// with the all-hits query ([`DeviceScene::exact`]). The GPU begins each walk where it
    /// can (else the host does) and takes the plain steps to the first constrained face,
    /// where it hands the walk back (it finishes no hit: the walk goes on); the CPU exact
    /// walk lists that face's points and walks on from there, so every list is the CPU exact
    /// walk's.
    pub fn intersections(
        &self,
        scene: &Scene,
        rays: &Rays<f32>,
        out: &mut [Listed],
        opts: &CastOptions,
    ) -> Result<GpuTimings> {
        check_ray_count(rays, out.len())?;
        let query = crate::query::AllHits(scene.closest());
        self.exact_query(scene, &query, rays, out, opts)
    }

    /// `query` on the exact kernels ([`DeviceScene::exact`]).
    fn exact_query<K: EndsOnDevice, S: Sink<K::Answer>>(
        &self,
        scene: &Scene,
        query: &K,
        rays: &Rays<f32>,
        out: S,
        opts: &CastOptions,
    ) -> Result<GpuTimings> {
        let kernel = KernelSpec::find(Some("exact"), Some("tet20"))?;
        self.on_device(
            scene,
            kernel,
            opts,
            Batching::default(),
            |device, timings| self.exact(scene, query, kernel, device, rays, out, opts, timings),
        )
    }

    /// `query` on the exact kernel: rays from one origin take the shared-origin kernel, others
    /// with their own origins the own-origin kernel, where each can take them (both begin
    /// every walk on the device: [`DeviceScene::cast_shared`]); any other batch the resumed
    /// kernel, which the host begins ([`resumed`]).
    #[allow(clippy::too_many_arguments)] // one cast's parts, as `resumed` takes them
    fn exact<K: EndsOnDevice, S: Sink<K::Answer>>(
        &self,
        scene: &Scene,
        query: &K,
        kernel: &KernelSpec,
        device: &OnDevice,
        rays: &Rays<f32>,
        out: S,
        opts: &CastOptions,
        timings: &mut GpuTimings,
    ) -> Result<()> {
        // The scan for one origin and its location count as the cast's location. Rays leaving
        // hits (`start=hits`) each begin next to their hit's tet (the CPU exact walk's
        // `settle_from`: no point location): the resumed kernel.
        let t0 = Instant::now();
        let slack = device.scene.points_slack;
        let begun = match rays.leaving {
            _ if !device.batching.begin_on_device => None,
            None => shared_origin(scene, rays, query.closest(), slack, opts.threads)
                .map(|u| (&SHARED_ORIGIN, u))
                .or_else(|| own_origins(scene, rays, slack).map(|u| (&OWN_ORIGINS, u))),
            Some(_) => None,
        };
        match begun {
            Some((k, uniform)) => {
                let rays = HostRays::Given(rays);
                let begins = (k, uniform, t0);
                self.cast_shared(scene, query, device, begins, rays, out, opts, timings)
            }
            None => resumed(scene, query, kernel, device, rays, out, opts, timings),
        }
    }

    /// Runs `f` with `kernel` ready on the device for `scene` (its pipeline, the scene's
    /// buffers for its layout, the kept ray buffers); returns the cast's timings.
    pub(super) fn on_device(
        &self,
        scene: &Scene,
        kernel: &KernelSpec,
        opts: &CastOptions,
        batching: Batching,
        f: impl FnOnce(&OnDevice, &mut GpuTimings) -> Result<()>,
    ) -> Result<GpuTimings> {
        let g = gpu()?;
        let pipeline = g.pipeline(kernel)?;
        let (scene_buffers, scene_upload) = self.buffers(&g, scene, kernel)?;
        let mut timings = GpuTimings {
            scene_upload,
            ..Default::default()
        };
        let cache = self.run_buffers(kernel);
        let device = OnDevice {
            g: &g,
            pipeline: &pipeline,
            scene: &scene_buffers,
            max_steps: opts.max_steps_for(scene.mesh.len()),
            batching,
            cache: &cache,
        };
        f(&device, &mut timings)?;
        Ok(timings)
    }
}

/// A shared-origin cast's rays as the host reads them (for the rays the device hands back):
/// the caller's arrays, or a camera's, made one at a time by the twin.
#[derive(Clone, Copy)]
enum HostRays<'a> {
    Given(&'a Rays<'a, f32>),
    Camera {
        cam: &'a CameraF32,
        eye: [f32; 3],
        tmin: f64,
        tmax: f64,
    },
}

impl HostRays<'_> {
    fn len(&self) -> usize {
        match self {
            HostRays::Given(r) => r.len(),
            HostRays::Camera { cam, .. } => cam.n_rays(),
        }
    }

    /// Whether every ray's tmax is infinite.
    fn infinite(&self) -> bool {
        match self {
            HostRays::Given(r) => r.tmax.iter().all(|&t| t == f64::INFINITY),
            HostRays::Camera { tmax, .. } => *tmax == f64::INFINITY,
        }
    }

    /// Whether some ray's range may start after its origin or be one the CPU refuses: a tmin
    /// above 0, or a NaN bound (`checked_range`). The kernels walk such rays from their origins
    /// all the same; the host then checks each ray's range.
    fn late(&self) -> bool {
        let late = |tmin: f64, tmax: f64| tmin > 0.0 || tmin.is_nan() || tmax.is_nan();
        match self {
            HostRays::Given(r) => {
                r.tmin.iter().any(|&t| late(t, 0.0)) || r.tmax.iter().any(|&t| late(0.0, t))
            }
            HostRays::Camera { tmin, tmax, .. } => late(*tmin, *tmax),
        }
    }

    fn ray(&self, i: usize) -> Ray {
        match *self {
            HostRays::Given(r) => r.ray(i),
            HostRays::Camera {
                cam,
                eye,
                tmin,
                tmax,
            } => Ray {
                o: eye.map(f64::from),
                d: cam.ray(i).map(f64::from),
                tmin,
                tmax,
                leaving: None,
            },
        }
    }
}

/// A query the exact kernels answer on the device where they end a walk without the host:
/// at a hit they finished (`gpu::finish`: the CPU exact walk's first meet, its t in range)
/// and at a walk that met nothing in range (handed back at the domain's boundary, or stopped
/// at a face met past tmax, where the CPU's policy stops with a miss).
pub(crate) trait EndsOnDevice: QueryKind {
    /// Whether the device finishes this query's hits (the hit table); where not, it hands
    /// every walk back at its first constrained face, as it stands there.
    const FINISHES: bool = true;
    /// The closest-hit query whose policy this query's walk follows (it decides whether an
    /// origin may touch the surface).
    fn closest(&self) -> &crate::query::ClosestHit<'_>;
    /// The answer at a hit the device finished; None where the query goes on past it.
    fn finished(o: &RayOut) -> Option<Self::Answer>;
    fn missed(o: &RayOut) -> Self::Answer;
}

impl EndsOnDevice for crate::query::ClosestHit<'_> {
    fn closest(&self) -> &crate::query::ClosestHit<'_> {
        self
    }
    #[inline(always)]
    fn finished(o: &RayOut) -> Option<RayHit> {
        Some(finished_hit(o))
    }
    #[inline(always)]
    fn missed(o: &RayOut) -> RayHit {
        boundary_miss(o)
    }
}

/// Occlusion: the first meet in range is a hit, whichever triangle it names.
impl EndsOnDevice for crate::query::AnyHit<'_> {
    fn closest(&self) -> &crate::query::ClosestHit<'_> {
        &self.0
    }
    fn finished(_: &RayOut) -> Option<u8> {
        Some(crate::status::HIT)
    }
    fn missed(_: &RayOut) -> u8 {
        crate::status::MISS
    }
}

/// Every point: the walk goes on past each hit, so the device finishes none and hands each
/// walk back at its first constrained face; one that met nothing lists nothing.
impl EndsOnDevice for crate::query::AllHits<'_> {
    const FINISHES: bool = false;
    fn closest(&self) -> &crate::query::ClosestHit<'_> {
        &self.0
    }
    fn finished(_: &RayOut) -> Option<Listed> {
        None
    }
    fn missed(_: &RayOut) -> Listed {
        Listed {
            status: crate::status::MISS,
            meets: Vec::new(),
        }
    }
}

impl DeviceScene {
    /// A batch from one origin (`gpu::origin`), or of rays with their own origins: the
    /// shared-origin kernel ([`SHARED_ORIGIN`]) or the own-origin kernel ([`OWN_ORIGINS`],
    /// which also locates each origin) begins every walk, walks on and finishes the hits it
    /// can certify; the host copies those, answers each other ray from where its walk was
    /// handed back, walks the rays whose start the kernel could not certify from their
    /// start, and answers the certain misses of the box.
    #[allow(clippy::too_many_arguments)] // one cast's parts, as `resumed` takes them
    fn cast_shared<K: EndsOnDevice, S: Sink<K::Answer>>(
        &self,
        scene: &Scene,
        query: &K,
        exact: &OnDevice,
        (begins, shared, t0): (&KernelSpec, Shared, Instant),
        rays: HostRays,
        out: S,
        opts: &CastOptions,
        timings: &mut GpuTimings,
    ) -> Result<()> {
        let g = exact.g;
        let pipeline = g.pipeline(begins)?;
        let (grid, grid_upload) = self.entry_grid(g, scene)?;
        let (table, table_upload) = self.hit_table(g, scene)?;
        let own = std::ptr::eq(begins, &OWN_ORIGINS);
        let (locate, locate_upload) = match own {
            true => self.locate_table(g, scene).map(|(t, s)| (Some(t), s))?,
            false => (None, 0.0),
        };
        let uploads = grid_upload + table_upload + locate_upload;
        timings.scene_upload += uploads;
        // With a finite tmax, or a tmin above 0, the host compares each finished hit's t with
        // the ray's range (below).
        let (finite_tmax, late) = (!rays.infinite(), rays.late());
        let shared = Shared {
            sides: grid.sides,
            finish: if K::FINISHES {
                table.sides
            } else {
                super::finish::NONE
            },
            beyond_at: locate.as_ref().map_or(0, |l| l.beyond_at),
            ..shared
        };
        let cache = self.run_buffers(begins);
        let mut extra = vec![(7, &grid.cells), (8, &grid.faces), (9, &table.buffer)];
        if let Some(l) = &locate {
            extra.push((10, &l.buffer));
        }
        // A camera's directions are made by its kernel on the device (its numbers, a few
        // bytes, are the upload); the host makes those of the rays handed back.
        let (kernel, on_device) = match rays {
            HostRays::Camera { cam, .. } => {
                let k = self.camera_kernel(g)?;
                let c = k.upload(g, cam)?;
                (Some(k), Some(c))
            }
            HostRays::Given(_) => (None, None),
        };
        let launch = Launch {
            g,
            pipeline: &pipeline,
            scene: exact.scene,
            max_steps: exact.max_steps,
            batching: exact.batching,
            cache: &cache,
            input_binding: 6,
            shared: Some(shared),
            extra: &extra,
            camera: kernel.as_deref().zip(on_device.as_ref()),
            origins: match rays {
                HostRays::Given(r) if own => Some(r.origins),
                _ => None,
            },
        };
        timings.camera_rays = launch.camera.is_some();
        let n = rays.len();
        timings.shared_origin = !own;
        timings.own_origins = own;
        timings.locate = t0.elapsed().as_secs_f64() - uploads;
        timings.walked = n;
        let setup = exact_setup(scene, exact.max_steps)?;
        let bvh = || scene.exact_bvh();
        let walk = TetWalk::<f64, Tet20, Exact, NoObserver>::new(scene.locators(), setup)
            .with_grazing(&bvh);
        let handed = AtomicUsize::new(0);
        let finished = AtomicUsize::new(0);
        // The rays the CPU does not walk: a range it refuses (`checked_range`), and a ray from
        // outside the box whose finite tmax ends before it (`exact_line` clips [0, tmax] to
        // the box). The kernel began them all the same, so the host answers them as the CPU
        // does. None: the ray walks (every ray with tmin ≤ 0 and an infinite tmax does).
        let locators = scene.locators();
        let unwalked = |ray: &Ray| {
            let status = match ray.tmax != f64::INFINITY {
                true => locators.exact_line(ray).err(),
                false => checked_range(ray).err(),
            };
            status.map(|s| match s {
                // A line that may touch the box without entering it: the exact BVH's answer.
                GRAZES => walk.answer_grazing(query, ray),
                s => query.skipped(s),
            })
        };
        // The host's walk of a ray from its start, as the CPU's.
        let again = |ray: &Ray, st: &mut LocateState| match walk.begin_elsewhere(query, ray, st) {
            Err(answer) => answer,
            Ok((s, at)) => walk.walk_on_from(query, &s, at),
        };
        let ranged = finite_tmax || late;
        // Each chunk answered from its rays' results, as they come back.
        let answer = |k: usize, mut chunk: S, results: &[RayOut]| {
            let mut st = LocateState::for_chunk(k);
            let (mut sent, mut done) = (0, 0);
            for (j, o) in results.iter().enumerate() {
                let i = k * CHUNK + j;
                // Where some range may end or start away from [0, ∞), each ray's own.
                let ray = ranged.then(|| rays.ray(i));
                if let Some(skipped) = ray.as_ref().and_then(unwalked) {
                    chunk.put(j, skipped);
                    continue;
                }
                let answer = match o.end {
                    END_FINISHED => {
                        // The hit is the CPU's first meet from the origin (`gpu::finish`). The
                        // CPU takes it if tmin ≤ its exact t ≤ tmax (`range_of`); past tmax it
                        // stops there with a miss, before tmin it walks on. The host's t rounds
                        // a float64 within an ulp of the exact t to float32, so the exact t
                        // lies strictly between t's float32 neighbours.
                        let t = o.hit[0];
                        let (below, above) = (f64::from(t.next_down()), f64::from(t.next_up()));
                        match ray {
                            // (A NaN tmin was answered above: `unwalked`.)
                            Some(ray) if ray.tmin > below.max(0.0) => {
                                // Before tmin, or within an ulp of it: walked again.
                                sent += 1;
                                again(&ray, &mut st)
                            }
                            // Past tmax: the walk's miss where it stopped.
                            Some(ray) if ray.tmax <= below => K::missed(o),
                            // Within an ulp of tmax: walked again.
                            Some(ray) if ray.tmax < above => {
                                sent += 1;
                                again(&ray, &mut st)
                            }
                            _ => match K::finished(o) {
                                Some(answer) => {
                                    done += 1;
                                    answer
                                }
                                // A query the device finishes no hit for: never so (its
                                // uniform says so), but walked again if it were.
                                None => {
                                    sent += 1;
                                    again(&rays.ray(i), &mut st)
                                }
                            },
                        }
                    }
                    END_MISS_BOX => query.skipped(crate::status::MISS),
                    END_BOUNDARY => K::missed(o),
                    END_UNBEGUN => {
                        sent += 1;
                        again(&ray.unwrap_or_else(|| rays.ray(i)), &mut st)
                    }
                    end => {
                        sent += (end == END_DEFERRED) as usize;
                        let ray = ray.unwrap_or_else(|| rays.ray(i));
                        match WalkStart::exact(&ray) {
                            Ok(s) => walk.walk_on_from(query, &s, plain_state(o)),
                            Err(status) => query.skipped(status),
                        }
                    }
                };
                chunk.put(j, answer);
            }
            handed.fetch_add(sent, Ordering::Relaxed);
            finished.fetch_add(done, Ordering::Relaxed);
        };
        let chunks = crate::query::chunks(out, CHUNK);
        let ends: Vec<usize> = (1..=chunks.len()).map(|k| (k * CHUNK).min(n)).collect();
        let mut by_chunk = ByChunk::new(chunks, &ends);
        // Straight from the caller's array (12 bytes a ray), or made on the device.
        let dirs: &[[f32; 3]] = match rays {
            HostRays::Given(r) => bytemuck::cast_slice(r.directions),
            HostRays::Camera { .. } => &[],
        };
        launch.run(&[dirs], n, timings, |before, results| {
            by_chunk.take(before, results, opts.threads, &answer)
        })?;
        crate::threads::checkpoint()?;
        timings.deferred = handed.into_inner();
        timings.finished = finished.into_inner();
        Ok(())
    }
}

/// The CPU exact walk of float32 rays on Tet20, as the CPU cast dispatches it: float64 points.
fn exact_setup(scene: &Scene, max_steps: u32) -> Result<WalkSetup<'_, f64, Tet20>> {
    Ok(WalkSetup {
        layout: crate::layout::get::<Tet20>(&scene.layouts.tet20, &scene.mesh)?,
        points: &scene.mesh.points[..],
        sides: &scene.mesh.constrained,
        max_steps,
    })
}

/// A kernel ready to run on the device, with the scene's buffers for it.
pub(super) struct OnDevice<'a> {
    pub g: &'a Gpu,
    pub pipeline: &'a wgpu::ComputePipeline,
    pub scene: &'a LayoutBuffers,
    pub max_steps: u32,
    pub batching: Batching,
    pub cache: &'a Mutex<Option<RunBuffers>>,
}

impl OnDevice<'_> {
    /// A cast in three phases, each chunk of rays as the CPU cast cuts them (same hints and
    /// seeds), on tetrace's pools as pieces (Ctrl-C skips the chunks not started): `begin`
    /// writes the answers of chunk k's rays that need no kernel and returns the others,
    /// prepared; the device walks them in batches; `end` answers each from its start and the
    /// kernel's result, chunk by chunk as the batches come back. Counts the rays the kernel
    /// deferred.
    fn cast<A, S: Sink<A>>(
        &self,
        out: S,
        opts: &CastOptions,
        timings: &mut GpuTimings,
        begin: impl Fn(usize, &mut S) -> Located + Sync,
        end: impl Fn(&WalkStart, &RayOut) -> A + Sync,
    ) -> Result<()> {
        let t0 = Instant::now();
        let mut chunks = crate::query::chunks(out, CHUNK);
        let mut located: Vec<Located> = (0..chunks.len()).map(|_| Default::default()).collect();
        let pieces: Vec<_> = chunks.iter_mut().zip(&mut located).enumerate().collect();
        run_pieces(pieces, opts.threads, |(k, (chunk, slot))| {
            *slot = begin(k, chunk)
        })?;
        timings.locate = t0.elapsed().as_secs_f64();

        // Where each chunk's walked rays end in the sequence the device walks.
        let ends: Vec<usize> = located
            .iter()
            .scan(0, |walked, (s, _)| {
                *walked += s.len();
                Some(*walked)
            })
            .collect();
        let walked = ends.last().copied().unwrap_or(0);
        timings.walked = walked;
        if walked == 0 {
            return Ok(());
        }
        let deferred = AtomicUsize::new(0);
        let answer = |k: usize, mut chunk: S, results: &[RayOut]| {
            for ((j, s), o) in located[k].0.iter().zip(results) {
                if o.end == END_DEFERRED {
                    deferred.fetch_add(1, Ordering::Relaxed);
                }
                let j = *j as usize;
                chunk.put(j, end(s, o));
            }
        };
        let all: Vec<&[RayIn]> = located.iter().map(|(_, r)| r.as_slice()).collect();
        let launch = Launch {
            g: self.g,
            pipeline: self.pipeline,
            scene: self.scene,
            max_steps: self.max_steps,
            batching: self.batching,
            cache: self.cache,
            input_binding: 1,
            shared: None,
            extra: &[],
            camera: None,
            origins: None,
        };
        let mut by_chunk = ByChunk::new(chunks, &ends);
        launch.run(&all, walked, timings, |before, results| {
            by_chunk.take(before, results, opts.threads, &answer)
        })?;
        crate::threads::checkpoint()?;
        timings.deferred = deferred.into_inner();
        Ok(())
    }
}

/// A cast's chunks of answers, finished as the device's results come back batch by batch
/// (chunk k's results are `ends[k - 1]..ends[k]` of the walked sequence): the chunks a batch
/// completes are answered together, in parallel, from the mapped batch where it lies; a
/// chunk a batch's end cuts keeps its first results in `carry` (at most one chunk's) and is
/// answered when the batch that completes it comes.
struct ByChunk<'a, S> {
    chunks: std::iter::Enumerate<std::vec::IntoIter<S>>,
    ends: &'a [usize],
    /// The first chunk not answered.
    next: usize,
    carry: Vec<RayOut>,
}

impl<'a, S: Send> ByChunk<'a, S> {
    fn new(chunks: Vec<S>, ends: &'a [usize]) -> Self {
        ByChunk {
            chunks: chunks.into_iter().enumerate(),
            ends,
            next: 0,
            carry: Vec::new(),
        }
    }

    /// Takes the results of the batch that begins `before` rays into the sequence.
    fn take(
        &mut self,
        before: usize,
        batch: &[RayOut],
        threads: Option<usize>,
        answer: &(impl Fn(usize, S, &[RayOut]) + Sync),
    ) -> Result<()> {
        let (mut rest, mut at) = (batch, before);
        let batch_end = before + batch.len();
        if !self.carry.is_empty() {
            // The chunk the last batch cut: completed from this one's head, if it ends here.
            let missing = self.ends[self.next] - at;
            if missing > rest.len() {
                self.carry.extend_from_slice(rest);
                return Ok(());
            }
            self.carry.extend_from_slice(&rest[..missing]);
            (rest, at) = (&rest[missing..], at + missing);
            let (k, chunk) = self.chunks.next().expect("a chunk for every end");
            answer(k, chunk, &self.carry);
            self.carry.clear();
            self.next += 1;
        }
        let mut pieces = Vec::new();
        while self.next < self.ends.len() && self.ends[self.next] <= batch_end {
            let len = self.ends[self.next] - at;
            let (k, chunk) = self.chunks.next().expect("a chunk for every end");
            pieces.push((k, chunk, &rest[..len]));
            (rest, at) = (&rest[len..], at + len);
            self.next += 1;
        }
        run_pieces(pieces, threads, |(k, chunk, results)| {
            answer(k, chunk, results)
        })?;
        self.carry.extend_from_slice(rest);
        Ok(())
    }
}

/// The exact kernel's cast (see the module docs) for `query`: the CPU exact walk on Tet20,
/// its plain steps taken on the device. A walk handed back at the domain's boundary met
/// nothing (its policy was fresh: `begin_elsewhere`), so it is answered without walking on
/// (`EndsOnDevice::missed`); the CPU walks on from any face.
#[allow(clippy::too_many_arguments)] // one cast's parts, as `cast_shared` takes them
fn resumed<K: EndsOnDevice, S: Sink<K::Answer>>(
    scene: &Scene,
    query: &K,
    kernel: &KernelSpec,
    device: &OnDevice,
    rays: &Rays<f32>,
    out: S,
    opts: &CastOptions,
    timings: &mut GpuTimings,
) -> Result<()> {
    let setup = exact_setup(scene, device.max_steps)?;
    let bvh = || scene.exact_bvh();
    let walk =
        TetWalk::<f64, Tet20, Exact, NoObserver>::new(scene.locators(), setup).with_grazing(&bvh);
    let points_slack = device.scene.points_slack;
    device.cast(
        out,
        opts,
        timings,
        |k, chunk| {
            let n = chunk.len();
            let (mut starts, mut prepared) = (Vec::with_capacity(n), Vec::with_capacity(n));
            let mut st = LocateState::for_chunk(k);
            for j in 0..n {
                let ray = rays.ray(k * CHUNK + j);
                match walk.begin_elsewhere(query, &ray, &mut st) {
                    Err(answer) => chunk.put(j, answer),
                    Ok((s, at)) => {
                        let r = (kernel.prepare)(&s, &scene.mesh);
                        prepared.push(RayIn {
                            tet: at.t,
                            entry: at.steps,
                            verts: [at.face[0], at.face[1], at.face[2], at.link],
                            slack: ((r.slack as f64 + points_slack as f64) * (1.0 + 1e-6)) as f32,
                            ..r
                        });
                        starts.push((j as u32, s));
                    }
                }
            }
            (starts, prepared)
        },
        |s, o| match o.end {
            END_BOUNDARY => K::missed(o),
            _ => walk.walk_on_from(query, s, plain_state(o)),
        },
    )
}

/// Locates the rays of chunk k; rays that need no walk are written to `chunk` at once.
fn locate_chunk(
    scene: &Scene,
    kernel: &KernelSpec,
    rays: &Rays<f32>,
    k: usize,
    chunk: &mut HitsOut<f32>,
) -> Located {
    let mut st = LocateState::for_chunk(k);
    let mut starts = Vec::with_capacity(chunk.len());
    let mut prepared = Vec::with_capacity(chunk.len());
    // As the CPU twin's cast: the robust walk starts in the perturbed start point's tet.
    let settle = kernel.perturbed_start.then_some(&scene.points_f32[..]);
    for j in 0..chunk.len() {
        let i = k * CHUNK + j;
        match scene.locate_one(rays, i, settle, &mut st) {
            Start::Done(status) => chunk.set(j, &RayHit::nothing(status)),
            Start::Walk(s) => {
                prepared.push((kernel.prepare)(&s, &scene.mesh));
                starts.push((j as u32, s));
            }
        }
    }
    (starts, prepared)
}

/// A kernel's result as the CPU walk's [`Walk`].
fn gpu_walk(kernel: &KernelSpec, o: &RayOut) -> Walk {
    let end = match o.end {
        END_BOUNDARY => WalkEnd::Boundary,
        END_HIT => WalkEnd::Hit {
            constrained: o.constrained,
        },
        _ => WalkEnd::StepLimit,
    };
    Walk {
        end,
        tet: o.tet,
        face: [o.face[0], o.face[1], o.face[2]],
        slots: kernel.layout.slots,
        steps: o.steps,
    }
}
