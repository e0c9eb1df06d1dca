//! Lagae & Dutré 2008: the plain tet, 4 vertex ids and 4 links (32 bytes). A step finds the
//! new vertex and the exit link by comparing ids.

use super::Layout;
use crate::error::Result;
use crate::mesh::{Link, TetMesh};

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PlainRecord {
    pub vertices: [u32; 4],
    /// `links[i]`: across the face opposite `vertices[i]`; constrained faces carry the flag bit.
    pub links: [Link; 4],
}

const _: () = assert!(std::mem::size_of::<PlainRecord>() == 32);

pub struct Plain {
    pub records: Vec<PlainRecord>,
}

impl Plain {
    #[inline(always)]
    fn record(&self, t: u32) -> &PlainRecord {
        debug_assert!((t as usize) < self.records.len());
        // SAFETY: the walk follows only links TetMesh::build validated as tet ids.
        unsafe { self.records.get_unchecked(t as usize) }
    }
}

impl Layout for Plain {
    const NAME: &'static str = "plain";
    const BYTES_PER_TET: usize = 32;

    fn build(mesh: &TetMesh) -> Result<Self> {
        let records = mesh
            .tets
            .iter()
            .zip(&mesh.links)
            .map(|(&vertices, &links)| PlainRecord { vertices, links })
            .collect();
        Ok(Plain { records })
    }

    #[inline(always)]
    fn new_vertex(&self, t: u32, a: u32, b: u32, c: u32) -> u32 {
        let v = self.record(t).vertices;
        // The one id that is none of the entry face's.
        let mut d = v[3];
        for &x in &v[..3] {
            if x != a && x != b && x != c {
                d = x;
            }
        }
        d
    }

    #[inline(always)]
    fn link_opposite(&self, t: u32, opposite: u32, _others: [u32; 3]) -> Link {
        let r = self.record(t);
        let i = (r.vertices[1] == opposite) as usize
            + 2 * (r.vertices[2] == opposite) as usize
            + 3 * (r.vertices[3] == opposite) as usize;
        r.links[i]
    }

    fn bytes(&self) -> usize {
        self.records.len() * Self::BYTES_PER_TET
    }
}
