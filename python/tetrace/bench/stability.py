"""``python -m tetrace.bench stability``: outcomes of every method on the stress families.

Counts per million rays (Maria et al.'s Table 4 counts failures per 1024x1024 image, about
one million rays), each ray's outcome decided against every triangle of the stress scene.
"""

from __future__ import annotations

import numpy as np

from .. import _native
from ..scene import Scene
from ..stress import OUTCOMES, cases, classify


def run_stability(n_per_family=20_000, seed=0, families=None, layout="tet32", out=print):
    """Cast every stress family with every method and precision; print and return the counts.

    Returns
    -------
    list of dict
        One row per (family, method, precision) with the counts of each outcome and ``rays``.
    """
    from .scene_bench import _table

    rows = []
    for case in cases(n_per_family, seed, families):
        scene = Scene.from_mesh((case.vertices, case.faces),
                                contain=np.vstack([case.origins, case.origins + 1e-9]))
        for precision in ("f32", "f64"):
            # Judge each precision on the rays it actually casts (float32 rounds the origins).
            dt = np.float32 if precision == "f32" else np.float64
            o, d = case.origins.astype(dt), case.directions.astype(dt)
            band = 1e-4 if precision == "f32" else 1e-9
            for method in _native.methods():
                h = scene.cast(o, d, method=method, layout=layout, precision=precision,
                               invalid="mark")
                c = classify(h, o, d, case.vertices, case.faces, case.closed, band=band)
                rows.append({"family": case.family, "method": method, "precision": precision,
                             "rays": len(h), **c})
    table = []
    for r in rows:
        per_m = 1e6 / r["rays"]
        table.append([r["family"], r["method"], r["precision"], f"{r['rays']:,}"]
                     + [f"{r[k] * per_m:.0f}" for k in OUTCOMES[1:]])
    out("stress rays per family, method and precision: outcomes per million rays (wrong: a hit "
        "before anything the ray touches or past a triangle it surely pierces, or a miss despite "
        "one; leak: a ray from inside a closed surface reported no hit; failed: step guard)")
    out(_table(table, ["family", "method", "precision", "rays", "wrong", "leak", "failed"]))
    return rows
