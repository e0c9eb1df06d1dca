//! Python bindings: validate, release the GIL, call the core over slices, hand the result
//! vectors to numpy without copying. Nothing else lives here: one file per concern.

mod alloc;
mod arrays;
mod bench;
mod camera;
mod errors;
mod gpu;
mod names;
mod query;
mod request;
mod scene;

use pyo3::prelude::*;

/// The extension's Rust allocations: the system allocator, except that freed large blocks (a
/// cast's answer columns) are kept for the next cast (`alloc.rs` says why).
#[global_allocator]
static ALLOC: alloc::KeepLarge = alloc::KeepLarge::new();

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<scene::PyScene>()?;
    m.add_class::<request::PyRayRequest>()?;
    m.add_function(wrap_pyfunction!(names::methods, m)?)?;
    m.add_function(wrap_pyfunction!(names::accels, m)?)?;
    m.add_function(wrap_pyfunction!(names::queries, m)?)?;
    m.add_function(wrap_pyfunction!(names::structure_defaults, m)?)?;
    m.add_function(wrap_pyfunction!(request::check_threads, m)?)?;
    m.add_function(wrap_pyfunction!(arrays::take_rows, m)?)?;
    m.add_function(wrap_pyfunction!(camera::camera_directions, m)?)?;
    m.add_function(wrap_pyfunction!(arrays::triangle_normals, m)?)?;
    m.add_function(wrap_pyfunction!(names::layouts, m)?)?;
    m.add_function(wrap_pyfunction!(names::simd_levels, m)?)?;
    m.add_function(wrap_pyfunction!(alloc::memory_cache, m)?)?;
    m.add_function(wrap_pyfunction!(bench::exitface_bench, m)?)?;
    m.add_function(wrap_pyfunction!(bench::referee_first_hit, m)?)?;
    m.add_function(wrap_pyfunction!(gpu::gpu_adapters, m)?)?;
    m.add_function(wrap_pyfunction!(gpu::gpu_device, m)?)?;
    m.add_function(wrap_pyfunction!(gpu::gpu_kernels, m)?)?;
    m.add_function(wrap_pyfunction!(gpu::gpu_kernel_for, m)?)?;
    m.add("DEFAULT_METHOD", crate::traverse::Method::DEFAULT.name())?;
    m.add("DEFAULT_LAYOUT", crate::layout::LayoutKind::DEFAULT.name())?;
    m.add("MeshError", m.py().get_type::<errors::MeshError>())?;
    m.add("TooLargeError", m.py().get_type::<errors::TooLargeError>())?;
    m.add("GpuError", m.py().get_type::<errors::GpuError>())?;
    m.add("MAX_THREADS", crate::threads::max_threads())?;
    m.add("MISS", crate::MISS)?;
    m.add("HIT", crate::HIT)?;
    m.add("FAILED", crate::FAILED)?;
    m.add("INVALID", crate::INVALID)?;
    m.add("STATUS_NAMES", crate::status::STATUS_NAMES.to_vec())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
