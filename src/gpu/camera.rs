//! The camera kernel (`shaders/camera.wgsl`): a camera's float32 directions made on the
//! device, the same bits as its CPU twin [`crate::camera::direction`], or NaN for a ray the
//! kernel hands back (the host makes those with the twin).

use super::context::Gpu;
use super::structs::WORKGROUP;
use crate::camera::CameraF32;
use crate::error::{Error, Result};
use bytemuck::{Pod, Zeroable};
use std::mem::{offset_of, size_of};
use wgpu::util::DeviceExt;

/// The kernel's file under `shaders/`, as embedded.
pub const PATH: &str = "camera.wgsl";
pub const FILE: &str = include_str!("../../shaders/camera.wgsl");

/// `CamParams` of the kernel (uniform).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct CamParams {
    pub forward: [f32; 3],
    pub n_rays: u32,
    pub right: [f32; 3],
    pub width: u32,
    pub up: [f32; 3],
    pub first: u32,
    pub normalize: u32,
    pub height: u32,
    pub _pad0: u32,
    pub _pad1: u32,
}

// WGSL layout: vec3<f32> aligns to 16 and takes 12, so a u32 follows it.
const _: () = {
    assert!(size_of::<CamParams>() == 64);
    assert!(offset_of!(CamParams, forward) == 0);
    assert!(offset_of!(CamParams, n_rays) == 12);
    assert!(offset_of!(CamParams, right) == 16);
    assert!(offset_of!(CamParams, width) == 28);
    assert!(offset_of!(CamParams, up) == 32);
    assert!(offset_of!(CamParams, first) == 44);
    assert!(offset_of!(CamParams, normalize) == 48);
    assert!(offset_of!(CamParams, height) == 52);
};

/// The kernel's pipeline on a device.
pub struct CameraKernel {
    pipeline: wgpu::ComputePipeline,
}

/// A camera's inputs on a device: its uniform and its coordinates (`xs`, `ys`, then the 0
/// the kernel reads as `zero_bits`).
pub struct DeviceCamera {
    params: CamParams,
    uniform: wgpu::Buffer,
    coords: wgpu::Buffer,
}

impl CameraKernel {
    pub fn new(g: &Gpu) -> Result<CameraKernel> {
        let pipeline = g.scoped("compiling the camera kernel", || {
            g.compute_pipeline(PATH, FILE, "main")
        })?;
        Ok(CameraKernel { pipeline })
    }

    /// Uploads `c`'s numbers. Refuses a camera the kernel cannot make exactly
    /// ([`CameraF32::fits_device`]: its rays are made on the host) or whose pixels do not fit
    /// the kernel's 32-bit indices.
    pub fn upload(&self, g: &Gpu, c: &CameraF32) -> Result<DeviceCamera> {
        c.check()?;
        if !c.fits_device() {
            return Err(Error::InvalidInput(
                "the camera kernel takes numbers of magnitude 0 or within [2^-60, 2^30]".into(),
            ));
        }
        let n = c.n_rays();
        if n > u32::MAX as usize {
            return Err(Error::InvalidInput(format!(
                "{n} pixels: the camera kernel numbers them in 32 bits"
            )));
        }
        let params = CamParams {
            forward: c.forward,
            right: c.right,
            up: c.up,
            width: c.width() as u32,
            height: c.height() as u32,
            normalize: c.normalize as u32,
            ..Default::default()
        };
        let coords: Vec<f32> = c.xs.iter().chain(&c.ys).copied().chain([0.0]).collect();
        g.scoped("uploading the camera", || {
            use wgpu::BufferUsages as U;
            DeviceCamera {
                params,
                uniform: g
                    .device
                    .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                        label: Some("camera"),
                        contents: bytemuck::bytes_of(&params),
                        usage: U::UNIFORM | U::COPY_DST,
                    }),
                coords: g
                    .device
                    .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                        label: Some("camera coordinates"),
                        contents: bytemuck::cast_slice(&coords),
                        usage: U::STORAGE,
                    }),
            }
        })
    }

    /// Records the kernel writing rays `first .. first + n` into `dirs` (three f32 a ray,
    /// from its start) into `enc`, in rows of at most `max_dim` workgroups (a 2D dispatch
    /// beyond), its pass timed by `stamps` where given. One record per submission: each
    /// writes the camera's uniform (queue writes land before the next submission, after the
    /// ones before it, so batches in flight keep theirs).
    #[allow(clippy::too_many_arguments)] // a dispatch's parts
    pub fn record(
        &self,
        g: &Gpu,
        enc: &mut wgpu::CommandEncoder,
        cam: &DeviceCamera,
        first: u32,
        n: u32,
        dirs: &wgpu::Buffer,
        max_dim: u32,
        stamps: Option<wgpu::ComputePassTimestampWrites>,
    ) -> Result<()> {
        let params = CamParams {
            first,
            n_rays: n,
            ..cam.params
        };
        g.queue
            .write_buffer(&cam.uniform, 0, bytemuck::bytes_of(&params));
        let bind = g.scoped("binding the camera kernel's buffers", || {
            g.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("camera"),
                layout: &self.pipeline.get_bind_group_layout(0),
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: cam.uniform.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: cam.coords.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 2,
                        resource: dirs.as_entire_binding(),
                    },
                ],
            })
        })?;
        let groups = n.div_ceil(WORKGROUP);
        let max_dim = max_dim
            .min(g.limits.max_compute_workgroups_per_dimension)
            .max(1);
        let (gx, gy) = if groups <= max_dim {
            (groups, 1)
        } else {
            (max_dim, groups.div_ceil(max_dim))
        };
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("camera"),
            timestamp_writes: stamps,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &bind, &[]);
        pass.dispatch_workgroups(gx, gy, 1);
        Ok(())
    }

    /// Every ray's direction made on the device and read back (NaN where the kernel handed
    /// the ray back): what the tests compare with the twin.
    pub fn directions(&self, g: &Gpu, c: &CameraF32) -> Result<Vec<f32>> {
        let cam = self.upload(g, c)?;
        let n = c.n_rays() as u32;
        let size = 12 * n.max(1) as u64;
        use wgpu::BufferUsages as U;
        let mk = |label, usage| {
            g.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage,
                mapped_at_creation: false,
            })
        };
        let dirs = mk("camera directions", U::STORAGE | U::COPY_SRC);
        let readback = mk("camera directions readback", U::MAP_READ | U::COPY_DST);
        let mut enc = g.device.create_command_encoder(&Default::default());
        self.record(g, &mut enc, &cam, 0, n, &dirs, u32::MAX, None)?;
        enc.copy_buffer_to_buffer(&dirs, 0, &readback, 0, size);
        g.scoped("running the camera kernel", || {
            g.queue.submit([enc.finish()])
        })?;
        let mut out = Vec::new();
        g.read_mapped(
            &readback,
            12 * n as u64,
            &mut out,
            "the camera's directions",
        )?;
        Ok(out)
    }
}
