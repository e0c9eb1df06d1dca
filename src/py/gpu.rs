//! GPU introspection: adapters, the device, the kernels; and the GPU cast's timings. Without
//! the `gpu` cargo feature the same functions exist and say the build has no GPU (GpuError;
//! no kernels), so `tetrace.gpu` and `device="gpu"` explain themselves.

#[cfg(feature = "gpu")]
pub(crate) use built::*;
#[cfg(not(feature = "gpu"))]
pub(crate) use not_built::*;

#[cfg(feature = "gpu")]
mod built {
    use crate::py::errors::guarded;
    use pyo3::prelude::*;
    use pyo3::types::PyDict;

    /// Every adapter wgpu finds, best first, as dicts.
    #[pyfunction]
    pub(crate) fn gpu_adapters<'py>(py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        let found = py.detach(|| guarded(|| Ok(crate::gpu::adapters())))?;
        found.iter().map(|a| adapter_dict(py, a)).collect()
    }

    /// The adapter GPU casts run on (opening the device on first use); GpuError without one.
    #[pyfunction]
    pub(crate) fn gpu_device<'py>(py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let g = py.detach(|| guarded(crate::gpu::gpu))?;
        let d = adapter_dict(py, &g.adapter)?;
        d.set_item(
            "device_max_storage_buffer_binding_size",
            g.limits.max_storage_buffer_binding_size,
        )?;
        d.set_item("device_max_buffer_size", g.limits.max_buffer_size)?;
        d.set_item("timestamps", g.timestamps)?;
        d.set_item("mapped_results", g.mapped_results)?;
        Ok(d)
    }

    /// The GPU kernels as (method, layout) pairs, the default first.
    #[pyfunction]
    pub(crate) fn gpu_kernels() -> Vec<(&'static str, &'static str)> {
        crate::gpu::KERNELS
            .iter()
            .map(|k| (k.method, k.layout.name))
            .collect()
    }

    /// The (method, layout) kernel a GPU cast with these names uses (None: the default
    /// kernel's method; the first layout with a kernel for the method); ValueError naming the
    /// kernels.
    #[pyfunction]
    #[pyo3(signature = (method=None, layout=None))]
    pub(crate) fn gpu_kernel_for(
        method: Option<&str>,
        layout: Option<&str>,
    ) -> PyResult<(&'static str, &'static str)> {
        let k = crate::gpu::KernelSpec::find(method, layout)?;
        Ok((k.method, k.layout.name))
    }

    /// A GPU cast's timings as the dict `Hits.timings` holds.
    pub(crate) fn timings_dict<'py>(
        py: Python<'py>,
        timings: &crate::gpu::GpuTimings,
    ) -> PyResult<Bound<'py, PyDict>> {
        let t = PyDict::new(py);
        for (k, v) in [
            ("locate", timings.locate),
            ("scene_upload", timings.scene_upload),
            ("upload", timings.upload),
            ("camera", timings.camera),
            ("kernel", timings.kernel),
            ("kernel_wall", timings.kernel_wall),
            ("readback", timings.readback),
            ("finish", timings.finish),
        ] {
            t.set_item(k, v)?;
        }
        t.set_item("walked", timings.walked)?;
        t.set_item("deferred", timings.deferred)?;
        t.set_item("batches", timings.batches)?;
        t.set_item("shared_origin", timings.shared_origin)?;
        t.set_item("own_origins", timings.own_origins)?;
        t.set_item("camera_rays", timings.camera_rays)?;
        t.set_item("finished", timings.finished)?;
        Ok(t)
    }

    fn adapter_dict<'py>(
        py: Python<'py>,
        a: &crate::gpu::AdapterSummary,
    ) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        d.set_item("name", &a.name)?;
        d.set_item("backend", &a.backend)?;
        d.set_item("device_type", &a.device_type)?;
        d.set_item("driver", &a.driver)?;
        d.set_item("driver_info", &a.driver_info)?;
        d.set_item("vendor", a.vendor)?;
        d.set_item("device", a.device)?;
        d.set_item("compute", a.compute)?;
        d.set_item(
            "max_storage_buffer_binding_size",
            a.max_storage_buffer_binding_size,
        )?;
        d.set_item("max_buffer_size", a.max_buffer_size)?;
        Ok(d)
    }
}

#[cfg(not(feature = "gpu"))]
mod not_built {
    use crate::py::errors::GpuError;
    use pyo3::exceptions::PyValueError;
    use pyo3::prelude::*;
    use pyo3::types::PyDict;

    const NOT_BUILT: &str = "this tetrace was built without GPU support (the `gpu` cargo \
        feature, on by default and in the wheel): rebuild with it, or cast with device=\"cpu\"";

    /// The error of every GPU entry point in a build without the `gpu` feature.
    pub(crate) fn not_built() -> PyErr {
        GpuError::new_err(NOT_BUILT)
    }

    /// GpuError: this build has no GPU support.
    #[pyfunction]
    pub(crate) fn gpu_adapters<'py>(_py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        Err(not_built())
    }

    /// GpuError: this build has no GPU support.
    #[pyfunction]
    pub(crate) fn gpu_device<'py>(_py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        Err(not_built())
    }

    /// No kernels: this build has no GPU support.
    #[pyfunction]
    pub(crate) fn gpu_kernels() -> Vec<(&'static str, &'static str)> {
        Vec::new()
    }

    /// ValueError: no kernel exists in a build without GPU support.
    #[pyfunction]
    #[pyo3(signature = (method=None, layout=None))]
    pub(crate) fn gpu_kernel_for(
        method: Option<&str>,
        layout: Option<&str>,
    ) -> PyResult<(&'static str, &'static str)> {
        Err(PyValueError::new_err(format!(
            "no GPU kernel for method {method:?} on layout {layout:?}: {NOT_BUILT}"
        )))
    }
}
