//! The one mapping from core errors to Python exceptions, and the net that keeps a panic
//! from crossing into Python.

use crate::error::Error;
use pyo3::exceptions::{PyKeyboardInterrupt, PyMemoryError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
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
            Error::OutOfMemory { .. } => PyMemoryError::new_err(msg),
            Error::Interrupted => PyKeyboardInterrupt::new_err(msg),
        }
    }
}

/// Runs core code with a net under it: a panic would be a bug, and it must reach Python as an
/// exception that says so rather than abort the interpreter.
pub(crate) fn guarded<T>(f: impl FnOnce() -> crate::Result<T>) -> PyResult<T> {
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

/// Runs core code as [`guarded`] does, with the GIL released and Python's signal handlers
/// polled from this thread every [`crate::threads::POLL_EVERY`] while the core's pieces run
/// (`threads::run_pieces`) and at the checkpoints between a build's stages: a handler that
/// raises (Ctrl-C's `KeyboardInterrupt`) stops the pieces not yet started, and once the
/// running ones finish, its exception is raised here; nothing the core computed is returned.
/// Every binding that builds, casts or queries goes through it.
pub(crate) fn interruptible<T: Send>(
    py: Python<'_>,
    f: impl FnOnce() -> crate::Result<T> + Send,
) -> PyResult<T> {
    interruptible_with_progress(py, None, f)
}

/// [`interruptible`], also calling `progress(done, total)` (pieces of the run under way) at
/// each poll that has a count: a cast's progress bar. An exception it raises stops the run
/// as Ctrl-C does and is raised here.
pub(crate) fn interruptible_with_progress<T: Send>(
    py: Python<'_>,
    progress: Option<Py<PyAny>>,
    f: impl FnOnce() -> crate::Result<T> + Send,
) -> PyResult<T> {
    use std::sync::{Arc, Mutex};
    let raised: Arc<Mutex<Option<PyErr>>> = Arc::default();
    let slot = raised.clone();
    let poll = move |p: crate::threads::Progress| {
        Python::attach(|py| {
            let report = || match &progress {
                Some(cb) if p.total > 0 => cb.call1(py, (p.done, p.total)).map(|_| ()),
                _ => Ok(()),
            };
            match py.check_signals().and_then(|()| report()) {
                Ok(()) => true,
                Err(e) => {
                    *slot.lock().unwrap_or_else(|p| p.into_inner()) = Some(e);
                    false
                }
            }
        })
    };
    let out = py.detach(|| crate::threads::with_poll(poll, || guarded(f)));
    // The core's Interrupted stands for what the poll caught (Ctrl-C, or the callback's error).
    let taken = raised.lock().unwrap_or_else(|p| p.into_inner()).take();
    match out {
        Err(e) if e.is_instance_of::<PyKeyboardInterrupt>(py) => Err(taken.unwrap_or(e)),
        other => other,
    }
}
