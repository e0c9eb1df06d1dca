"""The main job: build the bundled scene, cast a camera, write an image, compare with Embree.

``python -m tetrace.demo [--out spot.png] [--scene PATH]``
"""

from __future__ import annotations

import argparse
import sys

from ..bench.scene_bench import run_scene_bench


def main(argv=None):
    p = argparse.ArgumentParser(prog="python -m tetrace.demo", description=__doc__.splitlines()[0])
    p.add_argument("--scene", default=None, help="mesh file (default: the bundled scene, Spot)")
    p.add_argument("--out", default="tetrace_demo.png", help="PNG to write (default: %(default)s)")
    p.add_argument("--size", type=int, default=1024, help="image width and height in pixels")
    args = p.parse_args(argv)
    run_scene_bench(
        args.scene, width=args.size, height=args.size, repeat=3, image=args.out, distance=2.2
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
