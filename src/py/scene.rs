//! `NativeScene`: building a scene and casting through it (CPU and GPU).

use super::arrays::{check_cols, rows, slice};
use super::errors::{guarded, interruptible};
use super::names::{LayoutArg, QueryArg};
#[cfg(feature = "gpu")]
use super::query::columns_dict;
use super::query::Job;
use super::request::{threads_arg, PyRayRequest};
use crate::accel::reshetov_bvh::nearest::NearestPoint;
use crate::accel::{
    BvhParams, ExactBvh, ExactBvhParams, OctreeParams, PortalezOctree, ReshetovBvh,
};
use crate::error::{try_vec, try_zeroed_vec};
use crate::geom::real::Real;
#[cfg(feature = "gpu")]
use crate::scene::queries::{All, Closest, Column, Count, RayJob};
use crate::scene::CastOptions;
use crate::scene::{AccelKind, Scene};
use numpy::{
    Element, IntoPyArray, PyArray1, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2,
    PyReadonlyArray3, PyUntypedArrayMethods,
};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::sync::{Arc, RwLock};

#[pyclass(frozen, name = "NativeScene", module = "tetrace._native")]
pub struct PyScene {
    /// The scene as it is now. Each call clones the `Arc` once (a cast under way keeps the
    /// scene it started on); `update_points` swaps in a moved one. The lock is taken only
    /// with the GIL held and only to clone or swap the `Arc`, so no two callers wait on each
    /// other across a released GIL.
    state: RwLock<Arc<Loaded>>,
}

/// A scene and what lives beside it.
struct Loaded {
    scene: Scene,
    /// Whether the scene holds the caller's tetrahedralization (else it is
    /// `Scene::surface_only`'s box: the triangles alone, which no tet walk may cross).
    ct: bool,
    /// The scene's buffers on the GPU, uploaded per layout by the first GPU cast with it.
    #[cfg(feature = "gpu")]
    device: crate::gpu::DeviceScene,
}

impl Loaded {
    fn new(scene: Scene, ct: bool) -> Arc<Loaded> {
        Arc::new(Loaded {
            scene,
            ct,
            #[cfg(feature = "gpu")]
            device: Default::default(),
        })
    }
}

impl PyScene {
    /// The scene as it is now (held by the caller for the whole call).
    fn loaded(&self) -> Arc<Loaded> {
        self.state.read().unwrap_or_else(|e| e.into_inner()).clone()
    }

    /// The scene as it is now, if it holds its tetrahedralization; else a clear error where
    /// `what` would walk tets through the placeholder box and meet no triangle (Python's
    /// `Scene` builds the CT before asking: this is the core's own guard).
    fn with_ct(&self, what: &str) -> PyResult<Arc<Loaded>> {
        let loaded = self.loaded();
        if !loaded.ct {
            return Err(PyValueError::new_err(format!(
                "{what} walks the tetrahedralization, which this scene has not built \
                 (Scene.build_ct() builds it)"
            )));
        }
        Ok(loaded)
    }
}

#[pymethods]
impl PyScene {
    /// Builds the traversal structures from a tetrahedralization (see tetrace.meshing).
    #[new]
    #[pyo3(signature = (points, tets, faces, face_triangle, triangles, hilbert=true, alternatives=None))]
    #[allow(clippy::too_many_arguments)] // a Python signature: keyword arguments, not a design
    fn new(
        py: Python<'_>,
        points: PyReadonlyArray2<'_, f64>,
        tets: PyReadonlyArray2<'_, u32>,
        faces: PyReadonlyArray2<'_, u32>,
        face_triangle: PyReadonlyArray1<'_, u32>,
        triangles: PyReadonlyArray3<'_, f64>,
        hilbert: bool,
        alternatives: Option<(PyReadonlyArray1<'_, u32>, PyReadonlyArray1<'_, u32>)>,
    ) -> PyResult<Self> {
        check_cols(&points, 3, "points")?;
        check_cols(&tets, 4, "tets")?;
        check_cols(&faces, 3, "faces")?;
        let ts = triangles.shape();
        if ts[1] != 3 || ts[2] != 3 {
            return Err(PyValueError::new_err(format!(
                "triangles must have shape (F, 3, 3), got {ts:?}"
            )));
        }
        let p: Vec<[f64; 3]> = rows(slice(&points, "points")?);
        let t: Vec<[u32; 4]> = rows(slice(&tets, "tets")?);
        let f: Vec<[u32; 3]> = rows(slice(&faces, "faces")?);
        let ft = slice(&face_triangle, "face_triangle")?;
        let tri = triangle_rows(slice(&triangles, "triangles")?);
        let alternatives = match &alternatives {
            Some((offsets, ids)) => Some((
                slice(offsets, "alternatives offsets")?.to_vec(),
                slice(ids, "alternatives ids")?.to_vec(),
            )),
            None => None,
        };
        // In tetrace's pool: the build's parallel sorts must not use rayon's global pool,
        // whose threads a forked child lacks. Ctrl-C stops it at the next stage.
        let inner = interruptible(py, || {
            crate::threads::install(None, || {
                let mut scene = Scene::build_with(p, &t, &f, ft, tri, hilbert)?;
                if let Some((offsets, ids)) = alternatives {
                    scene.set_alternatives(offsets, ids)?;
                }
                Ok(scene)
            })?
        })?;
        Ok(PyScene {
            state: RwLock::new(Loaded::new(inner, true)),
        })
    }

    /// A scene of the caller's `triangles` ((F, 3, 3) float64) alone, in the domain box
    /// [`lo`, `hi`] and before any tetrahedralization (`Scene::surface_only`): the BVHs, the
    /// octree and the closest points answer on it; a tet walk is refused.
    #[staticmethod]
    fn surface_only(
        py: Python<'_>,
        triangles: PyReadonlyArray3<'_, f64>,
        lo: [f64; 3],
        hi: [f64; 3],
    ) -> PyResult<Self> {
        let ts = triangles.shape();
        if ts[1] != 3 || ts[2] != 3 {
            return Err(PyValueError::new_err(format!(
                "triangles must have shape (F, 3, 3), got {ts:?}"
            )));
        }
        let tri = triangle_rows(slice(&triangles, "triangles")?);
        let inner = interruptible(py, || {
            crate::threads::install(None, || Scene::surface_only(tri, lo, hi))?
        })?;
        Ok(PyScene {
            state: RwLock::new(Loaded::new(inner, false)),
        })
    }

    /// Whether the scene holds its tetrahedralization (False: `surface_only`).
    #[getter]
    fn has_ct(&self) -> bool {
        self.loaded().ct
    }

    /// Answers the query named `kind` (one of `queries()`) for the rays of `request`: a dict
    /// of the query's columns (flat arrays, in the request's precision where they hold t, u,
    /// v or points). `progress`: called with (rays done, rays) as chunks finish.
    #[pyo3(signature = (kind, request, progress=None))]
    fn query<'py>(
        &self,
        py: Python<'py>,
        kind: QueryArg,
        request: &PyRayRequest,
        progress: Option<Py<PyAny>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let loaded = if request.opts.accel == AccelKind::TetWalk {
            self.with_ct("a query with accel=\"tetwalk\" (or a method, layout or audit)")?
        } else {
            self.loaded()
        };
        let job = Job {
            py,
            scene: &loaded.scene,
            request,
            progress,
        };
        kind.0.visit(job)
    }

    /// Casts the float32 rays of `request` on the GPU and answers query `kind`: "closest"
    /// (start location and hits on the CPU, the walk on the device; any kernel), or "any"
    /// (occlusion), "all" or "count" (every point, listed or counted) on the exact kernel.
    /// Returns the query's columns and the seconds of each phase.
    #[pyo3(signature = (request, kind="closest"))]
    fn cast_gpu<'py>(
        &self,
        py: Python<'py>,
        request: &PyRayRequest,
        kind: &str,
    ) -> PyResult<(Bound<'py, PyDict>, Bound<'py, PyDict>)> {
        if request.accel_named && request.opts.accel != AccelKind::TetWalk {
            return Err(PyValueError::new_err(format!(
                "device=\"gpu\" walks the tetrahedralization; accel {:?} is CPU only",
                request.opts.accel.name()
            )));
        }
        if !matches!(kind, "closest" | "any" | "all" | "count") {
            return Err(PyValueError::new_err(format!(
                "the GPU answers the closest, any, all and count queries, not {kind:?}"
            )));
        }
        #[cfg(not(feature = "gpu"))]
        {
            let _ = (py, request);
            Err(super::gpu::not_built())
        }
        #[cfg(feature = "gpu")]
        {
            let loaded = self.with_ct("device=\"gpu\"")?;
            let scene = &loaded.scene;
            let rays = request.f32_rays(py)?;
            let rays = rays.rays(scene)?;
            let opts = CastOptions {
                threads: request.opts.threads,
                max_steps: request.opts.max_steps,
                ..Default::default()
            };
            let ask = request.ask;
            let device = &loaded.device;
            // On this thread, as before: its batches stop at `threads::checkpoint`, which
            // polls here (inside `threads::install` the GPU's waits would not see Ctrl-C).
            if kind != "closest" && ask.method.is_some_and(|m| m.name() != "exact") {
                return Err(PyValueError::new_err(format!(
                    "the {kind:?} query on the GPU takes the exact kernel (the default method)"
                )));
            }
            let (columns, timings) = if kind == "any" {
                let mut status = try_zeroed_vec::<u8>(rays.len(), "statuses")?;
                let t = interruptible(py, || device.occluded(scene, &rays, &mut status, &opts))?;
                (vec![Column::new("status", status)], t)
            } else if kind == "all" || kind == "count" {
                let mut listed = All::output::<f32>(rays.len(), &ask)?;
                let t = interruptible(py, || {
                    device.intersections(scene, &rays, &mut listed, &opts)
                })?;
                let columns = if kind == "all" {
                    All::columns::<f32>(listed)?
                } else {
                    Count::columns::<f32>(listed)?
                };
                (columns, t)
            } else {
                let (method, layout) = (ask.method.map(|m| m.name()), ask.layout.map(|l| l.name()));
                let mut out = Closest::output::<f32>(rays.len(), &ask)?;
                let t = interruptible(py, || {
                    device.cast(scene, method, layout, &rays, out.out(), &opts)
                })?;
                (Closest::columns(out)?, t)
            };
            Ok((
                columns_dict(py, columns)?,
                super::gpu::timings_dict(py, &timings)?,
            ))
        }
    }

    /// Casts a camera's rays on the GPU with the exact kernel (the default): the camera's
    /// float32 numbers (`Camera.float32_numbers()`), its `eye`, and one range [tmin, tmax]
    /// for every ray. The directions are made on the device; the host makes only those of
    /// the rays the device hands back (`DeviceScene::cast_camera_at`). Returns the closest
    /// hits' columns (row-major pixels) and the seconds of each phase.
    #[pyo3(signature = (axes, xs, ys, normalize, eye, tmin, tmax, threads=None, max_steps=None))]
    #[allow(clippy::too_many_arguments)] // a Python signature: keyword arguments, not a design
    fn cast_gpu_camera<'py>(
        &self,
        py: Python<'py>,
        axes: PyReadonlyArray2<'py, f32>,
        xs: PyReadonlyArray1<'py, f32>,
        ys: PyReadonlyArray1<'py, f32>,
        normalize: bool,
        eye: [f32; 3],
        tmin: f64,
        tmax: f64,
        threads: Option<&Bound<'py, PyAny>>,
        max_steps: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<(Bound<'py, PyDict>, Bound<'py, PyDict>)> {
        let cam = super::arrays::camera_arg(&axes, &xs, &ys, normalize)?;
        let opts = CastOptions {
            threads: threads_arg(threads)?,
            max_steps: super::request::max_steps_arg(max_steps)?,
            ..Default::default()
        };
        #[cfg(not(feature = "gpu"))]
        {
            let _ = (py, cam, eye, tmin, tmax, opts);
            Err(super::gpu::not_built())
        }
        #[cfg(feature = "gpu")]
        {
            let loaded = self.with_ct("device=\"gpu\"")?;
            let mut out = Closest::output::<f32>(cam.n_rays(), &Default::default())?;
            let t = interruptible(py, || {
                let (scene, range) = (&loaded.scene, (tmin, tmax));
                loaded
                    .device
                    .cast_camera_at(scene, &cam, eye, range, out.out(), &opts)
            })?;
            Ok((
                columns_dict(py, Closest::columns(out)?)?,
                super::gpu::timings_dict(py, &t)?,
            ))
        }
    }

    /// Containment of float32 points ((N, 3)) on the GPU, as `contains` answers (the kernel
    /// locates each point; the host answers those it cannot certify). Returns (N,) bool and
    /// the seconds of each phase.
    #[pyo3(signature = (points, threads=None))]
    fn contains_gpu<'py>(
        &self,
        py: Python<'py>,
        points: PyReadonlyArray2<'py, f32>,
        threads: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<(Bound<'py, PyArray1<bool>>, Bound<'py, PyDict>)> {
        let threads = threads_arg(threads)?;
        let n = check_cols(&points, 3, "points")?;
        let p = slice(&points, "points")?;
        #[cfg(not(feature = "gpu"))]
        {
            let _ = (py, n, p, threads);
            Err(super::gpu::not_built())
        }
        #[cfg(feature = "gpu")]
        {
            let loaded = self.with_ct("contains on the GPU")?;
            let mut out = try_zeroed_vec::<bool>(n, "the answers of contains")?;
            let t = interruptible(py, || {
                loaded.device.contains(&loaded.scene, p, &mut out, threads)
            })?;
            Ok((out.into_pyarray(py), super::gpu::timings_dict(py, &t)?))
        }
    }

    /// Containment: per row of `points` ((N, 3), float32 or float64), True when the point is
    /// inside the scene's surface or on it (the fewest scene-triangle crossings to outside the
    /// domain box is odd; points outside the box or not finite are False). Returns (N,) bool.
    #[pyo3(signature = (points, threads=None))]
    fn contains<'py>(
        &self,
        py: Python<'py>,
        points: &Bound<'py, PyAny>,
        threads: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyArray1<bool>>> {
        let threads = threads_arg(threads)?;
        if let Ok(p) = points.extract::<PyReadonlyArray2<'py, f32>>() {
            return contains_impl(py, &self.with_ct("contains (parity)")?.scene, p, threads);
        }
        if let Ok(p) = points.extract::<PyReadonlyArray2<'py, f64>>() {
            return contains_impl(py, &self.with_ct("contains (parity)")?.scene, p, threads);
        }
        let shape = points.getattr("shape").map(|s| s.to_string());
        let dtype = points.getattr("dtype").map(|s| s.to_string());
        match (shape, dtype) {
            (Ok(shape), Ok(_)) if points.getattr("ndim")?.extract::<usize>()? != 2 => Err(
                PyValueError::new_err(format!("points must have shape (N, 3), got {shape}")),
            ),
            (Ok(_), Ok(dtype)) => Err(PyTypeError::new_err(format!(
                "points must be float32 or float64, got {dtype}"
            ))),
            _ => Err(PyTypeError::new_err(
                "points must be a numpy array of shape (N, 3), float32 or float64",
            )),
        }
    }

    /// Containment by one ray's crossings, on the exact BVH (no tetrahedralization needed):
    /// per row of `points` ((N, 3) float64), 0 outside, 1 inside or on a kept triangle, 2
    /// undecided (every direction met a kept triangle's edge or corner or lay in its plane);
    /// `keep` ((F,) bool): which of the caller's triangles count. The scene's parity rule on
    /// a closed surface (`accel::exact_bvh::ray_parity`). Returns (N,) uint8.
    #[pyo3(signature = (points, keep, threads=None))]
    fn ray_parity<'py>(
        &self,
        py: Python<'py>,
        points: PyReadonlyArray2<'py, f64>,
        keep: PyReadonlyArray1<'py, bool>,
        threads: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyArray1<u8>>> {
        let threads = threads_arg(threads)?;
        let n = check_cols(&points, 3, "points")?;
        let p = slice(&points, "points")?;
        let keep = keep
            .as_slice()
            .map_err(|_| PyValueError::new_err("keep must be a contiguous (F,) bool array"))?;
        let mut out = try_zeroed_vec::<u8>(n, "the answers of ray_parity")?;
        let loaded = self.loaded();
        interruptible(py, || loaded.scene.ray_parity(p, keep, &mut out, threads))?;
        Ok(out.into_pyarray(py))
    }

    /// The scene's point nearest each row of `points` ((N, 3) float64, finite), found on the
    /// BVH: a dict of "point" (N, 3), "triangle" (N,) int32 (-1: the scene has none), "u",
    /// "v" (barycentrics of the triangle's second and third corners) and "distance".
    #[pyo3(signature = (points, threads=None))]
    fn closest_points<'py>(
        &self,
        py: Python<'py>,
        points: PyReadonlyArray2<'py, f64>,
        threads: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let threads = threads_arg(threads)?;
        let n = check_cols(&points, 3, "points")?;
        let p = slice(&points, "points")?;
        let mut out = try_vec(n, NearestPoint::NONE, "the closest points")?;
        let loaded = self.loaded();
        interruptible(py, || loaded.scene.nearest_points(p, &mut out, threads))?;
        let point: Vec<f64> = out.iter().flat_map(|r| r.point).collect();
        let d = PyDict::new(py);
        d.set_item("point", point.into_pyarray(py).reshape([n, 3])?)?;
        let column = |f: fn(&NearestPoint) -> f64| out.iter().map(f).collect::<Vec<f64>>();
        d.set_item(
            "triangle",
            out.iter()
                .map(|r| r.triangle)
                .collect::<Vec<i32>>()
                .into_pyarray(py),
        )?;
        d.set_item("u", column(|r| r.u).into_pyarray(py))?;
        d.set_item("v", column(|r| r.v).into_pyarray(py))?;
        d.set_item("distance", column(|r| r.distance).into_pyarray(py))?;
        Ok(d)
    }

    /// Builds Reshetov's BVH with these parameters for the casts that follow (a cast with
    /// `accel="reshetov_bvh"` builds one with the defaults when none is built); returns what
    /// `bvh_info` returns.
    /// None for a parameter: the core's default (`structure_defaults()["bvh"]`).
    #[pyo3(signature = (cost_ratio=None, max_leaf=None, bins=None, aperture=None))]
    fn build_bvh<'py>(
        &self,
        py: Python<'py>,
        cost_ratio: Option<f64>,
        max_leaf: Option<u32>,
        bins: Option<u32>,
        aperture: Option<bool>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let d = BvhParams::default();
        let params = BvhParams {
            cost_ratio: cost_ratio.unwrap_or(d.cost_ratio),
            max_leaf: max_leaf.unwrap_or(d.max_leaf),
            bins: bins.unwrap_or(d.bins),
            aperture: aperture.unwrap_or(d.aperture),
        };
        let bvh = py.detach(|| guarded(|| self.loaded().scene.build_bvh(params)))?;
        bvh_info(py, &bvh)
    }

    /// The BVH's shape (nodes, leaves, depth, bytes, its parameters), or None when none is
    /// built.
    fn bvh_info<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        self.loaded()
            .scene
            .built_bvh()
            .map(|b| bvh_info(py, &b))
            .transpose()
    }

    /// Builds the exact 8-wide BVH with these parameters for the casts that follow (a cast
    /// with `accel="exact_bvh"` builds one with the defaults when none is built); returns
    /// what `exact_bvh_info` returns.
    /// None for a parameter: the core's default (`structure_defaults()["exact_bvh"]`).
    #[pyo3(signature = (cost_ratio=None, max_leaf=None, bins=None, leaf_size=None))]
    fn build_exact_bvh<'py>(
        &self,
        py: Python<'py>,
        cost_ratio: Option<f64>,
        max_leaf: Option<u32>,
        bins: Option<u32>,
        leaf_size: Option<u32>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let d = ExactBvhParams::default();
        let params = ExactBvhParams {
            cost_ratio: cost_ratio.unwrap_or(d.cost_ratio),
            max_leaf: max_leaf.unwrap_or(d.max_leaf),
            bins: bins.unwrap_or(d.bins),
            leaf_size: leaf_size.unwrap_or(d.leaf_size),
        };
        let scene = &self.loaded().scene;
        let bvh = py.detach(|| {
            guarded(|| {
                scene
                    .structures
                    .build::<ExactBvh>(&scene.surface.triangles, params)
            })
        })?;
        exact_bvh_info(py, &bvh)
    }

    /// The 8-wide BVH's shape (nodes, leaves, mean children, depth, bytes, its parameters),
    /// or None when none is built.
    fn exact_bvh_info<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        self.loaded()
            .scene
            .structures
            .exact_bvh
            .get()
            .map(|b| exact_bvh_info(py, &b))
            .transpose()
    }

    /// Builds Portalez & Duguet's octree with these parameters for the casts that follow;
    /// returns what `octree_info` returns.
    /// None for a parameter: the core's default (`structure_defaults()["octree"]`).
    #[pyo3(signature = (max_depth=None, leaf_size=None, balance=None))]
    fn build_octree<'py>(
        &self,
        py: Python<'py>,
        max_depth: Option<u32>,
        leaf_size: Option<u32>,
        balance: Option<bool>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let d = OctreeParams::default();
        let params = OctreeParams {
            max_depth: max_depth.unwrap_or(d.max_depth),
            leaf_size: leaf_size.unwrap_or(d.leaf_size),
            balance: balance.unwrap_or(d.balance),
        };
        let octree = py.detach(|| guarded(|| self.loaded().scene.build_octree(params)))?;
        octree_info(py, &octree)
    }

    /// The octree's statistics and bytes per part, or None when none is built.
    fn octree_info<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        self.loaded()
            .scene
            .structures
            .octree
            .get()
            .map(|o| octree_info(py, &o))
            .transpose()
    }

    /// Takes over the structures `other` built. Over the same triangles, bit for bit (the
    /// tetrahedralization built for a scene that had none), they are shared as they are;
    /// over others (a scene meshed again from moved vertices), the rule of a move
    /// (`Structures::moved`), so a structure built with other than the default parameters
    /// is built again now with them.
    fn adopt_structures(&self, py: Python<'_>, other: &PyScene) -> PyResult<()> {
        let (this, from) = (self.loaded(), other.loaded());
        let (mine, theirs) = (&this.scene.surface.triangles, &from.scene.surface.triangles);
        let same = mine.len() == theirs.len()
            && mine
                .iter()
                .flatten()
                .flatten()
                .map(|x| x.to_bits())
                .eq(theirs.iter().flatten().flatten().map(|x| x.to_bits()));
        let moved = py.detach(|| {
            guarded(|| {
                if same {
                    return Ok(from.scene.structures.share());
                }
                crate::threads::install(None, || {
                    from.scene.structures.moved(&this.scene.surface.triangles)
                })?
            })
        })?;
        // Our own clones go before the swap, which needs the only reference.
        drop((this, from));
        let mut slot = self.state.write().unwrap_or_else(|e| e.into_inner());
        match Arc::get_mut(&mut slot) {
            Some(loaded) => loaded.scene.structures = moved,
            None => {
                return Err(PyValueError::new_err(
                    "adopt_structures: the scene is in use by a cast on another thread",
                ))
            }
        }
        Ok(())
    }

    /// Moves the scene's points to `points` ((P, 3) float64, in the order they were given to
    /// the constructor) and its triangles to `triangles` ((F, 3, 3) float64, as many as
    /// before), keeping the topology, when every tet stays positively oriented (exact) and
    /// the domain box stays: returns (applied, inverted tets, points outside). When not
    /// applied, nothing changes. Moving drops the GPU buffers (uploaded again by the next GPU
    /// cast). Runs with the GIL held: the swap must not interleave with other calls.
    fn update_points(
        &self,
        points: PyReadonlyArray2<'_, f64>,
        triangles: PyReadonlyArray3<'_, f64>,
    ) -> PyResult<(bool, usize, usize)> {
        check_cols(&points, 3, "points")?;
        let ts = triangles.shape();
        if ts[1] != 3 || ts[2] != 3 {
            return Err(PyValueError::new_err(format!(
                "triangles must have shape (F, 3, 3), got {ts:?}"
            )));
        }
        let p: Vec<[f64; 3]> = rows(slice(&points, "points")?);
        let tri = triangle_rows(slice(&triangles, "triangles")?);
        self.with_ct("update_points")?;
        let mut slot = self.state.write().unwrap_or_else(|e| e.into_inner());
        let target: &mut Arc<Loaded> = &mut slot;
        // In tetrace's pool (fork-safe), as the constructor.
        let moved = guarded(|| {
            crate::threads::install(None, || match Arc::get_mut(target) {
                // No cast holds the scene: move it in place.
                Some(loaded) => {
                    let moved = loaded.scene.update_points(&p, tri)?;
                    #[cfg(feature = "gpu")]
                    if moved.applied {
                        loaded.device = Default::default();
                    }
                    Ok(moved)
                }
                // A cast on another thread still reads it: move a copy.
                None => {
                    let (copy, moved) = target.scene.moved_copy(&p, tri)?;
                    if let Some(scene) = copy {
                        *target = Loaded::new(scene, true);
                    }
                    Ok(moved)
                }
            })?
        })?;
        Ok((moved.applied, moved.inverted, moved.outside))
    }

    /// Bytes used by each part of the structure (`gpu_<layout>`: on the device).
    fn memory<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        let loaded = self.loaded();
        for (k, v) in loaded.scene.memory() {
            d.set_item(k, v)?;
        }
        #[cfg(feature = "gpu")]
        for (k, v) in loaded.device.bytes() {
            d.set_item(format!("gpu_{k}"), v)?;
        }
        Ok(d)
    }

    #[getter]
    fn n_tets(&self) -> usize {
        self.loaded().scene.mesh.len()
    }
    #[getter]
    fn n_points(&self) -> usize {
        self.loaded().scene.mesh.points.len()
    }
    #[getter]
    fn n_constrained(&self) -> usize {
        self.loaded().scene.mesh.constrained.len()
    }
    /// Whether the mesher split caller's triangles into several faces (`Incidence::split`).
    #[getter]
    fn splits_triangles(&self) -> bool {
        self.loaded().scene.incidence.split
    }
    /// Builds a traversal layout now instead of at its first cast; returns its bytes.
    fn prepare_layout(&self, py: Python<'_>, layout: LayoutArg) -> PyResult<usize> {
        let loaded = self.loaded();
        let scene = &loaded.scene;
        py.detach(|| guarded(|| scene.layouts.prepare(layout.0, &scene.mesh)))
    }
    #[getter]
    fn bounds(&self) -> [[f64; 3]; 2] {
        self.loaded().scene.mesh.bounds
    }
    /// The points (P, 3) in the scene's order (Hilbert order unless disabled).
    fn points<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, numpy::PyArray2<f64>>> {
        let loaded = self.loaded();
        let points = &loaded.scene.mesh.points;
        let flat: Vec<f64> = points.iter().flatten().copied().collect();
        flat.into_pyarray(py).reshape([points.len(), 3])
    }

    /// The positively oriented tets (T, 4), for inspection and plotting.
    fn tets<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, numpy::PyArray2<u32>>> {
        let loaded = self.loaded();
        let tets = &loaded.scene.mesh.tets;
        let flat: Vec<u32> = tets.iter().flatten().copied().collect();
        flat.into_pyarray(py).reshape([tets.len(), 4])
    }
}

/// (F, 3, 3) values, flat, as F triangles.
fn triangle_rows(flat: &[f64]) -> Vec<[[f64; 3]; 3]> {
    rows::<f64, 9>(flat)
        .into_iter()
        .map(|r| [[r[0], r[1], r[2]], [r[3], r[4], r[5]], [r[6], r[7], r[8]]])
        .collect()
}

/// Validates, answers with the GIL released, returns the answers (the vector becomes the numpy
/// array without a copy).
fn contains_impl<'py, R: Real + Element>(
    py: Python<'py>,
    scene: &Scene,
    points: PyReadonlyArray2<'py, R>,
    threads: Option<usize>,
) -> PyResult<Bound<'py, PyArray1<bool>>> {
    let n = check_cols(&points, 3, "points")?;
    let p = slice(&points, "points")?;
    let mut out = try_zeroed_vec::<bool>(n, "the answers of contains")?;
    interruptible(py, || scene.contains(p, &mut out, threads))?;
    Ok(out.into_pyarray(py))
}

fn octree_info<'py>(py: Python<'py>, octree: &PortalezOctree) -> PyResult<Bound<'py, PyDict>> {
    let (stats, memory) = (octree.stats(), octree.memory());
    let d = PyDict::new(py);
    d.set_item("leaves", stats.leaves)?;
    d.set_item("empty_leaves", stats.empty_leaves)?;
    d.set_item("neighbours_per_leaf", stats.neighbours_per_leaf)?;
    d.set_item("triangles_per_leaf", stats.triangles_per_leaf)?;
    d.set_item("depth", stats.max_depth)?;
    d.set_item("node_links", stats.node_links)?;
    // Table 4's columns (bytes), and the hierarchy the paper does not keep.
    d.set_item("bytes_cube_map", memory.cube_map)?;
    d.set_item("bytes_octree", memory.octree)?;
    d.set_item("bytes_triangles", memory.triangles)?;
    d.set_item("bytes_boxes", memory.boxes)?;
    d.set_item("bytes_hierarchy", memory.hierarchy)?;
    d.set_item("bytes", memory.total)?;
    d.set_item("max_depth", octree.params.max_depth)?;
    d.set_item("leaf_size", octree.params.leaf_size)?;
    d.set_item("balance", octree.params.balance)?;
    Ok(d)
}

fn exact_bvh_info<'py>(py: Python<'py>, bvh: &ExactBvh) -> PyResult<Bound<'py, PyDict>> {
    let (leaves, children, depth) = bvh.shape();
    let d = PyDict::new(py);
    d.set_item("nodes", bvh.nodes.len())?;
    d.set_item("leaves", leaves)?;
    d.set_item("children_per_node", children)?;
    d.set_item("depth", depth)?;
    d.set_item("bytes", bvh.memory())?;
    d.set_item(
        "bytes_per_triangle",
        bvh.memory() as f64 / bvh.order.len().max(1) as f64,
    )?;
    d.set_item("cost_ratio", bvh.params.cost_ratio)?;
    d.set_item("max_leaf", bvh.params.max_leaf)?;
    d.set_item("bins", bvh.params.bins)?;
    d.set_item("leaf_size", bvh.params.leaf_size)?;
    Ok(d)
}

fn bvh_info<'py>(py: Python<'py>, bvh: &ReshetovBvh) -> PyResult<Bound<'py, PyDict>> {
    let (leaves, depth) = bvh.shape();
    let d = PyDict::new(py);
    d.set_item("nodes", bvh.nodes.len())?;
    d.set_item("leaves", leaves)?;
    d.set_item("depth", depth)?;
    d.set_item("bytes", bvh.memory())?;
    d.set_item("cost_ratio", bvh.params.cost_ratio)?;
    d.set_item("max_leaf", bvh.params.max_leaf)?;
    d.set_item("bins", bvh.params.bins)?;
    d.set_item("aperture", bvh.params.aperture)?;
    // What packets' frustum culling did on this tree since it was built (cumulative).
    let [tests, culled, aperture, no_axis, lone, frusta] = bvh.culling.read();
    d.set_item("packet_tests", tests)?;
    d.set_item("packet_culled", culled)?;
    d.set_item("packet_culled_aperture", aperture)?;
    d.set_item("packet_leaves_no_axis", no_axis)?;
    d.set_item("packet_leaves_lone", lone)?;
    d.set_item("packet_leaves_frustum", frusta)?;
    Ok(d)
}
