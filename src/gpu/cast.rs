//! Casting on the device: the CPU locates each ray's start (`Scene::locate_one`, the same code
//! and the same chunks as the CPU cast), prepares it as the CPU walk would (`ExitMethod::
//! prepare`), the GPU walks batches of rays, and the CPU finishes each hit on the caller's
//! triangle (`Scene::finish`). Robust rays the GPU defers are walked again by the CPU robust
//! walk from the same start.

use super::context::{gpu, Gpu};
use super::kernels::Kernel;
use super::structs::*;
use crate::error::{Error, Result};
use crate::locate::{LocateState, Start, WalkStart};
use crate::mesh::TetMesh;
use crate::query::RayHit;
use crate::scene::CastOptions;
use crate::scene::{check_lengths, HitsOut, Rays, Scene, CHUNK};
use crate::traverse::{walk, Aman2022, Maria2017, Robust, Walk, WalkEnd};
use rayon::prelude::*;
use std::collections::HashMap;
use std::sync::{Arc, Mutex};
use std::time::Instant;
use wgpu::util::DeviceExt;

/// Where the time of a GPU cast went, in seconds (each phase waits for the device before the
/// next starts, so the phases do not overlap).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GpuTimings {
    /// Start-tet location and ray preparation on the CPU.
    pub locate: f64,
    /// Uploading the scene's buffers (0 when they were already on the device).
    pub scene_upload: f64,
    /// Copying the rays to the device.
    pub upload: f64,
    /// The traversal kernel.
    pub kernel: f64,
    /// Copying the results back.
    pub readback: f64,
    /// Hits on the caller's triangles, and CPU walks of deferred rays.
    pub finish: f64,
    /// Rays the GPU walked (rays that miss the box or are invalid are settled on the CPU).
    pub walked: usize,
    /// Robust kernel: rays deferred to the CPU robust walk.
    pub deferred: usize,
    pub batches: usize,
}

/// A scene's buffers on the device, one set per kernel.
struct SceneBuffers {
    tets: wgpu::Buffer,
    points: Option<wgpu::Buffer>,
}

/// The device copies of a scene (kept in `Scene::gpu`): uploaded on the first GPU cast with a
/// layout and kept for the next; kernels on the same layout (aman2022 and robust on tet20)
/// share them.
#[derive(Default)]
pub struct GpuCache {
    buffers: Mutex<HashMap<&'static str, Arc<SceneBuffers>>>,
}

impl GpuCache {
    /// Bytes on the device per layout (records, and points for id layouts).
    pub fn bytes(&self) -> Vec<(&'static str, u64)> {
        let b = self.buffers.lock().unwrap_or_else(|e| e.into_inner());
        b.iter()
            .map(|(k, s)| {
                (
                    *k,
                    s.tets.size() + s.points.as_ref().map_or(0, |p| p.size()),
                )
            })
            .collect()
    }
}

/// A scene buffer of `size` bytes must fit one storage binding and one buffer of the device.
pub(crate) fn check_fits(
    label: &str,
    size: u64,
    limits: &wgpu::Limits,
    device: &str,
) -> Result<()> {
    let binding = limits.max_storage_buffer_binding_size;
    let max = limits.max_buffer_size;
    if size > binding || size > max {
        return Err(Error::TooLarge(format!(
            "the scene's {label} take {size} bytes on the GPU, but {device} binds at most \
             {binding} bytes per storage buffer (max_storage_buffer_binding_size) and allocates \
             at most {max} (max_buffer_size); use the CPU (device=\"cpu\"), a smaller layout, or a \
             device with larger limits"
        )));
    }
    Ok(())
}

/// A buffer of `n` records, filled while mapped (no second host copy of the whole scene), after
/// checking it fits the device's limits.
fn upload_records<T: bytemuck::Pod + Send>(
    g: &Gpu,
    label: &str,
    n: usize,
    fill: impl Fn(usize) -> T + Sync,
) -> Result<wgpu::Buffer> {
    let size = (n.max(1) * std::mem::size_of::<T>()) as u64;
    check_fits(label, size, &g.limits, &g.adapter.name)?;
    g.scoped(
        &format!("uploading the scene's {label} ({size} bytes)"),
        || {
            let buf = g.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage: wgpu::BufferUsages::STORAGE,
                mapped_at_creation: true,
            });
            {
                let mut view = buf
                    .slice(..)
                    .get_mapped_range_mut()
                    .map_err(|e| Error::Gpu(format!("mapping the {label}: {e}")))?;
                // The mapped memory is write-only: fill a block of records at a time and copy it.
                const BLOCK: usize = 1 << 16;
                let mut block: Vec<T> = Vec::with_capacity(BLOCK);
                let rsize = std::mem::size_of::<T>();
                for start in (0..n).step_by(BLOCK) {
                    let end = (start + BLOCK).min(n);
                    block.clear();
                    (start..end)
                        .into_par_iter()
                        .map(&fill)
                        .collect_into_vec(&mut block);
                    view.slice(start * rsize..end * rsize)
                        .copy_from_slice(bytemuck::cast_slice(&block));
                }
            }
            buf.unmap();
            Ok(buf)
        },
    )?
}

impl Scene {
    fn gpu_buffers(&self, g: &Gpu, kernel: Kernel) -> Result<(Arc<SceneBuffers>, f64)> {
        let mut cache = self.gpu.buffers.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(b) = cache.get(kernel.layout()) {
            return Ok((b.clone(), 0.0));
        }
        let t0 = Instant::now();
        let mesh = &self.mesh;
        let b = match kernel {
            Kernel::Aman2022Tet20 | Kernel::RobustTet20 => {
                let l = crate::layout::get(&self.layouts.tet20, mesh)?;
                let tets = upload_records(g, "tet20 records", l.records.len(), |i| {
                    let r = &l.records[i];
                    Tet20 {
                        vertex_xor: r.vertex_xor,
                        links: r.links,
                    }
                })?;
                let p = &self.points_f32;
                let points = upload_records(g, "float32 points", p.len(), |i| {
                    [p[i][0], p[i][1], p[i][2], 0.0f32]
                })?;
                SceneBuffers {
                    tets,
                    points: Some(points),
                }
            }
            Kernel::Maria2017Tet80 => {
                let l = crate::layout::get(&self.layouts.tet80, mesh)?;
                let tets = upload_records(g, "tet80 records", l.records.len(), |i| {
                    let r = &l.records[i];
                    let mut v = [0f32; 12];
                    for k in 0..4 {
                        v[3 * k..3 * k + 3].copy_from_slice(&r.vertices[k]);
                    }
                    Tet80 {
                        vertices: v,
                        faces: r.faces.map(|f| Face80 {
                            constrained: f.constrained,
                            neighbor: f.neighbor,
                        }),
                    }
                })?;
                SceneBuffers { tets, points: None }
            }
        };
        g.wait()?;
        let b = Arc::new(b);
        cache.insert(kernel.layout(), b.clone());
        Ok((b, t0.elapsed().as_secs_f64()))
    }

    /// Casts float32 rays on the GPU with the kernel for `method` and `layout` (None: the
    /// default kernel, Aman et al. 2022 on Tet20). Fills `out` exactly as
    /// [`Scene::cast_named`] does; `opts.threads` applies to the CPU's parts (location,
    /// finishing).
    pub fn cast_gpu(
        &self,
        method: Option<&str>,
        layout: Option<&str>,
        rays: &Rays<f32>,
        out: HitsOut<f32>,
        opts: &CastOptions,
    ) -> Result<GpuTimings> {
        self.cast_gpu_with(method, layout, rays, out, opts, MAX_BATCH, None)
    }

    /// [`Scene::cast_gpu`] with at most `max_batch` rays per dispatch and, if given, at most
    /// `max_groups` workgroups per dispatch dimension (tests use small values to exercise
    /// batching and the 2D dispatch).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn cast_gpu_with(
        &self,
        method: Option<&str>,
        layout: Option<&str>,
        rays: &Rays<f32>,
        out: HitsOut<f32>,
        opts: &CastOptions,
        max_batch: usize,
        max_groups: Option<u32>,
    ) -> Result<GpuTimings> {
        let kernel = Kernel::find(method, layout)?;
        check_lengths(rays, &out)?;
        if !out.audit.is_empty() {
            return Err(Error::InvalidOption(
                "the exact audit observes the CPU walk: cast with device=\"cpu\" to audit".into(),
            ));
        }
        let g = gpu()?;
        let pipeline = g.pipeline(kernel)?;
        let (scene_buffers, scene_upload) = self.gpu_buffers(&g, kernel)?;
        let mut timings = GpuTimings {
            scene_upload,
            ..Default::default()
        };
        let pool = match opts.threads {
            None => None,
            Some(k) => Some(
                rayon::ThreadPoolBuilder::new()
                    .num_threads(k)
                    .build()
                    .map_err(|e| Error::InvalidOption(format!("cannot start {k} threads: {e}")))?,
            ),
        };

        // 1. Locate and prepare, chunk by chunk as the CPU cast does (same hints and seeds).
        let t0 = Instant::now();
        let mut chunks = crate::query::chunks(out, CHUNK);
        let located: Vec<Located> = {
            let mut run = || {
                chunks
                    .par_iter_mut()
                    .enumerate()
                    .map(|(k, chunk)| self.locate_chunk(kernel, rays, k, chunk))
                    .collect()
            };
            match &pool {
                None => run(),
                Some(p) => p.install(run),
            }
        };
        let walked: usize = located.iter().map(|(s, _)| s.len()).sum();
        timings.walked = walked;
        timings.locate = t0.elapsed().as_secs_f64();

        // 2. Walk on the device, in batches.
        let mut results: Vec<RayOut> = Vec::with_capacity(walked);
        if walked > 0 {
            let all: Vec<&[RayIn]> = located.iter().map(|(_, r)| r.as_slice()).collect();
            self.run_batches(
                &g,
                &pipeline,
                &scene_buffers,
                &all,
                walked,
                opts,
                (max_batch, max_groups),
                &mut results,
                &mut timings,
            )?;
        }

        // 3. Finish: hits on the caller's triangles, deferred rays on the CPU.
        let t3 = Instant::now();
        let mut offsets = Vec::with_capacity(located.len());
        let mut acc = 0usize;
        for (s, _) in &located {
            offsets.push(acc);
            acc += s.len();
        }
        let tet20 = if kernel == Kernel::RobustTet20 {
            Some(crate::layout::get(&self.layouts.tet20, &self.mesh)?)
        } else {
            None
        };
        let mut finish = || -> usize {
            chunks
                .par_iter_mut()
                .enumerate()
                .map(|(k, chunk)| {
                    let (starts, _) = &located[k];
                    let res = &results[offsets[k]..offsets[k] + starts.len()];
                    let mut deferred = 0;
                    for ((j, s), o) in starts.iter().zip(res) {
                        let w = if o.end == END_DEFERRED {
                            deferred += 1;
                            let ray = s.prepare::<f32, Robust>(&self.mesh);
                            walk::<f32, _, Robust>(
                                tet20.expect("deferred rays come from the robust kernel"),
                                &self.points_f32,
                                &ray,
                                (s.tet, self.mesh.tets[s.tet as usize]),
                                s.entry,
                                opts.max_steps_for(self.mesh.len()),
                            )
                        } else {
                            gpu_walk(kernel, o)
                        };
                        let r = self.finish(s, &w);
                        chunk.set(*j as usize, &r, &rays.ray(k * CHUNK + *j as usize));
                    }
                    deferred
                })
                .sum()
        };
        timings.deferred = match &pool {
            None => finish(),
            Some(p) => p.install(finish),
        };
        timings.finish = t3.elapsed().as_secs_f64();
        Ok(timings)
    }

    /// Locates the rays of chunk k; rays that need no walk are written to `chunk` at once.
    fn locate_chunk(
        &self,
        kernel: Kernel,
        rays: &Rays<f32>,
        k: usize,
        chunk: &mut HitsOut<f32>,
    ) -> Located {
        let mut st = LocateState::for_chunk(k);
        let mut starts = Vec::with_capacity(chunk.len());
        let mut prepared = Vec::with_capacity(chunk.len());
        // As the CPU twin's cast: the robust walk starts in the perturbed start point's tet.
        let settle = kernel.perturbed_start().then_some(&self.points_f32[..]);
        for j in 0..chunk.len() {
            let i = k * CHUNK + j;
            match self.locate_one(rays, i, settle, &mut st) {
                Start::Done(status) => chunk.set(j, &RayHit::nothing(status), &rays.ray(i)),
                Start::Walk(s) => {
                    prepared.push(prepare(kernel, &s, &self.mesh));
                    starts.push((j as u32, s));
                }
            }
        }
        (starts, prepared)
    }

    #[allow(clippy::too_many_arguments)]
    fn run_batches(
        &self,
        g: &Gpu,
        pipeline: &wgpu::ComputePipeline,
        scene: &SceneBuffers,
        parts: &[&[RayIn]],
        walked: usize,
        opts: &CastOptions,
        (max_batch, max_groups): (usize, Option<u32>),
        results: &mut Vec<RayOut>,
        timings: &mut GpuTimings,
    ) -> Result<()> {
        let ray_bytes = std::mem::size_of::<RayIn>() as u64;
        let out_bytes = std::mem::size_of::<RayOut>() as u64;
        let cap = (g
            .limits
            .max_storage_buffer_binding_size
            .min(g.limits.max_buffer_size)
            / ray_bytes)
            .min(max_batch as u64) as usize;
        let batch = walked.min(cap).max(1);
        let (ray_buf, out_buf, read_buf, params_buf) =
            g.scoped("allocating ray buffers", || {
                let mk = |label, size, usage| {
                    g.device.create_buffer(&wgpu::BufferDescriptor {
                        label: Some(label),
                        size,
                        usage,
                        mapped_at_creation: false,
                    })
                };
                use wgpu::BufferUsages as U;
                (
                    mk("rays", batch as u64 * ray_bytes, U::STORAGE | U::COPY_DST),
                    mk("hits", batch as u64 * out_bytes, U::STORAGE | U::COPY_SRC),
                    mk(
                        "hits readback",
                        batch as u64 * out_bytes,
                        U::MAP_READ | U::COPY_DST,
                    ),
                    g.device
                        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                            label: Some("params"),
                            contents: bytemuck::bytes_of(&Params::default()),
                            usage: U::UNIFORM | U::COPY_DST,
                        }),
                )
            })?;
        let layout = pipeline.get_bind_group_layout(0);
        let mut entries = vec![
            wgpu::BindGroupEntry {
                binding: 0,
                resource: params_buf.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: ray_buf.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 2,
                resource: out_buf.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 3,
                resource: scene.tets.as_entire_binding(),
            },
        ];
        if let Some(p) = &scene.points {
            entries.push(wgpu::BindGroupEntry {
                binding: 4,
                resource: p.as_entire_binding(),
            });
        }
        let bind = g.scoped("binding buffers", || {
            g.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("tetrace"),
                layout: &layout,
                entries: &entries,
            })
        })?;
        // The rays of all chunks, in order, as one sequence cut into batches.
        let mut staged: Vec<RayIn> = Vec::with_capacity(batch);
        let mut iter = parts.iter().flat_map(|p| p.iter());
        let max_dim = max_groups
            .unwrap_or(u32::MAX)
            .min(g.limits.max_compute_workgroups_per_dimension)
            .max(1);
        loop {
            staged.clear();
            staged.extend(iter.by_ref().take(batch).copied());
            if staged.is_empty() {
                break;
            }
            let n = staged.len();
            timings.batches += 1;
            // Upload.
            let t = Instant::now();
            g.scoped("uploading rays", || {
                g.queue
                    .write_buffer(&ray_buf, 0, bytemuck::cast_slice(&staged));
                g.queue.write_buffer(
                    &params_buf,
                    0,
                    bytemuck::bytes_of(&Params {
                        n_rays: n as u32,
                        max_steps: opts.max_steps_for(self.mesh.len()),
                        ..Default::default()
                    }),
                );
                g.queue.submit([]);
            })?;
            g.wait()?;
            timings.upload += t.elapsed().as_secs_f64();
            // Kernel.
            let t = Instant::now();
            let groups = (n as u32).div_ceil(WORKGROUP);
            let (gx, gy) = if groups <= max_dim {
                (groups, 1)
            } else {
                (max_dim, groups.div_ceil(max_dim))
            };
            g.scoped("running the traversal kernel", || {
                let mut enc = g.device.create_command_encoder(&Default::default());
                {
                    let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                        label: Some("walk"),
                        timestamp_writes: None,
                    });
                    pass.set_pipeline(pipeline);
                    pass.set_bind_group(0, &bind, &[]);
                    pass.dispatch_workgroups(gx, gy, 1);
                }
                g.queue.submit([enc.finish()]);
            })?;
            g.wait()?;
            timings.kernel += t.elapsed().as_secs_f64();
            // Readback.
            let t = Instant::now();
            let size = n as u64 * out_bytes;
            g.scoped("reading results back", || {
                let mut enc = g.device.create_command_encoder(&Default::default());
                enc.copy_buffer_to_buffer(&out_buf, 0, &read_buf, 0, size);
                g.queue.submit([enc.finish()]);
            })?;
            let (tx, rx) = std::sync::mpsc::channel();
            read_buf
                .slice(..size)
                .map_async(wgpu::MapMode::Read, move |r| {
                    let _ = tx.send(r);
                });
            g.wait()?;
            rx.recv()
                .map_err(|_| Error::Gpu("the readback callback never ran".into()))?
                .map_err(|e| Error::Gpu(format!("mapping the results: {e}")))?;
            {
                let view = read_buf
                    .slice(..size)
                    .get_mapped_range()
                    .map_err(|e| Error::Gpu(format!("reading the results: {e}")))?;
                results.extend_from_slice(bytemuck::cast_slice(&view[..]));
            }
            read_buf.unmap();
            timings.readback += t.elapsed().as_secs_f64();
        }
        Ok(())
    }
}

/// A chunk's rays that walk: their index in the chunk and start, and as the kernel takes them.
type Located = (Vec<(u32, WalkStart)>, Vec<RayIn>);

/// Rays per batch at most: bounds the ray buffers (64 + 2 × 32 bytes a ray).
pub const MAX_BATCH: usize = 1 << 20;

/// The ray as the kernel's CPU twin prepares it (`WalkStart::prepare`, as the CPU cast does).
pub(super) fn prepare(kernel: Kernel, s: &WalkStart, mesh: &TetMesh) -> RayIn {
    let entry = s.entry.map_or(NO_ENTRY, |i| i as u32);
    let base = RayIn {
        tet: s.tet,
        entry,
        verts: mesh.tets[s.tet as usize],
        ..Default::default()
    };
    match kernel {
        Kernel::Aman2022Tet20 => {
            let r = s.prepare::<f32, Aman2022>(mesh);
            RayIn {
                origin: r.origin,
                e0: r.u,
                e1: r.w,
                ..base
            }
        }
        Kernel::Maria2017Tet80 => {
            let r = s.prepare::<f32, Maria2017>(mesh);
            RayIn {
                e0: r.u,
                e1: r.v,
                ..base
            }
        }
        Kernel::RobustTet20 => {
            // The CPU robust walk's exact line: s (already float32, so the slack is 0 unless
            // that changes) and b = s + k d; the kernel projects on the basis built from b − s.
            let r = s.prepare::<f32, Robust>(mesh);
            RayIn {
                origin: r.sr,
                e0: r.u,
                e1: r.w,
                slack: slack(r.s, r.sr),
                ..base
            }
        }
    }
}

/// |s − s̃|₁ rounded up to float32: how far the float32 start point the kernel subtracts is
/// from the exact start point of the robust walk's line (docs/gpu.md).
pub fn slack(s: [f64; 3], sr: [f32; 3]) -> f32 {
    // Each difference is exact in f64 (s̃ is s rounded); the sum and the conversion round by
    // far less than the 1e-6 margin.
    let e: f64 = (0..3).map(|k| (s[k] - sr[k] as f64).abs()).sum();
    (e * (1.0 + 1e-6)) as f32
}

/// A kernel's result as the CPU walk's [`Walk`].
fn gpu_walk(kernel: Kernel, o: &RayOut) -> Walk {
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
        slots: kernel == Kernel::Maria2017Tet80,
        steps: o.steps,
    }
}
