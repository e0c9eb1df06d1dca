"""Type stubs for the compiled core (hand-written; `make lint` runs stubtest against the built
extension, so they cannot drift from src/py/)."""

from collections.abc import Callable
from typing import Any, final

import numpy as np
import numpy.typing as npt

__all__ = [
    "NativeScene",
    "methods",
    "accels",
    "layouts",
    "simd_levels",
    "exitface_bench",
    "referee_first_hit",
    "gpu_adapters",
    "gpu_device",
    "gpu_kernels",
    "gpu_kernel_for",
    "DEFAULT_METHOD",
    "DEFAULT_LAYOUT",
    "MAX_THREADS",
    "MeshError",
    "TooLargeError",
    "GpuError",
    "MISS",
    "HIT",
    "FAILED",
    "INVALID",
    "__version__",
]

MISS: int
HIT: int
FAILED: int
INVALID: int
__version__: str

DEFAULT_METHOD: str
DEFAULT_LAYOUT: str
MAX_THREADS: int

def methods() -> list[str]: ...
def accels() -> list[str]: ...
def layouts() -> list[tuple[str, int]]: ...
def simd_levels() -> tuple[list[str], str]: ...
def exitface_bench(
    n_tets: int = 10_000, rays_per_tet: int = 16, seed: int = 1, repeat: int = 5
) -> list[tuple[str, str, float, int]]: ...

# The Rust twin of the exact referee (src/referee), brute force over every triangle: "hit"
# (bool), "t" (float64, inf on a miss), "triangle" (int64, smallest tied id, -1 on a miss),
# "ties" (int64, size of the tie set). tmin/tmax: (N,) or (1,).
def referee_first_hit(
    vertices: npt.NDArray[np.float64],
    faces: npt.NDArray[np.integer],
    origins: npt.NDArray[np.float64],
    directions: npt.NDArray[np.float64],
    tmin: npt.NDArray[np.float64],
    tmax: npt.NDArray[np.float64],
) -> dict[str, np.ndarray]: ...
def gpu_adapters() -> list[dict[str, Any]]: ...
def gpu_device() -> dict[str, Any]: ...
def gpu_kernels() -> list[tuple[str, str]]: ...
def gpu_kernel_for(method: str | None = None, layout: str | None = None) -> tuple[str, str]: ...

class MeshError(ValueError): ...
class TooLargeError(ValueError): ...
class GpuError(RuntimeError): ...

@final
class NativeScene:
    def __new__(
        cls,
        points: npt.NDArray[np.float64],
        tets: npt.NDArray[np.uint32],
        faces: npt.NDArray[np.uint32],
        face_triangle: npt.NDArray[np.uint32],
        triangles: npt.NDArray[np.float64],
        hilbert: bool = True,
        # (offsets (F+1,), ids) uint32 CSR: per caller triangle, the triangles a hit on a
        # face naming it may lie on instead (fTetWild); the ray's crossing nearest the face wins.
        alternatives: tuple[npt.NDArray[np.uint32], npt.NDArray[np.uint32]] | None = None,
    ) -> NativeScene: ...
    def cast(
        self,
        origins: npt.NDArray[np.floating],
        directions: npt.NDArray[np.floating],
        tmin: npt.NDArray[np.float64],
        tmax: npt.NDArray[np.float64],
        threads: int | None = None,
        max_steps: int | None = None,
        # None: the core's defaults (DEFAULT_METHOD, DEFAULT_LAYOUT).
        method: str | None = None,
        layout: str | None = None,
        audit: bool = False,
        # False: no packets for rays sharing an origin (same answers, bit for bit).
        packet: bool = True,
        # None: the tet walk; "reshetov_bvh": the BVH (same answers).
        accel: str | None = None,
        # Rays started from hits: per ray the scene triangle it leaves and the tet its hit's
        # walk ended in (int32, -1: none).
        start: tuple[npt.NDArray[np.int32], npt.NDArray[np.int32]] | None = None,
        # Called as progress(chunks_done, chunks) every 50 ms while the query runs.
        progress: Callable[[int, int], object] | None = None,
    ) -> dict[str, np.ndarray]: ...
    def cast_gpu(
        self,
        origins: npt.NDArray[np.float32],
        directions: npt.NDArray[np.float32],
        tmin: npt.NDArray[np.float64],
        tmax: npt.NDArray[np.float64],
        threads: int | None = None,
        max_steps: int | None = None,
        method: str | None = None,
        layout: str | None = None,
    ) -> tuple[dict[str, np.ndarray], dict[str, float]]: ...
    # The query kinds beside cast (src/query/): statuses MISS/HIT/FAILED/INVALID per ray.
    # HIT: the ray meets the surface at t in [tmin, tmax] (the walk may stop at the first).
    def occluded(
        self,
        origins: npt.NDArray[np.floating],
        directions: npt.NDArray[np.floating],
        tmin: npt.NDArray[np.float64],
        tmax: npt.NDArray[np.float64],
        threads: int | None = None,
        max_steps: int | None = None,
        method: str | None = None,
        layout: str | None = None,
        packet: bool = True,
        accel: str | None = None,
        start: tuple[npt.NDArray[np.int32], npt.NDArray[np.int32]] | None = None,
        # Called as progress(chunks_done, chunks) every 50 ms while the query runs.
        progress: Callable[[int, int], object] | None = None,
    ) -> npt.NDArray[np.uint8]: ...
    # "offsets" int64 (N+1,), "t" float64 (M,), "triangle" int32 (M,), "u", "v" float64 (M,),
    # "status" uint8 (N,): every point where a ray meets the surface once, sorted by t per ray.
    def intersections(
        self,
        origins: npt.NDArray[np.floating],
        directions: npt.NDArray[np.floating],
        tmin: npt.NDArray[np.float64],
        tmax: npt.NDArray[np.float64],
        threads: int | None = None,
        max_steps: int | None = None,
        method: str | None = None,
        layout: str | None = None,
        packet: bool = True,
        accel: str | None = None,
        start: tuple[npt.NDArray[np.int32], npt.NDArray[np.int32]] | None = None,
        # Called as progress(chunks_done, chunks) every 50 ms while the query runs.
        progress: Callable[[int, int], object] | None = None,
    ) -> dict[str, np.ndarray]: ...
    # "count" int32 (N,), "status" uint8 (N,).
    def count_intersections(
        self,
        origins: npt.NDArray[np.floating],
        directions: npt.NDArray[np.floating],
        tmin: npt.NDArray[np.float64],
        tmax: npt.NDArray[np.float64],
        threads: int | None = None,
        max_steps: int | None = None,
        method: str | None = None,
        layout: str | None = None,
        packet: bool = True,
        accel: str | None = None,
        start: tuple[npt.NDArray[np.int32], npt.NDArray[np.int32]] | None = None,
        # Called as progress(chunks_done, chunks) every 50 ms while the query runs.
        progress: Callable[[int, int], object] | None = None,
    ) -> dict[str, np.ndarray]: ...
    # (N, 3) float64 points -> (N,) bool: inside (on the surface counts as inside).
    def contains(
        self, points: npt.NDArray[np.float64], threads: int | None = None
    ) -> npt.NDArray[np.bool_]: ...
    # (N, 3) float64 points -> "point" (N, 3), "triangle" int32, "u", "v", "distance".
    def closest_points(
        self, points: npt.NDArray[np.float64], threads: int | None = None
    ) -> dict[str, np.ndarray]: ...
    def build_bvh(
        self, cost_ratio: float = 1.0, max_leaf: int = 8, bins: int = 16, aperture: bool = True
    ) -> dict[str, Any]: ...
    def bvh_info(self) -> dict[str, Any] | None: ...
    def build_octree(
        self, max_depth: int = 8, leaf_size: int = 12, balance: bool = True
    ) -> dict[str, Any]: ...
    def octree_info(self) -> dict[str, Any] | None: ...
    def update_points(
        self, points: npt.NDArray[np.float64], triangles: npt.NDArray[np.float64]
    ) -> tuple[bool, int, int]: ...
    def memory(self) -> dict[str, int]: ...
    def points(self) -> npt.NDArray[np.float64]: ...
    def tets(self) -> npt.NDArray[np.uint32]: ...
    @property
    def n_tets(self) -> int: ...
    @property
    def n_points(self) -> int: ...
    @property
    def n_constrained(self) -> int: ...
    def prepare_layout(self, layout: str) -> int: ...
    @property
    def bounds(self) -> list[list[float]]: ...
