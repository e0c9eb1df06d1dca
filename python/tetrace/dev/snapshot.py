"""Before/after check for refactors: hashes of every output field of every CPU method x layout x
precision and every GPU kernel, on the bundled scene and (if found) bunny, for random rays,
camera rays from outside and from inside the domain; and of every other query kind (any hit,
all hits, counts, ``start=hits`` secondary rays, containment, closest points) on every
accelerator in both precisions.

    python -m tetrace.dev.snapshot before.json                      # on the old build
    python -m tetrace.dev.snapshot after.json --compare before.json # on the new one

``--compare`` exits non-zero and lists the casts whose outputs are not bit-identical. GPU
kernels are included unless ``TETRACE_SKIP_GPU=1`` or no adapter opens.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import sys

import numpy as np

FIELDS = ("t", "u", "v", "point", "triangle", "tet", "steps", "status")


def _digest(a) -> str:
    return hashlib.sha256(np.ascontiguousarray(a).tobytes()).hexdigest()[:16]


def _rays(scene, n_random=20_000, res=160, seed=1):
    lo, hi = (np.asarray(x, dtype=np.float64) for x in scene.domain)
    c, ext = (lo + hi) / 2, hi - lo
    rng = np.random.default_rng(seed)
    o = lo + rng.random((n_random, 3)) * ext
    d = rng.normal(size=(n_random, 3))
    eye = c + np.array([0.3, 0.4, 1.5]) * ext.max()
    ys, xs = np.meshgrid(np.linspace(-1, 1, res), np.linspace(-1, 1, res), indexing="ij")
    fwd = (c - eye) / np.linalg.norm(c - eye)
    right = np.cross(fwd, [0, 1, 0])
    right /= np.linalg.norm(right)
    up = np.cross(right, fwd)
    dc = (fwd + 0.35 * (xs[..., None] * right + ys[..., None] * up)).reshape(-1, 3)
    inside = c + 0.45 * ext * np.array([1, 0.1, 0.2])
    return {
        "random": (o, d),
        "camera": (np.broadcast_to(eye, dc.shape), dc),
        "inside": (np.broadcast_to(inside, dc.shape), dc),
    }


def snapshot(scenes_dir=None) -> dict[str, dict[str, str]]:
    """``{"scene/rays/precision/method/layout": {field: hash}}`` for every cast."""
    import tetrace

    scenes = [("spot", tetrace.default_scene())]
    bunny = os.path.join(scenes_dir or os.environ.get("TETRACE_SCENES", ""), "bunny.obj")
    if os.path.exists(bunny):
        scenes.append(("bunny", tetrace.Scene.from_mesh(bunny)))
    use_gpu = os.environ.get("TETRACE_SKIP_GPU") != "1" and tetrace.gpu.available()
    out = {}

    def record(key, hits):
        out[key] = {f: _digest(getattr(hits, f)) for f in FIELDS}

    for sname, scene in scenes:
        for rname, (o, d) in _rays(scene).items():
            for prec, dt in (("f32", np.float32), ("f64", np.float64)):
                oo, dd = np.ascontiguousarray(o, dt), np.ascontiguousarray(d, dt)
                for m in tetrace.methods():
                    for lay in tetrace.layouts():
                        if lay == "tet80" and prec == "f64":
                            continue
                        hits = scene.cast(oo, dd, method=m, layout=lay, invalid="mark", threads=2)
                        record(f"{sname}/{rname}/{prec}/{m}/{lay}", hits)
                record(f"{sname}/{rname}/{prec}/default", scene.cast(oo, dd, invalid="mark"))
            if use_gpu:
                oo, dd = np.ascontiguousarray(o, np.float32), np.ascontiguousarray(d, np.float32)
                for m, lay in tetrace.gpu.kernels():
                    hits = scene.cast(oo, dd, method=m, layout=lay, device="gpu", invalid="mark")
                    record(f"{sname}/{rname}/gpu/{m}/{lay}", hits)
            _queries(scene, f"{sname}/{rname}", o, d, out)
        pts = _points(scene)
        for mode in ("parity", "winding"):
            out[f"{sname}/contains/{mode}"] = {
                "inside": _digest(scene.contains(pts, mode=mode, threads=2))
            }
        cp = scene.closest_points(pts, threads=2)
        out[f"{sname}/closest_points"] = {
            f: _digest(getattr(cp, f)) for f in ("point", "distance", "triangle", "u", "v")
        }
    return out


def _points(scene, n=5_000, seed=2):
    """Points in and around the domain box, a few on the scene's vertices."""
    lo, hi = (np.asarray(x, dtype=np.float64) for x in scene.domain)
    rng = np.random.default_rng(seed)
    p = lo - 0.1 * (hi - lo) + rng.random((n, 3)) * 1.2 * (hi - lo)
    v = np.asarray(scene.points(), dtype=np.float64)
    p[: min(200, len(v))] = v[rng.integers(0, len(v), min(200, len(v)))]
    return p


def _queries(scene, key, o, d, out, n=4_000):
    """The ray queries other than closest hit, on every accelerator and in both precisions,
    and the secondary rays started from a closest-hit cast's hits."""
    import tetrace

    o, d = o[:n], d[:n]
    for prec, dt in (("f32", np.float32), ("f64", np.float64)):
        oo, dd = np.ascontiguousarray(o, dt), np.ascontiguousarray(d, dt)
        for accel in tetrace.accels():
            kw = dict(accel=accel, invalid="mark", threads=2)
            k = f"{key}/{prec}/{accel}"
            out[f"{k}/cast"] = {
                f: _digest(getattr(scene.cast(oo, dd, **kw), f)) for f in FIELDS[:5] + ("status",)
            }
            out[f"{k}/occluded"] = {"occluded": _digest(scene.occluded(oo, dd, **kw))}
            out[f"{k}/count"] = {"count": _digest(scene.count_intersections(oo, dd, **kw))}
            ix = scene.intersections(oo, dd, **kw)
            out[f"{k}/intersections"] = {
                f: _digest(getattr(ix, f))
                for f in ("ray", "offsets", "t", "triangle", "u", "v", "point", "status")
                if getattr(ix, f, None) is not None
            }
            first = scene.cast(oo, dd, invalid="mark", threads=2)
            second = scene.cast(start=first, directions=-dd, accel=accel, invalid="mark", threads=2)
            out[f"{k}/start_hits"] = {
                f: _digest(getattr(second, f)) for f in ("t", "triangle", "status")
            }


def main(argv=None) -> int:
    p = argparse.ArgumentParser(
        prog="python -m tetrace.dev.snapshot",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("out", help="write the hashes here (JSON)")
    p.add_argument("--compare", default=None, help="an earlier snapshot to compare with")
    p.add_argument("--scenes", default=None, help="folder with bunny.obj (default $TETRACE_SCENES)")
    args = p.parse_args(argv)
    snap = snapshot(args.scenes)
    with open(args.out, "w") as f:
        json.dump(snap, f, indent=1, sort_keys=True)
    print(f"{len(snap)} casts hashed -> {args.out}")
    if args.compare is None:
        return 0
    with open(args.compare) as f:
        before = json.load(f)
    differ = sorted(k for k in before.keys() | snap.keys() if before.get(k) != snap.get(k))
    print(f"compared {len(before)} casts with {args.compare}: {len(differ)} differ")
    for k in differ[:50]:
        print("  ", k)
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main())
