//! How tets are stored for the walk. The walk loop is written once against [`Layout`]; each
//! layout decides how a step finds the new vertex and the link across the exit face.
//!
//! | layout | bytes/tet | record | limit |
//! |---|---|---|---|
//! | plain (Lagae & Dutré 2008) | 32 | 4 vertex ids, 4 links | 2^31 - 2 tets |
//! | tet80 (Maria et al. 2017) | 80 | 4 float32 vertices inline, 4 faces (constrained id, neighbour 30 bits + face 2 bits) | 2^30 tets, float32 only |
//! | tet32 (Aman et al. 2022) | 32 | 3 vertex ids, xor of all 4, 4 links | 2^31 - 2 tets |
//! | tet20 (Aman et al. 2022) | 20 | xor of the 4 vertex ids, 4 links ordered by the opposite vertex's id | 2^31 - 2 tets |
//! | tet16 (ours, after Aman et al.) | 16 | xor, 4 links of 24 bits ordered as in tet20 | 2^23 - 2 tets and constrained sides |
//!
//! Links use one encoding everywhere (see [`crate::mesh::Link`]): a neighbour tet id, the
//! domain BOUNDARY, or CONSTRAINED_BIT | index into the mesh's constrained-side table.

pub mod plain;
pub mod tet16;
pub mod tet20;
pub mod tet32;
pub mod tet80;

use crate::error::{Error, Result};
use crate::mesh::{Link, TetMesh};
use std::sync::OnceLock;

pub use plain::Plain;
pub use tet16::Tet16;
pub use tet20::Tet20;
pub use tet32::Tet32;
pub use tet80::Tet80;

/// The layout table: one row per layout (its field in [`Layouts`] and its type), in the order
/// `tetrace.layouts()` lists them. Adding a layout is a row here plus its own file.
macro_rules! layout_table {
    ($($field:ident: $ty:ident),* $(,)?) => {
        /// A layout, as Python names it.
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
        pub enum LayoutKind {
            $($ty),*
        }

        /// The names `tetrace.layouts()` lists, in the order of the table.
        pub const LAYOUTS: &[&str] = &[$(<$ty as Layout>::NAME),*];

        impl LayoutKind {
            pub const ALL: &'static [LayoutKind] = &[$(LayoutKind::$ty),*];

            pub fn name(self) -> &'static str {
                match self {
                    $(LayoutKind::$ty => <$ty as Layout>::NAME),*
                }
            }

            pub fn bytes_per_tet(self) -> usize {
                match self {
                    $(LayoutKind::$ty => <$ty as Layout>::BYTES_PER_TET),*
                }
            }
        }

        /// The traversal layouts of a scene, each built the first time a cast asks for it.
        #[derive(Default)]
        pub struct Layouts {
            $(pub $field: OnceLock<Result<$ty>>),*
        }

        impl Layouts {
            /// Bytes of the records of each layout built so far.
            pub fn built(&self) -> Vec<(&'static str, usize)> {
                let mut out = Vec::new();
                $(if let Some(Ok(l)) = self.$field.get() {
                    out.push((<$ty as Layout>::NAME, l.bytes()));
                })*
                out
            }

            /// Drops the layouts whose records hold vertex positions ([`Layout::INLINE`]), so
            /// that they are built again, on the moved points, by their next use; the others
            /// hold topology only and stay.
            pub fn forget_points(&mut self) {
                $(if <$ty as Layout>::INLINE {
                    self.$field = OnceLock::new();
                })*
            }

            /// Calls `v` with layout `kind` of `mesh`, built now if it was not yet.
            pub fn visit<V: LayoutVisitor>(&self, kind: LayoutKind, mesh: &TetMesh, v: V) -> Result<V::Out> {
                match kind {
                    $(LayoutKind::$ty => Ok(v.visit(get(&self.$field, mesh)?))),*
                }
            }
        }
    };
}

layout_table! {
    plain: Plain,
    tet80: Tet80,
    tet32: Tet32,
    tet20: Tet20,
    tet16: Tet16,
}

impl LayoutKind {
    /// The default: Aman et al.'s 20-byte record. The exact walk takes as many instructions
    /// per ray on it as on tet32 (bunny camera, callgrind) and reads 12 bytes less per tet,
    /// with no limit tet16's 24-bit links would put on large scenes; the GPU kernels use it
    /// too.
    pub const DEFAULT: LayoutKind = LayoutKind::Tet20;

    /// The layout named `name`, or an error listing the known ones.
    pub fn from_name(name: &str) -> Result<LayoutKind> {
        LayoutKind::ALL
            .iter()
            .copied()
            .find(|k| k.name() == name)
            .ok_or_else(|| Error::unknown("layout", name, LAYOUTS))
    }
}

impl Layouts {
    /// Builds a layout now (so its cost is not paid by the first cast, and its errors show);
    /// returns its bytes.
    pub fn prepare(&self, kind: LayoutKind, mesh: &TetMesh) -> Result<usize> {
        struct Bytes;
        impl LayoutVisitor for Bytes {
            type Out = usize;
            fn visit<L: Layout>(self, layout: &L) -> usize {
                layout.bytes()
            }
        }
        self.visit(kind, mesh, Bytes)
    }
}

/// Something to do with a layout of any type: [`Layouts::visit`] calls it with the one a
/// [`LayoutKind`] names (monomorphized per layout).
pub trait LayoutVisitor {
    type Out;
    fn visit<L: Layout>(self, layout: &L) -> Self::Out;
}

pub fn get<'a, L: Layout>(cell: &'a OnceLock<Result<L>>, mesh: &TetMesh) -> Result<&'a L> {
    cell.get_or_init(|| L::build(mesh))
        .as_ref()
        .map_err(Clone::clone)
}

pub trait Layout: Sized + Sync + Send {
    const NAME: &'static str;
    /// Bytes per tet of the traversal record (points and the constrained table excluded).
    const BYTES_PER_TET: usize;
    /// Vertex positions live in the records (Maria's Tet80) and the walk names the entry face
    /// by its local index in the tet, not by vertex ids: it uses [`Layout::inline_vertices`] and
    /// [`Layout::inline_face`] instead of the id-based pair.
    const INLINE: bool = false;

    fn build(mesh: &TetMesh) -> Result<Self>;

    /// The vertex of tet `t` that is not on the entry face (a, b, c).
    fn new_vertex(&self, t: u32, a: u32, b: u32, c: u32) -> u32;

    /// What lies across the face of tet `t` opposite its vertex `opposite`; `others` are the
    /// tet's other three vertices (in any order).
    fn link_opposite(&self, t: u32, opposite: u32, others: [u32; 3]) -> Link;

    /// INLINE layouts: the four vertices of tet t, in the order of `TetMesh::tets`.
    fn inline_vertices(&self, _t: u32) -> [[f32; 3]; 4] {
        [[0.0; 3]; 4]
    }

    /// INLINE layouts: what lies across face `i` (opposite vertex i) of tet t, and the index
    /// of the same face in the neighbour.
    fn inline_face(&self, _t: u32, _i: usize) -> (Link, usize) {
        (crate::mesh::BOUNDARY, 0)
    }

    fn bytes(&self) -> usize;

    /// Asks the cache for tet t's record ahead of its use (the lanes' walk: by the time the
    /// other lanes have stepped, the record has arrived). A hint only.
    #[inline(always)]
    fn prefetch(&self, _t: u32) {}
}

/// Asks the cache for the line holding `*p` (no-op where there is no prefetch instruction).
#[inline(always)]
pub fn prefetch<T>(p: *const T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch is a hint: it never faults, whatever the address.
    unsafe {
        std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(p as *const i8)
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = p;
}

/// The slot (0..4) of each tet's vertex `v`: used by layouts that store per-slot data.
#[inline(always)]
pub(crate) fn rank(x: u32, others: [u32; 3]) -> usize {
    (others[0] < x) as usize + (others[1] < x) as usize + (others[2] < x) as usize
}

/// Links of a tet reordered by the rank of the opposite vertex's id (Tet20, Tet16).
pub(crate) fn links_by_rank(tet: &[u32; 4], links: &[Link; 4]) -> [Link; 4] {
    let mut out = [0; 4];
    for i in 0..4 {
        let others = [tet[(i + 1) % 4], tet[(i + 2) % 4], tet[(i + 3) % 4]];
        out[rank(tet[i], others)] = links[i];
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::mem::size_of;

    #[test]
    fn record_sizes_are_as_designed() {
        assert_eq!(
            (Plain::BYTES_PER_TET, size_of::<plain::PlainRecord>()),
            (32, 32)
        );
        assert_eq!(
            (Tet80::BYTES_PER_TET, size_of::<tet80::Tet80Record>()),
            (80, 80)
        );
        assert_eq!(
            (Tet32::BYTES_PER_TET, size_of::<tet32::Tet32Record>()),
            (32, 32)
        );
        assert_eq!(
            (Tet20::BYTES_PER_TET, size_of::<tet20::Tet20Record>()),
            (20, 20)
        );
        assert_eq!(
            (Tet16::BYTES_PER_TET, size_of::<tet16::Tet16Record>()),
            (16, 16)
        );
        assert_eq!(LAYOUTS, ["plain", "tet80", "tet32", "tet20", "tet16"]);
    }

    /// Every layout answers the same questions the same way on a real mesh.
    #[test]
    fn layouts_agree_with_the_topology() {
        let mut rng = crate::testing::Rng::xorshift(17);
        let (p, t) = crate::testing::kuhn_grid(3, 0.3, &mut rng);
        let m = TetMesh::build(p, &t, &[], &[]).unwrap();
        let (plain, t32, t20, t16, t80) = (
            Plain::build(&m).unwrap(),
            Tet32::build(&m).unwrap(),
            Tet20::build(&m).unwrap(),
            Tet16::build(&m).unwrap(),
            Tet80::build(&m).unwrap(),
        );
        for (ti, tet) in m.tets.iter().enumerate() {
            let ti = ti as u32;
            for i in 0..4 {
                let others = [tet[(i + 1) % 4], tet[(i + 2) % 4], tet[(i + 3) % 4]];
                let want = m.links[ti as usize][i];
                for (name, got) in [
                    ("plain", plain.link_opposite(ti, tet[i], others)),
                    ("tet32", t32.link_opposite(ti, tet[i], others)),
                    ("tet20", t20.link_opposite(ti, tet[i], others)),
                    ("tet16", t16.link_opposite(ti, tet[i], others)),
                    ("tet80", t80.inline_face(ti, i).0),
                ] {
                    assert_eq!(got, want, "{name}: tet {ti} face {i}");
                }
                for (name, got) in [
                    (
                        "plain",
                        plain.new_vertex(ti, others[0], others[1], others[2]),
                    ),
                    ("tet32", t32.new_vertex(ti, others[0], others[1], others[2])),
                    ("tet20", t20.new_vertex(ti, others[0], others[1], others[2])),
                    ("tet16", t16.new_vertex(ti, others[0], others[1], others[2])),
                ] {
                    assert_eq!(got, tet[i], "{name}: new vertex of tet {ti}");
                }
                // Tet80: the neighbour's face index names the same three vertices.
                let (n, j) = t80.inline_face(ti, i);
                if n != crate::mesh::BOUNDARY {
                    let back = m.tets[n as usize];
                    let mut a: Vec<u32> = (0..4).filter(|&k| k != j).map(|k| back[k]).collect();
                    let mut b = others.to_vec();
                    a.sort();
                    b.sort();
                    assert_eq!(a, b, "tet80: tet {ti} face {i} -> tet {n} face {j}");
                }
            }
        }
    }
}
