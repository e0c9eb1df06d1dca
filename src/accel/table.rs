//! The accelerator table and the structure table. An accelerator that tests triangles is a row
//! type implementing [`Tested`]: its name and how it walks the structure it reads. A structure
//! (the BVH, the octree) is a type implementing [`Structure`]: how it is built from the
//! caller's triangles, its parameters and their defaults. `structure_table!` makes the scene's
//! caches ([`Structures`]: one slot each, built on first use) and the rule for what a move of
//! the scene's points keeps; `accel_table!` makes [`AccelKind`], the names Python lists
//! ([`ACCELS`]) and the dispatch ([`AccelKind::visit`]). A new accelerator is its file, a
//! `Tested` row type and one row; a new structure is one more row in `structure_table!`.

use super::exact_bvh::{ExactBvhAt, ExactBvhPackets};
use super::{Accel, BvhPackets, ExactBvh, PortalezOctree, ReshetovBvh};
use crate::error::{Error, Result};
use crate::simd::Simd;
use std::sync::{Arc, RwLock};

/// The caller's triangles, as structures are built from them.
pub type Triangles<'a> = &'a [[[f64; 3]; 3]];

/// A parameter's value, as the bindings show it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Param {
    F64(f64),
    U32(u32),
    Bool(bool),
}

/// A structure an accelerator reads, cached by the scene.
pub trait Structure: Sized + Send + Sync + 'static {
    /// Its name (`"bvh"`): the `memory()` entry and the key of its defaults.
    const NAME: &'static str;
    /// How it is built; `Default` is the core's defaults, which Python reads.
    type Params: Copy + Default + PartialEq + std::fmt::Debug + Send + Sync;
    fn build(triangles: Triangles, params: Self::Params) -> Result<Self>;
    fn params(&self) -> Self::Params;
    /// Bytes it holds.
    fn bytes(&self) -> usize;
    /// Its parameters by name.
    fn fields(params: &Self::Params) -> Vec<(&'static str, Param)>;
    /// Its slot among the scene's caches.
    fn slot(caches: &Structures) -> &Built<Self>;
}

/// A structure built on first use, or again with other parameters: casts hold the `Arc` they
/// started with, so a rebuild never changes a cast under way.
pub struct Built<T>(RwLock<Option<Arc<T>>>);

impl<T> Default for Built<T> {
    fn default() -> Self {
        Built(RwLock::new(None))
    }
}

impl<T> Built<T> {
    /// The one built last, if any.
    pub fn get(&self) -> Option<Arc<T>> {
        self.0.read().unwrap_or_else(|e| e.into_inner()).clone()
    }

    /// The one built last, else `build()`'s (kept).
    pub fn get_or_build(&self, build: impl FnOnce() -> Result<T>) -> Result<Arc<T>> {
        if let Some(b) = self.get() {
            return Ok(b);
        }
        let built = Arc::new(build()?);
        let mut slot = self.0.write().unwrap_or_else(|e| e.into_inner());
        Ok(slot.get_or_insert(built).clone())
    }

    /// Keeps `built` for what follows.
    pub fn set(&self, built: T) -> Result<Arc<T>> {
        let built = Arc::new(built);
        *self.0.write().unwrap_or_else(|e| e.into_inner()) = Some(built.clone());
        Ok(built)
    }

    /// The same structure, shared (a copy of the scene reads it until it is rebuilt).
    pub fn share(&self) -> Built<T> {
        Built(RwLock::new(self.get()))
    }
}

macro_rules! structure_table {
    ($($field:ident: $ty:ty),* $(,)?) => {
        /// The structures a scene caches for its accelerators, one slot each.
        #[derive(Default)]
        pub struct Structures {
            $(pub $field: Built<$ty>),*
        }

        $(impl Structure for $ty {
            const NAME: &'static str = stringify!($field);
            type Params = <$ty as StructureRow>::Params;
            fn build(triangles: Triangles, params: Self::Params) -> Result<Self> {
                <$ty as StructureRow>::build_row(triangles, params)
            }
            fn params(&self) -> Self::Params {
                self.params
            }
            fn bytes(&self) -> usize {
                <$ty as StructureRow>::bytes_row(self)
            }
            fn fields(params: &Self::Params) -> Vec<(&'static str, Param)> {
                <$ty as StructureRow>::fields_row(params)
            }
            fn slot(caches: &Structures) -> &Built<Self> {
                &caches.$field
            }
        })*

        /// The structures' names, in table order.
        pub const STRUCTURES: &[&str] = &[$(stringify!($field)),*];

        impl Structures {
            /// Bytes per structure (0 where none is built), by name.
            pub fn memory(&self) -> Vec<(String, usize)> {
                vec![$((
                    stringify!($field).to_string(),
                    self.$field.get().map_or(0, |s| Structure::bytes(&*s)),
                )),*]
            }

            /// The same structures, shared.
            pub fn share(&self) -> Structures {
                Structures { $($field: self.$field.share()),* }
            }

            /// What a move of the triangles keeps: a structure built with other than the
            /// default parameters is built again now over `triangles`, with the same ones; a
            /// default one is dropped and built again on first use.
            pub fn moved(&self, triangles: Triangles) -> Result<Structures> {
                let out = Structures::default();
                $(if let Some(p) = self.$field.get().map(|s| s.params) {
                    if p != Default::default() {
                        out.$field.set(<$ty as Structure>::build(triangles, p)?)?;
                    }
                })*
                Ok(out)
            }

            /// Each structure's default parameters, by name.
            pub fn defaults() -> Vec<(&'static str, Vec<(&'static str, Param)>)> {
                vec![$((
                    stringify!($field),
                    <$ty as Structure>::fields(&Default::default()),
                )),*]
            }
        }
    };
}

/// What a structure row supplies beyond the table (the table writes the rest).
pub trait StructureRow {
    type Params;
    fn build_row(triangles: Triangles, params: Self::Params) -> Result<Self>
    where
        Self: Sized;
    fn bytes_row(&self) -> usize;
    fn fields_row(params: &Self::Params) -> Vec<(&'static str, Param)>;
}

structure_table! {
    bvh: ReshetovBvh,
    octree: PortalezOctree,
    exact_bvh: ExactBvh,
}

impl StructureRow for ReshetovBvh {
    type Params = super::BvhParams;
    fn build_row(triangles: Triangles, params: Self::Params) -> Result<Self> {
        ReshetovBvh::build(triangles, params)
    }
    fn bytes_row(&self) -> usize {
        self.memory()
    }
    fn fields_row(p: &Self::Params) -> Vec<(&'static str, Param)> {
        vec![
            ("cost_ratio", Param::F64(p.cost_ratio)),
            ("max_leaf", Param::U32(p.max_leaf)),
            ("bins", Param::U32(p.bins)),
            ("aperture", Param::Bool(p.aperture)),
        ]
    }
}

impl StructureRow for ExactBvh {
    type Params = super::ExactBvhParams;
    fn build_row(triangles: Triangles, params: Self::Params) -> Result<Self> {
        ExactBvh::build(triangles, params)
    }
    fn bytes_row(&self) -> usize {
        self.memory()
    }
    fn fields_row(p: &Self::Params) -> Vec<(&'static str, Param)> {
        vec![
            ("cost_ratio", Param::F64(p.cost_ratio)),
            ("max_leaf", Param::U32(p.max_leaf)),
            ("bins", Param::U32(p.bins)),
            ("leaf_size", Param::U32(p.leaf_size)),
        ]
    }
}

impl StructureRow for PortalezOctree {
    type Params = super::OctreeParams;
    fn build_row(triangles: Triangles, params: Self::Params) -> Result<Self> {
        PortalezOctree::build(triangles, params)
    }
    fn bytes_row(&self) -> usize {
        self.memory().total
    }
    fn fields_row(p: &Self::Params) -> Vec<(&'static str, Param)> {
        vec![
            ("max_depth", Param::U32(p.max_depth)),
            ("leaf_size", Param::U32(p.leaf_size)),
            ("balance", Param::Bool(p.balance)),
        ]
    }
}

impl Structures {
    /// Structure S: the one built last, else one with the default parameters (built now over
    /// `triangles`).
    pub fn get<S: Structure>(&self, triangles: Triangles) -> Result<Arc<S>> {
        S::slot(self).get_or_build(|| S::build(triangles, S::Params::default()))
    }

    /// Builds structure S with `params` for what follows (casts running now keep the one they
    /// started with).
    pub fn build<S: Structure>(&self, triangles: Triangles, params: S::Params) -> Result<Arc<S>> {
        S::slot(self).set(S::build(triangles, params)?)
    }
}

/// Something to do with an accelerator that tests triangles, of any type.
pub trait AccelVisitor {
    type Out;
    fn visit<A: Accel<f64>>(self, accel: &A) -> Self::Out;
}

/// An accelerator that tests triangles, as a row of the table: its name, the structure it
/// reads and how it walks it (at SIMD level `simd`, where it has vector kernels).
pub trait Tested {
    const NAME: &'static str;
    type Over: Structure;
    fn walk<V: AccelVisitor>(over: &Self::Over, simd: Simd, v: V) -> V::Out;
}

/// Reshetov's BVH, one ray at a time.
pub struct OneRay;
impl Tested for OneRay {
    const NAME: &'static str = "reshetov_bvh";
    type Over = ReshetovBvh;
    fn walk<V: AccelVisitor>(bvh: &ReshetovBvh, _: Simd, v: V) -> V::Out {
        v.visit(bvh)
    }
}

/// The same tree walked by packets of 16 rays (4×4) with Reshetov's frustum vertex culling.
pub struct Packets16;
impl Tested for Packets16 {
    const NAME: &'static str = "reshetov_bvh_packets";
    type Over = ReshetovBvh;
    fn walk<V: AccelVisitor>(bvh: &ReshetovBvh, _: Simd, v: V) -> V::Out {
        v.visit(&BvhPackets { bvh, size: 16 })
    }
}

/// The same, 64 rays (8×8).
pub struct Packets64;
impl Tested for Packets64 {
    const NAME: &'static str = "reshetov_bvh_packets8";
    type Over = ReshetovBvh;
    fn walk<V: AccelVisitor>(bvh: &ReshetovBvh, _: Simd, v: V) -> V::Out {
        v.visit(&BvhPackets { bvh, size: 64 })
    }
}

/// Portalez & Duguet's neighbour-linked octree.
pub struct Octree;
impl Tested for Octree {
    const NAME: &'static str = "portalez_octree";
    type Over = PortalezOctree;
    fn walk<V: AccelVisitor>(octree: &PortalezOctree, _: Simd, v: V) -> V::Out {
        v.visit(octree)
    }
}

/// The exact 8-wide BVH, one ray at a time, its boxes tested eight at once.
pub struct Wide;
impl Tested for Wide {
    const NAME: &'static str = "exact_bvh";
    type Over = ExactBvh;
    fn walk<V: AccelVisitor>(bvh: &ExactBvh, simd: Simd, v: V) -> V::Out {
        v.visit(&ExactBvhAt { bvh, simd })
    }
}

/// The same tree walked by packets of up to 64 rays that share an origin.
pub struct WidePackets;
impl Tested for WidePackets {
    const NAME: &'static str = "exact_bvh_packets";
    type Over = ExactBvh;
    fn walk<V: AccelVisitor>(bvh: &ExactBvh, simd: Simd, v: V) -> V::Out {
        v.visit(&ExactBvhPackets { bvh, simd })
    }
}

macro_rules! accel_table {
    ($($variant:ident: $row:ty),* $(,)?) => {
        /// Which acceleration structure a cast runs: the tet walk through the constrained
        /// tetrahedralization (with the exit method and layout asked for; the default), or
        /// an accelerator that tests the caller's triangles.
        #[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
        pub enum AccelKind {
            #[default]
            TetWalk,
            $($variant),*
        }

        /// The acceleration structures there are, by name: the tet walk first (the default).
        pub const ACCELS: &[&str] = &["tetwalk", $(<$row as Tested>::NAME),*];

        impl AccelKind {
            pub const ALL: &'static [AccelKind] = &[AccelKind::TetWalk, $(AccelKind::$variant),*];

            /// Its name in [`ACCELS`].
            pub fn name(self) -> &'static str {
                match self {
                    AccelKind::TetWalk => "tetwalk",
                    $(AccelKind::$variant => <$row as Tested>::NAME),*
                }
            }

            /// Calls `v` with the accelerator over its structure from `caches` (built now over
            /// `triangles` with the defaults if none is), walking at SIMD level `simd`; None
            /// for the tet walk, which is not a triangle tester.
            pub fn visit<V: AccelVisitor>(
                self,
                caches: &Structures,
                triangles: Triangles,
                simd: Simd,
                v: V,
            ) -> Option<Result<V::Out>> {
                match self {
                    AccelKind::TetWalk => None,
                    $(AccelKind::$variant => Some(
                        caches
                            .get::<<$row as Tested>::Over>(triangles)
                            .map(|s| <$row as Tested>::walk(&*s, simd, v)),
                    )),*
                }
            }
        }
    };
}

accel_table! {
    ReshetovBvh: OneRay,
    ReshetovBvhPackets: Packets16,
    ReshetovBvhPackets8: Packets64,
    PortalezOctree: Octree,
    ExactBvh: Wide,
    ExactBvhPackets: WidePackets,
}

impl AccelKind {
    /// Whether it tests the caller's triangles (a BVH, the octree) rather than walking tets.
    pub fn tests_triangles(self) -> bool {
        self != AccelKind::TetWalk
    }

    /// The accelerator named `name`, or an error listing the known ones.
    pub fn from_name(name: &str) -> Result<AccelKind> {
        AccelKind::ALL
            .iter()
            .copied()
            .find(|a| a.name() == name)
            .ok_or_else(|| Error::unknown("accel", name, ACCELS))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::{BvhParams, ExactBvhParams, OctreeParams};
    use crate::testing::{random_scene, Rng};

    /// `memory` names every structure, with 0 bytes until it is built and then the bytes the
    /// structure itself reports; `build` keeps the parameters given; `fields` and `defaults`
    /// list each parameter under the name Python sets it by, with its value.
    #[test]
    fn the_table_reports_each_structure_and_its_parameters() {
        let (_, tris) = random_scene(&mut Rng::xorshift(3), 3, 0.3);
        let s = Structures::default();
        let none: Vec<(String, usize)> = STRUCTURES.iter().map(|n| (n.to_string(), 0)).collect();
        assert_eq!(s.memory(), none);
        let bvh = s.get::<ReshetovBvh>(&tris).unwrap();
        let octree = s.get::<PortalezOctree>(&tris).unwrap();
        let exact = s.get::<ExactBvh>(&tris).unwrap();
        let built = [
            ("bvh", bvh.memory()),
            ("octree", octree.memory().total),
            ("exact_bvh", exact.memory()),
        ];
        assert!(built.iter().all(|&(_, bytes)| bytes > 0), "{built:?}");
        let built: Vec<(String, usize)> = built.iter().map(|&(n, b)| (n.to_string(), b)).collect();
        assert_eq!(s.memory(), built);

        let bvh_params = BvhParams {
            cost_ratio: 2.5,
            max_leaf: 7,
            bins: 9,
            aperture: !BvhParams::default().aperture,
        };
        let octree_params = OctreeParams {
            max_depth: 5,
            leaf_size: 3,
            balance: !OctreeParams::default().balance,
        };
        let exact_params = ExactBvhParams {
            cost_ratio: 0.5,
            max_leaf: 6,
            bins: 11,
            leaf_size: 2,
        };
        assert_eq!(
            s.build::<ReshetovBvh>(&tris, bvh_params).unwrap().params(),
            bvh_params
        );
        assert_eq!(
            s.build::<PortalezOctree>(&tris, octree_params)
                .unwrap()
                .params(),
            octree_params
        );
        assert_eq!(
            s.build::<ExactBvh>(&tris, exact_params).unwrap().params(),
            exact_params
        );
        use Param::{Bool, F64, U32};
        let bvh_fields = |p: BvhParams| {
            vec![
                ("cost_ratio", F64(p.cost_ratio)),
                ("max_leaf", U32(p.max_leaf)),
                ("bins", U32(p.bins)),
                ("aperture", Bool(p.aperture)),
            ]
        };
        let octree_fields = |p: OctreeParams| {
            vec![
                ("max_depth", U32(p.max_depth)),
                ("leaf_size", U32(p.leaf_size)),
                ("balance", Bool(p.balance)),
            ]
        };
        let exact_fields = |p: ExactBvhParams| {
            vec![
                ("cost_ratio", F64(p.cost_ratio)),
                ("max_leaf", U32(p.max_leaf)),
                ("bins", U32(p.bins)),
                ("leaf_size", U32(p.leaf_size)),
            ]
        };
        assert_eq!(ReshetovBvh::fields(&bvh_params), bvh_fields(bvh_params));
        assert_eq!(
            PortalezOctree::fields(&octree_params),
            octree_fields(octree_params)
        );
        assert_eq!(ExactBvh::fields(&exact_params), exact_fields(exact_params));
        assert_eq!(
            Structures::defaults(),
            vec![
                ("bvh", bvh_fields(BvhParams::default())),
                ("octree", octree_fields(OctreeParams::default())),
                ("exact_bvh", exact_fields(ExactBvhParams::default())),
            ]
        );
    }
}
