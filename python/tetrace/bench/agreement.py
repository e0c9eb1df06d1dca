"""Agreement report: the acceptance rays on real scenes, cast by tetrace and embreex, each
judged by the exact referee (docs/referee.md).

``python -m tetrace.bench agreement [mesh ...]`` prints, per scene, ray set and precision, for
Embree and for tetrace's default and robust methods: rays right, failed, leaked (the referee
hits, the cast misses), late (a later triangle), wrong (a hit where there is none, an earlier
or other triangle, or t out of the bound) and the largest t error in ulps.
"""

from __future__ import annotations

import os
import time

import numpy as np

from ..dev.camera import orbit_views, pinhole, random_rays
from ..dev.compare import agreement
from ..scene import Scene, default_scene_path


def ray_sets(bounds, res=1024, n_random=100_000):
    """The acceptance rays: three orbit views of res x res pixels, and random rays."""
    sets = [
        (f"view{k}", *pinhole(*v, fov_deg=40.0, width=res, height=res, dtype=np.float64))
        for k, v in enumerate(orbit_views(bounds, n=3, distance=1.6))
    ]
    sets.append(("random", *random_rays(bounds, n_random, seed=1234, grow=0.25)))
    return sets


def run_agreement(paths, *, res=1024, n_random=100_000, methods=None, out=print):
    """Print the referee's table for the given meshes (None: the bundled scene).

    Returns
    -------
    list of dict
        One row per scene, ray set, precision and caster.
    """
    from .. import _native
    from ..baselines.embree import embree_scene
    from ..referee import Referee
    from .scene_bench import _table

    methods = methods or [_native.DEFAULT_METHOD, "robust"]
    rows = []
    for path in paths:
        path = str(path) if path else str(default_scene_path())
        t0 = time.perf_counter()
        scene = Scene.from_mesh(path)
        build = time.perf_counter() - t0
        v, f = scene.vertices, scene.faces
        ref_scene = embree_scene((v, f))
        referee = Referee(v, f)
        for name, o, d in ray_sets(np.array([v.min(0), v.max(0)]), res, n_random):
            for dtype in (np.float32, np.float64):
                o2, d2 = o.astype(dtype), d.astype(dtype)
                casts = {f"tetrace {m}": (scene.cast(o2, d2, method=m), "f64") for m in methods}
                casts["embreex rtcIntersect1 (float32)"] = (ref_scene.cast(o2, d2), "f32")
                t1 = time.perf_counter()
                verdict = referee.first_hits(
                    o2, d2, hint=casts[f"tetrace {methods[0]}"][0].triangle
                )
                judge_s = time.perf_counter() - t1
                for caster, (h, arith) in casts.items():
                    a = agreement(h, verdict, arith)
                    rows.append(
                        dict(
                            scene=os.path.basename(path),
                            tets=scene.n_tets,
                            build_s=build,
                            rays=name,
                            precision=np.dtype(dtype).name,
                            caster=caster,
                            n=a.rays,
                            right=a.right,
                            failed=a.failed,
                            leaked=a.leaked,
                            late=a.late,
                            wrong=a.wrong,
                            t_off=a.t_off,
                            max_t_ulps=a.max_t_ulps,
                            ties=a.ties,
                            referee_s=judge_s,
                            exact_pairs=verdict.exact_pairs,
                        )
                    )
    table = [
        [
            r["scene"],
            r["rays"],
            r["precision"],
            r["caster"],
            f"{r['n']:,}",
            f"{r['right'] / max(r['n'], 1) * 100:.4f}%",
            r["failed"],
            r["leaked"],
            r["late"],
            r["wrong"],
            r["t_off"],
            f"{r['max_t_ulps']:.3g}",
            r["ties"],
        ]
        for r in rows
    ]
    out(
        _table(
            table,
            [
                "scene",
                "rays",
                "prec",
                "caster",
                "N",
                "right",
                "failed",
                "leaked",
                "late",
                "wrong",
                "of which t off",
                "max ulp",
                "tied rays",
            ],
        )
    )
    return rows
