"""The exact referee: what the right answer to a ray is, for the numbers passed in.

Every correctness claim of tetrace is judged here (``docs/referee.md``). For each ray it
finds, among the caller's triangles, the hits of the contract: the ray's line meets the closed
triangle (edges and vertices included) at one point, never when it lies in the triangle's
plane, at a parameter ``t`` with ``tmin <= t <= tmax``; the answer is the smallest such ``t``
and the set of triangles tied there. It shares no code with the walk: it reads the triangles
and the rays and nothing else, and imports only numpy.

How: a bounding-volume hierarchy (boxes grown well past float64's rounding of the ray-box test)
yields every triangle a ray could meet; a float64 filter with a certified error bound decides
the clear cases; every sign it cannot certify, every ``t`` that may tie with another hit or
with ``tmin``/``tmax``, and each winner's ``t`` are evaluated exactly with Python integers.

Over 500 lines on purpose: the whole exact referee (candidates, float64 filter, exact
fallback, judging) in one file, read side by side with docs/referee.md and its Rust twin.
"""

from __future__ import annotations

import dataclasses
from fractions import Fraction

import numpy as np

__all__ = [
    "Crossings",
    "Referee",
    "Verdict",
    "first_hits",
    "judge",
    "judge_lists",
    "JUDGEMENTS",
    "ulp",
    "within_ulp",
    "judge_values",
]

EPS = 2.0**-53
#: Shewchuk's error bound for a float64 3x3 determinant of rounded differences, times its
#: permanent (orient3d's ``errboundA``): the filter certifies a sign when the value exceeds it.
FILTER = (7.0 + 56.0 * EPS) * EPS
#: A permanent below this may hide underflowed products; above it their absolute error
#: (a few times 2^-1074) is far below FILTER x permanent. Non-finite: overflow.
TINY = 2.0**-900
#: Relative growth of the BVH boxes in the ray-box test. The test's float64 rounding moves a
#: point by at most ~2.2e-16 of its distance to the origin per axis; 1e-12 covers that many
#: thousand times over, so no triangle a ray meets is culled (extra candidates only cost time).
BOX_GROW = 1e-12
LEAF = 4


def ulp(t, dtype):
    """Spacing of ``dtype`` (float32 or float64) at ``|t|``, as float64."""
    t = np.abs(np.asarray(t, np.float64))
    with np.errstate(over="ignore", invalid="ignore"):
        return np.spacing(t.astype(dtype)).astype(np.float64)


@dataclasses.dataclass
class Verdict:
    """The exact answers for ``N`` rays.

    Attributes
    ----------
    hit : numpy.ndarray
        ``(N,)`` bool: the ray hits a triangle in ``[tmin, tmax]``.
    t : numpy.ndarray
        ``(N,)`` float64: the exact first-hit parameter rounded to the nearest float64
        (``inf`` on a miss).
    triangle : numpy.ndarray
        ``(N,)`` int64: the smallest triangle id of the tie set, ``-1`` on a miss.
    tie_ptr, tie_ids : numpy.ndarray
        The tie sets in compressed rows: ray ``i``'s ties are
        ``tie_ids[tie_ptr[i]:tie_ptr[i + 1]]`` (ascending): every triangle hit at exactly ``t*``.
    zero_signs : numpy.ndarray
        ``(N,)`` uint8: of the first tie's crossing, how many side products are exactly zero
        (1: the ray crosses exactly on an edge, 2: exactly through a vertex).
    t_bound : numpy.ndarray
        ``(N,)`` float64: ``B`` of ``docs/referee.md``, the forward error bound of a plain
        float64 evaluation of the ray-plane quotient on the first tie (``0`` on a miss).
        Information only: :func:`judge` compares ``t`` with the exact ``t*``.
    t_num, t_den : numpy.ndarray
        ``(N,)`` object arrays of Python ints: ``t* = t_num / t_den`` exactly (``t_den > 0``);
        ``None`` on a miss.
    invalid : numpy.ndarray
        ``(N,)`` bool: a NaN or infinite component, a zero direction or NaN bounds.
    exact_pairs : int
        Ray-triangle pairs whose verdict needed exact arithmetic.
    """

    hit: np.ndarray
    t: np.ndarray
    triangle: np.ndarray
    tie_ptr: np.ndarray
    tie_ids: np.ndarray
    zero_signs: np.ndarray
    t_bound: np.ndarray
    invalid: np.ndarray
    t_num: np.ndarray = None
    t_den: np.ndarray = None
    exact_pairs: int = 0

    def __post_init__(self):
        if self.t_num is None:
            self.t_num = np.full(len(self.hit), None, object)
            self.t_den = np.full(len(self.hit), None, object)

    def __len__(self):
        return len(self.hit)

    @property
    def ties(self):
        """numpy.ndarray : ``(N,)`` size of each ray's tie set."""
        return np.diff(self.tie_ptr)

    def tie_set(self, i):
        """numpy.ndarray : the triangles tied at ray ``i``'s first hit."""
        return self.tie_ids[self.tie_ptr[i] : self.tie_ptr[i + 1]]

    def in_ties(self, triangle):
        """Whether each ray's given triangle id is in its tie set (``False`` on a miss)."""
        triangle = np.asarray(triangle, np.int64)
        n = len(self.hit)
        rows = np.repeat(np.arange(n, dtype=np.int64), self.ties)
        width = int(max(self.tie_ids.max(initial=0), triangle.max(initial=0))) + 2
        keys = rows * width + self.tie_ids
        probe = np.arange(n, dtype=np.int64) * width + np.where(triangle >= 0, triangle, width - 1)
        return np.isin(probe, keys)


@dataclasses.dataclass
class Crossings:
    """Every point where each of ``N`` rays meets the surface, exactly (``P`` points).

    A point is a distinct exact ``t`` in ``[tmin, tmax]`` at which the ray meets one or more
    closed triangles (never one whose plane holds the ray): where triangles share the edge or
    vertex the ray passes through, or overlap, they are one point.

    Attributes
    ----------
    ray_ptr : numpy.ndarray
        ``(N + 1,)`` int64: ray ``i``'s points are ``ray_ptr[i]:ray_ptr[i + 1]``, by exact
        ``t`` ascending.
    t : numpy.ndarray
        ``(P,)`` float64: each point's exact ``t`` rounded to the nearest float64.
    point_ptr : numpy.ndarray
        ``(P + 1,)`` int64: point ``p``'s triangles are ``point_ptr[p]:point_ptr[p + 1]`` of
        the next three arrays.
    triangle, zero_signs, t_bound : numpy.ndarray
        Per (point, triangle) pair: the triangle id, the number of its side products that
        are exactly zero (1: through an edge, 2: through a vertex) and ``B`` of
        ``docs/referee.md`` for a plain float64 evaluation of ``t`` on that triangle
        (information only).
    t_num, t_den : numpy.ndarray
        ``(P,)`` object arrays of Python ints: each point's exact ``t = t_num / t_den``
        (``t_den > 0``).
    invalid : numpy.ndarray
        ``(N,)`` bool: rays the referee refuses (as :attr:`Verdict.invalid`).
    """

    ray_ptr: np.ndarray
    t: np.ndarray
    point_ptr: np.ndarray
    triangle: np.ndarray
    zero_signs: np.ndarray
    t_bound: np.ndarray
    invalid: np.ndarray
    t_num: np.ndarray = None
    t_den: np.ndarray = None

    def __len__(self):
        return len(self.ray_ptr) - 1

    @property
    def count(self):
        """numpy.ndarray : ``(N,)`` int64, the points of each ray."""
        return np.diff(self.ray_ptr)

    def triangles_at(self, p):
        """numpy.ndarray : the triangles met at point ``p``."""
        return self.triangle[self.point_ptr[p] : self.point_ptr[p + 1]]


# -- small vector helpers over (K, 3) arrays ------------------------------------------------


def _cross(a, b):
    return np.stack(
        [
            a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1],
            a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2],
            a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0],
        ],
        axis=1,
    )


def _dot(a, b):
    return a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1] + a[:, 2] * b[:, 2]


def _perm(d, u, v):
    """Permanent of the determinant ``d . (u x v)``: the same sum with every term's magnitude."""
    d, u, v = np.abs(d), np.abs(u), np.abs(v)
    return _dot(
        d,
        np.stack(
            [
                u[:, 1] * v[:, 2] + u[:, 2] * v[:, 1],
                u[:, 2] * v[:, 0] + u[:, 0] * v[:, 2],
                u[:, 0] * v[:, 1] + u[:, 1] * v[:, 0],
            ],
            axis=1,
        ),
    )


def _certain_sign(value, perm):
    """+1/-1 where the float64 value's sign is certified by the filter, 0 where it is not."""
    ok = np.isfinite(value) & np.isfinite(perm) & (perm >= TINY)
    bound = FILTER * perm
    return np.where(ok & (value > bound), 1, np.where(ok & (value < -bound), -1, 0)).astype(np.int8)


# -- exact evaluation with Python integers -------------------------------------------------


def _exact_ints(values):
    """``(K, m)`` finite float64 -> ``(K, m)`` object array of Python ints, each row scaled by
    one power of two (so every homogeneous polynomial keeps its sign and every ratio of two of
    the same degree its value)."""
    m, e = np.frexp(values)
    mant = (m * 2.0**53).astype(np.int64)  # exact: a float64 has 53 significant bits
    exp = e.astype(np.int64) - 53
    exp = np.where(mant == 0, np.iinfo(np.int64).max, exp)
    low = exp.min(axis=1, keepdims=True)
    low = np.where(low == np.iinfo(np.int64).max, 0, low)
    shift = np.where(mant == 0, 0, exp - low)
    return mant.astype(object) << shift.astype(object)


def _ocross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def _odot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _exact_pairs(o, d, a, b, c):
    """Exact side products, numerator and denominator of ``t`` for ``(K, 3)`` float64 inputs.

    Returns ``signs`` ``(K, 3)`` int8 and ``num``, ``den`` object arrays of Python ints (both
    scaled by the same power of two, so ``t = num / den`` exactly).
    """
    ints = _exact_ints(np.concatenate([o, d, a, b, c], axis=1))
    O, D, A, B, C = ([ints[:, 3 * k + i] for i in range(3)] for k in range(5))
    u = [A[i] - O[i] for i in range(3)]
    v = [B[i] - O[i] for i in range(3)]
    w = [C[i] - O[i] for i in range(3)]
    s_ab = _odot(D, _ocross(u, v))
    s_bc = _odot(D, _ocross(v, w))
    s_ca = _odot(D, _ocross(w, u))
    num = _odot(u, _ocross(v, w))
    den = s_ab + s_bc + s_ca
    signs = np.stack(
        [(s > 0).astype(np.int8) - (s < 0).astype(np.int8) for s in (s_ab, s_bc, s_ca)], axis=1
    )
    return signs, num, den


def _meets(signs):
    """Closed-triangle crossing from exact signs: all >= 0 or all <= 0, not all zero."""
    nonneg = (signs >= 0).all(axis=1)
    nonpos = (signs <= 0).all(axis=1)
    return (nonneg | nonpos) & (signs != 0).any(axis=1)


def _frac(x):
    """A float as an exact (numerator, denominator) pair of Python ints."""
    return float(x).as_integer_ratio()


def _cmp_t(num, den, x):
    """Sign of ``num/den - x`` for Python ints num, den (den != 0) and a finite float x."""
    p, q = _frac(x)
    if den < 0:
        num, den = -num, -den
    lhs, rhs = num * q, p * den
    return (lhs > rhs) - (lhs < rhs)


def _prepare(origins, directions, tmin, tmax):
    """Rays as ``(N, 3)`` float64 (exact for float32 input), per-ray bounds, invalid rays."""
    o = np.asarray(origins, dtype=np.float64).reshape(-1, 3)
    d = np.asarray(directions, dtype=np.float64).reshape(-1, 3)
    n = len(o)
    if d.shape != o.shape:
        raise ValueError("origins and directions must both be (N, 3)")
    tmin = np.broadcast_to(np.asarray(tmin, np.float64), (n,)).copy()
    tmax = np.broadcast_to(np.asarray(tmax, np.float64), (n,)).copy()
    invalid = (
        ~np.isfinite(o).all(1)
        | ~np.isfinite(d).all(1)
        | ~(d != 0).any(1)
        | np.isnan(tmin)
        | np.isnan(tmax)
    )
    return o, d, tmin, tmax, invalid


# -- the hierarchy ---------------------------------------------------------------------------


class Referee:
    """Exact first hits on one triangle scene.

    Parameters
    ----------
    vertices : array_like
        ``(V, 3)`` float32 or float64 coordinates, taken exactly.
    faces : array_like
        ``(F, 3)`` vertex indices. Triangles without area are never hit (every ray lies in
        their plane).

    Examples
    --------
    >>> v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float)
    >>> r = Referee(v, [[0, 1, 2]])
    >>> ver = r.first_hits([[0.0, 0.0, 1.0]], [[0.0, 0.0, -1.0]])   # exactly at a vertex
    >>> bool(ver.hit[0]), float(ver.t[0]), int(ver.zero_signs[0])
    (True, 1.0, 2)
    """

    def __init__(self, vertices, faces):
        v = np.asarray(vertices)
        if v.dtype not in (np.float32, np.float64):
            v = v.astype(np.float64)
        self.vertices = v.astype(np.float64)  # exact for float32 input
        self.faces = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
        if len(self.faces) and (self.faces.min() < 0 or self.faces.max() >= len(self.vertices)):
            raise ValueError("faces index vertices that do not exist")
        if not np.isfinite(self.vertices).all():
            raise ValueError("vertices must be finite")
        self.tris = self.vertices[self.faces]  # (F, 3, 3)
        self._build()

    def _build(self):
        f = len(self.tris)
        lo, hi = self.tris.min(axis=1), self.tris.max(axis=1)
        n_leaves = 1
        while n_leaves * LEAF < max(f, 1):
            n_leaves *= 2
        self.depth = n_leaves.bit_length() - 1
        if f:
            c = (lo + hi) / 2
            span = np.maximum(c.max(0) - c.min(0), 1e-300)
            q = np.clip(((c - c.min(0)) / span * 1023).astype(np.int64), 0, 1023)
            code = np.zeros(f, np.int64)
            for bit in range(10):
                for axis in range(3):
                    code |= ((q[:, axis] >> bit) & 1) << (3 * bit + axis)
            order = np.argsort(code, kind="stable")
        else:
            order = np.zeros(0, np.int64)
        slots = np.full(n_leaves * LEAF, -1, np.int64)
        slots[:f] = order
        self.slots = slots.reshape(n_leaves, LEAF)
        inf = np.full(3, np.inf)
        slo = np.where((slots >= 0)[:, None], lo[np.maximum(slots, 0)] if f else inf, inf)
        shi = np.where((slots >= 0)[:, None], hi[np.maximum(slots, 0)] if f else -inf, -inf)
        levels = [(slo.reshape(n_leaves, LEAF, 3).min(1), shi.reshape(n_leaves, LEAF, 3).max(1))]
        while len(levels[-1][0]) > 1:
            l, h = levels[-1]
            levels.append((l.reshape(-1, 2, 3).min(1), h.reshape(-1, 2, 3).max(1)))
        self.levels = levels[::-1]  # levels[k] has 2^k boxes

    def hit_values(self, origins, directions, triangle):
        """The exact ``t``, barycentrics and point where each ray's line crosses the plane
        of a given triangle: what a caster's ``t``, ``u``, ``v`` and ``point`` for a hit on
        that triangle are judged against (:func:`judge_values`).

        Parameters
        ----------
        origins, directions : array_like
            ``(K, 3)`` float32 or float64 (taken exactly).
        triangle : array_like
            ``(K,)`` triangle ids (in the caller's faces); ``-1`` for none.

        Returns
        -------
        dict of numpy.ndarray
            Object arrays of :class:`fractions.Fraction`: ``t``, ``u`` (the weight of the
            triangle's second vertex), ``v`` (of its third) ``(K,)`` and ``point``
            ``(K, 3)`` (``o + t d``); ``None`` where no triangle is given or the line is
            parallel to its plane.
        """
        o = np.asarray(origins, np.float64).reshape(-1, 3)
        d = np.asarray(directions, np.float64).reshape(-1, 3)
        tri = np.asarray(triangle, np.int64).reshape(-1)
        k = len(tri)
        out = {name: np.full(k, None, object) for name in ("t", "u", "v")}
        out["point"] = np.full((k, 3), None, object)
        for i in np.flatnonzero(tri >= 0):
            oq = [Fraction(float(x)) for x in o[i]]
            dq = [Fraction(float(x)) for x in d[i]]
            a, b, c = ([Fraction(float(x)) for x in p] for p in self.tris[tri[i]])
            w = [a[j] - oq[j] for j in range(3)]
            e1 = [b[j] - a[j] for j in range(3)]
            e2 = [c[j] - a[j] for j in range(3)]
            den = _fdet(dq, e1, e2)
            if den == 0:
                continue
            t = _fdet(w, e1, e2) / den
            out["t"][i] = t
            out["u"][i] = _fdet(dq, e2, w) / den
            out["v"][i] = _fdet(dq, w, e1) / den
            out["point"][i] = [oq[j] + t * dq[j] for j in range(3)]
        return out

    def _candidates(self, o, d, tmin, tmax):
        """Every (ray, triangle) pair whose grown box the ray's [tmin, tmax] part may meet."""
        rays = np.arange(len(o))
        nodes = np.zeros(len(o), np.int64)
        # Scale each direction by a power of two (exact) so slab parameters cannot overflow.
        scale = np.exp2(-np.floor(np.log2(np.abs(d).max(axis=1))))
        ds = d * scale[:, None]
        with np.errstate(over="ignore", invalid="ignore"):
            t0s, t1s = tmin / scale, tmax / scale
        for k, (lo, hi) in enumerate(self.levels):
            if not len(rays):
                break
            oo, dd = o[rays], ds[rays]
            blo, bhi = lo[nodes], hi[nodes]
            with np.errstate(all="ignore"):  # empty (padding) boxes become NaN: never kept
                grow = BOX_GROW * (np.abs(oo) + np.maximum(np.abs(blo), np.abs(bhi))) + 1e-300
                blo, bhi = blo - grow, bhi + grow
                ta, tb = (blo - oo) / dd, (bhi - oo) / dd
            inside = (oo >= blo) & (oo <= bhi)
            zero = dd == 0
            near = np.where(zero, np.where(inside, -np.inf, np.inf), np.minimum(ta, tb))
            far = np.where(zero, np.where(inside, np.inf, -np.inf), np.maximum(ta, tb))
            tn = near.max(axis=1)
            tf = far.min(axis=1)
            # Slack on the parameters too: their rounding is relative, 1e-9 dwarfs it.
            fin = np.isfinite
            slack = 1e-9 * (np.abs(np.where(fin(tn), tn, 0)) + np.abs(np.where(fin(tf), tf, 0)))
            t0, t1 = t0s[rays], t1s[rays]
            with np.errstate(invalid="ignore"):
                keep = (
                    (tn <= tf + slack)
                    & (tf >= t0 - slack - 1e-9 * np.abs(t0))
                    & (tn <= t1 + slack + 1e-9 * np.abs(np.where(fin(t1), t1, 0)))
                )
            rays, nodes = rays[keep], nodes[keep]
            if k + 1 < len(self.levels):
                rays = np.repeat(rays, 2)
                nodes = (np.repeat(nodes, 2) * 2) + np.tile([0, 1], len(nodes))
        tri = self.slots[nodes].ravel()
        rays = np.repeat(rays, LEAF)
        keep = tri >= 0
        return rays[keep], tri[keep]

    def first_hits(
        self, origins, directions, tmin=0.0, tmax=np.inf, *, hint=None, leaving=None, chunk=2048
    ):
        """The exact first hit of every ray.

        Parameters
        ----------
        origins, directions : array_like
            ``(N, 3)`` float32 or float64 (taken exactly; directions need not be unit).
        tmin, tmax : float or array_like
            Per-ray or scalar bounds of the hit parameter (closed interval).
        hint : array_like, optional
            ``(N,)`` triangle ids, ``-1`` for none: a guess at each ray's first hit (from any
            caster). It only speeds the search up: a hinted triangle the referee finds surely
            hit bounds the region searched; the verdict does not depend on the hint.
        leaving : array_like, optional
            ``(N,)`` triangle ids, ``-1`` for none: rays started from a hit on that triangle
            (``Scene.cast(start=hits)``). Such a ray's hits must lie strictly beyond the
            point where its line crosses the triangle's plane (strictly beyond ``t = 0``
            when the line is parallel to that plane), on top of ``[tmin, tmax]``.
        chunk : int
            Rays per batch (bounds memory).

        Returns
        -------
        Verdict
        """
        o, d, tmin, tmax, invalid = _prepare(origins, directions, tmin, tmax)
        n = len(o)
        leaving = self._leaving(leaving, n)
        if leaving is not None:
            hint = None  # a hinted hit short of the leaving plane would bound the search wrongly
        if hint is not None:
            hint = np.broadcast_to(np.asarray(hint, np.int64), (n,))
            hint = np.where((hint >= 0) & (hint < len(self.tris)), hint, -1)
        out_t = np.full(n, np.inf)
        out_tri = np.full(n, -1, np.int64)
        zeros = np.zeros(n, np.uint8)
        bound = np.zeros(n)
        t_num = np.full(n, None, object)
        t_den = np.full(n, None, object)
        ties = []  # per chunk: (rays, triangles) of every tie
        exact_pairs = 0
        for s in range(0, n, chunk):
            idx = np.arange(s, min(s + chunk, n))
            idx = idx[~invalid[idx]]
            if not len(idx):
                continue
            exact_pairs += self._chunk(
                o,
                d,
                tmin,
                tmax,
                idx,
                hint,
                out_t,
                out_tri,
                zeros,
                bound,
                ties,
                leaving,
                (t_num, t_den),
            )
        rays = np.concatenate([x[0] for x in ties] + [np.zeros(0, np.int64)])
        ids = np.concatenate([x[1] for x in ties] + [np.zeros(0, np.int64)]).astype(np.int64)
        order = np.lexsort((ids, rays))  # by ray, then ascending triangle id
        ids = ids[order]
        ptr = np.zeros(n + 1, np.int64)
        np.cumsum(np.bincount(rays, minlength=n), out=ptr[1:])
        return Verdict(
            hit=out_tri >= 0,
            t=out_t,
            triangle=out_tri,
            tie_ptr=ptr,
            tie_ids=ids,
            zero_signs=zeros,
            t_bound=bound,
            invalid=invalid,
            t_num=t_num,
            t_den=t_den,
            exact_pairs=exact_pairs,
        )

    def crossings(self, origins, directions, tmin=0.0, tmax=np.inf, *, leaving=None, chunk=2048):
        """Every point where each ray meets the surface in ``[tmin, tmax]``, exactly.

        The reference for all hits, crossing counts and parity: each distinct exact ``t`` at
        which the ray meets a closed triangle (not one whose plane holds the ray) is one
        point, with every triangle met there.

        Parameters
        ----------
        origins, directions, tmin, tmax, leaving, chunk
            As for :meth:`first_hits`.

        Returns
        -------
        Crossings
        """
        o, d, tmin, tmax, invalid = _prepare(origins, directions, tmin, tmax)
        n = len(o)
        leaving = self._leaving(leaving, n)
        parts = []  # per chunk: (ray, new point, t, triangle, zeros, bound, num, den)
        for s in range(0, n, chunk):
            idx = np.arange(s, min(s + chunk, n))
            idx = idx[~invalid[idx]]
            if len(idx):
                parts.append(self._crossings_chunk(o, d, tmin, tmax, idx, leaving))
        cols = [np.concatenate([p[k] for p in parts] + [np.zeros(0)]) for k in range(6)]
        nums = np.concatenate([p[6] for p in parts] + [np.zeros(0, object)])
        dens = np.concatenate([p[7] for p in parts] + [np.zeros(0, object)])
        ray = cols[0].astype(np.int64)
        new_point = cols[1].astype(bool)
        tri, zeros, bound = cols[3].astype(np.int64), cols[4].astype(np.uint8), cols[5]
        starts = np.flatnonzero(new_point)
        point_ptr = np.r_[starts, len(ray)].astype(np.int64)
        ray_ptr = np.zeros(n + 1, np.int64)
        np.cumsum(np.bincount(ray[starts], minlength=n), out=ray_ptr[1:])
        return Crossings(
            ray_ptr=ray_ptr,
            t=cols[2][starts],
            point_ptr=point_ptr,
            triangle=tri,
            zero_signs=zeros,
            t_bound=bound,
            invalid=invalid,
            t_num=nums[starts],
            t_den=dens[starts],
        )

    def _leaving(self, leaving, n):
        """``leaving`` as ``(n,)`` int64 ids (-1: none), checked; None when not given."""
        if leaving is None:
            return None
        ids = np.broadcast_to(np.asarray(leaving, np.int64), (n,))
        if ((ids < -1) | (ids >= len(self.tris))).any():
            raise ValueError("leaving names triangles that do not exist")
        return ids

    def _beyond(self, o, d, r, f, pairs, keep, leaving):
        """``keep`` (pairs of rays ``r`` and triangles ``f`` met in range) less the pairs of
        rays leaving a triangle whose crossing does not lie strictly beyond the line's
        crossing of that triangle's plane (beyond t = 0 for a line parallel to it), exactly."""
        if leaving is None:
            return keep
        j = np.flatnonzero(keep & (leaving[r] >= 0))
        if not len(j):
            return keep
        want = np.zeros(len(r), bool)
        want[j] = True
        pairs.fill(want)
        rays = np.unique(r[j])
        t = self.tris[leaving[rays]]
        _, num, den = _exact_pairs(o[rays], d[rays], t[:, 0], t[:, 1], t[:, 2])
        plane = {
            int(k): Fraction(0) if dn == 0 else Fraction(nm, dn)
            for k, nm, dn in zip(rays, num, den)
        }
        out = keep.copy()
        for k in j:
            out[k] = Fraction(pairs.num[k], pairs.den[k]) > plane[int(r[k])]
        return out

    def _crossings_chunk(self, o, d, tmin, tmax, idx, leaving=None):
        """The (ray, triangle) pairs of ``idx``'s rays met in ``[tmin, tmax]``, ordered by ray
        and exact ``t``, with a flag on each pair that starts a new point."""
        empty = tuple(np.zeros(0) for _ in range(6)) + (np.zeros(0, object),) * 2
        r, f = self._candidates(o[idx], d[idx], tmin[idx], tmax[idx])
        r = idx[r]
        if not len(r):
            return empty
        pairs = _Pairs(self, o, d, r, f)
        h = np.flatnonzero(self._beyond(o, d, r, f, pairs, pairs.inside(tmin[r], tmax[r]), leaving))
        if not len(h):
            return empty
        want = np.zeros(len(r), bool)
        want[h] = True
        pairs.fill(want)
        te = _exact_t(pairs.num[h], pairs.den[h])
        order = np.lexsort((te, r[h]))
        h, te = h[order], te[order]
        rr = r[h]
        # Different rounded t: different exact t, in that order. Equal rounded t: compared
        # exactly (a run of pairs with one rounded t is sorted by exact value and split).
        same = np.r_[False, (rr[1:] == rr[:-1]) & (te[1:] == te[:-1])]
        new_point = ~same
        run_starts = np.flatnonzero(~same)
        run_ends = np.r_[run_starts[1:], len(h)]
        for a, b in zip(run_starts, run_ends):
            if b - a < 2:
                continue
            keyed = []
            for j in range(a, b):
                nm, dn = pairs.num[h[j]], pairs.den[h[j]]
                keyed.append((Fraction(nm, dn), j))
            keyed.sort()
            h[a:b] = [h[j] for _, j in keyed]
            new_point[a:b] = [k == 0 or keyed[k][0] != keyed[k - 1][0] for k in range(b - a)]
        zeros = (pairs.sign[h] == 0).sum(1)
        bound = _t_bound(pairs.O[h], pairs.D[h], pairs.A[h], pairs.B[h], pairs.C[h], te)
        num, den = _positive_den(pairs.num[h], pairs.den[h])
        return r[h], new_point, te, f[h], zeros, bound, num, den

    def _chunk(
        self, o, d, tmin, tmax, idx, hint, out_t, out_tri, zeros, bound, ties, leaving, exact
    ):
        prune = tmax.copy()
        exact_pairs = 0
        if hint is not None:
            # A hinted triangle that is surely hit bounds the search: boxes wholly past its
            # t cannot hold the first hit (nor a tie: the bound is its interval's top).
            hr = idx[hint[idx] >= 0]
            hp = _Pairs(self, o, d, hr, hint[hr])
            inside = hp.inside(tmin[hr], tmax[hr])
            prune[hr[inside]] = hp.t_hi[inside]
            exact_pairs += int(hp.have.sum())
        r, f = self._candidates(o[idx], d[idx], tmin[idx], prune[idx])
        r = idx[r]
        if not len(r):
            return exact_pairs
        pairs = _Pairs(self, o, d, r, f)
        inside = self._beyond(o, d, r, f, pairs, pairs.inside(tmin[r], tmax[r]), leaving)
        t_lo, t_hi = pairs.t_lo, pairs.t_hi
        enum, eden_, esign, fill = pairs.num, pairs.den, pairs.sign, pairs.fill
        O, D, A, B, C = pairs.O, pairs.D, pairs.A, pairs.B, pairs.C
        # First hit per ray: the smallest t_hi; every hit whose t_lo reaches it may tie.
        h = np.flatnonzero(inside)
        if not len(h):
            return exact_pairs + int(pairs.have.sum())
        order = np.lexsort((t_hi[h], r[h]))
        h = h[order]
        rr = r[h]
        first = np.flatnonzero(np.r_[True, rr[1:] != rr[:-1]])
        best_hi = np.repeat(t_hi[h[first]], np.diff(np.r_[first, len(h)]))
        contend = t_lo[h] <= best_hi
        hc = h[contend]
        want = np.zeros(len(r), bool)
        want[hc] = True
        fill(want)  # exact t for the winner (and any tie)
        rc = r[hc]
        starts = np.flatnonzero(np.r_[True, rc[1:] != rc[:-1]])
        sizes = np.diff(np.r_[starts, len(hc)])
        tied = [hc[starts[sizes == 1]]]  # one contender: it wins alone
        for a, k in zip(starts[sizes > 1], sizes[sizes > 1]):
            # several contenders (rare: rays near a tie): the exact minimum of num/den over
            # them, denominators made positive
            best, best_js = None, []
            for j in hc[a : a + k]:
                nm, dn = (enum[j], eden_[j]) if eden_[j] > 0 else (-enum[j], -eden_[j])
                if best is None or nm * best[1] < best[0] * dn:
                    best, best_js = (nm, dn), [j]
                elif nm * best[1] == best[0] * dn:
                    best_js.append(j)
            tied.append(np.asarray(best_js, np.int64))
        tied = np.concatenate(tied)
        ties.append((r[tied], f[tied]))
        # each ray's first tie: its smallest triangle id
        tied = tied[np.lexsort((f[tied], r[tied]))]
        first = tied[np.r_[True, r[tied][1:] != r[tied][:-1]]]
        rays = r[first]
        with np.errstate(all="ignore"):
            out_t[rays] = _exact_t(enum[first], eden_[first])
        out_tri[rays] = f[first]
        zeros[rays] = (esign[first] == 0).sum(1)
        bound[rays] = _t_bound(O[first], D[first], A[first], B[first], C[first], out_t[rays])
        exact[0][rays], exact[1][rays] = _positive_den(enum[first], eden_[first])
        return exact_pairs + int(pairs.have.sum())


class _Pairs:
    """Ray-triangle pairs: the float64 filter's verdicts and t intervals, and exact values
    filled in where the filter cannot decide (or where a caller asks for them)."""

    def __init__(self, referee, o, d, r, f):
        self.f = f
        O, D = o[r], d[r]
        tris = referee.tris[f]
        A, B, C = tris[:, 0], tris[:, 1], tris[:, 2]
        self.O, self.D, self.A, self.B, self.C = O, D, A, B, C
        k = len(r)
        with np.errstate(all="ignore"):  # overflow and underflow are sent to the exact path
            u, v, w = A - O, B - O, C - O
            s = np.stack([_dot(D, _cross(u, v)), _dot(D, _cross(v, w)), _dot(D, _cross(w, u))], 1)
            p = np.stack([_perm(D, u, v), _perm(D, v, w), _perm(D, w, u)], 1)
            sign = _certain_sign(s, p)
            miss = (sign > 0).any(1) & (sign < 0).any(1)
            meet = (sign > 0).all(1) | (sign < 0).all(1)
            # t = num / den with an interval that surely holds the exact value: the errors of
            # num and den (filter bounds, plus the rounding of the sum) and of the division.
            num = _dot(u, _cross(v, w))
            pnum = _perm(u, v, w)
            den = s.sum(1)
            eden = FILTER * p.sum(1) + 4 * EPS * np.abs(s).sum(1)
            tf = num / den
            dt = (FILTER * pnum + np.abs(tf) * eden) / (np.abs(den) - eden) + 4 * EPS * np.abs(tf)
            self.t_lo, self.t_hi = tf - dt, tf + dt
            good = (
                meet & np.isfinite(dt) & (np.abs(den) > eden) & (pnum >= TINY) & np.isfinite(pnum)
            )
        self.num = np.empty(k, object)
        self.den = np.empty(k, object)
        self.sign = np.zeros((k, 3), np.int8)
        self.have = np.zeros(k, bool)
        exact = ~miss & ~good  # the filter could not decide whether, or where, the line meets
        self.fill(exact)
        j = np.flatnonzero(exact)
        emeet = _meets(self.sign[j])
        self.meets = good.copy()
        self.meets[j] = emeet
        jj = j[emeet]
        te = _exact_t(self.num[jj], self.den[jj])
        # an exact t's interval: its nearest float64 and that float's neighbours
        self.t_lo[jj] = np.nextafter(te, -np.inf)
        self.t_hi[jj] = np.nextafter(te, np.inf)

    def fill(self, mask):
        """Evaluate the pairs in ``mask`` exactly (once)."""
        k = np.flatnonzero(mask & ~self.have)
        if len(k):
            sg, nm, dn = _exact_pairs(self.O[k], self.D[k], self.A[k], self.B[k], self.C[k])
            self.sign[k], self.num[k], self.den[k] = sg, nm, dn
            self.have[k] = True

    def inside(self, tmin, tmax):
        """Whether each pair's line crossing lies in ``[tmin, tmax]`` (exact where close)."""
        t_lo, t_hi, meets = self.t_lo, self.t_hi, self.meets
        sure_in = meets & (t_lo > tmin) & (t_hi < tmax)
        sure_out = ~meets | (t_hi < tmin) | (t_lo > tmax)
        edge = ~sure_in & ~sure_out
        self.fill(edge)
        inside = sure_in.copy()
        for j in np.flatnonzero(edge):
            nm, dn = self.num[j], self.den[j]
            ok = True
            if np.isfinite(tmin[j]):
                ok &= _cmp_t(nm, dn, tmin[j]) >= 0
            if np.isfinite(tmax[j]):
                ok &= _cmp_t(nm, dn, tmax[j]) <= 0
            inside[j] = ok
        return inside


def _exact_t(num, den):
    """Exact quotients of Python ints, rounded to the nearest float64 (CPython's int division
    rounds correctly); too large: inf."""
    out = np.empty(len(num))
    for i, (n, d) in enumerate(zip(num, den)):
        try:
            out[i] = n / d
        except OverflowError:
            out[i] = np.inf if (n > 0) == (d > 0) else -np.inf
    return out


def _fdet(a, b, c):
    """det(a, b, c) of three 3-vectors (exact for Fractions)."""
    return (
        a[0] * (b[1] * c[2] - b[2] * c[1])
        - a[1] * (b[0] * c[2] - b[2] * c[0])
        + a[2] * (b[0] * c[1] - b[1] * c[0])
    )


def judge_values(hits, values, dtype=None):
    """Whether each hit's ``t``, ``u``, ``v`` and ``point`` are within one ulp of the exact
    values on its triangle (:meth:`Referee.hit_values` for the hits' own triangles).

    Parameters
    ----------
    hits : Hits or Intersections
        Flat ``t``, ``u``, ``v`` ``(K,)`` and ``point`` ``(K, 3)`` (rows without an exact
        value, ``None`` in ``values``, are not judged).
    values : dict
        :meth:`Referee.hit_values` of the same rays and triangles.
    dtype : numpy.dtype, optional
        The output type whose ulp is allowed (default: that of ``hits.t``).

    Returns
    -------
    dict of numpy.ndarray
        ``(K,)`` bool masks ``judged`` (rows with exact values) and ``t_off``, ``u_off``,
        ``v_off``, ``point_off`` (judged rows more than an ulp away, exactly).
    """
    dtype = np.asarray(hits.t).dtype if dtype is None else np.dtype(dtype)
    judged = np.array([x is not None for x in values["t"]], bool)
    out = {"judged": judged}
    cols = {
        "t": (np.asarray(hits.t, np.float64).reshape(-1), values["t"]),
        "u": (np.asarray(hits.u, np.float64).reshape(-1), values["u"]),
        "v": (np.asarray(hits.v, np.float64).reshape(-1), values["v"]),
    }
    point = np.asarray(hits.point, np.float64).reshape(-1, 3)
    for k in range(3):
        cols[f"point{k}"] = (point[:, k], values["point"][:, k])
    j = np.flatnonzero(judged)
    for name, (got, exact) in cols.items():
        off = np.zeros(len(judged), bool)
        if len(j):
            fr = exact[j]
            num = np.array([x.numerator for x in fr], dtype=object)
            den = np.array([x.denominator for x in fr], dtype=object)
            rounded = np.array([_to_float(x) for x in fr])
            off[j] = ~within_ulp(got[j], rounded, num, den, dtype)
        key = "point_off" if name.startswith("point") else f"{name}_off"
        out[key] = out.get(key, np.zeros(len(judged), bool)) | off
    return out


def _to_float(x):
    """A Fraction rounded to the nearest float64 (CPython divides ints correctly rounded);
    beyond float64: an infinity."""
    try:
        return float(x)
    except OverflowError:
        return np.inf if x > 0 else -np.inf


def _positive_den(num, den):
    """``num / den`` as object arrays of ints with ``den > 0`` (the same quotients)."""
    num = np.array([-n if dn < 0 else n for n, dn in zip(num, den)], dtype=object)
    den = np.array([-dn if dn < 0 else dn for dn in den], dtype=object)
    return num, den


#: Significant bits and the smallest normal binade of each output type.
_FORMAT = {np.dtype(np.float32): (24, -126), np.dtype(np.float64): (53, -1022)}


def _ulp_exponent(num, den, dtype):
    """k with ``2^k = ulp(num / den)`` in ``dtype``: the spacing in the binade of the exact
    quotient (``den > 0``), the smallest subnormal spacing at zero and below the normal
    range."""
    bits, emin = _FORMAT[np.dtype(dtype)]
    if num == 0:
        return emin - (bits - 1)
    n = abs(num)
    b = n.bit_length() - den.bit_length()
    # floor(log2(n / den)) is b or b - 1.
    at_least = n >= (den << b) if b >= 0 else (n << -b) >= den
    e = b if at_least else b - 1
    return max(e, emin) - (bits - 1)


def _within_ulp_exact(t, num, den, dtype):
    """``|t - num/den| <= ulp(num/den)`` in ``dtype``, in exact arithmetic."""
    if not np.isfinite(t):
        return False
    k = _ulp_exponent(num, den, dtype)
    x = Fraction(float(t)) - Fraction(num, den)
    ulp_ = Fraction(2) ** k
    return abs(x) <= ulp_


def within_ulp(t, t_star, num, den, dtype):
    """Whether each ``t`` is within one ulp of the exact ``t* = num / den``.

    The contract's rule: ``|t - t*| <= ulp(t*)``, with ``ulp(t*)`` the spacing of ``dtype``
    (the caster's output type) in the binade of the exact ``t*``. Decided exactly: float64
    sure cases first (``t_star``, the exact value rounded to the nearest float64, is within
    half a float64 spacing of it), the rest in rationals.

    Parameters
    ----------
    t, t_star : array_like
        ``(K,)`` the caster's values (as float64) and the rounded exact ones.
    num, den : array_like
        ``(K,)`` object arrays of ints, ``den > 0``.
    dtype : numpy.dtype
        float32 or float64.

    Returns
    -------
    numpy.ndarray
        ``(K,)`` bool.
    """
    t = np.asarray(t, np.float64)
    r = np.asarray(t_star, np.float64)
    bits, emin = _FORMAT[np.dtype(dtype)]
    with np.errstate(invalid="ignore", over="ignore"):
        diff = np.abs(t - r)
        half64 = np.spacing(np.abs(r)) / 2  # >= |r - t*|
        mant, exp = np.frexp(r)
        e = np.maximum(exp - 1, emin)
        u_hi = np.ldexp(1.0, e - (bits - 1))
        # At a power of two t* may lie in the binade below, whose spacing is half.
        u_lo = np.where(np.abs(mant) == 0.5, u_hi / 2, u_hi)
        u_lo = np.where(r == 0, np.ldexp(1.0, emin - (bits - 1)), u_lo)
        sure = np.isfinite(t) & np.isfinite(r) & (diff + half64 <= u_lo) & (r != 0)
        sure_not = ~np.isfinite(t) | (np.isfinite(r) & (r != 0) & (diff - half64 > u_hi))
    out = sure.copy()
    for i in np.flatnonzero(~sure & ~sure_not):
        out[i] = _within_ulp_exact(t[i], num[i], den[i], dtype)
    return out


def _t_bound(o, d, a, b, c, t):
    """``B`` of docs/referee.md for ``(K, 3)`` rays and triangles: the forward error bound of a
    float64 evaluation of t on the triangle, anchored at the ray's origin or at the triangle's
    first vertex (the two permanents are summed, so either evaluation is covered)."""
    u, v, w = a - o, b - o, c - o
    e1, e2, tv = b - a, c - a, o - a
    with np.errstate(all="ignore"):
        den = np.abs(_dot(d, _cross(e1, e2)))
        p_num = _perm(u, v, w) + _perm(e2, tv, e1)
        p_den = _perm(d, u, v) + _perm(d, v, w) + _perm(d, w, u) + _perm(d, e1, e2)
        t = np.abs(t)
        return (8 * EPS * p_num + t * 8 * EPS * p_den) / den + 2 * EPS * t


def first_hits(vertices, faces, origins, directions, tmin=0.0, tmax=np.inf):
    """Exact first hits of rays on a triangle scene (see :class:`Referee`)."""
    return Referee(vertices, faces).first_hits(origins, directions, tmin, tmax)


#: Judgement names, in order of precedence (``docs/referee.md``).
JUDGEMENTS = ("right", "failed", "leaked", "late", "wrong")


def out_dtype(hits, arithmetic="f64"):
    """The precision of a cast's ``t`` values: its dtype, or float32 for a float32 caster
    (Embree) whatever container it returns them in."""
    return np.float32 if arithmetic == "f32" else np.asarray(hits.t).dtype


def judge(hits, verdict, arithmetic="f64"):
    """Judge a cast against the referee, ray by ray.

    Parameters
    ----------
    hits : Hits
        The cast (tetrace or a baseline) of the rays the verdict is for; ``t`` in the dtype
        it reports, whose ulp at ``t*`` is the one allowed.
    verdict : Verdict
    arithmetic : {"f64", "f32"}
        The precision the caster computes ``t`` in: ``"f32"`` (Embree) judges its ``t`` by
        float32's ulp whatever container it returns it in. Nothing else is excused: neither
        the rounding of float64 inputs to float32 nor a formula's own error.

    Returns
    -------
    dict of numpy.ndarray
        Boolean masks ``right``, ``failed``, ``leaked``, ``late``, ``wrong`` (exactly one holds
        per valid ray) and the parts of ``wrong``: ``phantom`` (a hit where the referee has
        none), ``early`` (a triangle not in the tie set, before ``t*``), ``other_triangle``
        (not in the tie set, within an ulp of ``t*``), ``t_off`` (the right triangle, ``t``
        more than an ulp from ``t*``: ``|t - t*| > ulp(t*)``, exactly), and ``invalid`` (rays
        the referee refuses; in no other mask).
    """
    from .hits import FAILED, HIT

    status = np.asarray(hits.status)
    valid = ~verdict.invalid
    failed = valid & (status == FAILED)
    c_hit = valid & (status == HIT)
    r_hit = verdict.hit
    leaked = valid & ~failed & r_hit & ~c_hit
    phantom = c_hit & ~r_hit
    both = c_hit & r_hit
    t = np.asarray(hits.t, np.float64)
    if arithmetic not in ("f64", "f32"):
        raise ValueError(f"arithmetic must be 'f64' or 'f32', got {arithmetic!r}")
    close = np.zeros(len(t), bool)
    k = np.flatnonzero(both)
    close[k] = within_ulp(
        t[k], verdict.t[k], verdict.t_num[k], verdict.t_den[k], out_dtype(hits, arithmetic)
    )
    # Not within an ulp of t*: then t is on the same side of t* as of its float64 rounding.
    off = ~close
    with np.errstate(invalid="ignore"):
        after = off & (t > verdict.t)
        before = off & ~after
    in_ties = verdict.in_ties(np.where(both, hits.triangle, -1))
    late = both & ~in_ties & after
    early = both & ~in_ties & before
    other = both & ~in_ties & ~after & ~before
    t_off = both & in_ties & off
    wrong = phantom | early | other | t_off
    right = valid & ~failed & ~leaked & ~late & ~wrong
    return dict(
        right=right,
        failed=failed,
        leaked=leaked,
        late=late,
        wrong=wrong,
        phantom=phantom,
        early=early,
        other_triangle=other,
        t_off=t_off,
        invalid=~valid,
    )


def judge_lists(offsets, t, triangle, crossings, arithmetic="f64", status=None):
    """Judge all-hits lists against the referee's :class:`Crossings`, ray by ray.

    Parameters
    ----------
    offsets : array_like
        ``(N + 1,)``: ray ``i``'s listed hits are ``offsets[i]:offsets[i + 1]``.
    t, triangle : array_like
        ``(M,)`` each listed hit's ``t`` and triangle id.
    crossings : Crossings
        The referee's points for the same rays.
    arithmetic : {"f64", "f32"}
        The precision the caster evaluates ``t`` in (see :func:`judge`).
    status : array_like, optional
        ``(N,)`` per-ray status; ``FAILED`` rays are judged failed.

    Returns
    -------
    dict of numpy.ndarray
        ``(N,)`` boolean masks: ``right`` (one listed hit per exact point, in order up to
        points whose exact ``t`` round alike, each naming a triangle met there, ``t`` within
        an ulp of the point's exact ``t``), ``failed``, ``missing`` (fewer hits listed than
        points), ``extra``
        (more: a point listed twice, or a hit the referee has not), ``wrong`` (as many, but
        a triangle or ``t`` that is not the point's), and ``invalid``.
    """
    from .hits import FAILED

    offsets = np.asarray(offsets, np.int64)
    t = np.asarray(t, np.float64)
    triangle = np.asarray(triangle, np.int64)
    n = len(offsets) - 1
    listed = np.diff(offsets)
    exact = crossings.count
    valid = ~crossings.invalid
    failed = valid & (
        np.zeros(n, bool) if status is None else (np.asarray(status).ravel() == FAILED)
    )
    judged = valid & ~failed
    missing = judged & (listed < exact)
    extra = judged & (listed > exact)
    same = judged & (listed == exact)
    dtype = np.float32 if arithmetic == "f32" else np.float64
    # Listed hit j of a ray with as many hits as points is checked against point j first.
    ray_of = np.repeat(np.arange(n), listed)
    rank = np.arange(len(t)) - offsets[ray_of]
    point = crossings.ray_ptr[ray_of] + rank
    ok = np.zeros(len(t), bool)
    sel = np.flatnonzero(same[ray_of])
    if len(sel):
        width = int(max(crossings.triangle.max(initial=0), triangle.max(initial=0))) + 2
        pair_point = np.repeat(np.arange(len(crossings.t)), np.diff(crossings.point_ptr))
        keys = pair_point * width + crossings.triangle
        order = np.argsort(keys, kind="stable")
        probe = point[sel] * width + np.where(triangle[sel] >= 0, triangle[sel], width - 1)
        at = np.clip(np.searchsorted(keys[order], probe), 0, max(len(keys) - 1, 0))
        found = len(keys) > 0
        member = keys[order][at] == probe if found else np.zeros(len(sel), bool)
        p = point[sel]
        close = within_ulp(t[sel], crossings.t[p], crossings.t_num[p], crossings.t_den[p], dtype)
        ok[sel] = member & close
    bad_rays = np.unique(ray_of[~ok & same[ray_of]])
    right = same.copy()
    for i in bad_rays:  # points whose exact t round alike may be listed in either order
        pts = list(range(crossings.ray_ptr[i], crossings.ray_ptr[i + 1]))
        used = set()
        if np.any(np.diff(t[offsets[i] : offsets[i + 1]]) < 0):
            right[i] = False  # not sorted by t
            continue
        for j in range(offsets[i], offsets[i + 1]):
            match = None
            for p in pts:
                if p in used:
                    continue
                tris = crossings.triangles_at(p)
                if (tris == triangle[j]).any() and _within_ulp_exact(
                    t[j], crossings.t_num[p], crossings.t_den[p], dtype
                ):
                    match = p
                    break
            if match is None:
                right[i] = False
                break
            used.add(match)
    wrong = same & ~right
    return dict(
        right=right,
        failed=failed,
        missing=missing,
        extra=extra,
        wrong=wrong,
        invalid=~valid,
    )
