"""Small synthetic triangle scenes for tests and examples.

Every builder returns ``(vertices, faces)``: ``(V, 3)`` float64 and ``(F, 3)``
int64 numpy arrays, deterministic, with outward-facing triangles where the
surface is closed. Only numpy is needed (trimesh for :func:`nested_spheres`).
"""

from __future__ import annotations

import numpy as np

__all__ = ["box", "cube", "thin_plate", "touching_boxes", "nested_spheres", "torus_knot"]

# Unit cube corners: vertex index = 4x + 2y + z, as in tests/test_reference.py.
_CUBE_FACES = np.array(
    [
        [0, 1, 3],
        [0, 3, 2],  # x = lo
        [4, 6, 7],
        [4, 7, 5],  # x = hi
        [0, 4, 5],
        [0, 5, 1],  # y = lo
        [2, 3, 7],
        [2, 7, 6],  # y = hi
        [0, 2, 6],
        [0, 6, 4],  # z = lo
        [1, 5, 7],
        [1, 7, 3],  # z = hi
    ],
    dtype=np.int64,
)


def box(lo=(0.0, 0.0, 0.0), hi=(1.0, 1.0, 1.0)):
    """An axis-aligned box, 8 vertices and 12 outward triangles.

    Parameters
    ----------
    lo, hi : array_like
        ``(3,)`` lower and upper corners.

    Returns
    -------
    vertices : numpy.ndarray
        ``(8, 3)`` float64; vertex ``4x + 2y + z`` is the corner with
        ``x, y, z`` in {0: lo, 1: hi}.
    faces : numpy.ndarray
        ``(12, 3)`` int64, two triangles per side, in the order x-lo, x-hi,
        y-lo, y-hi, z-lo, z-hi.
    """
    lo = np.asarray(lo, dtype=np.float64)
    hi = np.asarray(hi, dtype=np.float64)
    bits = np.array([[i >> 2 & 1, i >> 1 & 1, i & 1] for i in range(8)], dtype=bool)
    vertices = np.where(bits, hi, lo)
    return vertices, _CUBE_FACES.copy()


def cube(size=1.0):
    """The cube ``[0, size]^3`` (see :func:`box` for the numbering).

    Parameters
    ----------
    size : float
        Edge length.

    Returns
    -------
    vertices, faces : numpy.ndarray
        ``(8, 3)`` float64 and ``(12, 3)`` int64.
    """
    return box((0.0, 0.0, 0.0), (size, size, size))


def thin_plate(width=1.0, thickness=1e-3):
    """A square plate ``[0, width]^2 x [0, thickness]``: two large faces very close together.

    Parameters
    ----------
    width : float
        Side of the square, along x and y.
    thickness : float
        Extent along z (default one thousandth of ``width``).

    Returns
    -------
    vertices, faces : numpy.ndarray
        ``(8, 3)`` float64 and ``(12, 3)`` int64.
    """
    return box((0.0, 0.0, 0.0), (width, width, thickness))


def touching_boxes(offset=0.25):
    """Two unit boxes side by side whose facing sides overlap in part.

    Box A is ``[0, 1]^3``; box B is ``[1, 2] x [offset, 1 + offset]^2``, so
    A's side ``x = 1`` and B's side ``x = 1`` are coplanar and overlap on
    ``[offset, 1]^2`` with their triangle edges crossing. This is not a valid
    PLC as given (faces overlap other faces' interiors); it needs repair.

    Parameters
    ----------
    offset : float
        Shift of box B along y and z, in (0, 1) for a partial overlap.

    Returns
    -------
    vertices, faces : numpy.ndarray
        ``(16, 3)`` float64 and ``(24, 3)`` int64; faces 0-11 are box A
        (faces 2, 3 its side x = 1), 12-23 box B (faces 12, 13 its side x = 1).
    """
    va, fa = box((0.0, 0.0, 0.0), (1.0, 1.0, 1.0))
    vb, fb = box((1.0, offset, offset), (2.0, 1.0 + offset, 1.0 + offset))
    return np.vstack([va, vb]), np.vstack([fa, fb + len(va)])


def nested_spheres(radii=(1.0, 0.5), subdivisions=3):
    """Concentric icospheres, one inside the other (two disjoint components).

    Parameters
    ----------
    radii : sequence of float
        Radii, outermost first.
    subdivisions : int
        Icosphere subdivision level (``20 * 4**subdivisions`` triangles each).

    Returns
    -------
    vertices, faces : numpy.ndarray
        float64 and int64; the faces of sphere ``k`` follow those of sphere ``k - 1``.
    """
    import trimesh

    vertices, faces, offset = [], [], 0
    for r in radii:
        s = trimesh.creation.icosphere(subdivisions=subdivisions, radius=float(r))
        vertices.append(np.asarray(s.vertices, dtype=np.float64))
        faces.append(np.asarray(s.faces, dtype=np.int64) + offset)
        offset += len(s.vertices)
    return np.vstack(vertices), np.vstack(faces)


def torus_knot(p=2, q=3, major=2.0, minor=1.0, tube=0.25, segments=240, sides=12):
    """A closed tube around a ``(p, q)`` torus knot (the trefoil by default).

    The centre line is ``((major + minor cos(q t)) cos(p t), (major + minor
    cos(q t)) sin(p t), minor sin(q t))``; the tube is a ring of ``sides``
    vertices at each of ``segments`` samples, stitched into a watertight,
    outward-facing surface of ``2 * segments * sides`` triangles. The defaults
    keep the tube clear of itself.

    Parameters
    ----------
    p, q : int
        Winding numbers (coprime).
    major, minor : float
        Radii of the torus the knot lies on (``major > minor``).
    tube : float
        Tube radius.
    segments, sides : int
        Samples along the knot and around the tube.

    Returns
    -------
    vertices, faces : numpy.ndarray
        ``(segments * sides, 3)`` float64 and ``(2 * segments * sides, 3)`` int64.
    """
    t = np.linspace(0.0, 2.0 * np.pi, segments, endpoint=False)
    ring = major + minor * np.cos(q * t)
    centre = np.stack([ring * np.cos(p * t), ring * np.sin(p * t), minor * np.sin(q * t)], axis=1)
    # Analytic tangent. Its xy part never vanishes (major > minor), so crossing it with
    # +z gives a smooth normal without the flips of a Frenet frame.
    dring = -minor * q * np.sin(q * t)
    tangent = np.stack(
        [
            dring * np.cos(p * t) - ring * p * np.sin(p * t),
            dring * np.sin(p * t) + ring * p * np.cos(p * t),
            minor * q * np.cos(q * t),
        ],
        axis=1,
    )
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    normal = np.cross(tangent, [0.0, 0.0, 1.0])
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    binormal = np.cross(tangent, normal)
    a = np.linspace(0.0, 2.0 * np.pi, sides, endpoint=False)
    vertices = (
        centre[:, None, :]
        + tube
        * (
            np.cos(a)[None, :, None] * normal[:, None, :]
            + np.sin(a)[None, :, None] * binormal[:, None, :]
        )
    ).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(segments), np.arange(sides), indexing="ij")
    i1, j1 = (i + 1) % segments, (j + 1) % sides
    v00, v01 = i * sides + j, i * sides + j1
    v10, v11 = i1 * sides + j, i1 * sides + j1
    faces = np.concatenate(
        [np.stack([v00, v10, v11], -1).reshape(-1, 3), np.stack([v00, v11, v01], -1).reshape(-1, 3)]
    ).astype(np.int64)
    # Orient outward: the signed volume (divergence theorem) must be positive.
    tri = vertices[faces]
    if np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])).sum() < 0:
        faces = faces[:, ::-1].copy()
    return vertices, faces
