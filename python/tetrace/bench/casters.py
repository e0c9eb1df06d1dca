"""The casters the benchmarks time, behind one interface, and the one way they are timed.

Every benchmark (``matrix``, the scene bench, ``growth``) casts through :func:`timed`, which
treats every caster alike:

* **the same rays**: float32 rays, bit for bit; a float64 walk gets the same float32 values,
  widened exactly (so one exact verdict of :mod:`tetrace.referee` judges every caster);
* **the same scheduling**: the same thread count ``k`` and dynamic chunks, never a static
  split and never a cap on ``k``: tetrace's rayon pool of ``k`` threads steals
  :data:`~tetrace.baselines.embree.CHUNK`-ray chunks; embreex's ``k`` threads take
  :data:`~tetrace.baselines.embree.CHUNK`-ray chunks from one shared queue
  (:func:`tetrace.baselines.embree.run_chunks`); Open3D's ``cast_rays(nthreads=k)`` runs TBB's
  ``parallel_for`` over chunks of at most 1024 rays in a ``k``-thread arena (its own
  scheduler: ``cast_rays`` holds the GIL, so Python threads cannot drive it);
* **the same timing**: one untimed warm-up cast of the same rays on the same threads (lazy
  BVH commits and layout builds are not timed), then the best of ``repeat`` casts.

Each caster says exactly what it is (:attr:`label`: the library, its version, the call and
its flags) and how it was scheduled (:meth:`schedule`); the benchmarks print and store both.
"""

from __future__ import annotations

import time

import numpy as np

from ..baselines.embree import CHUNK
from ..hits import HIT, MISS, Hits

#: Rays per chunk of Open3D's ``RaycastingScene.cast_rays`` (``BATCH_SIZE``, the grain of its
#: ``tbb::blocked_range``: TBB splits the range into chunks of at most this many rays).
OPEN3D_CHUNK = 1024


def is_accel(method):
    """Whether a bench "method" names an acceleration structure other than the tet walk
    (``reshetov_bvh``): its rows have no layout."""
    from .. import _native

    return method in _native.accels() and method != "tetwalk"


def structure_bytes(memory, method, layout):
    """Bytes of what a cast with ``method`` on ``layout`` walks or tests: the layout's
    records, or the accelerator's structure."""
    return memory["bvh"] if is_accel(method) else memory[f"tets_{layout}"]


def _threads(k):
    return f"{k} thread" + ("" if k == 1 else "s")


def timed(caster, origins, directions, threads, repeat):
    """Cast once untimed, then ``repeat`` times; the best wall time and the last result.

    Parameters
    ----------
    caster : TetraceCaster or EmbreexCaster or Open3DCaster
    origins, directions : numpy.ndarray
        ``(N, 3)`` rays in the caster's precision (see :func:`rays_for`).
    threads : int or None
        Worker threads (``None`` only for the GPU caster).
    repeat : int
        Timed casts; the best is kept.

    Returns
    -------
    seconds : float
    raw : object
        What the caster's :meth:`cast` returned; :meth:`hits` turns it into :class:`Hits`.
    """
    caster.cast(origins, directions, threads)  # warm-up, untimed
    best, raw = np.inf, None
    for _ in range(max(int(repeat), 1)):
        t0 = time.perf_counter()
        raw = caster.cast(origins, directions, threads)
        best = min(best, time.perf_counter() - t0)
    return best, raw


def rays_for(precision, origins32, directions32):
    """The rays a caster of ``precision`` gets: the float32 rays, or them widened exactly."""
    if precision == "f32":
        return origins32, directions32
    return origins32.astype(np.float64), directions32.astype(np.float64)


def _peer_hits(origins, directions, prim, t, u, v):
    """:class:`Hits` (float32) of a peer's raw first hits; ``prim < 0`` is a miss."""
    hit = prim >= 0
    n = len(prim)
    t = np.where(hit, t, np.inf).astype(np.float32)
    with np.errstate(invalid="ignore", over="ignore"):
        point = origins + t[:, None] * directions
    point[~hit] = np.nan
    return Hits(
        t=t,
        triangle=np.where(hit, prim, -1).astype(np.int32),
        u=np.where(hit, u, np.nan).astype(np.float32),
        v=np.where(hit, v, np.nan).astype(np.float32),
        point=point.astype(np.float32),
        tet=np.full(n, -1, np.int32),
        steps=np.zeros(n, np.uint32),
        status=np.where(hit, np.uint8(HIT), np.uint8(MISS)),
    )


class TetraceCaster:
    """``Scene.cast`` with one method, layout, precision and device.

    Parameters
    ----------
    scene : tetrace.Scene
    method, layout, precision : str
    device : {"cpu", "gpu"}
    """

    name = "tetrace"
    #: The referee's arithmetic for ``t``: tetrace evaluates it in float64 on the named
    #: triangle, whatever the rays' precision (GPU hits are finished on the CPU alike).
    arithmetic = "f64"

    def __init__(self, scene, method, layout, precision="f32", device="cpu"):
        self.scene, self.method, self.layout = scene, method, layout
        self.precision, self.device = precision, device
        # A "method" that names an accelerator (the bench's method column): the exact
        # default's answers from another structure, with no exit method or layout.
        self.accel = method if is_accel(method) else None

    @property
    def label(self):
        from .. import __version__

        if self.accel:
            return (
                f"tetrace {__version__}: Scene.cast(accel={self.accel}, precision={self.precision})"
            )
        return (
            f"tetrace {__version__}: Scene.cast(method={self.method}, layout={self.layout}, "
            f"precision={self.precision}, device={self.device})"
        )

    def schedule(self, threads):
        if self.device == "gpu":
            return "GPU kernel (one invocation per ray); CPU start location and finishing on rayon"
        return f"{_threads(threads)}: rayon work stealing over {CHUNK}-ray chunks"

    def cast(self, origins, directions, threads):
        kw = dict(method=self.method, layout=self.layout, device=self.device)
        if self.accel:
            kw = dict(accel=self.accel)
        if self.device == "cpu":
            kw.update(threads=threads, precision=self.precision)
        return self.scene.cast(origins, directions, **kw)

    def hits(self, raw, origins, directions):
        return raw


class EmbreexCaster:
    """embreex's ``EmbreeScene.run`` (``rtcIntersect1`` per ray), robust flag set.

    Built (BVH committed) in the constructor; :meth:`cast` is
    :meth:`tetrace.baselines.embree.EmbreeReference.intersect` on float32 rays.
    """

    name = "embreex"
    precision = "f32"
    arithmetic = "f32"

    def __init__(self, vertices, faces, robust=True):
        from ..baselines.embree import embree_scene

        self.reference = embree_scene((vertices, faces), robust=robust)
        self.build_seconds = self.reference.build_seconds

    @property
    def label(self):
        return self.reference.label

    def schedule(self, threads):
        return f"{_threads(threads)}: {CHUNK}-ray chunks taken from one shared queue"

    def cast(self, origins, directions, threads):
        return self.reference.intersect(origins, directions, threads=threads)

    def hits(self, raw, origins, directions):
        prim, t, u, v = raw
        return _peer_hits(origins, directions, prim, t, u, v)


def open3d_module():
    """The ``open3d`` module, or None with the reason it cannot be imported."""
    try:
        import open3d as o3d
    except Exception as exc:  # ImportError, or OSError for a missing libusb-1.0
        return None, f"open3d not available ({type(exc).__name__}: {exc})"
    return o3d, None


class Open3DCaster:
    """Open3D's ``RaycastingScene.cast_rays`` on float32 rays.

    Open3D's CPU ``RaycastingScene`` calls Embree's ``rtcIntersect1`` once per ray on a scene
    built with ``RTC_SCENE_FLAG_ROBUST``, in a ``tbb::parallel_for`` over chunks of at most
    :data:`OPEN3D_CHUNK` rays within a ``task_arena`` of ``nthreads`` threads.
    """

    name = "open3d"
    precision = "f32"
    arithmetic = "f32"

    def __init__(self, o3d, vertices, faces):
        self.o3d = o3d
        t0 = time.perf_counter()
        self.scene = o3d.t.geometry.RaycastingScene()
        self.scene.add_triangles(
            o3d.core.Tensor(np.ascontiguousarray(vertices, np.float32)),
            o3d.core.Tensor(np.ascontiguousarray(faces, np.uint32)),
        )
        self.build_seconds = time.perf_counter() - t0  # the BVH itself is built on first cast

    @property
    def label(self):
        return (
            f"Open3D {self.o3d.__version__}: RaycastingScene.cast_rays (its bundled Embree, "
            f"rtcIntersect1 one ray per call, RTC_SCENE_FLAG_ROBUST)"
        )

    def schedule(self, threads):
        return (
            f"{_threads(threads)}: TBB parallel_for over chunks of at most {OPEN3D_CHUNK} rays "
            f"(cast_rays nthreads={threads})"
        )

    def cast(self, origins, directions, threads):
        rays = self.o3d.core.Tensor(np.ascontiguousarray(np.hstack([origins, directions])))
        return self.scene.cast_rays(rays, nthreads=int(threads))

    def hits(self, raw, origins, directions):
        t = raw["t_hit"].numpy()
        prim = raw["primitive_ids"].numpy().astype(np.int64)
        uv = raw["primitive_uvs"].numpy()
        prim = np.where(np.isfinite(t), prim, -1)
        return _peer_hits(origins, directions, prim, t, uv[:, 0], uv[:, 1])
