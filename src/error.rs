//! The one error type of the core. `src/py/` maps each variant to a Python exception once.

use std::fmt;

#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Error {
    /// Arrays with wrong shapes, non-finite values, indices out of range.
    InvalidInput(String),
    /// The tetrahedralization itself is broken: inverted or flat tets, non-manifold faces,
    /// constrained faces that are not faces of any tet.
    InvalidMesh(String),
    /// A size limit of a layout (e.g. 31-bit tet ids) would be exceeded.
    TooLarge(String),
    /// An option that does not exist or does not fit the others.
    InvalidOption(String),
    /// No GPU adapter, or the device failed (validation, out of memory, lost).
    Gpu(String),
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::InvalidInput(m) => write!(f, "invalid input: {m}"),
            Error::InvalidMesh(m) => write!(f, "invalid tetrahedralization: {m}"),
            Error::TooLarge(m) => write!(f, "too large: {m}"),
            Error::InvalidOption(m) => write!(f, "invalid option: {m}"),
            Error::Gpu(m) => write!(f, "GPU: {m}"),
        }
    }
}

impl std::error::Error for Error {}

impl Error {
    /// An unknown name for an option, listing the known ones.
    pub fn unknown(what: &str, name: &str, known: &[&str]) -> Error {
        Error::InvalidOption(format!(
            "unknown {what} {name:?}; known: {}",
            known.join(", ")
        ))
    }
}

pub type Result<T> = std::result::Result<T, Error>;
