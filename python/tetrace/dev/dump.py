"""Dump a scene's tetrahedralization and rays as raw arrays for ``examples/profile_cast.rs``.

``python -m tetrace.dev.dump MESH OUT`` meshes MESH with the defaults and writes, as
little-endian arrays (numpy ``tofile``): ``points.f64`` (P, 3), ``tets.u32`` (T, 4),
``faces.u32`` (F, 3), ``face_triangle.u32`` (F,), ``triangles.f64`` (N, 3, 3), and float32 rays
(origin, direction) as (R, 6): ``camera.f32`` (the scene bench's 1024² pinhole camera),
``cammid.f32`` (its middle 128 rows, for callgrind) and ``random.f32`` (200,000 rays with
origins and directions uniform in the bounding box, seed 0). The Rust example then times the
cast without Python (``cargo run --release --example profile_cast -- OUT camera 5``), or runs
under ``valgrind --tool=callgrind`` (see ``docs/performance.md``).
"""

from __future__ import annotations

import argparse
import os

import numpy as np


def dump(mesh, out, *, width=1024, n_random=200_000):
    """Mesh ``mesh`` and write the arrays described in the module docstring into ``out``."""
    from ..scene import Scene
    from .camera import orbit_views, pinhole

    os.makedirs(out, exist_ok=True)
    scene = Scene.from_mesh(mesh)
    tz = scene.tetrahedralization
    v, f = scene.vertices, scene.faces

    def write(name, array, dtype):
        np.ascontiguousarray(array, dtype=dtype).tofile(os.path.join(out, name))

    write("points.f64", tz.points, np.float64)
    write("tets.u32", tz.tets, np.uint32)
    write("faces.u32", np.asarray(tz.faces).reshape(-1, 3), np.uint32)
    write("face_triangle.u32", tz.face_triangle, np.uint32)
    write("triangles.f64", v[f], np.float64)
    bounds = np.array([v.min(0), v.max(0)])
    eye, target, up = orbit_views(bounds, n=1, distance=1.6)[0]
    o, d = pinhole(eye, target, up, fov_deg=40.0, width=width, height=width, dtype=np.float32)
    camera = np.concatenate([o, d], 1)
    write("camera.f32", camera, np.float32)
    mid = camera.reshape(width, width, 6)[width * 7 // 16 : width * 9 // 16]
    write("cammid.f32", mid.reshape(-1, 6), np.float32)
    rng = np.random.default_rng(0)
    o = rng.uniform(bounds[0], bounds[1], (n_random, 3))
    d = rng.uniform(bounds[0], bounds[1], (n_random, 3)) - o
    write("random.f32", np.concatenate([o, d], 1), np.float32)
    return scene


def main(argv=None):
    p = argparse.ArgumentParser(prog="python -m tetrace.dev.dump", description=__doc__)
    p.add_argument("mesh", help="mesh file")
    p.add_argument("out", help="folder to write the arrays into")
    args = p.parse_args(argv)
    scene = dump(args.mesh, args.out)
    print(f"{args.out}: {scene.n_tets} tets, {scene.n_points} points")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
