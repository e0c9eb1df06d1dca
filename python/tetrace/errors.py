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

Bad mesh input (``tests/test_bad_mesh.py``): a missing path raises
:class:`MeshFileNotFoundError` (``str``: ``mesh file not found: PATH``, with the working
directory when ``PATH`` is relative); a directory, a file trimesh cannot read or reads no
triangles from (empty, corrupt, truncated: the message says what the bytes show, such as a
binary STL shorter than its triangle count, :func:`tetrace.io.unreadable_reason`), NaN/inf
vertices or coordinates beyond ``tetrace.io.MAX_COORDINATE``, negative or out-of-range
indices, faces not of shape ``(F, 3)``, no faces, or only degenerate triangles raise
:class:`MeshingError`, the message naming the file (or the argument) and the problem; faces
that are not integers raise ``TypeError``. Needles that TetGen takes for self-intersections
are named as needles in the failure's message; needles narrower than
``tetrace.mesh.clean.DEGENERATE_WIDTH`` of their longest edge (collinear up to rounding)
are dropped by cleaning like zero-area ones (``tetrahedralization.clean.triangle_ids``
lacks them).

``MeshError``, ``TooLargeError`` and ``GpuError`` are defined by the compiled core
(``tetrace._native``) and re-exported here unchanged.

Built-in exceptions, where they say it best (each message names the argument and the problem;
the scene stays usable after any of them, ``tests/test_bad_input.py`` checks each case):

* ``TypeError``: an argument of the wrong type: rays of dtype object, complex, bool or str;
  ``threads`` or ``max_steps`` not an int (``1.5``, ``"2"``, ``True``); a method or layout
  name that is not a str; an unknown keyword.
* ``ValueError``: a wrong value: a ray array of the wrong shape, or origins and directions
  that do not broadcast; NaN/inf in ``origins`` or ``directions``, a zero-length direction, or
  a hit whose ``t`` overflows the rays' precision (a direction so short that ``t`` has no
  finite value), unless ``invalid="mark"``; ``tmin < 0`` or NaN bounds; an unknown method,
  layout, accel, precision or device name; ``threads`` outside ``[1, MAX_THREADS]``
  (``tetrace.scene.MAX_THREADS``: 4 per core, at least 64); ``max_steps`` outside
  ``[1, 2**32)``.
* ``MemoryError``: the outputs of a query (sized by the ray count) cannot be allocated; the
  message gives the bytes asked for. The core allocates them before it starts, so nothing is
  half-done.
* ``KeyboardInterrupt`` (or whatever a signal handler raises): Ctrl-C during a cast or query
  (the core polls Python's signal handlers at the start of a query and every 50 ms, and
  stops between chunks of 4096 rays; no partial answer is returned) or during meshing (the
  mesher's child process is killed). The mesher's forked-child signals
(``_TetGenFailed`` and its kin) are private to :mod:`tetrace.mesh.isolate` and never reach
the caller: they become :class:`MeshingError`.
"""

from __future__ import annotations

import errno
import os

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


class _MissingFile:
    """Mixin (first in the bases) of a missing file that is also a ``ValueError`` and a
    ``FileNotFoundError``: ``FileNotFoundError``'s attributes (``errno`` ENOENT,
    ``strerror``, ``filename``) and a sentence for its ``str``.

    With ``ValueError`` before ``FileNotFoundError`` in the bases (``except ValueError``
    catches them), ``OSError``'s constructor, which fills the attributes, never runs, and
    its ``__str__`` printed the arguments as a tuple: both are done here.
    """

    def __init__(self, message: str, filename) -> None:
        super().__init__(message)
        self.errno = errno.ENOENT
        self.strerror = os.strerror(errno.ENOENT)
        self.filename = os.fspath(filename)

    def __str__(self) -> str:
        return str(self.args[0]) if self.args else ""

    def __reduce__(self):
        # OSError's would rebuild from (errno, strerror, filename): not this signature.
        return type(self), (str(self), self.filename)


class MeshingError(ValueError):
    """A scene cannot be loaded or tetrahedralized; the message names the cause."""


class MeshFileNotFoundError(_MissingFile, MeshingError, FileNotFoundError):
    """The mesh file does not exist (both a :class:`MeshingError` and a ``FileNotFoundError``).

    Parameters
    ----------
    message : str
        The sentence ``str(error)`` gives; it names the path.
    filename : str or os.PathLike
        The path asked for (``error.filename``); ``error.errno`` is ``errno.ENOENT``.
    """


class SceneFileError(ValueError):
    """A saved scene cannot be loaded (:meth:`tetrace.Scene.load`, unpickling): not a scene
    file, a newer format version, a truncated or corrupt file; the message names the file
    and what is wrong."""


class SceneFileNotFoundError(_MissingFile, SceneFileError, FileNotFoundError):
    """The scene file does not exist (both a :class:`SceneFileError` and a
    ``FileNotFoundError``; parameters as :class:`MeshFileNotFoundError`'s)."""


#: The compiled core rejects a tetrahedralization (a ``ValueError``).
MeshError = _native.MeshError
#: The mesh exceeds a traversal layout's limits (a ``ValueError``).
TooLargeError = _native.TooLargeError
#: No adapter can run the GPU kernels, or the device failed (a ``RuntimeError``).
GpuError = _native.GpuError
