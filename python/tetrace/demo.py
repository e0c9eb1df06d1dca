"""``python -m tetrace.demo``: build the bundled scene, cast a camera, write
``tetrace_demo.png``, compare with Embree and the other peers (:mod:`tetrace.dev.demo`)."""

from __future__ import annotations

import sys

from .dev.demo import main

__all__ = ["main"]

if __name__ == "__main__":
    sys.exit(main())
