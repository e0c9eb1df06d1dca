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
  scheduler: ``cast_rays`` holds the GIL, so Python threads cannot drive it); warp-lang's CPU
  launch runs its kernel threads one after another on the calling thread, and mitsuba's
  ``scalar_rgb`` variant is a Python loop over the rays (it holds the GIL): both run on one
  thread whatever ``k`` is, and their :meth:`schedule` says so; mitsuba's ``llvm_ad_rgb``
  variant runs in Dr.Jit's pool of ``k`` threads (``drjit.set_thread_count(k)``);
* **the same timing**: one untimed warm-up cast of the same rays on the same threads (lazy
  BVH commits and layout builds are not timed), then the best of ``repeat`` casts
  (:func:`timed`), or, where a bench compares casters row against row, ``repeat`` rounds
  that cast each in turn (:func:`timed_in_turn`).

Each caster says exactly what it is (:attr:`label`: the library, its version, the call and
its flags) and how it was scheduled (:meth:`schedule`); the benchmarks print and store both.
"""

from __future__ import annotations

import contextlib
import functools
import os
import sys
import tempfile
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
    if not is_accel(method):
        return memory[f"tets_{layout}"]
    return memory["octree"] if method == "portalez_octree" else memory["bvh"]


def _threads(k):
    return f"{k} thread" + ("" if k == 1 else "s")


def timed(caster, origins, directions, threads, repeat):
    """Cast once untimed, then ``repeat`` times; the best wall time and the last result.

    Parameters
    ----------
    caster : TetraceCaster or EmbreexCaster or Open3DCaster or WarpCaster or MitsubaCaster
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
    return timed_in_turn([(caster, origins, directions, threads)], repeat, settle=0.0)[0]


def timed_in_turn(jobs, repeat, settle=0.2, digest=None):
    """:func:`timed` for several casts at once, in rounds: every job cast once untimed, then
    ``repeat`` rounds that each cast every job once, in turn; each job's best wall time.

    Timed one caster after the other (:func:`timed`), a ratio of two casters compares casts
    made tens of seconds apart, and on the 2-core VM the machine's speed moves that much
    from one spell to the next (other guests, a peer's thread pool). In turn, every caster
    meets the same spells: on bunny's random rays (Zen 5, one thread) the bench in blocks gave
    tetrace 0.73-0.92x embreex over six runs, in turn 0.80-0.89x over six (docs/bvh.md,
    stop 79).

    Parameters
    ----------
    jobs : list of tuple
        ``(caster, origins, directions, threads)``, as :func:`timed` takes them.
    repeat : int
        Rounds; the best of each job's casts is kept.
    settle : float
        Seconds slept before each timed cast, untimed.
    digest : callable, optional
        ``digest(j, raw)``, applied to job ``j``'s last cast as it returns; what it returns
        is kept instead of ``raw``. Every job's result is held until the end, and a bench of
        every method, layout and precision has hundreds of jobs of a million rays each: a
        digest (a verdict, a mean) keeps that small.

    Returns
    -------
    list of tuple
        ``(seconds, raw)`` per job, in the jobs' order (``raw`` from its last cast, or its
        digest).
    """
    rounds = max(int(repeat), 1)
    for caster, o, d, k in jobs:
        caster.cast(o, d, k)  # warm-ups, untimed
    best, raws = [np.inf] * len(jobs), [None] * len(jobs)
    for r in range(rounds):
        for j, (caster, o, d, k) in enumerate(jobs):
            # A precaution: the cast before may have left its pool's threads spinning for
            # work (rayon's and TBB's idle threads spin a while before they sleep), which on
            # 2 cores would slow this cast; in blocks, the untimed warm-up absorbed that.
            # Measured on embreex right after tetrace's 2-thread cast, with and without the
            # pause, the difference was within the noise (stop 79).
            time.sleep(settle)
            t0 = time.perf_counter()
            raws[j] = caster.cast(o, d, k)
            best[j] = min(best[j], time.perf_counter() - t0)
            if digest is not None and r == rounds - 1:
                raws[j] = digest(j, raws[j])
    return list(zip(best, raws))


def gpu_cast_timed(scene, o, d, repeat, **kw):
    """``scene.cast(o, d, device="gpu")`` after one untimed cast (which uploads the scene and
    compiles the kernel), then ``repeat`` timed casts.

    Returns
    -------
    best : dict
        The phases (seconds) of the fastest cast, numpy to numpy, with ``wall`` (its whole
        call) and ``kernel_min`` (the least kernel time of any cast) added.
    host : float
        The least host time per ray over the casts: the whole call, numpy to numpy, less the
        kernel's timestamped time (issue 34's measure), in seconds.
    hits : Hits
        The last cast's hits.
    scene_upload : float
        Seconds the first cast spent uploading the scene.
    """
    first = scene.cast(o[:1], d[:1], device="gpu", **kw)
    scene_upload = first.timings["scene_upload"]
    best, host, hits, kernel_min = None, float("inf"), None, float("inf")
    for _ in range(max(int(repeat), 1)):
        # The last cast's arrays are freed before the clock starts, not inside the timed call.
        hits = None
        t0 = time.perf_counter()
        hits = scene.cast(o, d, device="gpu", **kw)
        wall = time.perf_counter() - t0
        t = dict(hits.timings, wall=wall)
        kernel_min = min(kernel_min, t["kernel"])
        if best is None or wall < best["wall"]:
            best = t
        host = min(host, (wall - t["kernel"]) / max(len(o), 1))
    return dict(best, kernel_min=kernel_min), host, hits, scene_upload


class CameraRun:
    """One scene's pinhole camera (``res``² float32 rays, one thread) with embreex timed on it:
    what the sweeps of one accelerator's parameters (``bench bvh``, ``bench octree``) measure
    each tetrace cast against, judged by the exact referee.

    Parameters
    ----------
    path : str or None
        Mesh file; None uses the bundled scene.
    res : int
    distance : float
        Camera distance from the scene centre, in bounding radii.
    repeat : int
        Timed casts per measurement; the best is kept.
    """

    def __init__(self, path, res, distance, repeat):
        from ..dev.camera import orbit_views, pinhole
        from ..scene import Scene, default_scene_path

        self.path = str(path) if path is not None else str(default_scene_path())
        self.scene = Scene.from_mesh(self.path)
        v, f = self.scene.vertices, self.scene.faces
        eye, target, up = orbit_views(np.array([v.min(0), v.max(0)]), n=1, distance=distance)[0]
        self.o, self.d = pinhole(
            eye, target, up, fov_deg=40.0, width=res, height=res, dtype=np.float32
        )
        self.n, self.repeat, self.verdict = len(self.o), repeat, None
        te, _ = timed(EmbreexCaster(v, f), self.o, self.d, 1, repeat)
        self.embree_rate = self.n / te / 1e6

    def measure(self, method):
        """Cast with ``method`` (an exit method or an accelerator); return ``mrays_per_s``,
        ``ratio_to_embree``, ``steps_per_ray`` (tets, nodes or leaves visited) and ``right``
        (the share of rays the referee finds right)."""
        from ..dev.compare import agreement
        from ..referee import Referee

        caster = TetraceCaster(self.scene, method, None, "f32")
        seconds, hits = timed(caster, self.o, self.d, 1, self.repeat)
        if self.verdict is None:
            v, f = self.scene.vertices, self.scene.faces
            self.verdict = Referee(v, f).first_hits(self.o, self.d, hint=hits.triangle)
        rate = self.n / seconds / 1e6
        return dict(
            mrays_per_s=rate,
            ratio_to_embree=rate / self.embree_rate,
            steps_per_ray=float(hits.steps.mean()),
            right=agreement(hits, self.verdict, "f64").fraction,
        )


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


#: The line warp's native library prints on stderr when it finds no CUDA driver: the
#: benches use warp's CPU device only, so a machine without NVIDIA's driver is expected.
WARP_NO_CUDA_LINE = "Warp CUDA warning: Could not find or load the NVIDIA CUDA driver."


@contextlib.contextmanager
def _without_stderr_line(prefix):
    """Drop the lines starting with ``prefix`` that native code writes to file descriptor 2
    in the block; every other line goes to stderr as it would have.

    warp-lang (1.19) prints :data:`WARP_NO_CUDA_LINE` with C's ``fprintf(stderr, ...)`` in
    ``wp.init()``, whatever ``wp.config`` says (``log_level`` governs its Python messages
    only), so the descriptor itself is caught for the call.
    """
    sys.stderr.flush()
    saved = os.dup(2)
    with tempfile.TemporaryFile() as caught:
        os.dup2(caught.fileno(), 2)
        try:
            yield
        finally:
            sys.stderr.flush()  # Python's own writes in the block, into the file too
            os.dup2(saved, 2)
            os.close(saved)
            caught.seek(0)
            text = caught.read().decode("utf-8", "replace")
            kept = [ln for ln in text.splitlines(keepends=True) if not ln.startswith(prefix)]
            if kept:
                sys.stderr.write("".join(kept))
                sys.stderr.flush()


def warp_module():
    """The ``warp`` module (warp-lang), initialised, or None with the reason it cannot be.

    Its log level is set to warnings: no greeting and no module-load lines on stdout; the
    native library's "no CUDA driver" line (:data:`WARP_NO_CUDA_LINE`) is dropped, since
    the benches run warp on its CPU device. Any other line it prints is kept.
    """
    try:
        import warp as wp

        wp.config.log_level = wp.LOG_WARNING
        with _without_stderr_line(WARP_NO_CUDA_LINE):
            wp.init()
    except Exception as exc:
        return None, f"warp-lang not available ({type(exc).__name__}: {exc})"
    return wp, None


@functools.cache
def _warp_kernel(wp):
    """The warp kernel of :class:`WarpCaster`: one ``wp.mesh_query_ray`` per kernel thread,
    one kernel thread per ray; a miss is ``face = -1``, ``t = inf``."""

    @wp.kernel(enable_backward=False, module="unique")
    def first_hits(
        mesh: wp.uint64,
        origins: wp.array(dtype=wp.vec3),
        directions: wp.array(dtype=wp.vec3),
        tmax: float,
        t: wp.array(dtype=float),
        face: wp.array(dtype=int),
        u: wp.array(dtype=float),
        v: wp.array(dtype=float),
    ):
        i = wp.tid()
        q = wp.mesh_query_ray(mesh, origins[i], directions[i], tmax)
        if q.result:
            t[i] = q.t
            face[i] = q.face
            u[i] = q.u
            v[i] = q.v
        else:
            t[i] = wp.inf
            face[i] = -1
            u[i] = 0.0
            v[i] = 0.0

    return first_hits


class WarpCaster:
    """warp-lang's ``wp.mesh_query_ray`` in a ``@wp.kernel`` on warp's ``"cpu"`` device, float32.

    ``wp.Mesh`` (its default BVH) is built in the constructor, and the kernel is compiled
    there too (one launch on one ray: warp compiles a module on its first launch, seconds
    that are not the cast's; :attr:`compile_seconds`). A cast wraps the rays in ``wp.array``
    views, launches one kernel thread per ray and reads the outputs back.

    Warp runs a CPU launch's kernel threads one after another on the calling thread (its CPU
    device has no thread pool): a cast runs on one thread whatever thread count the bench
    asks for, and :meth:`schedule` says so.

    warp's barycentrics weigh the triangle's first two vertices (``point = u p0 + v p1 +
    (1 - u - v) p2``); :meth:`hits` turns them into embreex's and :class:`~tetrace.hits.Hits`'
    (``point = (1 - u - v) p0 + u p1 + v p2``).
    """

    name = "warp"
    precision = "f32"
    arithmetic = "f32"

    def __init__(self, wp, vertices, faces):
        self.wp = wp
        t0 = time.perf_counter()
        self.mesh = wp.Mesh(
            points=wp.array(
                np.ascontiguousarray(vertices, np.float32), dtype=wp.vec3, device="cpu"
            ),
            indices=wp.array(
                np.ascontiguousarray(faces, np.int32).ravel(), dtype=int, device="cpu"
            ),
        )
        self.build_seconds = time.perf_counter() - t0
        self.kernel = _warp_kernel(wp)
        t0 = time.perf_counter()
        one = np.zeros((1, 3), np.float32)
        self._launch(one, one + np.float32(1))  # compiles (or loads) the kernel's module
        self.compile_seconds = time.perf_counter() - t0

    @property
    def label(self):
        return (
            f"warp-lang {self.wp.__version__}: wp.mesh_query_ray in a @wp.kernel on device cpu "
            f"(float32, one ray per kernel thread, wp.Mesh default BVH)"
        )

    def schedule(self, threads):
        return (
            f"1 thread (asked for {threads}): warp runs a CPU launch's kernel threads one after "
            f"another on the calling thread"
        )

    def cast(self, origins, directions, threads):
        return self._launch(origins, directions)

    def _launch(self, origins, directions):
        wp = self.wp
        n = len(origins)
        o = wp.array(np.ascontiguousarray(origins, np.float32), dtype=wp.vec3, device="cpu")
        d = wp.array(np.ascontiguousarray(directions, np.float32), dtype=wp.vec3, device="cpu")
        out = [wp.empty(n, dtype=dt, device="cpu") for dt in (float, int, float, float)]
        wp.launch(
            self.kernel, dim=n, inputs=[self.mesh.id, o, d, float(np.inf), *out], device="cpu"
        )
        wp.synchronize_device("cpu")
        return tuple(a.numpy() for a in out)

    def hits(self, raw, origins, directions):
        t, face, u, v = raw
        # warp's (u, v) weigh p0 and p1; embreex's (and Hits') weigh p1 and p2.
        return _peer_hits(origins, directions, face, t, v, np.float32(1) - u - v)


def mitsuba_module(variant="scalar_rgb"):
    """The ``mitsuba`` module with ``variant`` set, or None with the reason it cannot be."""
    try:
        import mitsuba as mi

        if variant not in mi.variants():
            return None, f"mitsuba {mi.__version__} has no variant {variant} ({mi.variants()})"
        if variant.startswith("llvm_"):
            import drjit as dr

            if not dr.has_backend(dr.JitBackend.LLVM):
                return None, (
                    f"mitsuba {mi.__version__}: no {variant}: Dr.Jit finds no LLVM library "
                    f"(libLLVM; Debian: libllvm15)"
                )
        mi.set_variant(variant)
    except Exception as exc:
        return None, f"mitsuba not available ({type(exc).__name__}: {exc})"
    return mi, None


class MitsubaCaster:
    """mitsuba 3's ``Scene.ray_intersect_preliminary`` (its bundled Embree 3, robust
    intersections on), float32.

    The mesh is an ``mi.Mesh`` filled from numpy (``vertex_positions``, ``faces``) in a
    scene of ``mi.load_dict`` (Embree's BVH is built there: :attr:`build_seconds`).

    * ``scalar_rgb`` (the caster ``mitsuba``): one ``ray_intersect_preliminary`` call per ray
      in a Python loop; the loop holds the GIL, so a cast runs on one thread whatever thread
      count the bench asks for, and :meth:`schedule` says so. Its time includes the loop.
    * ``llvm_ad_rgb`` (the caster ``mitsuba_llvm``): one vectorised call on all the rays,
      Dr.Jit's LLVM backend on its pool of ``k`` threads (``drjit.set_thread_count``); its
      time includes moving the rays into Dr.Jit arrays and the hits back to numpy.

    Its ``prim_uv`` has embreex's convention (``point = (1 - u - v) p0 + u p1 + v p2``).
    """

    precision = "f32"
    arithmetic = "f32"

    def __init__(self, mi, vertices, faces, variant="scalar_rgb"):
        mi.set_variant(variant)
        self.mi, self.variant = mi, variant
        self.name = "mitsuba" if variant == "scalar_rgb" else f"mitsuba_{variant.split('_')[0]}"
        self.types = getattr(mi, variant)  # Ray3f, Point3f, Vector3f of this variant
        t0 = time.perf_counter()
        mesh = mi.Mesh(
            "tetrace",
            vertex_count=len(vertices),
            face_count=len(faces),
            has_vertex_normals=False,
            has_vertex_texcoords=False,
        )
        params = mi.traverse(mesh)
        params["vertex_positions"] = np.ascontiguousarray(vertices, np.float32).ravel()
        params["faces"] = np.ascontiguousarray(faces, np.uint32).ravel()
        params.update()
        self.scene = mi.load_dict(
            {"type": "scene", "embree_use_robust_intersections": True, "mesh": mesh}
        )
        self.build_seconds = time.perf_counter() - t0

    @property
    def label(self):
        call = (
            "one call per ray in a Python loop"
            if self.variant == "scalar_rgb"
            else "one vectorised call on all rays"
        )
        return (
            f"mitsuba {self.mi.__version__} ({self.variant}): Scene.ray_intersect_preliminary, "
            f"{call} (its bundled Embree 3, embree_use_robust_intersections)"
        )

    def schedule(self, threads):
        if self.variant == "scalar_rgb":
            return f"1 thread (asked for {threads}): a Python loop over the rays holds the GIL"
        return f"{_threads(threads)}: Dr.Jit's LLVM thread pool (drjit.set_thread_count({threads}))"

    def cast(self, origins, directions, threads):
        m = self.types
        if self.variant == "scalar_rgb":
            ray, intersect = m.Ray3f, self.scene.ray_intersect_preliminary
            out = []
            for o, d in zip(origins.tolist(), directions.tolist()):
                pi = intersect(ray(o, d))
                uv = pi.prim_uv
                out.append((pi.t, pi.prim_index, uv[0], uv[1]))
            out = np.array(out, np.float64).reshape(-1, 4)
            return out[:, 0], out[:, 1].astype(np.int64), out[:, 2], out[:, 3]
        import drjit as dr

        dr.set_thread_count(int(threads))
        o = np.ascontiguousarray(np.asarray(origins, np.float32).T)
        d = np.ascontiguousarray(np.asarray(directions, np.float32).T)
        pi = self.scene.ray_intersect_preliminary(
            m.Ray3f(m.Point3f(o[0], o[1], o[2]), m.Vector3f(d[0], d[1], d[2]))
        )
        uv = np.array(pi.prim_uv)
        return np.array(pi.t), np.array(pi.prim_index).astype(np.int64), uv[0], uv[1]

    def hits(self, raw, origins, directions):
        t, prim, u, v = raw
        prim = np.where(np.isfinite(t), prim, -1)  # a miss: t = inf (its prim_index is 0)
        return _peer_hits(origins, directions, prim, t, u, v)


#: The peers besides embreex that install with pip, by caster name: the getter of each one's
#: module (the module, or None and why it cannot be imported) and how its caster is built.
PEERS = {
    "open3d": (open3d_module, lambda m, v, f: Open3DCaster(m, v, f)),
    "warp": (warp_module, lambda m, v, f: WarpCaster(m, v, f)),
    "mitsuba": (lambda: mitsuba_module("scalar_rgb"), lambda m, v, f: MitsubaCaster(m, v, f)),
    "mitsuba_llvm": (
        lambda: mitsuba_module("llvm_ad_rgb"),
        lambda m, v, f: MitsubaCaster(m, v, f, "llvm_ad_rgb"),
    ),
}
#: How the peers are named in messages.
PEER_TITLES = {"open3d": "Open3D", "warp": "warp", "mitsuba": "mitsuba", "mitsuba_llvm": "mitsuba"}


def optional_peers(vertices, faces, modules=None):
    """The casters of :data:`PEERS` on one mesh, and why any is missing.

    Parameters
    ----------
    vertices, faces : numpy.ndarray
    modules : dict, optional
        Module getters by caster name, replacing those of :data:`PEERS` (the matrix passes
        its own, which a test swaps for a missing module).

    Returns
    -------
    peers : list
        The casters whose module imports, in the order of :data:`PEERS`.
    skipped : dict
        Caster name -> the reason, for each peer whose module does not.
    """
    peers, skipped = [], {}
    for name, (module, make) in PEERS.items():
        m, why = (modules or {}).get(name, module)()
        if m is None:
            skipped[name] = why
        else:
            peers.append(make(m, vertices, faces))
    return peers, skipped
