//! tetrace: ray casting through constrained tetrahedralizations.
//!
//! The core is plain Rust over slices; the Python bindings live in `py` only. A ray goes
//! `scene::cast` → `accel` (the tet walk) → `locate` (start tet) → `traverse` (the walk, exit
//! method × `layout`) with a `query` policy deciding at constrained faces → the answer, written
//! to `scene::buffers`. docs/architecture.md has the map.

pub mod accel;
pub mod bench;
pub mod camera;
pub mod error;
/// Stable-Rust fuzz targets (construction, the walk): `cargo test --features fuzz` runs them
/// bounded, `examples/fuzz.rs` long (docs/fuzzing.md). Not in the wheel.
#[cfg(feature = "fuzz")]
pub mod fuzz;
pub mod geom;
#[cfg(feature = "gpu")]
pub mod gpu;
pub mod layout;
pub mod locate;
pub mod mesh;
pub mod query;
pub mod referee;
pub mod rng;
pub mod scene;
pub mod simd;
pub mod status;
pub mod threads;
pub mod traverse;

#[cfg(test)]
pub(crate) mod testing;

// Tests of the crate as a whole (its file graph); the others sit beside their code.
#[cfg(test)]
mod tests;

#[cfg(feature = "python")]
mod py;

pub use error::{Error, Result};
pub use scene::{CastOptions, HitBuffers, HitsOut, Rays, Scene};
pub use status::{FAILED, HIT, INVALID, MISS};
