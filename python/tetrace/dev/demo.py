"""The main job: build the bundled scene, cast a camera, write an image, compare with Embree.

``python -m tetrace.demo [--out tetrace_demo.png] [--scene PATH] [--size 1024]`` (also
``python -m tetrace.dev.demo``, which ``make demo`` runs). It prints the full-scene bench's
report (:func:`tetrace.bench.scene_bench.run_scene_bench`: build times, Mrays/s of tetrace,
embreex and the peers that import, each judged by the exact referee) and writes a shaded
PNG of tetrace's hits. The camera looks at the bundled cow, Spot, from its front left,
whole in the frame.
"""

from __future__ import annotations

import argparse
import sys

from ..bench.scene_bench import run_scene_bench

#: The demo camera's direction from the scene's centre, in degrees (azimuth about +y from
#: +z, elevation) and its distance in bounding radii: Spot faces -z, so an azimuth of 225
#: sees its face and its left flank; at 2.7 radii its horns and hooves are in the 40-degree
#: frame (tests/test_demo.py casts this view and checks the frame's edges miss).
AZIMUTH, ELEVATION, DISTANCE = 225.0, 20.0, 2.7
#: Where the image goes unless ``--out`` says otherwise: the working directory (the
#: repository's .gitignore lists it, so ``make demo`` leaves no untracked file).
DEFAULT_OUT = "tetrace_demo.png"


def main(argv=None):
    """Run the demo; ``argv`` as for the command line (default: ``sys.argv[1:]``)."""
    p = argparse.ArgumentParser(prog="python -m tetrace.demo", description=__doc__.splitlines()[0])
    p.add_argument("--scene", default=None, help="mesh file (default: the bundled scene, Spot)")
    p.add_argument("--out", default=DEFAULT_OUT, help="PNG to write (default: %(default)s)")
    p.add_argument("--size", type=int, default=1024, help="image width and height in pixels")
    p.add_argument(
        "--azimuth", type=float, default=AZIMUTH, help="camera azimuth, degrees about +y"
    )
    p.add_argument("--elevation", type=float, default=ELEVATION, help="camera elevation, degrees")
    p.add_argument(
        "--distance",
        type=float,
        default=DISTANCE,
        help="camera distance from the scene's centre, in bounding radii",
    )
    p.add_argument("--repeat", type=int, default=3, help="timed casts per caster; the best is kept")
    args = p.parse_args(argv)
    run_scene_bench(
        args.scene,
        width=args.size,
        height=args.size,
        repeat=args.repeat,
        image=args.out,
        distance=args.distance,
        azimuth=args.azimuth,
        elevation=args.elevation,
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
