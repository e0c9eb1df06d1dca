"""Per-ray results of a cast, shared by the tet-mesh caster and the Embree reference.

This module imports only numpy, so it loads without the compiled extension.
"""

from __future__ import annotations

import dataclasses

import numpy as np

__all__ = ["MISS", "HIT", "FAILED", "INVALID", "STATUS_NAMES", "Hits"]

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


@dataclasses.dataclass(frozen=True, eq=False, repr=False)
class Hits:
    """Per-ray results of casting ``N`` rays.

    All arrays have length ``N`` (``point`` is ``(N, 3)``) and are indexed by ray.
    Fields that have no meaning for a ray (a miss, or a failed ray) hold the
    sentinel given below.

    Parameters
    ----------
    t : numpy.ndarray
        ``(N,)`` float32 or float64. Ray parameter of the hit, in units of the
        direction's length (``point = origin + t * direction``). ``inf`` on miss.
    triangle : numpy.ndarray
        ``(N,)`` int32. Index of the hit triangle in the caller's face array
        (not in any cleaned or merged copy). ``-1`` on miss.
    u, v : numpy.ndarray
        ``(N,)`` float. Barycentric coordinates on that triangle, so that
        ``point = (1 - u - v) * p0 + u * p1 + v * p2`` with ``p0, p1, p2`` the
        triangle's vertices in the caller's face order. ``nan`` on miss.
    point : numpy.ndarray
        ``(N, 3)`` float. Hit point. ``nan`` on miss.
    tet : numpy.ndarray
        ``(N,)`` int32. Tetrahedron where the walk ended, ``-1`` if none (always
        ``-1`` for casters that do not walk tetrahedra, such as Embree).
    steps : numpy.ndarray
        ``(N,)`` uint32. Number of tetrahedra visited (``0`` for Embree).
    status : numpy.ndarray
        ``(N,)`` uint8. One of :data:`MISS`, :data:`HIT`, :data:`FAILED`, :data:`INVALID`.

    Notes
    -----
    The class is a frozen dataclass compared by identity (``eq=False``): use
    ``numpy`` on the fields to compare two results.

    Examples
    --------
    >>> h = Hits.misses(2)
    >>> len(h), int(h.hit.sum())
    (2, 0)
    """

    t: np.ndarray
    triangle: np.ndarray
    u: np.ndarray
    v: np.ndarray
    point: np.ndarray
    tet: np.ndarray
    steps: np.ndarray
    status: np.ndarray

    def __post_init__(self) -> None:
        n = len(self.t)
        for field in dataclasses.fields(self):
            arr = getattr(self, field.name)
            if not isinstance(arr, np.ndarray):
                raise TypeError(
                    f"Hits.{field.name} must be a numpy array, got {type(arr).__name__}"
                )
            want = (n, 3) if field.name == "point" else (n,)
            if arr.shape != want:
                raise ValueError(f"Hits.{field.name} has shape {arr.shape}, expected {want}")

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
        return len(self.status)

    @property
    def hit(self) -> np.ndarray:
        """numpy.ndarray : ``(N,)`` bool mask of rays with ``status == HIT``."""
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
        counts = np.bincount(self.status, minlength=4)
        return {
            "rays": len(self),
            "hit": int(counts[HIT]),
            "miss": int(counts[MISS]),
            "failed": int(counts[FAILED]),
            "invalid": int(counts[INVALID]),
            "mean_steps": float(self.steps.mean()) if len(self) else 0.0,
        }

    def __repr__(self) -> str:
        s = self.summary()
        return f"Hits(N={s['rays']}, hits={s['hit']}, misses={s['miss']}, failed={s['failed']})"
