//! What a GPU cast reports of its phases (filled by `cast.rs` and `launch.rs`).

/// Where the time of a GPU cast went, in seconds. Batches are pipelined (`launch.rs`): the
/// host writes and answers batches while the device walks the next, so the host's phases
/// (`upload`, `readback`, `finish`) may overlap the kernel's, and they are host time, the
/// kernel's device time.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GpuTimings {
    /// Start-tet location and ray preparation on the CPU.
    pub locate: f64,
    /// Uploading the scene's buffers (0 when they were already on the device).
    pub scene_upload: f64,
    /// Writing the rays for the device and recording each batch's one submission (with
    /// `camera_rays`, the batches' uniforms only); the submission itself is the kernel's.
    pub upload: f64,
    /// With `camera_rays`: the camera kernel making the directions on the device (its pass's
    /// timestamps, summed over the batches; 0 where the device has none, its time then in
    /// `kernel`).
    pub camera: f64,
    /// The traversal kernel: the GPU's timestamps around each dispatch, summed, where the
    /// device has them (`Gpu::timestamps`), else `kernel_wall`.
    pub kernel: f64,
    /// The host's wall time from submitting each batch to seeing its end, summed (a batch's
    /// span includes the device's time on the batch before it, still in flight).
    pub kernel_wall: f64,
    /// Mapping each batch's results (and timestamps) once the device is done with it.
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
