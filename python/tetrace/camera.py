"""Pinhole cameras: one ray per pixel, for :meth:`tetrace.Scene.cast` (``camera=``) and friends.

>>> import tetrace
>>> cam = tetrace.Camera.look_at(eye=(0, 0, 3), target=(0, 0, 0), width=64, height=48)
>>> origins, directions = cam.rays()          # float32, image layout
>>> directions.shape
(48, 64, 3)
>>> scene.cast(camera=cam).t.shape             # doctest: +SKIP
(48, 64)

Two ways to make one: :meth:`Camera.look_at` (an eye, a target, an up vector and a vertical
field of view, as :func:`tetrace.dev.camera.pinhole` always did) and
:meth:`Camera.from_intrinsics` (a 3x3 intrinsic matrix and a world-to-camera extrinsic, as
Open3D's ``RaycastingScene.create_rays_pinhole`` takes them). The rays are numpy arrays for a
cast on any device; a GPU cast of ``camera=cam`` makes the same float32 rays in its kernel
instead of uploading them.

Float32 rays follow one recipe, the same bits wherever they are made: the camera's numbers
rounded once to float32, then ``d = (forward + x * right) + y * up`` and, when the camera
normalizes, ``d / sqrt((dx * dx + dy * dy) + dz * dz)``, each operation correctly rounded in
float32 (the core makes them, ``tetrace._native.camera_directions``; the GPU's kernel
``shaders/camera.wgsl`` makes them alike). Float64 rays are computed in float64.

Imports numpy, and the core for float32 rays.
"""

from __future__ import annotations

import dataclasses
import operator

import numpy as np

__all__ = ["Camera"]


def _unit(v, name):
    v = np.asarray(v, dtype=np.float64)
    norm = np.linalg.norm(v)
    if not np.isfinite(norm) or norm == 0.0:
        raise ValueError(f"{name} must be a finite nonzero vector, got {v}")
    return v / norm


def _vector3(v, name):
    v = np.asarray(v, dtype=np.float64)
    if v.shape != (3,):
        raise ValueError(f"{name} must have shape (3,), got {v.shape}")
    return v


def _size(width, height):
    """``width`` and ``height`` as positive Python ints, or a ValueError naming them."""
    try:
        w, h = operator.index(width), operator.index(height)
    except TypeError:
        w = h = 0
    if isinstance(width, bool) or isinstance(height, bool) or w < 1 or h < 1:
        raise ValueError(f"width and height must be positive integers, got {width} x {height}")
    return w, h


def _frozen_array(a, name, ndim):
    a = np.array(a, dtype=np.float64)  # a copy: the camera owns its numbers
    if a.ndim != ndim:
        raise ValueError(f"{name} must be {ndim}-dimensional, got shape {a.shape}")
    if not np.isfinite(a).all():
        raise ValueError(f"{name} must be finite, got {a}")
    a.setflags(write=False)
    return a


@dataclasses.dataclass(frozen=True, eq=False, repr=False)
class Camera:
    """A pinhole camera: an eye and one ray direction per pixel, immutable.

    The ray through pixel ``(i, j)`` (row ``i``, column ``j``) starts at :attr:`eye` and goes
    in the direction ``axes[2] + xs[j] * axes[0] + ys[i] * axes[1]``, divided by its length
    when :attr:`normalize` is set: ``(xs[j], ys[i], 1)`` is the pixel's centre on the image
    plane at depth 1, in the camera frame whose axes (in world coordinates) are the rows of
    :attr:`axes`. Build one with :meth:`look_at` or :meth:`from_intrinsics`; the fields are
    read-only float64 arrays.

    Attributes
    ----------
    eye : numpy.ndarray
        ``(3,)`` float64, the origin of every ray (the camera centre).
    axes : numpy.ndarray
        ``(3, 3)`` float64: row 0 is the direction ``xs`` step along, row 1 the one ``ys``
        step along, row 2 the direction through the image plane's origin.
    xs : numpy.ndarray
        ``(width,)`` float64, each column's image-plane coordinate along ``axes[0]``.
    ys : numpy.ndarray
        ``(height,)`` float64, each row's image-plane coordinate along ``axes[1]``.
    normalize : bool
        Whether the directions are scaled to unit length (:meth:`look_at`) or left as the
        projection gives them (:meth:`from_intrinsics`, as Open3D does).
    """

    eye: np.ndarray
    axes: np.ndarray
    xs: np.ndarray
    ys: np.ndarray
    normalize: bool = True

    def __post_init__(self):
        eye = _frozen_array(self.eye, "eye", 1)
        axes = _frozen_array(self.axes, "axes", 2)
        xs, ys = _frozen_array(self.xs, "xs", 1), _frozen_array(self.ys, "ys", 1)
        if eye.shape != (3,):
            raise ValueError(f"eye must have shape (3,), got {eye.shape}")
        if axes.shape != (3, 3):
            raise ValueError(f"axes must have shape (3, 3), got {axes.shape}")
        if len(xs) == 0 or len(ys) == 0:
            raise ValueError(f"xs and ys must not be empty, got {len(xs)} x {len(ys)} pixels")
        if not isinstance(self.normalize, (bool, np.bool_)):
            raise ValueError(f"normalize must be a bool, got {self.normalize!r}")
        for name, value in (("eye", eye), ("axes", axes), ("xs", xs), ("ys", ys)):
            object.__setattr__(self, name, value)
        object.__setattr__(self, "normalize", bool(self.normalize))

    @classmethod
    def look_at(cls, eye, target, up=(0, 1, 0), fov_deg=45.0, width=1024, height=1024):
        """A camera at ``eye`` looking at ``target``, with a vertical field of view.

        The geometry of :func:`tetrace.dev.camera.pinhole`, bit for bit: square pixels, one
        ray through each pixel's centre, row 0 at the top of the image and column 0 at its
        left, unit directions.

        Parameters
        ----------
        eye : array_like
            ``(3,)`` camera position.
        target : array_like
            ``(3,)`` point the camera looks at; it projects to the image centre.
        up : array_like, optional
            ``(3,)`` approximate up direction; must not be parallel to ``target - eye``.
        fov_deg : float, optional
            Vertical field of view in degrees, in ``(0, 180)``: the angle between the top
            and bottom edges of the image (not the pixel centres). The horizontal one
            follows from ``width / height``.
        width, height : int, optional
            Image size in pixels.

        Returns
        -------
        Camera
            With ``normalize=True``; ``axes`` are the right, true up and forward unit
            vectors, ``xs`` and ``ys`` the pixel centres' coordinates on the image plane
            at distance 1 (``ys`` decreasing down the image).

        Raises
        ------
        ValueError
            A non-positive or non-integer size, a field of view outside ``(0, 180)``,
            ``target == eye``, a zero or non-finite ``up``, or ``up`` parallel to the
            viewing direction.
        """
        width, height = _size(width, height)
        if not 0.0 < fov_deg < 180.0:
            raise ValueError(f"fov_deg must be in (0, 180), got {fov_deg}")
        eye = _vector3(eye, "eye")
        forward = _unit(_vector3(target, "target") - eye, "target - eye")
        right = np.cross(forward, _unit(_vector3(up, "up"), "up"))
        if np.linalg.norm(right) < 1e-9:
            raise ValueError("up is parallel to the viewing direction")
        right /= np.linalg.norm(right)
        true_up = np.cross(right, forward)

        half_h = np.tan(np.radians(fov_deg) / 2.0)
        half_w = half_h * width / height
        xs = ((np.arange(width) + 0.5) / width * 2.0 - 1.0) * half_w
        ys = (1.0 - (np.arange(height) + 0.5) / height * 2.0) * half_h
        return cls(eye, np.stack([right, true_up, forward]), xs, ys, normalize=True)

    @classmethod
    def from_intrinsics(cls, intrinsic, extrinsic, width, height):
        """A camera from an intrinsic matrix and a world-to-camera extrinsic, as Open3D.

        The rays of Open3D's ``RaycastingScene.create_rays_pinhole(intrinsic_matrix,
        extrinsic_matrix, width_px, height_px)``: with ``K = intrinsic`` and
        ``[R | t]`` the extrinsic's top three rows (a world point ``X`` is at ``R X + t``
        in the camera frame, whose ``+z`` looks forward and ``+y`` down the image), pixel
        ``(i, j)`` (row ``i``, column ``j``) has the ray

        * origin ``-R^T t``, the camera centre;
        * direction ``R^T K^{-1} (j + 0.5, i + 0.5, 1)``: through the pixel's centre (pixel
          ``(0, 0)`` covers ``[0, 1] x [0, 1]`` in image coordinates), **not** normalized:
          with ``K[2, 2] == 1`` its camera-frame depth is 1, so a hit's ``t`` is the
          point's depth along the optical axis, as in Open3D.

        Open3D computes ``R^T K^{-1}`` in float64, rounds it to float32 and multiplies in
        float32; here ``axes``, ``xs`` and ``ys`` are float64, and float32 rays round them once
        and combine them in float32 (:meth:`rays`), so both agree to a few float32 ulps of
        the terms summed.

        Parameters
        ----------
        intrinsic : array_like
            ``(3, 3)`` upper triangular ``[[fx, s, cx], [0, fy, cy], [0, 0, 1]]`` (a nonzero
            ``K[2, 2]`` other than 1 scales the directions by its inverse, as in Open3D),
            in pixels.
        extrinsic : array_like
            ``(4, 4)`` world-to-camera rigid transform, last row ``(0, 0, 0, 1)``, or its
            ``(3, 4)`` top rows ``[R | t]``. ``R`` must be a rotation (orthonormal to
            ``1e-5``, so float32-stored matrices pass; determinant +1).
        width, height : int
            Image size in pixels.

        Returns
        -------
        Camera
            With ``normalize=False``; ``axes`` are ``R``'s rows (the camera's x, y and z
            axes in world coordinates; row 1 sheared by ``s`` and row 2 divided by
            ``K[2, 2]``), ``xs[j] = (j + 0.5 - cx) / fx`` and ``ys[i] = (i + 0.5 - cy) /
            fy``.

        Raises
        ------
        ValueError
            A matrix of the wrong shape, with a NaN or infinite entry, an intrinsic that is
            not upper triangular or has a zero ``fx``, ``fy`` or ``K[2, 2]``, an extrinsic
            whose last row is not ``(0, 0, 0, 1)`` or whose ``R`` is not a rotation, or a
            non-positive or non-integer size.
        """
        width, height = _size(width, height)
        k = np.asarray(intrinsic, dtype=np.float64)
        if k.shape != (3, 3):
            raise ValueError(f"intrinsic must have shape (3, 3), got {k.shape}")
        if not np.isfinite(k).all():
            raise ValueError(f"intrinsic must be finite, got {k.tolist()}")
        if k[1, 0] != 0.0 or k[2, 0] != 0.0 or k[2, 1] != 0.0:
            raise ValueError(
                f"intrinsic must be upper triangular [[fx, s, cx], [0, fy, cy], [0, 0, 1]], "
                f"got {k.tolist()}"
            )
        if k[0, 0] == 0.0 or k[1, 1] == 0.0 or k[2, 2] == 0.0:
            raise ValueError(
                f"intrinsic's focal lengths fx, fy and K[2, 2] must be nonzero, got "
                f"fx={k[0, 0]}, fy={k[1, 1]}, K[2, 2]={k[2, 2]}"
            )
        e = np.asarray(extrinsic, dtype=np.float64)
        if e.shape not in ((4, 4), (3, 4)):
            raise ValueError(f"extrinsic must have shape (4, 4) or (3, 4), got {e.shape}")
        if not np.isfinite(e).all():
            raise ValueError(f"extrinsic must be finite, got {e.tolist()}")
        if e.shape == (4, 4) and not np.array_equal(e[3], [0.0, 0.0, 0.0, 1.0]):
            raise ValueError(f"extrinsic's last row must be (0, 0, 0, 1), got {e[3].tolist()}")
        r, t = e[:3, :3], e[:3, 3]
        if np.abs(r @ r.T - np.eye(3)).max() > 1e-5 or np.linalg.det(r) <= 0.0:
            raise ValueError(
                f"extrinsic's 3x3 block must be a rotation (orthonormal, determinant +1), "
                f"got {r.tolist()}"
            )
        fx, s, cx = k[0]
        fy, cy, kz = k[1, 1], k[1, 2], k[2, 2]
        # K p = (u, v, 1) for p = (x_u - (s / fx) y_v, y_v, 1 / kz), with
        # x_u = (u - cx / kz) / fx and y_v = (v - cy / kz) / fy; the direction R^T p.
        axes = np.stack([r[0], r[1] - (s / fx) * r[0], r[2] / kz])
        xs = (np.arange(width) + 0.5 - cx / kz) / fx
        ys = (np.arange(height) + 0.5 - cy / kz) / fy
        return cls(-(r.T @ t), axes, xs, ys, normalize=False)

    @property
    def width(self):
        """int: the image's width in pixels (columns)."""
        return len(self.xs)

    @property
    def height(self):
        """int: the image's height in pixels (rows)."""
        return len(self.ys)

    @property
    def shape(self):
        """tuple of int: ``(height, width)``, the leading shape of the rays and of a cast's
        results."""
        return (self.height, self.width)

    @property
    def n_rays(self):
        """int: ``height * width``."""
        return self.height * self.width

    def rays(self, dtype=np.float32):
        """Return the camera's rays, one per pixel, in image layout.

        Parameters
        ----------
        dtype : {numpy.float32, numpy.float64}, optional
            Float type of the arrays. Float64 directions are computed in float64; float32
            ones by the module's float32 recipe (the camera's numbers rounded once, then
            each operation rounded in float32), the rays a GPU cast of ``camera=`` makes in
            its kernel, bit for bit.

        Returns
        -------
        origins : numpy.ndarray
            ``(height, width, 3)``, every ray's origin the :attr:`eye`: a read-only
            broadcast of one ``(3,)`` array (no memory per ray; ``np.array(origins)``
            copies it).
        directions : numpy.ndarray
            ``(height, width, 3)``, C-contiguous: ``directions[i, j]`` goes through row
            ``i`` (row 0 at the top) and column ``j`` (column 0 at the left); unit length
            when :attr:`normalize` is set.
        """
        dtype = np.dtype(dtype)
        if dtype not in (np.float32, np.float64):
            raise ValueError(f"dtype must be float32 or float64, got {dtype}")
        origins = np.broadcast_to(self.eye.astype(dtype), self.shape + (3,))
        if dtype == np.float32:
            from . import _native

            directions = _native.camera_directions(*self.float32_numbers())
            return origins, directions
        right, vertical, forward = self.axes
        dirs = (
            forward[None, None, :]
            + self.xs[None, :, None] * right[None, None, :]
            + self.ys[:, None, None] * vertical[None, None, :]
        ).reshape(-1, 3)
        if self.normalize:
            dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
        directions = dirs.reshape(self.shape + (3,))
        return origins, directions

    def float32_numbers(self):
        """Return the numbers float32 rays are made from: ``(axes, xs, ys, normalize)``,
        each array rounded once to float32 (C-contiguous).

        Returns
        -------
        tuple
            ``(3, 3)``, ``(width,)`` and ``(height,)`` float32 arrays, and the bool
            :attr:`normalize`.
        """
        f32 = lambda a: np.ascontiguousarray(a, dtype=np.float32)  # noqa: E731
        return f32(self.axes), f32(self.xs), f32(self.ys), self.normalize

    def __repr__(self):
        return (
            f"Camera(width={self.width}, height={self.height}, eye={self.eye.tolist()}, "
            f"forward={self.axes[2].tolist()}, normalize={self.normalize})"
        )
