"""Deprecated alias of :mod:`tetrace.baselines.embree` (the Embree reference moved there)."""

import warnings

from .baselines.embree import *  # noqa: F403
from .baselines.embree import __all__  # noqa: F401

warnings.warn(
    "tetrace.reference is deprecated; use tetrace.baselines.embree",
    DeprecationWarning,
    stacklevel=2,
)
