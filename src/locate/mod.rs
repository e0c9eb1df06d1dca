//! Point location: which tet holds a ray's start point.

pub mod grid;

pub use grid::{GridLocator, Located};
