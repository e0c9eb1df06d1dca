//! How tets are stored for the walk. The walk loop is written once against [`Layout`]; each
//! layout decides how a step finds the new vertex and the link across the exit face.

pub mod tet20;

use crate::error::Result;
use crate::mesh::{Link, TetMesh};

pub use tet20::Tet20;

pub trait Layout: Sized + Sync + Send {
    const NAME: &'static str;
    /// Bytes per tet of the traversal record (points and the constrained table excluded).
    const BYTES_PER_TET: usize;

    fn build(mesh: &TetMesh) -> Result<Self>;

    /// The vertex of tet `t` that is not on the entry face (a, b, c).
    fn new_vertex(&self, t: u32, a: u32, b: u32, c: u32) -> u32;

    /// What lies across the face of tet `t` opposite its vertex `opposite`; `others` are the
    /// tet's other three vertices (in any order).
    fn link_opposite(&self, t: u32, opposite: u32, others: [u32; 3]) -> Link;

    fn bytes(&self) -> usize;
}
