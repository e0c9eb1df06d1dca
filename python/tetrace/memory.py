"""The freed memory tetrace keeps for reuse (re-exported as ``tetrace.memory_cache``).

Imports only the compiled core.
"""

from __future__ import annotations

from . import _native

__all__ = ["memory_cache"]


def memory_cache(limit=None):
    """Return, and optionally bound, the freed memory tetrace keeps for its next casts.

    A cast's answer arrays are allocated by tetrace's compiled core. When numpy frees them,
    blocks of 1 MiB or more are kept, not given back to the system, and the next allocation
    of the same size takes one back. So a cast of as many rays as the last finds its memory
    ready, instead of faulting fresh pages in (about 9,000 page faults for a million rays).
    At most ``limit`` bytes are kept (256 MiB unless set), the oldest given back first. The
    kept pages count in the process's resident memory.

    Parameters
    ----------
    limit : int, optional
        The new bound on the bytes kept. ``0`` keeps nothing and gives back what is kept;
        a lower bound gives back the oldest blocks above it at once. Without it, nothing
        changes.

    Returns
    -------
    dict
        ``blocks`` and ``bytes`` kept now, and ``limit``, the bound in force.

    Raises
    ------
    ValueError
        If ``limit`` is negative.
    TypeError
        If ``limit`` is not an integer.

    Examples
    --------
    >>> import tetrace
    >>> before = tetrace.memory_cache()["limit"]
    >>> tetrace.memory_cache(0)["bytes"]
    0
    >>> tetrace.memory_cache(before)["limit"] == before
    True
    """
    if limit is not None:
        if isinstance(limit, bool) or not isinstance(limit, int):
            raise TypeError(f"limit must be an integer number of bytes, not {limit!r}")
        if limit < 0:
            raise ValueError(f"limit must be at least 0 bytes, not {limit}")
    blocks, kept, bound = _native.memory_cache(limit)
    return {"blocks": blocks, "bytes": kept, "limit": bound}
