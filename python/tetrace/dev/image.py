"""Turn camera hits into images and PNG files.

Imports only numpy; ``save_png`` needs matplotlib (colormaps only, no pyplot)
and Pillow.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..hits import HIT

__all__ = ["depth_image", "shade", "lambert", "save_png"]


def _check_size(hits, width, height):
    if len(hits) != width * height:
        raise ValueError(f"{len(hits)} rays do not make a {width} x {height} image")


def depth_image(hits, width, height):
    """Hit distances as an image.

    Parameters
    ----------
    hits : Hits
        Results of casting ``width * height`` rays in row-major pixel order
        (as :func:`tetrace.dev.camera.pinhole` makes them).
    width, height : int
        Image size.

    Returns
    -------
    numpy.ndarray
        ``(height, width)`` float64 array of ``t``, ``nan`` where the ray did
        not hit (miss or failed).
    """
    _check_size(hits, width, height)
    depth = np.where(hits.status == HIT, hits.t, np.nan).astype(np.float64)
    return depth.reshape(height, width)


def shade(hits, directions, width, height):
    """Grey depth shading: near surfaces bright, far ones darker, misses black.

    Parameters
    ----------
    hits : Hits
        Results of casting ``width * height`` camera rays.
    directions : array_like
        ``(width * height, 3)`` ray directions, used to turn ``t`` into a
        distance when they are not unit length.
    width, height : int
        Image size.

    Returns
    -------
    numpy.ndarray
        ``(height, width)`` float64 in ``[0, 1]``: hits from 1.0 (nearest) to
        0.2 (farthest), 0.0 where the ray did not hit. Save it with
        ``save_png(path, image, cmap="gray", vmin=0.0, vmax=1.0)``.
    """
    _check_size(hits, width, height)
    lengths = np.linalg.norm(np.asarray(directions, dtype=np.float64).reshape(-1, 3), axis=1)
    hit = hits.status == HIT
    dist = np.where(hit, hits.t * lengths, np.nan)
    out = np.zeros(len(hits), dtype=np.float64)
    if hit.any():
        near, far = np.nanmin(dist), np.nanmax(dist)
        span = far - near if far > near else 1.0
        out[hit] = 1.0 - 0.8 * (dist[hit] - near) / span
    return out.reshape(height, width)


def lambert(hits, directions, vertices, faces, width, height):
    """Headlight shading: brightness |cos| between each ray and the normal of the triangle it hit.

    Parameters
    ----------
    hits : Hits
        Results of casting ``width * height`` camera rays.
    directions : array_like
        ``(width * height, 3)`` ray directions.
    vertices, faces : numpy.ndarray
        The mesh the hit triangle ids index.
    width, height : int
        Image size.

    Returns
    -------
    numpy.ndarray
        ``(height, width)`` float64 in ``[0, 1]``, 0 where the ray did not hit; save with
        ``cmap="gray", vmin=0, vmax=1``.
    """
    _check_size(hits, width, height)
    d = np.asarray(directions, dtype=np.float64).reshape(-1, 3)
    hit = hits.status == HIT
    out = np.zeros(len(hits), dtype=np.float64)
    if hit.any():
        p = np.asarray(vertices, np.float64)[np.asarray(faces)[hits.triangle[hit]]]
        n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
        with np.errstate(invalid="ignore", divide="ignore"):
            cos = np.abs(np.einsum("ij,ij->i", n, d[hit])) / (
                np.linalg.norm(n, axis=1) * np.linalg.norm(d[hit], axis=1)
            )
        out[hit] = 0.15 + 0.85 * np.nan_to_num(cos)
    return out.reshape(height, width)


def save_png(path, array, cmap="viridis", mask_value=np.nan, *, vmin=None, vmax=None):
    """Write a 2-D array to a PNG through a matplotlib colormap.

    Parameters
    ----------
    path : str or os.PathLike
        Output file; missing parent folders are created.
    array : array_like
        ``(H, W)`` values. Non-finite values, and values equal to
        ``mask_value``, are drawn black.
    cmap : str, optional
        Matplotlib colormap name (``"viridis"``, ``"inferno"``, ``"gray"``, ...).
    mask_value : float, optional
        Extra value to draw black (``nan``: only non-finite values are masked).
    vmin, vmax : float, optional
        Value range mapped to the colormap ends; defaults to the min and max
        of the unmasked values.

    Returns
    -------
    pathlib.Path
        The file written.
    """
    import matplotlib
    from PIL import Image

    data = np.asarray(array, dtype=np.float64)
    if data.ndim != 2:
        raise ValueError(f"array must be 2-D, got shape {data.shape}")
    mask = ~np.isfinite(data)
    if not np.isnan(mask_value):
        mask |= data == mask_value
    valid = data[~mask]
    lo = vmin if vmin is not None else (valid.min() if valid.size else 0.0)
    hi = vmax if vmax is not None else (valid.max() if valid.size else 1.0)
    scale = hi - lo if hi > lo else 1.0
    norm = np.clip((np.where(mask, lo, data) - lo) / scale, 0.0, 1.0)
    rgba = matplotlib.colormaps[cmap](norm, bytes=True)
    rgb = rgba[..., :3].copy()
    rgb[mask] = 0
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(np.ascontiguousarray(rgb)).save(path)
    return path
