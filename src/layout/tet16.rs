//! Tet16: 16 bytes per tet, our design after Aman et al. 2022 (whose appendix with their Tet16
//! is not in our copy of the paper). The xor of the vertex ids as in Tet20, then the four links
//! in 24 bits each, packed into three words, in the rank order of Tet20.
//!
//! A 24-bit link is the Link encoding narrowed: 0xFFFFFF is the domain boundary, bit 23 marks
//! a constrained face (the rest indexes the constrained-side table), else a tet id. So this
//! layout holds at most 2^23 - 1 tets and 2^23 - 1 constrained sides; `build` refuses larger
//! meshes with an error naming the limit instead of wrapping ids.

use super::{links_by_rank, rank, Layout};
use crate::error::{Error, Result};
use crate::mesh::build::CONSTRAINED_BIT;
use crate::mesh::{Link, TetMesh, BOUNDARY};

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Tet16Record {
    pub vertex_xor: u32,
    /// Four 24-bit links, little end first: link k occupies bits 24k..24k+24 of the 96.
    pub packed: [u32; 3],
}

const _: () = assert!(std::mem::size_of::<Tet16Record>() == 16);

const NARROW_BOUNDARY: u32 = 0xFF_FFFF;
const NARROW_CONSTRAINED: u32 = 1 << 23;
/// Largest tet id or constrained index a 24-bit link can hold.
pub const MAX_ID: u32 = NARROW_CONSTRAINED - 2;

pub struct Tet16 {
    pub records: Vec<Tet16Record>,
}

fn narrow(l: Link) -> Option<u32> {
    if l == BOUNDARY {
        Some(NARROW_BOUNDARY)
    } else if l & CONSTRAINED_BIT != 0 {
        let i = l & !CONSTRAINED_BIT;
        (i <= MAX_ID).then_some(NARROW_CONSTRAINED | i)
    } else {
        (l <= MAX_ID).then_some(l)
    }
}

#[inline(always)]
fn widen(n: u32) -> Link {
    if n == NARROW_BOUNDARY {
        BOUNDARY
    } else if n & NARROW_CONSTRAINED != 0 {
        CONSTRAINED_BIT | (n & !NARROW_CONSTRAINED)
    } else {
        n
    }
}

impl Tet16 {
    #[inline(always)]
    fn record(&self, t: u32) -> &Tet16Record {
        debug_assert!((t as usize) < self.records.len());
        // SAFETY: the walk follows only links TetMesh::build validated as tet ids.
        unsafe { self.records.get_unchecked(t as usize) }
    }

    /// Link k (0..4) of a record.
    #[inline(always)]
    pub fn link(r: &Tet16Record, k: usize) -> Link {
        let bits =
            (r.packed[0] as u128) | (r.packed[1] as u128) << 32 | (r.packed[2] as u128) << 64;
        widen(((bits >> (24 * k)) & 0xFF_FFFF) as u32)
    }
}

impl Layout for Tet16 {
    const NAME: &'static str = "tet16";
    const BYTES_PER_TET: usize = 16;

    fn build(mesh: &TetMesh) -> Result<Self> {
        if mesh.len() > MAX_ID as usize + 1 || mesh.constrained.len() > MAX_ID as usize + 1 {
            return Err(Error::TooLarge(format!(
                "tet16 links have 24 bits: at most {} tets and constrained sides, this mesh has {} \
                 tets and {} constrained sides; use tet20",
                MAX_ID + 1,
                mesh.len(),
                mesh.constrained.len()
            )));
        }
        let records = mesh
            .tets
            .iter()
            .zip(&mesh.links)
            .map(|(tet, links)| {
                let mut bits = 0u128;
                for (k, &l) in links_by_rank(tet, links).iter().enumerate() {
                    // In range: checked above.
                    bits |= (narrow(l).unwrap_or(NARROW_BOUNDARY) as u128) << (24 * k);
                }
                Tet16Record {
                    vertex_xor: tet[0] ^ tet[1] ^ tet[2] ^ tet[3],
                    packed: [bits as u32, (bits >> 32) as u32, (bits >> 64) as u32],
                }
            })
            .collect();
        Ok(Tet16 { records })
    }

    #[inline(always)]
    fn new_vertex(&self, t: u32, a: u32, b: u32, c: u32) -> u32 {
        self.record(t).vertex_xor ^ a ^ b ^ c
    }

    #[inline(always)]
    fn link_opposite(&self, t: u32, opposite: u32, others: [u32; 3]) -> Link {
        Self::link(self.record(t), rank(opposite, others))
    }

    fn bytes(&self) -> usize {
        self.records.len() * Self::BYTES_PER_TET
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn narrow_links_round_trip() {
        for l in [
            0,
            1,
            12345,
            MAX_ID,
            BOUNDARY,
            CONSTRAINED_BIT,
            CONSTRAINED_BIT | MAX_ID,
        ] {
            assert_eq!(widen(narrow(l).unwrap()), l);
        }
        assert_eq!(narrow(MAX_ID + 1), None);
        assert_eq!(narrow(CONSTRAINED_BIT | (MAX_ID + 1)), None);
    }
}
