//! Running a kernel over prepared rays: the ray buffers, the bind group, then per batch an
//! upload, a dispatch (a 2D grid when one row of workgroups is not enough) and a readback.

use super::camera::{CameraKernel, DeviceCamera};
use super::context::Gpu;
use super::structs::{Params, RayOut, Shared, WORKGROUP};
use super::timings::GpuTimings;
use super::upload::LayoutBuffers;
use crate::error::Result;
use std::sync::Mutex;
use std::time::Instant;
use wgpu::util::DeviceExt;

/// Rays per batch at most: bounds the ray buffers (at most 64 + 2 × 32 bytes a ray).
pub const MAX_BATCH: usize = 1 << 20;

/// Rays in a run's first batch (or fewer). A batch's kernel cannot be interrupted: Ctrl-C is
/// seen between batches. Batches start at this size and grow while the device is quick
/// ([`next_batch`]), so a slow device (lavapipe walks an exact batch at microseconds a ray)
/// keeps batches of a fraction of a second and a fast one reaches full batches in a few.
const FIRST_BATCH: usize = 1 << 16;

/// What a batch's kernel may take (seconds) before batches stop growing.
const BATCH_SECONDS: f64 = 0.25;

/// The next batch's size after one of `size` rays whose kernel took `took` seconds: four
/// times larger (at most `cap`) while four times the time stays within [`BATCH_SECONDS`].
pub(crate) fn next_batch(size: usize, took: f64, cap: usize) -> usize {
    if 4.0 * took <= BATCH_SECONDS {
        (4 * size).min(cap)
    } else {
        size
    }
}

/// How rays are cut into dispatches.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Batching {
    /// Rays per dispatch at most (the device's binding limit may lower it).
    pub max_batch: usize,
    /// Workgroups per dispatch dimension at most, below the device's own limit (None: the
    /// device's). Tests use small values to exercise batching and the 2D dispatch.
    pub max_groups: Option<u32>,
    /// Write the rays through the queue's staging memory and copy the results to a readback
    /// buffer even where the device could map both where they lie (`Gpu::mapped_results`):
    /// a discrete GPU's path, which tests take on lavapipe.
    pub copy_results: bool,
    /// Let the exact kernels that begin walks on the device take the rays they can (one
    /// origin, or their own origins: `gpu::origin`); tests turn it off to send every ray
    /// through the resumed kernel, which the host begins.
    pub begin_on_device: bool,
}

impl Default for Batching {
    fn default() -> Self {
        Batching {
            max_batch: MAX_BATCH,
            max_groups: None,
            copy_results: false,
            begin_on_device: true,
        }
    }
}

/// One kernel's run over a cast's rays.
pub(crate) struct Launch<'a> {
    pub g: &'a Gpu,
    pub pipeline: &'a wgpu::ComputePipeline,
    pub scene: &'a LayoutBuffers,
    pub max_steps: u32,
    pub batching: Batching,
    /// The kernel's ray buffers and bind group, kept from cast to cast (`DeviceScene`): made
    /// by the first run, remade only for a larger batch. Held for the whole run, so casts on
    /// one scene with one kernel take turns on the device.
    pub cache: &'a Mutex<Option<RunBuffers>>,
    /// Where the rays go: binding 1 (`rays`, RayIn) or the shared-origin kernel's 6 (`dirs`).
    pub input_binding: u32,
    /// What every ray of the cast shares (the shared-origin kernel's uniform, binding 5).
    pub shared: Option<Shared>,
    /// The scene's further buffers the kernel reads, by binding (the entry grid).
    pub extra: &'a [(u32, &'a wgpu::Buffer)],
    /// Directions made on the device by the camera kernel, batch by batch, instead of
    /// uploaded (the shared-origin kernel's `dirs`): `run`'s parts are then not read.
    pub camera: Option<(&'a CameraKernel, &'a DeviceCamera)>,
    /// The own-origin kernel's origins (three floats a ray, every ray of the run), written
    /// after each batch's rays in the same buffer (`Params::origins_at`).
    pub origins: Option<&'a [f32]>,
}

/// A kernel's ray buffers for batches of up to `batch` rays, and their bind group.
pub(crate) struct RunBuffers {
    batch: usize,
    bufs: RayBuffers,
    bind: wgpu::BindGroup,
}

impl RunBuffers {
    /// Bytes on the device.
    pub(crate) fn bytes(&self) -> u64 {
        let b = &self.bufs;
        b.rays.size()
            + b.hits.size()
            + b.readback.as_ref().map_or(0, wgpu::Buffer::size)
            + b.params.size()
            + b.shared.as_ref().map_or(0, wgpu::Buffer::size)
    }
}

/// The device buffers of a run, sized for one batch.
struct RayBuffers {
    rays: wgpu::Buffer,
    hits: wgpu::Buffer,
    /// Where the results are copied to be mapped; None where `hits` itself is mapped (and
    /// `rays` too: `Gpu::mapped_results`).
    readback: Option<wgpu::Buffer>,
    params: wgpu::Buffer,
    /// The shared-origin kernel's uniform (binding 5).
    shared: Option<wgpu::Buffer>,
    /// Where the device has timestamps: the pass's two, resolved and read back.
    stamps: Option<Stamps>,
}

impl RayBuffers {
    /// Whether rays and results are mapped where the kernel reads and writes them.
    fn mapped(&self) -> bool {
        self.readback.is_none()
    }
}

/// The kernel's begin and end timestamps (`Gpu::timestamps`).
struct Stamps {
    set: wgpu::QuerySet,
    resolved: wgpu::Buffer,
    readback: wgpu::Buffer,
}

impl Launch<'_> {
    /// Walks the rays of `parts` (all chunks' rays, in order: `walked` in all), as one
    /// sequence cut into batches, and gives each batch's results to `take` with the number
    /// of rays before it, in order, where they lie in the mapped readback buffer: the host
    /// copies nothing before it answers from them. A ray is a RayIn, or for the
    /// shared-origin kernel its direction. `take`'s time counts as the cast's finishing.
    pub fn run<T: bytemuck::Pod>(
        &self,
        parts: &[&[T]],
        walked: usize,
        timings: &mut GpuTimings,
        mut take: impl FnMut(usize, &[RayOut]) -> Result<()>,
    ) -> Result<()> {
        let g = self.g;
        // With origins, each ray also has its 12 bytes of origin in the ray buffer.
        let ray_bytes = std::mem::size_of::<T>() as u64 + 12 * self.origins.is_some() as u64;
        let cap = (g
            .limits
            .max_storage_buffer_binding_size
            .min(g.limits.max_buffer_size)
            / ray_bytes)
            .min(self.batching.max_batch as u64) as usize;
        let batch = walked.min(cap).max(1);
        let mapped = g.mapped_results && !self.batching.copy_results;
        let mut cache = self.cache.lock().unwrap_or_else(|e| e.into_inner());
        if cache
            .as_ref()
            .is_none_or(|c| c.batch < batch || c.bufs.mapped() != mapped)
        {
            // Dropped first: the old buffers and the new need not both fit.
            *cache = None;
            let bufs = self.allocate(batch, ray_bytes, mapped)?;
            let bind = self.bind(&bufs)?;
            *cache = Some(RunBuffers { batch, bufs, bind });
        }
        let RunBuffers { bufs, bind, .. } = cache.as_ref().expect("made just above");
        let max_dim = self
            .batching
            .max_groups
            .unwrap_or(u32::MAX)
            .min(g.limits.max_compute_workgroups_per_dimension)
            .max(1);
        // The rays in order, cut into batches of at most `batch`: each batch is the pieces of
        // the chunks' slices it spans, written to the device as they lie (no copy of them
        // gathered first).
        let mut rest = parts.iter().copied().filter(|p| !p.is_empty());
        let mut carry: &[T] = &[];
        let mut before = 0usize;
        let mut size = batch.min(FIRST_BATCH);
        loop {
            let (mut pieces, mut n) = (Vec::new(), 0usize);
            if self.camera.is_some() {
                n = size.min(walked - before);
            }
            while n < size && self.camera.is_none() {
                if carry.is_empty() {
                    match rest.next() {
                        Some(p) => carry = p,
                        None => break,
                    }
                }
                let take = (size - n).min(carry.len());
                pieces.push(&carry[..take]);
                carry = &carry[take..];
                n += take;
            }
            if n == 0 {
                break;
            }
            // Between batches, Ctrl-C (the bindings' poll) stops the cast.
            crate::threads::checkpoint()?;
            timings.batches += 1;
            self.upload(bufs, &pieces, before, n, timings)?;
            let wall = timings.kernel_wall;
            self.dispatch(bind, bufs, n, max_dim, timings)?;
            if n == size {
                size = next_batch(size, timings.kernel_wall - wall, batch);
            }
            read_back(g, bufs, n, timings, |results| take(before, results))??;
            before += n;
        }
        Ok(())
    }

    fn allocate(&self, batch: usize, ray_bytes: u64, mapped: bool) -> Result<RayBuffers> {
        let g = self.g;
        let out_bytes = std::mem::size_of::<RayOut>() as u64;
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
            // Mapped where they lie, or written through staging and copied out.
            let (into, out_of) = if mapped {
                (U::MAP_WRITE, U::MAP_READ)
            } else {
                (U::COPY_DST, U::COPY_SRC)
            };
            RayBuffers {
                rays: mk("rays", batch as u64 * ray_bytes, U::STORAGE | into),
                hits: mk("hits", batch as u64 * out_bytes, U::STORAGE | out_of),
                readback: (!mapped).then(|| {
                    mk(
                        "hits readback",
                        batch as u64 * out_bytes,
                        U::MAP_READ | U::COPY_DST,
                    )
                }),
                params: g
                    .device
                    .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                        label: Some("params"),
                        contents: bytemuck::bytes_of(&Params::default()),
                        usage: U::UNIFORM | U::COPY_DST,
                    }),
                shared: self.shared.map(|s| {
                    g.device
                        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                            label: Some("shared origin"),
                            contents: bytemuck::bytes_of(&s),
                            usage: U::UNIFORM | U::COPY_DST,
                        })
                }),
                stamps: g.timestamps.then(|| Stamps {
                    set: g.device.create_query_set(&wgpu::QuerySetDescriptor {
                        label: Some("kernel timestamps"),
                        ty: wgpu::QueryType::Timestamp,
                        count: 2,
                    }),
                    resolved: mk("timestamps", 16, U::QUERY_RESOLVE | U::COPY_SRC),
                    readback: mk("timestamps readback", 16, U::MAP_READ | U::COPY_DST),
                }),
            }
        })
    }

    fn bind(&self, bufs: &RayBuffers) -> Result<wgpu::BindGroup> {
        let layout = self.pipeline.get_bind_group_layout(0);
        let mut entries = vec![
            wgpu::BindGroupEntry {
                binding: 0,
                resource: bufs.params.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: self.input_binding,
                resource: bufs.rays.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 2,
                resource: bufs.hits.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 3,
                resource: self.scene.tets.as_entire_binding(),
            },
        ];
        if let Some(p) = &self.scene.points {
            entries.push(wgpu::BindGroupEntry {
                binding: 4,
                resource: p.as_entire_binding(),
            });
        }
        if let Some(b) = &bufs.shared {
            entries.push(wgpu::BindGroupEntry {
                binding: 5,
                resource: b.as_entire_binding(),
            });
        }
        for (binding, b) in self.extra {
            entries.push(wgpu::BindGroupEntry {
                binding: *binding,
                resource: b.as_entire_binding(),
            });
        }
        self.g.scoped("binding buffers", || {
            self.g.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("tetrace"),
                layout: &layout,
                entries: &entries,
            })
        })
    }

    /// Writes the batch's rays (`pieces`, or the camera kernel's directions for rays
    /// `before .. before + n`) and its uniforms, and waits for them.
    fn upload<T: bytemuck::Pod>(
        &self,
        bufs: &RayBuffers,
        pieces: &[&[T]],
        before: usize,
        n: usize,
        timings: &mut GpuTimings,
    ) -> Result<()> {
        let g = self.g;
        let mut t = Instant::now();
        let mapped = bufs.mapped();
        if let Some((kernel, cam)) = self.camera {
            let mut enc = g.device.create_command_encoder(&Default::default());
            let max_dim = self.batching.max_groups.unwrap_or(u32::MAX);
            kernel.record(
                g,
                &mut enc,
                cam,
                before as u32,
                n as u32,
                &bufs.rays,
                max_dim,
            )?;
            g.scoped("making the camera's rays", || {
                g.queue.submit([enc.finish()])
            })?;
            // The camera kernel's time is its own phase (a kernel's, not the upload's).
            g.wait()?;
            timings.camera += t.elapsed().as_secs_f64();
            t = Instant::now();
        }
        // The batch's rays, then its origins (the own-origin kernel's), one piece after another.
        let origins = self.origins.map(|o| &o[3 * before..3 * (before + n)]);
        let slices = || {
            let rays = pieces.iter().map(|p| bytemuck::cast_slice::<T, u8>(p));
            rays.chain(origins.map(bytemuck::cast_slice))
        };
        if mapped && self.camera.is_none() {
            // Shared memory (`Gpu::mapped_results`): the rays go where the kernel reads them.
            let size: usize = slices().map(<[u8]>::len).sum();
            g.write_mapped(&bufs.rays, size as u64, "the rays", |dst| {
                let mut offset = 0;
                for bytes in slices() {
                    dst.slice(offset..offset + bytes.len())
                        .copy_from_slice(bytes);
                    offset += bytes.len();
                }
            })?;
        }
        g.scoped("uploading rays", || {
            if !mapped && self.camera.is_none() {
                // Through the queue's staging memory.
                let mut offset = 0u64;
                for bytes in slices() {
                    g.queue.write_buffer(&bufs.rays, offset, bytes);
                    offset += bytes.len() as u64;
                }
            }
            if let (Some(b), Some(s)) = (&bufs.shared, &self.shared) {
                g.queue.write_buffer(b, 0, bytemuck::bytes_of(s));
            }
            g.queue.write_buffer(
                &bufs.params,
                0,
                bytemuck::bytes_of(&Params {
                    n_rays: n as u32,
                    max_steps: self.max_steps,
                    origins_at: origins.map_or(0, |_| 3 * n as u32),
                    ..Default::default()
                }),
            );
            g.queue.submit([]);
        })?;
        g.wait()?;
        timings.upload += t.elapsed().as_secs_f64();
        Ok(())
    }

    fn dispatch(
        &self,
        bind: &wgpu::BindGroup,
        bufs: &RayBuffers,
        n: usize,
        max_dim: u32,
        timings: &mut GpuTimings,
    ) -> Result<()> {
        let g = self.g;
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
                    timestamp_writes: bufs.stamps.as_ref().map(|s| {
                        wgpu::ComputePassTimestampWrites {
                            query_set: &s.set,
                            beginning_of_pass_write_index: Some(0),
                            end_of_pass_write_index: Some(1),
                        }
                    }),
                });
                pass.set_pipeline(self.pipeline);
                pass.set_bind_group(0, bind, &[]);
                pass.dispatch_workgroups(gx, gy, 1);
            }
            if let Some(s) = &bufs.stamps {
                enc.resolve_query_set(&s.set, 0..2, &s.resolved, 0);
                enc.copy_buffer_to_buffer(&s.resolved, 0, &s.readback, 0, 16);
            }
            g.queue.submit([enc.finish()]);
        })?;
        g.wait()?;
        let wall = t.elapsed().as_secs_f64();
        timings.kernel_wall += wall;
        timings.kernel += match &bufs.stamps {
            Some(s) => {
                let mut ticks: Vec<u64> = Vec::with_capacity(2);
                g.read_mapped(&s.readback, 16, &mut ticks, "the kernel's timestamps")?;
                // Ticks of `get_timestamp_period` nanoseconds; a device that wraps or resets
                // them between the two gives no time: the wall time stands in.
                let period = g.queue.get_timestamp_period() as f64;
                match ticks[1].checked_sub(ticks[0]) {
                    Some(dt) if period > 0.0 => dt as f64 * period * 1e-9,
                    _ => wall,
                }
            }
            None => wall,
        };
        Ok(())
    }
}

/// Copies the first `n` results to the readback buffer and gives them, mapped, to `take`
/// (its time is the finishing's, the rest the readback's).
fn read_back<R>(
    g: &Gpu,
    bufs: &RayBuffers,
    n: usize,
    timings: &mut GpuTimings,
    take: impl FnOnce(&[RayOut]) -> R,
) -> Result<R> {
    let t = Instant::now();
    let size = n as u64 * std::mem::size_of::<RayOut>() as u64;
    let mapped = match &bufs.readback {
        Some(readback) => {
            g.scoped("reading results back", || {
                let mut enc = g.device.create_command_encoder(&Default::default());
                enc.copy_buffer_to_buffer(&bufs.hits, 0, readback, 0, size);
                g.queue.submit([enc.finish()]);
            })?;
            readback
        }
        None => &bufs.hits,
    };
    let mut taken = 0.0;
    let r = g.with_mapped(mapped, size, "the results", |results| {
        let t = Instant::now();
        let r = take(results);
        taken = t.elapsed().as_secs_f64();
        r
    })?;
    timings.finish += taken;
    timings.readback += t.elapsed().as_secs_f64() - taken;
    Ok(r)
}

#[cfg(test)]
mod tests {
    use super::{next_batch, BATCH_SECONDS};

    /// Batches grow fourfold while the kernel is quick, up to the cap, and stop growing once
    /// a fourfold batch could pass the time a batch may take (Ctrl-C waits for a batch).
    #[test]
    fn batches_grow_only_while_the_kernel_is_quick() {
        assert_eq!(next_batch(1 << 16, 0.001, 1 << 20), 1 << 18);
        assert_eq!(next_batch(1 << 18, 0.001, 1 << 20), 1 << 20);
        assert_eq!(next_batch(1 << 20, 0.001, 1 << 20), 1 << 20);
        assert_eq!(next_batch(1000, 0.0, 1000), 1000);
        assert_eq!(next_batch(1 << 16, BATCH_SECONDS / 4.0, 1 << 20), 1 << 18);
        assert_eq!(next_batch(1 << 16, BATCH_SECONDS / 3.9, 1 << 20), 1 << 16);
        assert_eq!(next_batch(1 << 16, 6.0, 1 << 20), 1 << 16);
    }
}
