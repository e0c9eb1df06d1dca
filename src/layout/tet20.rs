//! Aman, Demirci & Güdükbay 2022, Tet20: 20 bytes per tet.
//!
//! The four vertex ids are stored as their xor: entering through a face whose three ids the
//! walk already holds, the fourth is `xor ^ a ^ b ^ c`, so one vertex is fetched per step.
//! The four links are stored in the order of the ids of the vertices opposite them, so the
//! slot of the face opposite vertex x is the rank of x among the tet's four ids.

use super::{links_by_rank, rank, Layout};
use crate::error::Result;
use crate::mesh::{Link, TetMesh};

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Tet20Record {
    pub vertex_xor: u32,
    /// `links[k]`: across the face opposite the vertex of rank k (smallest id first).
    pub links: [Link; 4],
}

const _: () = assert!(std::mem::size_of::<Tet20Record>() == 20);

pub struct Tet20 {
    pub records: Vec<Tet20Record>,
}

impl Tet20 {
    #[inline(always)]
    fn record(&self, t: u32) -> &Tet20Record {
        debug_assert!((t as usize) < self.records.len());
        // SAFETY: the walk only follows links that TetMesh::build checked to be tet ids of this
        // mesh (or BOUNDARY/constrained, which it never dereferences); the bounds check costs
        // a measurable share of a step that is a handful of instructions.
        unsafe { self.records.get_unchecked(t as usize) }
    }
}

impl Layout for Tet20 {
    const NAME: &'static str = "tet20";
    const BYTES_PER_TET: usize = 20;

    fn build(mesh: &TetMesh) -> Result<Self> {
        let records = mesh
            .tets
            .iter()
            .zip(&mesh.links)
            .map(|(tet, links)| Tet20Record {
                vertex_xor: tet[0] ^ tet[1] ^ tet[2] ^ tet[3],
                links: links_by_rank(tet, links),
            })
            .collect();
        Ok(Tet20 { records })
    }

    #[inline(always)]
    fn new_vertex(&self, t: u32, a: u32, b: u32, c: u32) -> u32 {
        self.record(t).vertex_xor ^ a ^ b ^ c
    }

    #[inline(always)]
    fn link_opposite(&self, t: u32, opposite: u32, others: [u32; 3]) -> Link {
        self.record(t).links[rank(opposite, others)]
    }

    fn bytes(&self) -> usize {
        self.records.len() * Self::BYTES_PER_TET
    }
}
