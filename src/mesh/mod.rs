//! The tetrahedralization as the core sees it: oriented tets, face adjacency, constrained faces.

pub mod build;

pub use build::{Link, TetMesh, BOUNDARY};
