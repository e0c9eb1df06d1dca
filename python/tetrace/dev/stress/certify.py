"""Certifying that each ray does what its family claims, with the exact referee."""

from fractions import Fraction

import numpy as np

# --------------------------------------------------------------------------- certification


def _ints(*arrays):
    """Float64 arrays (same leading length) -> object arrays of Python ints, all scaled by one
    power of two per row (so equalities and signs of homogeneous expressions are exact)."""
    cols = np.concatenate([np.asarray(a, np.float64).reshape(len(a), -1) for a in arrays], 1)
    mant, ex = np.frexp(cols)
    m = (mant * 2.0**53).astype(np.int64)
    ex = ex.astype(np.int64) - 53
    ex = np.where(m == 0, np.iinfo(np.int64).max, ex)
    low = ex.min(axis=1, keepdims=True)
    low = np.where(low == np.iinfo(np.int64).max, 0, low)
    shift = np.where(m == 0, 0, ex - low)
    out = m.astype(object) * (np.ones_like(shift, dtype=object) << shift.astype(object))
    parts, s = [], 0
    for a in arrays:
        w = int(np.prod(np.shape(a)[1:], dtype=np.int64))
        parts.append(out[:, s : s + w])
        s += w
    return parts


def exact_through(o, d, p, t):
    """Whether ``o + t d == p`` exactly, per ray (all float64 numbers, taken exactly)."""
    o, d, p = (np.asarray(x, np.float64) for x in (o, d, p))
    ok = np.zeros(len(o), bool)
    for i in range(len(o)):
        ti = Fraction(float(t[i]))
        ok[i] = all(
            Fraction(float(o[i, k])) + ti * Fraction(float(d[i, k])) == Fraction(float(p[i, k]))
            for k in range(3)
        )
    return ok


def _plane_dets(o, d, tri):
    """Per ray, the exact integers ``det(b - a, c - a, o - a)`` and ``det(b - a, c - a, d)``
    (each row scaled by one positive power of two, so their signs and zeros are exact)."""
    O, D, A, B, C = _ints(o, d, tri[:, 0], tri[:, 1], tri[:, 2])

    def det(x, y, z):
        return (
            x[:, 0] * (y[:, 1] * z[:, 2] - y[:, 2] * z[:, 1])
            - x[:, 1] * (y[:, 0] * z[:, 2] - y[:, 2] * z[:, 0])
            + x[:, 2] * (y[:, 0] * z[:, 1] - y[:, 1] * z[:, 0])
        )

    e1, e2 = B - A, C - A
    return det(e1, e2, O - A), det(e1, e2, D)


def exact_in_plane(o, d, tri):
    """Whether the line ``o + t d`` lies exactly in the plane of each triangle ``(N, 3, 3)``:
    ``det(b - a, c - a, o - a) == 0`` and ``det(b - a, c - a, d) == 0`` in exact integers."""
    off, along = _plane_dets(o, d, tri)
    return np.array([x == 0 for x in off], bool) & np.array([x == 0 for x in along], bool)


def exact_parallel(o, d, tri):
    """Whether the line ``o + t d`` is exactly parallel to the plane of each triangle
    ``(N, 3, 3)`` without lying in it (``det(b - a, c - a, d) == 0 != det(b - a, c - a, o - a)``):
    it never meets the triangle. Returns ``(parallel, side)``, ``side`` the sign of
    ``det(b - a, c - a, o - a)`` (the side of the plane the line runs on; 0 in it)."""
    off, along = _plane_dets(o, d, tri)
    side = np.array([(x > 0) - (x < 0) for x in off], np.int8)
    return np.array([x == 0 for x in along], bool) & (side != 0), side


def check_claims(case, verdict, precision):
    """Per ray, whether every claim of ``case`` holds for its rays in ``precision`` and their
    exact ``verdict``; returns ``(ok, failures)``, ``failures`` a dict claim -> mask."""
    c = case.claims
    o, d = case.rays(precision)
    o, d = o.astype(np.float64), d.astype(np.float64)
    fail = {}
    h = c["hit"]
    fail["hit"] = (h >= 0) & (verdict.hit != (h == 1))
    tc = ~np.isnan(c["t"])
    with np.errstate(invalid="ignore"):
        fail["t"] = tc & ~(verdict.hit & (verdict.t == c["t"]))
    zc = c["zs_lo"] >= 0
    zs = verdict.zero_signs.astype(np.int16)
    fail["zero_signs"] = zc & ~(verdict.hit & (zs >= c["zs_lo"]) & (zs <= c["zs_hi"]))
    it = c["in_tie"] >= 0
    fail["in_tie"] = it & ~verdict.in_ties(np.where(it, c["in_tie"], -1))
    nt = np.zeros(len(o), bool)
    for col in range(c["not_tie"].shape[1]):
        x = c["not_tie"][:, col]
        nt |= (x >= 0) & verdict.in_ties(np.where(x >= 0, x, -1))
    fail["not_tie"] = nt
    th = ~np.isnan(c["through_t"])
    bad = np.zeros(len(o), bool)
    if th.any():
        idx = np.flatnonzero(th)
        bad[idx] = ~exact_through(o[idx], d[idx], c["through"][idx], c["through_t"][idx])
    fail["through"] = bad
    pl = c["plane"] >= 0
    bad = np.zeros(len(o), bool)
    if pl.any():
        idx = np.flatnonzero(pl)
        tri = case.vertices[case.faces[c["plane"][idx]]]
        bad[idx] = ~exact_in_plane(o[idx], d[idx], tri)
    fail["plane"] = bad
    pa = c["parallel"] >= 0
    bad = np.zeros(len(o), bool)
    if pa.any():
        idx = np.flatnonzero(pa)
        tri = case.vertices[case.faces[c["parallel"][idx]]]
        bad[idx] = ~exact_parallel(o[idx], d[idx], tri)[0]
    fail["parallel"] = bad | (pa & verdict.in_ties(np.where(pa, c["parallel"], -1)))
    fail["invalid"] = verdict.invalid
    ok = np.ones(len(o), bool)
    for m in fail.values():
        ok &= ~m
    return ok, fail


def _subset_verdict(ver, keep):
    from ...referee import Verdict

    idx = np.flatnonzero(keep)
    counts = np.diff(ver.tie_ptr)[idx]
    ptr = np.zeros(len(idx) + 1, np.int64)
    np.cumsum(counts, out=ptr[1:])
    ids = (
        np.concatenate([ver.tie_ids[ver.tie_ptr[i] : ver.tie_ptr[i + 1]] for i in idx])
        if len(idx)
        else np.zeros(0, np.int64)
    )
    return Verdict(
        hit=ver.hit[idx],
        t=ver.t[idx],
        triangle=ver.triangle[idx],
        tie_ptr=ptr,
        tie_ids=ids.astype(np.int64),
        zero_signs=ver.zero_signs[idx],
        t_bound=ver.t_bound[idx],
        invalid=ver.invalid[idx],
        t_num=ver.t_num[idx],
        t_den=ver.t_den[idx],
        exact_pairs=ver.exact_pairs,
    )


def _take(case, keep):
    case.origins, case.directions = case.origins[keep], case.directions[keep]
    case.tmin, case.tmax, case.kind = case.tmin[keep], case.tmax[keep], case.kind[keep]
    case.claims = {k: v[keep] for k, v in case.claims.items()}


def subset(case, n):
    """A copy of a certified case keeping about ``n`` of its rays, evenly strided (so every
    kind keeps its share: the rays are stored kind by kind), with their verdicts."""
    import dataclasses

    step = max(1, -(-len(case) // max(n, 1)))
    keep = np.arange(len(case)) % step == 0
    out = dataclasses.replace(case, claims=dict(case.claims), verdicts=dict(case.verdicts))
    _take(out, keep)
    out.verdicts = {p: _subset_verdict(v, keep) for p, v in case.verdicts.items()}
    out.uncertified = getattr(case, "uncertified", 0)
    return out


def certify(case, keep_uncertified=False):
    """Compute the referee's verdicts of the case's rays in both precisions, check every claim
    (:func:`check_claims`), record the certified fraction per precision in
    ``case.certified``, keep only the rays certified in both (unless ``keep_uncertified``) and
    store their verdicts in ``case.verdicts``. Returns the case."""
    from ...referee import Referee

    def is32(x):
        return x.astype(np.float32).astype(np.float64) == x

    if not is32(case.vertices).all():
        raise AssertionError(f"{case.family}: the vertices are not float32 numbers")
    # Rays of an exact32 family must be float32 numbers: a construction error where the
    # family is built exact; on a real mesh, a ray that does not certify.
    f32ok = np.ones(len(case), bool)
    if case.exact32:
        f32ok = is32(case.origins).all(1) & is32(case.directions).all(1)
        if case.built_exact and not f32ok.all():
            raise AssertionError(
                f"{case.family}: {int((~f32ok).sum())} rays are not float32 numbers"
            )
    ref = Referee(case.vertices, case.faces)
    verdicts, oks = {}, {}
    n = len(case)
    for p in ("f64", "f32"):
        if p == "f32" and case.exact32:
            verdicts[p] = verdicts["f64"]  # the same numbers: the same verdict
        else:
            o, d = case.rays(p)
            verdicts[p] = ref.first_hits(o, d, case.tmin, case.tmax)
        oks[p] = check_claims(case, verdicts[p], p)[0] & f32ok
    case.candidates = n
    case.certified = {p: float(oks[p].mean()) if n else 1.0 for p in oks}
    keep = oks["f64"] & oks["f32"]
    case.uncertified = int((~keep).sum())
    if keep_uncertified or keep.all():
        case.verdicts = verdicts
        return case
    _take(case, keep)
    case.verdicts = {p: _subset_verdict(v, keep) for p, v in verdicts.items()}
    return case
