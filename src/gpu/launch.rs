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
/// ([`next_batch`]), so a fast device reaches full batches in a few. Each batch costs the
/// device time its timestamps do not hold (about a millisecond on lavapipe, where a batch
/// of 2^16 exact rays took 0.2 s and a 512² camera's four batches left 19–37 ns a ray of
/// host time against 18–22 for one batch and its tail), so batches start at 2^18: a slow
/// device's batch then takes up to about a second, Ctrl-C's wait.
const FIRST_BATCH: usize = 1 << 18;

/// Rays a run's last batch leaves to one more at least: one chunk of the cast's (`ByChunk`).
const TAIL: usize = 4096;

/// Rays in the next batch when `left` remain and a batch holds `size`: as many as fit, except
/// that a last batch of more than 2 [`TAIL`] rays leaves `TAIL` of them to one more batch.
/// The host answers each batch while the device walks the next, but the last batch's answers
/// overlap no walk: a small last batch leaves little of them exposed (docs/gpu.md, "Fewer
/// batches and a small last one").
pub(crate) fn batch_rays(size: usize, left: usize) -> usize {
    if left <= size && left > 2 * TAIL {
        left - TAIL
    } else {
        left.min(size)
    }
}

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

/// A kernel's ray buffers for batches of up to `batch` rays, and their bind groups: one set,
/// or two for a run of more than one batch, which is pipelined (a batch's kernel runs while the
/// host finishes the batch before it and writes the one after it).
pub(crate) struct RunBuffers {
    batch: usize,
    mapped: bool,
    sets: Vec<BatchSet>,
}

/// One batch's buffers on the device and the kernel's bind group over them.
struct BatchSet {
    bufs: RayBuffers,
    bind: wgpu::BindGroup,
}

impl RunBuffers {
    /// Bytes on the device.
    pub(crate) fn bytes(&self) -> u64 {
        self.sets.iter().map(|s| s.bufs.bytes()).sum()
    }
}

/// A batch submitted and not yet read back.
struct InFlight {
    /// Its buffer set.
    slot: usize,
    /// Rays of the run before it, and its own.
    before: usize,
    n: usize,
    /// Whether it was as large as the schedule allowed (its time then informs the next size).
    full: bool,
    index: wgpu::SubmissionIndex,
    submitted: Instant,
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
    fn bytes(&self) -> u64 {
        self.rays.size()
            + self.hits.size()
            + self.readback.as_ref().map_or(0, wgpu::Buffer::size)
            + self.params.size()
            + self.shared.as_ref().map_or(0, wgpu::Buffer::size)
    }

    /// Whether rays and results are mapped where the kernel reads and writes them.
    fn mapped(&self) -> bool {
        self.readback.is_none()
    }
}

/// The walk's begin and end timestamps, then the camera kernel's (`Gpu::timestamps`).
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
    ///
    /// Batches are pipelined: each is one submission (its rays or camera kernel, the walk,
    /// the copies back), and the host writes and submits batch k + 1 before it waits for
    /// batch k and answers from it, so the device walks k + 1 meanwhile.
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
        let mut size = batch.min(FIRST_BATCH);
        // A run of one batch needs one set of buffers; a longer one two, to overlap.
        let sets = if batch_rays(size, walked) < walked {
            2
        } else {
            1
        };
        let mut cache = self.cache.lock().unwrap_or_else(|e| e.into_inner());
        if cache
            .as_ref()
            .is_none_or(|c| c.batch < batch || c.mapped != mapped)
        {
            // Dropped first: the old buffers and the new need not both fit.
            *cache = None;
            *cache = Some(RunBuffers {
                batch,
                mapped,
                sets: Vec::new(),
            });
        }
        let kept = cache.as_mut().expect("made just above");
        while kept.sets.len() < sets {
            let bufs = self.allocate(kept.batch, ray_bytes, mapped)?;
            let bind = self.bind(&bufs)?;
            kept.sets.push(BatchSet { bufs, bind });
        }
        let kept = &kept.sets[..sets];
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
        // Each set's last submission in this run: what writing into it again waits for (None,
        // at a run's start: a set no submission uses maps at once, else after all work, as
        // where an interrupted run left a batch in flight).
        let mut last: Vec<Option<wgpu::SubmissionIndex>> = vec![None; sets];
        let mut in_flight: Option<InFlight> = None;
        let mut slot = 0;
        loop {
            let (mut pieces, mut n) = (Vec::new(), 0usize);
            let limit = batch_rays(size, walked - before);
            if self.camera.is_some() {
                n = limit;
            }
            while n < limit && self.camera.is_none() {
                if carry.is_empty() {
                    match rest.next() {
                        Some(p) => carry = p,
                        None => break,
                    }
                }
                let take = (limit - n).min(carry.len());
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
            if let Some(p) = in_flight.take_if(|p| p.slot == slot) {
                // One set: the batch before is read back before its buffers are reused.
                size = self.complete(&kept[p.slot], p, size, batch, timings, &mut take)?;
            }
            let set = &kept[slot];
            let (index, submitted) =
                self.submit(set, last[slot].take(), &pieces, before, n, max_dim, timings)?;
            last[slot] = Some(index.clone());
            let now = InFlight {
                slot,
                before,
                n,
                full: n == size,
                index,
                submitted,
            };
            if let Some(p) = in_flight.replace(now) {
                size = self.complete(&kept[p.slot], p, size, batch, timings, &mut take)?;
            }
            slot = (slot + 1) % sets;
            before += n;
        }
        if let Some(p) = in_flight {
            self.complete(&kept[p.slot], p, size, batch, timings, &mut take)?;
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
                        count: 4,
                    }),
                    resolved: mk("timestamps", 32, U::QUERY_RESOLVE | U::COPY_SRC),
                    readback: mk("timestamps readback", 32, U::MAP_READ | U::COPY_DST),
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

    /// Writes batch `before .. before + n`'s rays (`pieces`, with their origins) and
    /// uniforms into `set`, and submits, in one submission, the camera kernel making its
    /// directions where there is one, the walk, and the copies of its timestamps and results
    /// to where they are read back. `last` is the set's previous submission in this run.
    /// Returns the submission and when it was made.
    #[allow(clippy::too_many_arguments)] // a batch's parts
    fn submit<T: bytemuck::Pod>(
        &self,
        set: &BatchSet,
        last: Option<wgpu::SubmissionIndex>,
        pieces: &[&[T]],
        before: usize,
        n: usize,
        max_dim: u32,
        timings: &mut GpuTimings,
    ) -> Result<(wgpu::SubmissionIndex, Instant)> {
        let g = self.g;
        let t = Instant::now();
        let bufs = &set.bufs;
        let mapped = bufs.mapped();
        // The batch's rays, then its origins (the own-origin kernel's), one piece after another.
        let origins = self.origins.map(|o| &o[3 * before..3 * (before + n)]);
        let slices = || {
            let rays = pieces.iter().map(|p| bytemuck::cast_slice::<T, u8>(p));
            rays.chain(origins.map(bytemuck::cast_slice))
        };
        if mapped && self.camera.is_none() {
            // Shared memory (`Gpu::mapped_results`): the rays go where the kernel reads them.
            let size: usize = slices().map(<[u8]>::len).sum();
            g.write_mapped(&bufs.rays, size as u64, last, "the rays", |dst| {
                let mut offset = 0;
                for bytes in slices() {
                    dst.slice(offset..offset + bytes.len())
                        .copy_from_slice(bytes);
                    offset += bytes.len();
                }
            })?;
        }
        let groups = (n as u32).div_ceil(WORKGROUP);
        let (gx, gy) = if groups <= max_dim {
            (groups, 1)
        } else {
            (max_dim, groups.div_ceil(max_dim))
        };
        let stamps = |at: u32| {
            bufs.stamps
                .as_ref()
                .map(|s| wgpu::ComputePassTimestampWrites {
                    query_set: &s.set,
                    beginning_of_pass_write_index: Some(at),
                    end_of_pass_write_index: Some(at + 1),
                })
        };
        let index = g.scoped("running the traversal kernel", || {
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
            let mut enc = g.device.create_command_encoder(&Default::default());
            if let Some((kernel, cam)) = self.camera {
                let max_dim = self.batching.max_groups.unwrap_or(u32::MAX);
                kernel.record(
                    g,
                    &mut enc,
                    cam,
                    before as u32,
                    n as u32,
                    &bufs.rays,
                    max_dim,
                    stamps(2),
                )?;
            }
            {
                let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("walk"),
                    timestamp_writes: stamps(0),
                });
                pass.set_pipeline(self.pipeline);
                pass.set_bind_group(0, &set.bind, &[]);
                pass.dispatch_workgroups(gx, gy, 1);
            }
            if let Some(s) = &bufs.stamps {
                let count = self.stamp_count();
                enc.resolve_query_set(&s.set, 0..count, &s.resolved, 0);
                enc.copy_buffer_to_buffer(&s.resolved, 0, &s.readback, 0, 8 * count as u64);
            }
            if let Some(readback) = &bufs.readback {
                let size = n as u64 * std::mem::size_of::<RayOut>() as u64;
                enc.copy_buffer_to_buffer(&bufs.hits, 0, readback, 0, size);
            }
            let cmd = enc.finish();
            // The submission counts as the kernel's (`kernel_wall`), not the upload's: a
            // driver may run the work before `submit` returns (lavapipe does).
            let at = Instant::now();
            Ok((g.queue.submit([cmd]), at))
        })??;
        timings.upload += (index.1 - t).as_secs_f64();
        Ok(index)
    }

    /// The timestamps a batch writes: the walk's two, and the camera kernel's.
    fn stamp_count(&self) -> u32 {
        if self.camera.is_some() {
            4
        } else {
            2
        }
    }

    /// Waits for batch `p`, reads its kernels' times and gives its results, mapped where they
    /// lie, to `take` (its time is the finishing's; the mappings' the readback's). Returns
    /// the next batch's size: `size`, grown by [`next_batch`] after a full batch.
    fn complete(
        &self,
        set: &BatchSet,
        p: InFlight,
        size: usize,
        cap: usize,
        timings: &mut GpuTimings,
        take: &mut impl FnMut(usize, &[RayOut]) -> Result<()>,
    ) -> Result<usize> {
        let g = self.g;
        g.wait_for(Some(p.index.clone()))?;
        // From the submission to the host seeing its end: with the batch before it in flight,
        // this includes the time the device spent on that one.
        let wall = p.submitted.elapsed().as_secs_f64();
        timings.kernel_wall += wall;
        let t = Instant::now();
        let bufs = &set.bufs;
        let (kernel, camera) = match &bufs.stamps {
            Some(s) => {
                let count = self.stamp_count();
                let mut ticks: Vec<u64> = Vec::with_capacity(count as usize);
                g.with_mapped_after(
                    &s.readback,
                    8 * count as u64,
                    Some(p.index.clone()),
                    "the kernel's timestamps",
                    |v: &[u64]| ticks.extend_from_slice(v),
                )?;
                // Ticks of `get_timestamp_period` nanoseconds; a device that wraps or resets
                // them between the two gives no time: the wall time stands in.
                let period = g.queue.get_timestamp_period() as f64;
                let span = |at: usize| match ticks[at + 1].checked_sub(ticks[at]) {
                    Some(dt) if period > 0.0 => Some(dt as f64 * period * 1e-9),
                    _ => None,
                };
                let camera = if self.camera.is_some() { span(2) } else { None };
                (span(0).unwrap_or(wall), camera.unwrap_or(0.0))
            }
            // No timestamps: the wall time holds the camera kernel's too.
            None => (wall, 0.0),
        };
        timings.kernel += kernel;
        timings.camera += camera;
        let results = bufs.readback.as_ref().unwrap_or(&bufs.hits);
        let bytes = p.n as u64 * std::mem::size_of::<RayOut>() as u64;
        let mut taken = 0.0;
        g.with_mapped_after(results, bytes, Some(p.index), "the results", |r| {
            let t = Instant::now();
            let out = take(p.before, r);
            taken = t.elapsed().as_secs_f64();
            out
        })??;
        timings.finish += taken;
        timings.readback += t.elapsed().as_secs_f64() - taken;
        Ok(if p.full {
            size.max(next_batch(p.n, kernel + camera, cap))
        } else {
            size
        })
    }
}

#[cfg(test)]
mod tests {
    use super::{batch_rays, next_batch, BATCH_SECONDS, TAIL};

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

    /// A run's batches take every ray once, none above the batch size; a run whose last batch
    /// would exceed 2 TAIL rays ends on one of TAIL rays; runs of at most 2 TAIL rays (or a
    /// batch's) are one batch.
    #[test]
    fn the_last_batch_is_small() {
        for (size, walked) in [
            (1 << 16, 262_144),
            (1 << 16, 65_536),
            (1 << 16, 100_000),
            (1 << 20, 2_764_800),
            (1 << 16, 2 * TAIL),
            (1 << 16, 2 * TAIL + 1),
            (1 << 16, 17),
            (1000, 36_384),
            (100, 250),
        ] {
            let (mut left, mut cuts) = (walked, Vec::new());
            while left > 0 {
                let n = batch_rays(size, left);
                assert!(
                    n > 0 && n <= size && n <= left,
                    "{size} {walked}: {n} of {left}"
                );
                cuts.push(n);
                left -= n;
            }
            let last = *cuts.last().unwrap();
            if walked <= size.min(2 * TAIL) {
                assert_eq!(cuts, [walked]);
            }
            if size > 2 * TAIL && walked > 2 * TAIL {
                // The batch before the last was cut: the last holds what it left.
                let full_last = walked - (walked - 1) / size * size;
                assert!(last < full_last && last == TAIL, "{cuts:?}");
            }
        }
    }
}
