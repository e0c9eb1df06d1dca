//! tetrace: ray casting through constrained tetrahedralizations.
//!
//! The core is plain Rust over slices; the Python bindings live in `py` only.

pub mod bench;
pub mod dispatch;
pub mod error;
#[cfg(feature = "gpu")]
pub mod gpu;
pub mod layout;
pub mod locate;
pub mod mesh;
pub mod real;
pub mod referee;
pub mod scene;
pub mod sort;
pub mod traverse;

#[cfg(feature = "python")]
mod py;

pub use error::{Error, Result};
pub use scene::{CastOptions, HitsOut, Rays, Scene, FAILED, HIT, INVALID, MISS};
