//! The flattened octree's buffers and pipeline on a device, and the kernel run over batches.

use super::*;
use crate::error::Result;
use crate::gpu::context::Gpu;
use crate::gpu::upload::check_fits;
use bytemuck::Pod;
use std::mem::size_of;
use wgpu::util::DeviceExt;

/// An octree's buffers and the kernel's pipeline on a device.
pub struct DeviceOctree {
    params: OctParams,
    records: wgpu::Buffer,
    boxes: wgpu::Buffer,
    grid: wgpu::Buffer,
    tris: wgpu::Buffer,
    cube: wgpu::Buffer,
    pipeline: wgpu::ComputePipeline,
}

impl DeviceOctree {
    /// Uploads `host`'s buffers and compiles the kernel.
    pub fn new(g: &Gpu, host: &OctreeHost) -> Result<DeviceOctree> {
        let device = g.adapter.name.clone();
        fn bytes<T: Pod>(v: &[T], pad: T) -> Vec<u8> {
            // A binding may not be empty (a scene with no triangles).
            if v.is_empty() {
                bytemuck::bytes_of(&pad).to_vec()
            } else {
                bytemuck::cast_slice(v).to_vec()
            }
        }
        let parts = [
            ("octree records", bytes(&host.records, 0u32)),
            ("octree boxes", bytes(&host.boxes, [0u32; 4])),
            ("octree planes", bytes(&host.grid, 0f32)),
            ("octree triangles", bytes(&host.tris, [0f32; 4])),
            ("octree cube map", bytes(&host.cube, 0u32)),
        ];
        for (label, b) in &parts {
            check_fits(label, b.len() as u64, &g.limits, &device)?;
        }
        let source = source();
        let (bufs, pipeline) = g.scoped("uploading the octree and compiling its kernel", || {
            let bufs: Vec<wgpu::Buffer> = parts
                .iter()
                .map(|(label, b)| {
                    g.device
                        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                            label: Some(label),
                            contents: b,
                            usage: wgpu::BufferUsages::STORAGE,
                        })
                })
                .collect();
            (bufs, g.compute_pipeline(PATH, &source, "main"))
        })?;
        let [records, boxes, grid, tris, cube]: [wgpu::Buffer; 5] =
            bufs.try_into().expect("five buffers");
        Ok(DeviceOctree {
            params: host.params,
            records,
            boxes,
            grid,
            tris,
            cube,
            pipeline,
        })
    }

    /// Runs the kernel on prepared rays, in batches of at most `max_batch`.
    pub fn run(
        &self,
        g: &Gpu,
        rays: &[OctRayIn],
        max_steps: Option<u32>,
        max_batch: usize,
    ) -> Result<Vec<OctRayOut>> {
        let mut out = Vec::with_capacity(rays.len());
        if rays.is_empty() {
            return Ok(out);
        }
        let batch = rays.len().min(max_batch.max(1));
        let in_bytes = (batch * size_of::<OctRayIn>()) as u64;
        let out_bytes = (batch * size_of::<OctRayOut>()) as u64;
        check_fits("octree rays", in_bytes, &g.limits, &g.adapter.name)?;
        use wgpu::BufferUsages as U;
        let mk = |label, size, usage| {
            g.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage,
                mapped_at_creation: false,
            })
        };
        let (params, rays_buf, hits, readback, bind) = g.scoped("octree ray buffers", || {
            let params = mk("octree params", 64, U::UNIFORM | U::COPY_DST);
            let rays_buf = mk("octree rays", in_bytes, U::STORAGE | U::COPY_DST);
            let hits = mk("octree hits", out_bytes, U::STORAGE | U::COPY_SRC);
            let readback = mk("octree readback", out_bytes, U::MAP_READ | U::COPY_DST);
            let layout = self.pipeline.get_bind_group_layout(0);
            let entries: Vec<wgpu::BindGroupEntry> = [
                &params,
                &rays_buf,
                &hits,
                &self.records,
                &self.boxes,
                &self.grid,
                &self.tris,
                &self.cube,
            ]
            .iter()
            .enumerate()
            .map(|(i, b)| wgpu::BindGroupEntry {
                binding: i as u32,
                resource: b.as_entire_binding(),
            })
            .collect();
            let bind = g.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("octree"),
                layout: &layout,
                entries: &entries,
            });
            (params, rays_buf, hits, readback, bind)
        })?;
        let max_dim = g.limits.max_compute_workgroups_per_dimension.max(1);
        for chunk in rays.chunks(batch) {
            let n = chunk.len();
            let size = (n * size_of::<OctRayOut>()) as u64;
            g.scoped("running the octree kernel", || {
                let p = OctParams {
                    n_rays: n as u32,
                    max_steps: max_steps.unwrap_or(self.params.max_steps),
                    ..self.params
                };
                g.queue.write_buffer(&params, 0, bytemuck::bytes_of(&p));
                g.queue
                    .write_buffer(&rays_buf, 0, bytemuck::cast_slice(chunk));
                let groups = (n as u32).div_ceil(WORKGROUP);
                let (gx, gy) = if groups <= max_dim {
                    (groups, 1)
                } else {
                    (max_dim, groups.div_ceil(max_dim))
                };
                let mut enc = g.device.create_command_encoder(&Default::default());
                {
                    let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                        label: Some("octree walk"),
                        timestamp_writes: None,
                    });
                    pass.set_pipeline(&self.pipeline);
                    pass.set_bind_group(0, &bind, &[]);
                    pass.dispatch_workgroups(gx, gy, 1);
                }
                enc.copy_buffer_to_buffer(&hits, 0, &readback, 0, size);
                g.queue.submit([enc.finish()]);
            })?;
            g.read_mapped(&readback, size, &mut out, "the octree results")?;
        }
        Ok(out)
    }

    /// Prepares rays on the host (as the twin does) and traces them on the device; rays that
    /// cannot be traced come back INVALID without reaching it.
    pub fn cast(
        &self,
        g: &Gpu,
        host: &OctreeHost,
        o: &[f32],
        d: &[f32],
        max_steps: Option<u32>,
    ) -> Result<Vec<OctRayOut>> {
        let n = o.len() / 3;
        let v = |x: &[f32], i: usize| [x[3 * i], x[3 * i + 1], x[3 * i + 2]];
        let prepared: Vec<_> = (0..n).map(|i| host.prepare(v(o, i), v(d, i))).collect();
        let rays: Vec<OctRayIn> = prepared.iter().filter_map(|r| r.ok()).collect();
        let mut walked = self.run(g, &rays, max_steps, MAX_BATCH)?.into_iter();
        Ok(prepared
            .iter()
            .map(|r| match r {
                Ok(_) => walked.next().expect("one result per walked ray"),
                Err(s) => OctRayOut::new(*s, NO_TRI, 0.0, 0),
            })
            .collect())
    }
}
