"""Every exception tetrace raises on purpose, in one place.

The hierarchy (the built-in base each one also is, so ``except ValueError`` keeps working)::

    ValueError
    ├── MeshingError            a scene cannot be loaded or tetrahedralized (tetrace.mesh)
    │   └── MeshFileNotFoundError   ... because the file is missing (also a FileNotFoundError)
    ├── SceneFileError          a saved scene cannot be loaded: not a scene file, a newer
    │   │                       format version, truncated or corrupt (tetrace.Scene.load)
    │   └── SceneFileNotFoundError  ... because the file is missing (also a FileNotFoundError)
    ├── MeshError               the compiled core rejects a tetrahedralization (bad indices,
    │                           inverted or degenerate tets, a face that is no tet face)
    └── TooLargeError           the mesh exceeds a layout's limits (e.g. tet16's 24-bit links)
    RuntimeError
    └── GpuError                no GPU adapter can run the kernels, or the device failed

``MeshError``, ``TooLargeError`` and ``GpuError`` are defined by the compiled core
(``tetrace._native``) and re-exported here unchanged. Bad arguments (a wrong shape, an unknown
method name) raise plain ``ValueError`` or ``TypeError``. The mesher's forked-child signals
(``_TetGenFailed`` and its kin) are private to :mod:`tetrace.mesh.isolate` and never reach
the caller: they become :class:`MeshingError`.
"""

from __future__ import annotations

from . import _native

__all__ = [
    "MeshingError",
    "MeshFileNotFoundError",
    "SceneFileError",
    "SceneFileNotFoundError",
    "MeshError",
    "TooLargeError",
    "GpuError",
]


class MeshingError(ValueError):
    """A scene cannot be loaded or tetrahedralized; the message names the cause."""


class MeshFileNotFoundError(MeshingError, FileNotFoundError):
    """The mesh file does not exist (both a :class:`MeshingError` and a ``FileNotFoundError``)."""


class SceneFileError(ValueError):
    """A saved scene cannot be loaded (:meth:`tetrace.Scene.load`, unpickling): not a scene
    file, a newer format version, a truncated or corrupt file; the message names the file
    and what is wrong."""


class SceneFileNotFoundError(SceneFileError, FileNotFoundError):
    """The scene file does not exist (both a :class:`SceneFileError` and a
    ``FileNotFoundError``)."""


#: The compiled core rejects a tetrahedralization (a ``ValueError``).
MeshError = _native.MeshError
#: The mesh exceeds a traversal layout's limits (a ``ValueError``).
TooLargeError = _native.TooLargeError
#: No adapter can run the GPU kernels, or the device failed (a ``RuntimeError``).
GpuError = _native.GpuError
