"""Benchmarks: ``python -m tetrace.bench [scene] [options]``.

Throughput is always reported next to embreex's on the same rays in the same run, as a
ratio: absolute numbers on a shared, noisy machine mean little.
"""

from .scene_bench import run_scene_bench

__all__ = ["run_scene_bench"]
