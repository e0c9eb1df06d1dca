"""Per-ray results of a cast, shared by the tet-mesh caster and the Embree reference.

This module imports only numpy, so it loads without the compiled extension.
"""

from __future__ import annotations

import dataclasses
import weakref

import numpy as np

__all__ = ["MISS", "HIT", "FAILED", "INVALID", "STATUS_NAMES", "Hits", "Intersections"]

#: ``status`` code: the ray left the scene (or reached ``tmax``) without hitting a triangle.
MISS = 0
#: ``status`` code: the ray hit a triangle; ``t``, ``triangle``, ``u``, ``v`` and ``point`` are
#: valid.
HIT = 1
#: ``status`` code: the caster gave up on this ray (for example a walk that could not
#: leave a degenerate configuration, or ran past its step limit). Treat as unknown.
FAILED = 2
#: ``status`` code: the ray itself is unusable (a NaN or infinite component, a zero-length
#: direction, or NaN bounds); only produced by ``cast(..., invalid="mark")``.
INVALID = 3

#: Names of the status codes, indexed by code.
STATUS_NAMES = ("miss", "hit", "failed", "invalid")

# Hits fields that casters other than tetrace's may leave out (None).
_OPTIONAL = ("normal", "geometry", "scene_triangle")


class _Gathered:
    """A field of :class:`Hits` that a cast leaves to its first read: ``normal``, and
    ``geometry`` in a scene of one mesh. An array given at construction is kept as given.

    A cast's caller often never reads them (the bench, depth maps, visibility), and each was
    a pass over every ray after the cast: the normals' gather 2.6 ms of about 130 for a
    million random rays on bunny, the geometry column 2.3 ms for a 1920×1440 camera on two
    cores, where a GPU cast at issue 34's goal takes 5.5 ms in all. :meth:`Hits.from_core`
    leaves a :class:`_Source` in ``_WAITING`` instead, and the first read of each field makes
    its array from ``scene_triangle`` and keeps it. The normals' table is the one the scene
    held at the cast: a scene whose vertices move makes a new table, so normals read later
    are still those of the triangles hit. (A dataclass field whose default is a descriptor:
    ``__init__`` hands the value to :meth:`__set__`, reads go through :meth:`__get__`; the
    value stays in the instance's ``__dict__`` under the field's name, so ``vars(hits)``
    names the fields, with a waiting one None.)
    """

    def __set_name__(self, owner, name):
        self.name = name

    def __get__(self, obj, objtype=None):
        if obj is None:
            return None  # the field's default
        value = obj.__dict__.get(self.name)
        if value is None:
            # Read, not popped, until every waiting field is in place: a second thread
            # reading at once then makes the same array too, rather than finding neither.
            source = _WAITING.get(obj)
            if source is not None:
                value = source.make(self.name, obj)
                obj.__dict__[self.name] = value
                if all(obj.__dict__.get(name) is not None for name in _GATHERED):
                    _WAITING.pop(obj, None)
        return value

    def __set__(self, obj, value):
        obj.__dict__[self.name] = value


class _Source:
    """What a cast's waiting fields are made from: the scene's table of triangle normals
    (``(F + 1, 3)`` in the rays' dtype, the last row ``nan`` for triangle -1) and the
    threads that gather them."""

    __slots__ = ("rows", "threads")

    def __init__(self, rows, threads):
        self.rows, self.threads = rows, threads

    def make(self, name: str, hits: Hits) -> np.ndarray:
        scene_triangle = hits.scene_triangle
        if name == "normal":
            from . import _native

            index = np.ascontiguousarray(scene_triangle, dtype=np.int32).reshape(-1)
            rows = _native.take_rows(self.rows, index, self.threads)
            return rows.reshape(hits.t.shape + (3,))
        # geometry, in a scene of one mesh (a scene of several gives it at the cast).
        return locate(None, scene_triangle)[0]


#: The fields :class:`_Gathered` makes when first read.
_GATHERED = ("normal", "geometry")

#: Hits whose fields wait to be made (:class:`_Gathered`): their :class:`_Source`, until
#: every waiting field is read.
_WAITING: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


@dataclasses.dataclass(frozen=True, eq=False, repr=False)
class Hits:
    """Per-ray results of casting ``N`` rays.

    All arrays have the rays' leading shape (``(N,)`` for ``(N, 3)`` rays, ``(H, W)`` for
    ``(H, W, 3)`` directions, ``()`` for one ray picked by an integer index; ``point`` and
    ``normal`` add a last axis of 3) and are indexed by ray; the shapes below are written
    for ``(N,)``. Fields that have no meaning for a ray (a miss, or a failed ray) hold the
    sentinel given below.

    Parameters
    ----------
    t : numpy.ndarray
        ``(N,)`` float32 or float64. Ray parameter of the hit, in units of the
        direction's length (``point = origin + t * direction``), within one ulp of the
        exact value for the numbers passed in (tetrace's casts; a baseline's ``t`` is
        its own). ``inf`` on miss.
    triangle : numpy.ndarray
        ``(N,)`` int32. Index of the hit triangle in the caller's face array
        (not in any cleaned or merged copy). In a scene of several meshes
        (:meth:`tetrace.Scene.from_meshes`) the index *within the mesh* ``geometry``
        names; ``scene_triangle`` is the index in the concatenated scene. ``-1`` on miss.
    u, v : numpy.ndarray
        ``(N,)`` float. Barycentric coordinates on that triangle, so that
        ``point = (1 - u - v) * p0 + u * p1 + v * p2`` with ``p0, p1, p2`` the
        triangle's vertices in the caller's face order; each within one ulp of its
        exact value. ``nan`` on miss.
    point : numpy.ndarray
        ``(N, 3)`` float. Hit point: the exact point ``origin + t* direction`` rounded,
        each coordinate within one ulp of it (not ``origin + t * direction`` evaluated in
        floating point). ``nan`` on miss.
    tet : numpy.ndarray
        ``(N,)`` int32. Tetrahedron where the walk ended, ``-1`` if none (always
        ``-1`` for casters that do not walk tetrahedra: the CPU default
        ``accel="exact_bvh"``, the other BVHs and the octree, Embree).
    steps : numpy.ndarray
        ``(N,)`` uint32. Number of tetrahedra visited by a tet walk (``accel="tetwalk"``,
        the GPU); the nodes a ray entered for a BVH or the octree; ``0`` for Embree.
    status : numpy.ndarray
        ``(N,)`` uint8. One of :data:`MISS`, :data:`HIT`, :data:`FAILED`, :data:`INVALID`.
    normal : numpy.ndarray or None
        ``(N, 3)``, the dtype of ``t``. Unit geometric normal of the hit triangle,
        oriented by its winding in the caller's faces: ``cross(p1 - p0, p2 - p0)``
        normalized in float64, then rounded. ``nan`` on miss. None for casters that
        do not give it (Embree). A cast's normals are gathered when first read (a
        cast whose caller never reads them skips that pass), from the triangles as they
        were at the cast, also when the scene's vertices moved since.
    geometry : numpy.ndarray or None
        ``(N,)`` int32. Which mesh of the scene was hit (``0`` for a scene of one mesh),
        ``-1`` on miss. None for casters that do not give it. In a scene of one mesh a
        cast's geometry is made when first read.
    scene_triangle : numpy.ndarray or None
        ``(N,)`` int32. The hit triangle's index among all the scene's triangles (the
        meshes' faces concatenated in order; equal to ``triangle`` for one mesh), ``-1``
        on miss. None for casters that do not give it.
    timings : dict or None
        Not per ray: the seconds of each phase of the GPU cast that made these hits
        (``locate``, ``scene_upload``, ``upload``, ``kernel``, ``readback``, ``finish``;
        ``kernel`` from the GPU's timestamps where the device has them, ``kernel_wall`` the
        host's wait for it) and counts (``walked``: rays the GPU walked, ``deferred``: rays
        the kernel handed back to the CPU walk before a face, ``batches``) and
        ``shared_origin`` (whether the rays shared one origin, located once, and began their
        walks on the GPU from their directions alone), ``own_origins`` (whether rays with
        their own origins were located, or entered the box, on the GPU), ``camera_rays``
        (whether a camera's directions were made on the GPU, not uploaded; ``camera``: that
        kernel's seconds)
        and ``finished`` (hits the GPU finished itself: triangle, t, u, v and point certified
        to be the CPU's). None for CPU
        casts and other casters. :meth:`reshape` keeps it; :meth:`__getitem__` drops it (the
        rays selected are not what was timed).

    Notes
    -----
    The class is a frozen dataclass compared by identity (``eq=False``): use
    ``numpy`` on the fields to compare two results. ``len(hits)`` counts the rays along
    the first axis and ``hits[key]`` selects rays with any numpy index of the leading
    shape, every per-ray field alike (:meth:`__getitem__`). Selections, reshapes,
    copies and pickles keep the normals and the geometry (making them when they must);
    ``vars(hits)`` shows each as None until it is first read.

    Examples
    --------
    >>> h = Hits.misses(2)
    >>> len(h), int(h.hit.sum())
    (2, 0)
    >>> h[h.hit].shape, h[:1].point.shape
    ((0,), (1, 3))
    """

    t: np.ndarray
    triangle: np.ndarray
    u: np.ndarray
    v: np.ndarray
    point: np.ndarray
    tet: np.ndarray
    steps: np.ndarray
    status: np.ndarray
    normal: np.ndarray | None = _Gathered()  # type: ignore[assignment]
    geometry: np.ndarray | None = _Gathered()  # type: ignore[assignment]
    scene_triangle: np.ndarray | None = None
    timings: dict | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.t, np.ndarray):
            raise TypeError(f"Hits.t must be a numpy array, got {type(self.t).__name__}")
        if self.timings is not None and not isinstance(self.timings, dict):
            raise TypeError(f"Hits.timings must be a dict or None, got {type(self.timings)}")
        shape = self.t.shape
        for field in dataclasses.fields(self):
            if field.name == "timings":
                continue
            arr = self._stored(field.name)
            if arr is None and field.name in _OPTIONAL:
                continue
            if not isinstance(arr, np.ndarray):
                raise TypeError(
                    f"Hits.{field.name} must be a numpy array, got {type(arr).__name__}"
                )
            want = shape + (3,) if field.name in ("point", "normal") else shape
            if arr.shape != want:
                raise ValueError(f"Hits.{field.name} has shape {arr.shape}, expected {want}")

    def _stored(self, name):
        """Field ``name`` as stored: a :class:`_Gathered` field is None while it waits."""
        return self.__dict__.get(name) if name in _GATHERED else getattr(self, name)

    def _derived(self, fields: dict) -> Hits:
        """A Hits of ``fields`` (every field's selection or reshape of this one's), which
        makes its waiting fields from its own ``scene_triangle`` where this one's wait."""
        hits = Hits(**fields)
        source = _WAITING.get(self)
        if source is not None and any(fields.get(name) is None for name in _GATHERED):
            _WAITING[hits] = source
        return hits

    def __getstate__(self):
        # Pickled (and copied) with its fields made, not with the scene's table.
        for name in _GATHERED:
            getattr(self, name)  # makes it if it waits
        return dict(self.__dict__)

    @property
    def shape(self) -> tuple:
        """tuple : The rays' leading shape (``(N,)`` for ``N`` rays in a row)."""
        return self.t.shape

    def reshape(self, shape) -> Hits:
        """Return the same hits with every field reshaped to leading shape ``shape``.

        Parameters
        ----------
        shape : tuple of int
            A shape with as many elements as there are rays.

        Returns
        -------
        Hits
            Views of these arrays where numpy can make them.
        """
        shape = tuple(shape)
        fields = {}
        for field in dataclasses.fields(self):
            arr = self._stored(field.name)
            if arr is not None and field.name != "timings":
                arr = arr.reshape(shape + arr.shape[self.t.ndim :])
            fields[field.name] = arr
        return self._derived(fields)

    @classmethod
    def from_core(cls, r, normal_rows, geometries, timings=None, threads=None) -> Hits:
        """Hits from the core's flat answer ``r`` (``NativeScene.query("closest", ...)`` or
        a GPU cast): the scene triangle split into mesh and triangle in it
        (:func:`locate`; in a scene of one mesh, ``geometry`` is made when first read), the
        hit triangle's row of ``normal_rows`` (``(F + 1, 3)`` in the rays' dtype, the last
        row ``nan``: a miss's triangle -1 takes it; gathered on ``threads`` threads, None:
        all, when ``normal`` is first read), and a GPU cast's ``timings``."""
        scene_triangle = np.asarray(r["triangle"])
        if geometries is None:  # one mesh: the ids are the mesh's, geometry waits
            geometry, triangle = None, scene_triangle.astype(np.int32, copy=False)
        else:
            geometry, triangle = locate(geometries, scene_triangle)
        hits = cls(
            **dict(r, triangle=triangle),
            geometry=geometry,
            scene_triangle=scene_triangle,
            timings=timings,
        )
        # The normals, and a scene of one mesh's geometry, are made when first read.
        _WAITING[hits] = _Source(normal_rows, threads)
        return hits

    @classmethod
    def misses(cls, n: int, dtype=np.float64) -> Hits:
        """Return ``n`` rays that all missed.

        Parameters
        ----------
        n : int
            Number of rays.
        dtype : numpy dtype, optional
            Float type of ``t``, ``u``, ``v`` and ``point``.

        Returns
        -------
        Hits
            Every field holds its miss sentinel.
        """
        return cls(
            t=np.full(n, np.inf, dtype=dtype),
            triangle=np.full(n, -1, dtype=np.int32),
            u=np.full(n, np.nan, dtype=dtype),
            v=np.full(n, np.nan, dtype=dtype),
            point=np.full((n, 3), np.nan, dtype=dtype),
            tet=np.full(n, -1, dtype=np.int32),
            steps=np.zeros(n, dtype=np.uint32),
            status=np.full(n, MISS, dtype=np.uint8),
        )

    def __len__(self) -> int:
        """Rays along the first axis (all rays for a 1-D batch; ``status.size`` counts all).

        Raises
        ------
        TypeError
            For the 0-d ``Hits`` of one ray (``hits[i]``), as ``len`` of a 0-d numpy array.
        """
        if self.t.ndim == 0:
            raise TypeError("len() of a 0-d Hits (one ray, from an integer index)")
        return len(self.status)

    def __getitem__(self, key) -> Hits:
        """Select rays, as numpy indexes the rays' leading shape.

        Every per-ray field is indexed alike (``timings``, the whole cast's, is dropped):
        ``hits[mask]``, ``hits[:10]``, ``hits[idx]`` (an
        integer array), ``hits[i, j]`` for ``(H, W)`` rays. ``point`` and ``normal`` keep
        their last axis of 3, which the key never reaches.

        Parameters
        ----------
        key : int, slice, array_like of int or bool, tuple, ``None`` or ``Ellipsis``
            A numpy index into the leading shape.

        Returns
        -------
        Hits
            The selected rays. Basic indexing (integers, slices) gives views of these
            arrays, as numpy does; masks and integer arrays give copies. An integer (one
            index per leading axis) gives a ``Hits`` of shape ``()``: each field a 0-d
            array (``point`` of shape ``(3,)``), as ``np.arange(3)[..., 1]`` is;
            ``float(hits[i].t)`` reads the value.

        Raises
        ------
        IndexError
            As numpy's: an index out of range, a mask of the wrong shape, or more indices
            than the leading shape has axes.
        TypeError
            ``key`` is a field name: read fields as attributes (``hits.t``).

        Examples
        --------
        >>> h = Hits.misses(5)
        >>> len(h[h.t > 0]), len(h[:2]), len(h[[0, 4]]), h[3].shape
        (5, 2, 2, ())
        """
        if isinstance(key, str):
            raise TypeError(f"Hits are indexed by ray, not by field name: use hits.{key}")
        key = key if isinstance(key, tuple) else (key,)
        # A trailing Ellipsis keeps a full index's result an array (a 0-d one, not a numpy
        # scalar, so every field stays an ndarray) and spans point's and normal's last axis;
        # a key with its own Ellipsis gets an explicit slice for that axis instead.
        if any(k is Ellipsis for k in key):
            rays, vectors = key, key + (slice(None),)
        else:
            rays = vectors = key + (Ellipsis,)
        fields = {}
        for field in dataclasses.fields(self):
            if field.name == "timings":  # the whole cast's, not the selected rays'
                continue
            arr = self._stored(field.name)
            if arr is not None:
                arr = arr[vectors if field.name in ("point", "normal") else rays]
            fields[field.name] = arr
        return self._derived(fields)

    @property
    def hit(self) -> np.ndarray:
        """numpy.ndarray : bool mask of rays with ``status == HIT`` (the leading shape)."""
        return self.status == HIT

    def summary(self) -> dict:
        """Count the rays by status.

        Returns
        -------
        dict
            ``{"rays": N, "hit": int, "miss": int, "failed": int, "invalid": int,
            "mean_steps": float}``. ``mean_steps`` is the mean of ``steps`` over
            all rays (``0.0`` when ``N == 0``).
        """
        counts = np.bincount(self.status.reshape(-1), minlength=4)
        n = int(self.status.size)
        return {
            "rays": n,
            "hit": int(counts[HIT]),
            "miss": int(counts[MISS]),
            "failed": int(counts[FAILED]),
            "invalid": int(counts[INVALID]),
            "mean_steps": float(self.steps.mean()) if n else 0.0,
        }

    def __repr__(self) -> str:
        s = self.summary()
        return f"Hits(N={s['rays']}, hits={s['hit']}, misses={s['miss']}, failed={s['failed']})"


def locate(geometries, scene_triangle):
    """``(geometry, triangle)``: which mesh of a :meth:`~tetrace.Scene.from_meshes` scene's
    ``geometries`` each scene triangle id belongs to and its index there (-1 for -1); a
    scene of one mesh (``geometries`` None) has geometry 0 and keeps the ids."""
    if geometries is None:
        s = np.asarray(scene_triangle).astype(np.int32, copy=False)
        # 0 where a triangle was hit, -1 where none (triangle -1): a quarter of np.where's
        # time. asarray: a 0-d id gives a 0-d array, not a numpy scalar.
        return np.asarray(np.minimum(s, np.int32(0))), s
    return geometries.locate(scene_triangle)


@dataclasses.dataclass(frozen=True, eq=False, repr=False)
class Intersections:
    """Every hit of every ray (:meth:`tetrace.Scene.intersections`), flat, in ray order.

    ``M`` hits of ``N`` rays, sorted by ray (in C order of the rays' leading shape),
    then by ``t``. The hits of ray ``i`` (flat index) are rows
    ``offsets[i]:offsets[i + 1]``; :meth:`for_ray` selects them. Each point where a ray
    meets the surface is one hit, even where the ray crosses a shared edge or vertex
    (then ``triangle`` names one of the triangles that meet there).

    Parameters
    ----------
    offsets : numpy.ndarray
        ``(N + 1,)`` int64, nondecreasing, ``offsets[0] == 0`` and ``offsets[-1] == M``.
    ray : numpy.ndarray
        ``(M,)`` int64. Flat index of the ray of each hit (:attr:`ray_index` gives it as
        an index into the leading shape).
    t : numpy.ndarray
        ``(M,)`` float64. Ray parameter of each hit, in units of the direction's length.
    triangle : numpy.ndarray
        ``(M,)`` int32. The triangle hit, within its mesh (as :attr:`Hits.triangle`).
    u, v : numpy.ndarray
        ``(M,)`` float64. Barycentric coordinates on that triangle, in the caller's
        vertex order (as :attr:`Hits.u`).
    point : numpy.ndarray
        ``(M, 3)`` float64. ``origin + t * direction`` of the hit's ray.
    geometry : numpy.ndarray
        ``(M,)`` int32. Which mesh of the scene the triangle belongs to.
    scene_triangle : numpy.ndarray
        ``(M,)`` int32. The triangle's index among all the scene's triangles.
    status : numpy.ndarray
        uint8 per ray, of the rays' leading shape: :data:`HIT` (one hit or more),
        :data:`MISS` (none), :data:`FAILED` (the walk gave up: the ray's hits are
        unknown and none is listed) or :data:`INVALID`.

    Examples
    --------
    >>> x = Intersections.empty((2,))
    >>> len(x), x.counts.tolist()
    (0, [0, 0])
    """

    offsets: np.ndarray
    ray: np.ndarray
    t: np.ndarray
    triangle: np.ndarray
    u: np.ndarray
    v: np.ndarray
    point: np.ndarray
    geometry: np.ndarray
    scene_triangle: np.ndarray
    status: np.ndarray

    def __post_init__(self) -> None:
        for field in dataclasses.fields(self):
            arr = getattr(self, field.name)
            if not isinstance(arr, np.ndarray):
                raise TypeError(
                    f"Intersections.{field.name} must be a numpy array, got {type(arr).__name__}"
                )
        n = int(self.status.size)
        m = len(self.t)
        if self.offsets.shape != (n + 1,) or int(self.offsets[-1]) != m:
            raise ValueError(
                f"Intersections.offsets has shape {self.offsets.shape} and ends at "
                f"{int(self.offsets[-1]) if self.offsets.size else None}, expected "
                f"({n + 1},) ending at {m}"
            )
        for name in ("ray", "triangle", "u", "v", "geometry", "scene_triangle"):
            if getattr(self, name).shape != (m,):
                raise ValueError(
                    f"Intersections.{name} has shape {getattr(self, name).shape}, expected ({m},)"
                )
        if self.point.shape != (m, 3):
            raise ValueError(f"Intersections.point has shape {self.point.shape}, expected ({m}, 3)")

    @classmethod
    def from_core(cls, r, shape, geometries) -> Intersections:
        """The core's flat answer ``r`` (``NativeScene.query("all", ...)``) for rays of
        leading ``shape``, on a scene of ``geometries`` (:func:`locate`)."""
        offsets = np.asarray(r["offsets"], np.int64)
        scene_triangle = np.asarray(r["triangle"]).astype(np.int32, copy=False)
        geometry, triangle = locate(geometries, scene_triangle)
        return cls(
            offsets=offsets,
            ray=np.repeat(np.arange(len(offsets) - 1, dtype=np.int64), np.diff(offsets)),
            t=np.asarray(r["t"], np.float64),
            triangle=triangle,
            u=np.asarray(r["u"], np.float64),
            v=np.asarray(r["v"], np.float64),
            point=np.asarray(r["point"], np.float64).reshape(-1, 3),
            geometry=geometry,
            scene_triangle=scene_triangle,
            status=np.asarray(r["status"]).reshape(shape),
        )

    @classmethod
    def empty(cls, shape) -> Intersections:
        """Return the intersections of rays of leading shape ``shape`` that hit nothing."""
        shape = tuple(shape)
        n = int(np.prod(shape))
        i32 = np.zeros(0, np.int32)
        return cls(
            offsets=np.zeros(n + 1, np.int64),
            ray=np.zeros(0, np.int64),
            t=np.zeros(0),
            triangle=i32,
            u=np.zeros(0),
            v=np.zeros(0),
            point=np.zeros((0, 3)),
            geometry=i32.copy(),
            scene_triangle=i32.copy(),
            status=np.full(shape, MISS, np.uint8),
        )

    def __len__(self) -> int:
        """Number of hits ``M`` (of all rays)."""
        return len(self.t)

    @property
    def shape(self) -> tuple:
        """tuple : The rays' leading shape."""
        return self.status.shape

    @property
    def counts(self) -> np.ndarray:
        """numpy.ndarray : int64 hits per ray, of the rays' leading shape."""
        return np.diff(self.offsets).reshape(self.shape)

    @property
    def ray_index(self) -> tuple:
        """tuple of numpy.ndarray : Each hit's ray as an index into the leading shape
        (``np.unravel_index(ray, shape)``; one array for 1-D rays)."""
        return np.unravel_index(self.ray, self.shape)

    def for_ray(self, i) -> Intersections:
        """Return the hits of one ray.

        Parameters
        ----------
        i : int or tuple of int
            The ray: a flat index, or an index into the leading shape.

        Returns
        -------
        Intersections
            Of leading shape ``(1,)``: that ray's hits in order of ``t`` (``ray`` still
            holds its flat index) and its status.
        """
        if isinstance(i, tuple):
            k = int(np.ravel_multi_index(i, self.shape))
        else:
            k = int(i)
            n = self.status.size
            if not -n <= k < n:
                raise IndexError(f"ray {k} out of range for {n} rays")
            k %= n
        lo, hi = int(self.offsets[k]), int(self.offsets[k + 1])
        rows = slice(lo, hi)
        return Intersections(
            offsets=np.array([0, hi - lo], np.int64),
            ray=self.ray[rows],
            t=self.t[rows],
            triangle=self.triangle[rows],
            u=self.u[rows],
            v=self.v[rows],
            point=self.point[rows],
            geometry=self.geometry[rows],
            scene_triangle=self.scene_triangle[rows],
            status=self.status.reshape(-1)[k : k + 1],
        )

    def __repr__(self) -> str:
        counts = np.bincount(self.status.reshape(-1), minlength=4)
        return (
            f"Intersections(rays={self.status.size}, hits={len(self)}, "
            f"rays_hit={int(counts[HIT])}, failed={int(counts[FAILED])})"
        )


@dataclasses.dataclass(frozen=True, eq=False)
class ClosestPoints:
    """The scene's point nearest each query point (:meth:`tetrace.Scene.closest_points`).

    Every field has the query points' leading shape (``point``: plus a last axis of 3).

    Parameters
    ----------
    point : numpy.ndarray
        float64. The nearest point of the scene's surface (``nan`` for a scene without
        triangles).
    triangle : numpy.ndarray
        int32. The triangle it lies on, within its mesh (``-1``: none).
    u, v : numpy.ndarray
        float64. Its barycentric coordinates on that triangle, in the caller's vertex order:
        ``point = (1 - u - v) p0 + u p1 + v p2``.
    distance : numpy.ndarray
        float64. Euclidean distance from the query point to ``point``.
    geometry : numpy.ndarray
        int32. Which mesh of the scene the triangle belongs to (``-1``: none).
    scene_triangle : numpy.ndarray
        int32. The triangle's index among all the scene's triangles.
    """

    point: np.ndarray
    triangle: np.ndarray
    u: np.ndarray
    v: np.ndarray
    distance: np.ndarray
    geometry: np.ndarray
    scene_triangle: np.ndarray
