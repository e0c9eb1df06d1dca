"""``python -m tetrace.bench first``: time to first answers (issue 35).

What a user who has a mesh and a batch of rays waits for: in a fresh Python process per
measurement, the mesh's build and one cast of random float32 rays in its box. tetrace is
``Scene.from_mesh((vertices, faces))`` (which meshes nothing: the first cast builds the exact
BVH) and ``scene.cast``; embreex is its scene's build (robust flag) and the same cast. The
mesh is read (``tetrace.mesh.load_triangles``) and the rays are made before the clock starts,
and each process imports its caster before it: what is timed is the build and the cast. Each
row is the best of ``--repeat`` fresh processes per caster, with both casters' hit counts.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys

#: The child: argv = caster, mesh path, threads, rays, seed. Prints one JSON line.
CHILD = r"""
import json, sys, time
import numpy as np
caster, path = sys.argv[1], sys.argv[2]
threads, n, seed = (int(x) for x in sys.argv[3:6])
from tetrace.dev.camera import random_rays
from tetrace.mesh import load_triangles
v, f = load_triangles(path)
o, d = random_rays(np.array([v.min(0), v.max(0)]), n, seed, dtype=np.float32)
if caster == "tetrace":
    import tetrace
    t0 = time.perf_counter()
    scene = tetrace.Scene.from_mesh((v, f))
    t1 = time.perf_counter()
    hit = scene.cast(o, d, threads=threads).hit
else:
    from tetrace.bench.casters import EmbreexCaster
    t0 = time.perf_counter()
    scene = EmbreexCaster(v, f)
    t1 = time.perf_counter()
    hit = np.asarray(scene.cast(o, d, threads)[0]) >= 0
t2 = time.perf_counter()
print(json.dumps({"build": t1 - t0, "cast": t2 - t1, "hits": int(hit.sum()), "triangles": len(f)}))
"""

CASTERS = ("embreex", "tetrace")


def measure(caster, path, threads, rays, seed):
    """One fresh process's build and first cast (seconds) and hit count."""
    run = subprocess.run(
        [sys.executable, "-c", CHILD, caster, str(path), str(threads), str(rays), str(seed)],
        capture_output=True,
        text=True,
    )
    if run.returncode:
        raise RuntimeError(f"{caster} on {path} failed:\n{run.stderr[-3000:]}")
    row = json.loads(run.stdout.strip().splitlines()[-1])
    row["first"] = row["build"] + row["cast"]
    return row


def run_first(paths, *, threads=None, rays=100_000, repeat=2, seed=1234, out=print):
    """Time to first answers on each mesh.

    Parameters
    ----------
    paths : list of str
        Mesh files (default: the bundled scene).
    threads : int, optional
        Threads of both casts (default: every core).
    rays : int
        Random float32 rays in the mesh's box.
    repeat : int
        Fresh processes per caster and mesh; the fastest is kept.
    seed : int

    Returns
    -------
    list of dict
        Per mesh: ``mesh``, ``triangles``, and per caster its fastest ``build``, ``cast``,
        ``first`` (their sum, seconds) and ``hits``; ``ratio`` = embreex's ``first`` /
        tetrace's (≥ 1: tetrace answers first).
    """
    from ..baselines.embree import cpu_count
    from ..scene import default_scene_path

    threads = cpu_count() if threads is None else int(threads)
    rows = []
    for path in paths or [str(default_scene_path())]:
        row = {"mesh": os.path.basename(str(path))}
        for caster in CASTERS:
            best = min(
                (measure(caster, path, threads, rays, seed) for _ in range(max(repeat, 1))),
                key=lambda r: r["first"],
            )
            row["triangles"] = best.pop("triangles")
            row[caster] = best
        row["ratio"] = row["embreex"]["first"] / row["tetrace"]["first"]
        rows.append(row)
    out(
        f"time to first answers: {rays:,} random float32 rays, {threads} threads, a fresh "
        f"process per measurement, best of {repeat}; seconds"
    )
    out(
        "| mesh | triangles | embreex build + cast = first | tetrace from_mesh + cast = first "
        "| embreex / tetrace | hits (embreex / tetrace) |"
    )
    out("|---|---:|---|---|---:|---|")
    for r in rows:
        e, t = r["embreex"], r["tetrace"]
        out(
            f"| {r['mesh']} | {r['triangles']:,} | {e['build']:.3f} + {e['cast']:.3f} = "
            f"{e['first']:.3f} | {t['build']:.3f} + {t['cast']:.3f} = {t['first']:.3f} | "
            f"{r['ratio']:.2f}× | {e['hits']:,} / {t['hits']:,} |"
        )
    return rows


def first_main(argv):
    p = argparse.ArgumentParser(
        prog="python -m tetrace.bench first",
        description="Time to first answers: a fresh process builds the mesh's scene and casts "
        "random rays, tetrace (Scene.from_mesh + cast: the BVH is built by the cast, nothing "
        "is meshed) against embreex (build + cast).",
    )
    p.add_argument("meshes", nargs="*", help="mesh files (default: the bundled scene)")
    p.add_argument("--threads", type=int, default=None, help="default: every core")
    p.add_argument("--rays", type=int, default=100_000)
    p.add_argument("--repeat", type=int, default=2, help="fresh processes per caster")
    p.add_argument("--seed", type=int, default=1234)
    args = p.parse_args(argv)
    run_first(args.meshes, threads=args.threads, rays=args.rays, repeat=args.repeat, seed=args.seed)
    return 0
