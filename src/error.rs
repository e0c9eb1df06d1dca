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
    /// An allocation sized by the caller failed: `bytes` asked for, for `what`.
    OutOfMemory { bytes: usize, what: String },
    /// The caller's poll ([`crate::threads::with_poll`]) asked to stop; nothing was returned.
    Interrupted,
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::InvalidInput(m) => write!(f, "invalid input: {m}"),
            Error::InvalidMesh(m) => write!(f, "invalid tetrahedralization: {m}"),
            Error::TooLarge(m) => write!(f, "too large: {m}"),
            Error::InvalidOption(m) => write!(f, "invalid option: {m}"),
            Error::Gpu(m) => write!(f, "GPU: {m}"),
            Error::OutOfMemory { bytes, what } => write!(
                f,
                "cannot allocate {bytes} bytes ({:.3} GiB) for {what}",
                *bytes as f64 / (1u64 << 30) as f64
            ),
            Error::Interrupted => write!(f, "interrupted"),
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

/// A vector of `n` copies of `value`, or [`Error::OutOfMemory`] naming `what` and the bytes
/// asked for instead of aborting the process (outputs sized by the caller's ray count).
pub fn try_vec<T: Clone>(n: usize, value: T, what: &str) -> Result<Vec<T>> {
    let mut v = try_with_capacity(n, what)?;
    v.resize(n, value);
    Ok(v)
}

/// A vector of `n` zeros, or [`Error::OutOfMemory`] naming `what` and the bytes. The memory
/// comes zeroed from the allocator (calloc: a large block is fresh pages, zero from the OS,
/// touched first by whichever thread writes the answer there), where [`try_vec`] would write
/// every byte once on this thread before the cast writes it again.
pub fn try_zeroed_vec<T: bytemuck::Zeroable>(n: usize, what: &str) -> Result<Vec<T>> {
    bytemuck::allocation::try_zeroed_slice_box(n)
        .map(Vec::from)
        .map_err(|()| Error::OutOfMemory {
            bytes: n.saturating_mul(std::mem::size_of::<T>()),
            what: what.to_string(),
        })
}

/// An empty vector with room for `n`, or [`Error::OutOfMemory`] naming `what` and the bytes
/// (outputs whose length the caller's rays decide, filled by pushing).
pub fn try_with_capacity<T>(n: usize, what: &str) -> Result<Vec<T>> {
    let mut v = Vec::new();
    v.try_reserve_exact(n).map_err(|_| Error::OutOfMemory {
        bytes: n.saturating_mul(std::mem::size_of::<T>()),
        what: what.to_string(),
    })?;
    Ok(v)
}

pub type Result<T> = std::result::Result<T, Error>;
