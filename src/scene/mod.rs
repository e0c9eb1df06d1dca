//! A scene ready to cast: the topology, the locators, the traversal layouts (built on first
//! use), the points in both precisions and the caller's triangles hits are evaluated on.
//! Casting lives in `cast.rs`, the buffers it fills in `buffers.rs`.

pub mod buffers;
pub mod cast;
pub mod deform;
pub mod queries;

use crate::accel::exact_bvh::ray_parity;
use crate::accel::reshetov_bvh::nearest::NearestPoint;
pub use crate::accel::Built;
use crate::accel::{BvhParams, ExactBvh, OctreeParams, PortalezOctree, ReshetovBvh, Structures};
use crate::error::{Error, Result};
use crate::geom::real::Real;
use crate::layout::{LayoutKind, Layouts};
use crate::locate::{BoundaryLocator, GridLocator, Locators};
#[cfg(feature = "gpu")]
use crate::locate::{LocateState, Start, WalkStart};
use crate::mesh::{Incidence, Surface, TetMesh};
use crate::query::contains::{self, Containment, Parity};
use crate::query::ClosestHit;
#[cfg(feature = "gpu")]
use crate::query::RayHit;
use crate::threads::checkpoint;
#[cfg(feature = "gpu")]
use crate::traverse::Walk;
use std::sync::{Arc, OnceLock};

pub use buffers::{check_lengths, check_ray_count, HitBuffers, HitsOut, Rays};
pub use cast::{AccelKind, CastOptions, Lanes, Packets, CHUNK};
pub use deform::Moved;

pub struct Scene {
    pub mesh: TetMesh,
    pub locator: GridLocator,
    pub entry: BoundaryLocator,
    /// Traversal layouts, built on first use.
    pub layouts: Layouts,
    pub points_f32: Vec<[f32; 3]>,
    /// The caller's triangles and the alternatives a hit may name.
    pub surface: Surface,
    /// Constrained faces by vertex: the exact walk's touches and containment read it.
    pub incidence: Incidence,
    /// Containment's parity of each tet's region, built by the first `contains`.
    pub parity: OnceLock<Parity>,
    /// The structures the triangle-testing accelerators read (Reshetov's BVH, Portalez &
    /// Duguet's octree, as the structure table lists them): each built by the first cast
    /// that asks for it with the default parameters, or again with others.
    pub structures: Structures,
    /// Where each point came from: scene point k is point `input_index[k]` of those given to
    /// [`Scene::build_with`] (the Hilbert order renumbers them); [`Scene::update_points`]
    /// takes new points in the order given.
    pub input_index: Vec<u32>,
}

/// Whether some constrained face has a corner that is not a corner of the caller's triangle it
/// names (see [`Incidence::split`]).
pub(crate) fn split(mesh: &TetMesh, incidence: &Incidence, triangles: &[[[f64; 3]; 3]]) -> bool {
    incidence.faces.iter().any(|f| {
        let named = mesh.constrained[f.side as usize].triangle as usize;
        let tri = &triangles[named];
        f.points
            .iter()
            .any(|&p| !tri.contains(&mesh.points[p as usize]))
    })
}

impl Scene {
    /// Builds with points and tets in Hilbert order (see [`Scene::build_with`]).
    pub fn build(
        points: Vec<[f64; 3]>,
        tets: &[[u32; 4]],
        faces: &[[u32; 3]],
        face_triangle: &[u32],
        triangles: Vec<[[f64; 3]; 3]>,
    ) -> Result<Scene> {
        Scene::build_with(points, tets, faces, face_triangle, triangles, true)
    }

    /// `hilbert`: renumber points along a Hilbert curve and tets by region, then along the
    /// curve by centroid, so that the walk's memory accesses are local. Point and tet ids of the
    /// scene are then the new ones.
    pub fn build_with(
        points: Vec<[f64; 3]>,
        tets: &[[u32; 4]],
        faces: &[[u32; 3]],
        face_triangle: &[u32],
        triangles: Vec<[[f64; 3]; 3]>,
        hilbert: bool,
    ) -> Result<Scene> {
        if let Some(k) = face_triangle
            .iter()
            .position(|&t| t as usize >= triangles.len())
        {
            return Err(Error::InvalidInput(format!(
                "constrained face {k} names triangle {} but only {} triangles were given",
                face_triangle[k],
                triangles.len()
            )));
        }
        crate::mesh::surface::check_finite(&triangles)?;
        let np = points.len() as u64;
        let in_range = tets
            .iter()
            .flatten()
            .chain(faces.iter().flatten())
            .all(|&v| (v as u64) < np);
        let mut input_index: Vec<u32> = (0..np as u32).collect();
        let mesh = if hilbert && in_range && points.iter().flatten().all(|x| x.is_finite()) {
            // Build once unordered to find the regions, then again in Hilbert order within
            // regions: construction is cheap next to meshing (bunny: ~0.1 s).
            let unordered = TetMesh::build(points, tets, faces, face_triangle)?;
            checkpoint()?;
            let regions = unordered.regions();
            let (p, t, f, _, point_order) = crate::mesh::hilbert::reorder(
                &unordered.points,
                &unordered.tets,
                faces,
                unordered.bounds,
                Some(&regions),
            );
            input_index = point_order;
            checkpoint()?;
            TetMesh::build(p, &t, &f, face_triangle)?
        } else {
            // Out-of-range or non-finite input: let build() name the problem.
            TetMesh::build(points, tets, faces, face_triangle)?
        };
        if !mesh.domain_is_box {
            return Err(Error::InvalidMesh(
                "some boundary faces do not lie on the bounding box: the domain must be a box \
                 (tetrace.meshing wraps scenes in one)"
                    .into(),
            ));
        }
        checkpoint()?;
        let locator = GridLocator::build(&mesh);
        let entry = BoundaryLocator::build(&mesh);
        checkpoint()?;
        let points_f32 = mesh.points.iter().map(|p| p.map(|x| x as f32)).collect();
        let mut incidence = Incidence::build(&mesh);
        incidence.split = split(&mesh, &incidence, &triangles);
        checkpoint()?;
        let scene = Scene {
            mesh,
            locator,
            entry,
            layouts: Default::default(),
            points_f32,
            surface: Surface {
                triangles,
                alternatives: Default::default(),
            },
            incidence,
            parity: OnceLock::new(),
            structures: Structures::default(),
            input_index,
        };
        scene.layouts.prepare(LayoutKind::DEFAULT, &scene.mesh)?;
        Ok(scene)
    }

    /// A scene of the caller's triangles alone, before (or without) a tetrahedralization: the
    /// box [lo, hi] cut into Kuhn's six tets around its diagonal, with no constrained face.
    /// What reads only the triangles answers on it as on the tetrahedralized scene: the
    /// triangle-testing accelerators (the BVHs, the octree) and the closest points. A tet walk
    /// through it would meet no triangle, so the bindings refuse one (`PyScene`). Every
    /// triangle must lie strictly inside the box, as in a tetrahedralized scene's domain.
    pub fn surface_only(
        triangles: Vec<[[f64; 3]; 3]>,
        lo: [f64; 3],
        hi: [f64; 3],
    ) -> Result<Scene> {
        crate::mesh::surface::check_finite(&triangles)?;
        if !(0..3).all(|a| lo[a].is_finite() && hi[a].is_finite() && lo[a] < hi[a]) {
            return Err(Error::InvalidInput(format!(
                "the domain box {lo:?} to {hi:?} is not a finite box"
            )));
        }
        let inside = |p: &[f64; 3]| (0..3).all(|a| lo[a] < p[a] && p[a] < hi[a]);
        if let Some(k) = triangles.iter().position(|t| !t.iter().all(inside)) {
            return Err(Error::InvalidInput(format!(
                "triangle {k} is not strictly inside the domain box {lo:?} to {hi:?}"
            )));
        }
        // Corner i takes hi on axis a where bit a of i is set.
        let points: Vec<[f64; 3]> = (0..8)
            .map(|i| [0, 1, 2].map(|a| if i >> a & 1 == 1 { hi[a] } else { lo[a] }))
            .collect();
        // One tet per order of the axes: 0, then one axis, then two, then the far corner.
        let tets: Vec<[u32; 4]> = [(1, 2), (1, 4), (2, 1), (2, 4), (4, 1), (4, 2)]
            .map(|(a, b)| [0, a, a | b, 7])
            .to_vec();
        Scene::build_with(points, &tets, &[], &[], triangles, false)
    }

    /// See [`Surface::set_alternatives`].
    pub fn set_alternatives(&mut self, offsets: Vec<u32>, ids: Vec<u32>) -> Result<()> {
        self.surface.set_alternatives(offsets, ids)
    }

    /// Bytes of each part: points (both precisions), the constrained-side table, the locator
    /// (seed grid, boundary grid and the topology location walks on), and the records of each
    /// traversal layout built so far (as `tets_<name>`).
    pub fn memory(&self) -> Vec<(String, usize)> {
        let mut m = vec![
            ("points_f64".to_string(), self.mesh.points.len() * 24),
            ("points_f32".to_string(), self.points_f32.len() * 12),
            (
                "constrained".to_string(),
                self.mesh.constrained.len() * 8 + self.surface.alternatives_bytes(),
            ),
            (
                "locator".to_string(),
                self.locator.bytes() + self.entry.bytes() + self.mesh.tets.len() * 32,
            ),
            ("incidence".to_string(), self.incidence.bytes()),
            (
                "parity".to_string(),
                self.parity.get().map_or(0, |p| p.bytes()),
            ),
        ];
        m.extend(self.structures.memory());
        m.extend(
            self.layouts
                .built()
                .into_iter()
                .map(|(n, b)| (format!("tets_{n}"), b)),
        );
        m
    }

    /// The points in precision R.
    pub fn points<R: Real>(&self) -> &[[R; 3]] {
        R::pick(&self.points_f32, &self.mesh.points)
    }

    /// What location reads.
    pub fn locators(&self) -> Locators<'_> {
        Locators {
            mesh: &self.mesh,
            grid: &self.locator,
            entry: &self.entry,
        }
    }

    /// The closest-hit query over this scene's triangles.
    /// Reshetov's BVH: the one built last, else one with the default parameters (built now).
    pub fn bvh(&self) -> Result<Arc<ReshetovBvh>> {
        self.structures.get(&self.surface.triangles)
    }

    /// The exact 8-wide BVH: the one built last, else one with the default parameters (built
    /// now).
    pub fn exact_bvh(&self) -> Result<Arc<ExactBvh>> {
        self.structures.get(&self.surface.triangles)
    }

    /// The BVH if one is built.
    pub fn built_bvh(&self) -> Option<Arc<ReshetovBvh>> {
        self.structures.bvh.get()
    }

    /// Builds Reshetov's BVH with `params`, for the casts that follow (casts running now keep
    /// the tree they started with).
    pub fn build_bvh(&self, params: BvhParams) -> Result<Arc<ReshetovBvh>> {
        self.structures.build(&self.surface.triangles, params)
    }

    /// Portalez & Duguet's octree: the one built last, else one with the default parameters.
    pub fn octree(&self) -> Result<Arc<PortalezOctree>> {
        self.structures.get(&self.surface.triangles)
    }

    /// Builds the octree with `params`, for the casts that follow.
    pub fn build_octree(&self, params: OctreeParams) -> Result<Arc<PortalezOctree>> {
        self.structures.build(&self.surface.triangles, params)
    }

    pub fn closest(&self) -> ClosestHit<'_> {
        ClosestHit {
            mesh: &self.mesh,
            surface: &self.surface,
            incidence: &self.incidence,
            narrow: None,
        }
    }

    /// Containment of points (`points`: x y z of each, 3N values): `out[i]` is true when point
    /// i is inside the scene's surface or on it (see [`crate::query::contains`] for the rule).
    /// The first call builds the parity of each region.
    pub fn contains<R: Real>(
        &self,
        points: &[R],
        out: &mut [bool],
        threads: Option<usize>,
    ) -> Result<()> {
        contains::check(points.len(), out.len(), threads)?;
        self.containment().points(points, out, threads)
    }

    /// Containment's rule on this scene (the parity of each region built now if it is not
    /// yet).
    pub fn containment(&self) -> Containment<'_> {
        Containment {
            mesh: &self.mesh,
            grid: &self.locator,
            incidence: &self.incidence,
            parity: self.parity.get_or_init(|| Parity::build(&self.mesh)),
        }
    }

    /// Containment by the parity of one ray's crossings, on the exact BVH and without the
    /// tetrahedralization ([`ray_parity`], which says when it is
    /// [`Scene::contains`]'s rule): `out[i]` is `OUTSIDE`, `INSIDE` or `UNDECIDED` for point
    /// i (3N values); `keep[i]`: whether the caller's triangle i counts.
    pub fn ray_parity<R: Real>(
        &self,
        points: &[R],
        keep: &[bool],
        out: &mut [u8],
        threads: Option<usize>,
    ) -> Result<()> {
        let triangles = &self.surface.triangles;
        if keep.len() != triangles.len() {
            return Err(Error::InvalidInput(format!(
                "keep has {} entries for the scene's {} triangles",
                keep.len(),
                triangles.len()
            )));
        }
        let bvh: Arc<ExactBvh> = self.structures.get(triangles)?;
        ray_parity::sides(&bvh, triangles, keep, points, out, threads)
    }

    /// The scene's point nearest each point (`points`: x y z of each, 3N values, finite), on
    /// the BVH ([`Scene::bvh`]): `out[i]` for point i.
    pub fn nearest_points<R: Real>(
        &self,
        points: &[R],
        out: &mut [NearestPoint],
        threads: Option<usize>,
    ) -> Result<()> {
        contains::check(points.len(), out.len(), threads)?;
        if let Some(i) =
            (0..out.len()).find(|&i| !(0..3).all(|a| points[3 * i + a].to_f64().is_finite()))
        {
            return Err(Error::InvalidInput(format!(
                "point {i} has a NaN or infinite coordinate"
            )));
        }
        let bvh = self.bvh()?;
        contains::per_point(
            points,
            out,
            threads,
            |_| Vec::with_capacity(64),
            |p, stack| bvh.nearest(p, stack),
        )
    }

    /// Where ray i of `rays` starts (the GPU cast's first half, as the CPU cast locates).
    #[cfg(feature = "gpu")]
    #[inline]
    pub(crate) fn locate_one<R: Real>(
        &self,
        rays: &Rays<R>,
        i: usize,
        settle: Option<&[[R; 3]]>,
        st: &mut LocateState,
    ) -> Start {
        self.locators().locate(&rays.ray(i), settle, st)
    }

    /// The hit of a finished walk (the GPU cast's second half).
    #[cfg(feature = "gpu")]
    #[inline]
    pub(crate) fn finish(&self, s: &WalkStart, w: &Walk) -> RayHit {
        self.closest().finish(s, w)
    }
}
