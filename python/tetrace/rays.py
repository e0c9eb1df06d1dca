"""Checking and normalising ray arrays before they reach the compiled core."""

from __future__ import annotations

import numpy as np

__all__ = ["prepare_rays", "prepare_bounds", "raise_invalid"]


def prepare_rays(origins, directions=None, *, invalid="raise"):
    """Return C-contiguous ``(N, 3)`` origins and directions of one float dtype.

    Parameters
    ----------
    origins : array_like
        ``(N, 3)`` origins, or ``(N, 6)`` rays ``[ox, oy, oz, dx, dy, dz]`` when
        ``directions`` is None. A single ``(3,)`` origin is shared by all directions.
    directions : array_like, optional
        ``(N, 3)`` directions (need not be unit length), or one ``(3,)`` direction
        shared by all origins.
    invalid : {"raise", "mark"}
        Checked here for its value only: the core marks rays that have a NaN or infinite
        component or a zero-length direction with status ``INVALID`` as it casts, and
        :func:`raise_invalid` turns those marks into an error (cheaper than checking the
        arrays in numpy first).

    Returns
    -------
    origins, directions : numpy.ndarray
        float32 if both inputs are float32 (or float16), float64 otherwise.
    """
    if invalid not in ("raise", "mark"):
        raise ValueError(f'invalid must be "raise" or "mark", got {invalid!r}')
    o = _as_float(origins, "origins")
    if directions is None:
        if o.ndim == 1:
            o = o[None, :]
        if o.ndim != 2 or o.shape[1] != 6:
            raise ValueError(
                f"rays must have shape (N, 6) [ox, oy, oz, dx, dy, dz] when no directions are "
                f"given, got {o.shape}"
            )
        o, d = o[:, :3], o[:, 3:]
    else:
        d = _as_float(directions, "directions")
        for name, a in (("origins", o), ("directions", d)):
            if a.ndim not in (1, 2) or a.shape[-1] != 3:
                raise ValueError(f"{name} must have shape (N, 3) or (3,), got {a.shape}")
        if o.ndim == 1 and d.ndim == 1:
            o, d = o[None], d[None]
        elif o.ndim == 1:
            o = np.broadcast_to(o, d.shape)
        elif d.ndim == 1:
            d = np.broadcast_to(d, o.shape)
        if o.shape != d.shape:
            raise ValueError(
                f"origins {o.shape} and directions {d.shape} must have the same length"
            )
    dtype = np.float32 if (o.dtype == np.float32 and d.dtype == np.float32) else np.float64
    o = np.ascontiguousarray(o, dtype=dtype)
    d = np.ascontiguousarray(d, dtype=dtype)
    return o, d


def raise_invalid(status, origins, directions):
    """Raise ``ValueError`` naming the rays the core marked ``INVALID``, if any."""
    from .hits import INVALID

    bad = status == INVALID
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        raise ValueError(
            f"{int(bad.sum())} of {len(status)} rays have a NaN/inf component or a zero-length "
            f"direction (first: ray {k}, origin {origins[k].tolist()}, direction "
            f'{directions[k].tolist()}); pass invalid="mark" to get status INVALID for them instead'
        )


def prepare_bounds(value, n, name):
    """Return tmin or tmax as a float64 array of 1 or ``n`` values."""
    a = np.asarray(value)
    if a.dtype.kind not in "biuf":
        raise TypeError(f"{name} must be a number or an array of numbers, got dtype {a.dtype}")
    a = a.astype(np.float64, copy=False)
    if a.ndim == 0:
        a = a.reshape(1)
    if a.ndim != 1 or len(a) not in (1, n):
        raise ValueError(f"{name} must be a scalar or have shape ({n},), got {np.shape(value)}")
    if np.isnan(a).any():
        raise ValueError(f"{name} contains NaN")
    if name == "tmin" and (a < 0).any():
        raise ValueError("tmin must be >= 0")
    return np.ascontiguousarray(a)


def _as_float(a, name):
    arr = np.asarray(a)
    if arr.dtype.kind in "biu":
        return arr.astype(np.float64)
    if arr.dtype.kind != "f":
        raise TypeError(f"{name} must be a float array (float32 or float64), got dtype {arr.dtype}")
    if arr.dtype == np.float16:
        return arr.astype(np.float32)
    if arr.dtype not in (np.float32, np.float64):  # longdouble
        return arr.astype(np.float64)
    return arr
