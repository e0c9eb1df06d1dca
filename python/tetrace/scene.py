"""The user-facing scene: a constrained tetrahedralization ready to cast rays through."""

from __future__ import annotations

import time
import warnings
from functools import lru_cache
from importlib import resources

import numpy as np

from . import _native, deform, gpu, point_queries
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
from .rays import RayRequest, _check_threads, _query_points

__all__ = [
    "Scene",
    "Deformation",
    "cast",
    "measure_accuracy",
    "default_scene",
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
        What the mesher produced (points, tets, constrained faces, timings).
    vertices, faces : numpy.ndarray
        The caller's mesh, as given (a :meth:`from_meshes` scene: the meshes
        concatenated in order): hit ``scene_triangle`` ids index ``faces``.
    geometries : tetrace.meshes.Geometries or None
        Where each mesh of a :meth:`from_meshes` scene sits in ``faces``; None for one mesh.
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
        #: tetrace.meshes.Geometries or None: the meshes of a :meth:`from_meshes` scene
        #: (None: one mesh).
        self.geometries = None
        self._normals = None
        # The caller's mesh as cleaned, with its edge census (tetrace.winding.Surface): what
        # is_closed and the winding number read; built on first use, dropped when the vertices
        # move. And whether contains(mode="parity") has warned that the mesh is open.
        self._surface = None
        self._parity_warned = False
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
        progress=None,
    ):
        """Tetrahedralize a triangle scene.

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
            TetGen settings (``tetrace.mesh.PRESETS``): ``"quality"`` (radius-edge
            bound 5, the default), ``"quality3"``, ``"quality2"``, ``"quality1.5"`` or any
            ``"quality<r>"`` (tighter bounds, more tets), ``"constrained"`` (constrained
            Delaunay without refinement: the fewest points and the fastest build, but not
            the fewest tets, bunny 228,894 against ``"quality"``'s 215,821, and more tets
            per ray), ``"graded"`` (quality plus tets that grow away from the surface).
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
        progress : bool, optional
            Show a status line per stage on stderr (cleaning, each repair and TetGen attempt
            with its preset and running time, fTetWild, the build of the compiled scene) and
            ``mesher="auto"``'s candidates as a bar. None (default): on when stderr is a
            terminal or in a Jupyter kernel, off when the environment variable ``CI`` is
            set; True/False force it (:mod:`tetrace.progress`). The scene is the same.

        Returns
        -------
        Scene

        Raises
        ------
        tetrace.MeshingError
            The scene cannot be meshed; the message names the stage and the cause.
        """
        from .io import _mesh_name, is_trimesh_scene
        from .mesh import FTETWILD_EDGE_LENGTH, FTETWILD_EPSILON, load_triangles, tetrahedralize
        from .progress import reporting, stage

        # What the scene was built with: a rebuild (update_vertices) meshes again with it.
        options = dict(
            preset=preset,
            mesher=mesher,
            margin=margin,
            contain=contain,
            minratio=minratio,
            maxvolume=maxvolume,
            sizing=sizing,
            repair=repair,
            epsilon=epsilon,
            edge_length=edge_length,
            timeout=timeout,
            accuracy=accuracy,
        )
        if is_trimesh_scene(mesh):
            # Meshed as one, like its path, but with the per-mesh ids from_meshes records.
            return cls.from_meshes(mesh, hilbert=hilbert, progress=progress, **options)
        with reporting(progress):
            vertices, faces = load_triangles(mesh)
            tet = tetrahedralize(
                (vertices, faces),
                **dict(
                    options,
                    epsilon=FTETWILD_EPSILON if epsilon is None else epsilon,
                    edge_length=FTETWILD_EDGE_LENGTH if edge_length is None else edge_length,
                ),
                measure=measure_accuracy,
                name=_mesh_name(mesh),
            )
            with stage(f"build the scene ({len(tet.tets)} tets)"):
                scene = cls(tet, vertices, faces, hilbert=hilbert)
        scene._build_options = options
        return scene

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

    def cast(
        self,
        origins=None,
        directions=None,
        *,
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
        origins : array_like, optional
            ``(N, 3)`` or ``(..., 3)`` ray origins, or ``(N, 6)``/``(..., 6)`` rays
            ``[ox, oy, oz, dx, dy, dz]`` when ``directions`` is None. Origins may lie
            anywhere, inside or outside the domain. Not with ``start``.
        directions : array_like, optional
            ``(N, 3)`` or ``(..., 3)`` directions, not necessarily unit length; ``t`` is in
            their units. Origins and directions broadcast over their leading axes (one
            ``(3,)`` origin with ``(H, W, 3)`` directions: ``(H, W)`` rays); the results
            have that leading shape (a single ray gives shape ``(1,)``).
        start : Hits, optional
            Secondary rays (shadow rays, reflections, bounces): start each ray at a hit of
            an earlier :meth:`cast` of this scene, at ``start.point``, in ``directions``
            (which broadcast against the hits' shape: ``(S, *hits.shape, 3)`` casts ``S``
            rays from every hit). Such a ray needs no offset origin and never hits the
            triangle it leaves: its hits lie strictly beyond the point where its line
            crosses that triangle's plane (beyond its origin for a line parallel to the
            plane), decided exactly, so it goes off on the side its direction points to
            (a reflection stays, a transmission crosses), on grazing and concave
            geometry alike; ``tmin``/``tmax`` still apply (``tmax=1`` with
            ``directions = light - hits.point`` stops at the light). Its walk starts from
            the tet the hit's walk ended in (Lagae & Dutré 2008's ray connectivity: no
            point location). Rays whose ``start`` entry is not a ``HIT`` are answered as
            misses. Needs the ``exact`` method and the CPU; every ``accel`` takes it.
        tmin, tmax : float or array_like
            Only hits with ``tmin <= t <= tmax`` count: scalars, or arrays that broadcast
            to the rays' leading shape. A ray with ``tmin > tmax`` (an empty interval)
            misses, as in Embree; ``tmin < 0`` or NaN raises ``ValueError``.
        threads : int, optional
            Worker threads, 1 to :data:`MAX_THREADS`; None uses all cores. The GIL is
            released while casting; Ctrl-C stops the cast (``KeyboardInterrupt``, within
            about 50 ms plus a chunk of 4096 rays).
        max_steps : int, optional
            Guard on tets visited per ray; a ray that reaches it is reported FAILED.
        invalid : {"raise", "mark"}
            Rays with NaN/inf components, zero directions or directions whose components
            span more than float64's exponent range (``1e308`` beside ``0.1``: no
            power-of-two scaling keeps them exact), and hits whose ``t`` overflows the
            rays' precision (a direction so short, e.g. a denormal, that ``t`` has no
            finite value), raise ``ValueError``, or with
            ``"mark"`` come back with status ``INVALID``.
        method : str, optional
            Exit-face method, one of :func:`tetrace.methods` (default: ``exact``, the only
            one that keeps tetrace's contract on every ray; the others are faster float
            methods for the speed-accuracy chart).
        layout : str, optional
            Tet layout, one of :func:`tetrace.layouts`; built on first use.
        precision : {"f32", "f64"}, optional
            Precision of the rays as the core takes them; default: the rays' own. Rays are
            converted when it differs. Float methods walk in that precision; ``exact`` walks
            the float64 mesh either way (exactly, on the rays' numbers).
        device : {"cpu", "gpu", "auto"}
            Where the walk runs. ``"gpu"``: on the GPU (:mod:`tetrace.gpu`), in float32:
            float64 rays are rounded to float32 and ``precision="f64"`` is refused; method
            and layout must name a GPU kernel (:func:`tetrace.gpu.kernels`; by default
            ``aman2022`` on ``tet20``). Start location and the hit on your triangle stay on
            the CPU. ``"auto"``: the GPU when a device opens, the walk is float32 and a kernel
            exists for the method (named explicitly: the default ``exact`` has none) and
            layout, else the CPU.
        packet : bool
            Let rays that share an origin (a camera, rays from one point) walk as packets
            where the method allows (the ``exact`` default): a chunk of rays is taken as
            sharing one when its first two rays do, and a packet steps once for all its
            rays while every ray leaves a tet by the same face, exactly. Answers are the
            same, bit for bit, either way; ``False`` walks every ray on its own.
        accel : str, optional
            Acceleration structure, one of :func:`tetrace.accels`: ``"tetwalk"`` (the
            default, the walk through the tetrahedralization), ``"reshetov_bvh"``
            (Reshetov 2007's BVH over the same triangles, built on first use or by
            :meth:`build_bvh`, one ray at a time) or ``"reshetov_bvh_packets"`` /
            ``"reshetov_bvh_packets8"`` (that BVH walked by packets of 16 / 64 rays with
            the paper's frustum vertex culling; :meth:`bvh_info` counts what was culled)
            or ``"portalez_octree"`` (Portalez & Duguet's neighbour-linked octree, built on
            first use or by :meth:`build_octree`). All keep the contract exactly and give
            the same answers; those other than the tet walk take only the ``exact``
            method, any layout, and the CPU.
        progress : bool, optional
            A bar of the rays done (tqdm, on stderr) for a cast that runs more than
            :data:`tetrace.progress.CAST_DELAY_S` seconds; None (the default): on in a
            terminal or a notebook, off when ``CI`` is set; see :mod:`tetrace.progress`.
            Answers are the same either way. GPU casts show none.

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
        q = self._request(locals())
        timings = None
        if gpu.wanted(device, q.precision, method, layout, accel, start):
            r, timings = self._native.cast_gpu(q.native)
        else:
            r = q.run(self._native, "closest", "casting")
        q.check(r["status"])
        return self._hits(r, timings).reshape(q.shape)

    def _request(self, args):
        """The :class:`~tetrace.rays.RayRequest` of a ray query's arguments (the public
        method's ``locals()``): every query takes the same ones, checked once."""
        return RayRequest(
            geometries=self.geometries, **{k: args[k] for k in RayRequest.ARGS if k in args}
        )

    def _hits(self, r, timings=None):
        """Hits from the core's flat answer: the triangle split into mesh and triangle in
        it, and the hit triangle's normal (and a GPU cast's ``timings``)."""
        scene_triangle = np.asarray(r["triangle"])
        geometry, triangle = self._locate(scene_triangle)
        hit = scene_triangle >= 0
        normal = np.full((len(scene_triangle), 3), np.nan, dtype=np.asarray(r["t"]).dtype)
        normal[hit] = self.normals()[scene_triangle[hit]]
        return Hits(
            **dict(r, triangle=triangle),
            normal=normal,
            geometry=geometry,
            scene_triangle=scene_triangle,
            timings=timings,
        )

    def _locate(self, scene_triangle):
        if self.geometries is None:
            s = np.asarray(scene_triangle)
            return np.where(s >= 0, 0, -1).astype(np.int32), s.astype(np.int32, copy=False)
        return self.geometries.locate(scene_triangle)

    def normals(self):
        """Return the unit geometric normal of each of the scene's triangles.

        Returns
        -------
        numpy.ndarray
            ``(F, 3)`` float64: ``cross(p1 - p0, p2 - p0)`` normalized, with ``p0, p1, p2``
            the triangle's vertices in the caller's face order (its winding); ``nan``
            for a zero-area triangle (one no ray hits). Computed once.
        """
        if self._normals is None:
            p = np.asarray(self.vertices, np.float64)[np.asarray(self.faces)]
            n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
            length = np.linalg.norm(n, axis=1, keepdims=True)
            with np.errstate(divide="ignore", invalid="ignore"):
                n = np.where(length > 0, n / length, np.nan)
            n.setflags(write=False)
            self._normals = n
        return self._normals

    @property
    def gpu_timings(self):
        """None. Deprecated: a GPU cast's phase timings come back with its result,
        :attr:`Hits.timings` (kept on the scene, two threads casting at once raced on them)."""
        warnings.warn(
            "Scene.gpu_timings is deprecated and always None: read hits.timings of the GPU "
            "cast's result",
            DeprecationWarning,
            stacklevel=2,
        )
        return None

    # ------------------------------------------------------------------ other query kinds

    def occluded(
        self,
        origins=None,
        directions=None,
        *,
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
        packet=True,
        accel=None,
        progress=None,
    ):
        """Return whether each ray hits any triangle (a shadow ray), without finding which.

        A ray hits a triangle when it meets the closed triangle (edges and vertices
        included) at one point at ``t`` in ``[tmin, tmax]``; a ray in a triangle's plane
        never hits it. Stops at the first hit found, so it costs no more than
        :meth:`cast` and usually less.

        Parameters
        ----------
        origins, directions, tmin, tmax, threads, max_steps, invalid, method, layout
            As for :meth:`cast` (rays of any leading shape, CPU only).
        start, precision, packet, accel, progress
            As for :meth:`cast` (``start=hits``: rays from an earlier cast's hits).
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
        q = self._request(locals())
        status = q.run(self._native, "any", "occluded")["status"]
        q.check(status)
        status = status.reshape(q.shape)
        hit = status == HIT
        return (hit, status) if return_status else hit

    def intersections(
        self,
        origins=None,
        directions=None,
        *,
        start=None,
        tmin=0.0,
        tmax=np.inf,
        threads=None,
        max_steps=None,
        invalid="raise",
        method=None,
        layout=None,
        precision=None,
        packet=True,
        accel=None,
        progress=None,
    ):
        """Return every hit of every ray, sorted by ray, then by exact ``t``.

        A ray hits a triangle when it meets the closed triangle (edges and vertices
        included) at one point at ``t`` in ``[tmin, tmax]``; a ray in a triangle's plane
        never hits it. Each point where a ray meets the surface is reported once, even
        where it crosses an edge or vertex that triangles share (then ``triangle`` names
        one of them); triangles that meet the ray at one point in space (duplicates,
        overlaps) count once there too.

        Parameters
        ----------
        origins, directions, tmin, tmax, threads, max_steps, invalid
            As for :meth:`cast` (rays of any leading shape, CPU only).
        method : str, optional
            ``"exact"`` (the default); the core refuses any other (``ValueError``).
        layout : str, optional
            Checked as a name, then ignored: the core's all-hits walk takes no tet layout
            (the argument is there so that every ray query takes :meth:`cast`'s).
        start, precision, packet, accel, progress
            As for :meth:`cast` (``start=hits``: rays from an earlier cast's hits).

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
        q = self._request(locals())
        r = q.run(self._native, "all", "intersections")
        q.check(r["status"])
        return Intersections.from_core(r, q.shape, self._locate)

    def count_intersections(
        self,
        origins=None,
        directions=None,
        *,
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
        origins, directions, tmin, tmax, threads, max_steps, invalid
            As for :meth:`cast` (rays of any leading shape, CPU only).
        method : str, optional
            ``"exact"`` (the default); the core refuses any other (``ValueError``).
        layout : str, optional
            Checked as a name, then ignored: the core's all-hits walk takes no tet layout
            (the argument is there so that every ray query takes :meth:`cast`'s).
        start, precision, packet, accel, progress
            As for :meth:`cast` (``start=hits``: rays from an earlier cast's hits).
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
        q = self._request(locals())
        r = q.run(self._native, "count", "counting")
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
            A point has a NaN or infinite coordinate, or ``points`` is not ``(..., 3)``.
        """
        flat, shape = _query_points(points)
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
            ``mode`` is not one of the above, a point has a NaN or infinite coordinate, or
            ``points`` is not ``(..., 3)``.
        """
        flat, shape = _query_points(points)
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
            ``nodes``, ``leaves``, ``depth``, ``bytes`` and the parameters it was built
            with (``cost_ratio``, ``max_leaf``, ``bins``, ``aperture``); and what packets
            (``accel="reshetov_bvh_packets"``) did on this tree since it was built:
            ``packet_tests`` (ray-triangle pairs reached at leaves), ``packet_culled``
            (those the frustum culled), and the leaves reached with a frustum
            (``packet_leaves_frustum``), with one active ray (``packet_leaves_lone``) or
            with no prevalent axis (``packet_leaves_no_axis``).
        """
        return self._native.bvh_info()

    def contains(self, points, *, mode=None, threads=None):
        """Return whether each point lies inside the surface.

        Two rules; :attr:`is_closed` picks one unless ``mode`` does:

        * ``"parity"``, for closed surfaces (every edge shared by an even number of
          triangles), **exact**: a point is inside when a ray from it crosses the surface an
          odd number of times, decided with exact predicates on the tetrahedralization (no
          ray is cast). Points on the surface count as inside; points outside the domain box
          are outside. Nested shells alternate, and where closed pieces overlap the overlap
          is outside (an even number of crossings). Of an open surface it answers whether the
          fewest crossings needed to reach the outside of the domain box is odd, which lets
          every point escape through a hole (a scan's inside is all "outside"): asking for it
          on a scene that is not closed warns (:class:`UserWarning`, once per scene object).
        * ``"winding"``, for open, cracked or non-manifold surfaces: inside when the
          generalized winding number of the scene's triangles (Jacobson et al. 2013, the sum
          of their signed solid angles over 4 pi) is at least 1/2. It is 1 inside and 0
          outside a closed outward surface, and varies smoothly across a hole, so points
          well inside a scan with small holes are inside. Where closed pieces overlap it is 2:
          inside (their union). It needs the triangles oriented consistently (normals
          outward); a triangle facing the wrong way subtracts what it should add.

        **Error of the winding mode.** The fast winding number (libigl, Barill et al. 2018:
        Barnes-Hut, far triangles replaced by a Taylor expansion) is computed first; where it
        lies within 0.05 of 1/2 the exact sum of solid angles (libigl's hierarchical
        evaluation, exact up to rounding) replaces it. The fast value was off by at most
        0.0044 on the Stanford bunny (10^4 points in its box, 8 x 10^4 near its surface),
        so the answer is the exact sum's unless that error exceeds 0.05 (not proven, never
        seen). The uncertain points are those whose exact winding number is itself near
        1/2: points on the surface, where it jumps between 0 and 1 (parity counts them as
        inside; the winding mode has no such rule), and points across a hole, where it is near 1/2
        only because of the hole and the side is a matter of convention. Points far from
        holes and from the surface get the same answer as any watertight closing of the
        holes would give. ``tetrace.winding`` documents the measurements; docs/queries.md
        compares with trimesh and Open3D.

        Parameters
        ----------
        points : array_like
            ``(..., 3)`` points (a single ``(3,)`` point gives a 0-d answer).
        mode : {None, "parity", "winding"}
            None (the default): ``"parity"`` when :attr:`is_closed`, else ``"winding"``.
        threads : int, optional
            Worker threads of the parity mode (the GIL released); None uses all cores. The
            winding number runs on libigl's own threads (all cores), holding the GIL.

        Returns
        -------
        numpy.ndarray
            bool, the points' leading shape.

        Raises
        ------
        ValueError
            ``mode`` is not one of the above, a point has a NaN or infinite coordinate, or
            ``points`` is not ``(..., 3)``.

        Warns
        -----
        UserWarning
            ``mode="parity"`` on a scene that is not closed (once per scene).
        """
        flat, shape = _query_points(points)
        _check_threads(threads)
        mode = point_queries.contains_mode(self, mode)
        return point_queries.inside(self, flat, mode, threads).reshape(shape)

    @property
    def is_closed(self):
        """bool: whether :meth:`contains` uses exact parity by default (else the winding
        number): every edge of the caller's mesh is shared by an even number of triangles.

        That is two on a manifold surface, and 4, 6, ... where closed pieces touch along an
        edge; a hole's boundary edge has one, an edge where three sheets meet has three.
        Orientation is not part of it, because parity does not use it (a closed surface with
        some triangles flipped is still exact by parity, whereas its winding number is not).
        The mesh is read as the scene's cleaning leaves it (:func:`tetrace.mesh.clean`):
        exactly coincident vertices are one (UV seams do not open a mesh), and zero-area
        and duplicate triangles (the same three vertices, either orientation) are dropped.
        A :meth:`from_meshes` scene is judged as the one mesh of all its meshes. Computed
        on first use and kept until :meth:`update_vertices` moves the vertices.
        """
        return self._surface_info().closed

    def _surface_info(self):
        """The caller's mesh as cleaned, with its edge census (built once per vertices)."""
        if self._surface is None:
            from .winding import surface

            self._surface = surface(self.vertices, self.faces)
        return self._surface

    def update_vertices(self, vertices):
        """Move the scene's vertices, keeping its tetrahedralization when it stays valid.

        Lagae & Dutré 2008: the constrained tetrahedralization keeps its topology and every
        point moves (``docs/deformation.md`` gives the rule: the caller's vertices go where
        they are sent, points on the domain box stay, Steiner points on a triangle follow it,
        Steiner points in the volume follow a smoothed displacement). The core checks every
        tet's orientation exactly and that every point stays in the domain box; if all hold
        it takes the new points, else the scene is meshed again from the new vertices with
        the options it was built with. Either way every query answers on the moved mesh
        afterwards, with the same contract.

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

    # ------------------------------------------------------------------ save and load

    def to_bytes(self):
        """Serialize the scene in tetrace's scene file format (``docs/save_format.md``).

        What is written rebuilds the scene exactly, without meshing: the tetrahedralization
        as last built (the core rebuilds its structure from it deterministically), the
        current positions of a moved scene (:meth:`update_vertices`) and its rest state (so
        that it keeps deforming as the original would), the caller's mesh, the meshes of a
        :meth:`from_meshes` scene, the meshing options a rebuild uses, the build times, the
        last deformation report, and the parameters of a built BVH or octree.

        Returns
        -------
        bytes
            Loaded back by :meth:`from_bytes`; every query answers the same, bit for bit.
        """
        from . import persist

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
        from . import persist

        return persist.from_bytes(cls, data, source)

    def save(self, path):
        """Write the scene to a file (:meth:`to_bytes`'s format), to load with :meth:`load`.

        Parameters
        ----------
        path : str or os.PathLike or file object
            A path (written to a temporary file beside it, then renamed) or a binary file
            object open for writing.
        """
        from .scenefile import write_bytes

        write_bytes(path, self.to_bytes())

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
        from .scenefile import read_bytes

        data, source = read_bytes(path)
        return cls.from_bytes(data, source=source)

    def __reduce__(self):
        # Pickling ships the scene file's bytes: unpickling rebuilds, it never re-meshes.
        return (_scene_from_bytes, (self.to_bytes(),))

    def __deepcopy__(self, memo):
        return Scene.from_bytes(self.to_bytes(), source="<deepcopy>")

    def __repr__(self):
        tz = self.tetrahedralization
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
    """Fraction of random rays on which a tetrahedralization agrees with Embree: what
    :func:`tetrace.accuracy.measure_accuracy` documents, cast with :class:`Scene`."""
    from .accuracy import measure_accuracy

    return measure_accuracy(
        Scene, tetrahedralization, vertices, faces, rays=rays, seed=seed, hit_distance=hit_distance
    )
