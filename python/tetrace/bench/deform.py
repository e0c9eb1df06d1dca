"""Deformation (Lagae & Dutré 2008's deforming Armadillo): a smooth bounded displacement over
N frames, tetrace moving its CT (``Scene.update_vertices``) against re-meshing and against
embreex building a new scene per frame.

``python -m tetrace.bench deform [mesh] --frames 100 [--amplitude 0.005] [--res 256]`` (mesh:
default ``$TETRACE_SCENES``/armadillo.obj, else the bundled scene). Per frame: tetrace's
update (the exact orientation check and swap, or the rebuild it falls back to), embreex's
scene build on the moved vertices, and one camera of ``res``² float32 rays through both,
judged by the exact referee on ``--judge`` rays. tetrace's own re-meshing of the moved mesh
(what the update avoids) is timed on every ``--rebuild-every``-th frame only: it takes
seconds. embreex 4 exposes no refit of a committed scene's vertex buffer
(``rtcUpdateGeometryBuffer``), so a new scene per frame is its only route here.
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import numpy as np

__all__ = ["deform_frame", "run_deform", "deform_main"]


def deform_frame(rest, k, frames, amplitude):
    """Frame ``k`` of a periodic bend and twist of ``rest`` about its vertical (y) axis:
    displacement at most ``amplitude`` x the bounding diagonal (bend), plus a twist of the
    same arc length; frame 0 is ``rest`` itself."""
    lo, hi = rest.min(0), rest.max(0)
    c = (lo + hi) / 2
    size = float(np.linalg.norm(hi - lo))
    phase = 2 * np.pi * k / frames
    a = amplitude * size
    y = (rest[:, 1] - c[1]) / (hi[1] - lo[1])
    out = np.array(rest, dtype=np.float64)
    out[:, 0] += a * np.sin(phase) * np.sin(np.pi * y)
    out[:, 2] += 0.5 * a * (np.cos(phase) - 1.0) * np.cos(np.pi * y)
    angle = a * np.sin(phase) * np.sin(np.pi * y) / (size / 2)
    x, z = out[:, 0] - c[0], out[:, 2] - c[2]
    out[:, 0] = c[0] + np.cos(angle) * x - np.sin(angle) * z
    out[:, 2] = c[2] + np.sin(angle) * x + np.cos(angle) * z
    return out


def _default_path():
    scenes = os.environ.get("TETRACE_SCENES")
    folder = (
        Path(scenes) if scenes else Path(__file__).resolve().parents[3].parent / "shared" / "scenes"
    )
    found = sorted(folder.glob("armadillo*")) if folder.is_dir() else []
    return found[0] if found else None


def run_deform(
    path=None,
    *,
    frames=100,
    amplitude=0.005,
    res=256,
    judge=4096,
    rebuild_every=10,
    distance=1.6,
    out=print,
):
    """Run the deformation benchmark; print its table and return the per-frame rows.

    Parameters
    ----------
    path : str, optional
        Mesh file; None: ``armadillo*`` in ``$TETRACE_SCENES`` (or ``../shared/scenes``),
        else the bundled scene.
    frames : int
        Frames of the displacement (one period).
    amplitude : float
        Largest displacement, a fraction of the scene's bounding diagonal.
    res : int
        Camera resolution (``res``² float32 rays per frame, all threads).
    judge : int
        Rays of each frame's camera the referee judges (a fixed random subsample).
    rebuild_every : int
        Time tetrace's re-meshing of the moved mesh on every this-many-th frame (0: never).
    distance : float
        Camera distance from the scene centre, in bounding radii.
    out : callable

    Returns
    -------
    list of dict
        One per frame: ``action``, ``inverted``, ``update_s`` (``update_vertices`` but the
        point map), ``points_s``, ``check_s``, ``map_s`` (None when not built),
        ``rebuild_s`` (None when not timed), ``embree_build_s``, ``tetrace_mrays``,
        ``embree_mrays``, ``tetrace_wrong``, ``embree_wrong``, ``judged``.
    """
    from ..baselines.embree import embree_scene
    from ..dev.camera import orbit_views, pinhole
    from ..dev.compare import agreement
    from ..referee import Referee
    from ..scene import Scene, default_scene_path
    from .scene_bench import _table

    path = path or _default_path() or default_scene_path()
    t0 = time.perf_counter()
    scene = Scene.from_mesh(str(path), lazy=False)
    build = time.perf_counter() - t0
    rest = np.array(scene.vertices, dtype=np.float64)
    faces = np.asarray(scene.faces)
    bounds = np.array([rest.min(0), rest.max(0)])
    eye, target, up = orbit_views(bounds, n=1, distance=distance)[0]
    o, d = pinhole(eye, target, up, fov_deg=40.0, width=res, height=res, dtype=np.float32)
    o, d = o.reshape(-1, 3), d.reshape(-1, 3)
    sample = np.sort(np.random.default_rng(0).permutation(len(o))[: min(judge, len(o))])
    out(
        f"{Path(str(path)).name}: {len(faces):,} triangles, {scene.n_tets:,} tets, built in "
        f"{build:.2f} s; {frames} frames, amplitude {amplitude:g} x diagonal, "
        f"{res}x{res} float32 camera rays per frame, {len(sample)} judged by the referee"
    )
    rows = []
    for k in range(1, frames + 1):
        V = deform_frame(rest, k, frames, amplitude)
        report = scene.update_vertices(V)
        sec = report.seconds
        row = dict(
            frame=k,
            action=report.action,
            inverted=report.inverted,
            update_s=sec["total"] - sec["map"],
            points_s=sec["points"],
            check_s=sec["update"],
            map_s=sec["map"] or None,
            rebuild_s=None,
        )
        if rebuild_every and k % rebuild_every == 0:
            t = time.perf_counter()
            Scene.from_mesh((V, faces), lazy=False)
            row["rebuild_s"] = time.perf_counter() - t
        t = time.perf_counter()
        emb = embree_scene((V, faces))
        row["embree_build_s"] = time.perf_counter() - t
        t = time.perf_counter()
        scene.cast(o, d)
        row["tetrace_mrays"] = len(o) / (time.perf_counter() - t) / 1e6
        t = time.perf_counter()
        emb.cast(o, d)
        row["embree_mrays"] = len(o) / (time.perf_counter() - t) / 1e6
        # The judged subsample, cast again on its own (the same answers: rays are
        # independent).
        os_, ds = o[sample], d[sample]
        hs = scene.cast(os_, ds)
        verdict = Referee(V, faces).first_hits(os_, ds, hint=hs.triangle)
        a = agreement(hs, verdict)
        e = agreement(emb.cast(os_, ds), verdict, arithmetic="f32")
        row.update(tetrace_wrong=a.rays - a.right, embree_wrong=e.rays - e.right)
        row["judged"] = a.rays
        rows.append(row)
    out("")
    out(_summary(rows, _table, rebuild_every, frames))
    return rows


def _summary(rows, table, rebuild_every, frames):
    def stats(values, unit=1e3):
        v = np.array([x for x in values if x is not None], dtype=float) * unit
        if not len(v):
            return ["-", "-", "-"]
        return [f"{np.median(v):.2f}", f"{v.mean():.2f}", f"{v.max():.2f}"]

    moved = [r for r in rows if r["action"] == "moved"]
    rebuilt = [r for r in rows if r["action"] != "moved"]
    timed = sum(r["rebuild_s"] is not None for r in rows)
    body = [
        ["tetrace move: new positions (numpy)", len(moved)] + stats([r["points_s"] for r in moved]),
        ["tetrace move: exact check + swap (core)", len(moved)]
        + stats([r["check_s"] for r in moved]),
        ["tetrace update_vertices, moved frames", len(moved)]
        + stats([r["update_s"] for r in moved]),
        ["tetrace point map (once after each build)", sum(r["map_s"] is not None for r in rows)]
        + stats([r["map_s"] for r in rows]),
        ["tetrace update_vertices, frames it rebuilt", len(rebuilt)]
        + stats([r["update_s"] for r in rebuilt]),
        [f"tetrace re-meshing the moved mesh (every {rebuild_every}th frame)", timed]
        + stats([r["rebuild_s"] for r in rows]),
        ["embreex new scene per frame (build + commit)", len(rows)]
        + stats([r["embree_build_s"] for r in rows]),
        ["embreex refit of the vertex buffer", "-", "not exposed by embreex", "-", "-"],
    ]
    casts = [
        [
            "tetrace (exact)",
            f"{np.median([r['tetrace_mrays'] for r in rows]):.2f}",
            f"{sum(r['tetrace_wrong'] for r in rows)} / {sum(r['judged'] for r in rows)}",
        ],
        [
            "embreex (float32)",
            f"{np.median([r['embree_mrays'] for r in rows]):.2f}",
            f"{sum(r['embree_wrong'] for r in rows)} / {sum(r['judged'] for r in rows)}",
        ],
    ]
    return (
        table(body, ["per frame", "frames", "median ms", "mean ms", "max ms"])
        + f"\n\nframes that needed a rebuild: {len(rebuilt)} of {frames}"
        + (
            f" (most inverted tets in one: {max(r['inverted'] for r in rebuilt)})"
            if rebuilt
            else ""
        )
        + "\n\n"
        + table(casts, ["camera cast per frame", "median Mrays/s", "wrong (referee)"])
    )


def deform_main(argv):
    p = argparse.ArgumentParser(
        prog="python -m tetrace.bench deform",
        description="A smooth bounded displacement over N frames: tetrace moving its "
        "tetrahedralization (rebuilding when a tet would invert) against re-meshing and "
        "against a new embreex scene per frame, and a camera cast through both per frame, "
        "judged by the exact referee.",
    )
    p.add_argument(
        "scene", nargs="?", default=None, help="mesh file (default: armadillo, else the bundled)"
    )
    p.add_argument("--frames", type=int, default=100)
    p.add_argument(
        "--amplitude", type=float, default=0.005, help="largest displacement, x diagonal"
    )
    p.add_argument("--res", type=int, default=256, help="camera resolution")
    p.add_argument("--judge", type=int, default=4096, help="camera rays judged per frame")
    p.add_argument(
        "--rebuild-every",
        type=int,
        default=10,
        help="time tetrace's re-meshing on every n-th frame (0: never; it takes seconds)",
    )
    args = p.parse_args(argv)
    run_deform(
        args.scene,
        frames=args.frames,
        amplitude=args.amplitude,
        res=args.res,
        judge=args.judge,
        rebuild_every=args.rebuild_every,
    )
    return 0
