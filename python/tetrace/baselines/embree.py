"""Reference hits from Intel Embree (through the ``embreex`` binding).

Embree is the ground truth that tests and benchmarks compare the tet-mesh caster
against. It takes the triangles exactly as given: no cleaning, merging or
removal of degenerate triangles (zero-area triangles are harmless to it), so the
triangle ids it reports are the caller's face indices.

This module imports only numpy (trimesh and embreex are imported when needed),
so it loads without the compiled extension.

Notes
-----
Things about ``embreex`` 4.4 that shape this module:

* Embree works in float32. Vertices, origins and directions are rounded to
  float32 before casting, and ``t``, ``u`` and ``v`` carry float32 precision,
  whatever the dtype of the arrays returned.
* ``EmbreeScene.run`` takes a per-ray ``tfar`` (its ``dists`` argument, which it
  overwrites in place) but no ``tnear``: every ray starts at ``tnear = 0``. A
  ``tmin`` other than zero is emulated by moving the origin to
  ``origin + tmin * direction`` and adding ``tmin`` back to ``t``.
* ``EmbreeScene(robust=True)`` sets ``RTC_SCENE_FLAG_ROBUST`` (Embree avoids
  optimisations that lose accuracy, so rays do not slip through shared edges).
* ``run`` loops over its rays calling ``rtcIntersect1``, one ray per call, on the
  calling thread, with the GIL released. :meth:`EmbreeReference.intersect` hands
  chunks of :data:`CHUNK` rays from one shared queue to its worker threads
  (:func:`run_chunks`), each chunk one ``run`` call: dynamic scheduling, like
  tetrace's own (``CHUNK`` rays per rayon task, in ``src/scene.rs``).
"""

from __future__ import annotations

import functools
import os
import threading
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from ..hits import HIT, INVALID, MISS, Hits
from ..io import load_triangles
from ..rays import prepare_rays

__all__ = [
    "embree_available",
    "embree_scene",
    "embree_cast",
    "EmbreeReference",
    "load_triangles",
    "run_chunks",
    "CHUNK",
    "cpu_count",
    "embree_version",
    "embreex_label",
]

#: Rays per chunk a worker thread takes from the queue: tetrace's own chunk (``CHUNK`` in
#: ``src/scene.rs``), so that embreex and tetrace are scheduled alike.
CHUNK = 4096


def cpu_count() -> int:
    """CPUs this process may use (its affinity mask where the OS has one)."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()


def run_chunks(n, threads, fn, chunk=CHUNK):
    """Call ``fn(start, stop)`` over ``[0, n)`` in chunks, on ``threads`` threads, dynamically.

    The chunks (``chunk`` items each, the last one shorter) are handed out in order from
    one shared queue: a thread that finishes a chunk takes the next one not yet taken, so
    a slow chunk delays only the thread running it (no static split of the range).

    Parameters
    ----------
    n : int
        Items (rays) in all.
    threads : int
        Worker threads: exactly this many are started (``1``: every chunk on the calling
        thread, in order). ``fn`` must release the GIL for threads to overlap.
    fn : callable
        ``fn(start, stop)``; it writes its results itself (chunks never overlap).
    chunk : int
        Items per chunk.

    Raises
    ------
    Exception
        The first exception raised by ``fn`` (after every worker has stopped).
    """
    threads, chunk = int(threads), int(chunk)
    if threads < 1 or chunk < 1:
        raise ValueError(f"threads and chunk must be >= 1, got {threads} and {chunk}")
    n_chunks = -(-int(n) // chunk)
    if threads == 1:
        for k in range(n_chunks):
            fn(k * chunk, min(n, (k + 1) * chunk))
        return
    lock = threading.Lock()
    state = {"next": 0, "failed": False}

    def worker():
        while True:
            with lock:
                k = state["next"]
                if k >= n_chunks or state["failed"]:
                    return
                state["next"] = k + 1
            try:
                fn(k * chunk, min(n, (k + 1) * chunk))
            except BaseException:
                state["failed"] = True  # the others stop after their current chunk
                raise

    with ThreadPoolExecutor(threads) as pool:
        futures = [pool.submit(worker) for _ in range(threads)]
    for fut in futures:
        fut.result()


@functools.cache
def embree_version() -> str:
    """The version of the Embree library embreex loaded (``"4.4.0"``), or ``"?"``.

    Read from the library itself (``rtcGetDeviceProperty(RTC_DEVICE_PROPERTY_VERSION)``),
    as embreex does not report it.
    """
    try:
        import ctypes

        from embreex import rtcore_scene  # noqa: F401  (loads libembree)

        with open("/proc/self/maps") as fh:
            paths = sorted({ln.split()[-1] for ln in fh if "libembree" in ln})
        lib = ctypes.CDLL(paths[0])
        lib.rtcNewDevice.restype = ctypes.c_void_p
        lib.rtcNewDevice.argtypes = [ctypes.c_char_p]
        lib.rtcGetDeviceProperty.restype = ctypes.c_ssize_t
        lib.rtcGetDeviceProperty.argtypes = [ctypes.c_void_p, ctypes.c_int]
        lib.rtcReleaseDevice.argtypes = [ctypes.c_void_p]
        device = lib.rtcNewDevice(b"threads=1")
        if not device:
            return "?"
        v = int(lib.rtcGetDeviceProperty(device, 0))  # RTC_DEVICE_PROPERTY_VERSION
        lib.rtcReleaseDevice(device)
        return f"{v // 10000}.{v // 100 % 100}.{v % 100}" if v > 0 else "?"
    except Exception:  # no /proc (not Linux), no embreex, an unexpected library
        return "?"


def embree_available() -> bool:
    """Return whether the ``embreex`` binding can be imported.

    Returns
    -------
    bool
        ``True`` if :func:`embree_cast` and :func:`embree_scene` can run.
    """
    try:
        from embreex import rtcore_scene  # noqa: F401
        from embreex.mesh_construction import TriangleMesh  # noqa: F401
    except Exception:
        return False
    return True


class EmbreeReference:
    """An Embree scene built once and cast many times.

    Build it with :func:`embree_scene`. The BVH is built (committed) in the
    constructor, so :meth:`cast` times casting only: Embree plus the numpy work
    of filling a :class:`~tetrace.hits.Hits`. :meth:`intersect` is the Embree
    call alone, on float32 arrays, for kernel-only timings.

    Parameters
    ----------
    mesh : trimesh.Trimesh or str or os.PathLike or tuple
        See :func:`load_triangles`.
    robust : bool, optional
        Build with ``RTC_SCENE_FLAG_ROBUST`` (default ``True``).

    Attributes
    ----------
    vertices : numpy.ndarray
        ``(V, 3)`` float32 vertices as Embree sees them.
    faces : numpy.ndarray
        ``(F, 3)`` int32 faces, the caller's order.
    robust : bool
        Whether the robust flag was set.
    build_seconds : float
        Wall time of building and committing the scene.
    """

    def __init__(self, mesh, *, robust: bool = True):
        from embreex import rtcore_scene as rtcs
        from embreex.mesh_construction import TriangleMesh

        vertices, faces = load_triangles(mesh)
        # Keep the arrays alive as long as the scene: embreex may share their memory.
        self.vertices = np.ascontiguousarray(vertices, dtype=np.float32)
        self.faces = np.ascontiguousarray(faces, dtype=np.int32)
        self.robust = bool(robust)
        start = time.perf_counter()
        self._scene = rtcs.EmbreeScene(robust=self.robust)
        self._geometry = None
        if len(self.faces):
            self._geometry = TriangleMesh(self._scene, self.vertices, self.faces)
        # run() commits (builds the BVH) on first use; pay for it here.
        probe = np.zeros((1, 3), dtype=np.float32)
        self._scene.run(probe, probe + np.float32(1.0), dists=np.zeros(1, np.float32), output=1)
        self.build_seconds = time.perf_counter() - start

    @property
    def n_triangles(self) -> int:
        """int : Number of triangles in the scene."""
        return len(self.faces)

    def __repr__(self) -> str:
        return (
            f"EmbreeReference(triangles={self.n_triangles}, robust={self.robust}, "
            f"build_seconds={self.build_seconds:.3f})"
        )

    def _run(self, origins32, directions32, tfar32):
        out = self._scene.run(origins32, directions32, dists=tfar32, output=1)
        return out["primID"], out["tfar"], out["u"], out["v"]

    def cast(self, origins, directions=None, tmin=0.0, tmax=np.inf, *, threads=None) -> Hits:
        """Cast rays and return the first hit of each.

        Parameters
        ----------
        origins : array_like
            ``(N, 3)`` ray origins, or ``(N, 6)`` rays ``[ox, oy, oz, dx, dy, dz]``
            when ``directions`` is ``None``.
        directions : array_like, optional
            ``(N, 3)`` directions, or one ``(3,)`` direction for all rays. They
            need not be unit length: ``t`` is measured in units of their length.
        tmin, tmax : float or array_like, optional
            Only hits with ``tmin <= t <= tmax`` count. Scalars or ``(N,)`` arrays.
        threads : int, optional
            Worker threads taking chunks of :data:`CHUNK` rays from one queue
            (default: every CPU this process may use). The results do not depend
            on it.

        Returns
        -------
        Hits
            Float fields have the floating dtype of the inputs (float64 for
            float64 or integer input, float32 for float32 input), with float32
            precision in ``t``, ``u`` and ``v``. ``point = origin + t * direction``
            in that dtype. ``tet`` is ``-1`` and ``steps`` ``0`` for every ray.
            ``status`` is ``HIT`` or ``MISS``, or ``INVALID`` for a ray with a
            NaN or infinite component or a zero-length direction (miss
            sentinels in the other fields); nothing is raised for those.
        """
        # Same ray forms and dtype rules as Scene.cast; bad rays are marked here, not raised.
        origins, directions = prepare_rays(origins, directions, invalid="mark")
        dtype = origins.dtype
        n = len(origins)
        tmin = np.broadcast_to(np.asarray(tmin, dtype=np.float64), (n,))
        tmax = np.broadcast_to(np.asarray(tmax, dtype=np.float64), (n,))
        if not np.all(np.isfinite(tmin)):
            raise ValueError("tmin must be finite")
        if n == 0:
            return Hits.misses(0, dtype=dtype)

        # Rays Embree cannot take (NaN/inf components, zero-length direction) are
        # reported INVALID, as the tet-mesh caster does with invalid="mark".
        with np.errstate(invalid="ignore", over="ignore"):
            # a row sum is finite exactly when its entries are (barring overflow)
            invalid = ~np.isfinite(origins.sum(axis=1) + directions.sum(axis=1))
        invalid |= ~directions.any(axis=1)

        shifted = np.any(tmin != 0.0)
        if shifted:
            start = origins.astype(np.float64) + tmin[:, None] * directions.astype(np.float64)
        else:
            start = origins
        o32 = np.ascontiguousarray(start, dtype=np.float32)
        d32 = np.ascontiguousarray(directions, dtype=np.float32)
        # embreex writes the hit distances into this array, so it must be a fresh copy.
        # A negative tfar (tmax < tmin, or an invalid ray) makes Embree skip the ray.
        with np.errstate(invalid="ignore"):
            span = tmax - tmin
        tfar = np.where((span >= 0.0) & ~invalid, span, -1.0).astype(np.float32)
        if invalid.any():  # new arrays: o32 and d32 may be the caller's own
            o32 = np.where(invalid[:, None], np.float32(0.0), o32)
            d32 = np.where(invalid[:, None], np.float32(1.0), d32)

        prim, t32, u32, v32 = self.intersect(o32, d32, tfar, threads=threads)

        hit = prim >= 0  # invalid rays had tfar = -1, so they cannot hit
        with np.errstate(invalid="ignore", over="ignore"):
            t = t32.astype(dtype)
            if shifted:
                t += tmin.astype(dtype)
            t = np.where(hit, t, np.inf).astype(dtype, copy=False)
            point = origins + t[:, None] * directions
        point[~hit] = np.nan
        return Hits(
            t=t,
            triangle=prim.astype(np.int32, copy=False),  # -1 on miss, as Embree reports it
            u=np.where(hit, u32, np.nan).astype(dtype, copy=False),
            v=np.where(hit, v32, np.nan).astype(dtype, copy=False),
            point=point,
            tet=np.full(n, -1, dtype=np.int32),
            steps=np.zeros(n, dtype=np.uint32),
            status=np.where(
                hit, np.uint8(HIT), np.where(invalid, np.uint8(INVALID), np.uint8(MISS))
            ),
        )

    def intersect(self, origins32, directions32, tfar32=None, *, threads=None, chunk=CHUNK):
        """The bare Embree call, for timing: float32 rays in, raw results out.

        The rays are cast in chunks of ``chunk`` rays (one ``EmbreeScene.run`` call
        each: ``rtcIntersect1`` per ray, GIL released) that ``threads`` worker threads
        take from one shared queue (:func:`run_chunks`).

        Parameters
        ----------
        origins32, directions32 : numpy.ndarray
            ``(N, 3)`` C-contiguous float32 arrays (not checked or converted).
        tfar32 : numpy.ndarray, optional
            ``(N,)`` float32 upper limits of ``t``. Embree overwrites it with the
            hit distances. Default: ``inf`` for every ray.
        threads : int, optional
            Worker threads (default: every CPU this process may use), whatever the
            number of rays.
        chunk : int, optional
            Rays per chunk (default :data:`CHUNK`, tetrace's own).

        Returns
        -------
        triangle : numpy.ndarray
            ``(N,)`` int32 hit triangle, ``-1`` on miss.
        t : numpy.ndarray
            ``(N,)`` float32, the hit distance (``tfar32`` unchanged on miss); it is
            ``tfar32`` itself when given.
        u, v : numpy.ndarray
            ``(N,)`` float32 barycentrics (undefined on miss).
        """
        n = len(origins32)
        if tfar32 is None:
            tfar32 = np.full(n, np.inf, dtype=np.float32)
        threads = cpu_count() if threads is None else int(threads)
        prim = np.empty(n, dtype=np.int32)
        u = np.empty(n, dtype=np.float32)
        v = np.empty(n, dtype=np.float32)

        def one(a, b):
            # embreex writes the distances into the view tfar32[a:b] in place.
            p, _, uu, vv = self._run(origins32[a:b], directions32[a:b], tfar32[a:b])
            prim[a:b], u[a:b], v[a:b] = p, uu, vv

        run_chunks(n, threads, one, chunk)
        return prim, tfar32, u, v

    def occluded(self, origins32, directions32, tfar32=None, *, threads=None, chunk=CHUNK):
        """The bare Embree occlusion call: whether each ray hits anything in ``[0, tfar]``.

        ``EmbreeScene.run(query="OCCLUDED")`` (``rtcOccluded1`` per ray), in chunks on
        ``threads`` threads as :meth:`intersect`.

        Parameters
        ----------
        origins32, directions32, tfar32, threads, chunk
            As for :meth:`intersect` (``tfar32`` is not written).

        Returns
        -------
        numpy.ndarray
            ``(N,)`` bool.
        """
        n = len(origins32)
        tfar32 = (
            np.full(n, np.inf, dtype=np.float32)
            if tfar32 is None
            else np.array(tfar32, dtype=np.float32)
        )
        threads = cpu_count() if threads is None else int(threads)
        out = np.empty(n, dtype=bool)

        def one(a, b):
            ids = self._scene.run(
                origins32[a:b], directions32[a:b], dists=tfar32[a:b], query="OCCLUDED"
            )
            out[a:b] = np.asarray(ids) != -1  # -1: not occluded

        run_chunks(n, threads, one, chunk)
        return out

    @property
    def label(self) -> str:
        """str : What this caster is, exactly: binding, library, call and scene flag."""
        return embreex_label(self.robust)


def embreex_label(robust: bool = True) -> str:
    """The exact description of the embreex caster, for tables and charts.

    ``EmbreeScene.run`` (embreex's only cast) loops over the rays calling
    ``rtcIntersect1``, one ray per call, ``tnear = 0``; the scene flag is
    ``RTC_SCENE_FLAG_ROBUST`` when built with ``robust=True`` (the default here).
    """
    try:
        from importlib.metadata import version

        binding = version("embreex")
    except Exception:
        binding = "?"
    flag = "RTC_SCENE_FLAG_ROBUST" if robust else "RTC_SCENE_FLAG_NONE"
    return (
        f"embreex {binding} (Embree {embree_version()}): EmbreeScene.run, "
        f"rtcIntersect1 one ray per call, {flag}"
    )


def embree_scene(mesh, *, robust: bool = True) -> EmbreeReference:
    """Build a reusable Embree scene.

    Parameters
    ----------
    mesh : trimesh.Trimesh or str or os.PathLike or tuple
        A ``trimesh.Trimesh``, a mesh file path, or ``(vertices, faces)``.
        Triangles are used as given (see :func:`load_triangles`).
    robust : bool, optional
        Set Embree's ``RTC_SCENE_FLAG_ROBUST`` (default ``True``).

    Returns
    -------
    EmbreeReference
        Call ``.cast(origins, directions, tmin, tmax)`` on it; the BVH build is
        already done (``.build_seconds``).

    Notes
    -----
    Embree works in float32: vertices are rounded to float32.

    Examples
    --------
    >>> scene = embree_scene("bunny.obj")  # doctest: +SKIP
    >>> hits = scene.cast(origins, directions)  # doctest: +SKIP
    """
    return EmbreeReference(mesh, robust=robust)


def embree_cast(
    mesh, origins, directions=None, *, tmin=0.0, tmax=np.inf, robust=True, threads=None
) -> Hits:
    """Cast rays against a triangle mesh with Embree and return the first hits.

    Parameters
    ----------
    mesh : trimesh.Trimesh or str or os.PathLike or tuple
        A ``trimesh.Trimesh``, a path (loaded with
        ``trimesh.load(path, force="mesh")``) or ``(vertices (V, 3), faces (F, 3))``.
        Embree takes the triangles as given, so ``Hits.triangle`` indexes the
        caller's faces; degenerate triangles are harmless.
    origins : array_like
        ``(N, 3)`` origins, or ``(N, 6)`` rays ``[ox, oy, oz, dx, dy, dz]`` when
        ``directions`` is ``None``.
    directions : array_like, optional
        ``(N, 3)`` directions or one ``(3,)`` direction for every ray. Not
        normalised: ``t`` is in units of their length.
    tmin, tmax : float or array_like, optional
        Only hits with ``tmin <= t <= tmax`` count.
    robust : bool, optional
        Set Embree's ``RTC_SCENE_FLAG_ROBUST`` (default ``True``).
    threads : int, optional
        Worker threads (default: all available); results do not depend on it.

    Returns
    -------
    Hits
        ``t``, ``triangle``, ``u``, ``v`` (``point = (1-u-v)*p0 + u*p1 + v*p2``),
        ``point = origin + t * direction``; ``tet = -1``, ``steps = 0``,
        ``status`` ``HIT`` or ``MISS`` (``INVALID`` for rays with a NaN or
        infinite component or a zero-length direction).

    Notes
    -----
    Embree computes in float32: vertices, origins and directions are rounded to
    float32 and ``t``, ``u``, ``v`` have float32 precision (about 1e-7 relative),
    even when the returned arrays are float64. Compare against it with
    tolerances, and expect rays that graze an edge or a vertex to pick either
    neighbouring triangle. ``embreex`` has no ``tnear``, so a nonzero ``tmin``
    moves the origin to ``origin + tmin * direction`` before casting.

    The scene is built for this call only; use :func:`embree_scene` to build
    once and time casting alone.
    """
    return embree_scene(mesh, robust=robust).cast(origins, directions, tmin, tmax, threads=threads)
