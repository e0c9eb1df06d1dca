//! A scene's copies on the device: one set of buffers per layout, uploaded by the first GPU
//! cast with a kernel on that layout and kept for the next. The CPU scene does not hold them:
//! whoever casts on the GPU keeps a [`DeviceScene`] beside its [`Scene`].

use super::context::Gpu;
use super::kernels::{GpuLayout, KernelSpec};
use super::upload::LayoutBuffers;
use crate::error::Result;
use crate::scene::Scene;
use std::collections::HashMap;
use std::sync::{Arc, Mutex};
use std::time::Instant;

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
