"""Every shared scene through the meshers: what built it, how big, how fast, how accurate.

``python -m tetrace.bench scenes`` builds each mesh file of the scenes folder with
``mesher="fallback"`` (TetGen's exact route, snap rounding when TetGen fails, fTetWild
when that fails too) and the given preset, casts camera rays (three orbit views) and
random rays with tetrace and embreex, and prints one row per scene:

* the mesher and preset that built it (``+snap`` when snap-rounded, ``+repair`` when
  self-intersections were cut) and why the earlier attempts failed;
* tets, seconds in the mesher (repair and failed attempts included) and in Rust;
* the exact referee's judgement of tetrace's casts on the input (:mod:`tetrace.referee`,
  ``docs/referee.md``): the fraction of rays right and the counts leaked, late and wrong
  (for fTetWild, how its remeshed surface answers for the input);
* for information about fTetWild's naming, agreement with embreex on hit/miss and on the
  triangle id; "same plane": the rays
  that name Embree's triangle or a neighbour in the same plane at the hit point (within
  1e-5 of the diagonal, normals within 1 degree) - fTetWild's surface faces can span
  several coplanar input triangles and name only one; rays that differ away from
  edges, p99 of |dt| over the diagonal, and (fTetWild) how far the remeshed surface is
  from the input.

A scene that no mesher can build gets a row with the reason.
"""

from __future__ import annotations

import gc
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

from ..dev.compare import same_plane

MESH_SUFFIXES = (".obj", ".ply", ".off", ".stl", ".glb", ".gltf")


def default_scenes_dir():
    """``TETRACE_SCENES`` if set, else ``../shared/scenes`` from the working directory."""
    env = os.environ.get("TETRACE_SCENES")
    return Path(env) if env else Path("..") / "shared" / "scenes"


def scene_files(folder):
    """Mesh files of a folder, smallest first."""
    folder = Path(folder)
    if not folder.is_dir():
        raise FileNotFoundError(f"scenes folder not found: {folder} (set TETRACE_SCENES or --dir)")
    files = [p for p in folder.iterdir() if p.suffix.lower() in MESH_SUFFIXES]
    return sorted(files, key=lambda p: p.stat().st_size)


def _mesher_label(tz):
    label = tz.mesher if tz.mesher == "ftetwild" else f"tetgen {tz.preset}"
    if tz.auto:
        label = f"auto: {tz.auto['setting']}"
    if tz.mesher == "tetgen" and tz.repaired:
        label += "+repair"
    if tz.snap:
        label += "+snap"
    return label


def run_scene(
    path,
    *,
    mesher="fallback",
    preset="quality",
    res=512,
    n_random=100_000,
    timeout=None,
    epsilon=None,
    accuracy=None,
):
    """Build one scene and compare it with embreex; returns a dict (see the module doc)."""
    from ..baselines.embree import embree_scene
    from ..dev.compare import agreement, compare
    from ..errors import MeshingError
    from ..hits import HIT
    from ..io import load_triangles
    from ..referee import Referee
    from ..scene import Scene
    from .agreement import ray_sets

    path = Path(path)
    row = dict(scene=path.name)
    v, f = load_triangles(path)
    row["triangles"] = int(len(f))
    t0 = time.perf_counter()
    try:
        scene = Scene.from_mesh(
            (v, f),
            preset,
            mesher=mesher,
            timeout=timeout,
            epsilon=epsilon,
            accuracy=accuracy,
            lazy=False,
        )
    except MeshingError as exc:
        row.update(ok=False, error=str(exc), seconds=time.perf_counter() - t0)
        return row
    tz = scene.tetrahedralization
    bt = scene.build_times
    row.update(
        ok=True,
        mesher=_mesher_label(tz),
        tets=int(scene.n_tets),
        mesher_seconds=float(tz.auto["seconds"] if tz.auto else bt["total"] - bt["rust"]),
        rust_seconds=float(bt["rust"]),
        timings={k: float(x) for k, x in bt.items()},
        attempts=list(tz.attempts),
        snap=float(tz.snap),
        options={k: v for k, v in tz.options.items() if isinstance(v, (int, float, str, bool))},
    )
    if tz.surface_distance:
        diag = tz.surface_distance["diagonal"]
        row["surface_distance"] = {
            k: x / diag for k, x in tz.surface_distance.items() if k != "diagonal"
        }
    ref_scene = embree_scene((v, f))
    bounds = np.array([v.min(0), v.max(0)])
    referee = Referee(v, f)
    totals = dict(
        rays=0, agree=0, coincident=0, same_plane=0, hit_differ=0, unexplained=0, failed=0
    )
    judged = dict(right=0, leaked=0, late=0, wrong=0, t_off=0)
    dts = []
    for _, o, d in ray_sets(bounds, res, n_random):
        hits = scene.cast(o, d)
        score = agreement(hits, referee.first_hits(o, d, hint=hits.triangle))
        for k in ("right", "leaked", "late", "wrong", "t_off"):
            judged[k] += getattr(score, k)
        ref = ref_scene.cast(o.astype(np.float32), d.astype(np.float32))
        a = compare(hits, ref, v, f, origins=o, directions=d)
        totals["rays"] += a.rays
        totals["agree"] += a.agree
        totals["coincident"] += a.coincident
        totals["unexplained"] += a.far_from_edges
        totals["failed"] += a.failed
        totals["hit_differ"] += int(((hits.status == HIT) != (ref.status == HIT)).sum())
        totals["same_plane"] += same_plane(hits, ref, v, f)
        both = (hits.status == HIT) & (ref.status == HIT) & (hits.triangle == ref.triangle)
        dts.append(np.abs(hits.t[both] - ref.t[both].astype(np.float64)))
    diag = float(np.linalg.norm(bounds[1] - bounds[0]))
    dt = np.concatenate(dts) / diag
    row.update(totals)
    row["right"] = judged["right"] / totals["rays"]
    row.update(
        leaked=judged["leaked"], late=judged["late"], wrong=judged["wrong"], t_off=judged["t_off"]
    )
    row["agreement"] = (totals["agree"] + totals["coincident"]) / totals["rays"]
    row["hit_agreement"] = 1 - totals["hit_differ"] / totals["rays"]
    row["plane_agreement"] = (totals["agree"] + totals["same_plane"]) / totals["rays"]
    row["p99_dt"] = float(np.quantile(dt, 0.99)) if len(dt) else 0.0
    del scene, ref_scene
    gc.collect()
    return row


def run_scenes(
    paths,
    *,
    mesher="fallback",
    preset="quality",
    res=512,
    n_random=100_000,
    timeout=None,
    epsilon=None,
    accuracy=None,
    json_path=None,
    out=print,
):
    """Print the table for the given mesh files; return the rows."""
    from .scene_bench import _table

    rows, table = [], []
    header = [
        "scene",
        "tris",
        "mesher",
        "tets",
        "mesher s",
        "rust s",
        "rays",
        "right",
        "leaked",
        "late",
        "wrong",
        "failed",
        "embreex: hit agree",
        "id agree",
        "same plane",
        "differ off edges",
        "p99 |dt|/diag",
        "surface max/mean",
        "note",
    ]
    for path in paths:
        row = run_scene(
            path,
            mesher=mesher,
            preset=preset,
            res=res,
            n_random=n_random,
            timeout=timeout,
            epsilon=epsilon,
            accuracy=accuracy,
        )
        rows.append(row)
        if not row["ok"]:
            table.append(
                [row["scene"], f"{row['triangles']:,}", "FAILED", "-", f"{row['seconds']:.1f}"]
                + ["-"] * (len(header) - 6)
                + [row["error"]]
            )
        else:
            sd = row.get("surface_distance")
            note = " | ".join(row["attempts"])
            table.append(
                [
                    row["scene"],
                    f"{row['triangles']:,}",
                    row["mesher"],
                    f"{row['tets']:,}",
                    f"{row['mesher_seconds']:.1f}",
                    f"{row['rust_seconds']:.2f}",
                    f"{row['rays']:,}",
                    f"{row['right'] * 100:.3f}%",
                    row["leaked"],
                    row["late"],
                    row["wrong"],
                    row["failed"],
                    f"{row['hit_agreement'] * 100:.3f}%",
                    f"{row['agreement'] * 100:.3f}%",
                    f"{row['plane_agreement'] * 100:.3f}%",
                    row["unexplained"],
                    f"{row['p99_dt']:.1e}",
                    f"{sd['max']:.1e}/{sd['mean']:.1e}" if sd else "-",
                    note,
                ]
            )
        # Progress on stderr: a full run takes a while.
        print(
            f"{row['scene']}: "
            + ("ok " if row["ok"] else "FAILED ")
            + json.dumps(
                {k: row[k] for k in ("mesher", "tets", "right", "agreement", "error") if k in row}
            ),
            file=sys.stderr,
            flush=True,
        )
        if json_path:
            with open(json_path, "w") as fh:
                json.dump(rows, fh, indent=2)
    out(_table(table, header))
    return rows
