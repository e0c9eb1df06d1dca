//! `NativeScene`: building a scene and casting through it (CPU and GPU).

use super::arrays::{check_cols, rows, slice};
use super::errors::{guarded, interruptible, interruptible_with_progress};
use super::names::{AccelArg, LayoutArg, MethodArg};
use crate::accel::reshetov_bvh::nearest::NearestPoint;
use crate::accel::{BvhParams, OctreeParams, PortalezOctree, ReshetovBvh};
use crate::error::try_vec;
use crate::geom::real::Real;
use crate::layout::LayoutKind;
use crate::query::Listed;
use crate::scene::buffers::LeavingRays;
use crate::scene::{AccelKind, CastOptions, HitBuffers, HitsOut, Packets, Rays, Scene};
use crate::traverse::Method;
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
    /// The scene's buffers on the GPU, uploaded per layout by the first GPU cast with it.
    #[cfg(feature = "gpu")]
    device: crate::gpu::DeviceScene,
}

impl Loaded {
    fn new(scene: Scene) -> Arc<Loaded> {
        Arc::new(Loaded {
            scene,
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
        let tri: Vec<[[f64; 3]; 3]> = rows::<f64, 9>(slice(&triangles, "triangles")?)
            .into_iter()
            .map(|r| [[r[0], r[1], r[2]], [r[3], r[4], r[5]], [r[6], r[7], r[8]]])
            .collect();
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
            state: RwLock::new(Loaded::new(inner)),
        })
    }

    /// Casts rays: origins and directions both float32 (the walk runs in float32) or both
    /// float64. Returns a dict of the Hits fields, in that precision; with `audit`, also
    /// "audit": (N, 2) uint32, per ray the exit faces taken that exact predicates reject and
    /// the steps where the method found no exit face. `method`, `layout`: None for the core's
    /// defaults.
    #[pyo3(signature = (origins, directions, tmin, tmax, threads=None, max_steps=None, method=None, layout=None, audit=false, packet=true, accel=None, start=None, progress=None))]
    #[allow(clippy::too_many_arguments)] // a Python signature: keyword arguments, not a design
    fn cast<'py>(
        &self,
        py: Python<'py>,
        origins: &Bound<'py, PyAny>,
        directions: &Bound<'py, PyAny>,
        tmin: PyReadonlyArray1<'py, f64>,
        tmax: PyReadonlyArray1<'py, f64>,
        threads: Option<usize>,
        max_steps: Option<u32>,
        method: Option<MethodArg>,
        layout: Option<LayoutArg>,
        audit: bool,
        packet: bool,
        accel: Option<AccelArg>,
        start: Option<StartArrays<'py>>,
        progress: Option<Py<PyAny>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let loaded = self.loaded();
        let scene = &loaded.scene;
        let opts = cast_options(threads, max_steps, packet, accel);
        let method = method.map_or(Method::DEFAULT, |m| m.0);
        let layout = layout.map_or(LayoutKind::DEFAULT, |l| l.0);
        let f32s = (
            origins.extract::<PyReadonlyArray2<'py, f32>>(),
            directions.extract::<PyReadonlyArray2<'py, f32>>(),
        );
        if let (Ok(o), Ok(d)) = f32s {
            let rays = RayArrays::new(o, d, tmin, tmax, start);
            return cast_impl(py, scene, rays, &opts, audit, progress, |r, out, opts| {
                scene.cast_with(method, layout, r, out, opts)
            });
        }
        match (
            origins.extract::<PyReadonlyArray2<'py, f64>>(),
            directions.extract::<PyReadonlyArray2<'py, f64>>(),
        ) {
            (Ok(o), Ok(d)) => {
                let rays = RayArrays::new(o, d, tmin, tmax, start);
                cast_impl(py, scene, rays, &opts, audit, progress, |r, out, opts| {
                    scene.cast_with(method, layout, r, out, opts)
                })
            }
            _ => Err(pyo3::exceptions::PyTypeError::new_err(
                "origins and directions must be 2-D arrays, both float32 or both float64",
            )),
        }
    }

    /// Any hit (occlusion) per ray: status HIT when a scene triangle lies on the ray within
    /// [tmin, tmax], else MISS (FAILED, INVALID as for casts). Arguments as for `cast`.
    #[pyo3(signature = (origins, directions, tmin, tmax, threads=None, max_steps=None, method=None, layout=None, packet=true, accel=None, start=None, progress=None))]
    #[allow(clippy::too_many_arguments)] // a Python signature: keyword arguments, not a design
    fn occluded<'py>(
        &self,
        py: Python<'py>,
        origins: &Bound<'py, PyAny>,
        directions: &Bound<'py, PyAny>,
        tmin: PyReadonlyArray1<'py, f64>,
        tmax: PyReadonlyArray1<'py, f64>,
        threads: Option<usize>,
        max_steps: Option<u32>,
        method: Option<MethodArg>,
        layout: Option<LayoutArg>,
        packet: bool,
        accel: Option<AccelArg>,
        start: Option<StartArrays<'py>>,
        progress: Option<Py<PyAny>>,
    ) -> PyResult<Bound<'py, numpy::PyArray1<u8>>> {
        let job = Occluded {
            method: method.map_or(Method::DEFAULT, |m| m.0),
            layout: layout.map_or(LayoutKind::DEFAULT, |l| l.0),
        };
        let opts = cast_options(threads, max_steps, packet, accel);
        let bounds = (tmin, tmax);
        let out = query_rays(
            py,
            &self.loaded().scene,
            (origins, directions),
            bounds,
            (start, progress),
            &opts,
            job,
        )?;
        Ok(out.into_pyarray(py))
    }

    /// Every point where each ray meets the surface in [tmin, tmax] (the exact walk): a dict
    /// of flat arrays "offsets" (N + 1), "t", "triangle", "u", "v", "point" (M, 3) sorted by
    /// exact t within each ray (each value within a float64 ulp of the exact one), and
    /// "status" (N). `method` must be None or "exact"; `layout` is ignored.
    #[pyo3(signature = (origins, directions, tmin, tmax, threads=None, max_steps=None, method=None, layout=None, packet=true, accel=None, start=None, progress=None))]
    #[allow(clippy::too_many_arguments)] // a Python signature: keyword arguments, not a design
    fn intersections<'py>(
        &self,
        py: Python<'py>,
        origins: &Bound<'py, PyAny>,
        directions: &Bound<'py, PyAny>,
        tmin: PyReadonlyArray1<'py, f64>,
        tmax: PyReadonlyArray1<'py, f64>,
        threads: Option<usize>,
        max_steps: Option<u32>,
        method: Option<MethodArg>,
        layout: Option<LayoutArg>,
        packet: bool,
        accel: Option<AccelArg>,
        start: Option<StartArrays<'py>>,
        progress: Option<Py<PyAny>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let _ = layout;
        let opts = cast_options(threads, max_steps, packet, accel);
        let listed = all_hits(
            py,
            &self.loaded().scene,
            (origins, directions),
            (tmin, tmax),
            (start, progress),
            &opts,
            method,
        )?;
        let n = listed.len();
        let total: usize = listed.iter().map(|l| l.meets.len()).sum();
        let mut offsets = try_capacity(n + 1, "the offsets of the intersections")?;
        let what = "the intersections";
        let (mut t, mut tri, mut u, mut v) = (
            try_capacity(total, what)?,
            try_capacity(total, what)?,
            try_capacity(total, what)?,
            try_capacity(total, what)?,
        );
        let mut point = try_capacity(3 * total, what)?;
        let mut status = try_capacity(n, "the statuses")?;
        offsets.push(0i64);
        for l in &listed {
            for m in &l.meets {
                t.push(m.t);
                tri.push(m.triangle as i32);
                u.push(m.u);
                v.push(m.v);
                point.extend(m.point);
            }
            offsets.push(t.len() as i64);
            status.push(l.status);
        }
        let out = PyDict::new(py);
        out.set_item("offsets", offsets.into_pyarray(py))?;
        out.set_item("t", t.into_pyarray(py))?;
        out.set_item("triangle", tri.into_pyarray(py))?;
        out.set_item("u", u.into_pyarray(py))?;
        out.set_item("v", v.into_pyarray(py))?;
        out.set_item("point", point.into_pyarray(py).reshape([total, 3])?)?;
        out.set_item("status", status.into_pyarray(py))?;
        Ok(out)
    }

    /// The number of points where each ray meets the surface in [tmin, tmax] (as
    /// `intersections`): a dict of "count" (int32, N) and "status" (N).
    #[pyo3(signature = (origins, directions, tmin, tmax, threads=None, max_steps=None, method=None, layout=None, packet=true, accel=None, start=None, progress=None))]
    #[allow(clippy::too_many_arguments)] // a Python signature: keyword arguments, not a design
    fn count_intersections<'py>(
        &self,
        py: Python<'py>,
        origins: &Bound<'py, PyAny>,
        directions: &Bound<'py, PyAny>,
        tmin: PyReadonlyArray1<'py, f64>,
        tmax: PyReadonlyArray1<'py, f64>,
        threads: Option<usize>,
        max_steps: Option<u32>,
        method: Option<MethodArg>,
        layout: Option<LayoutArg>,
        packet: bool,
        accel: Option<AccelArg>,
        start: Option<StartArrays<'py>>,
        progress: Option<Py<PyAny>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let _ = layout;
        let opts = cast_options(threads, max_steps, packet, accel);
        let listed = all_hits(
            py,
            &self.loaded().scene,
            (origins, directions),
            (tmin, tmax),
            (start, progress),
            &opts,
            method,
        )?;
        let count: Vec<i32> = listed.iter().map(|l| l.meets.len() as i32).collect();
        let status: Vec<u8> = listed.iter().map(|l| l.status).collect();
        let out = PyDict::new(py);
        out.set_item("count", count.into_pyarray(py))?;
        out.set_item("status", status.into_pyarray(py))?;
        Ok(out)
    }

    /// Casts float32 rays on the GPU (start location and hits on the CPU, the walk on the
    /// device). Returns the Hits fields and the seconds of each phase.
    #[pyo3(signature = (origins, directions, tmin, tmax, threads=None, max_steps=None, method=None, layout=None))]
    #[allow(clippy::too_many_arguments)] // a Python signature: keyword arguments, not a design
    fn cast_gpu<'py>(
        &self,
        py: Python<'py>,
        origins: PyReadonlyArray2<'py, f32>,
        directions: PyReadonlyArray2<'py, f32>,
        tmin: PyReadonlyArray1<'py, f64>,
        tmax: PyReadonlyArray1<'py, f64>,
        threads: Option<usize>,
        max_steps: Option<u32>,
        method: Option<MethodArg>,
        layout: Option<LayoutArg>,
    ) -> PyResult<(Bound<'py, PyDict>, Bound<'py, PyDict>)> {
        #[cfg(not(feature = "gpu"))]
        {
            let _ = (py, origins, directions, tmin, tmax, threads, max_steps);
            let _ = (method, layout);
            Err(super::gpu::not_built())
        }
        #[cfg(feature = "gpu")]
        {
            let loaded = self.loaded();
            let scene = &loaded.scene;
            let opts = CastOptions {
                threads,
                max_steps,
                ..Default::default()
            };
            let (method, layout) = (method.map(|m| m.0.name()), layout.map(|l| l.0.name()));
            let mut timings = crate::gpu::GpuTimings::default();
            let rays = RayArrays::new(origins, directions, tmin, tmax, None);
            let hits = cast_impl(py, scene, rays, &opts, false, None, |r, out, opts| {
                timings = loaded.device.cast(scene, method, layout, r, out, opts)?;
                Ok(())
            })?;
            Ok((hits, super::gpu::timings_dict(py, &timings)?))
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
        threads: Option<usize>,
    ) -> PyResult<Bound<'py, PyArray1<bool>>> {
        if let Ok(p) = points.extract::<PyReadonlyArray2<'py, f32>>() {
            return contains_impl(py, &self.loaded().scene, p, threads);
        }
        if let Ok(p) = points.extract::<PyReadonlyArray2<'py, f64>>() {
            return contains_impl(py, &self.loaded().scene, p, threads);
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

    /// The scene's point nearest each row of `points` ((N, 3) float64, finite), found on the
    /// BVH: a dict of "point" (N, 3), "triangle" (N,) int32 (-1: the scene has none), "u",
    /// "v" (barycentrics of the triangle's second and third corners) and "distance".
    #[pyo3(signature = (points, threads=None))]
    fn closest_points<'py>(
        &self,
        py: Python<'py>,
        points: PyReadonlyArray2<'py, f64>,
        threads: Option<usize>,
    ) -> PyResult<Bound<'py, PyDict>> {
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
    #[pyo3(signature = (cost_ratio=1.0, max_leaf=8, bins=16, aperture=true))]
    fn build_bvh<'py>(
        &self,
        py: Python<'py>,
        cost_ratio: f64,
        max_leaf: u32,
        bins: u32,
        aperture: bool,
    ) -> PyResult<Bound<'py, PyDict>> {
        let params = BvhParams {
            cost_ratio,
            max_leaf,
            bins,
            aperture,
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

    /// Builds Portalez & Duguet's octree with these parameters for the casts that follow;
    /// returns what `octree_info` returns.
    #[pyo3(signature = (max_depth=8, leaf_size=12, balance=true))]
    fn build_octree<'py>(
        &self,
        py: Python<'py>,
        max_depth: u32,
        leaf_size: u32,
        balance: bool,
    ) -> PyResult<Bound<'py, PyDict>> {
        let params = OctreeParams {
            max_depth,
            leaf_size,
            balance,
        };
        let octree = py.detach(|| guarded(|| self.loaded().scene.build_octree(params)))?;
        octree_info(py, &octree)
    }

    /// The octree's statistics and bytes per part, or None when none is built.
    fn octree_info<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        self.loaded()
            .scene
            .octree
            .get()
            .map(|o| octree_info(py, &o))
            .transpose()
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
        let tri: Vec<[[f64; 3]; 3]> = rows::<f64, 9>(slice(&triangles, "triangles")?)
            .into_iter()
            .map(|r| [[r[0], r[1], r[2]], [r[3], r[4], r[5]], [r[6], r[7], r[8]]])
            .collect();
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
                        *target = Loaded::new(scene);
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
    let mut out = try_vec(n, false, "the answers of contains")?;
    interruptible(py, || scene.contains(p, &mut out, threads))?;
    Ok(out.into_pyarray(py))
}

/// Per ray, the hit a ray starts from (`start=hits`): the caller's triangle it leaves and the
/// tet that hit's walk ended in, −1 for none.
type StartArrays<'py> = (PyReadonlyArray1<'py, i32>, PyReadonlyArray1<'py, i32>);

/// A cast's ray arrays as numpy passed them.
struct RayArrays<'py, R: Element> {
    origins: PyReadonlyArray2<'py, R>,
    directions: PyReadonlyArray2<'py, R>,
    tmin: PyReadonlyArray1<'py, f64>,
    tmax: PyReadonlyArray1<'py, f64>,
    start: Option<StartArrays<'py>>,
}

impl<'py, R: Element + Real> RayArrays<'py, R> {
    fn new(
        origins: PyReadonlyArray2<'py, R>,
        directions: PyReadonlyArray2<'py, R>,
        tmin: PyReadonlyArray1<'py, f64>,
        tmax: PyReadonlyArray1<'py, f64>,
        start: Option<StartArrays<'py>>,
    ) -> Self {
        RayArrays {
            origins,
            directions,
            tmin,
            tmax,
            start,
        }
    }

    /// The rays as slices over `scene` (the number of rays, checked against the directions).
    fn slices<'a>(&'a self, scene: &'a Scene) -> PyResult<(usize, Rays<'a, R>)> {
        let n = check_cols(&self.origins, 3, "origins")?;
        if check_cols(&self.directions, 3, "directions")? != n {
            return Err(PyValueError::new_err(
                "origins and directions must have the same number of rows",
            ));
        }
        let leaving = match &self.start {
            Some((triangle, tet)) => Some(LeavingRays {
                triangles: &scene.surface.triangles,
                triangle: slice(triangle, "start triangles")?,
                tet: slice(tet, "start tets")?,
            }),
            None => None,
        };
        let rays = Rays {
            origins: slice(&self.origins, "origins")?,
            directions: slice(&self.directions, "directions")?,
            tmin: slice(&self.tmin, "tmin")?,
            tmax: slice(&self.tmax, "tmax")?,
            leaving,
        };
        Ok((n, rays))
    }
}

/// Validates, allocates the outputs (with `audit`, two counts per ray), runs `cast` with the
/// GIL released, returns the fields (the vectors become numpy arrays without a copy).
fn cast_impl<'py, R: Real + Element>(
    py: Python<'py>,
    scene: &Scene,
    rays: RayArrays<'py, R>,
    opts: &CastOptions,
    audit: bool,
    progress: Option<Py<PyAny>>,
    cast: impl FnOnce(&Rays<R>, HitsOut<R>, &CastOptions) -> crate::Result<()> + Send,
) -> PyResult<Bound<'py, PyDict>> {
    let (n, rays) = rays.slices(scene)?;
    opts.check()?;
    let mut buffers = HitBuffers::<R>::try_new(n, audit)?;
    interruptible_with_progress(py, progress, || cast(&rays, buffers.out(), opts))?;
    let out = PyDict::new(py);
    out.set_item("t", buffers.t.into_pyarray(py))?;
    out.set_item("u", buffers.u.into_pyarray(py))?;
    out.set_item("v", buffers.v.into_pyarray(py))?;
    out.set_item("point", buffers.point.into_pyarray(py).reshape([n, 3])?)?;
    out.set_item("triangle", buffers.triangle.into_pyarray(py))?;
    out.set_item("tet", buffers.tet.into_pyarray(py))?;
    out.set_item("steps", buffers.steps.into_pyarray(py))?;
    out.set_item("status", buffers.status.into_pyarray(py))?;
    if audit {
        out.set_item("audit", buffers.audit.into_pyarray(py).reshape([n, 2])?)?;
    }
    Ok(out)
}

/// An empty vector with room for `n`, or `MemoryError` naming `what` and the bytes.
fn try_capacity<T>(n: usize, what: &str) -> crate::Result<Vec<T>> {
    let mut v = Vec::new();
    v.try_reserve_exact(n)
        .map_err(|_| crate::Error::OutOfMemory {
            bytes: n.saturating_mul(std::mem::size_of::<T>()),
            what: what.to_string(),
        })?;
    Ok(v)
}

/// A query over rays of either precision: what the query bindings share.
trait RayQuery: Sync {
    type Out: Send;
    fn output(&self, n: usize) -> crate::Result<Self::Out>;
    fn run<R: Real>(
        &self,
        scene: &Scene,
        rays: &Rays<R>,
        out: &mut Self::Out,
        opts: &CastOptions,
    ) -> crate::Result<()>;
}

struct Occluded {
    method: Method,
    layout: LayoutKind,
}

impl RayQuery for Occluded {
    type Out = Vec<u8>;
    fn output(&self, n: usize) -> crate::Result<Vec<u8>> {
        try_vec(n, 0, "the answers of occluded")
    }
    fn run<R: Real>(
        &self,
        scene: &Scene,
        rays: &Rays<R>,
        out: &mut Vec<u8>,
        opts: &CastOptions,
    ) -> crate::Result<()> {
        scene.occluded(self.method, self.layout, rays, out, opts)
    }
}

struct AllHitsJob;

impl RayQuery for AllHitsJob {
    type Out = Vec<Listed>;
    fn output(&self, n: usize) -> crate::Result<Vec<Listed>> {
        try_vec(n, Listed::default(), "the hits of each ray")
    }
    fn run<R: Real>(
        &self,
        scene: &Scene,
        rays: &Rays<R>,
        out: &mut Vec<Listed>,
        opts: &CastOptions,
    ) -> crate::Result<()> {
        scene.intersections(rays, out, opts)
    }
}

/// The options the bindings share (`packet=False`: never walk rays as packets; `accel`: None
/// for the tet walk).
fn cast_options(
    threads: Option<usize>,
    max_steps: Option<u32>,
    packet: bool,
    accel: Option<AccelArg>,
) -> CastOptions {
    CastOptions {
        threads,
        max_steps,
        packets: if packet { Packets::Auto } else { Packets::Off },
        accel: accel.map_or(AccelKind::TetWalk, |a| a.0),
        ..Default::default()
    }
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

fn all_hits<'py>(
    py: Python<'py>,
    scene: &Scene,
    (origins, directions): (&Bound<'py, PyAny>, &Bound<'py, PyAny>),
    (tmin, tmax): (PyReadonlyArray1<'py, f64>, PyReadonlyArray1<'py, f64>),
    (start, progress): (Option<StartArrays<'py>>, Option<Py<PyAny>>),
    opts: &CastOptions,
    method: Option<MethodArg>,
) -> PyResult<Vec<Listed>> {
    if let Some(m) = method {
        if m.0 != Method::Exact {
            return Err(PyValueError::new_err(format!(
                "all hits and counts need the exact method, not {:?}",
                m.0.name()
            )));
        }
    }
    query_rays(
        py,
        scene,
        (origins, directions),
        (tmin, tmax),
        (start, progress),
        opts,
        AllHitsJob,
    )
}

/// Validates rays of either precision and runs `query` with the GIL released.
fn query_rays<'py, Q: RayQuery>(
    py: Python<'py>,
    scene: &Scene,
    (origins, directions): (&Bound<'py, PyAny>, &Bound<'py, PyAny>),
    (tmin, tmax): (PyReadonlyArray1<'py, f64>, PyReadonlyArray1<'py, f64>),
    (start, progress): (Option<StartArrays<'py>>, Option<Py<PyAny>>),
    opts: &CastOptions,
    query: Q,
) -> PyResult<Q::Out> {
    fn go<'py, R: Real + Element, Q: RayQuery>(
        py: Python<'py>,
        scene: &Scene,
        rays: RayArrays<'py, R>,
        progress: Option<Py<PyAny>>,
        opts: &CastOptions,
        query: Q,
    ) -> PyResult<Q::Out> {
        let (n, rays) = rays.slices(scene)?;
        opts.check()?;
        let mut out = query.output(n)?;
        interruptible_with_progress(py, progress, || query.run(scene, &rays, &mut out, opts))?;
        Ok(out)
    }
    if let (Ok(o), Ok(d)) = (
        origins.extract::<PyReadonlyArray2<'py, f32>>(),
        directions.extract::<PyReadonlyArray2<'py, f32>>(),
    ) {
        return go(
            py,
            scene,
            RayArrays::new(o, d, tmin, tmax, start),
            progress,
            opts,
            query,
        );
    }
    match (
        origins.extract::<PyReadonlyArray2<'py, f64>>(),
        directions.extract::<PyReadonlyArray2<'py, f64>>(),
    ) {
        (Ok(o), Ok(d)) => go(
            py,
            scene,
            RayArrays::new(o, d, tmin, tmax, start),
            progress,
            opts,
            query,
        ),
        _ => Err(pyo3::exceptions::PyTypeError::new_err(
            "origins and directions must be 2-D arrays, both float32 or both float64",
        )),
    }
}
