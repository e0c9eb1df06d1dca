"""Secondary rays: Lagae & Dutré 2008's ray connectivity against locating every origin, and
against the epsilon offset renderers use (``python -m tetrace.bench secondary``).

A camera's float32 hits on one scene, then two passes from every hit, as a renderer casts
them: **shadow** rays to a point light (any hit, ``tmax = 1``) and diffuse **bounce** rays
(closest hit, cosine-weighted about the normal on the side the camera sees). Each pass runs
four ways on the same directions, one thread, best of ``repeat``:

* ``start=hits``: each ray starts in the tet its hit's walk ended in (no point location);
* ``start=hits``, no tet: the same rays and answers, each origin located (the hits' ``tet``
  set to -1), the baseline Lagae & Dutré measured connectivity against;
* tetrace from offset origins ``point + eps * n`` (n turned to the ray's side), as renderers
  do to avoid self-hits; ``eps`` a fraction of the scene's diagonal;
* embreex (Embree, robust flag) from the same offset origins.

Every row is judged by the exact referee (``leaving=``: the rule of ``start=hits``): the
``start=hits`` rows must be right on every ray (hit or miss, the triangle, ``t`` within the
referee's bound); the offset rows answer a slightly different question (a moved origin, whose
``t`` is measured from there) and the table counts the rays where that changes the answer:
hit or miss, or the triangle hit.
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from ..hits import HIT


def _best(fn, repeat):
    fn()  # warm-up, untimed
    best, out = np.inf, None
    for _ in range(max(int(repeat), 1)):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def _cosine_bounces(n, rng):
    """Cosine-weighted unit directions about the unit normals ``n`` ``(N, 3)``."""
    u1, u2 = rng.random(len(n)), rng.random(len(n))
    r, phi = np.sqrt(u1), 2 * np.pi * u2
    local = np.stack([r * np.cos(phi), r * np.sin(phi), np.sqrt(1 - u1)], 1)
    a = np.where(np.abs(n[:, :1]) > 0.9, [[0.0, 1.0, 0.0]], [[1.0, 0.0, 0.0]])
    t = np.cross(n, a)
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    b = np.cross(n, t)
    return local[:, :1] * t + local[:, 1:2] * b + local[:, 2:] * n


def _subset(hits, mask):
    """The hits of the rays in ``mask`` (every array field indexed)."""
    fields = {
        f.name: (np.asarray(getattr(hits, f.name))[mask] if getattr(hits, f.name) is not None
                 else None)
        for f in dataclasses.fields(hits)
    }  # fmt: skip
    return dataclasses.replace(hits, **fields)


def _setup(path, res, rng):
    """The scene, the camera's hits (only the rays that hit), the normals on the side the
    camera sees and each pass's float32 directions."""
    from ..dev.camera import orbit_views, pinhole
    from ..scene import Scene, default_scene_path

    path = str(path) if path is not None else str(default_scene_path())
    scene = Scene.from_mesh(path)
    v = scene.vertices
    lo, hi = v.min(0), v.max(0)
    eye, target, up = orbit_views(np.array([lo, hi]), n=1, distance=2.0)[0]
    o, d = pinhole(eye, target, up, fov_deg=40.0, width=res, height=res, dtype=np.float32)
    all_hits = scene.cast(o, d)
    hit = all_hits.status == HIT
    hits, d = _subset(all_hits, hit), d[hit]
    n = hits.normal.astype(np.float64)
    n *= np.where(np.sum(n * d, axis=1, keepdims=True) > 0, -1.0, 1.0)
    # A light inside the scene's box, high up (in a room: under the ceiling).
    light = (lo + hi) / 2 + np.array([0.1, 0.35, 0.1]) * (hi - lo)
    shadow = (light - hits.point).astype(np.float32)
    bounce = _cosine_bounces(n, rng).astype(np.float32)
    return scene, path, hits, n, {"shadow": shadow, "bounce": bounce}


def _wrong(scene, hits, d, tmax, got_hit, got_t=None, got_tri=None, moved=False):
    """Rays whose answer differs from the exact one for rays started from ``hits``: hit or
    miss, the triangle (one of those tied) and ``t`` within the referee's bound; ``moved``
    (rays cast from another origin, whose ``t`` is measured from there): hit or miss and the
    triangle only."""
    from ..referee import Referee, judge

    o, dd = hits.point.astype(np.float64), d.astype(np.float64)
    verdict = Referee(scene.vertices, scene.faces).first_hits(
        o, dd, 0.0, tmax, leaving=hits.scene_triangle
    )
    if got_t is None:  # any hit: only the yes/no is asked
        return int((np.asarray(got_hit, bool) != verdict.hit).sum())
    if moved:
        got_hit = np.asarray(got_hit, bool)
        same = (got_hit == verdict.hit) & (
            ~got_hit | verdict.in_ties(np.where(got_hit, got_tri, -1))
        )
        return int((~same).sum())
    got = dataclasses.replace(
        hits, status=np.where(got_hit, HIT, 0).astype(np.uint8), t=got_t, triangle=got_tri
    )
    return int((~judge(got, verdict, "f32")["right"]).sum())


def run_secondary(paths, res=256, repeat=3, eps=1e-4, seed=7):
    """Print the table for each scene (see the module's docstring); return the rows."""
    from ..baselines.embree import embree_scene

    rows = []
    for path in paths:
        scene, name, hits, n, passes = _setup(path, res, np.random.default_rng(seed))
        embree = embree_scene((scene.vertices, scene.faces))
        print(
            f"\n{name}: {len(scene.faces)} triangles, {scene.n_tets} tets; {res}x{res} camera, "
            f"{len(hits.t)} hits, one shadow and one bounce ray from each; offset eps = "
            f"{eps:g} x diagonal; 1 thread, best of {repeat}"
        )
        print("| pass | caster | Mrays/s | steps/ray | wrong (exact referee) |")
        print("|---|---|---|---|---|")
        for kind, d in passes.items():
            for row in _pass(scene, embree, hits, n, kind, d, eps, repeat):
                st = "" if row["steps_per_ray"] is None else f"{row['steps_per_ray']:.1f}"
                print(
                    f"| {kind} | {row['caster']} | {row['mrays_per_s']:.2f} | {st} | "
                    f"{row['wrong']} of {row['rays']} |"
                )
                rows.append(dict(row, scene=name, kind=kind))
    return rows


def _pass(scene, embree, hits, n, kind, d, eps, repeat):
    """One pass's rows: each caster's rate, tets per ray and answers the referee rejects."""
    shadow = kind == "shadow"
    tmax = 1.0 if shadow else np.inf
    k = len(hits.t)
    diag = float(np.linalg.norm(scene.vertices.max(0) - scene.vertices.min(0)))
    side = np.where(np.sum(n * d, axis=1, keepdims=True) >= 0, 1.0, -1.0)
    offset = (hits.point + eps * diag * side * n).astype(np.float32)
    tf = np.full(k, tmax, np.float32)
    no_tet = dataclasses.replace(hits, tet=np.full_like(hits.tet, -1))

    def from_hits(start):
        if shadow:
            return scene.occluded(start=start, directions=d, tmax=tmax, threads=1)
        return scene.cast(start=start, directions=d, threads=1)

    def from_offset():
        if shadow:
            return scene.occluded(offset, d, tmax=tmax, threads=1)
        return scene.cast(offset, d, tmax=tmax, threads=1)

    def embree_offset():
        if shadow:
            return embree.occluded(offset, d, tf, threads=1)
        return embree.intersect(offset, d, tf, threads=1)

    def steps(start):
        return float(scene.cast(start=start, directions=d, tmax=tmax, threads=1).steps.mean())

    casters = (
        ("tetrace start=hits (connectivity)", lambda: from_hits(hits), steps(hits)),
        ("tetrace start=hits, every origin located", lambda: from_hits(no_tet), steps(no_tet)),
        ("tetrace, offset origins", from_offset, None),
        ("embreex, offset origins", embree_offset, None),
    )
    rows = []
    for label, fn, st in casters:
        seconds, out = _best(fn, repeat)
        if shadow:
            wrong = _wrong(scene, hits, d, tmax, out)
        elif label.startswith("embreex"):
            prim, t, _, _ = out
            wrong = _wrong(scene, hits, d, tmax, prim >= 0, t, prim.astype(np.int32), True)
        else:
            moved = "offset" in label
            wrong = _wrong(scene, hits, d, tmax, out.status == HIT, out.t, out.triangle, moved)
        rows.append(
            dict(caster=label, mrays_per_s=k / seconds / 1e6, steps_per_ray=st, wrong=wrong,
                 rays=k)
        )  # fmt: skip
    return rows


def secondary_main(argv):
    import argparse

    p = argparse.ArgumentParser(
        prog="python -m tetrace.bench secondary",
        description="Shadow and bounce rays from a camera's hits: start=hits (ray "
        "connectivity) against locating every origin and against offset origins (tetrace "
        "and embreex), judged by the exact referee.",
    )
    p.add_argument("scenes", nargs="*", help="mesh files (default: the bundled scene)")
    p.add_argument("--res", type=int, default=256)
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--eps", type=float, default=1e-4, help="offset, a fraction of the diagonal")
    args = p.parse_args(argv)
    run_secondary(args.scenes or [None], res=args.res, repeat=args.repeat, eps=args.eps)
    return 0
