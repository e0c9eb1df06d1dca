//! Benchmarks that live in the core (the exit-face micro-benchmark).

pub mod exitface;

pub use exitface::{cases, exitface, time_method, Case};
