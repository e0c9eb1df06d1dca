"""``python -m tetrace.bench dask``: casting throughput on a Dask ``LocalCluster`` of 1, 2, ...
worker processes (``docs/dask.md``).

Random rays (origins in the domain box, directions normal) are generated on the workers as
a Dask array and persisted there, so that neither their making nor their transfer is timed;
the scene is scattered once per worker before timing. Each worker process casts with
``--threads`` threads (default 1), one block at a time. Every run's hits are checked
against a local cast of the same rays (every field equal, or the command fails).
"""

from __future__ import annotations

import argparse
import logging
import time

import numpy as np


def _rays(scene, n, chunk, seed):
    import dask.array as da

    lo, hi = scene.domain
    rng = da.random.default_rng(seed)
    o = rng.uniform(0.0, 1.0, size=(n, 3), chunks=(chunk, 3)) * (hi - lo) + lo
    d = rng.normal(size=(n, 3), chunks=(chunk, 3))
    return da.concatenate([o, d], axis=1).rechunk((chunk, 6))


def run_dask_bench(mesh, *, n, chunk, workers, threads, repeats, seed=0):
    """Time :func:`tetrace.dask.cast_dask` on clusters of each size in ``workers``; return
    the rows (workers, seconds, Mrays/s) and print them as a table."""
    import dask
    import distributed

    import tetrace
    import tetrace.dask as tdask

    t0 = time.perf_counter()
    scene = tetrace.Scene.from_mesh(mesh) if mesh else tetrace.default_scene()
    print(
        f"{mesh or 'bundled scene'}: {scene.n_triangles:,} triangles, {scene.n_tets:,} tets, "
        f"built in {time.perf_counter() - t0:.2f} s; {n:,} random float64 rays in chunks of "
        f"{chunk:,}; {threads} thread(s) per worker process"
    )
    fields = ("t", "triangle", "status")
    rows, reference = [], None
    for w in workers:
        cluster = distributed.LocalCluster(
            n_workers=w,
            threads_per_worker=1,
            processes=True,
            dashboard_address=":0",
            silence_logs=logging.ERROR,
        )
        with distributed.Client(cluster) as client:
            rays = client.persist(_rays(scene, n, chunk, seed))
            distributed.wait(rays)
            future = tdask.scatter_scene(scene, client)
            hits = tdask.cast_dask(future, rays, fields=fields, local_scene=scene, threads=threads)
            best = np.inf
            for _ in range(repeats):
                t = time.perf_counter()
                out = dask.compute(*hits.values())
                best = min(best, time.perf_counter() - t)
            if reference is None:
                local_rays = rays.compute()
                t = time.perf_counter()
                local = scene.cast(local_rays, threads=threads)
                local_s = time.perf_counter() - t
                reference = [getattr(local, f) for f in fields]
                rows.append(("local (no Dask)", local_s, n / local_s / 1e6))
            for name, a, b in zip(fields, out, reference):
                if not np.array_equal(a, b):
                    raise AssertionError(f"{w} workers: {name} differs from the local cast")
            rows.append((f"{w} worker(s)", best, n / best / 1e6))
        cluster.close()
    width = max(len(r[0]) for r in rows)
    head = f"seconds (best of {repeats})"
    print(f"\n| {'cast':>{width}} | {head} | Mrays/s |")
    print(f"|{'-' * (width + 2)}|{'-' * (len(head) + 2)}|---------|")
    for label, s, rate in rows:
        print(f"| {label:>{width}} | {s:{len(head)}.3f} | {rate:7.3f} |")
    print("\nevery run's t, triangle and status equal the local cast's")
    return rows


def dask_main(argv):
    p = argparse.ArgumentParser(
        prog="python -m tetrace.bench dask",
        description="Casting throughput on a Dask LocalCluster of 1, 2, ... worker processes, "
        "checked against a local cast.",
    )
    p.add_argument("mesh", nargs="?", default=None, help="mesh file (default: bundled scene)")
    p.add_argument("--rays", type=int, default=2_000_000)
    p.add_argument("--chunk", type=int, default=100_000)
    p.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    p.add_argument("--threads", type=int, default=1, help="cast threads per worker process")
    p.add_argument("--repeats", type=int, default=3)
    args = p.parse_args(argv)
    run_dask_bench(
        args.mesh,
        n=args.rays,
        chunk=args.chunk,
        workers=args.workers,
        threads=args.threads,
        repeats=args.repeats,
    )
    return 0
