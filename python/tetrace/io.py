"""Reading triangle scenes: the caller's triangles, validated, numbered as given.

Everything that takes a mesh (:func:`tetrace.mesh.tetrahedralize`, :meth:`tetrace.Scene.from_mesh`,
:func:`tetrace.baselines.embree.embree_scene`) reads it with :func:`load_triangles`, so they all
number triangles alike. trimesh is imported only to read a file.
"""

from __future__ import annotations

import codecs
import os
import sys
from pathlib import Path

import numpy as np

from .errors import MeshFileNotFoundError, MeshingError

__all__ = [
    "load_triangles",
    "weld",
    "is_trimesh_scene",
    "trimesh_scene_meshes",
    "unreadable_reason",
]


def _mesh_name(mesh) -> str:
    """Name a mesh argument in messages."""
    if isinstance(mesh, (str, os.PathLike)):
        return Path(mesh).name
    return "the mesh"


def is_trimesh_scene(mesh) -> bool:
    """Whether ``mesh`` is a ``trimesh.Scene`` (what ``trimesh.load`` returns for a file of
    several objects). Checked without importing trimesh: a caller holding a scene has
    imported it."""
    trimesh = sys.modules.get("trimesh")
    return trimesh is not None and isinstance(mesh, trimesh.Scene)


def trimesh_scene_meshes(scene) -> dict:
    """The triangle meshes of a ``trimesh.Scene``, placed where the scene puts them.

    Parameters
    ----------
    scene : trimesh.Scene

    Returns
    -------
    dict of str to trimesh.Trimesh
        One mesh per scene node that holds one (a geometry placed twice is two meshes),
        keyed by node name, in ``scene.dump()``'s order, each with its node's transform
        applied (trimesh reverses the faces' winding where a transform mirrors).
        Concatenated in this order they are ``scene.to_mesh()``, so scene triangle ids
        are those of ``trimesh.load(path, force="mesh")``. Paths, point clouds and meshes
        without faces are left out: they have nothing to hit.

    Raises
    ------
    MeshingError
        The scene holds no triangles.
    """
    import trimesh

    meshes, other = {}, []
    for geometry in scene.dump():
        node = geometry.metadata.get("node", geometry.metadata.get("name"))
        if isinstance(geometry, trimesh.Trimesh) and len(geometry.faces):
            meshes[str(node)] = geometry
        else:
            other.append(f"{node!r} ({type(geometry).__name__})")
    if not meshes:
        raise MeshingError(
            "the trimesh.Scene holds no triangles"
            + (f": only {', '.join(other)}" if other else ": it is empty")
        )
    return meshes


def weld(triangles) -> tuple[np.ndarray, np.ndarray]:
    """Turn a triangle soup into ``(vertices, faces)``, welding identical vertices.

    Parameters
    ----------
    triangles : array_like
        ``(F, 3, 3)``: triangle, corner, coordinate.

    Returns
    -------
    vertices : numpy.ndarray
        ``(V, 3)`` float64, the distinct corners in order of first occurrence. Corners
        weld only when their coordinates are exactly equal (``-0.0`` equals ``0.0``):
        no tolerance, so no triangle changes shape.
    faces : numpy.ndarray
        ``(F, 3)`` int64; face ``i`` is triangle ``i`` with its corners in the given
        order (its winding kept).
    """
    p = np.asarray(triangles, dtype=np.float64).reshape(-1, 3) + 0.0
    if len(p) == 0:
        return p, np.zeros((0, 3), np.int64)
    _, first, inverse = np.unique(p, axis=0, return_index=True, return_inverse=True)
    order = np.argsort(first, kind="stable")
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    faces = rank[inverse.reshape(-1)].reshape(-1, 3).astype(np.int64)
    return np.ascontiguousarray(p[first[order]]), np.ascontiguousarray(faces)


def _is_soup(mesh) -> bool:
    """An ``(F, 3, 3)`` array of numbers, or a list of them that is not a pair (a pair is
    ``(vertices, faces)``; pass a soup of two triangles as an array)."""
    if isinstance(mesh, tuple) or (isinstance(mesh, list) and len(mesh) == 2):
        return False
    if not isinstance(mesh, (np.ndarray, list)):
        return False
    try:
        a = np.asarray(mesh)
    except ValueError:  # ragged
        return False
    return a.ndim == 3 and a.shape[1:] == (3, 3) and a.dtype.kind in "biuf"


def load_triangles(mesh) -> tuple[np.ndarray, np.ndarray]:
    """Return the caller's triangles as ``(vertices, faces)`` arrays, validated.

    Nothing is merged or removed, so face indices are the caller's triangle ids.

    Parameters
    ----------
    mesh : trimesh.Trimesh or trimesh.Scene or str or os.PathLike or tuple or numpy.ndarray
        A ``trimesh.Trimesh`` (anything with ``vertices`` and ``faces``), a
        ``trimesh.Scene`` (its meshes placed and concatenated as
        :func:`trimesh_scene_meshes` gives them, numbered as ``scene.to_mesh()``), a file
        loaded with ``trimesh.load(path, force="mesh")`` (trimesh's default
        processing, so that every caster numbers triangles alike), a
        ``(vertices (V, 3), faces (F, 3))`` tuple, or a triangle soup: an
        ``(F, 3, 3)`` array whose identical corners are welded exactly
        (:func:`weld`); triangle ``i`` of the soup is face ``i``.

    Returns
    -------
    vertices : numpy.ndarray
        ``(V, 3)`` float64, C-contiguous.
    faces : numpy.ndarray
        ``(F, 3)`` int64.

    Raises
    ------
    MeshFileNotFoundError
        The path does not exist (also a ``FileNotFoundError``).
    MeshingError
        The file cannot be loaded or holds no triangles (the message names the
        file and trimesh's complaint); the mesh has no faces; vertices have
        non-finite coordinates or coordinates beyond :data:`MAX_COORDINATE`;
        face indices are negative or out of range;
        arrays have the wrong shape.
    TypeError
        ``mesh`` is of an unsupported type, faces are not integers, or vertices
        are not real numbers.
    """
    if isinstance(mesh, (str, os.PathLike)):
        path = Path(mesh)
        if path.is_dir():
            raise MeshingError(f"{path} is a directory, not a mesh file")
        if not path.is_file():
            # A relative path is looked up from the working directory: name it, since
            # that is where a newcomer's path usually goes wrong.
            where = "" if path.is_absolute() else f" (relative to {Path.cwd()})"
            raise MeshFileNotFoundError(f"mesh file not found: {path}{where}", path)
        import trimesh

        try:
            mesh = trimesh.load(path, force="mesh")
        except Exception as exc:  # trimesh raises many types for bad files
            # What trimesh raises for a damaged file can name an unrelated cause (a module
            # its text decoder lacks, an unpacking error): say what is wrong with the bytes
            # where they show it, trimesh's own words otherwise.
            why = unreadable_reason(path) or f"{type(exc).__name__}: {exc}"
            raise MeshingError(f"could not load mesh file {path}: {why}") from exc
        if not hasattr(mesh, "faces"):
            raise MeshingError(
                f"could not load mesh file {path}: trimesh returned "
                f"{type(mesh).__name__}, not a triangle mesh"
            )
        if len(mesh.faces) == 0:
            why = unreadable_reason(path) or (
                f"trimesh read no triangles from it ({path.stat().st_size} bytes; empty, "
                f"truncated, corrupt or not a {path.suffix or 'mesh'} file)"
            )
            raise MeshingError(f"could not load mesh file {path}: {why}")
        try:
            return _validate(mesh.vertices, mesh.faces)
        except (MeshingError, TypeError) as exc:
            raise type(exc)(f"mesh file {path}: {exc}") from None
    if is_trimesh_scene(mesh):
        # Concatenated here rather than by tetrace.meshes.concatenate, which imports this
        # module; the order and offsets are the same.
        vertices, faces, offset = [], [], 0
        for name, part in trimesh_scene_meshes(mesh).items():
            try:
                v, f = _validate(part.vertices, part.faces)
            except (MeshingError, TypeError) as exc:
                raise type(exc)(f"trimesh.Scene node {name!r}: {exc}") from None
            vertices.append(v)
            faces.append(f + offset)
            offset += len(v)
        return np.concatenate(vertices), np.concatenate(faces)
    if _is_soup(mesh):
        soup = np.asarray(mesh)
        if not np.isfinite(soup).all():
            bad = ~np.isfinite(soup).all(axis=(1, 2))
            raise MeshingError(
                f"{int(bad.sum())} of {len(soup)} triangles of the soup have non-finite "
                f"coordinates (NaN or inf), first triangle {int(np.argmax(bad))}"
            )
        vertices, faces = weld(soup)
    elif hasattr(mesh, "vertices") and hasattr(mesh, "faces"):
        vertices, faces = mesh.vertices, mesh.faces
    elif isinstance(mesh, (tuple, list)) and len(mesh) == 2:
        vertices, faces = mesh
    else:
        raise TypeError(
            "mesh must be a trimesh.Trimesh, a path, a (vertices, faces) tuple, an "
            f"(F, 3, 3) triangle soup or a trimesh.Scene, got {type(mesh).__name__}"
        )

    return _validate(vertices, faces)


#: Bytes of a file :func:`unreadable_reason` reads: enough to tell text from binary data.
_SNIFF_BYTES = 1 << 16
#: Formats trimesh reads as text (an STL may be either: its bytes decide).
_TEXT_SUFFIXES = (".obj", ".off", ".stl")


def _binary_stl_reason(size: int, head: bytes) -> str | None:
    """Why a binary STL of ``size`` bytes starting with ``head`` cannot be whole: its length
    must be the 80-byte header, a uint32 triangle count and 50 bytes per triangle."""
    if size < 84:
        return f"truncated binary STL: {size} bytes, shorter than its 84-byte header"
    count = int(np.frombuffer(head[80:84], "<u4")[0])
    expected = 84 + 50 * count
    if size == expected:
        return None
    return (
        f"truncated or corrupt binary STL: its header announces {count:,} triangles "
        f"(84 + 50 x {count:,} = {expected:,} bytes), but the file has {size:,} bytes"
    )


def unreadable_reason(path) -> str | None:
    """Say why a mesh file trimesh could not read, or read no triangles from, is unreadable.

    Only what the file's bytes show: it is empty; a binary STL whose length disagrees with
    its triangle count; an OBJ, OFF or ASCII STL (text formats) that is binary data, or
    text that is not UTF-8 when trimesh cannot read other encodings. trimesh's own
    complaint about such files names its internals (``No module named
    'charset_normalizer'``, a failed unpacking), not the file.

    Parameters
    ----------
    path : str or os.PathLike

    Returns
    -------
    str or None
        A sentence (without the file's name), or None when the bytes show nothing wrong.
    """
    path = Path(path)
    try:
        size = path.stat().st_size
        with open(path, "rb") as fh:
            head = fh.read(_SNIFF_BYTES)
    except OSError as exc:
        return f"it cannot be read ({exc.strerror or exc})"
    if size == 0:
        return "the file is empty (0 bytes)"
    suffix = path.suffix.lower()
    if suffix not in _TEXT_SUFFIXES:
        return None
    # Control characters other than whitespace do not occur in text meshes.
    control = sum(1 for b in head if (b < 32 and b not in b"\t\n\r\f\v") or b == 127)
    if suffix == ".stl" and not (head[:5].lower() == b"solid" and control == 0):
        return _binary_stl_reason(size, head)
    # A prefix may end inside a multi-byte character: the incremental decoder waits for it.
    try:
        codecs.getincrementaldecoder("utf-8")().decode(head, final=size <= len(head))
    except UnicodeDecodeError as exc:
        at = f"byte 0x{head[exc.start]:02x} at offset {exc.start}"
        if control:
            return (
                f"it is binary data, not {suffix[1:].upper()} text: it is not UTF-8 ({at}) "
                f"and {control:,} of its first {len(head):,} bytes are control characters"
            )
        try:
            import charset_normalizer  # noqa: F401
        except ImportError:
            return (
                f"it is not UTF-8 text ({at}); trimesh reads text in other encodings only "
                f"with the charset-normalizer package, which is not installed "
                f"(pip install charset-normalizer)"
            )
        return None
    if control:
        return (
            f"it is not {suffix[1:].upper()} text: {control:,} of its first {len(head):,} "
            f"bytes are control characters"
        )
    return None


#: Largest coordinate magnitude accepted: exact orientation tests multiply three coordinate
#: differences, which must not overflow float64 (``(2e100)**3`` does not).
MAX_COORDINATE = 1e100


def beyond_max_coordinate(rows: np.ndarray, nouns: str, noun: str) -> str | None:
    """Where ``(N, 3)`` float64 ``rows`` have a coordinate beyond :data:`MAX_COORDINATE`,
    how many and the first ("3 of 4 vertices have coordinates beyond +-1e+100, first at
    vertex 1 [...]"); None where none has."""
    big = (np.abs(rows) > MAX_COORDINATE).any(axis=1)
    if not big.any():
        return None
    i = int(np.argmax(big))
    return (
        f"{int(big.sum())} of {len(rows)} {nouns} have coordinates beyond "
        f"+-{MAX_COORDINATE:g}, first at {noun} {i} {rows[i].tolist()}"
    )


def _validate(vertices, faces) -> tuple[np.ndarray, np.ndarray]:
    """Check ``(vertices, faces)`` arrays (see :func:`load_triangles`) and convert them."""
    vertices = np.asarray(vertices)
    faces = np.asarray(faces)
    if vertices.dtype.kind not in "biuf":
        raise TypeError(f"vertices must be real numbers, got dtype {vertices.dtype}")
    if faces.size == 0:
        raise MeshingError(f"empty mesh: it has no faces (faces shape {faces.shape})")
    if faces.dtype.kind not in "iu":
        raise TypeError(f"faces must be integers (vertex indices), got dtype {faces.dtype}")
    if vertices.ndim != 2 or vertices.shape[1] != 3:
        raise MeshingError(f"vertices must have shape (V, 3), got {vertices.shape}")
    if faces.ndim != 2 or faces.shape[1] != 3:
        raise MeshingError(f"faces must have shape (F, 3) (triangles only), got {faces.shape}")
    vertices = np.ascontiguousarray(vertices, dtype=np.float64)
    bad = ~np.isfinite(vertices).all(axis=1)
    if bad.any():
        raise MeshingError(
            f"{int(bad.sum())} of {len(vertices)} vertices have non-finite "
            f"coordinates (NaN or inf), first at vertex {int(np.argmax(bad))}"
        )
    big = beyond_max_coordinate(vertices, "vertices", "vertex")
    if big:
        raise MeshingError(
            f"{big}: exact orientation tests multiply three coordinates, which would "
            f"overflow float64; rescale the mesh"
        )
    # Compare before converting: a huge uint64 would wrap to a negative int64.
    if faces.dtype.kind == "i" and faces.min() < 0:
        n = int((faces < 0).any(axis=1).sum())
        raise MeshingError(f"{n} faces have negative vertex indices (smallest {int(faces.min())})")
    if faces.max() >= len(vertices):
        n = int((faces >= len(vertices)).any(axis=1).sum())
        raise MeshingError(
            f"{n} faces have vertex indices out of range: largest index "
            f"{int(faces.max())}, but there are {len(vertices)} vertices"
        )
    return vertices, np.ascontiguousarray(faces, dtype=np.int64)
