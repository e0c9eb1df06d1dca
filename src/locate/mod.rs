//! Point location: which tet holds a ray's start point.

pub mod boundary;
pub mod grid;
pub mod start;

pub use boundary::BoundaryLocator;
pub use grid::{GridLocator, Located};
pub use start::{ExactOrigin, LocateState, Locators, Start, WalkStart, GRAZES};
