"""tetrace: cast rays through constrained tetrahedralizations of triangle scenes.

>>> import tetrace
>>> scene = tetrace.Scene.from_mesh("bunny.obj")            # doctest: +SKIP
>>> hits = scene.cast(origins, directions)                   # doctest: +SKIP
>>> hits.t, hits.triangle, hits.status                       # doctest: +SKIP
>>> cam = tetrace.Camera.look_at(eye, target, width=640, height=480)  # doctest: +SKIP
>>> scene.cast(camera=cam).t.shape                           # doctest: +SKIP
(480, 640)
"""

from . import (
    _native,
    camera,  # noqa: F401  (tetrace.camera is part of the API)
    gpu,  # noqa: F401  (tetrace.gpu.info() is part of the API)
    io,  # noqa: F401  (tetrace.io.load_triangles and MAX_COORDINATE are part of the API)
)
from .camera import Camera
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
from .memory import memory_cache
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
    "Camera",
    "cast",
    "default_scene",
    "default_scene_path",
    "methods",
    "accels",
    "layouts",
    "simd_levels",
    "memory_cache",
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
    "camera",
    "io",
]
