//! A scene's copies on the device: one set of buffers per layout, uploaded by the first GPU
//! cast with a kernel on that layout and kept for the next. The CPU scene does not hold them:
//! whoever casts on the GPU keeps a [`DeviceScene`] beside its [`Scene`].

use super::context::Gpu;
use super::kernels::{GpuLayout, KernelSpec};
use super::structs::{Face80, Tet20, Tet80};
use crate::error::{Error, Result};
use crate::scene::Scene;
use rayon::prelude::*;
use std::collections::HashMap;
use std::sync::{Arc, Mutex};
use std::time::Instant;

/// A scene's buffers on the device for one layout.
pub struct LayoutBuffers {
    /// The layout's records (binding 3).
    pub tets: wgpu::Buffer,
    /// Float32 points, padded to 16 bytes (binding 4), for layouts naming vertices by id.
    pub points: Option<wgpu::Buffer>,
}

impl LayoutBuffers {
    fn bytes(&self) -> u64 {
        self.tets.size() + self.points.as_ref().map_or(0, wgpu::Buffer::size)
    }
}

/// The device copies of one scene, by layout name: kernels on the same layout (aman2022 and
/// robust on tet20) share them. Empty until the first GPU cast; it must only ever be used with
/// the one scene it was first used with.
#[derive(Default)]
pub struct DeviceScene {
    buffers: Mutex<HashMap<&'static str, Arc<LayoutBuffers>>>,
}

impl DeviceScene {
    /// Bytes on the device per layout (records, and points for id layouts).
    pub fn bytes(&self) -> Vec<(&'static str, u64)> {
        let b = self.buffers.lock().unwrap_or_else(|e| e.into_inner());
        b.iter().map(|(k, s)| (*k, s.bytes())).collect()
    }

    /// The buffers for `kernel`'s layout, uploaded now if they are not on the device yet, and
    /// the seconds the upload took (0 when they were there).
    pub(crate) fn buffers(
        &self,
        g: &Gpu,
        scene: &Scene,
        kernel: &KernelSpec,
    ) -> Result<(Arc<LayoutBuffers>, f64)> {
        let layout: &GpuLayout = kernel.layout;
        let mut cache = self.buffers.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(b) = cache.get(layout.name) {
            return Ok((b.clone(), 0.0));
        }
        let t0 = Instant::now();
        let b = (layout.upload)(g, scene)?;
        g.wait()?;
        let b = Arc::new(b);
        cache.insert(layout.name, b.clone());
        Ok((b, t0.elapsed().as_secs_f64()))
    }
}

/// Tet20: its records, and the points in float32.
pub(crate) fn upload_tet20(g: &Gpu, scene: &Scene) -> Result<LayoutBuffers> {
    let l = crate::layout::get(&scene.layouts.tet20, &scene.mesh)?;
    let tets = upload_records(g, "tet20 records", l.records.len(), |i| {
        let r = &l.records[i];
        Tet20 {
            vertex_xor: r.vertex_xor,
            links: r.links,
        }
    })?;
    let p = &scene.points_f32;
    let points = upload_records(g, "float32 points", p.len(), |i| {
        [p[i][0], p[i][1], p[i][2], 0.0f32]
    })?;
    Ok(LayoutBuffers {
        tets,
        points: Some(points),
    })
}

/// Tet80: its records alone (the vertices are in them).
pub(crate) fn upload_tet80(g: &Gpu, scene: &Scene) -> Result<LayoutBuffers> {
    let l = crate::layout::get(&scene.layouts.tet80, &scene.mesh)?;
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
    Ok(LayoutBuffers { tets, points: None })
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
