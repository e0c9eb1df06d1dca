"""The names the core knows: exit-face methods, acceleration structures, tet layouts, SIMD
levels, and the thread limit; and the check of a method and layout name.

Re-exported by :mod:`tetrace` and :mod:`tetrace.scene` (``tetrace.methods()``,
``tetrace.scene.methods()``). Imports only the compiled core.
"""

from __future__ import annotations

from . import _native

__all__ = ["methods", "accels", "layouts", "simd_levels", "LAYOUT_BYTES", "MAX_THREADS"]

#: Bytes per tet of each layout's record.
LAYOUT_BYTES = dict(_native.layouts())


def methods():
    """Return the names of the exit-face methods, in the order of the papers.

    Returns
    -------
    list of str
    """
    return list(_native.methods())


def accels():
    """Return the names of the acceleration structures, the default (``tetwalk``) first.

    Returns
    -------
    list of str
    """
    return list(_native.accels())


def layouts():
    """Return the names of the tet layouts (bytes per tet in :data:`LAYOUT_BYTES`).

    Returns
    -------
    list of str
    """
    return list(LAYOUT_BYTES)


def simd_levels():
    """Return the SIMD levels this CPU runs and the one casts use now.

    Kernels with a vector version (the packets' per-ray exits) run at the highest level the
    CPU has; the environment variable ``TETRACE_SIMD`` (``"scalar"`` or ``"avx2"``) caps it,
    read at every cast. Answers are the same at every level, bit for bit.

    Returns
    -------
    levels : list of str
        Lowest first: ``"scalar"``, then ``"avx2"`` on x86-64 CPUs that have AVX2.
    current : str
        The level a cast runs at now.

    Raises
    ------
    ValueError
        If ``TETRACE_SIMD`` names no level.
    """
    levels, current = _native.simd_levels()
    return list(levels), current


#: The most worker threads a call may ask for: 4 per core, and at least 64. More only adds
#: switching, and a typo (``threads=10**9``) would otherwise try to start them all.
MAX_THREADS = _native.MAX_THREADS
