//! The names Python can pass, read from the core's tables: a method or layout argument is
//! checked against the table as it is extracted, and the lists Python shows come from the same
//! tables.

use crate::accel::{AccelKind, ACCELS};
use crate::layout::LayoutKind;
use crate::scene::queries::{QueryName, QUERIES};
use crate::traverse::{Method, METHODS};
use pyo3::prelude::*;

/// A name argument as a string, or a TypeError that says what was given instead.
fn name_of(obj: pyo3::Borrowed<'_, '_, PyAny>, what: &str) -> PyResult<String> {
    obj.extract().map_err(|_| {
        let got = obj
            .get_type()
            .name()
            .map_or_else(|_| "?".to_string(), |n| n.to_string());
        pyo3::exceptions::PyTypeError::new_err(format!("{what} must be a name (str), got {got}"))
    })
}

/// An exit-method argument (`method="aman2022"`), checked against the method table.
pub(crate) struct MethodArg(pub Method);

impl<'a, 'py> FromPyObject<'a, 'py> for MethodArg {
    type Error = PyErr;
    fn extract(obj: pyo3::Borrowed<'a, 'py, PyAny>) -> PyResult<Self> {
        let name: String = name_of(obj, "method")?;
        Ok(MethodArg(Method::from_name(&name)?))
    }
}

/// A layout argument (`layout="tet32"`), checked against the layout table.
pub(crate) struct LayoutArg(pub LayoutKind);

impl<'a, 'py> FromPyObject<'a, 'py> for LayoutArg {
    type Error = PyErr;
    fn extract(obj: pyo3::Borrowed<'a, 'py, PyAny>) -> PyResult<Self> {
        let name: String = name_of(obj, "layout")?;
        Ok(LayoutArg(LayoutKind::from_name(&name)?))
    }
}

/// An acceleration-structure argument (`accel="reshetov_bvh"`), checked against the table.
pub(crate) struct AccelArg(pub AccelKind);

impl<'a, 'py> FromPyObject<'a, 'py> for AccelArg {
    type Error = PyErr;
    fn extract(obj: pyo3::Borrowed<'a, 'py, PyAny>) -> PyResult<Self> {
        let name: String = name_of(obj, "accel")?;
        Ok(AccelArg(AccelKind::from_name(&name)?))
    }
}

/// A ray-query argument (`"closest"`, `"any"`, ...), checked against the query table.
pub(crate) struct QueryArg(pub QueryName);

impl<'a, 'py> FromPyObject<'a, 'py> for QueryArg {
    type Error = PyErr;
    fn extract(obj: pyo3::Borrowed<'a, 'py, PyAny>) -> PyResult<Self> {
        let name: String = name_of(obj, "query")?;
        Ok(QueryArg(QueryName::from_name(&name)?))
    }
}

/// The ray queries `NativeScene.query` answers, from the query table.
#[pyfunction]
pub(crate) fn queries() -> Vec<&'static str> {
    QUERIES.to_vec()
}

/// Acceleration structures: the tet walk first (the default).
#[pyfunction]
pub(crate) fn accels() -> Vec<&'static str> {
    ACCELS.to_vec()
}

/// Each structure's default parameters (`{"bvh": {"cost_ratio": 1.0, ...}, ...}`): the core
/// owns them, Python's signatures read them.
#[pyfunction]
pub(crate) fn structure_defaults(py: Python<'_>) -> PyResult<Bound<'_, pyo3::types::PyDict>> {
    use crate::accel::table::Param;
    let out = pyo3::types::PyDict::new(py);
    for (name, fields) in crate::accel::Structures::defaults() {
        let d = pyo3::types::PyDict::new(py);
        for (k, v) in fields {
            match v {
                Param::F64(x) => d.set_item(k, x)?,
                Param::U32(x) => d.set_item(k, x)?,
                Param::Bool(x) => d.set_item(k, x)?,
            }
        }
        out.set_item(name, d)?;
    }
    Ok(out)
}

/// Exit methods, in the order of the papers.
#[pyfunction]
pub(crate) fn methods() -> Vec<&'static str> {
    METHODS.to_vec()
}

/// Traversal layouts, with their bytes per tet.
#[pyfunction]
pub(crate) fn layouts() -> Vec<(&'static str, usize)> {
    LayoutKind::ALL
        .iter()
        .map(|k| (k.name(), k.bytes_per_tet()))
        .collect()
}

/// The SIMD levels this CPU runs, lowest first, and the one a cast uses now (the highest,
/// capped by `TETRACE_SIMD`; an unknown name there is a ValueError).
#[pyfunction]
pub(crate) fn simd_levels() -> PyResult<(Vec<&'static str>, &'static str)> {
    let levels = crate::simd::Simd::supported_levels();
    let now = crate::simd::Simd::from_env()?;
    Ok((levels.into_iter().map(|s| s.name()).collect(), now.name()))
}
