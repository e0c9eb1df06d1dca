//! A scene's copies on the device: one set of buffers per layout, uploaded by the first GPU
//! cast with a kernel on that layout and kept for the next. The CPU scene does not hold them:
//! whoever casts on the GPU keeps a [`DeviceScene`] beside its [`Scene`].

use super::camera::CameraKernel;
use super::context::Gpu;
use super::context::KernelKey;
use super::finish::{upload_hit_table, HitTable};
use super::kernels::{GpuLayout, KernelSpec};
use super::launch::RunBuffers;
use super::origin::{upload_entry_grid, upload_locate_table, EntryGrid, LocateTable};
use super::upload::LayoutBuffers;
use crate::error::Result;
use crate::scene::Scene;
use std::collections::HashMap;
use std::sync::{Arc, Mutex};
use std::time::Instant;

/// One kernel's ray buffers, shared by the casts that take turns with them.
pub(crate) type KeptRuns = Arc<Mutex<Option<RunBuffers>>>;

/// The device copies of one scene, by layout name: kernels on the same layout (aman2022 and
/// robust on tet20) share them. Empty until the first GPU cast; it must only ever be used with
/// the one scene it was first used with.
#[derive(Default)]
pub struct DeviceScene {
    buffers: Mutex<HashMap<&'static str, Arc<LayoutBuffers>>>,
    /// Each kernel's ray buffers and bind group (bound to this scene's buffers), by kernel:
    /// made by its first cast, kept for the next (`launch::Launch::cache`).
    runs: Mutex<HashMap<KernelKey, KeptRuns>>,
    /// The box's entry grid, for the shared-origin kernel (uploaded by its first cast).
    entry_grid: Mutex<Option<Arc<EntryGrid>>>,
    /// The shared-origin kernel's hit table (uploaded by its first cast).
    hit_table: Mutex<Option<Arc<HitTable>>>,
    /// The own-origin kernel's locate table (uploaded by its first cast).
    locate_table: Mutex<Option<Arc<LocateTable>>>,
    /// Containment's region parity, a bit a tet (uploaded by the first GPU `contains`).
    parity: Mutex<Option<Arc<wgpu::Buffer>>>,
    /// The camera kernel (compiled by the first cast of a camera's rays).
    camera: Mutex<Option<Arc<CameraKernel>>>,
}

impl DeviceScene {
    /// Bytes on the device per layout (records, and points for id layouts), and under "rays"
    /// the kernels' ray buffers kept between casts.
    pub fn bytes(&self) -> Vec<(&'static str, u64)> {
        let b = self.buffers.lock().unwrap_or_else(|e| e.into_inner());
        let mut out: Vec<(&'static str, u64)> = b.iter().map(|(k, s)| (*k, s.bytes())).collect();
        let runs = self.runs.lock().unwrap_or_else(|e| e.into_inner());
        let rays: u64 = runs
            .values()
            .filter_map(|r| {
                r.try_lock()
                    .ok()
                    .and_then(|c| c.as_ref().map(RunBuffers::bytes))
            })
            .sum();
        if rays > 0 {
            out.push(("rays", rays));
        }
        let grid = self.entry_grid.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(g) = grid.as_ref() {
            out.push(("entry_grid", g.bytes()));
        }
        let table = self.hit_table.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(t) = table.as_ref() {
            out.push(("hit_table", t.bytes()));
        }
        let locate = self.locate_table.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(t) = locate.as_ref() {
            out.push(("locate_table", t.bytes()));
        }
        let parity = self.parity.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(b) = parity.as_ref() {
            out.push(("parity", b.size()));
        }
        out
    }

    /// `kernel`'s ray buffers kept between casts on this scene (empty until its first cast).
    pub(crate) fn run_buffers(&self, kernel: &KernelSpec) -> KeptRuns {
        let mut runs = self.runs.lock().unwrap_or_else(|e| e.into_inner());
        runs.entry(kernel.key()).or_default().clone()
    }

    /// The scene's box entry grid on the device, uploaded now if it is not there yet, and the
    /// seconds the upload took.
    pub(crate) fn entry_grid(&self, g: &Gpu, scene: &Scene) -> Result<(Arc<EntryGrid>, f64)> {
        kept(g, &self.entry_grid, || upload_entry_grid(g, scene))
    }

    /// The scene's hit table on the device (`gpu::finish`), uploaded now if it is not there
    /// yet, and the seconds the upload took.
    pub(crate) fn hit_table(&self, g: &Gpu, scene: &Scene) -> Result<(Arc<HitTable>, f64)> {
        kept(g, &self.hit_table, || upload_hit_table(g, scene))
    }

    /// The scene's locate table on the device (`gpu::origin`), uploaded now if it is not
    /// there yet, and the seconds the upload took.
    pub(crate) fn locate_table(&self, g: &Gpu, scene: &Scene) -> Result<(Arc<LocateTable>, f64)> {
        kept(g, &self.locate_table, || upload_locate_table(g, scene))
    }

    /// Containment's region parity on the device, uploaded now by `upload` if it is not
    /// there yet, and the seconds the upload took.
    pub(crate) fn parity_bits(
        &self,
        g: &Gpu,
        upload: impl FnOnce() -> Result<wgpu::Buffer>,
    ) -> Result<(Arc<wgpu::Buffer>, f64)> {
        kept(g, &self.parity, upload)
    }

    /// The camera kernel (`gpu::camera`), compiled now if it is not yet.
    pub(crate) fn camera_kernel(&self, g: &Gpu) -> Result<Arc<CameraKernel>> {
        Ok(kept(g, &self.camera, || CameraKernel::new(g))?.0)
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

/// What `slot` holds, or what `upload` puts on the device now (and the seconds it took).
fn kept<T>(
    g: &Gpu,
    slot: &Mutex<Option<Arc<T>>>,
    upload: impl FnOnce() -> Result<T>,
) -> Result<(Arc<T>, f64)> {
    let mut slot = slot.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(x) = slot.as_ref() {
        return Ok((x.clone(), 0.0));
    }
    let t0 = Instant::now();
    let x = Arc::new(upload()?);
    g.wait()?;
    *slot = Some(x.clone());
    Ok((x, t0.elapsed().as_secs_f64()))
}
