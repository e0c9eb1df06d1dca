"""The full-scene benchmark of the foundation: camera rays, tetrace against embreex."""

from __future__ import annotations

import json
import os
import time

import numpy as np

from ..camera import orbit_views, pinhole
from ..compare import compare
from ..hits import HIT
from ..scene import Scene, default_scene_path


def _best(fn, repeat):
    """Best wall time of `repeat` calls, and the last result."""
    best, out = np.inf, None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def _table(rows, header):
    widths = [max(len(str(r[i])) for r in rows + [header]) for i in range(len(header))]
    line = lambda r: "| " + " | ".join(str(c).rjust(w) for c, w in zip(r, widths)) + " |"
    sep = "|" + "|".join("-" * (w + 2) for w in widths) + "|"
    return "\n".join([line(header), sep] + [line(r) for r in rows])


def run_scene_bench(path=None, *, preset="quality", width=1024, height=1024, repeat=3,
                    distance=1.6, image=None, json_path=None, out=print):
    """Build a scene, cast a pinhole camera with tetrace and embreex, print one report.

    Parameters
    ----------
    path : str, optional
        Mesh file; None uses the bundled scene.
    preset : str
        Meshing preset passed to :meth:`tetrace.Scene.from_mesh`.
    width, height : int
        Camera resolution.
    repeat : int
        Timed repetitions per configuration; the best time is reported.
    distance : float
        Camera distance from the scene centre in bounding radii (the first orbit view).
    image : str, optional
        Write a shaded PNG of tetrace's float32 hits there.
    json_path : str, optional
        Write the results as JSON there.
    out : callable
        Where lines go (print by default).

    Returns
    -------
    dict
        Everything printed, as numbers.
    """
    from ..reference import embree_scene

    path = str(path) if path is not None else str(default_scene_path())
    name = os.path.basename(path)
    scene = Scene.from_mesh(path, preset)
    bt = scene.build_times
    v, f = scene.vertices, scene.faces
    bounds = np.array([v.min(0), v.max(0)])
    eye, target, up = orbit_views(bounds, n=1, distance=distance)[0]
    o64, d64 = pinhole(eye, target, up, fov_deg=40.0, width=width, height=height, dtype=np.float64)
    n = len(o64)
    ref_scene = embree_scene((v, f))
    o32, d32 = o64.astype(np.float32), d64.astype(np.float32)
    ncpu = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()

    results = {"scene": name, "preset": preset, "rays": n, "triangles": int(len(f)),
               "tets": scene.n_tets, "points": scene.n_points,
               "bytes_per_tet": scene.bytes_per_tet, "memory": scene.memory(),
               "build_seconds": {k: float(x) for k, x in bt.items()},
               "embree_build_seconds": float(ref_scene.build_seconds), "runs": []}
    rows = []
    embree_rate = {}
    for threads, label in ((1, "1"), (None, f"all ({ncpu})")):
        te, _ = _best(lambda: ref_scene.intersect(o32, d32, threads=threads or ncpu), repeat)
        embree_rate[threads] = n / te / 1e6
        rows.append(["embreex", "f32", label, f"{embree_rate[threads]:.2f}", "1.00", "-", "-"])
        results["runs"].append({"caster": "embreex", "precision": "f32", "threads": threads or ncpu,
                                "mrays_per_s": embree_rate[threads]})
    ref = ref_scene.cast(o32, d32)
    for prec, (o, d) in (("f32", (o32, d32)), ("f64", (o64, d64))):
        for threads, label in ((1, "1"), (None, f"all ({ncpu})")):
            tt, hits = _best(lambda: scene.cast(o, d, threads=threads), repeat)
            rate = n / tt / 1e6
            a = compare(hits, ref, v, f)
            rows.append([f"tetrace", prec, label, f"{rate:.2f}", f"{rate / embree_rate[threads]:.2f}",
                         f"{hits.steps.mean():.1f}", f"{a.fraction * 100:.3f}%"])
            results["runs"].append({"caster": "tetrace", "precision": prec, "threads": threads or ncpu,
                                    "mrays_per_s": rate, "ratio_to_embree": rate / embree_rate[threads],
                                    "tets_per_ray": float(hits.steps.mean()),
                                    "agreement": a.fraction, "failed": a.failed,
                                    "unexplained": a.far_from_edges, "max_dt": a.max_dt})
            if prec == "f32" and threads is None:
                last32 = hits

    hit_frac = float((ref.status == HIT).mean())
    out(f"tetrace bench: {name} ({len(f):,} triangles), preset {preset!r}, "
        f"{width}x{height} pinhole camera, {hit_frac * 100:.1f}% of rays hit, best of {repeat}")
    out(f"build: tetgen {bt.get('tetgen', 0):.2f} s (clean {bt.get('clean', 0):.2f} s, "
        f"repair {bt.get('repair', 0):.2f} s), rust construction {bt['rust']:.2f} s; "
        f"embreex BVH {ref_scene.build_seconds:.2f} s")
    mem = scene.memory()
    out(f"structure: {scene.n_tets:,} tets, {scene.n_points:,} points, {scene.bytes_per_tet} bytes/tet "
        f"(tet20 layout); memory MB: " + ", ".join(f"{k} {b / 1e6:.1f}" for k, b in mem.items()))
    out(_table(rows, ["caster", "precision", "threads", "Mrays/s", "x embreex", "tets/ray",
                      "agree w/ embreex"]))
    if image:
        from ..image import lambert, save_png
        save_png(image, lambert(last32, d32, v, f, width, height), cmap="gray", vmin=0, vmax=1)
        out(f"image: {image}")
    if json_path:
        with open(json_path, "w") as fh:
            json.dump(results, fh, indent=2)
    return results
