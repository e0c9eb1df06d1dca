"""Checking and normalising ray arrays before they reach the compiled core."""

from __future__ import annotations

import re
from typing import NamedTuple

import numpy as np

from . import _native
from .camera import Camera
from .hits import HIT, Hits

__all__ = [
    "RayBatch",
    "prepare_ray_batch",
    "prepare_rays",
    "prepare_bounds",
    "raise_invalid",
    "documented",
]


class RayBatch(NamedTuple):
    """Rays flattened for the core, and the leading shape to give the answers back in.

    Attributes
    ----------
    origins, directions : numpy.ndarray
        C-contiguous ``(N, 3)``, one float dtype (float32 or float64).
    shape : tuple of int
        The rays' leading shape: ``(N,)`` for ``(N, 3)``/``(N, 6)`` inputs and for a
        single ``(3,)``/``(6,)`` ray (``(1,)``), ``(H, W)`` for ``(H, W, 3)`` directions.
        ``N == prod(shape)``.
    """

    origins: np.ndarray
    directions: np.ndarray
    shape: tuple

    def unravel(self, k):
        """Return flat ray index ``k`` as an index into :attr:`shape` (an int for 1-D)."""
        if len(self.shape) == 1:
            return int(k)
        return tuple(int(i) for i in np.unravel_index(int(k), self.shape))


def prepare_ray_batch(origins, directions=None, *, invalid="raise") -> RayBatch:
    """Flatten rays of any leading shape to C-contiguous ``(N, 3)`` arrays.

    Parameters
    ----------
    origins : array_like
        ``(..., 3)`` origins, or ``(..., 6)`` rays ``[ox, oy, oz, dx, dy, dz]`` when
        ``directions`` is None.
    directions : array_like, optional
        ``(..., 3)`` directions (need not be unit length). Origins and directions
        broadcast against each other over their leading dimensions, as numpy does: one
        ``(3,)`` origin with ``(H, W, 3)`` directions gives ``(H, W)`` rays.
    invalid : {"raise", "mark"}
        Checked here for its value only: the core marks rays that have a NaN or infinite
        component or a zero-length direction with status ``INVALID`` as it casts, and
        :func:`raise_invalid` turns those marks into an error (cheaper than checking the
        arrays in numpy first).

    Returns
    -------
    RayBatch
        float32 if both inputs are float32 (or float16), float64 otherwise. A single
        ray (``(3,)`` with ``(3,)``, or ``(6,)``) has shape ``(1,)``, as before leading
        shapes were accepted.
    """
    if invalid not in ("raise", "mark"):
        raise ValueError(f'invalid must be "raise" or "mark", got {invalid!r}')
    o = _as_float(origins, "origins")
    if directions is None:
        if o.ndim == 0 or o.shape[-1] != 6:
            raise ValueError(
                f"rays must have shape (N, 6) or (..., 6) [ox, oy, oz, dx, dy, dz] when no "
                f"directions are given, got {o.shape}"
            )
        o, d = o[..., :3], o[..., 3:]
        shape = o.shape[:-1]
    else:
        d = _as_float(directions, "directions")
        for name, a in (("origins", o), ("directions", d)):
            if a.ndim == 0 or a.shape[-1] != 3:
                raise ValueError(f"{name} must have shape (N, 3), (..., 3) or (3,), got {a.shape}")
        try:
            shape = np.broadcast_shapes(o.shape[:-1], d.shape[:-1])
        except ValueError:
            raise ValueError(
                f"origins {o.shape} and directions {d.shape} must have the same length "
                f"(leading shapes that broadcast)"
            ) from None
    shape = tuple(shape) or (1,)
    o = np.broadcast_to(o, shape + (3,))
    d = np.broadcast_to(d, shape + (3,))
    dtype = np.float32 if (o.dtype == np.float32 and d.dtype == np.float32) else np.float64
    o = np.ascontiguousarray(o.reshape(-1, 3), dtype=dtype)
    d = np.ascontiguousarray(d.reshape(-1, 3), dtype=dtype)
    return RayBatch(o, d, shape)


def prepare_rays(origins, directions=None, *, invalid="raise"):
    """Return C-contiguous ``(N, 3)`` origins and directions of one float dtype.

    :func:`prepare_ray_batch` without the leading shape: rays of any leading shape come
    back flattened, in C order.

    Returns
    -------
    origins, directions : numpy.ndarray
    """
    batch = prepare_ray_batch(origins, directions, invalid=invalid)
    return batch.origins, batch.directions


def _spans_exponent_range(d):
    """Whether scaling d by a power of two to a largest component in [1, 2), as the core
    does, would round it (its components span more than float64's exponent range)."""
    d = np.asarray(d, np.float64)
    m = np.abs(d).max()
    if m == 0 or not np.isfinite(m):
        return False
    e = int(np.frexp(m)[1]) - 1
    return not np.array_equal(np.ldexp(np.ldexp(d, -e), e), d)


def raise_invalid(status, origins, directions, shape=None):
    """Raise ``ValueError`` naming the rays the core marked ``INVALID``, if any.

    ``shape``: the rays' leading shape, to name the first bad ray by its index in it.
    """
    from .hits import INVALID

    bad = status == INVALID
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        where = k if shape is None or len(shape) == 1 else np.unravel_index(k, shape)
        where = tuple(int(i) for i in where) if isinstance(where, tuple) else where
        o, d = np.asarray(origins[k]), np.asarray(directions[k])
        if not np.isfinite(o).all():
            why = "origins: a NaN/inf coordinate"
        elif not np.isfinite(d).all():
            why = "directions: a NaN/inf component"
        elif not d.any():
            why = "directions: zero length"
        elif _spans_exponent_range(d):
            why = (
                "directions: components span more than float64's exponent range (such as "
                "1e308 beside 0.1), so no power-of-two scaling keeps them exact"
            )
        else:
            why = (
                f"directions: so short that the hit's t overflows {d.dtype} (scale the "
                f"direction up: t is measured in direction lengths)"
            )
        raise ValueError(
            f"{int(bad.sum())} of {len(status)} rays are invalid (first: ray {where}, {why}; "
            f"origin {o.tolist()}, direction {d.tolist()}); rays with a NaN/inf component, a "
            f"zero-length direction, a direction spanning more than float64's exponent range "
            f"or a hit whose t overflows the rays' precision raise; pass "
            f'invalid="mark" to get status INVALID for them instead'
        )


def prepare_bounds(value, n, name, shape=None):
    """Return tmin or tmax as a float64 array of 1 or ``n`` values.

    ``shape``: the rays' leading shape (``n`` values in all); a value of another shape that
    broadcasts to it is broadcast and flattened. Default ``(n,)``.
    """
    a = np.asarray(value)
    if a.dtype.kind not in "biuf":
        raise TypeError(f"{name} must be a number or an array of numbers, got dtype {a.dtype}")
    a = a.astype(np.float64, copy=False)
    shape = (n,) if shape is None else tuple(shape)
    if a.size == 1:
        a = a.reshape(1)
    elif a.shape != (n,):
        try:
            a = np.broadcast_to(a, shape).reshape(-1)
        except ValueError:
            a = None
    if a is None or a.ndim != 1 or len(a) not in (1, n):
        want = f"have shape ({n},)" if len(shape) == 1 else f"broadcast to the rays' shape {shape}"
        raise ValueError(f"{name} must be a scalar or {want}, got {np.shape(value)}")
    if np.isnan(a).any():
        raise ValueError(f"{name} contains NaN")
    if name == "tmin" and (a < 0).any():
        raise ValueError("tmin must be >= 0")
    return np.ascontiguousarray(a)


def _as_float(a, name):
    arr = np.asarray(a)
    if arr.dtype.kind == "b":
        raise TypeError(f"{name} must be numbers (float32 or float64), got dtype bool")
    if arr.dtype.kind in "iu":
        return arr.astype(np.float64)
    if arr.dtype.kind != "f":
        raise TypeError(f"{name} must be a float array (float32 or float64), got dtype {arr.dtype}")
    if arr.dtype == np.float16:
        return arr.astype(np.float32)
    if arr.dtype not in (np.float32, np.float64):  # longdouble
        return arr.astype(np.float64)
    return arr


# The request every ray query makes of the core: its arguments checked once (moved from
# tetrace.scene as they were).


def _check_threads(threads):
    """``threads``: None (all cores) or an int in [1, :data:`MAX_THREADS`], by the core's
    rule (``tetrace._native.check_threads``): TypeError for other types (bool, float, str),
    ValueError for counts out of range."""
    _native.check_threads(threads)


def _query_points(points, *, bounded=False):
    """Query points as a flat ``(N, 3)`` float64 array and their leading shape; a clear
    error for anything else or for a NaN/inf coordinate, and with ``bounded`` for a
    coordinate beyond ``io.MAX_COORDINATE`` (squared distances from there overflow)."""
    p = np.asarray(points)
    if p.dtype.kind not in "biuf":
        raise TypeError(f"points must be real numbers, got dtype {p.dtype}")
    if p.ndim == 0 or p.shape[-1] != 3:
        raise ValueError(f"points must have shape (..., 3), got {p.shape}")
    flat = np.ascontiguousarray(p.reshape(-1, 3), dtype=np.float64)
    bad = ~np.isfinite(flat).all(axis=1)
    if bad.any():
        k = int(np.argmax(bad))
        raise ValueError(
            f"{int(bad.sum())} of {len(flat)} points have a NaN/inf coordinate "
            f"(first: point {k}, {flat[k].tolist()})"
        )
    if bounded:
        from .io import beyond_max_coordinate

        big = beyond_max_coordinate(flat, "points", "point")
        if big:
            raise ValueError(
                f"{big}: their squared distances would overflow float64; rescale the scene "
                f"and the points"
            )
    return flat, p.shape[:-1]


def _from_hits(start, directions, geometries):
    """Rays started from a cast's hits (``start=hits``): origins at the hit points, the
    directions given, and per ray whether its entry was a hit, the scene triangle it leaves
    and the tet the hit's walk ended in, all broadcast to the rays' leading shape."""
    if not isinstance(start, Hits):
        raise TypeError(f"start must be the Hits of a cast of this scene, got {type(start)}")
    if directions is None:
        raise TypeError("start=hits needs directions (one per hit, or broadcasting to the hits)")
    triangle = start.scene_triangle
    if triangle is None:
        if geometries is not None:
            raise TypeError("start must be a tetrace cast's Hits: they name the scene triangle")
        triangle = start.triangle
    d = np.asarray(directions)
    if d.dtype.kind not in "biuf":
        raise TypeError(f"directions must be real numbers, got dtype {d.dtype}")
    if d.ndim == 0 or d.shape[-1] != 3:
        raise ValueError(f"directions must have shape (..., 3), got {d.shape}")
    try:
        shape = np.broadcast_shapes(np.shape(start.t), d.shape[:-1])
    except ValueError:
        raise ValueError(
            f"directions {d.shape} must broadcast against the hits' shape {np.shape(start.t)}"
        ) from None
    hit = np.broadcast_to(np.asarray(start.status) == HIT, shape)
    point = np.broadcast_to(np.asarray(start.point), shape + (3,))
    # A miss has no point to start from: such rays are answered as misses (tmax = -inf), and
    # their NaN origins and directions are replaced so that they are not taken as invalid.
    origins = np.where(hit[..., None], point, 0).astype(point.dtype, copy=False)
    with np.errstate(invalid="ignore"):
        d = np.where(hit[..., None], np.broadcast_to(d, shape + (3,)), 1).astype(d.dtype)
    ids = lambda a: np.where(hit, np.broadcast_to(np.asarray(a), shape), -1).astype(np.int32)
    tet = start.tet if start.tet is not None else np.full(np.shape(start.t), -1)
    return origins, d, (hit.reshape(-1), ids(triangle).reshape(-1), ids(tet).reshape(-1))


def _camera_rays(camera, origins, directions, start, precision):
    """A camera's rays (``camera=cam``), ``(H, W, 3)`` each, generated on the host in the
    requested precision (float32 by default, as the GPU and Open3D take them)."""
    if not isinstance(camera, Camera):
        raise TypeError(f"camera must be a tetrace.Camera, got {type(camera)}")
    if origins is not None or directions is not None or start is not None:
        raise ValueError(
            "give camera or rays (origins, directions or start=hits), not both: the camera "
            "makes its own rays"
        )
    return camera.rays(np.float64 if precision == "f64" else np.float32)


class RayRequest:
    """One ray query's arguments, checked once, as every ray query of a :class:`Scene` takes
    them: the rays (``origins``/``directions`` of any leading shape, ``camera=cam`` or
    ``start=hits``), the bounds, the threads, the precision (named, not guessed by the core),
    the packets, the accelerator, the walk's method and layout, and the progress bar.

    Python does what only Python can (broadcasting leading shapes, ``start=hits``, the dtype
    the inputs ask for); the core's :class:`tetrace._native.RayRequest` checks every rule
    (threads, step guard, names, shapes) once, as it is built.
    """

    #: The public ray queries' keyword arguments that make a request.
    ARGS = (
        "origins",
        "directions",
        "camera",
        "start",
        "tmin",
        "tmax",
        "threads",
        "max_steps",
        "invalid",
        "precision",
        "packet",
        "accel",
        "method",
        "layout",
        "progress",
    )

    def __init__(
        self,
        origins,
        directions,
        *,
        camera=None,
        start=None,
        tmin=0.0,
        tmax=np.inf,
        threads=None,
        max_steps=None,
        invalid="raise",
        precision=None,
        packet=True,
        accel=None,
        method=None,
        layout=None,
        geometries=None,
        progress=None,
        audit=False,
    ):
        from .progress import enabled

        enabled(progress)  # a TypeError for anything but None/True/False, before any work
        self.progress = progress
        leaving = None
        if camera is not None:
            origins, directions = _camera_rays(camera, origins, directions, start, precision)
        elif start is not None:
            if origins is not None:
                raise TypeError("give origins or start=hits, not both")
            origins, directions, leaving = _from_hits(start, directions, geometries)
        elif origins is None:
            raise TypeError("rays need origins (or camera=cam or start=hits)")
        batch = prepare_ray_batch(origins, directions, invalid=invalid)
        o, d = batch.origins, batch.directions
        if precision is None:
            # The inputs' precision: float32 when both are (prepare_ray_batch made them one).
            precision = "f32" if o.dtype == np.float32 else "f64"
        want = {"f32": np.float32, "f64": np.float64}.get(precision)
        if want is not None:
            o, d = o.astype(want, copy=False), d.astype(want, copy=False)
        self.o, self.d, self.shape, self.invalid = o, d, batch.shape, invalid
        self.threads = threads
        lo = prepare_bounds(tmin, len(o), "tmin", batch.shape)
        hi = prepare_bounds(tmax, len(o), "tmax", batch.shape)
        start_ids = None
        if leaving is not None:
            hit, triangle, tet = leaving
            hi = np.broadcast_to(hi, (len(o),)).copy()
            hi[~hit] = -np.inf  # below tmin: the core answers MISS
            start_ids = (triangle, tet)
        self.method, self.layout = method, layout
        self.native = _native.RayRequest(
            o,
            d,
            np.ascontiguousarray(lo),
            np.ascontiguousarray(hi),
            precision=precision,
            threads=threads,
            max_steps=max_steps,
            method=method,
            layout=layout,
            accel=accel,
            packet=packet,
            start=start_ids,
            audit=audit,
        )

    @property
    def precision(self):
        """``"f32"`` or ``"f64"``."""
        return self.native.precision

    def run(self, scene, kind, description):
        """The core's answer to query ``kind`` (one of ``tetrace._native.queries()``) on
        ``scene``'s core, as a dict of flat columns, with a progress bar when progress is
        on."""
        from . import progress

        with progress.rays(self.progress, len(self.o), description) as report:
            return scene.query(kind, self.native, report)

    def check(self, status):
        """Raise for rays the core marked INVALID, unless ``invalid="mark"``."""
        if self.invalid == "raise":
            raise_invalid(np.asarray(status).reshape(-1), self.o, self.d, self.shape)


#: The numpydoc of every ray-query argument, written once (the arguments are the request's,
#: :attr:`RayRequest.ARGS`, and ``device``): :func:`documented` puts the ones a query takes
#: into its docstring.
ARG_DOCS = """\
origins : array_like, optional
    ``(N, 3)`` or ``(..., 3)`` ray origins, or ``(N, 6)``/``(..., 6)`` rays
    ``[ox, oy, oz, dx, dy, dz]`` when ``directions`` is None. Origins may lie
    anywhere, inside or outside the domain. Not with ``start`` or ``camera``.
directions : array_like, optional
    ``(N, 3)`` or ``(..., 3)`` directions, not necessarily unit length; ``t`` is in
    their units. Origins and directions broadcast over their leading axes (one
    ``(3,)`` origin with ``(H, W, 3)`` directions: ``(H, W)`` rays); the results
    have that leading shape (a single ray gives shape ``(1,)``).
camera : Camera, optional
    A :class:`tetrace.Camera`: one ray per pixel instead of ``origins`` and
    ``directions`` (give one or the other, else ``ValueError``); the results have
    the image's shape ``(height, width)``, row 0 at the top, column 0 at the left.
    The rays are those of :meth:`Camera.rays <tetrace.Camera.rays>`, in ``precision``
    (default ``"f32"``; ``"f64"`` generates them in float64, not rounded through
    float32), so ``cast(camera=cam)`` equals ``cast(*cam.rays())`` field for field.
    For now they are generated on the host (numpy) and cast like any others, on any
    ``device``.
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
    misses. Needs the ``exact`` method; every ``accel`` takes it, and
    ``device="gpu"`` too (its exact kernel: the CPU begins each walk next to the
    hit's tet, the GPU takes the plain steps, answers bit for bit the CPU's).
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
    methods for the speed-accuracy chart). All hits and counts take ``exact`` only
    (another raises ``ValueError``).
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
    ``exact`` on ``tet20``: the GPU takes the exact walk's certified steps and the
    answers are the CPU exact cast's, bit for bit). The exact kernels locate each start
    on the device (one origin once, or each ray's own) and finish the hits they can
    certify; what they cannot certify the CPU exact walk finishes from where the device
    left it (``hits.timings`` counts both). The float kernels leave start location and
    the hit on your triangle to the CPU. ``"auto"``: the GPU when the walk is float32, a kernel
    exists for the method and layout, and a device opens (for the ``exact`` default, a
    hardware GPU: a software driver such as lavapipe is slower than the CPU), else the
    CPU. ``occluded``, ``intersections`` and ``count_intersections`` run on the GPU
    with the ``exact`` kernel only: the GPU takes the plain steps to each ray's first
    scene triangle and the CPU exact walk answers from there, so the answers are the
    CPU exact walk's.
packet : bool
    Let rays that share an origin (a camera, rays from one point) walk as packets
    where the method allows (the ``exact`` default): a chunk of rays is taken as
    sharing one when its first two rays do, and a packet steps once for all its
    rays while every ray leaves a tet by the same face, exactly. On ``"exact_bvh"``
    (the CPU default), a batch of at least 1,024 rays (and half as many as the scene has
    triangles) that all start from one point is answered through a grid over its
    directions built for the cast (docs/bvh.md, "The fan"). Answers are the same, bit
    for bit, either way; ``False`` walks every ray on its own.
accel : str, optional
    Acceleration structure, one of :func:`tetrace.accels`. None (the default) takes
    ``"exact_bvh"`` on the CPU for the ``exact`` method with no ``layout`` named (an
    8-wide BVH over the caller's triangles whose boxes a ray tests eight at once, in
    float32 padded to be conservative, AVX2 where the CPU has it; built on first use or
    by :meth:`build_exact_bvh`), and the tet walk otherwise (a paper's ``method``, a
    ``layout``, a ``max_steps``, and ``device="gpu"``, which always walks tets). The others:
    ``"tetwalk"`` (the walk through the tetrahedralization), ``"reshetov_bvh"``
    (Reshetov 2007's BVH over the same triangles, built on first use or by
    :meth:`build_bvh`, one ray at a time) or ``"reshetov_bvh_packets"`` /
    ``"reshetov_bvh_packets8"`` (that BVH walked by packets of 16 / 64 rays with
    the paper's frustum vertex culling; :meth:`bvh_info` counts what was culled)
    or ``"portalez_octree"`` (Portalez & Duguet's neighbour-linked octree, built on
    first use or by :meth:`build_octree`) or ``"exact_bvh_packets"`` (the exact BVH
    walked by packets of up to 64 consecutive rays that share an origin, each ray testing
    its own boxes and triangles; rays with their own origins walk alone). All keep the
    contract exactly and give the same ``status``, ``triangle``, ``t``, ``u``, ``v`` and
    ``point``; ``tet`` and ``steps`` are the walk's with ``"tetwalk"`` and, with the
    others, -1 and the nodes (boxes or cells) the ray entered. Those other than the tet
    walk take only the ``exact`` method, any layout, and the CPU.
progress : bool, optional
    A bar of the rays done (tqdm, on stderr) for a cast that runs more than
    :data:`tetrace.progress.CAST_DELAY_S` seconds; None (the default): on in a
    terminal or a notebook, off when ``CI`` is set; see :mod:`tetrace.progress`.
    Answers are the same either way. GPU casts show none.
"""

_ENTRY = re.compile(r"^(\w+(?:, \w+)*) :", re.M)


def _arg_entries():
    """``ARG_DOCS`` as ``(names, text)`` pairs, one per numpydoc entry."""
    starts = [m.start() for m in _ENTRY.finditer(ARG_DOCS)] + [len(ARG_DOCS)]
    return [
        (_ENTRY.match(ARG_DOCS, a).group(1).split(", "), ARG_DOCS[a:b])
        for a, b in zip(starts, starts[1:])
    ]


def documented(query):
    """Decorate a ray query: its docstring's ``{ray_arguments}`` line becomes the numpydoc
    of the ray arguments its signature takes (:data:`ARG_DOCS`, in that order), except those
    its Parameters section documents itself (a query's own wording wins)."""
    import inspect
    import textwrap

    doc = query.__doc__
    if doc is None:  # python -OO strips docstrings
        return query
    takes = set(inspect.signature(query).parameters)
    line = re.search(r"^( *)\{ray_arguments\}\n", doc, re.M)
    section = doc[doc.rindex("\n", 0, doc.index("Parameters")) : doc.index("Returns")]
    params = textwrap.dedent(section)
    own = {n for m in _ENTRY.finditer(params) for n in m.group(1).split(", ")}
    text = "".join(t for names, t in _arg_entries() if takes & set(names) and not own & set(names))
    indented = textwrap.indent(text, line.group(1))  # blank lines stay blank
    query.__doc__ = doc[: line.start()] + indented + doc[line.end() :]
    return query
