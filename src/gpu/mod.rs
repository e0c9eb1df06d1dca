//! Traversal on the GPU through wgpu compute shaders (`shaders/`, assembled in
//! `kernels.rs`).
//!
//! Start-tet location and the hit on the caller's triangle stay on the CPU (the same code as
//! the CPU cast), except for rays sharing one origin, which begin their walks on the device
//! (`origin.rs`) and have the hits it can certify finished there (`finish.rs`); the walk from
//! tet to tet runs on the device, one invocation per ray. Each
//! kernel has a CPU twin, the float32 walk with the same method and layout, which it matches
//! up to the GPU compiler's freedom to fuse multiply-adds. The robust kernel certifies each
//! sign with an error bound valid under any fusing and hands rays it cannot certify back to
//! the CPU robust walk. The exact kernel (the default) takes the CPU exact walk's plain steps
//! on the same certified signs, between a start and an end the CPU exact walk takes
//! (`cast.rs`), so its answers are the CPU exact cast's. Design, bounds and measurements:
//! docs/gpu.md.

pub mod camera;
pub mod cast;
pub mod contains;
pub mod context;
pub mod device_scene;
pub mod finish;
pub mod kernels;
pub mod launch;
pub mod origin;
// Portalez & Duguet's octree walk in float32 on the GPU, measured by its tests only (the
// `gpu-octree` feature, which `make test` turns on).
#[cfg(feature = "gpu-octree")]
pub mod octree;
pub mod structs;
pub mod timings;
pub mod upload;

pub use context::{adapters, gpu, AdapterSummary, Gpu};
pub use device_scene::DeviceScene;
pub use kernels::{KernelSpec, GPU_LAYOUTS, KERNELS};
pub use launch::{Batching, MAX_BATCH};
pub use timings::GpuTimings;

#[cfg(test)]
mod tests;
