//! A scene's records on the device: one set of buffers per layout (`GpuLayout::upload`, the
//! kernel table's), each checked against the device's limits and filled while mapped.

use super::context::Gpu;
use super::structs::{Face80, Tet20, Tet80};
use crate::error::{Error, Result};
use crate::scene::Scene;
use rayon::prelude::*;

/// A scene's buffers on the device for one layout.
pub struct LayoutBuffers {
    /// The layout's records (binding 3).
    pub tets: wgpu::Buffer,
    /// Float32 points, padded to 16 bytes (binding 4), for layouts naming vertices by id.
    pub points: Option<wgpu::Buffer>,
    /// max |p − p̃|₁ over the points p and their float32 copies p̃ on the device, rounded up:
    /// how far a vertex the kernels read may be from the mesh's float64 one (0 when every
    /// point is a float32 number). The exact kernel's certified signs allow for it.
    pub points_slack: f32,
}

impl LayoutBuffers {
    pub(crate) fn bytes(&self) -> u64 {
        self.tets.size() + self.points.as_ref().map_or(0, wgpu::Buffer::size)
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
        points_slack: points_slack(&scene.mesh.points, p),
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
    Ok(LayoutBuffers {
        tets,
        points: None,
        points_slack: points_slack(&scene.mesh.points, &scene.points_f32),
    })
}

/// max |p − p̃|₁ over the points and their float32 copies, rounded up to float32.
pub(crate) fn points_slack(points: &[[f64; 3]], f32s: &[[f32; 3]]) -> f32 {
    // One pass, on this thread: a few ns a point, beside the upload of the records.
    points
        .iter()
        .zip(f32s)
        .map(|(p, q)| slack(*p, *q))
        .fold(0.0f32, f32::max)
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
pub(crate) fn upload_records<T: bytemuck::Pod + Send>(
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
                // The fill runs in tetrace's default pool, as every parallel step does
                // (threads.rs: fork-safe), not in rayon's global one.
                let pool = crate::threads::pool(None)?;
                const BLOCK: usize = 1 << 16;
                let mut block: Vec<T> = Vec::with_capacity(BLOCK);
                let rsize = std::mem::size_of::<T>();
                for start in (0..n).step_by(BLOCK) {
                    let end = (start + BLOCK).min(n);
                    block.clear();
                    pool.install(|| {
                        (start..end)
                            .into_par_iter()
                            .map(&fill)
                            .collect_into_vec(&mut block)
                    });
                    view.slice(start * rsize..end * rsize)
                        .copy_from_slice(bytemuck::cast_slice(&block));
                }
            }
            buf.unmap();
            Ok(buf)
        },
    )?
}

/// |s − s̃|₁ rounded up to float32: how far the float32 start point the kernel subtracts is
/// from the exact start point of the robust walk's line (docs/gpu.md).
pub fn slack(s: [f64; 3], sr: [f32; 3]) -> f32 {
    // Each difference is exact in f64 (s̃ is s rounded); the sum and the conversion round by
    // far less than the 1e-6 margin.
    let e: f64 = (0..3).map(|k| (s[k] - sr[k] as f64).abs()).sum();
    (e * (1.0 + 1e-6)) as f32
}
