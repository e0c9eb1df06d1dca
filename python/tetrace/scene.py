"""The user-facing scene: a constrained tetrahedralization ready to cast rays through."""

from __future__ import annotations

import time
from importlib import resources

import numpy as np

from . import _native, construct, deform, gpu, persist, point_queries, scenefile
from .deform import Deformation
from .hits import FAILED, HIT, INVALID, Hits, Intersections
from .names import (  # noqa: F401  (the public names stay where they were: tetrace.scene.methods)
    LAYOUT_BYTES,
    MAX_THREADS,
    accels,
    layouts,
    methods,
    simd_levels,
)
from .rays import RayRequest, _check_threads, _query_points, documented

__all__ = [
    "Scene",
    "Deformation",
    "default_scene_path",
    "methods",
    "accels",
    "layouts",
    "LAYOUT_BYTES",
    "MAX_THREADS",
]


#: Each structure's default parameters, owned by the core (its structure table): the
#: signatures of :meth:`Scene.build_bvh` and :meth:`Scene.build_octree` read them.
_DEFAULTS = _native.structure_defaults()


class Scene:
    """A triangle scene tetrahedralized for ray casting.

    Build one with :meth:`Scene.from_mesh` (one mesh) or :meth:`Scene.from_meshes`
    (several); cast with :meth:`Scene.cast` (closest hits), :meth:`Scene.occluded` (any
    hit), :meth:`Scene.intersections` (all hits), :meth:`Scene.count_intersections`;
    test points with :meth:`Scene.contains` (exact parity on a closed mesh, the generalized
    winding number on an open one: :attr:`Scene.is_closed`) and measure distances with
    :meth:`Scene.closest_points`, :meth:`Scene.distance`, :meth:`Scene.signed_distance`.

    The ray queries share one contract: a ray hits a triangle when it meets the closed
    triangle (edges and vertices included) at one point at ``t`` in ``[tmin, tmax]``; a
    ray in a triangle's plane never hits it; each point where a ray meets the surface
    counts once, even at an edge or vertex that triangles share.

    Attributes
    ----------
    tetrahedralization : tetrace.mesh.Tetrahedralization
        What the mesher produced (points, tets, constrained faces, timings); meshed when
        first needed (:meth:`build_ct`).
    vertices, faces : numpy.ndarray
        The caller's mesh, as given (a :meth:`from_meshes` scene: the meshes
        concatenated in order): hit ``scene_triangle`` ids index ``faces``.
    geometries : tetrace.meshes.Geometries or None
        Where each mesh of a :meth:`from_meshes` scene sits in ``faces``; None for one mesh.
    build_times : dict
        Seconds per build stage: ``clean``, ``repair``, ``mesher`` and its parts
        (:class:`tetrace.mesh.Tetrahedralization`), ``rust`` (the core's build), ``total``.
    """

    def __init__(self, tetrahedralization, vertices, faces, *, hilbert=True):
        self._setup(vertices, faces, hilbert)
        self._install_ct(tetrahedralization)

    def _setup(self, vertices, faces, hilbert):
        """The state every scene has, with or without its tetrahedralization."""
        self.vertices = vertices
        self.faces = faces
        #: tetrace.meshes.Geometries or None: the meshes of a :meth:`from_meshes` scene
        #: (None: one mesh).
        self.geometries = None
        self._normals = None
        # The cleaned mesh's edge census (point_queries.surface_info), and whether
        # contains(mode="parity") has warned that the mesh is open.
        self._surface = None
        self._parity_warned = False
        self.hilbert = bool(hilbert)
        #: Deformation or None: what the last :meth:`update_vertices` did.
        self.last_deformation = None
        # The options from_mesh was given (a rebuild meshes with them), how the CT's points
        # follow the vertices (built by the first update) and updates since the last build.
        self._build_options: dict = {}
        self._point_map = None
        self._frames = 0
        # (tetrahedralization, vertices) as last built, once a move has replaced them: the
        # point map and a saved scene start from it.
        self._rest = None
        # The tetrahedralization, or None until a query needs it (from_mesh's lazy=True),
        # and the name its meshing reports.
        self._tet = None
        self._mesh_name = None

    def _install_ct(self, tet):
        """Make ``tet`` the scene's tetrahedralization and its core the scene's, keeping the
        BVHs and octree a core without it had built (over the same triangles: shared)."""
        t0 = time.perf_counter()
        native = construct.native_scene(tet, self.vertices, self.faces, self.hilbert)
        old = self.__dict__.get("_native")
        if old is not None:
            native.adopt_structures(old)
        rust = time.perf_counter() - t0
        self._native, self._tet = native, tet
        self.build_times = dict(tet.timings)
        self.build_times["rust"] = rust
        self.build_times["total"] = tet.timings.get("total", 0.0) + rust

    @classmethod
    def _without_ct(cls, vertices, faces, options, hilbert, name):
        """A scene of the caller's triangles alone, in the domain box ``options`` give; its
        tetrahedralization is built by the first query that needs one (:meth:`build_ct`)."""
        scene = cls.__new__(cls)
        scene._setup(vertices, faces, hilbert)
        scene._build_options = options
        scene._mesh_name = name
        t0 = time.perf_counter()
        scene._native = construct.surface_scene(vertices, faces, options)
        rust = time.perf_counter() - t0
        scene.build_times = {"rust": rust, "total": rust}
        return scene

    @property
    def tetrahedralization(self):
        """tetrace.mesh.Tetrahedralization : What the mesher produced (points, tets,
        constrained faces, timings); built now if the scene has none yet
        (:meth:`build_ct`)."""
        self.build_ct()
        return self._tet

    @tetrahedralization.setter
    def tetrahedralization(self, tet):
        self._tet = tet

    @property
    def has_ct(self):
        """bool : Whether the tetrahedralization is built (:meth:`from_mesh` leaves it to
        the first query that walks tets, or to :meth:`build_ct`)."""
        return self._tet is not None

    def build_ct(self, progress=None):
        """Build the constrained tetrahedralization now, if the scene has none yet.

        :meth:`from_mesh` builds only what CPU queries need (the exact BVH, at the first
        cast); the tetrahedralization is meshed when something walks tets: a cast with
        ``accel="tetwalk"``, a paper's ``method``, a ``layout``, ``max_steps`` or
        ``device="gpu"``, ``contains(mode="parity")`` on a surface that is not closed (or
        for a point no ray decides), and the tetrahedralization's own attributes
        (:attr:`n_tets`, :meth:`tets`, ...). It is meshed with the options :meth:`from_mesh`
        was given, from the vertices as they are then (:meth:`update_vertices` before it
        moves the triangles alone).

        Parameters
        ----------
        progress : bool, optional
            A status line per meshing stage on stderr (:meth:`from_mesh`'s ``progress``).

        Returns
        -------
        Scene
            This scene.

        Raises
        ------
        tetrace.MeshingError
            The scene cannot be meshed; the scene stays as it was (its queries that need no
            tetrahedralization still answer).
        """
        if self._tet is None:
            construct.build_ct(self, progress)
        return self

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
        progress=None,
        lazy=True,
    ):
        """A triangle scene, ready for ray queries; tetrahedralized when first needed.

        Parameters
        ----------
        mesh : trimesh.Trimesh or trimesh.Scene or str or os.PathLike or tuple or numpy.ndarray
            A mesh, a file trimesh can load, ``(vertices (V, 3), faces (F, 3))``, or a
            triangle soup ``(F, 3, 3)`` (identical corners are welded exactly; triangle
            ``i`` keeps id ``i``). Non-watertight, multi-component and self-intersecting
            scenes are accepted. A ``trimesh.Scene`` (what ``trimesh.load`` returns for a
            file of several objects) is :meth:`from_meshes` of its meshes, placed by
            their transforms: hits name the mesh (``geometry``, its node name in
            ``geometries.names``) and the triangle within it; ``scene_triangle`` numbers
            the triangles as the file's path does.
        preset : str
            TetGen settings (``tetrace.mesh.PRESETS``): ``"quality"`` (radius-edge bound 5,
            the default), ``"quality<r>"`` (tighter bounds, more tets), ``"constrained"`` (no
            refinement: the fastest build, but more tets than ``"quality"`` on the bunny),
            ``"graded"`` (quality plus tets that grow away from the surface).
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
            Renumber points and tets along a Hilbert curve (Aman et al. 2022) for memory
            locality; False keeps the mesher's order (to measure the effect).
        progress : bool, optional
            A status line per stage on stderr (each repair and TetGen attempt with its
            running time, fTetWild, the build) and ``mesher="auto"``'s candidates as a bar.
            None (default): on in a terminal or Jupyter unless ``CI`` is set
            (:mod:`tetrace.progress`). The scene is the same.
        lazy : bool
            True (the default): load the triangles and mesh nothing yet. CPU queries
            answer on the exact BVH (``accel="exact_bvh"``, built by the first, as fast as
            Embree's build); the tetrahedralization is meshed, with the options above, by
            the first query that walks tets (:meth:`build_ct` lists them). False: mesh it
            now, as :meth:`build_ct` would.

        Returns
        -------
        Scene

        Raises
        ------
        tetrace.MeshingError
            The mesh cannot be read, or (``lazy=False``, or later when the
            tetrahedralization is built) the scene cannot be meshed; the message names the
            stage and the cause.
        """
        options = {k: v for k, v in locals().items() if k in construct.MESH_OPTIONS}
        return construct.from_mesh(cls, mesh, options, hilbert, progress, lazy)

    @classmethod
    def from_meshes(cls, meshes, preset="quality", **mesh_options):
        """Tetrahedralize a scene of several meshes as one.

        Parameters
        ----------
        meshes : iterable or dict or trimesh.Scene
            Each mesh is anything :meth:`from_mesh` takes: a ``(vertices, faces)`` pair, a
            ``trimesh.Trimesh``, a path, or an ``(F, 3, 3)`` triangle soup. Meshes may
            touch or cross each other (the scene is repaired as one). A dict's keys name
            its meshes (``geometries.names``); a ``trimesh.Scene`` is the dict of its
            meshes by node name, each placed by its transform
            (:func:`tetrace.io.trimesh_scene_meshes`).
        preset : str
            As for :meth:`from_mesh`.
        **mesh_options
            Passed to :meth:`from_mesh` (``mesher``, ``margin``, ``contain``, ...).

        Returns
        -------
        Scene
            Its hits report ``geometry``, the index of the mesh hit in ``meshes`` (``-1``
            on a miss), and ``triangle``, the index of the triangle *within that mesh*;
            ``scene_triangle`` is the index among all triangles (``vertices`` and
            ``faces`` are the meshes concatenated in order; :attr:`geometries` has the
            offsets).

        Raises
        ------
        tetrace.MeshingError
            A mesh cannot be read (the message names its index) or the scene cannot be
            meshed.
        """
        from .meshes import concatenate

        vertices, faces, geometries = concatenate(meshes)
        scene = cls.from_mesh((vertices, faces), preset, **mesh_options)
        scene.geometries = geometries
        return scene

    @documented
    def cast(
        self,
        origins=None,
        directions=None,
        *,
        camera=None,
        start=None,
        tmin=0.0,
        tmax=np.inf,
        threads=None,
        max_steps=None,
        invalid="raise",
        method=None,
        layout=None,
        precision=None,
        device="cpu",
        packet=True,
        accel=None,
        progress=None,
    ):
        """Cast rays and return their closest hits.

        Parameters
        ----------
        {ray_arguments}

        Returns
        -------
        Hits
            Fields of the rays' leading shape, in the walk's precision (hit ``t``, ``u``,
            ``v`` are evaluated in float64 on the caller's triangle, then rounded), with
            the hit triangle's unit ``normal`` and, for a :meth:`from_meshes` scene, the
            ``geometry`` hit and ``triangle`` within it. After a GPU cast, its
            ``timings`` hold the seconds of each phase (None after a CPU cast).

        Raises
        ------
        tetrace.gpu.GpuError
            ``device="gpu"`` without a usable adapter, or the device failed.
        """
        gpu.check_cast(device)
        if device == "gpu" and precision is None:
            precision = "f32"  # WGSL has no float64: the GPU walks float32 rays
        if self._camera_on_gpu(locals()):
            return self._cast_camera_gpu(locals())
        q = self._request(locals())
        timings = None
        if gpu.wanted(device, q.precision, method, layout, accel, start):
            r, timings = self.build_ct()._native.cast_gpu(q.native)
        else:
            r = q.run(self._core(q), "closest", "casting")
        q.check(r["status"])
        rows = self._normal_rows(np.asarray(r["t"]).dtype)
        return Hits.from_core(r, rows, self.geometries, timings, q.threads).reshape(q.shape)

    def _core(self, q):
        """The compiled core that answers request ``q`` on the CPU: a request that walks
        tets (its accel resolved to ``"tetwalk"``) builds the tetrahedralization first."""
        if q.native.accel == "tetwalk":
            self.build_ct()
        return self._native

    @staticmethod
    def _camera_on_gpu(args):
        """Whether a cast (``locals()`` of :meth:`cast`) is a camera's that the GPU's exact
        kernel takes with no rays on the host: ``camera=`` alone, float32, the default
        method and layout, one scalar range, on a GPU the cast goes to. (Anything else makes
        the camera's rays on the host, as any rays.)"""
        from .camera import Camera

        return (
            isinstance(args["camera"], Camera)
            and all(args[k] is None for k in ("origins", "directions", "start"))
            and args["precision"] in (None, "f32")
            and args["method"] in (None, "exact")
            and args["layout"] in (None, "tet20")
            and args["accel"] in (None, "tetwalk")
            and args["invalid"] in ("raise", "mark")
            and np.ndim(args["tmin"]) == 0
            and np.ndim(args["tmax"]) == 0
            and gpu.wanted(args["device"], "f32", args["method"], None, args["accel"], None)
        )

    def _cast_camera_gpu(self, args):
        """:meth:`cast` of a camera on the GPU (:meth:`_camera_on_gpu`): the directions made
        in the kernel, the host's only per-ray work the answers (and the rays handed back)."""
        from .progress import enabled
        from .rays import prepare_bounds, raise_invalid

        enabled(args["progress"])  # a TypeError for anything but None/True/False
        cam = args["camera"]
        tmin = prepare_bounds(args["tmin"], cam.n_rays, "tmin")[0]
        tmax = prepare_bounds(args["tmax"], cam.n_rays, "tmax")[0]
        r, timings = self.build_ct()._native.cast_gpu_camera(
            *cam.float32_numbers(),
            cam.eye.astype(np.float32),
            tmin,
            tmax,
            threads=args["threads"],
            max_steps=args["max_steps"],
        )
        if args["invalid"] == "raise" and (np.asarray(r["status"]) == INVALID).any():
            o, d = cam.rays(np.float32)
            raise_invalid(r["status"], o.reshape(-1, 3), d.reshape(-1, 3), cam.shape)
        rows = self._normal_rows(np.float32)
        hits = Hits.from_core(r, rows, self.geometries, timings, args["threads"])
        return hits.reshape(cam.shape)

    def _request(self, args):
        """The :class:`~tetrace.rays.RayRequest` of a ray query's arguments (the public
        method's ``locals()``): every query takes the same ones, checked once."""
        return RayRequest(
            geometries=self.geometries, **{k: args[k] for k in RayRequest.ARGS if k in args}
        )

    def _exact_query(self, args, kind, what):
        """Run ray query ``kind`` ("any", "all" or "count") over a public method's
        ``locals()``: on the GPU's exact kernel where ``device`` asks for it (``"auto"``
        keeps another method on the CPU), else on the CPU. Returns the request and the
        core's columns."""
        device, method = args["device"], args["method"]
        gpu.check_cast(device)
        if device == "gpu" and args["precision"] is None:
            args = {**args, "precision": "f32"}  # WGSL has no float64: float32 rays
        q = self._request(args)
        on_gpu = gpu.wanted(
            device, q.precision, method, args["layout"], args["accel"], args["start"]
        )
        if on_gpu and (device == "gpu" or method in (None, "exact")):
            return q, self.build_ct()._native.cast_gpu(q.native, kind)[0]
        return q, q.run(self._core(q), kind, what)

    def normals(self):
        """Return the unit geometric normal of each of the scene's triangles.

        Returns
        -------
        numpy.ndarray
            ``(F, 3)`` float64: ``cross(p1 - p0, p2 - p0)`` normalized, with ``p0, p1, p2``
            the triangle's vertices in the caller's face order (its winding); ``nan``
            for a zero-area triangle (one no ray hits). Computed once (read-only).
        """
        return self._normal_table()[:-1]

    def _normal_table(self):
        """:meth:`normals` with a row of ``nan`` appended, as the core computes them (kept
        until the vertices change)."""
        if self._normals is None:
            self._normals = construct.triangle_normals(self.vertices, self.faces)
        return self._normals

    def _normal_rows(self, dtype):
        """:meth:`_normal_table` in ``dtype``: a hit's normal is its triangle's row and a
        miss's (triangle -1) the last, so one ``take`` fills every ray's (no mask, no second
        pass). The float64 table itself; another dtype's copy kept until the normals
        change."""
        table = self._normal_table()
        key = np.dtype(dtype)
        if key == table.dtype:
            return table
        cache = self.__dict__.get("_normal_rows_cache")
        if cache is None or cache[0] is not table:
            cache = (table, {})
            self._normal_rows_cache = cache
        if key not in cache[1]:
            cache[1][key] = table.astype(key)
        return cache[1][key]

    @property
    def gpu_timings(self):
        """None. Deprecated: a GPU cast's phase timings are its result's :attr:`Hits.timings`
        (on the scene, two threads casting at once raced on them)."""
        return gpu.deprecated_timings()

    # ------------------------------------------------------------------ other query kinds

    @documented
    def occluded(
        self,
        origins=None,
        directions=None,
        *,
        camera=None,
        start=None,
        tmin=0.0,
        tmax=np.inf,
        threads=None,
        max_steps=None,
        invalid="raise",
        method=None,
        layout=None,
        precision=None,
        return_status=False,
        device="cpu",
        packet=True,
        accel=None,
        progress=None,
    ):
        """Return whether each ray hits any triangle (a shadow ray), without finding which.

        The ray queries' contract (:class:`Scene`). Stops at the first hit found, so it
        costs no more than :meth:`cast` and usually less.

        Parameters
        ----------
        {ray_arguments}
        return_status : bool
            Also return the status per ray.

        Returns
        -------
        occluded : numpy.ndarray
            bool, the rays' leading shape: True where the ray hits a triangle. False
            for rays whose status is ``FAILED`` or ``INVALID`` (``invalid="mark"``):
            ask for the status to tell them apart.
        status : numpy.ndarray
            uint8, the same shape (``return_status=True`` only): ``HIT``, ``MISS``,
            ``FAILED`` or ``INVALID``.
        """
        q, r = self._exact_query(locals(), "any", "occluded")
        status = r["status"]
        q.check(status)
        status = status.reshape(q.shape)
        hit = status == HIT
        return (hit, status) if return_status else hit

    @documented
    def intersections(
        self,
        origins=None,
        directions=None,
        *,
        camera=None,
        start=None,
        tmin=0.0,
        tmax=np.inf,
        threads=None,
        max_steps=None,
        invalid="raise",
        method=None,
        layout=None,
        precision=None,
        device="cpu",
        packet=True,
        accel=None,
        progress=None,
    ):
        """Return every hit of every ray, sorted by ray, then by exact ``t``.

        The ray queries' contract (:class:`Scene`): each point where a ray meets the
        surface is reported once, even at an edge or vertex that triangles share (then
        ``triangle`` names one of them); triangles that meet the ray at one point in space
        (duplicates, overlaps) count once there too.

        Parameters
        ----------
        {ray_arguments}

        Returns
        -------
        Intersections
            Flat arrays of the ``M`` hits (``ray``, ``t``, ``triangle``, ``u``, ``v``,
            ``point``, ``geometry``, ``scene_triangle``), ``offsets`` into them per ray,
            and each ray's ``status`` (``HIT`` if it hit anything; a ``FAILED`` ray lists
            no hit). ``t``, ``u``, ``v`` and ``point`` are float64, each within one ulp of
            its exact value on the caller's triangle (the exact point
            ``origin + t* direction``, rounded).
        """
        q, r = self._exact_query(locals(), "all", "intersections")
        q.check(r["status"])
        return Intersections.from_core(r, q.shape, self.geometries)

    @documented
    def count_intersections(
        self,
        origins=None,
        directions=None,
        *,
        camera=None,
        start=None,
        tmin=0.0,
        tmax=np.inf,
        threads=None,
        max_steps=None,
        invalid="raise",
        method=None,
        layout=None,
        precision=None,
        return_status=False,
        device="cpu",
        packet=True,
        accel=None,
        progress=None,
    ):
        """Count the points where each ray meets the surface, in ``[tmin, tmax]``.

        The count is ``len`` of that ray's :meth:`intersections` (each point where a ray
        meets the surface counts once, even at an edge or vertex that triangles share; a
        ray in a triangle's plane never hits it), without storing the hits.

        Parameters
        ----------
        {ray_arguments}
        return_status : bool
            Also return the status per ray.

        Returns
        -------
        count : numpy.ndarray
            int32, the rays' leading shape; ``-1`` for rays whose status is ``FAILED`` or
            ``INVALID`` (``invalid="mark"``).
        status : numpy.ndarray
            uint8, the same shape (``return_status=True`` only).
        """
        q, r = self._exact_query(locals(), "count", "counting")
        status = np.asarray(r["status"])
        q.check(status)
        count = np.asarray(r["count"]).astype(np.int32, copy=True)
        count[(status == FAILED) | (status == INVALID)] = -1
        count, status = count.reshape(q.shape), status.reshape(q.shape)
        return (count, status) if return_status else count

    def closest_points(self, points, *, threads=None):
        """Return the point of the scene's surface nearest each query point.

        Found on Reshetov's BVH (built on first use, see :meth:`build_bvh`), after Open3D's
        ``RaycastingScene.compute_closest_points``. Distances are float64 evaluations;
        of triangles equally near as float64 tells, the one with the smallest scene index.

        Parameters
        ----------
        points : array_like
            ``(..., 3)`` query points, finite.
        threads : int, optional
            Worker threads; None uses all cores. The GIL is released meanwhile.

        Returns
        -------
        ClosestPoints
            ``point``, ``triangle``, ``u``, ``v``, ``distance``, ``geometry``,
            ``scene_triangle`` of the points' leading shape.

        Raises
        ------
        ValueError
            A point has a NaN or infinite coordinate or one beyond
            ``tetrace.io.MAX_COORDINATE`` (as the mesh's), or ``points`` is not ``(..., 3)``.
        """
        flat, shape = _query_points(points, bounded=True)
        _check_threads(threads)
        return point_queries.closest_points(self, flat, shape, threads)

    def distance(self, points, *, threads=None):
        """Return the distance from each point to the scene's surface (unsigned).

        Parameters
        ----------
        points : array_like
            ``(..., 3)`` query points, finite.
        threads : int, optional
            Worker threads; None uses all cores.

        Returns
        -------
        numpy.ndarray
            float64, the points' leading shape (``inf`` for a scene without triangles).
        """
        return self.closest_points(points, threads=threads).distance

    def signed_distance(self, points, *, mode=None, threads=None):
        """Return the distance to the surface, negative inside it.

        The magnitude is :meth:`distance` (the exact closest distance, whatever the mode);
        the sign is :meth:`contains`'s answer with the same ``mode``: exact parity on a
        closed surface (a point on the surface counts as inside: ``-0.0`` or the small
        negative distance float64 gives it), the winding number on an open one.

        Parameters
        ----------
        points : array_like
            ``(..., 3)`` query points, finite.
        mode : {None, "parity", "winding"}
            The inside rule, as for :meth:`contains` (None: by :attr:`is_closed`).
        threads : int, optional
            Worker threads; None uses all cores.

        Returns
        -------
        numpy.ndarray
            float64, the points' leading shape.

        Raises
        ------
        ValueError
            ``mode`` is not one of the above, a point has a NaN or infinite coordinate or
            one beyond ``tetrace.io.MAX_COORDINATE``, or ``points`` is not ``(..., 3)``.
        """
        flat, shape = _query_points(points, bounded=True)
        _check_threads(threads)
        mode = point_queries.contains_mode(self, mode)
        d = self.distance(flat, threads=threads).reshape(shape)
        inside = point_queries.inside(self, flat, mode, threads).reshape(shape)
        return np.where(inside, -d, d)

    def build_bvh(
        self,
        *,
        cost_ratio=_DEFAULTS["bvh"]["cost_ratio"],
        max_leaf=_DEFAULTS["bvh"]["max_leaf"],
        bins=_DEFAULTS["bvh"]["bins"],
        aperture=_DEFAULTS["bvh"]["aperture"],
    ):
        """Build Reshetov's BVH over the scene's triangles for ``accel="reshetov_bvh"``.

        A query with that accel builds one with the defaults when none is built; this
        builds (again) with other parameters, e.g. for the paper's SAH-ratio sweep.

        Parameters
        ----------
        cost_ratio : float
            The SAH's cost of visiting a node over the cost of testing a triangle (>= 0):
            larger makes larger leaves and smaller trees.
        max_leaf : int
            Most triangles per leaf (1 to 65536); more are split even where SAH would not.
        bins : int
            Bins per axis of the binned SAH (2 to 256).
        aperture : bool
            Whether packets (``accel="reshetov_bvh_packets"``) whose rays share an origin
            also run the paper's optional aperture test on the triangles the frustum keeps.

        Returns
        -------
        dict
            As :meth:`bvh_info`.
        """
        return self._native.build_bvh(cost_ratio, max_leaf, bins, bool(aperture))

    def build_octree(
        self,
        *,
        max_depth=_DEFAULTS["octree"]["max_depth"],
        leaf_size=_DEFAULTS["octree"]["leaf_size"],
        balance=_DEFAULTS["octree"]["balance"],
    ):
        """Build Portalez & Duguet's octree over the scene's triangles for
        ``accel="portalez_octree"``.

        A query with that accel builds one with the defaults when none is built.

        Parameters
        ----------
        max_depth : int
            Leaves are at most this deep (0 to 16; the root is depth 0).
        leaf_size : int
            A node splits while it holds more triangles than this (1 to 65536).
        balance : bool
            Keep face-adjacent leaves within one level of each other (2:1), as the paper
            does: each leaf face then has 0, 1 or 4 neighbours.

        Returns
        -------
        dict
            As :meth:`octree_info`.
        """
        return self._native.build_octree(max_depth, leaf_size, balance)

    def octree_info(self):
        """Return the octree's statistics and memory, or None when none is built.

        Returns
        -------
        dict or None
            ``leaves``, ``empty_leaves``, ``neighbours_per_leaf`` (links per leaf),
            ``triangles_per_leaf``, ``depth`` (deepest leaf), ``node_links`` (links to
            coarser hierarchy nodes, unbalanced trees only); bytes per part as the
            paper's Table 4 (``bytes_cube_map``, ``bytes_octree``, ``bytes_triangles``,
            ``bytes_boxes``), ``bytes_hierarchy`` (kept to locate origins inside the
            root box) and ``bytes`` (the total); the parameters it was built with.
        """
        return self._native.octree_info()

    def bvh_info(self):
        """Return the BVH's shape, or None when none is built.

        Returns
        -------
        dict or None
            ``nodes``, ``leaves``, ``depth``, ``bytes``, the build parameters, and what
            packets did on this tree: ``packet_tests`` (ray-triangle pairs at leaves),
            ``packet_culled`` (those the frustum culled), leaves reached with a frustum
            (``packet_leaves_frustum``), one active ray (``packet_leaves_lone``) or no
            prevalent axis (``packet_leaves_no_axis``).
        """
        return self._native.bvh_info()

    def build_exact_bvh(
        self,
        *,
        cost_ratio=_DEFAULTS["exact_bvh"]["cost_ratio"],
        max_leaf=_DEFAULTS["exact_bvh"]["max_leaf"],
        bins=_DEFAULTS["exact_bvh"]["bins"],
        leaf_size=_DEFAULTS["exact_bvh"]["leaf_size"],
    ):
        """Build the exact 8-wide BVH over the scene's triangles for ``accel="exact_bvh"``.

        A query with that accel builds one with the defaults when none is built. The tree
        is Reshetov's binned-SAH tree collapsed to nodes of eight children, whose boxes a ray
        tests at once in float32 (AVX2 where the CPU has it), padded so that no box the ray
        meets is skipped; triangles are tested exactly, so the answers are the exact walk's.

        Parameters
        ----------
        cost_ratio : float
            The binary SAH's cost of visiting a node over the cost of testing a triangle.
        max_leaf : int
            Most triangles per binary leaf (1 to 16).
        bins : int
            Bins per axis of the binned SAH (2 to 256).
        leaf_size : int
            A binary subtree of at most this many triangles becomes one leaf (1 to 16).

        Returns
        -------
        dict
            As :meth:`exact_bvh_info`.
        """
        return self._native.build_exact_bvh(cost_ratio, max_leaf, bins, leaf_size)

    def exact_bvh_info(self):
        """Return the 8-wide BVH's shape, or None when none is built.

        Returns
        -------
        dict or None
            ``nodes``, ``leaves``, ``children_per_node``, ``depth``, ``bytes``,
            ``bytes_per_triangle`` and the build parameters.
        """
        return self._native.exact_bvh_info()

    def contains(self, points, *, mode=None, threads=None, device="cpu"):
        """Return whether each point lies inside the surface.

        Two rules; :attr:`is_closed` picks one unless ``mode`` does:

        * ``"parity"``, for closed surfaces, **exact**: inside when a ray from the point
          crosses the surface an odd number of times. Points on the surface are inside,
          points outside the domain box outside; nested shells alternate, overlaps are
          outside. On a closed surface any ray gives the same parity: without a
          tetrahedralization one ray's crossings are counted on the exact BVH with exact
          predicates (a ray that meets an edge or a corner, or runs in a triangle's plane, is
          replaced by another; nothing is meshed); with one, the point's tet gives its
          region's parity. On an open surface every point escapes through a hole, so asking
          for it there warns (:class:`UserWarning`, once per scene object) and the answer is
          the tetrahedralization's (the fewest crossings to outside, odd), built if needed.
        * ``"winding"``, for open, cracked or non-manifold surfaces: inside when the
          generalized winding number (Jacobson et al. 2013) is at least 1/2: 1 inside a
          closed outward surface, 0 outside, smooth across a hole (points well inside a scan
          with small holes are inside), 2 in overlaps (inside). It needs consistently
          oriented triangles (normals outward).

        **Error of the winding mode.** libigl's fast winding number (Barill et al. 2018) is
        computed first, and the exact sum of solid angles replaces it within 0.05 of 1/2; the
        fast value was off by at most 0.0044 on the bunny (:mod:`tetrace.winding` gives the
        measurements). Points on the surface and across a hole are the uncertain ones (their
        exact winding number is near 1/2); docs/queries.md compares with trimesh and Open3D.

        Parameters
        ----------
        points : array_like
            ``(..., 3)`` points (a single ``(3,)`` point gives a 0-d answer).
        mode : {None, "parity", "winding"}
            None (the default): ``"parity"`` when :attr:`is_closed`, else ``"winding"``.
        threads : int, optional
            Worker threads of the parity mode (the GIL released); None uses all cores. The
            winding number runs on libigl's own threads (all cores), holding the GIL.
        device : {"cpu", "gpu"}
            ``"gpu"``: the parity mode on the tetrahedralization (built if needed), each
            point located on the GPU (docs/gpu.md); the points are taken as float32 (float64
            ones rounded, as GPU casts take rays), and each answer is the CPU's for those
            numbers. The points the GPU cannot certify (on or near a face) are answered on
            the CPU.

        Returns
        -------
        numpy.ndarray
            bool, the points' leading shape.

        Raises
        ------
        ValueError
            ``mode`` is not one of the above, a point has a NaN or infinite coordinate,
            ``points`` is not ``(..., 3)``, or ``device="gpu"`` with the winding mode.
        tetrace.gpu.GpuError
            ``device="gpu"`` without a usable adapter, or the device failed.

        Warns
        -----
        UserWarning
            ``mode="parity"`` on a scene that is not closed (once per scene).
        """
        if device not in ("cpu", "gpu"):
            raise ValueError(f'device must be "cpu" or "gpu", got {device!r}')
        flat, shape = _query_points(points)
        _check_threads(threads)
        mode = point_queries.contains_mode(self, mode)
        if device == "gpu":
            if mode != "parity":
                raise ValueError(
                    'contains(device="gpu") answers by parity (mode="parity" or a closed '
                    f"surface); mode {mode!r} runs on the CPU"
                )
            points32 = np.ascontiguousarray(flat, dtype=np.float32)
            inside, _ = self.build_ct()._native.contains_gpu(points32, threads)
            return np.asarray(inside, dtype=bool).reshape(shape)
        return point_queries.inside(self, flat, mode, threads).reshape(shape)

    @property
    def is_closed(self):
        """bool: whether :meth:`contains` uses exact parity by default (else the winding
        number): every edge of the caller's mesh is shared by an even number of triangles.

        Two on a manifold surface, 4, 6, ... where closed pieces touch along an edge; not
        orientation (parity does not use it). Read on the mesh as the scene's cleaning leaves
        it (:func:`tetrace.mesh.clean`: coincident vertices merged, zero-area and duplicate
        triangles dropped); a :meth:`from_meshes` scene as one mesh. Kept until
        :meth:`update_vertices` moves the vertices.
        """
        return self._surface_info().closed

    def _surface_info(self):
        """The caller's mesh as cleaned, with its edge census (built once per vertices)."""
        return point_queries.surface_info(self)

    def update_vertices(self, vertices):
        """Move the scene's vertices, keeping its tetrahedralization when it stays valid.

        Lagae & Dutré 2008: the tetrahedralization keeps its topology and every point moves
        (the rule is in ``docs/deformation.md``). If every tet stays positively oriented
        (checked exactly) and every point in the domain box, the core takes the new points;
        else the scene is meshed again with the options it was built with. A scene whose
        tetrahedralization is not built yet (:meth:`build_ct`) moves its triangles alone and
        meshes nothing. Either way every query answers on the moved mesh, with the same
        contract.

        Parameters
        ----------
        vertices : array_like
            The new positions, of the shape of :attr:`vertices` (the faces stay), real
            numbers, all finite.

        Returns
        -------
        Deformation
            What happened (also kept as :attr:`last_deformation`).

        Raises
        ------
        TypeError
            ``vertices`` are not real numbers.
        ValueError
            ``vertices`` have another shape than :attr:`vertices`, or a NaN or infinite
            coordinate. The scene is unchanged.
        tetrace.MeshingError
            The move needs a rebuild and meshing the new vertices fails; the scene is
            unchanged.
        """
        return deform.update_vertices(self, vertices)

    @property
    def n_tets(self):
        """int : Tetrahedra in the tetrahedralization (built now if it is not yet)."""
        return self.build_ct()._native.n_tets

    @property
    def n_points(self):
        """int : Points of the tetrahedralization (scene vertices, box corners, Steiner points)."""
        return self.build_ct()._native.n_points

    @property
    def n_triangles(self):
        """int : Triangles of the caller's mesh."""
        return len(self.faces)

    @property
    def splits_triangles(self):
        """bool : Whether the tetrahedralization (built now if it is not yet) splits some of
        the caller's triangles into several faces (a mesher's Steiner points on them). The
        exact answers are the same either way; where it is False, GPU casts of rays with
        their own origins locate each origin on the device (docs/gpu.md)."""
        return self.build_ct()._native.splits_triangles

    @property
    def domain(self):
        """numpy.ndarray : ``(2, 3)`` lower and upper corners of the domain box (the
        tetrahedralization's, built now if it is not yet)."""
        return np.array(self.build_ct()._native.bounds)

    @property
    def bytes_per_tet(self):
        """int : Bytes per tet of the default traversal layout (points excluded)."""
        return LAYOUT_BYTES[_native.DEFAULT_LAYOUT]

    def prepare_layout(self, layout):
        """Build a traversal layout now rather than at its first cast.

        Parameters
        ----------
        layout : str
            One of :func:`tetrace.layouts`.

        Returns
        -------
        int
            Bytes of its records.

        Raises
        ------
        tetrace.TooLargeError
            The mesh exceeds the layout's limits (e.g. tet16's 24-bit links).
        """
        return self.build_ct()._native.prepare_layout(layout)

    def memory(self):
        """Bytes used by each part of the traversal structure.

        Returns
        -------
        dict
            ``points_f64``, ``points_f32``, ``constrained`` (constrained-side table),
            ``locator`` (seed grid, boundary grid, location topology),
            ``tets_<layout>`` for each layout built so far, ``gpu_<layout>`` for each
            layout's buffers on the GPU (records, and float32 points for tet20), and
            ``gpu_rays`` for the ray buffers GPU casts keep for the next cast, and
            ``gpu_entry_grid`` for the box's entry grid (uploaded by the first GPU cast of
            rays from one origin outside the box), and ``bvh``, ``octree``, ``exact_bvh``
            for the structures built over the triangles. Before the tetrahedralization is
            built (:meth:`build_ct`) its parts are 0.
        """
        m = dict(self._native.memory())
        if self._tet is None:
            # Until the tetrahedralization is built the core holds the domain box as six tets
            # in its place: the scene's tetrahedralization takes no bytes yet.
            m = {k: v if k in _DEFAULTS or k.startswith("gpu") else 0 for k, v in m.items()}
        return m

    def tets(self):
        """Return the positively oriented tets, ``(T, 4)`` uint32 indices into ``points()``.

        ``Hits.tet`` indexes these rows. Points and tets are renumbered along a Hilbert
        curve at build time, so they differ in order from ``tetrahedralization``.
        """
        return self.build_ct()._native.tets()

    def points(self):
        """Return the ``(P, 3)`` float64 points, in the order ``tets()`` indexes."""
        return self.build_ct()._native.points()

    # ------------------------------------------------------------------ save and load

    def to_bytes(self):
        """Serialize the scene in tetrace's scene file format (``docs/save_format.md``).

        It rebuilds the scene exactly, without meshing: the tetrahedralization as last built,
        a moved scene's positions and rest state (it keeps deforming as the original would),
        the caller's meshes, the meshing options, build times, last deformation report and
        the parameters of a built BVH or octree. A scene whose tetrahedralization is not
        built yet (:attr:`has_ct` false) is saved without one and is not meshed to save
        it: the loaded scene meshes it when a query needs it, as the original would have.

        Returns
        -------
        bytes
            Loaded back by :meth:`from_bytes`; every query answers the same, bit for bit.
        """
        return persist.to_bytes(self)

    @classmethod
    def from_bytes(cls, data, *, source="<bytes>"):
        """Rebuild a scene from :meth:`to_bytes`'s bytes (no meshing).

        Parameters
        ----------
        data : bytes-like
        source : str
            How error messages name the data (a path).

        Returns
        -------
        Scene

        Raises
        ------
        tetrace.SceneFileError
            Not a scene file, a newer format version, truncated or corrupt data; the
            message names ``source`` and what is wrong.
        """
        return persist.from_bytes(cls, data, source)

    def save(self, path):
        """Write the scene to a file (:meth:`to_bytes`'s format), to load with :meth:`load`.

        Parameters
        ----------
        path : str or os.PathLike or file object
            A path (written to a temporary file beside it, then renamed) or a binary file
            object open for writing.
        """
        scenefile.write_bytes(path, self.to_bytes())

    @classmethod
    def load(cls, path):
        """Read a scene that :meth:`save` wrote, without meshing it again.

        Parameters
        ----------
        path : str or os.PathLike or file object
            A path or a binary file object open for reading (read to its end).

        Returns
        -------
        Scene
            Answers every query as the saved scene did, bit for bit; a moved scene stays
            moved and keeps deforming from the same rest state.

        Raises
        ------
        tetrace.SceneFileError
            The file is not a scene file, is of a newer format version, or is truncated or
            corrupt (every array's CRC32 is checked); the message names the path and what
            is wrong. :class:`tetrace.SceneFileNotFoundError` (also a ``FileNotFoundError``)
            when it does not exist.
        """
        data, source = scenefile.read_bytes(path)
        return cls.from_bytes(data, source=source)

    def __reduce__(self):
        # Pickling ships the scene file's bytes: unpickling rebuilds, it never re-meshes.
        return (_scene_from_bytes, (self.to_bytes(),))

    def __deepcopy__(self, memo):
        return Scene.from_bytes(self.to_bytes(), source="<deepcopy>")

    def __repr__(self):
        if self._tet is None:
            return f"Scene({self.n_triangles} triangles, tetrahedralization not built yet)"
        tz = self._tet
        return (
            f"Scene({self.n_triangles} triangles, {self.n_tets} tets, {self.n_points} points, "
            f"mesher={getattr(tz, 'mesher', 'tetgen')!r}, preset={tz.preset!r})"
        )


def _scene_from_bytes(data):
    """Unpickle a :class:`Scene` (its :meth:`Scene.__reduce__`). It stays here, not in
    :mod:`tetrace.persist`: pickles name it as ``tetrace.scene._scene_from_bytes``."""
    return Scene.from_bytes(data, source="<pickle>")


def default_scene_path():
    """Return the path of the bundled default scene (Keenan Crane's Spot, CC0)."""
    return resources.files("tetrace").joinpath("data", "spot.obj")
