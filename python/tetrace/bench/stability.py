"""``python -m tetrace.bench stability``: every method on the stress families, judged by the exact
referee (Maria et al.'s Table 4 counts failures per 1024x1024 image, about a million rays; we
count per million rays, and give the counts).

Each family's rays are certified to be what the family claims (:mod:`tetrace.dev.stress`); each
cast is judged per ray against the referee's verdict (late, leaked, failed, wrong:
``docs/referee.md``) and per step by the exact audit (wrong_exit, no_exit).
"""

from __future__ import annotations

import json
import time

import numpy as np

from .. import _native
from ..dev.stress import OUTCOMES, build_scene, cases, cast_case, count, examples

#: The parts of ``wrong`` (``tetrace.referee.judge``) kept in each row.
WRONG_PARTS = ("phantom", "early", "other_triangle", "t_off")


def layouts_for(precision, layouts):
    """The layouts that serve ``precision`` (tet80 stores float32 vertices: float32 only)."""
    return [lay for lay in layouts if not (lay == "tet80" and precision == "f64")]


#: The ``method`` name of Embree's rows: the peer, judged by the same referee on the same rays.
EMBREE = "embreex"


def embree_row(case, precision):
    """Embree's row for one certified case and precision (``None`` without embreex).

    embreex has no ``tnear``: a ray with ``tmin > 0`` is cast from ``origin + tmin * direction``
    (``tetrace.baselines.embree.embree_cast``), which is what a user of embreex can do; its ``t`` is
    float32 arithmetic (``judge(..., arithmetic="f32")``), and it has no walk to audit.
    """
    from ..baselines.embree import embree_available, embree_cast
    from ..referee import judge

    if not embree_available():
        return None
    o, d = case.rays(precision)
    h = embree_cast((case.vertices, case.faces), o, d, tmin=case.tmin, tmax=case.tmax)
    masks = judge(h, case.verdicts[precision], "f32")
    masks["wrong_exit"] = masks["no_exit"] = np.zeros(len(o), bool)
    row = dict(
        family=case.family, method=EMBREE, layout="-", precision=precision, tets=0, **count(masks)
    )
    row.update({k: int(masks[k].sum()) for k in WRONG_PARTS})
    return row


def run_family(
    case, methods, layouts, precisions, *, scene=None, threads=None, n_examples=3, embree=True
):
    """Cast one certified case with every method, layout and precision; one row each.

    Returns
    -------
    list of dict
        ``family``, ``method``, ``layout``, ``precision``, ``rays``, ``tets``, ``right``, the
        counts of :data:`tetrace.dev.stress.OUTCOMES` and of the parts of ``wrong``, ``bad_kinds``
        (per outcome, the ray kinds it holds for, with counts) and ``examples`` (per outcome,
        up to ``n_examples`` rays: :func:`tetrace.dev.stress.examples`).
    """
    scene = build_scene(case) if scene is None else scene
    rows = []
    for precision in precisions:
        for method in methods:
            for layout in layouts_for(precision, layouts):
                h, _, masks = cast_case(case, scene, method, layout, precision, threads=threads)
                row = dict(
                    family=case.family,
                    method=method,
                    layout=layout,
                    precision=precision,
                    tets=scene.n_tets,
                    **count(masks),
                )
                row.update({k: int(masks[k].sum()) for k in WRONG_PARTS})
                row["bad_kinds"] = {}
                row["examples"] = {}
                for k in OUTCOMES:
                    if masks[k].any():
                        kinds, n = np.unique(case.kind[masks[k]], return_counts=True)
                        row["bad_kinds"][k] = {str(a): int(b) for a, b in zip(kinds, n)}
                        row["examples"][k] = examples(
                            case, h, masks, case.verdicts[precision], k, n_examples
                        )
                rows.append(row)
        if embree:
            row = embree_row(case, precision)
            if row is not None:
                rows.append(row)
    return rows


def run_stability(
    n_per_family=20_000,
    seed=0,
    families=None,
    methods=None,
    layouts=None,
    precisions=("f32", "f64"),
    out=print,
    json_path=None,
    threads=None,
):
    """Build and certify every stress family, cast it with every method, layout and precision,
    print the table and the per-method summary, and return the rows (:func:`run_family`).
    ``layouts``: None casts on the default layout only.

    Families that cannot be built here (a shared scene without ``$TETRACE_SCENES``) are listed
    with the reason.
    """
    methods = list(_native.methods()) if methods is None else list(methods)
    layouts = [_native.DEFAULT_LAYOUT] if layouts is None else list(layouts)
    rows, certs, skipped = [], [], []
    t_start = time.perf_counter()
    for case in cases(n_per_family, seed, families, skipped=skipped):
        certs.append(
            (case.family, case.what, case.candidates, len(case), case.certified, case.exact32)
        )
        rows += run_family(case, methods, layouts, list(precisions), threads=threads)
    seconds = time.perf_counter() - t_start
    out(f"stress families: rays certified exact by the referee ({seconds:.0f} s)")
    out(certification_table(certs))
    for name, why in skipped:
        out(f"skipped {name}: {why}")
    out("")
    out(
        f"outcomes per million rays (counts in brackets); default = {_native.DEFAULT_METHOD} on "
        f"{_native.DEFAULT_LAYOUT}. late: a triangle past the first hit; leaked: a miss where "
        "the referee hits; failed: the walk gave up (its step guard fired: a cycle); wrong: "
        "anything else not right (a phantom or early hit, a triangle outside the tie set, t "
        "outside its bound); wrong_exit: took an exit face the line does not leave by (exact "
        "predicates); no_exit: the method's tests found no exit face"
    )
    out(table(rows))
    out("")
    out(summary(rows))
    out("")
    out(grid(rows))
    if json_path:
        with open(json_path, "w") as fh:
            json.dump(rows, fh, indent=1)
    return rows


def certification_table(certs):
    from .scene_bench import _table

    body = []
    for fam, what, cand, kept, frac, exact32 in certs:
        body.append(
            [
                fam,
                f"{cand:,}",
                f"{kept:,}",
                f"{100 * frac['f32']:.2f}%",
                f"{100 * frac['f64']:.2f}%",
                "same" if exact32 else "rounded",
                what,
            ]
        )
    return _table(
        body,
        [
            "family",
            "candidates",
            "kept",
            "certified f32",
            "certified f64",
            "f32 rays",
            "what is exact",
        ],
    )


def _cell(n, rays):
    return f"{n * 1e6 / rays:.0f} ({n})" if n else "0"


def table(rows):
    """The family x method x layout x precision table: per million rays, counts in brackets."""
    from .scene_bench import _table

    body = []
    for r in rows:
        default = (r["method"], r["layout"]) == (_native.DEFAULT_METHOD, _native.DEFAULT_LAYOUT)
        body.append(
            [
                r["family"],
                r["method"] + (" *" if default else ""),
                r["layout"],
                r["precision"],
                f"{r['rays']:,}",
            ]
            + [_cell(r[k], r["rays"]) for k in OUTCOMES]
        )
    return _table(body, ["family", "method (* default)", "layout", "precision", "rays", *OUTCOMES])


def summary(rows):
    """Table 4 in the large: per method, layout and precision, all families together."""
    from .scene_bench import _table

    keys = []
    for r in rows:
        k = (r["method"], r["layout"], r["precision"])
        if k not in keys:
            keys.append(k)
    body = []
    for m, lay, p in keys:
        sel = [r for r in rows if (r["method"], r["layout"], r["precision"]) == (m, lay, p)]
        n = sum(r["rays"] for r in sel)
        bad = [sum(r[k] for r in sel) for k in OUTCOMES]
        clean = sum(1 for r in sel if not any(r[k] for k in OUTCOMES))
        body.append([m, lay, p, f"{n:,}"] + [_cell(b, n) for b in bad] + [f"{clean}/{len(sel)}"])
    return (
        "all families together, per million rays (counts in brackets); last column: "
        "families with no late, leaked, failed, wrong, wrong_exit or no_exit ray\n"
        + _table(body, ["method", "layout", "precision", "rays", *OUTCOMES, "clean families"])
    )


def grid(rows):
    """Family x method, one row per family and precision: each cell is
    ``late/leaked/failed/wrong/fabricated`` rays (``0`` when all are zero; fabricated is the
    part of wrong that is a hit where the referee has none): the contract's failures without
    the exit-face audit (the form of docs/stability.md)."""
    from .scene_bench import _table

    methods, keys = [], []
    for r in rows:
        if r["method"] not in methods:
            methods.append(r["method"])
        k = (r["family"], r["precision"])
        if k not in keys:
            keys.append(k)
    cells = {(r["family"], r["precision"], r["method"]): r for r in rows}
    body = []
    for fam, prec in keys:
        row = [fam, prec, f"{max(r['rays'] for r in rows if r['family'] == fam):,}"]
        for m in methods:
            r = cells.get((fam, prec, m))
            keys = ("late", "leaked", "failed", "wrong", "fabricated")
            counts = [r[k] for k in keys] if r else None
            row.append(
                "-" if r is None else ("0" if not any(counts) else "/".join(map(str, counts)))
            )
        body.append(row)
    names = [m + (" *" if m == _native.DEFAULT_METHOD else "") for m in methods]
    return (
        "late/leaked/failed/wrong/fabricated rays per family (0: none; fabricated: the "
        "wrong hits where the referee has none); * the default\n"
        + _table(body, ["family", "prec", "rays", *names])
    )
