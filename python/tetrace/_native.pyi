"""Type stubs for the compiled core (hand-written; keep in step with src/py/mod.rs)."""

from typing import Optional

import numpy as np
import numpy.typing as npt

MISS: int
HIT: int
FAILED: int
INVALID: int
__version__: str

DEFAULT_METHOD: str
DEFAULT_LAYOUT: str

def methods() -> list[str]: ...
def layouts() -> list[tuple[str, int]]: ...
def exitface_bench(
    n_tets: int = 10_000, rays_per_tet: int = 16, seed: int = 1, repeat: int = 5
) -> list[tuple[str, str, float, int]]: ...

class MeshError(ValueError): ...
class TooLargeError(ValueError): ...

class NativeScene:
    def __init__(
        self,
        points: npt.NDArray[np.float64],
        tets: npt.NDArray[np.uint32],
        faces: npt.NDArray[np.uint32],
        face_triangle: npt.NDArray[np.uint32],
        triangles: npt.NDArray[np.float64],
        hilbert: bool = True,
    ) -> None: ...
    def cast(
        self,
        origins: npt.NDArray[np.floating],
        directions: npt.NDArray[np.floating],
        tmin: npt.NDArray[np.float64],
        tmax: npt.NDArray[np.float64],
        threads: Optional[int] = None,
        max_steps: Optional[int] = None,
        method: str = "aman2022",
        layout: str = "tet32",
    ) -> dict[str, np.ndarray]: ...
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
