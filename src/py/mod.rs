//! Python bindings: validate, release the GIL, call the core over slices, hand the result
//! vectors to numpy without copying. Nothing else lives here.

use crate::dispatch::Precision;
use crate::error::Error;
use crate::scene::{CastOptions, HitsOut, Rays, Scene};
use numpy::{
    Element, IntoPyArray, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyReadonlyArray3,
    PyUntypedArrayMethods,
};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::panic::{catch_unwind, AssertUnwindSafe};

pyo3::create_exception!(
    _native,
    MeshError,
    PyValueError,
    "The tetrahedralization is unusable (flat tets, non-manifold faces, ...)."
);
pyo3::create_exception!(
    _native,
    TooLargeError,
    PyValueError,
    "A size limit of a layout would be exceeded."
);

pyo3::create_exception!(
    _native,
    GpuError,
    PyRuntimeError,
    "No usable GPU adapter, or the device failed."
);

/// The one mapping from core errors to Python exceptions.
impl From<Error> for PyErr {
    fn from(e: Error) -> PyErr {
        let msg = e.to_string();
        match e {
            Error::InvalidInput(_) | Error::InvalidOption(_) => PyValueError::new_err(msg),
            Error::InvalidMesh(_) => MeshError::new_err(msg),
            Error::TooLarge(_) => TooLargeError::new_err(msg),
            Error::Gpu(_) => GpuError::new_err(msg),
        }
    }
}

/// Runs core code with a net under it: a panic would be a bug, and it must reach Python as an
/// exception that says so rather than abort the interpreter.
fn guarded<T>(f: impl FnOnce() -> crate::Result<T>) -> PyResult<T> {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(r) => r.map_err(PyErr::from),
        Err(p) => {
            let what = p
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_default();
            Err(PyRuntimeError::new_err(format!(
                "internal error in tetrace (please report): {what}"
            )))
        }
    }
}

fn slice<'a, T: Element, D: numpy::ndarray::Dimension>(
    a: &'a numpy::PyReadonlyArray<'_, T, D>,
    name: &str,
) -> PyResult<&'a [T]> {
    a.as_slice()
        .map_err(|_| PyValueError::new_err(format!("{name} must be C-contiguous")))
}

fn check_cols<T: Element>(a: &PyReadonlyArray2<'_, T>, cols: usize, name: &str) -> PyResult<usize> {
    let s = a.shape();
    if s[1] != cols {
        return Err(PyValueError::new_err(format!(
            "{name} must have shape (N, {cols}), got {s:?}"
        )));
    }
    Ok(s[0])
}

/// Reinterprets a flat slice of 3k (or 4k, 9k) values as k fixed-size rows.
fn rows<T: Copy, const K: usize>(flat: &[T]) -> Vec<[T; K]> {
    flat.chunks_exact(K)
        .map(|c| std::array::from_fn(|i| c[i]))
        .collect()
}

#[pyclass(frozen, name = "NativeScene", module = "tetrace._native")]
pub struct PyScene {
    inner: Scene,
}

#[pymethods]
impl PyScene {
    /// Builds the traversal structures from a tetrahedralization (see tetrace.meshing).
    #[new]
    #[pyo3(signature = (points, tets, faces, face_triangle, triangles, hilbert=true, alternatives=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        points: PyReadonlyArray2<'_, f64>,
        tets: PyReadonlyArray2<'_, u32>,
        faces: PyReadonlyArray2<'_, u32>,
        face_triangle: PyReadonlyArray1<'_, u32>,
        triangles: PyReadonlyArray3<'_, f64>,
        hilbert: bool,
        alternatives: Option<(PyReadonlyArray1<'_, u32>, PyReadonlyArray1<'_, u32>)>,
    ) -> PyResult<Self> {
        check_cols(&points, 3, "points")?;
        check_cols(&tets, 4, "tets")?;
        check_cols(&faces, 3, "faces")?;
        let ts = triangles.shape();
        if ts[1] != 3 || ts[2] != 3 {
            return Err(PyValueError::new_err(format!(
                "triangles must have shape (F, 3, 3), got {ts:?}"
            )));
        }
        let p: Vec<[f64; 3]> = rows(slice(&points, "points")?);
        let t: Vec<[u32; 4]> = rows(slice(&tets, "tets")?);
        let f: Vec<[u32; 3]> = rows(slice(&faces, "faces")?);
        let ft = slice(&face_triangle, "face_triangle")?;
        let tri: Vec<[[f64; 3]; 3]> = rows::<f64, 9>(slice(&triangles, "triangles")?)
            .into_iter()
            .map(|r| [[r[0], r[1], r[2]], [r[3], r[4], r[5]], [r[6], r[7], r[8]]])
            .collect();
        let alternatives = match &alternatives {
            Some((offsets, ids)) => Some((
                slice(offsets, "alternatives offsets")?.to_vec(),
                slice(ids, "alternatives ids")?.to_vec(),
            )),
            None => None,
        };
        let inner = py.detach(|| {
            guarded(|| {
                let mut scene = Scene::build_with(p, &t, &f, ft, tri, hilbert)?;
                if let Some((offsets, ids)) = alternatives {
                    scene.set_alternatives(offsets, ids)?;
                }
                Ok(scene)
            })
        })?;
        Ok(PyScene { inner })
    }

    /// Casts rays: origins and directions both float32 (the walk runs in float32) or both
    /// float64. Returns a dict of the Hits fields, in that precision; with `audit`, also
    /// "audit": (N, 2) uint32, per ray the exit faces taken that exact predicates reject and
    /// the steps where the method found no exit face.
    #[pyo3(signature = (origins, directions, tmin, tmax, threads=None, max_steps=None, method="aman2022", layout="tet32", audit=false))]
    #[allow(clippy::too_many_arguments)]
    fn cast<'py>(
        &self,
        py: Python<'py>,
        origins: &Bound<'py, PyAny>,
        directions: &Bound<'py, PyAny>,
        tmin: PyReadonlyArray1<'py, f64>,
        tmax: PyReadonlyArray1<'py, f64>,
        threads: Option<usize>,
        max_steps: Option<u32>,
        method: &str,
        layout: &str,
        audit: bool,
    ) -> PyResult<Bound<'py, PyDict>> {
        let scene = &self.inner;
        let f32s = (
            origins.extract::<PyReadonlyArray2<'py, f32>>(),
            directions.extract::<PyReadonlyArray2<'py, f32>>(),
        );
        if let (Ok(o), Ok(d)) = f32s {
            return cast_any(
                py, scene, o, d, tmin, tmax, threads, max_steps, method, layout, audit,
            );
        }
        match (
            origins.extract::<PyReadonlyArray2<'py, f64>>(),
            directions.extract::<PyReadonlyArray2<'py, f64>>(),
        ) {
            (Ok(o), Ok(d)) => cast_any(
                py, scene, o, d, tmin, tmax, threads, max_steps, method, layout, audit,
            ),
            _ => Err(pyo3::exceptions::PyTypeError::new_err(
                "origins and directions must be 2-D arrays, both float32 or both float64",
            )),
        }
    }

    /// Casts float32 rays on the GPU (start location and hits on the CPU, the walk on the
    /// device). Returns the Hits fields and the seconds of each phase.
    #[pyo3(signature = (origins, directions, tmin, tmax, threads=None, max_steps=None, method=None, layout=None))]
    #[allow(clippy::too_many_arguments)]
    fn cast_gpu<'py>(
        &self,
        py: Python<'py>,
        origins: PyReadonlyArray2<'py, f32>,
        directions: PyReadonlyArray2<'py, f32>,
        tmin: PyReadonlyArray1<'py, f64>,
        tmax: PyReadonlyArray1<'py, f64>,
        threads: Option<usize>,
        max_steps: Option<u32>,
        method: Option<&str>,
        layout: Option<&str>,
    ) -> PyResult<(Bound<'py, PyDict>, Bound<'py, PyDict>)> {
        let scene = &self.inner;
        let mut timings = crate::gpu::GpuTimings::default();
        let hits = cast_impl(
            py,
            scene,
            origins,
            directions,
            tmin,
            tmax,
            threads,
            max_steps,
            false,
            |rays, out, opts| {
                timings = scene.cast_gpu(method, layout, rays, out, opts)?;
                Ok(())
            },
        )?;
        let t = PyDict::new(py);
        for (k, v) in [
            ("locate", timings.locate),
            ("scene_upload", timings.scene_upload),
            ("upload", timings.upload),
            ("kernel", timings.kernel),
            ("readback", timings.readback),
            ("finish", timings.finish),
        ] {
            t.set_item(k, v)?;
        }
        t.set_item("walked", timings.walked)?;
        t.set_item("deferred", timings.deferred)?;
        t.set_item("batches", timings.batches)?;
        Ok((hits, t))
    }

    /// Bytes used by each part of the structure (`gpu_<layout>`: on the device).
    fn memory<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for (k, v) in self.inner.memory() {
            d.set_item(k, v)?;
        }
        for (k, v) in self.inner.gpu.bytes() {
            d.set_item(format!("gpu_{k}"), v)?;
        }
        Ok(d)
    }

    #[getter]
    fn n_tets(&self) -> usize {
        self.inner.mesh.len()
    }
    #[getter]
    fn n_points(&self) -> usize {
        self.inner.mesh.points.len()
    }
    #[getter]
    fn n_constrained(&self) -> usize {
        self.inner.mesh.constrained.len()
    }
    /// Builds a traversal layout now instead of at its first cast; returns its bytes.
    fn prepare_layout(&self, py: Python<'_>, layout: &str) -> PyResult<usize> {
        py.detach(|| guarded(|| self.inner.layouts.prepare(layout, &self.inner.mesh)))
    }
    #[getter]
    fn bounds(&self) -> [[f64; 3]; 2] {
        self.inner.mesh.bounds
    }
    /// The points (P, 3) in the scene's order (Hilbert order unless disabled).
    fn points<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, numpy::PyArray2<f64>>> {
        let flat: Vec<f64> = self.inner.mesh.points.iter().flatten().copied().collect();
        Ok(flat
            .into_pyarray(py)
            .reshape([self.inner.mesh.points.len(), 3])?)
    }

    /// The positively oriented tets (T, 4), for inspection and plotting.
    fn tets<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, numpy::PyArray2<u32>>> {
        let flat: Vec<u32> = self.inner.mesh.tets.iter().flatten().copied().collect();
        Ok(flat.into_pyarray(py).reshape([self.inner.mesh.len(), 4])?)
    }
}

#[allow(clippy::too_many_arguments)]
fn cast_any<'py, R: Precision + Element>(
    py: Python<'py>,
    scene: &Scene,
    origins: PyReadonlyArray2<'py, R>,
    directions: PyReadonlyArray2<'py, R>,
    tmin: PyReadonlyArray1<'py, f64>,
    tmax: PyReadonlyArray1<'py, f64>,
    threads: Option<usize>,
    max_steps: Option<u32>,
    method: &str,
    layout: &str,
    audit: bool,
) -> PyResult<Bound<'py, PyDict>> {
    cast_impl(
        py,
        scene,
        origins,
        directions,
        tmin,
        tmax,
        threads,
        max_steps,
        audit,
        |rays, out, opts| scene.cast_named(method, layout, rays, out, opts),
    )
}

/// Validates, allocates the outputs (with `audit`, two counts per ray), runs `cast` with the
/// GIL released, returns the fields.
#[allow(clippy::too_many_arguments)]
fn cast_impl<'py, R: Precision + Element>(
    py: Python<'py>,
    scene: &Scene,
    origins: PyReadonlyArray2<'py, R>,
    directions: PyReadonlyArray2<'py, R>,
    tmin: PyReadonlyArray1<'py, f64>,
    tmax: PyReadonlyArray1<'py, f64>,
    threads: Option<usize>,
    max_steps: Option<u32>,
    audit: bool,
    cast: impl FnOnce(&Rays<R>, HitsOut<R>, &CastOptions) -> crate::Result<()> + Send,
) -> PyResult<Bound<'py, PyDict>> {
    let n = check_cols(&origins, 3, "origins")?;
    if check_cols(&directions, 3, "directions")? != n {
        return Err(PyValueError::new_err(
            "origins and directions must have the same number of rows",
        ));
    }
    if threads == Some(0) {
        return Err(PyValueError::new_err(
            "threads must be at least 1 (or None for all cores)",
        ));
    }
    let (o, d) = (
        slice(&origins, "origins")?,
        slice(&directions, "directions")?,
    );
    let (lo, hi) = (slice(&tmin, "tmin")?, slice(&tmax, "tmax")?);
    let max_steps = max_steps.unwrap_or_else(|| default_max_steps(scene.mesh.len()));
    let opts = CastOptions { threads, max_steps };
    let (mut t, mut u, mut v, mut p) = (
        vec![R::ZERO; n],
        vec![R::ZERO; n],
        vec![R::ZERO; n],
        vec![R::ZERO; 3 * n],
    );
    let (mut tri, mut tet, mut steps, mut status) =
        (vec![0i32; n], vec![0i32; n], vec![0u32; n], vec![0u8; n]);
    let mut audit_counts = vec![0u32; if audit { 2 * n } else { 0 }];
    py.detach(|| {
        guarded(|| {
            let rays = Rays {
                origins: o,
                directions: d,
                tmin: lo,
                tmax: hi,
            };
            let out = HitsOut {
                t: &mut t,
                u: &mut u,
                v: &mut v,
                point: &mut p,
                triangle: &mut tri,
                tet: &mut tet,
                steps: &mut steps,
                status: &mut status,
                audit: &mut audit_counts,
            };
            cast(&rays, out, &opts)
        })
    })?;
    let out = PyDict::new(py);
    out.set_item("t", t.into_pyarray(py))?;
    out.set_item("u", u.into_pyarray(py))?;
    out.set_item("v", v.into_pyarray(py))?;
    out.set_item("point", p.into_pyarray(py).reshape([n, 3])?)?;
    out.set_item("triangle", tri.into_pyarray(py))?;
    out.set_item("tet", tet.into_pyarray(py))?;
    out.set_item("steps", steps.into_pyarray(py))?;
    out.set_item("status", status.into_pyarray(py))?;
    if audit {
        out.set_item("audit", audit_counts.into_pyarray(py).reshape([n, 2])?)?;
    }
    Ok(out)
}

/// A valid walk visits each tet at most once, so the tet count bounds it; the cap keeps a
/// cycling ray in a huge mesh from costing seconds.
pub fn default_max_steps(n_tets: usize) -> u32 {
    (n_tets as u64 + 1).min(1 << 20) as u32
}

/// The exit-face micro-benchmark: (method, precision, ns per decision, decisions that are not
/// among the exact exit faces of the line, decided by the referee) for every method and
/// precision, one thread.
#[pyfunction]
#[pyo3(signature = (n_tets=10_000, rays_per_tet=16, seed=1, repeat=5))]
fn exitface_bench(
    py: Python<'_>,
    n_tets: usize,
    rays_per_tet: usize,
    seed: u64,
    repeat: usize,
) -> PyResult<Vec<(&'static str, &'static str, f64, usize)>> {
    if n_tets == 0 || rays_per_tet == 0 {
        return Err(PyValueError::new_err(
            "n_tets and rays_per_tet must be positive",
        ));
    }
    py.detach(|| {
        guarded(|| {
            let cases = crate::bench::cases(n_tets, rays_per_tet, seed);
            let mut out = Vec::new();
            for m in crate::dispatch::METHODS {
                for p in ["f32", "f64"] {
                    let (ns, wrong) = crate::bench::exitface(m, p, &cases, repeat)?;
                    out.push((m, p, ns, wrong));
                }
            }
            Ok(out)
        })
    })
}

/// The exact referee (`crate::referee`, docs/referee.md) by brute force over every triangle,
/// for cross-checking `tetrace.referee` on small scenes: per ray `hit` (bool), `t` (the exact
/// first hit rounded to float64, inf on a miss), `triangle` (the smallest id of the tie set,
/// -1 on a miss) and `ties` (the size of the tie set). `tmin`/`tmax`: one per ray, or one.
#[pyfunction]
fn referee_first_hit<'py>(
    py: Python<'py>,
    vertices: PyReadonlyArray2<'py, f64>,
    faces: &Bound<'py, PyAny>,
    origins: PyReadonlyArray2<'py, f64>,
    directions: PyReadonlyArray2<'py, f64>,
    tmin: PyReadonlyArray1<'py, f64>,
    tmax: PyReadonlyArray1<'py, f64>,
) -> PyResult<Bound<'py, PyDict>> {
    use rayon::prelude::*;
    check_cols(&vertices, 3, "vertices")?;
    let v: Vec<[f64; 3]> = rows(slice(&vertices, "vertices")?);
    if v.iter().flatten().any(|x| !x.is_finite()) {
        return Err(PyValueError::new_err("vertices must be finite"));
    }
    let f: Vec<[i64; 3]> = if let Ok(a) = faces.extract::<PyReadonlyArray2<'py, i64>>() {
        check_cols(&a, 3, "faces")?;
        rows(slice(&a, "faces")?)
    } else if let Ok(a) = faces.extract::<PyReadonlyArray2<'py, i32>>() {
        check_cols(&a, 3, "faces")?;
        rows::<i32, 3>(slice(&a, "faces")?)
            .into_iter()
            .map(|r| r.map(i64::from))
            .collect()
    } else if let Ok(a) = faces.extract::<PyReadonlyArray2<'py, u32>>() {
        check_cols(&a, 3, "faces")?;
        rows::<u32, 3>(slice(&a, "faces")?)
            .into_iter()
            .map(|r| r.map(i64::from))
            .collect()
    } else {
        return Err(pyo3::exceptions::PyTypeError::new_err(
            "faces must be a 2-D int64, int32 or uint32 array",
        ));
    };
    if f.iter().flatten().any(|&i| i < 0 || i as usize >= v.len()) {
        return Err(PyValueError::new_err(
            "faces index vertices that do not exist",
        ));
    }
    let n = check_cols(&origins, 3, "origins")?;
    if check_cols(&directions, 3, "directions")? != n {
        return Err(PyValueError::new_err(
            "origins and directions must have the same number of rows",
        ));
    }
    let (o, d) = (
        slice(&origins, "origins")?,
        slice(&directions, "directions")?,
    );
    let (lo, hi) = (slice(&tmin, "tmin")?, slice(&tmax, "tmax")?);
    for (name, b) in [("tmin", lo), ("tmax", hi)] {
        if b.len() != n && b.len() != 1 {
            return Err(PyValueError::new_err(format!(
                "{name} must have {n} values (one per ray) or one"
            )));
        }
    }
    let tris: Vec<crate::referee::Tri> = f.iter().map(|t| t.map(|i| v[i as usize])).collect();
    let verdicts = py.detach(|| {
        guarded(|| {
            let at = |b: &[f64], i: usize| b[if b.len() == 1 { 0 } else { i }];
            Ok((0..n)
                .into_par_iter()
                .map(|i| {
                    let p = |x: &[f64]| [x[3 * i], x[3 * i + 1], x[3 * i + 2]];
                    crate::referee::first_hit(p(o), p(d), at(lo, i), at(hi, i), &tris)
                        .map(|v| (v.t, v.ties[0] as i64, v.ties.len() as i64))
                })
                .collect::<Vec<_>>())
        })
    })?;
    let out = PyDict::new(py);
    let hit: Vec<bool> = verdicts.iter().map(Option::is_some).collect();
    let t: Vec<f64> = verdicts
        .iter()
        .map(|v| v.map_or(f64::INFINITY, |v| v.0))
        .collect();
    let tri: Vec<i64> = verdicts.iter().map(|v| v.map_or(-1, |v| v.1)).collect();
    let ties: Vec<i64> = verdicts.iter().map(|v| v.map_or(0, |v| v.2)).collect();
    out.set_item("hit", hit.into_pyarray(py))?;
    out.set_item("t", t.into_pyarray(py))?;
    out.set_item("triangle", tri.into_pyarray(py))?;
    out.set_item("ties", ties.into_pyarray(py))?;
    Ok(out)
}

/// Exit-face methods, in the order of the papers.
#[pyfunction]
fn methods() -> Vec<&'static str> {
    crate::dispatch::METHODS.to_vec()
}

/// Traversal layouts, with their bytes per tet.
#[pyfunction]
fn layouts() -> Vec<(&'static str, usize)> {
    use crate::layout::*;
    vec![
        (Plain::NAME, Plain::BYTES_PER_TET),
        (Tet80::NAME, Tet80::BYTES_PER_TET),
        (Tet32::NAME, Tet32::BYTES_PER_TET),
        (Tet20::NAME, Tet20::BYTES_PER_TET),
        (Tet16::NAME, Tet16::BYTES_PER_TET),
    ]
}

/// Every adapter wgpu finds, best first, as dicts.
#[pyfunction]
fn gpu_adapters<'py>(py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
    let found = py.detach(|| guarded(|| Ok(crate::gpu::adapters())))?;
    found.iter().map(|a| adapter_dict(py, a)).collect()
}

/// The adapter GPU casts run on (opening the device on first use); GpuError without one.
#[pyfunction]
fn gpu_device<'py>(py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
    let g = py.detach(|| guarded(crate::gpu::gpu))?;
    let d = adapter_dict(py, &g.adapter)?;
    d.set_item(
        "device_max_storage_buffer_binding_size",
        g.limits.max_storage_buffer_binding_size,
    )?;
    d.set_item("device_max_buffer_size", g.limits.max_buffer_size)?;
    Ok(d)
}

/// The GPU kernels as (method, layout) pairs, the default first.
#[pyfunction]
fn gpu_kernels() -> Vec<(&'static str, &'static str)> {
    crate::gpu::KERNELS
        .iter()
        .map(|k| (k.method, k.layout.name))
        .collect()
}

/// The (method, layout) kernel a GPU cast with these names uses (None: the default kernel's
/// method; the first layout with a kernel for the method); ValueError naming the kernels.
#[pyfunction]
#[pyo3(signature = (method=None, layout=None))]
fn gpu_kernel_for(
    method: Option<&str>,
    layout: Option<&str>,
) -> PyResult<(&'static str, &'static str)> {
    let k = crate::gpu::KernelSpec::find(method, layout)?;
    Ok((k.method, k.layout.name))
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

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyScene>()?;
    m.add_function(wrap_pyfunction!(methods, m)?)?;
    m.add_function(wrap_pyfunction!(layouts, m)?)?;
    m.add_function(wrap_pyfunction!(exitface_bench, m)?)?;
    m.add_function(wrap_pyfunction!(referee_first_hit, m)?)?;
    m.add_function(wrap_pyfunction!(gpu_adapters, m)?)?;
    m.add_function(wrap_pyfunction!(gpu_device, m)?)?;
    m.add_function(wrap_pyfunction!(gpu_kernels, m)?)?;
    m.add_function(wrap_pyfunction!(gpu_kernel_for, m)?)?;
    m.add("DEFAULT_METHOD", crate::dispatch::DEFAULT_METHOD)?;
    m.add("DEFAULT_LAYOUT", crate::dispatch::DEFAULT_LAYOUT)?;
    m.add("MeshError", m.py().get_type::<MeshError>())?;
    m.add("TooLargeError", m.py().get_type::<TooLargeError>())?;
    m.add("GpuError", m.py().get_type::<GpuError>())?;
    m.add("MISS", crate::MISS)?;
    m.add("HIT", crate::HIT)?;
    m.add("FAILED", crate::FAILED)?;
    m.add("INVALID", crate::INVALID)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
