"""``python -m tetrace.bench occupancy`` (or ``python -m tetrace.bench.occupancy``):
inside/outside of a scan with holes (the Stanford bunny by default), tetrace against trimesh
and Open3D, judged against a closed copy.

The reference: the scan's holes closed by :func:`close_holes` (a fan of triangles from each
boundary loop to the loop's centroid), checked closed, edge-manifold and consistently oriented,
and its inside decided exactly by the crossing parity of the exact referee
(:func:`tetrace.bench.queries.reference_contains`, which shares no code with the scene).

Where the scan may rightly differ from that copy: the copy is the scan plus the fan patches,
so the scan's winding number is the copy's (exactly 0 or 1 off its surface, as it is closed
and embedded) minus the patches' own, ``w_scan = w_copy - w_patch``. The threshold at 1/2
therefore gives the copy's answer wherever ``|w_patch| < 1/2``, and may differ only where the
patches alone subtend at least half the sphere, which happens only very near them (a flat patch
never does; the fans of a scan's holes are nearly flat). Those points, the *band*, are counted
apart: ``|w_patch| >= 1/2 - 1e-6`` with ``w_patch`` summed exactly, the 1e-6 covering the
rounding of the sums. Every caster's agreement is reported on all points and outside the band.

Casters, on the same points (float32 values, as Open3D takes them), each timed as the best
of ``repeat`` calls after one untimed call: tetrace's ``Scene.contains`` in its default mode
(the winding number on this open mesh) and in ``mode="parity"`` (what it answered before:
every point escapes through a hole); libigl's exact and fast winding numbers alone (what the
winding mode combines: the measurement behind its choice); trimesh's ``Trimesh.contains``
(ray parity); Open3D's ``RaycastingScene.compute_occupancy`` with ``nsamples`` rays per
point voting.
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings

import numpy as np

from .queries import _best

#: Open3D's ``nsamples`` values timed (odd: its vote needs a majority).
NSAMPLES = (1, 5, 11)
#: Slack on the patches' exact winding number for the band (rounding of the sums).
BAND_SLACK = 1e-6


def boundary_loops(faces):
    """The mesh's holes: each boundary loop as vertex indices in the order of its boundary
    half-edges (a boundary half-edge is a triangle's directed edge whose reverse no triangle
    has). A vertex on two loops (a pinch) raises ValueError."""
    f = np.asarray(faces, np.int64)
    a, b = f.ravel(), f[:, [1, 2, 0]].ravel()
    n = int(f.max()) + 1 if len(f) else 1
    lone = ~np.isin(a * n + b, b * n + a)
    start, end = a[lone].tolist(), b[lone].tolist()
    if len(set(start)) != len(start):
        raise ValueError("a vertex lies on two boundary loops (a pinch); no fan closes it")
    following = dict(zip(start, end))
    loops, seen = [], set()
    for s in start:
        if s in seen:
            continue
        loop, x = [s], following[s]
        seen.add(s)
        while x != s:
            loop.append(x)
            seen.add(x)
            x = following[x]
        loops.append(loop)
    return loops


def close_holes(vertices, faces):
    """Close every hole with a fan from its boundary loop to the loop's centroid.

    Parameters
    ----------
    vertices, faces : array_like
        A cleaned mesh (coincident vertices merged), consistently oriented.

    Returns
    -------
    vertices : numpy.ndarray
        The input's, then one centroid per hole.
    faces : numpy.ndarray
        The input's, then the patches' triangles, oriented as their neighbours (each boundary
        half-edge ``a -> b`` gets the triangle ``b, a, centroid``).
    n_patch : int
        How many triangles were added (the last rows of ``faces``).
    """
    v = np.asarray(vertices, np.float64)
    f = np.asarray(faces, np.int64)
    new_v, new_f = [v], [f]
    for k, loop in enumerate(boundary_loops(f)):
        c = len(v) + k
        new_v.append(v[loop].mean(axis=0, keepdims=True))
        a = np.asarray(loop)
        new_f.append(np.stack([np.roll(a, -1), a, np.full(len(a), c)], axis=1))
    patch = sum(len(x) for x in new_f[1:])
    return np.vstack(new_v), np.vstack(new_f), patch


def closed_reference(vertices, faces, points):
    """The reference of the module docstring for a scan ``(vertices, faces)``.

    Returns
    -------
    dict
        ``inside`` (bool, the closed copy's exact parity), ``band`` (bool: the patches'
        exact winding number is within :data:`BAND_SLACK` of +-1/2 or beyond), ``holes``,
        ``patch_triangles``, ``band_distance`` (the largest distance from a band point to the
        nearest patch triangle, 0.0 when the band is empty), ``seconds``.
    """
    import igl

    from ..referee import Referee
    from ..winding import surface
    from .queries import reference_contains

    t0 = time.perf_counter()
    s = surface(vertices, faces)
    holes = len(boundary_loops(s.faces))
    cv, cf, n_patch = close_holes(s.vertices, s.faces)
    closed = surface(cv, cf)
    if not (closed.odd == closed.non_manifold == closed.misoriented == 0):
        raise ValueError(f"the closed copy is not closed and oriented: {closed.describe()}")
    p = np.ascontiguousarray(points, np.float64)
    inside, decided = reference_contains(Referee(cv, cf), p)
    if not decided.all():
        raise ValueError(f"{int((~decided).sum())} points found no generic ray")
    patch = np.ascontiguousarray(cf[len(cf) - n_patch :])
    w_patch = np.asarray(igl.winding_number(cv, patch, p)) if n_patch else np.zeros(len(p))
    band = np.abs(w_patch) >= 0.5 - BAND_SLACK
    band_distance = 0.0
    if band.any():
        d2 = igl.point_mesh_squared_distance(np.ascontiguousarray(p[band]), cv, patch)[0]
        band_distance = float(np.sqrt(np.max(d2)))
    return dict(
        inside=inside,
        band=band,
        holes=holes,
        patch_triangles=n_patch,
        band_distance=band_distance,
        seconds=time.perf_counter() - t0,
    )


def run_occupancy(path=None, *, n=20_000, seed=0, repeat=3, exact=True, out=print):
    """Time and judge inside/outside on ``n`` points uniform in the scene's bounding box.

    Parameters
    ----------
    path : str, optional
        A mesh file (default: the shared scenes' ``bunny.obj``).
    n, seed : int
        Points, and the seed that draws them.
    repeat : int
        Timed calls per caster; the best is kept.
    exact : bool
        Also time libigl's exact winding number on every point (about 0.1 ms a point).

    Returns
    -------
    list of dict
        One row per caster: ``caster``, ``seconds`` (best), ``first`` (first call),
        ``inside`` (fraction), ``agree`` and ``agree_outside_band`` (fractions of points
        answering as the reference), ``wrong`` (points that do not), ``wrong_farthest``
        (the largest distance from such a point to the scan, in bounding-box diagonals),
        ``points``, ``band``.
    """
    import igl
    import trimesh

    from ..scene import Scene
    from .casters import open3d_module
    from .scenes import default_scenes_dir

    path = str(path) if path else str(default_scenes_dir() / "bunny.obj")
    mesh = trimesh.load(path, force="mesh")
    v, f = np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces, np.int64)
    t0 = time.perf_counter()
    scene = Scene.from_mesh((v, f), progress=False)
    build = time.perf_counter() - t0
    lo, hi = v.min(axis=0), v.max(axis=0)
    rng = np.random.default_rng(seed)
    p32 = rng.uniform(lo, hi, (n, 3)).astype(np.float32)
    p = p32.astype(np.float64)  # the same values for every caster
    ref = closed_reference(v, f, p)
    t0 = time.perf_counter()
    s = scene._surface_info()  # the edge census behind is_closed: once per scene
    census = time.perf_counter() - t0
    out(
        f"scene {path}: {len(f):,} triangles, is_closed {scene.is_closed} ({s.describe()}); "
        f"tetrace build {build:.1f} s, edge census {census:.2f} s; {n:,} points uniform in "
        f"the bounding box (seed {seed}); "
        f"cores: {_cores()}"
    )
    out(
        f"reference: {ref['holes']} holes closed by {ref['patch_triangles']} fan triangles, "
        f"exact parity of the closed copy ({ref['seconds']:.1f} s): "
        f"{ref['inside'].mean():.2%} inside; band (|w_patch| >= 1/2 - {BAND_SLACK:g}): "
        f"{int(ref['band'].sum())} points, within {ref['band_distance']:.2g} of a patch"
    )

    def parity():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # the open-mesh warning: known here
            return scene.contains(p, mode="parity")

    casters = [
        ("tetrace contains (auto: winding)", lambda: scene.contains(p)),
        ("tetrace contains (mode='parity')", parity),
        (
            "libigl fast_winding_number >= 1/2",
            lambda: igl.fast_winding_number(s.vertices, s.faces, p) >= 0.5,
        ),
    ]
    if exact:
        casters.append(
            (
                "libigl winding_number (exact) >= 1/2",
                lambda: igl.winding_number(s.vertices, s.faces, p) >= 0.5,
            )
        )
    casters.append(("trimesh contains", lambda: mesh.contains(p)))
    o3d, why = open3d_module()
    if o3d is None:
        out(f"Open3D: {why}")
    else:
        rs = o3d.t.geometry.RaycastingScene()
        rs.add_triangles(
            o3d.core.Tensor(v.astype(np.float32)), o3d.core.Tensor(f.astype(np.uint32))
        )
        q = o3d.core.Tensor(p32)
        for k in NSAMPLES:
            casters.append(
                (
                    f"Open3D compute_occupancy(nsamples={k})",
                    lambda k=k: rs.compute_occupancy(q, nsamples=k).numpy() > 0.5,
                )
            )
    rows = []
    keep = ~ref["band"]
    # How far each point is from the scan, in diagonals: wrong answers near the surface or a
    # hole are a matter of resolution; far ones are not.
    far = scene.distance(p) / float(np.linalg.norm(hi - lo))
    for name, fn in casters:
        best, first, got = _best(fn, repeat)
        got = np.asarray(got, bool).reshape(-1)
        same = got == ref["inside"]
        rows.append(
            dict(
                caster=name,
                seconds=best,
                first=first,
                inside=float(got.mean()),
                agree=float(same.mean()),
                agree_outside_band=float(same[keep].mean()) if keep.any() else 1.0,
                wrong=int((~same).sum()),
                wrong_farthest=float(far[~same].max()) if (~same).any() else 0.0,
                points=n,
                band=int(ref["band"].sum()),
            )
        )
    out(_format(rows))
    return rows


def _cores():
    import os

    return os.cpu_count()


def _format(rows):
    from .scene_bench import _table

    table = [
        [
            r["caster"],
            f"{r['seconds'] * 1e3:.1f}",
            f"{r['first'] * 1e3:.1f}",
            f"{r['inside']:.2%}",
            f"{r['agree']:.2%} ({r['wrong']:,} wrong)",
            f"{r['agree_outside_band']:.2%}",
            f"{r['wrong_farthest']:.2g}",
        ]
        for r in rows
    ]
    head = [
        "caster",
        "best ms",
        "first ms",
        "inside",
        "agrees with closed copy",
        "outside band",
        "farthest wrong (diagonals)",
    ]
    return _table(table, head)


def occupancy_main(argv=None):
    p = argparse.ArgumentParser(
        prog="python -m tetrace.bench occupancy",
        description="Inside/outside of points in a scan with holes (default: the shared "
        "scenes' bunny.obj): tetrace's contains (winding number, and parity), libigl's exact "
        "and fast winding numbers, trimesh's contains and Open3D's compute_occupancy, timed "
        "and judged against the exact parity of a copy with its holes closed.",
    )
    p.add_argument("scene", nargs="?", default=None, help="mesh file (default: bunny.obj)")
    p.add_argument("--points", type=int, default=20_000, help="points in the bounding box")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--repeat", type=int, default=3, help="timed repetitions; the best is kept")
    p.add_argument(
        "--no-exact", action="store_true", help="skip libigl's exact winding number alone"
    )
    p.add_argument("--json", default=None, help="also write the rows as JSON here")
    args = p.parse_args(argv)
    rows = run_occupancy(
        args.scene, n=args.points, seed=args.seed, repeat=args.repeat, exact=not args.no_exact
    )
    if args.json:
        import json

        with open(args.json, "w") as fh:
            json.dump(rows, fh, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(occupancy_main())
