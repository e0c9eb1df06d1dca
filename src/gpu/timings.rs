//! What a GPU cast reports of its phases (filled by `cast.rs` and `launch.rs`).

/// Where the time of a GPU cast went, in seconds (each phase waits for the device before the
/// next starts, so the phases do not overlap).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GpuTimings {
    /// Start-tet location and ray preparation on the CPU.
    pub locate: f64,
    /// Uploading the scene's buffers (0 when they were already on the device).
    pub scene_upload: f64,
    /// Copying the rays to the device (with `camera_rays`, the batches' uniforms only).
    pub upload: f64,
    /// With `camera_rays`: the camera kernel making the directions on the device (the host's
    /// wall time from its submission to its end, summed over the batches).
    pub camera: f64,
    /// The traversal kernel: the GPU's timestamps around each dispatch, summed, where the
    /// device has them (`Gpu::timestamps`), else `kernel_wall`.
    pub kernel: f64,
    /// The host's wall time from submitting each dispatch to its end, summed.
    pub kernel_wall: f64,
    /// Copying the results back.
    pub readback: f64,
    /// Hits on the caller's triangles, and CPU walks of deferred rays.
    pub finish: f64,
    /// Rays the GPU walked (rays that miss the box or are invalid are settled on the CPU).
    pub walked: usize,
    /// Robust kernel: rays deferred to the CPU robust walk. Exact kernel: rays handed back
    /// before the face their query decides (or, shared origin, before their start).
    pub deferred: usize,
    /// Shared-origin kernel: hits finished on the device (`gpu::finish`).
    pub finished: usize,
    pub batches: usize,
    /// Whether the batch took the shared-origin exact kernel (`gpu::origin`): one origin
    /// located once, every start on the device.
    pub shared_origin: bool,
    /// Whether the batch took the own-origin exact kernel (`gpu::origin::own_origins`): each
    /// ray's origin located (or its entry into the box found) on the device.
    pub own_origins: bool,
    /// Whether the directions were made on the device by the camera kernel
    /// (`DeviceScene::cast_camera`), not uploaded.
    pub camera_rays: bool,
}
