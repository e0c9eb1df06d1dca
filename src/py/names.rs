//! The names Python can pass, read from the core's tables.

use pyo3::prelude::*;

/// Exit-face methods, in the order of the papers.
#[pyfunction]
pub(crate) fn methods() -> Vec<&'static str> {
    crate::dispatch::METHODS.to_vec()
}

/// Traversal layouts, with their bytes per tet.
#[pyfunction]
pub(crate) fn layouts() -> Vec<(&'static str, usize)> {
    use crate::layout::*;
    vec![
        (Plain::NAME, Plain::BYTES_PER_TET),
        (Tet80::NAME, Tet80::BYTES_PER_TET),
        (Tet32::NAME, Tet32::BYTES_PER_TET),
        (Tet20::NAME, Tet20::BYTES_PER_TET),
        (Tet16::NAME, Tet16::BYTES_PER_TET),
    ]
}
