"""Agreement report: the foundation's acceptance rays, cast by tetrace and embreex.

``python -m tetrace.bench agreement [mesh ...]`` prints, per scene, ray set and precision,
how many rays agree on hit/miss and triangle id, how many differ near an edge, on
coincident triangles, or unexplained, failures, and |dt| relative to the diagonal.
"""

from __future__ import annotations

import os
import time

import numpy as np

from ..camera import orbit_views, pinhole, random_rays
from ..compare import compare
from ..scene import Scene, default_scene_path


def ray_sets(bounds, res=1024, n_random=100_000):
    """The acceptance rays: three orbit views of res x res pixels, and random rays."""
    sets = [(f"view{k}", *pinhole(*v, fov_deg=40.0, width=res, height=res, dtype=np.float64))
            for k, v in enumerate(orbit_views(bounds, n=3, distance=1.6))]
    sets.append(("random", *random_rays(bounds, n_random, seed=1234, grow=0.25)))
    return sets


def run_agreement(paths, *, res=1024, n_random=100_000, out=print):
    """Print the agreement table for the given meshes (None: the bundled scene)."""
    from ..reference import embree_scene
    from .scene_bench import _table

    rows = []
    for path in paths:
        path = str(path) if path else str(default_scene_path())
        t0 = time.perf_counter()
        scene = Scene.from_mesh(path)
        build = time.perf_counter() - t0
        v, f = scene.vertices, scene.faces
        ref_scene = embree_scene((v, f))
        for name, o, d in ray_sets(np.array([v.min(0), v.max(0)]), res, n_random):
            for dtype in (np.float32, np.float64):
                o2, d2 = o.astype(dtype), d.astype(dtype)
                h = scene.cast(o2, d2)
                ref = ref_scene.cast(o2.astype(np.float32), d2.astype(np.float32))
                a = compare(h, ref, v, f, origins=o2, directions=d2)
                rows.append([os.path.basename(path), f"{scene.n_tets:,}", f"{build:.1f}", name,
                             np.dtype(dtype).name, f"{a.rays:,}", f"{a.fraction * 100:.4f}%",
                             a.rays - a.agree - a.coincident, a.coincident, a.far_from_edges,
                             a.failed, f"{a.max_dt:.1e}", a.dt_over, a.dt_over_unexplained])
    out(_table(rows, ["scene", "tets", "build s", "rays", "prec", "N", "agree", "near edge",
                      "coincident", "unexplained", "failed", "max|dt|/diag", "dt>1e-5",
                      "dt not embree's"]))
    return rows
