//! Point location: which tet holds a ray's start point.

pub mod boundary;
pub mod grid;

pub use boundary::BoundaryLocator;
pub use grid::{GridLocator, Located};
