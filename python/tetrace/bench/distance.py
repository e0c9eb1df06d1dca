"""How far ``t`` strays from the exact value as the origin moves away (issue 32's table).

A unit icosphere; per distance ``R``, rays from a sphere of radius ``R`` around it, each aimed
at a random point of a random triangle, cast in float64 and float32 through each accelerator.
``t`` is compared with the exact ``t*`` on the reported triangle, computed here in
:class:`fractions.Fraction` (not by the referee's judge); hit or miss and the triangle are
judged by the referee. The last column is the referee's old bound ``B`` (``t_bound``) relative
to ``t``: what the rule ``|t - t*| <= ulp + B`` excused before issue 32.
"""

from __future__ import annotations

import argparse
from fractions import Fraction

import numpy as np

#: Significant bits and the smallest normal binade of each precision.
_FORMAT = {"f32": (24, -126), "f64": (53, -1022)}


def _det(a, b, c):
    return (
        a[0] * (b[1] * c[2] - b[2] * c[1])
        - a[1] * (b[0] * c[2] - b[2] * c[0])
        + a[2] * (b[0] * c[1] - b[1] * c[0])
    )


def _ulp(x, precision):
    """The spacing of ``precision`` in the binade of the exact ``x``."""
    bits, emin = _FORMAT[precision]
    x = abs(x)
    if x == 0:
        return Fraction(2) ** (emin - bits + 1)
    e = x.numerator.bit_length() - x.denominator.bit_length()
    if Fraction(2) ** e > x:
        e -= 1
    return Fraction(2) ** (max(e, emin) - bits + 1)


def _exact_t(v, f, tri, o, d):
    """The exact t of the line (o, d) on triangle ``tri``'s plane."""
    a, b, c = ([Fraction(float(x)) for x in v[j]] for j in f[tri])
    o = [Fraction(float(x)) for x in o]
    d = [Fraction(float(x)) for x in d]
    e1 = [b[k] - a[k] for k in range(3)]
    e2 = [c[k] - a[k] for k in range(3)]
    return _det([a[k] - o[k] for k in range(3)], e1, e2) / _det(d, e1, e2)


def aimed_rays(rng, v, f, distance, n):
    """``n`` rays from a sphere of radius ``distance`` around the origin, each aimed at a
    random point of a random triangle of ``(v, f)``: float64 ``(n, 3)`` origins and
    directions (the aimed-at point rounded into the direction)."""
    u = rng.standard_normal((n, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    fi = rng.integers(0, len(f), n)
    w = rng.random((n, 2))
    w = np.where(w.sum(1, keepdims=True) > 1, 1 - w, w)
    a, b, c = (v[f[fi, k]] for k in range(3))
    o = distance * u
    return o, a + w[:, :1] * (b - a) + w[:, 1:] * (c - a) - o


def rows(distances, rays, accels, subdivisions=3, seed=7):
    """One row per (distance, precision, accelerator): counts and relative errors."""
    import trimesh

    import tetrace
    from tetrace.referee import Referee

    m = trimesh.creation.icosphere(subdivisions=subdivisions)
    v, f = np.asarray(m.vertices, np.float64), np.asarray(m.faces, np.int64)
    scene = tetrace.Scene.from_mesh((v, f))
    ref = Referee(v, f)
    out = []
    for r in distances:
        o, d = aimed_rays(np.random.default_rng([seed, int(np.log10(r) * 8)]), v, f, r, rays)
        for precision in ("f64", "f32"):
            dt = np.float32 if precision == "f32" else np.float64
            oo, dd = o.astype(dt), d.astype(dt)
            verdict = ref.first_hits(oo, dd)
            for accel in accels:
                h = scene.cast(oo, dd, accel=accel)
                hit = np.asarray(h.status) == tetrace.HIT
                ok = (hit == verdict.hit) & (~hit | verdict.in_ties(np.where(hit, h.triangle, -1)))
                errs, off = [], 0
                for i in np.flatnonzero(hit):
                    ts = _exact_t(v, f, h.triangle[i], oo[i], dd[i])
                    diff = abs(Fraction(float(h.t[i])) - ts)
                    errs.append(float(diff / abs(ts)) if ts else float(diff))
                    off += diff > _ulp(ts, precision)
                both = hit & verdict.hit
                out.append(
                    dict(
                        distance=r,
                        precision=precision,
                        accel=accel,
                        wrong=int((~ok).sum()),
                        hits=int(hit.sum()),
                        median=float(np.median(errs)) if errs else 0.0,
                        max=max(errs, default=0.0),
                        t_off=int(off),
                        bound=float((verdict.t_bound[both] / verdict.t[both]).max())
                        if both.any()
                        else 0.0,
                    )
                )
    return out


def distance_main(argv=None):
    p = argparse.ArgumentParser(
        prog="python -m tetrace.bench distance",
        description=__doc__.split("\n\n")[0],
    )
    p.add_argument("--distances", type=float, nargs="+", default=[3.0, 1e3, 1e4, 1e6, 1e8])
    p.add_argument("--rays", type=int, default=3000, help="rays per distance")
    p.add_argument(
        "--accel",
        action="append",
        help="accelerator (repeatable; default: every one of tetrace.accels())",
    )
    args = p.parse_args(argv)
    import tetrace

    accels = args.accel or [a for a in tetrace.accels() if "packets" not in a]
    print(
        "| R | prec | accel | triangle, hit/miss | rel. error of t, median | max "
        "| t more than 1 ulp off | old bound B / t, max |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for row in rows(args.distances, args.rays, accels):
        right = "all right" if row["wrong"] == 0 else f"{row['wrong']} wrong"
        print(
            f"| {row['distance']:g} | {row['precision']} | {row['accel']} | {right} "
            f"| {row['median']:.1e} | {row['max']:.1e} | {row['t_off']} of {row['hits']} "
            f"| {row['bound']:.1e} |",
            flush=True,
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(distance_main())
