"""The user-facing scene: a constrained tetrahedralization ready to cast rays through."""

from __future__ import annotations

import time
from functools import lru_cache
from importlib import resources

import numpy as np

from . import _native
from .hits import HIT, Hits
from .rays import prepare_bounds, prepare_rays, raise_invalid

__all__ = [
    "Scene",
    "cast",
    "measure_accuracy",
    "default_scene",
    "default_scene_path",
    "methods",
    "layouts",
    "LAYOUT_BYTES",
]

#: Bytes per tet of each layout's record.
LAYOUT_BYTES = dict(_native.layouts())


def methods():
    """Return the names of the exit-face methods, in the order of the papers.

    Returns
    -------
    list of str
    """
    return list(_native.methods())


def layouts():
    """Return the names of the tet layouts (bytes per tet in :data:`LAYOUT_BYTES`).

    Returns
    -------
    list of str
    """
    return list(LAYOUT_BYTES)


class Scene:
    """A triangle scene tetrahedralized for ray casting.

    Build one with :meth:`Scene.from_mesh`; cast with :meth:`Scene.cast`.

    Attributes
    ----------
    tetrahedralization : tetrace.mesh.Tetrahedralization
        What the mesher produced (points, tets, constrained faces, timings).
    vertices, faces : numpy.ndarray
        The caller's mesh, as given: hit ``triangle`` ids index ``faces``.
    build_times : dict
        Seconds spent in each build stage: ``clean``, ``repair``, ``mesher`` (TetGen or fTetWild),
        ``rust`` (topology, locator and layout construction), ``total``; see
        :class:`tetrace.mesh.Tetrahedralization` for the mesher's (``tetgen``,
        ``ftetwild``, ``recover``, ``mesher``).
    """

    def __init__(self, tetrahedralization, vertices, faces, *, hilbert=True):
        self.tetrahedralization = tet = tetrahedralization
        self.vertices = vertices
        self.faces = faces
        triangles = np.ascontiguousarray(vertices[faces], dtype=np.float64)
        t0 = time.perf_counter()
        # fTetWild's faces lie near the input, not on it: let hits name the neighbour of a
        # face's triangle that the ray crosses (see tetrace.mesh.neighbour_triangles).
        alternatives = None
        if getattr(tet, "mesher", "tetgen") == "ftetwild":
            from .mesh.ftetwild import neighbour_triangles

            alternatives = neighbour_triangles(tet.clean, len(faces))
        self._native = _native.NativeScene(
            np.ascontiguousarray(tet.points, dtype=np.float64),
            np.ascontiguousarray(tet.tets, dtype=np.uint32),
            np.ascontiguousarray(tet.faces, dtype=np.uint32).reshape(-1, 3),
            np.ascontiguousarray(tet.face_triangle, dtype=np.uint32),
            triangles,
            hilbert=bool(hilbert),
            alternatives=alternatives,
        )
        self.hilbert = bool(hilbert)
        #: dict or None: seconds of each phase of the last GPU cast (``locate``,
        #: ``scene_upload``, ``upload``, ``kernel``, ``readback``, ``finish``) and counts
        #: (``walked``: rays the GPU walked, ``deferred``: robust rays re-walked on the CPU,
        #: ``batches``).
        self.gpu_timings = None
        rust = time.perf_counter() - t0
        self.build_times = dict(tet.timings)
        self.build_times["rust"] = rust
        self.build_times["total"] = tet.timings.get("total", 0.0) + rust

    @classmethod
    def from_mesh(
        cls,
        mesh,
        preset="quality",
        *,
        mesher="tetgen",
        margin=0.02,
        contain=None,
        minratio=None,
        maxvolume=None,
        sizing=None,
        repair="auto",
        epsilon=None,
        edge_length=None,
        timeout=None,
        accuracy=None,
        hilbert=True,
    ):
        """Tetrahedralize a triangle scene.

        Parameters
        ----------
        mesh : trimesh.Trimesh or str or os.PathLike or tuple
            A mesh, a file trimesh can load, or ``(vertices (V, 3), faces (F, 3))``.
            Non-watertight, multi-component and self-intersecting scenes are accepted.
        preset : str
            TetGen settings (``tetrace.mesh.PRESETS``): ``"quality"`` (radius-edge
            bound 5, the default), ``"quality3"``, ``"quality2"``, ``"quality1.5"`` or any
            ``"quality<r>"`` (tighter bounds, more tets), ``"constrained"`` (constrained
            Delaunay without refinement, fewest tets, more tets per ray), ``"graded"``
            (quality plus tets that grow away from the surface).
        mesher : {"tetgen", "ftetwild", "fallback", "auto"}
            ``"tetgen"``: exact, hits name the caller's triangles exactly. ``"ftetwild"``:
            fTetWild (``pip install 'pytetwild<0.3'``) remeshes the surface within
            ``epsilon`` of the input, for scenes TetGen cannot take; each hit names the
            triangle, of the one nearest to the face it crossed and its neighbours, that
            the ray crosses nearest the face. ``"fallback"``: TetGen, then
            fTetWild if it fails (``tetrahedralization.attempts`` says why). ``"auto"``:
            the setting with the fewest tets among those that meet ``accuracy`` at a
            near-lowest weight (total face area, which predicts time);
            ``tetrahedralization.auto`` lists every candidate.
        margin : float
            Domain box margin as a fraction of the scene's bounding-box diagonal.
        contain : array_like, optional
            ``(N, 3)`` points (e.g. ray origins or a camera position) the domain must contain.
            Rays may start anywhere regardless; starting inside avoids locating the entry.
        minratio, maxvolume : float, optional
            Override the preset's TetGen radius-edge bound and maximum tet volume.
        sizing : (float, float), optional
            ``(h0, growth)``: tets grow from ``h0`` x diagonal at the surface by ``growth``
            per unit distance (TetGen).
        repair : {"auto", True, False}
            Resolve self-intersections exactly (libigl/CGAL) when TetGen cannot mesh the
            scene, snap-rounding if that is not enough.
        epsilon, edge_length : float, optional
            fTetWild's envelope and target edge length, fractions of the diagonal
            (defaults ``1e-3`` and ``0.05``).
        timeout : float, optional
            Seconds each meshing stage may run (default: grows with the scene's size).
        accuracy : float, optional
            ``mesher="auto"``: the fraction of random rays that must agree with Embree on
            the input mesh (default 0.999).
        hilbert : bool
            Renumber points along a Hilbert curve and tets by region, then along the curve
            (Aman et al. 2022), for memory locality; False keeps the mesher's order (to measure
            the effect).

        Returns
        -------
        Scene

        Raises
        ------
        tetrace.MeshingError
            The scene cannot be meshed; the message names the stage and the cause.
        """
        from .mesh import FTETWILD_EDGE_LENGTH, FTETWILD_EPSILON, load_triangles, tetrahedralize

        vertices, faces = load_triangles(mesh)
        tet = tetrahedralize(
            (vertices, faces),
            preset,
            mesher=mesher,
            margin=margin,
            contain=contain,
            minratio=minratio,
            maxvolume=maxvolume,
            sizing=sizing,
            repair=repair,
            epsilon=FTETWILD_EPSILON if epsilon is None else epsilon,
            edge_length=FTETWILD_EDGE_LENGTH if edge_length is None else edge_length,
            timeout=timeout,
            accuracy=accuracy,
            measure=measure_accuracy,
        )
        return cls(tet, vertices, faces, hilbert=hilbert)

    def cast(
        self,
        origins,
        directions=None,
        *,
        tmin=0.0,
        tmax=np.inf,
        threads=None,
        max_steps=None,
        invalid="raise",
        method=None,
        layout=None,
        precision=None,
        device="cpu",
    ):
        """Cast rays and return their closest hits.

        Parameters
        ----------
        origins : array_like
            ``(N, 3)`` ray origins (or one ``(3,)`` origin shared by all rays), or ``(N, 6)``
            rays when ``directions`` is None. Origins may lie anywhere, inside or outside
            the domain.
        directions : array_like, optional
            ``(N, 3)`` directions, not necessarily unit length; ``t`` is in their units.
        tmin, tmax : float or array_like
            Only hits with ``tmin <= t <= tmax`` count (scalars or one value per ray).
        threads : int, optional
            Worker threads; None uses all cores. The GIL is released while casting.
        max_steps : int, optional
            Guard on tets visited per ray; a ray that reaches it is reported FAILED.
        invalid : {"raise", "mark"}
            Rays with NaN/inf components or zero directions raise ``ValueError``, or with
            ``"mark"`` come back with status ``INVALID``.
        method : str, optional
            Exit-face method, one of :func:`tetrace.methods` (default: the fastest robust one).
        layout : str, optional
            Tet layout, one of :func:`tetrace.layouts`; built on first use.
        precision : {"f32", "f64"}, optional
            Precision of the walk; default: float32 for float32 rays, float64 otherwise.
            Rays are converted when it differs.
        device : {"cpu", "gpu", "auto"}
            Where the walk runs. ``"gpu"``: on the GPU (:mod:`tetrace.gpu`), in float32:
            float64 rays are rounded to float32 and ``precision="f64"`` is refused; method
            and layout must name a GPU kernel (:func:`tetrace.gpu.kernels`; by default
            ``aman2022`` on ``tet20``). Start location and the hit on your triangle stay on
            the CPU. ``"auto"``: the GPU when a device opens, the walk is float32 and a kernel
            exists for the method and layout, else the CPU.

        Returns
        -------
        Hits
            Fields in the walk's precision (hit ``t``, ``u``, ``v`` are evaluated in float64
            on the caller's triangle, then rounded). After a GPU cast, :attr:`gpu_timings`
            holds the seconds of each phase.

        Raises
        ------
        tetrace.gpu.GpuError
            ``device="gpu"`` without a usable adapter, or the device failed.
        """
        o, d = prepare_rays(origins, directions, invalid=invalid)
        if precision is not None:
            if precision not in ("f32", "f64"):
                raise ValueError(f'precision must be "f32" or "f64", got {precision!r}')
            want = np.float32 if precision == "f32" else np.float64
            o, d = o.astype(want, copy=False), d.astype(want, copy=False)
        if device not in ("cpu", "gpu", "auto"):
            raise ValueError(f'device must be "cpu", "gpu" or "auto", got {device!r}')
        for what, value in (("method", method), ("layout", layout)):
            if value is not None and not isinstance(value, str):
                raise TypeError(f"{what} must be a name (str), got {type(value).__name__}")
        use_gpu = False
        if device == "gpu":
            if precision == "f64":
                raise ValueError(
                    'device="gpu" walks in float32 (WGSL has no float64); use '
                    'precision="f32" or device="cpu"'
                )
            use_gpu = True
        elif device == "auto" and o.dtype == np.float32:
            from . import gpu

            use_gpu = gpu.kernel_for(method, layout) is not None and gpu.available()
        if not use_gpu:
            method = _native.DEFAULT_METHOD if method is None else method
            layout = _native.DEFAULT_LAYOUT if layout is None else layout
        n = len(o)
        lo = prepare_bounds(tmin, n, "tmin")
        hi = prepare_bounds(tmax, n, "tmax")
        if threads is not None and (not isinstance(threads, (int, np.integer)) or threads < 1):
            raise ValueError(f"threads must be a positive int or None, got {threads!r}")
        if max_steps is not None and (
            not isinstance(max_steps, (int, np.integer)) or not 0 < max_steps < 2**32
        ):
            raise ValueError(f"max_steps must be a positive int below 2**32, got {max_steps!r}")
        if use_gpu:
            o, d = o.astype(np.float32, copy=False), d.astype(np.float32, copy=False)
            r, self.gpu_timings = self._native.cast_gpu(
                o, d, lo, hi, threads, max_steps, method, layout
            )
        else:
            r = self._native.cast(o, d, lo, hi, threads, max_steps, method, layout)
        if invalid == "raise":
            raise_invalid(r["status"], o, d)
        return Hits(**r)

    def _cast_audited(
        self,
        origins,
        directions,
        *,
        tmin=0.0,
        tmax=np.inf,
        method=None,
        layout=None,
        precision="f64",
        threads=None,
        max_steps=None,
    ):
        """Cast with the exact per-step audit (``tetrace.dev.stress.audited_cast``): the Hits
        and, per ray, ``(N, 2)`` uint32 counts of exit faces the exact predicates reject and
        of steps where the method found no exit face."""
        dt = np.float32 if precision == "f32" else np.float64
        o = np.ascontiguousarray(origins, dtype=dt)
        d = np.ascontiguousarray(directions, dtype=dt)
        n = len(o)
        r = self._native.cast(
            o,
            d,
            prepare_bounds(tmin, n, "tmin"),
            prepare_bounds(tmax, n, "tmax"),
            threads=threads,
            max_steps=max_steps,
            method=method,
            layout=layout,
            audit=True,
        )
        audit = r.pop("audit")
        return Hits(**r), audit

    @property
    def n_tets(self):
        """int : Tetrahedra in the tetrahedralization."""
        return self._native.n_tets

    @property
    def n_points(self):
        """int : Points of the tetrahedralization (scene vertices, box corners, Steiner points)."""
        return self._native.n_points

    @property
    def n_triangles(self):
        """int : Triangles of the caller's mesh."""
        return len(self.faces)

    @property
    def domain(self):
        """numpy.ndarray : ``(2, 3)`` lower and upper corners of the domain box."""
        return np.array(self._native.bounds)

    @property
    def bytes_per_tet(self):
        """int : Bytes per tet of the default traversal layout (points excluded)."""
        return LAYOUT_BYTES[_native.DEFAULT_LAYOUT]

    def prepare_layout(self, layout):
        """Build a traversal layout now rather than at its first cast.

        Returns
        -------
        int
            Bytes of its records.

        Raises
        ------
        tetrace.TooLargeError
            The mesh exceeds the layout's limits (e.g. tet16's 24-bit links).
        """
        return self._native.prepare_layout(layout)

    def memory(self):
        """Bytes used by each part of the traversal structure.

        Returns
        -------
        dict
            ``points_f64``, ``points_f32``, ``constrained`` (constrained-side table),
            ``locator`` (seed grid, boundary grid, location topology),
            ``tets_<layout>`` for each layout built so far, and ``gpu_<layout>`` for each
            layout's buffers on the GPU (records, and float32 points for tet20).
        """
        return dict(self._native.memory())

    def tets(self):
        """Return the positively oriented tets, ``(T, 4)`` uint32 indices into ``points()``.

        ``Hits.tet`` indexes these rows. Points and tets are renumbered along a Hilbert
        curve at build time, so they differ in order from ``tetrahedralization``.
        """
        return self._native.tets()

    def points(self):
        """Return the ``(P, 3)`` float64 points, in the order ``tets()`` indexes."""
        return self._native.points()

    def __repr__(self):
        tz = self.tetrahedralization
        return (
            f"Scene({self.n_triangles} triangles, {self.n_tets} tets, {self.n_points} points, "
            f"mesher={getattr(tz, 'mesher', 'tetgen')!r}, preset={tz.preset!r})"
        )


def default_scene_path():
    """Return the path of the bundled default scene (Keenan Crane's Spot, CC0)."""
    return resources.files("tetrace").joinpath("data", "spot.obj")


@lru_cache(maxsize=1)
def default_scene():
    """Return the bundled default scene, built once per process with the default preset."""
    return Scene.from_mesh(str(default_scene_path()))


def cast(rays, scene=None, **kwargs):
    """Cast rays through a scene.

    Parameters
    ----------
    rays : array_like or tuple
        ``(N, 6)`` rays ``[ox, oy, oz, dx, dy, dz]`` or an ``(origins, directions)`` tuple.
    scene : Scene or mesh or path, optional
        A built :class:`Scene`, or anything :meth:`Scene.from_mesh` takes; None casts into
        the bundled default scene.
    **kwargs
        Passed to :meth:`Scene.cast` (``tmin``, ``tmax``, ``threads``, ...).

    Returns
    -------
    Hits
    """
    if scene is None:
        scene = default_scene()
    elif not isinstance(scene, Scene):
        scene = Scene.from_mesh(scene)
    if isinstance(rays, tuple):
        if len(rays) != 2:
            raise ValueError("rays given as a tuple must be (origins, directions)")
        return scene.cast(rays[0], rays[1], **kwargs)
    return scene.cast(rays, **kwargs)


def measure_accuracy(
    tetrahedralization, vertices, faces, *, rays=20_000, seed=0, hit_distance=1e-3
):
    """Fraction of random rays on which a tetrahedralization agrees with Embree.

    Parameters
    ----------
    tetrahedralization : tetrace.mesh.Tetrahedralization
    vertices, faces : numpy.ndarray
        The caller's mesh, which ``tetrahedralization`` was built from.
    rays : int
        Random rays, origins uniform in the scene's box grown by a quarter of its size
        on each side, directions uniform on the sphere.
    seed : int
    hit_distance : float
        Hits on different triangles agree when the hit points are this close, as a
        fraction of the scene's diagonal (``tetrace.mesh.auto.HIT_DISTANCE``: fTetWild's
        surface lies within its envelope of the input).

    Returns
    -------
    float
        Rays with the same outcome as Embree (both miss, or both hit the same triangle
        or points within ``hit_distance``), over all rays.

    Raises
    ------
    ImportError
        embreex is not installed.
    """
    from .baselines.embree import embree_scene
    from .dev.camera import random_rays

    v = np.asarray(vertices, np.float64)
    o, d = random_rays(np.array([v.min(0), v.max(0)]), int(rays), seed)
    hits = Scene(tetrahedralization, v, faces).cast(o, d, precision="f64")
    ref = embree_scene((v, faces)).cast(o, d)
    diagonal = float(np.linalg.norm(v.max(0) - v.min(0)))
    near = np.linalg.norm(hits.point - ref.point, axis=1) <= hit_distance * diagonal
    same = (hits.status == ref.status) & (
        (hits.status != HIT) | (hits.triangle == ref.triangle) | near
    )
    return float(same.mean())
