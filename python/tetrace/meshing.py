"""Deprecated alias of :mod:`tetrace.mesh` (meshing is split into tetrace.mesh's modules)."""

import warnings

from .mesh import *  # noqa: F403
from .mesh import __all__  # noqa: F401

warnings.warn("tetrace.meshing is deprecated; use tetrace.mesh", DeprecationWarning, stacklevel=2)
