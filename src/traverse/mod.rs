//! The walk from tet to tet, written once. An [`ExitMethod`] decides which face a ray leaves a
//! tet by; a [`Layout`] says what lies across it. Every method here works on the same
//! invariant: the ray enters the current tet through face (a, b, c), ordered so that seen along
//! the ray it turns counter-clockwise around the ray; the new vertex d then makes three
//! candidate exit faces (a,b,d), (b,c,d), (c,a,d), each already in that order for the next tet.

pub mod aman2022;
pub mod exact;
pub mod lagae2008_halfspace;
pub mod lagae2008_plane;
pub mod lagae2008_plucker;
pub mod lagae2008_stp;
pub mod maria2017;
pub mod ms06;
pub mod packet;
pub mod robust;
pub mod walk;

use crate::error::{Error, Result};
use crate::geom::real::{Real, V3};

pub use aman2022::Aman2022;
pub use exact::Exact;
pub use lagae2008_halfspace::Lagae2008Halfspace;
pub use lagae2008_plane::Lagae2008Plane;
pub use lagae2008_plucker::Lagae2008Plucker;
pub use lagae2008_stp::Lagae2008Stp;
pub use maria2017::Maria2017;
pub use ms06::Ms06;
pub use robust::Robust;
pub use walk::{
    entry_face, plain_step, walk, walk_begin, walk_resume, walk_with, Touch, Walk, WalkEnd,
    WalkSetup, WalkState,
};

/// Which of the three candidate faces a ray leaves by (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Exit {
    /// (a, b, d): the face opposite c.
    Abd,
    /// (b, c, d): the face opposite a.
    Bcd,
    /// (c, a, d): the face opposite b.
    Cad,
}

impl Exit {
    /// By rotation of the entry face (a, b, c): the exit face keeps (a, b), (b, c) or (c, a).
    pub const ROTATIONS: [Exit; 3] = [Exit::Abd, Exit::Bcd, Exit::Cad];
}

/// Where the exact line meets a face the walk leaves by (or, at the start, where the ray's
/// origin lies): what a method with exact contacts reports besides the exit face. Indices are
/// 0..3 into the face's vertices (a, b, c); edge k is (k, k+1 mod 3).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Contact {
    /// Through the face's interior (nothing to report).
    Interior,
    /// Through vertex k of the face.
    Vertex(u8),
    /// Through the interior of edge k.
    Edge(u8),
    /// The line lies in the face's plane; it meets the face's boundary at the vertices in the
    /// bit mask `vertices` and in the interiors of the edges in `edges` (in no order along it).
    Coplanar { vertices: u8, edges: u8 },
    /// The ray's origin, at the start of the walk in tet `Touch::tet` (t = 0): the query
    /// checks the caller's triangles around it.
    Origin,
}

pub trait ExitMethod<R: Real> {
    const NAME: &'static str;
    /// The walk follows a symbolically perturbed line starting at s + εδ (the robust walk):
    /// the start tet must be the one holding that point (`robust::settle_start`).
    const PERTURBED_START: bool = false;
    /// The walk follows the ray's own line (o, d) exactly and reports where it touches the
    /// vertices and edges of exit faces ([`Contact`]); it starts at the origin itself or, from
    /// outside, at the exact entry face (`locate::Locators::locate_exact`).
    const CONTACTS: bool = false;
    /// The exit is the one the exact sides of the ray's line name (`Exact`), and `enters` is
    /// the exact crossing of that line: rays sharing an origin may walk as a packet
    /// (`packet`), with the line given by [`ExitMethod::line`], and may take the last ray's
    /// entry face when their sides on its edges are the same (`locate::start::EnteredFace`).
    const PACKETS: bool = false;
    /// Per-ray data computed once (e.g. a basis).
    type Ray: Copy;
    /// Per-vertex data computed once per fetched vertex (e.g. its 2D projection).
    type Vert: Copy;

    /// `origin` is the point the walk starts from (inside the start tet); `dir` need not be
    /// normalized; `domain` is the box ([min, max]) holding every vertex the walk will read,
    /// which methods with error bounds (the robust walk) use to bound their rounding.
    fn prepare(origin: V3<f64>, dir: V3<f64>, domain: &[V3<f64>; 2]) -> Self::Ray;
    fn vertex(ray: &Self::Ray, p: V3<R>) -> Self::Vert;
    /// The line the exact sides are taken on, (origin, direction), for methods with `PACKETS`.
    fn line(_ray: &Self::Ray) -> (V3<f64>, V3<f64>) {
        unreachable!("only methods with PACKETS walk packets")
    }
    /// `prepare(line(ray).0, dir, domain)` for a ray prepared from the same origin and
    /// domain: what depends on the origin alone is copied (packets prepare many rays from one
    /// origin). Methods with `PACKETS`.
    fn redirect(ray: &Self::Ray, dir: V3<f64>, domain: &[V3<f64>; 2]) -> Self::Ray {
        Self::prepare(Self::line(ray).0, dir, domain)
    }
    /// The face (index i of OUTWARD_FACES, opposite vertex i) by which the ray leaves the start
    /// tet, whose four vertices (data `v`, positions `p`) are given in positive orientation.
    fn start_exit(ray: &Self::Ray, v: &[Self::Vert; 4], p: &[V3<R>; 4]) -> usize;
    /// The exit face of a tet entered through (a, b, c) whose fourth vertex is d, or None
    /// when the vertex data cannot decide it (a filter found the float result uncertain): the
    /// walk then reads the positions and calls [`ExitMethod::step_exact`].
    fn step(
        ray: &Self::Ray,
        a: &Self::Vert,
        b: &Self::Vert,
        c: &Self::Vert,
        d: &Self::Vert,
    ) -> Option<Exit>;
    /// `step` where its answer is all a walk step needs (`walk::plain_step`, the lanes' step):
    /// for methods with contacts only when, besides, the exit face's edges are certain, so the
    /// walk cannot touch it. Given an entry face whose edges are all certain, a methods with
    /// contacts must return Some only when the new exit face's are too. None: the full step.
    #[inline(always)]
    fn step_plain(
        ray: &Self::Ray,
        a: &Self::Vert,
        b: &Self::Vert,
        c: &Self::Vert,
        d: &Self::Vert,
    ) -> Option<Exit> {
        if Self::CONTACTS {
            None
        } else {
            Self::step(ray, a, b, c, d)
        }
    }
    /// The exit face from the positions of a, b, c, d. Only methods whose `step` can return
    /// None need to provide it; for the others it is `step` on the same data.
    fn step_exact(ray: &Self::Ray, p: &[V3<R>; 4]) -> Exit {
        let v = p.map(|x| Self::vertex(ray, x));
        Self::step(ray, &v[0], &v[1], &v[2], &v[3]).unwrap_or(Exit::Bcd)
    }
    /// Whether the method's own tests named the face `step` returns, rather than a fallback
    /// choosing one when rounding made every test fail ("no exit face found"). Decision-tree
    /// methods always name one. Only the audit asks.
    fn exit_found(
        _ray: &Self::Ray,
        _a: &Self::Vert,
        _b: &Self::Vert,
        _c: &Self::Vert,
        _d: &Self::Vert,
    ) -> bool {
        true
    }
    /// Whether the line may pass through the boundary of the exit face (a, b, c) (vertex data
    /// only; methods with CONTACTS): false when every edge's side is certain.
    #[inline(always)]
    fn may_touch(_ray: &Self::Ray, _a: &Self::Vert, _b: &Self::Vert, _c: &Self::Vert) -> bool {
        false
    }
    /// Whether the line enters a tet through `face` (positions in the tet's outward order):
    /// the exact start's test of a boundary face (methods with CONTACTS).
    fn enters(_ray: &Self::Ray, _face: &[V3<R>; 3]) -> bool {
        false
    }
    /// Where the line meets the exit face (positions a, b, c; `w` is the tet's fourth vertex,
    /// off the face's plane). Exact; called only when `may_touch`.
    fn contact(_ray: &Self::Ray, _face: &[V3<R>; 3], _w: V3<R>) -> Contact {
        Contact::Interior
    }
}

/// The full decision for one step, as the walk makes it: `step`, else `step_exact`.
#[inline(always)]
pub fn decide<R: Real, M: ExitMethod<R>>(ray: &M::Ray, p: &[V3<R>; 4]) -> Exit {
    let v = p.map(|x| M::vertex(ray, x));
    M::step(ray, &v[0], &v[1], &v[2], &v[3]).unwrap_or_else(|| M::step_exact(ray, p))
}

/// Sees each exit face a walk takes (the audit of `tetrace.stress`); the walk's hot loop calls
/// it only when `ACTIVE`, so the plain walk compiles as if it did not exist.
pub trait WalkObserver<R: Real> {
    const ACTIVE: bool;
    /// A fresh observer for one ray's walk from `start` along `dir` in the box `domain`.
    fn for_ray(start: V3<f64>, dir: V3<f64>, domain: &[V3<f64>; 2]) -> Self;
    /// The face the walk leaves a tet by, counter-clockwise around the ray, and whether the
    /// method's tests found it (see [`ExitMethod::exit_found`]).
    fn exit(&mut self, face: [V3<R>; 3], found: bool);
    /// What it counted: exit faces the exact predicates reject, steps with no exit face found.
    fn counts(&self) -> [u32; 2];
}

/// The plain walk's observer: nothing.
pub struct NoObserver;

impl<R: Real> WalkObserver<R> for NoObserver {
    const ACTIVE: bool = false;
    #[inline(always)]
    fn for_ray(_: V3<f64>, _: V3<f64>, _: &[V3<f64>; 2]) -> Self {
        NoObserver
    }
    #[inline(always)]
    fn exit(&mut self, _face: [V3<R>; 3], _found: bool) {}
    #[inline(always)]
    fn counts(&self) -> [u32; 2] {
        [0, 0]
    }
}

/// The method table: one row per exit method (its type), in the order of the papers, as
/// `tetrace.methods()` lists them. Adding a method is a row here plus its own file.
macro_rules! method_table {
    ($($ty:ident),* $(,)?) => {
        /// An exit method, as Python names it.
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
        pub enum Method {
            $($ty),*
        }

        /// The names `tetrace.methods()` lists (each is its type's `ExitMethod::NAME`).
        pub const METHODS: &[&str] = &[$(<$ty as ExitMethod<f64>>::NAME),*];

        impl Method {
            pub const ALL: &'static [Method] = &[$(Method::$ty),*];

            pub fn name(self) -> &'static str {
                match self {
                    $(Method::$ty => <$ty as ExitMethod<f64>>::NAME),*
                }
            }

            /// Calls `v` with the method's type, in precision R (monomorphized per method).
            pub fn visit<R: Real, V: MethodVisitor<R>>(self, v: V) -> V::Out {
                match self {
                    $(Method::$ty => v.visit::<$ty>()),*
                }
            }
        }
    };
}

method_table! {
    Lagae2008Plane,
    Lagae2008Halfspace,
    Lagae2008Plucker,
    Lagae2008Stp,
    Ms06,
    Maria2017,
    Aman2022,
    Robust,
    Exact,
}

impl Method {
    /// The default: the exact walk, the only method that keeps tetrace's contract (closed
    /// triangles, in-plane rays never hit, the answer exact arithmetic gives) for every ray.
    /// The float methods stay selectable for the speed–accuracy chart.
    pub const DEFAULT: Method = Method::Exact;

    /// The method named `name`, or an error listing the known ones.
    pub fn from_name(name: &str) -> Result<Method> {
        Method::ALL
            .iter()
            .copied()
            .find(|m| m.name() == name)
            .ok_or_else(|| Error::unknown("method", name, METHODS))
    }
}

/// Something to do with an exit method of any type: [`Method::visit`] calls it with the one a
/// [`Method`] names.
pub trait MethodVisitor<R: Real> {
    type Out;
    fn visit<M: ExitMethod<R>>(self) -> Self::Out;
}

#[cfg(test)]
pub(crate) mod tests;
