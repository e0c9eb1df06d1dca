//! The device: adapters wgpu can see, the one tetrace picks, its device and queue (created
//! once per process with the adapter's own limits), and the kernels' pipelines.

use crate::error::{Error, Result};
use std::collections::HashMap;
use std::sync::{Arc, Mutex};

/// A kernel's identity, which names its pipeline and kept ray buffers: (method, layout, walk
/// file) (`KernelSpec::key`).
pub type KernelKey = (&'static str, &'static str, &'static str);

/// What `tetrace.gpu.info()` shows of an adapter.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct AdapterSummary {
    pub name: String,
    /// "Vulkan", "Metal", "Dx12", "Gl".
    pub backend: String,
    /// "DiscreteGpu", "IntegratedGpu", "VirtualGpu", "Cpu" (lavapipe, llvmpipe), "Other".
    pub device_type: String,
    pub driver: String,
    pub driver_info: String,
    pub vendor: u32,
    pub device: u32,
    /// Whether it runs compute shaders (GL adapters may not).
    pub compute: bool,
    pub max_storage_buffer_binding_size: u64,
    pub max_buffer_size: u64,
}

fn summary(a: &wgpu::Adapter) -> AdapterSummary {
    let info = a.get_info();
    let limits = a.limits();
    AdapterSummary {
        name: info.name,
        backend: format!("{:?}", info.backend),
        device_type: format!("{:?}", info.device_type),
        driver: info.driver,
        driver_info: info.driver_info,
        vendor: info.vendor,
        device: info.device,
        compute: a
            .get_downlevel_capabilities()
            .flags
            .contains(wgpu::DownlevelFlags::COMPUTE_SHADERS),
        max_storage_buffer_binding_size: limits.max_storage_buffer_binding_size,
        max_buffer_size: limits.max_buffer_size,
    }
}

/// The backends this build can use on this platform (a subset of Vulkan, Metal, DX12, GL).
pub fn backends_looked_for() -> String {
    let enabled = wgpu::Instance::enabled_backend_features();
    let mut names = Vec::new();
    for (b, n) in [
        (wgpu::Backends::VULKAN, "Vulkan"),
        (wgpu::Backends::METAL, "Metal"),
        (wgpu::Backends::DX12, "DX12"),
        (wgpu::Backends::GL, "OpenGL/GLES"),
    ] {
        if enabled.contains(b) {
            names.push(n);
        }
    }
    names.join(", ")
}

fn instance() -> wgpu::Instance {
    // WGPU_BACKEND (e.g. "vulkan", "gl") narrows the backends, as everywhere in wgpu.
    wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env())
}

fn all_adapters() -> Vec<wgpu::Adapter> {
    let inst = instance();
    pollster::block_on(inst.enumerate_adapters(wgpu::Backends::all()))
}

/// Every adapter wgpu finds, best first (the first with compute shaders is the one used).
pub fn adapters() -> Vec<AdapterSummary> {
    let mut a = all_adapters();
    a.sort_by_key(preference);
    a.iter().map(summary).collect()
}

/// Real GPUs before virtual and software ones; Vulkan/Metal/DX12 before GL.
fn preference(a: &wgpu::Adapter) -> (u8, u8) {
    let info = a.get_info();
    let kind = match info.device_type {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Cpu => 3,
        wgpu::DeviceType::Other => 4,
    };
    let backend = match info.backend {
        wgpu::Backend::Vulkan | wgpu::Backend::Metal | wgpu::Backend::Dx12 => 0,
        _ => 1,
    };
    (kind, backend)
}

/// The error of a machine where wgpu finds no usable adapter.
pub fn no_adapter_error(found: &[AdapterSummary]) -> Error {
    let env = std::env::var("WGPU_BACKEND")
        .map(|v| format!(" (WGPU_BACKEND={v} narrows the search)"))
        .unwrap_or_default();
    let seen = if found.is_empty() {
        "none found".to_string()
    } else {
        let names: Vec<String> = found
            .iter()
            .map(|a| format!("{} ({}, no compute shaders)", a.name, a.backend))
            .collect();
        format!("found only {}", names.join("; "))
    };
    Error::Gpu(format!(
        "no GPU adapter with compute shaders: wgpu looked for {} adapters{env}: {seen}. On Linux \
         without a GPU, Mesa's software Vulkan driver (lavapipe) provides one: apt-get install \
         mesa-vulkan-drivers",
        backends_looked_for()
    ))
}

/// The device tetrace casts on.
pub struct Gpu {
    pub adapter: AdapterSummary,
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    /// The device's limits: the adapter's own, all requested (large scenes need their
    /// max_storage_buffer_binding_size and max_buffer_size, not WebGPU's defaults).
    pub limits: wgpu::Limits,
    /// Whether the device writes GPU timestamps (`Features::TIMESTAMP_QUERY`): the kernel's
    /// time is then the GPU's own, not the host's wait for it.
    pub timestamps: bool,
    /// Whether the kernels' rays and results are written and read where the device reads
    /// and writes them: on a device that shares memory with the host (software drivers such
    /// as lavapipe, integrated GPUs) those buffers are mappable
    /// (`Features::MAPPABLE_PRIMARY_BUFFERS`), so no staging copy comes before the kernel
    /// and no copy to a readback buffer after it. A discrete GPU keeps the copy
    /// (mapping its own memory would make the kernel's writes cross the bus one by one).
    pub mapped_results: bool,
    /// Compiled kernels, by (method, layout) (`Gpu::pipeline`, in kernels.rs).
    pub(super) pipelines: Mutex<HashMap<KernelKey, Arc<wgpu::ComputePipeline>>>,
}

static GPU: Mutex<Option<Arc<Gpu>>> = Mutex::new(None);

/// The process's device, created on first use. Failures are not cached (a driver installed
/// later is found by the next call).
pub fn gpu() -> Result<Arc<Gpu>> {
    let mut slot = GPU.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(g) = slot.as_ref() {
        return Ok(g.clone());
    }
    let g = Arc::new(Gpu::new()?);
    *slot = Some(g.clone());
    Ok(g)
}

impl Gpu {
    fn new() -> Result<Gpu> {
        // Native APIs first; GL only when they offer nothing (probing GL on a headless Linux
        // machine prints EGL complaints, and it is the slowest path).
        let compute = |a: &wgpu::Adapter| {
            a.get_downlevel_capabilities()
                .flags
                .contains(wgpu::DownlevelFlags::COMPUTE_SHADERS)
        };
        let native = wgpu::Backends::VULKAN | wgpu::Backends::METAL | wgpu::Backends::DX12;
        let inst = instance();
        let mut all = pollster::block_on(inst.enumerate_adapters(native));
        if !all.iter().any(compute) {
            all = all_adapters();
        }
        all.sort_by_key(preference);
        let Some(adapter) = all.iter().find(|a| compute(a)) else {
            let seen: Vec<AdapterSummary> = all.iter().map(summary).collect();
            return Err(no_adapter_error(&seen));
        };
        let limits = adapter.limits();
        let shares_memory = matches!(
            adapter.get_info().device_type,
            wgpu::DeviceType::Cpu | wgpu::DeviceType::IntegratedGpu
        );
        let mut wanted = wgpu::Features::TIMESTAMP_QUERY;
        if shares_memory {
            wanted |= wgpu::Features::MAPPABLE_PRIMARY_BUFFERS;
        }
        let desc = wgpu::DeviceDescriptor {
            label: Some("tetrace"),
            // GPU timestamps time the kernel where the adapter has them (`launch.rs`); results
            // are mapped where they lie where memory is shared (`mapped_results`).
            required_features: adapter.features() & wanted,
            required_limits: limits.clone(),
            memory_hints: wgpu::MemoryHints::Performance,
            ..Default::default()
        };
        let (device, queue) = pollster::block_on(adapter.request_device(&desc)).map_err(|e| {
            Error::Gpu(format!(
                "cannot open a device on {}: {e}",
                adapter.get_info().name
            ))
        })?;
        // Errors outside an error scope would otherwise panic inside wgpu; every operation
        // here runs in a scope (see `scoped`), so this only reports what escapes them.
        device.on_uncaptured_error(Arc::new(|e| {
            eprintln!("tetrace: uncaptured GPU error: {e}");
        }));
        Ok(Gpu {
            timestamps: device.features().contains(wgpu::Features::TIMESTAMP_QUERY),
            mapped_results: device
                .features()
                .contains(wgpu::Features::MAPPABLE_PRIMARY_BUFFERS),
            adapter: summary(adapter),
            limits: device.limits(),
            device,
            queue,
            pipelines: Mutex::new(HashMap::new()),
        })
    }

    /// Runs `f` inside validation and out-of-memory error scopes; a captured error becomes
    /// `Error::Gpu` naming `what`.
    /// A compute pipeline from a WGSL module's `source` and its entry point `entry`, the
    /// bind group layout taken from the shader (call it inside [`Gpu::scoped`]: wgpu reports
    /// a bad shader through the device's error scope).
    pub fn compute_pipeline(
        &self,
        label: &str,
        source: &str,
        entry: &str,
    ) -> wgpu::ComputePipeline {
        let module = self
            .device
            .create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(label),
                source: wgpu::ShaderSource::Wgsl(source.into()),
            });
        self.device
            .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(label),
                layout: None,
                module: &module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            })
    }

    pub fn scoped<T>(&self, what: &str, f: impl FnOnce() -> T) -> Result<T> {
        let oom = self.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let val = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let out = f();
        let e1 = pollster::block_on(val.pop());
        let e2 = pollster::block_on(oom.pop());
        match e1.or(e2) {
            Some(e) => Err(Error::Gpu(format!("{what}: {e}"))),
            None => Ok(out),
        }
    }

    /// Waits for all submitted work.
    pub fn wait(&self) -> Result<()> {
        self.wait_for(None)
    }

    /// Waits for the submission `index` (and those before it), or for all submitted work
    /// where None, running the callbacks of buffers mapped meanwhile. A pipelined run waits
    /// for one batch while the next one's kernel runs (`launch.rs`).
    pub fn wait_for(&self, index: Option<wgpu::SubmissionIndex>) -> Result<()> {
        self.device
            .poll(wgpu::PollType::Wait {
                submission_index: index,
                timeout: None,
            })
            .map(|_| ())
            .map_err(|e| Error::Gpu(format!("waiting for the device: {e}")))
    }

    /// Maps the first `size` bytes of `readback` (a MAP_READ buffer the results were copied
    /// into), appends them to `out` as T, and unmaps it; `what` names the results in errors.
    pub fn read_mapped<T: bytemuck::Pod>(
        &self,
        readback: &wgpu::Buffer,
        size: u64,
        out: &mut Vec<T>,
        what: &str,
    ) -> Result<()> {
        self.with_mapped(readback, size, what, |v: &[T]| out.extend_from_slice(v))
    }

    /// Maps the first `size` bytes of `readback`, gives them to `f` as T where they lie (no
    /// copy: `f` may read them from several threads), and unmaps it afterwards.
    pub fn with_mapped<T: bytemuck::Pod, R>(
        &self,
        readback: &wgpu::Buffer,
        size: u64,
        what: &str,
        f: impl FnOnce(&[T]) -> R,
    ) -> Result<R> {
        self.with_mapped_after(readback, size, None, what, f)
    }

    /// [`Gpu::with_mapped`] for a buffer whose last use is the submission `after` (or
    /// earlier): the wait for the mapping is a wait for it, not for later work.
    pub fn with_mapped_after<T: bytemuck::Pod, R>(
        &self,
        readback: &wgpu::Buffer,
        size: u64,
        after: Option<wgpu::SubmissionIndex>,
        what: &str,
        f: impl FnOnce(&[T]) -> R,
    ) -> Result<R> {
        self.map(readback, size, wgpu::MapMode::Read, after, what)?;
        let r = {
            let view = readback
                .slice(..size)
                .get_mapped_range()
                .map_err(|e| Error::Gpu(format!("reading {what}: {e}")))?;
            // A mapped range is aligned to wgpu::MAP_ALIGNMENT (8 bytes): enough for the
            // 4-byte words of every result type.
            bytemuck::try_cast_slice(&view[..])
                .map(f)
                .map_err(|e| Error::Gpu(format!("reading {what}: {e}")))
        };
        readback.unmap();
        r
    }

    /// Maps the first `size` bytes of `buffer` (MAP_WRITE), lets `f` write them (write-only:
    /// the memory may be write-combined), and unmaps it: the device then reads what `f`
    /// wrote, with no staging copy between.
    /// Where `after` is given, the buffer's last use is that submission (or an earlier one).
    pub fn write_mapped<R>(
        &self,
        buffer: &wgpu::Buffer,
        size: u64,
        after: Option<wgpu::SubmissionIndex>,
        what: &str,
        f: impl FnOnce(&mut wgpu::BufferViewMut) -> R,
    ) -> Result<R> {
        self.map(buffer, size, wgpu::MapMode::Write, after, what)?;
        let r = {
            let mut view = buffer
                .slice(..size)
                .get_mapped_range_mut()
                .map_err(|e| Error::Gpu(format!("writing {what}: {e}")))?;
            f(&mut view)
        };
        buffer.unmap();
        Ok(r)
    }

    /// Maps the first `size` bytes of `buffer` and waits until it is mapped: for the
    /// submission `after`, the buffer's last use, or where None, not at all if the buffer is
    /// idle (a pipelined run's other set), else for all submitted work.
    fn map(
        &self,
        buffer: &wgpu::Buffer,
        size: u64,
        mode: wgpu::MapMode,
        after: Option<wgpu::SubmissionIndex>,
        what: &str,
    ) -> Result<()> {
        let (tx, rx) = std::sync::mpsc::channel();
        buffer.slice(..size).map_async(mode, move |r| {
            let _ = tx.send(r);
        });
        let poll = match after {
            Some(index) => wgpu::PollType::Wait {
                submission_index: Some(index),
                timeout: None,
            },
            None => wgpu::PollType::Poll,
        };
        self.device
            .poll(poll)
            .map_err(|e| Error::Gpu(format!("waiting for the device: {e}")))?;
        // The callback has run once the buffer's last submission is done; where it has not
        // (the buffer is still in use, or `after` was not its last use), all work is waited
        // for.
        let r = match rx.try_recv() {
            Ok(r) => r,
            Err(_) => {
                self.wait()?;
                rx.recv()
                    .map_err(|_| Error::Gpu(format!("mapping {what}: the callback never ran")))?
            }
        };
        r.map_err(|e| Error::Gpu(format!("mapping {what}: {e}")))
    }
}
