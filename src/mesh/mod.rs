//! The tetrahedralization as the core sees it: oriented tets, face adjacency, constrained faces,
//! the Hilbert order the walk reads them in, and the caller's triangles hits are evaluated on.

pub mod build;
pub mod hilbert;
pub mod incidence;
pub mod kuhn;
pub mod surface;

pub use build::{Link, TetMesh, BOUNDARY};
pub use incidence::{Incidence, SurfaceFace};
pub use surface::{Alternatives, Surface};
