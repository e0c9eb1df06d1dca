//! Maria, Horna & Aveneau 2017: the 80-byte tet. Four float32 vertices inline (48 bytes) and
//! four faces of 8 bytes: the constrained side's index (Maria's `brdf`, -1 when the face is
//! not a scene triangle) and the neighbour tet in 30 bits with, in 2 bits, the index of the
//! same face in the neighbour. A step reads one record: no vertex ids, no point array.
//!
//! Positions are float32, as on their GPU: this layout serves the f32 walk only, and holds at
//! most 2^30 - 1 tets (30-bit ids); `build` refuses larger meshes.

use super::Layout;
use crate::error::{Error, Result};
use crate::mesh::build::{CONSTRAINED_BIT, OUTWARD_FACES};
use crate::mesh::{Link, TetMesh, BOUNDARY};

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Tet80Face {
    /// Index into the constrained-side table, or u32::MAX (Maria's -1) for a free face.
    pub constrained: u32,
    /// neighbour << 2 | face index in the neighbour; u32::MAX on the domain boundary.
    pub neighbor: u32,
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Tet80Record {
    pub vertices: [[f32; 3]; 4],
    /// `faces[i]`: the face opposite vertex i.
    pub faces: [Tet80Face; 4],
}

const _: () = assert!(std::mem::size_of::<Tet80Record>() == 80);

pub const MAX_TETS: usize = 1 << 30;

pub struct Tet80 {
    pub records: Vec<Tet80Record>,
}

impl Tet80 {
    #[inline(always)]
    fn record(&self, t: u32) -> &Tet80Record {
        debug_assert!((t as usize) < self.records.len());
        // SAFETY: the walk follows only neighbours TetMesh::build validated as tet ids.
        unsafe { self.records.get_unchecked(t as usize) }
    }
}

impl Layout for Tet80 {
    const NAME: &'static str = "tet80";
    const BYTES_PER_TET: usize = 80;
    const INLINE: bool = true;

    fn build(mesh: &TetMesh) -> Result<Self> {
        if mesh.len() >= MAX_TETS {
            return Err(Error::TooLarge(format!(
                "tet80 stores neighbours in 30 bits: at most {} tets, this mesh has {}; use tet20",
                MAX_TETS - 1,
                mesh.len()
            )));
        }
        let records = (0..mesh.len())
            .map(|t| {
                let tet = mesh.tets[t];
                let mut r = Tet80Record {
                    vertices: tet.map(|v| mesh.points[v as usize].map(|x| x as f32)),
                    faces: [Tet80Face::default(); 4],
                };
                for (i, &l) in mesh.links[t].iter().enumerate() {
                    let (constrained, beyond) = if l != BOUNDARY && l & CONSTRAINED_BIT != 0 {
                        let c = l & !CONSTRAINED_BIT;
                        (c, mesh.constrained[c as usize].beyond)
                    } else {
                        (u32::MAX, l)
                    };
                    let neighbor = if beyond == BOUNDARY {
                        u32::MAX
                    } else {
                        // The same face in the neighbour: the one whose vertex set matches.
                        let f = OUTWARD_FACES[i].map(|k| tet[k]);
                        let other = mesh.tets[beyond as usize];
                        let j = (0..4).find(|&j| !f.contains(&other[j])).unwrap_or(0);
                        beyond << 2 | j as u32
                    };
                    r.faces[i] = Tet80Face {
                        constrained,
                        neighbor,
                    };
                }
                r
            })
            .collect();
        Ok(Tet80 { records })
    }

    fn new_vertex(&self, _t: u32, _a: u32, _b: u32, _c: u32) -> u32 {
        u32::MAX // INLINE: the walk does not name vertices by id
    }

    fn link_opposite(&self, _t: u32, _opposite: u32, _others: [u32; 3]) -> Link {
        BOUNDARY // INLINE: the walk uses inline_face
    }

    #[inline(always)]
    fn inline_vertices(&self, t: u32) -> [[f32; 3]; 4] {
        self.record(t).vertices
    }

    #[inline(always)]
    fn inline_face(&self, t: u32, i: usize) -> (Link, usize) {
        let f = self.record(t).faces[i];
        if f.constrained != u32::MAX {
            // The face index beyond rides along: a query may walk on through the face.
            (CONSTRAINED_BIT | f.constrained, (f.neighbor & 3) as usize)
        } else if f.neighbor == u32::MAX {
            (BOUNDARY, 0)
        } else {
            (f.neighbor >> 2, (f.neighbor & 3) as usize)
        }
    }

    fn bytes(&self) -> usize {
        self.records.len() * Self::BYTES_PER_TET
    }
}
