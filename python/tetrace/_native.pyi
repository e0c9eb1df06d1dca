"""Type stubs for the compiled core (hand-written; `make lint` runs stubtest against the built
extension, so they cannot drift from src/py/)."""

from collections.abc import Callable
from typing import Any, final

import numpy as np
import numpy.typing as npt

__all__ = [
    "NativeScene",
    "RayRequest",
    "methods",
    "accels",
    "queries",
    "structure_defaults",
    "check_threads",
    "take_rows",
    "camera_directions",
    "triangle_normals",
    "layouts",
    "simd_levels",
    "memory_cache",
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
    "STATUS_NAMES",
    "__version__",
]

MISS: int
HIT: int
FAILED: int
INVALID: int
STATUS_NAMES: list[str]
__version__: str

DEFAULT_METHOD: str
DEFAULT_LAYOUT: str
MAX_THREADS: int

def methods() -> list[str]: ...
def accels() -> list[str]: ...
def queries() -> list[str]: ...
def structure_defaults() -> dict[str, dict[str, Any]]: ...
def check_threads(threads: int | None = None) -> int | None: ...

# rows[index] for an (F + 1, 3) float32/float64 table, index -1 taking the last row, filled
# on the pool's threads (the hits' normals); ValueError for an index outside [-1, F).
def take_rows(
    rows: npt.NDArray[np.floating], index: npt.NDArray[np.int32], threads: int | None = None
) -> npt.NDArray[np.floating]: ...

# A camera's float32 directions (H, W, 3) by the recipe the GPU's camera kernel follows:
# axes (3, 3) rows right, up, forward; xs (W,), ys (H,) image-plane coordinates.
def camera_directions(
    axes: npt.NDArray[np.float32],
    xs: npt.NDArray[np.float32],
    ys: npt.NDArray[np.float32],
    normalize: bool,
    threads: int | None = None,
) -> npt.NDArray[np.float32]: ...
def triangle_normals(
    vertices: npt.NDArray[np.float64], faces: npt.NDArray[np.int64], threads: int | None = None
) -> npt.NDArray[np.float64]: ...
def layouts() -> list[tuple[str, int]]: ...
def simd_levels() -> tuple[list[str], str]: ...
def memory_cache(limit: int | None = None) -> tuple[int, int, int]: ...
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
class RayRequest:
    # One ray query's arguments, checked once: origins, directions (N, 3) C-contiguous in the
    # named precision; tmin, tmax float64 (1 or N); names None for the core's defaults; start:
    # per ray the scene triangle it leaves and the tet its hit's walk ended in (int32, -1: none).
    def __new__(
        cls,
        origins: npt.NDArray[np.floating],
        directions: npt.NDArray[np.floating],
        tmin: npt.NDArray[np.float64],
        tmax: npt.NDArray[np.float64],
        *,
        precision: str,
        threads: int | None = None,
        max_steps: int | None = None,
        method: str | None = None,
        layout: str | None = None,
        accel: str | None = None,
        packet: bool | None = None,
        start: tuple[npt.NDArray[np.int32], npt.NDArray[np.int32]] | None = None,
        audit: bool = False,
    ) -> RayRequest: ...
    def __len__(self) -> int: ...
    @property
    def precision(self) -> str: ...
    # The accelerator a CPU query takes: the one named, else "exact_bvh" for the exact method
    # with no layout, max_steps or audit, "tetwalk" otherwise.
    @property
    def accel(self) -> str: ...

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
    # The caller's triangles (F, 3, 3) alone in the domain box [lo, hi], before any
    # tetrahedralization: the BVHs, the octree and closest points answer; a tet walk
    # (accel "tetwalk", the GPU, parity contains, update_points) is a ValueError.
    @staticmethod
    def surface_only(
        triangles: npt.NDArray[np.float64],
        lo: tuple[float, float, float] | npt.NDArray[np.float64],
        hi: tuple[float, float, float] | npt.NDArray[np.float64],
    ) -> NativeScene: ...
    # Whether the scene holds its tetrahedralization (False: surface_only).
    @property
    def has_ct(self) -> bool: ...
    # One binding for every ray query of the table (queries()): "closest" -> the Hits fields
    # ("t", "u", "v", "point" (N, 3), "triangle", "tet", "steps", "status", and "audit" (N, 2)
    # when the request audits); "any" -> "status" (HIT: something lies in [tmin, tmax]);
    # "all" -> "offsets" int64 (N+1,), "t", "triangle", "u", "v", "point" (M, 3), "status":
    # every point where a ray meets the surface once, sorted by t per ray; "count" -> "count"
    # int32 (N,), "status". progress is called as progress(chunks_done, chunks): once at
    # the start (0, chunks) of a query of several chunks, then every 50 ms.
    def query(
        self,
        kind: str,
        request: RayRequest,
        progress: Callable[[int, int], object] | None = None,
    ) -> dict[str, np.ndarray]: ...
    # The request's float32 rays on the GPU, answering "closest" (the hit fields) or "any"
    # (occlusion: "status"); with the seconds of each phase.
    def cast_gpu(
        self, request: RayRequest, kind: str = "closest"
    ) -> tuple[dict[str, np.ndarray], dict[str, float]]: ...
    # A camera's rays (its float32 axes, xs, ys, normalize; its eye; one range) on the GPU's
    # exact kernel, the directions made on the device: the closest hits and the phases.
    def cast_gpu_camera(
        self,
        axes: npt.NDArray[np.float32],
        xs: npt.NDArray[np.float32],
        ys: npt.NDArray[np.float32],
        normalize: bool,
        eye: npt.NDArray[np.float32],
        tmin: float,
        tmax: float,
        threads: int | None = None,
        max_steps: int | None = None,
    ) -> tuple[dict[str, np.ndarray], dict[str, float]]: ...
    # (N, 3) float32 points -> (N,) bool as contains answers, on the GPU, and its timings.
    def contains_gpu(
        self, points: npt.NDArray[np.float32], threads: int | None = None
    ) -> tuple[npt.NDArray[np.bool_], dict[str, float]]: ...
    # (N, 3) float64 points -> (N,) bool: inside (on the surface counts as inside).
    def contains(
        self, points: npt.NDArray[np.floating], threads: int | None = None
    ) -> npt.NDArray[np.bool_]: ...
    # (N, 3) float64 points, (F,) bool triangles that count -> (N,) uint8: 0 outside,
    # 1 inside, 2 undecided (one ray's crossings on the exact BVH; no tetrahedralization).
    def ray_parity(
        self,
        points: npt.NDArray[np.float64],
        keep: npt.NDArray[np.bool_],
        threads: int | None = None,
    ) -> npt.NDArray[np.uint8]: ...
    # (N, 3) float64 points -> "point" (N, 3), "triangle" int32, "u", "v", "distance".
    def closest_points(
        self, points: npt.NDArray[np.float64], threads: int | None = None
    ) -> dict[str, np.ndarray]: ...
    # None: the core's default (structure_defaults()).
    def build_bvh(
        self,
        cost_ratio: float | None = None,
        max_leaf: int | None = None,
        bins: int | None = None,
        aperture: bool | None = None,
    ) -> dict[str, Any]: ...
    def bvh_info(self) -> dict[str, Any] | None: ...
    def build_exact_bvh(
        self,
        cost_ratio: float | None = None,
        max_leaf: int | None = None,
        bins: int | None = None,
        leaf_size: int | None = None,
    ) -> dict[str, Any]: ...
    def exact_bvh_info(self) -> dict[str, Any] | None: ...
    def build_octree(
        self,
        max_depth: int | None = None,
        leaf_size: int | None = None,
        balance: bool | None = None,
    ) -> dict[str, Any]: ...
    def octree_info(self) -> dict[str, Any] | None: ...
    # Takes over what `other` built (a scene meshed again): non-default structures rebuilt now.
    def adopt_structures(self, other: NativeScene) -> None: ...
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
    @property
    def splits_triangles(self) -> bool: ...
    def prepare_layout(self, layout: str) -> int: ...
    @property
    def bounds(self) -> list[list[float]]: ...
