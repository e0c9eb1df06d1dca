//! Aman, Demirci & Güdükbay 2022, Tet32: the first three vertex ids, the xor of all four, and
//! four links (32 bytes). The new vertex comes from the xor; the exit link's slot from
//! comparing the opposite vertex with the three stored ids (Algorithm 3).

use super::Layout;
use crate::error::Result;
use crate::mesh::{Link, TetMesh};

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Tet32Record {
    pub vertices: [u32; 3],
    pub vertex_xor: u32,
    /// `links[i]`: across the face opposite vertex i (vertex 3 = xor ^ v0 ^ v1 ^ v2).
    pub links: [Link; 4],
}

const _: () = assert!(std::mem::size_of::<Tet32Record>() == 32);

pub struct Tet32 {
    pub records: Vec<Tet32Record>,
}

impl Tet32 {
    #[inline(always)]
    fn record(&self, t: u32) -> &Tet32Record {
        debug_assert!((t as usize) < self.records.len());
        // SAFETY: the walk follows only links TetMesh::build validated as tet ids.
        unsafe { self.records.get_unchecked(t as usize) }
    }
}

impl Layout for Tet32 {
    const NAME: &'static str = "tet32";
    const BYTES_PER_TET: usize = 32;

    fn build(mesh: &TetMesh) -> Result<Self> {
        let records = mesh
            .tets
            .iter()
            .zip(&mesh.links)
            .map(|(t, &links)| Tet32Record {
                vertices: [t[0], t[1], t[2]],
                vertex_xor: t[0] ^ t[1] ^ t[2] ^ t[3],
                links,
            })
            .collect();
        Ok(Tet32 { records })
    }

    #[inline(always)]
    fn new_vertex(&self, t: u32, a: u32, b: u32, c: u32) -> u32 {
        self.record(t).vertex_xor ^ a ^ b ^ c
    }

    #[inline(always)]
    fn link_opposite(&self, t: u32, opposite: u32, _others: [u32; 3]) -> Link {
        let r = self.record(t);
        let v = r.vertices;
        let i = if v[0] == opposite {
            0
        } else if v[1] == opposite {
            1
        } else if v[2] == opposite {
            2
        } else {
            3
        };
        r.links[i]
    }

    #[inline(always)]
    fn prefetch(&self, t: u32) {
        // wrapping: a boundary or constrained link is no tet, and prefetching it is harmless.
        super::prefetch(self.records.as_ptr().wrapping_add(t as usize));
    }

    fn bytes(&self) -> usize {
        self.records.len() * Self::BYTES_PER_TET
    }
}
