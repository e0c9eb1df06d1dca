"""tetrace: cast rays through constrained tetrahedralizations of triangle scenes.

>>> import tetrace
>>> scene = tetrace.Scene.from_mesh("bunny.obj")            # doctest: +SKIP
>>> hits = scene.cast(origins, directions)                   # doctest: +SKIP
>>> hits.t, hits.triangle, hits.status                       # doctest: +SKIP
"""

from . import (
    _native,
    gpu,  # noqa: F401  (tetrace.gpu.info() is part of the API)
)
from .conveniences import cast, default_scene
from .errors import (
    GpuError,
    MeshError,
    MeshFileNotFoundError,
    MeshingError,
    SceneFileError,
    SceneFileNotFoundError,
    TooLargeError,
)
from .hits import FAILED, HIT, INVALID, MISS, STATUS_NAMES, Hits
from .scene import (
    LAYOUT_BYTES,
    Deformation,
    Scene,
    accels,
    default_scene_path,
    layouts,
    methods,
    simd_levels,
)

__version__ = _native.__version__

__all__ = [
    "Scene",
    "Deformation",
    "Hits",
    "cast",
    "default_scene",
    "default_scene_path",
    "methods",
    "accels",
    "layouts",
    "simd_levels",
    "LAYOUT_BYTES",
    "MISS",
    "HIT",
    "FAILED",
    "INVALID",
    "STATUS_NAMES",
    "MeshingError",
    "MeshFileNotFoundError",
    "SceneFileError",
    "SceneFileNotFoundError",
    "MeshError",
    "TooLargeError",
    "GpuError",
    "gpu",
]
