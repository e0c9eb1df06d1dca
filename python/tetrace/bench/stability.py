"""``python -m tetrace.bench stability``: the failure taxonomy of every method on the stress
families (Maria et al.'s Table 4 counts failures per 1024x1024 image, about a million rays;
we count per million rays).

Each ray is judged per step by the exact audit and per ray against every triangle of the
stress scene (see :mod:`tetrace.stress`).
"""

from __future__ import annotations

import json
import time

import numpy as np

from .. import _native
from ..stress import OUTCOMES, audited_cast, brute_bounds, build_scene, cases, classify

#: Relative barycentric margin between "touches" and "pierces" per precision: float32's
#: rounding of the mesh and rays must fall inside it.
BAND = {"f32": 1e-4, "f64": 1e-9}


def run_stability(n_per_family=20_000, seed=0, families=None, methods=None, layouts=("tet32",),
                  precisions=("f32", "f64"), out=print, json_path=None):
    """Cast every stress family with every method, layout and precision; print and return
    the counts.

    Returns
    -------
    list of dict
        One row per (family, method, layout, precision): ``rays`` and the count of each of
        :data:`tetrace.stress.OUTCOMES`.
    """
    from .scene_bench import _table

    methods = list(_native.methods()) if methods is None else list(methods)
    rows = []
    t_start = time.perf_counter()
    for case in cases(n_per_family, seed, families):
        scene = build_scene(case)
        diag = float(np.linalg.norm(np.ptp(case.vertices, axis=0)))
        for precision in precisions:
            # Judge each precision on the rays it actually casts (float32 rounds them).
            dt = np.float32 if precision == "f32" else np.float64
            o, d = case.origins.astype(dt), case.directions.astype(dt)
            bounds = brute_bounds(o, d, case.vertices, case.faces, BAND[precision])
            for method in methods:
                for layout in layouts:
                    if layout == "tet80" and precision == "f64":
                        continue  # float32-only layout
                    h, audit = audited_cast(scene, o, d, method=method, layout=layout,
                                            precision=precision)
                    c = classify(h, audit, bounds, d, diag, case.closed)
                    rows.append({"family": case.family, "method": method, "layout": layout,
                                 "precision": precision, "rays": len(h), "tets": scene.n_tets,
                                 **c})
    seconds = time.perf_counter() - t_start
    bad = OUTCOMES[1:]
    table = []
    for r in rows:
        per_m = 1e6 / r["rays"]
        table.append([r["family"], r["method"], r["layout"], r["precision"], f"{r['rays']:,}"]
                     + [f"{r[k] * per_m:.0f}" for k in bad])
    out(f"stress rays: outcomes per million rays ({seconds:.0f} s). wrong_exit: took an exit "
        "face the line does not leave by (exact predicates); no_exit: the method's tests found "
        "no exit face; cycle: step guard (FAILED); leak: a ray that must hit reported none; "
        "wrong_hit: a hit before anything the ray touches or past a triangle it surely "
        "pierces, or a miss despite one")
    out(_table(table, ["family", "method", "layout", "precision", "rays", *bad]))
    out("")
    out(summary(rows))
    if json_path:
        with open(json_path, "w") as fh:
            json.dump(rows, fh, indent=1)
    return rows


def summary(rows):
    """Table 4 in the large: per method and precision, all families together, per million."""
    from .scene_bench import _table

    keys = []
    for r in rows:
        k = (r["method"], r["precision"])
        if k not in keys:
            keys.append(k)
    bad = OUTCOMES[1:]
    table = []
    for m, p in keys:
        sel = [r for r in rows if (r["method"], r["precision"]) == (m, p)]
        n = sum(r["rays"] for r in sel)
        table.append([m, p, f"{n:,}"] + [f"{sum(r[k] for r in sel) * 1e6 / n:.1f}" for k in bad]
                     + [str(sum(r[k] for r in sel)) for k in ("cycle", "leak", "wrong_hit")])
    return ("all families, per million rays (last three columns: ray counts)\n"
            + _table(table, ["method", "precision", "rays", *bad, "cycles", "leaks",
                             "wrong hits"]))
