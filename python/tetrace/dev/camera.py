"""Ray generators: a pinhole camera, orbit viewpoints and random rays.

The pinhole camera moved to :class:`tetrace.Camera` (:mod:`tetrace.camera`); :func:`pinhole`
stays here as a thin wrapper over it. Imports only numpy (and :mod:`tetrace.camera`).
"""

from __future__ import annotations

import numpy as np

from ..camera import Camera

__all__ = ["pinhole", "orbit_views", "orbit_view", "random_rays"]


def pinhole(eye, target, up=(0, 1, 0), fov_deg=45.0, width=1024, height=1024, dtype=np.float32):
    """Primary rays of a pinhole camera, one per pixel centre, as flat ``(N, 3)`` arrays.

    Moved to the public :class:`tetrace.Camera`: this is
    ``Camera.look_at(eye, target, up, fov_deg, width, height).rays(dtype)`` flattened, the
    same numbers bit for bit as before the move (kept for the tests, benches and notebooks
    that import it). New code: ``scene.cast(camera=tetrace.Camera.look_at(...))``.

    Parameters
    ----------
    eye : array_like
        ``(3,)`` camera position.
    target : array_like
        ``(3,)`` point the camera looks at; it projects to the image centre.
    up : array_like, optional
        ``(3,)`` approximate up direction; must not be parallel to
        ``target - eye``.
    fov_deg : float, optional
        Vertical field of view in degrees. The horizontal one follows from
        ``width / height`` (square pixels).
    width, height : int, optional
        Image size in pixels.
    dtype : numpy dtype, optional
        Float type of the returned arrays.

    Returns
    -------
    origins : numpy.ndarray
        ``(height * width, 3)``, every row equal to ``eye`` (a writable copy per ray).
    directions : numpy.ndarray
        ``(height * width, 3)`` unit directions, pixels in row-major order:
        ray ``i * width + j`` goes through row ``i`` (row 0 is the top of the
        image) and column ``j`` (column 0 is the left).
    """
    cam = Camera.look_at(eye, target, up, fov_deg=fov_deg, width=width, height=height)
    _, directions = cam.rays(dtype)
    origins = np.tile(cam.eye.astype(dtype), (cam.n_rays, 1))
    return origins, directions.reshape(-1, 3)


def orbit_views(bounds, n=3, distance=2.0):
    """Viewpoints around a bounding box, all looking at its centre.

    The eyes sit at ``distance`` times the bounding radius (half the box
    diagonal) from the centre, at azimuths ``30 + 360 k / n`` degrees about
    the +y axis and alternating elevations of +25 and -15 degrees, so no view
    is axis-aligned and the ``n`` directions are distinct.

    Parameters
    ----------
    bounds : array_like
        ``(2, 3)`` ``[min, max]`` corners (as ``trimesh.Trimesh.bounds``).
    n : int, optional
        Number of views.
    distance : float, optional
        Eye distance from the centre, in bounding radii.

    Returns
    -------
    list of tuple
        ``n`` tuples ``(eye, target, up)`` of ``(3,)`` float64 arrays, ready
        for ``pinhole(*view, ...)``. ``up`` is +y.
    """
    bounds = np.asarray(bounds, dtype=np.float64)
    if bounds.shape != (2, 3):
        raise ValueError(f"bounds must have shape (2, 3), got {bounds.shape}")
    if n < 1:
        raise ValueError(f"n must be at least 1, got {n}")
    return [
        orbit_view(bounds, 30.0 + 360.0 * k / n, 25.0 if k % 2 == 0 else -15.0, distance)
        for k in range(n)
    ]


def orbit_view(bounds, azimuth=30.0, elevation=25.0, distance=2.0):
    """One viewpoint on a sphere about a bounding box's centre, looking at the centre.

    Parameters
    ----------
    bounds : array_like
        ``(2, 3)`` ``[min, max]`` corners.
    azimuth : float, optional
        Degrees about the +y axis, from +z towards +x.
    elevation : float, optional
        Degrees above the xz plane.
    distance : float, optional
        Eye distance from the centre, in bounding radii (half the box diagonal). With a
        pinhole's vertical field of view ``fov``, the whole box is in a square frame when
        ``distance >= 1 / sin(fov / 2)`` (2.92 for 40 degrees).

    Returns
    -------
    tuple
        ``(eye, target, up)`` of ``(3,)`` float64 arrays for ``pinhole(*view, ...)``;
        ``up`` is +y.
    """
    bounds = np.asarray(bounds, dtype=np.float64)
    if bounds.shape != (2, 3):
        raise ValueError(f"bounds must have shape (2, 3), got {bounds.shape}")
    centre = bounds.mean(axis=0)
    radius = 0.5 * np.linalg.norm(bounds[1] - bounds[0])
    if not radius > 0.0:
        radius = 1.0
    a, e = np.radians(azimuth), np.radians(elevation)
    direction = np.array([np.cos(e) * np.sin(a), np.sin(e), np.cos(e) * np.cos(a)])
    return centre + distance * radius * direction, centre.copy(), np.array([0.0, 1.0, 0.0])


def random_rays(bounds, n, seed, grow=0.25, dtype=np.float64):
    """Random rays in and around a bounding box.

    Parameters
    ----------
    bounds : array_like
        ``(2, 3)`` ``[min, max]`` corners.
    n : int
        Number of rays.
    seed : int or numpy.random.SeedSequence
        Seed for ``numpy.random.default_rng``; the same seed gives the same rays.
    grow : float, optional
        The box is grown by ``grow`` times its size on each side before sampling
        origins, so some rays start outside the mesh's box.
    dtype : numpy dtype, optional
        Float type of the returned arrays.

    Returns
    -------
    origins : numpy.ndarray
        ``(n, 3)``, uniform in the grown box.
    directions : numpy.ndarray
        ``(n, 3)`` unit vectors, uniform on the sphere.
    """
    bounds = np.asarray(bounds, dtype=np.float64)
    if bounds.shape != (2, 3):
        raise ValueError(f"bounds must have shape (2, 3), got {bounds.shape}")
    rng = np.random.default_rng(seed)
    size = bounds[1] - bounds[0]
    lo = bounds[0] - grow * size
    hi = bounds[1] + grow * size
    origins = lo + rng.random((n, 3)) * (hi - lo)
    directions = rng.standard_normal((n, 3))
    norms = np.linalg.norm(directions, axis=1, keepdims=True)
    bad = norms[:, 0] == 0.0  # probability zero, but keep the output unit length
    directions[bad] = (1.0, 0.0, 0.0)
    norms[bad] = 1.0
    directions /= norms
    return origins.astype(dtype), directions.astype(dtype)
