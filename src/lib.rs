//! tetrace: ray casting through constrained tetrahedralizations.
//!
//! The core is plain Rust over slices; the Python bindings live in `py` only. A ray goes
//! `scene::cast` → `accel` (the tet walk) → `locate` (start tet) → `traverse` (the walk, exit
//! method × `layout`) with a `query` policy deciding at constrained faces → the answer, written
//! to `scene::buffers`. docs/architecture.md has the map.

/// A count of some work done on this thread, kept in test builds only: tests read it to learn
/// that a piece of code ran, or which SIMD level's kernel did (answers alike by design cannot
/// tell). `test_count!(NAME, reader)` declares the thread-local and its reader; the counted code
/// adds with `test_count!(NAME += n)`, which compiles to nothing outside tests.
macro_rules! test_count {
    ($(#[$doc:meta])* $name:ident, $reader:ident) => {
        #[cfg(test)]
        thread_local! {
            static $name: std::cell::Cell<u64> = const { std::cell::Cell::new(0) };
        }
        $(#[$doc])*
        #[cfg(test)]
        pub fn $reader() -> u64 {
            $name.with(|c| c.get())
        }
    };
    ($($name:ident)::+ += $n:expr) => {
        #[cfg(test)]
        $($name)::+.with(|c| c.set(c.get() + $n as u64));
    };
}

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
