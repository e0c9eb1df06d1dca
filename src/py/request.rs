//! `RayRequest`: one ray query's arguments, checked once as Python builds it, and taken by the
//! one query binding (`NativeScene.query`) for every query kind and by the GPU cast. The
//! precision is named, not guessed from the arrays; the names (method, layout, accel) are
//! checked against the core's tables, the threads and the step guard against the core's rules.

use super::arrays::{check_cols, slice};
use super::names::{AccelArg, LayoutArg, MethodArg};
use crate::geom::real::Real;
use crate::scene::buffers::LeavingRays;
use crate::scene::queries::Ask;
use crate::scene::{CastOptions, Packets, Rays, Scene};
use numpy::{Element, PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyInt};

/// The rays' arrays in the precision the request names.
enum Arrays {
    F32(Py<PyArray2<f32>>, Py<PyArray2<f32>>),
    F64(Py<PyArray2<f64>>, Py<PyArray2<f64>>),
}

/// Per ray, the hit a ray starts from (`start=hits`): the caller's triangle it leaves and the
/// tet that hit's walk ended in, −1 for none.
type Start = (Py<PyArray1<i32>>, Py<PyArray1<i32>>);
/// The same, as Python passes it.
type StartArg<'py> = (Bound<'py, PyArray1<i32>>, Bound<'py, PyArray1<i32>>);
/// The same, borrowed for one call.
type StartRead<'py> = (PyReadonlyArray1<'py, i32>, PyReadonlyArray1<'py, i32>);

#[pyclass(frozen, name = "RayRequest", module = "tetrace._native")]
pub struct PyRayRequest {
    arrays: Arrays,
    tmin: Py<PyArray1<f64>>,
    tmax: Py<PyArray1<f64>>,
    start: Option<Start>,
    pub(crate) opts: CastOptions,
    pub(crate) ask: Ask,
    /// Whether the caller named the accelerator (else `opts.accel` is the CPU default,
    /// [`Ask::default_accel`], and the GPU walks the tets as it always does).
    pub(crate) accel_named: bool,
    n: usize,
}

#[pymethods]
impl PyRayRequest {
    /// Checks a ray query's arguments: `origins`, `directions` (N, 3) C-contiguous in the
    /// named `precision` ("f32" or "f64"); `tmin`, `tmax` float64, 1 or N values; `threads`
    /// None or an int in [1, MAX_THREADS]; `max_steps` None or an int in [1, 2**32);
    /// `method`, `layout`, `accel` None (the defaults) or names from the tables; `packet` a
    /// bool; `start` None or two int32 arrays of N (the triangle each ray leaves, the tet its
    /// hit's walk ended in); `audit` (closest hits only) counts rejected exit faces.
    #[new]
    #[pyo3(signature = (origins, directions, tmin, tmax, *, precision, threads=None, max_steps=None, method=None, layout=None, accel=None, packet=None, start=None, audit=false))]
    #[allow(clippy::too_many_arguments)] // a Python signature: keyword arguments, not a design
    fn new(
        origins: &Bound<'_, PyAny>,
        directions: &Bound<'_, PyAny>,
        tmin: Bound<'_, PyArray1<f64>>,
        tmax: Bound<'_, PyArray1<f64>>,
        precision: &str,
        threads: Option<&Bound<'_, PyAny>>,
        max_steps: Option<&Bound<'_, PyAny>>,
        method: Option<MethodArg>,
        layout: Option<LayoutArg>,
        accel: Option<AccelArg>,
        packet: Option<&Bound<'_, PyAny>>,
        start: Option<StartArg<'_>>,
        audit: bool,
    ) -> PyResult<Self> {
        let (arrays, n) = match precision {
            "f32" => {
                let (o, d, n) = pair::<f32>(origins, directions, precision)?;
                (Arrays::F32(o, d), n)
            }
            "f64" => {
                let (o, d, n) = pair::<f64>(origins, directions, precision)?;
                (Arrays::F64(o, d), n)
            }
            _ => {
                return Err(PyValueError::new_err(format!(
                    "precision must be \"f32\" or \"f64\", got {precision:?}"
                )))
            }
        };
        for (name, a) in [("tmin", &tmin), ("tmax", &tmax)] {
            let ro = a.try_readonly()?;
            slice(&ro, name)?;
        }
        if let Some((triangle, tet)) = &start {
            for (name, a) in [("start triangles", triangle), ("start tets", tet)] {
                slice(&a.try_readonly()?, name)?;
            }
        }
        let threads = threads_arg(threads)?;
        let max_steps = max_steps_arg(max_steps)?;
        // None (the default) is True: packets where rays share an origin.
        let packet = match packet {
            None => true,
            Some(p) if p.is_instance_of::<PyBool>() || is_numpy(p, "bool_")? => p.is_truthy()?,
            Some(p) => {
                return Err(PyTypeError::new_err(format!(
                    "packet must be True or False, got {}",
                    p.repr()?
                )))
            }
        };
        let ask = Ask {
            method: method.map(|m| m.0),
            layout: layout.map(|l| l.0),
            audit,
        };
        let opts = CastOptions {
            threads,
            max_steps,
            packets: if packet { Packets::Auto } else { Packets::Off },
            accel: accel.as_ref().map_or(ask.default_accel(max_steps), |a| a.0),
            ..Default::default()
        };
        Ok(PyRayRequest {
            arrays,
            tmin: tmin.unbind(),
            tmax: tmax.unbind(),
            start: start.map(|(a, b)| (a.unbind(), b.unbind())),
            opts,
            ask,
            accel_named: accel.is_some(),
            n,
        })
    }

    /// The number of rays.
    fn __len__(&self) -> usize {
        self.n
    }

    /// The accelerator a CPU query takes: the one named, else the default for the method,
    /// layout, step guard and audit asked for (`Ask::default_accel`).
    #[getter]
    fn accel(&self) -> &'static str {
        self.opts.accel.name()
    }

    /// "f32" or "f64".
    #[getter]
    fn precision(&self) -> &'static str {
        match self.arrays {
            Arrays::F32(..) => "f32",
            Arrays::F64(..) => "f64",
        }
    }
}

/// Whether `obj` is an instance of numpy's scalar type `name` (`bool_`, `integer`).
fn is_numpy(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<bool> {
    obj.is_instance(&obj.py().import("numpy")?.getattr(name)?)
}

/// A `threads` argument: None (all cores) or an int in [1, MAX_THREADS], by the core's rule
/// (`threads::check_threads`); a TypeError for a bool, a float or a string.
pub(crate) fn threads_arg(obj: Option<&Bound<'_, PyAny>>) -> PyResult<Option<usize>> {
    let threads = int_arg(obj, "threads", "None")?;
    crate::threads::check_threads(threads)?;
    Ok(threads)
}

/// A `max_steps` argument: None, or an int in [1, 2**32).
pub(crate) fn max_steps_arg(obj: Option<&Bound<'_, PyAny>>) -> PyResult<Option<u32>> {
    match int_arg(obj, "max_steps", "None")? {
        None => Ok(None),
        Some(k) if k > 0 && k <= u32::MAX as usize => Ok(Some(k as u32)),
        Some(k) => Err(PyValueError::new_err(format!(
            "max_steps must be a positive int below 2**32, got {k}"
        ))),
    }
}

/// Checks a `threads` argument by the core's rule and returns it (Python's point queries
/// call this before a query that may not reach the core, such as the winding number).
#[pyfunction]
#[pyo3(signature = (threads=None))]
pub(crate) fn check_threads(threads: Option<&Bound<'_, PyAny>>) -> PyResult<Option<usize>> {
    threads_arg(threads)
}

/// An optional count: None, or an int (a Python or numpy integer, not a bool or a float).
fn int_arg(obj: Option<&Bound<'_, PyAny>>, name: &str, none: &str) -> PyResult<Option<usize>> {
    let Some(obj) = obj else { return Ok(None) };
    // A Python int or a numpy integer; not a bool (an int subclass), a float or a string.
    let is_int = !obj.is_instance_of::<PyBool>()
        && !is_numpy(obj, "bool_")?
        && (obj.is_instance_of::<PyInt>() || is_numpy(obj, "integer")?);
    if !is_int {
        return Err(PyTypeError::new_err(format!(
            "{name} must be an int or {none}, got {} {}",
            obj.get_type().name()?,
            obj.repr()?
        )));
    }
    let k: i128 = obj.call_method0("__index__")?.extract()?;
    if k < 0 {
        return Err(PyValueError::new_err(format!(
            "{name} must be at least 1, got {k}"
        )));
    }
    Ok(Some(usize::try_from(k).unwrap_or(usize::MAX)))
}

/// Origins and directions as (N, 3) arrays of precision R, N the same for both.
#[allow(clippy::type_complexity)]
fn pair<R: Element>(
    origins: &Bound<'_, PyAny>,
    directions: &Bound<'_, PyAny>,
    precision: &str,
) -> PyResult<(Py<PyArray2<R>>, Py<PyArray2<R>>, usize)> {
    fn array<'py, R: Element>(
        a: &Bound<'py, PyAny>,
        name: &str,
        precision: &str,
    ) -> PyResult<Bound<'py, PyArray2<R>>> {
        a.cast::<PyArray2<R>>().cloned().map_err(|_| {
            let got = a
                .getattr("dtype")
                .map(|d| d.to_string())
                .unwrap_or_else(|_| a.get_type().to_string());
            let ndim = a.getattr("ndim").map(|d| d.to_string()).unwrap_or_default();
            PyTypeError::new_err(format!(
                "{name} must be a 2-D numpy array of the precision asked for ({precision}), \
                 got {got} with ndim {ndim}"
            ))
        })
    }
    let (o, d) = (
        array::<R>(origins, "origins", precision)?,
        array::<R>(directions, "directions", precision)?,
    );
    let n = check_cols(&o.try_readonly()?, 3, "origins")?;
    if check_cols(&d.try_readonly()?, 3, "directions")? != n {
        return Err(PyValueError::new_err(
            "origins and directions must have the same number of rows",
        ));
    }
    slice(&o.try_readonly()?, "origins")?;
    slice(&d.try_readonly()?, "directions")?;
    Ok((o.unbind(), d.unbind(), n))
}

/// The request's arrays borrowed for one call.
pub(crate) struct Borrowed<'py, R: Element> {
    origins: PyReadonlyArray2<'py, R>,
    directions: PyReadonlyArray2<'py, R>,
    tmin: PyReadonlyArray1<'py, f64>,
    tmax: PyReadonlyArray1<'py, f64>,
    start: Option<StartRead<'py>>,
}

impl<R: Element + Real> Borrowed<'_, R> {
    /// The rays as slices over `scene` (checked contiguous when the request was made; checked
    /// again since an array's flags can change).
    pub(crate) fn rays<'a>(&'a self, scene: &'a Scene) -> PyResult<Rays<'a, R>> {
        let leaving = match &self.start {
            Some((triangle, tet)) => Some(LeavingRays {
                triangles: &scene.surface.triangles,
                triangle: slice(triangle, "start triangles")?,
                tet: slice(tet, "start tets")?,
            }),
            None => None,
        };
        Ok(Rays {
            origins: slice(&self.origins, "origins")?,
            directions: slice(&self.directions, "directions")?,
            tmin: slice(&self.tmin, "tmin")?,
            tmax: slice(&self.tmax, "tmax")?,
            leaving,
        })
    }
}

/// Something to do with the request's rays in their precision.
pub(crate) trait WithRays {
    type Out;
    fn run<R: Real + Element>(self, rays: Borrowed<'_, R>, n: usize) -> PyResult<Self::Out>;
}

impl PyRayRequest {
    /// Calls `f` with the rays borrowed in the request's precision.
    pub(crate) fn with_rays<F: WithRays>(&self, py: Python<'_>, f: F) -> PyResult<F::Out> {
        let (tmin, tmax) = (
            self.tmin.bind(py).try_readonly()?,
            self.tmax.bind(py).try_readonly()?,
        );
        let start = self.start_read(py)?;
        match &self.arrays {
            Arrays::F32(o, d) => f.run(
                Borrowed {
                    origins: o.bind(py).try_readonly()?,
                    directions: d.bind(py).try_readonly()?,
                    tmin,
                    tmax,
                    start,
                },
                self.n,
            ),
            Arrays::F64(o, d) => f.run(
                Borrowed {
                    origins: o.bind(py).try_readonly()?,
                    directions: d.bind(py).try_readonly()?,
                    tmin,
                    tmax,
                    start,
                },
                self.n,
            ),
        }
    }

    /// The float32 rays of a GPU cast (which walks in float32 only).
    pub(crate) fn f32_rays<'py>(&self, py: Python<'py>) -> PyResult<Borrowed<'py, f32>> {
        let Arrays::F32(o, d) = &self.arrays else {
            return Err(PyValueError::new_err(
                "device=\"gpu\" walks in float32 (WGSL has no float64); use precision=\"f32\" \
                 or device=\"cpu\"",
            ));
        };
        let start = self.start_read(py)?;
        Ok(Borrowed {
            origins: o.bind(py).try_readonly()?,
            directions: d.bind(py).try_readonly()?,
            tmin: self.tmin.bind(py).try_readonly()?,
            tmax: self.tmax.bind(py).try_readonly()?,
            start,
        })
    }

    /// The `start=hits` arrays (triangle, tet), borrowed, if the request has them.
    fn start_read<'py>(&self, py: Python<'py>) -> PyResult<Option<StartRead<'py>>> {
        Ok(match &self.start {
            Some((a, b)) => Some((a.bind(py).try_readonly()?, b.bind(py).try_readonly()?)),
            None => None,
        })
    }
}
