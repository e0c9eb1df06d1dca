"""In-process A/B of tetrace builds: casts of each build alternated in one process.

On the 2-core VM the same build's speed moves by about ±15% from one process to the next,
more than most changes under test. Imported side by side (each installed build's
``tetrace`` package copied under another name: the package imports itself relatively, and
each copy loads its own ``_native`` library) and cast in turn, the builds meet the same
machine state, so their ratio holds where separate runs do not (``docs/performance.md``).

Usage::

    python -m tetrace.dev.ab [--scene FILE] [--distance R] camera|random|away ROUNDS SITE [SITE ...]

Each SITE is a folder holding an installed ``tetrace`` (``pip install --no-deps --target
SITE wheel``). ``away`` casts the camera's rays with their directions negated, so that
every ray misses the scene's box: the per-ray setup and answer alone. Prints the best and
median Mrays/s of one-thread casts of ``FILE`` (default bunny.obj, in ``TETRACE_SCENES`` or
``../shared/scenes``; the camera ``R`` bounding radii from the centre, default 1.6, as the
bench's ``--distance``), after checking that every build gives the same ``t`` bits.

Run each comparison in both orders (``A B``, then ``B A``) and compare the means: the same
build under two names came out 1-2% faster in the median when listed first (its scene is
built first; built in the other order, the gap mostly went), which is as much as many
changes under test (docs/bvh.md, stop 66). Each build's speed against the first build's is
also printed as the median of the rounds' ratios (each round casts every build once, in
turn): on a noisy machine that pairs casts made moments apart.
"""

from __future__ import annotations

import importlib
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from .camera import orbit_view, pinhole, random_rays


def load_builds(sites: list[str], into: Path) -> list:
    """Each site's ``tetrace`` package, imported as ``tetrace_ab<k>``."""
    modules = []
    for k, site in enumerate(sites):
        name = f"tetrace_ab{k}"
        shutil.copytree(Path(site) / "tetrace", into / name)
        modules.append(name)
    sys.path.insert(0, str(into))
    return [importlib.import_module(name) for name in modules]


def rays_for(
    kind: str, vertices: np.ndarray, distance: float = 1.6
) -> tuple[np.ndarray, np.ndarray]:
    """The bench's 1024² camera (``away``: reversed) or 1M random rays, float32."""
    box = np.array([vertices.min(0), vertices.max(0)])
    if kind == "random":
        return random_rays(box, 1 << 20, 0, dtype=np.float32)
    eye, target, up = orbit_view(box, 30.0, 25.0, distance)
    o, d = pinhole(eye, target, up, fov_deg=40.0, width=1024, height=1024, dtype=np.float32)
    o, d = np.ascontiguousarray(o.reshape(-1, 3)), np.ascontiguousarray(d.reshape(-1, 3))
    return (o, -d) if kind == "away" else (o, d)


def main(argv: list[str]) -> None:
    options = {"--scene": "bunny.obj", "--distance": "1.6"}
    while argv and argv[0] in options:
        if len(argv) < 2:
            raise SystemExit(__doc__)
        options[argv[0]], argv = argv[1], argv[2:]
    if len(argv) < 3 or argv[0] not in ("camera", "random", "away"):
        raise SystemExit(__doc__)
    kind, rounds, sites = argv[0], int(argv[1]), argv[2:]
    scenes_dir = Path(os.environ.get("TETRACE_SCENES", "../shared/scenes"))
    with tempfile.TemporaryDirectory() as tmp:
        builds = load_builds(sites, Path(tmp))
        scenes = [b.Scene.from_mesh(str(scenes_dir / options["--scene"])) for b in builds]
        o, d = rays_for(kind, scenes[0].vertices, float(options["--distance"]))
        first = scenes[0].cast(o, d, threads=1).t
        for site, scene in zip(sites, scenes):
            t = scene.cast(o, d, threads=1).t
            if not np.array_equal(t.view(np.uint32), first.view(np.uint32)):
                raise SystemExit(f"{site} gives other t than {sites[0]}")
        times: list[list[float]] = [[] for _ in sites]
        for r in range(rounds):
            # Every other round in reverse, so that neither build always follows the other.
            order = range(len(scenes)) if r % 2 == 0 else reversed(range(len(scenes)))
            for k in order:
                start = time.perf_counter()
                scenes[k].cast(o, d, threads=1)
                times[k].append(time.perf_counter() - start)
        first_times = np.array(times[0])
        for site, ts in zip(sites, times):
            best, median = len(o) / min(ts) / 1e6, len(o) / float(np.median(ts)) / 1e6
            # Each round's casts met the same machine state: the ratio within a round holds
            # where the machine's speed moves between rounds (stop 71: best and median moved
            # by 20-40% within one run, the paired ratio's quartiles by a few percent).
            q25, q50, q75 = np.percentile(first_times / np.array(ts), [25, 50, 75])
            print(
                f"{site} {kind}: best {best:.3f}  median {median:.3f} Mrays/s;"
                f" speed against {sites[0]}, per round: median {q50:.3f}"
                f" (quartiles {q25:.3f}-{q75:.3f})"
            )


if __name__ == "__main__":
    main(sys.argv[1:])
