"""Saving and loading scenes (:meth:`tetrace.Scene.to_bytes`, :meth:`~tetrace.Scene.from_bytes`
and the methods built on them): what of a scene is written, and how a scene is rebuilt from
it. :mod:`tetrace.scenefile` is the file format; ``docs/save_format.md`` describes both.

Loaded on a scene's first save or load. The functions take the scene (or its class) as an
argument: this module does not import :mod:`tetrace.scene`.
"""

from __future__ import annotations

import dataclasses
import inspect

import numpy as np

from . import _native, scenefile
from .deform import Deformation, set_vertices
from .errors import SceneFileError

__all__ = ["to_bytes", "from_bytes", "restore", "tz_fields", "tz_from_fields"]


def to_bytes(scene):
    """The body of :meth:`tetrace.Scene.to_bytes` (which documents it)."""
    arrays, seen = {}, {}

    def enc(value, path):
        return scenefile.encode(value, arrays, path, seen)

    # A scene whose tetrahedralization is not built yet is saved without one (format
    # version 2): saving or pickling a lazy scene must not mesh it (minutes on big scenes,
    # and a dask worker that only casts never needs it). Loading gives a lazy scene again.
    tz = scene._tet
    rest_tz, rest_vertices = scene._rest or (tz, scene.vertices)
    structures = {}
    for name, info, build in (
        ("bvh", scene.bvh_info(), scene.build_bvh),
        ("octree", scene.octree_info(), scene.build_octree),
        ("exact_bvh", scene.exact_bvh_info(), scene.build_exact_bvh),
    ):
        if info is not None:
            structures[name] = {k: info[k] for k in inspect.signature(build).parameters}
    geometries = scene.geometries
    meta = dict(
        kind="tetrace.Scene",
        hilbert=scene.hilbert,
        tetrahedralization=None if tz is None else enc(tz_fields(tz), "tz"),
        mesh_name=scene._mesh_name,
        vertices=enc(np.asarray(scene.vertices), "vertices"),
        faces=enc(np.asarray(scene.faces), "faces"),
        moved=scene._rest is not None,
        rest_tetrahedralization=None if rest_tz is None else enc(tz_fields(rest_tz), "rest_tz"),
        rest_vertices=enc(np.asarray(rest_vertices), "rest_vertices"),
        geometries=None
        if geometries is None
        else enc(
            (geometries.triangle_offsets, geometries.vertex_offsets, geometries.names),
            "geometries",
        ),
        build_options=enc(scene._build_options, "build_options"),
        build_times=enc(scene.build_times, "build_times"),
        frames=scene._frames,
        last_deformation=enc(scene.last_deformation, "last_deformation"),
        structures=structures,
    )
    return scenefile.pack(
        arrays, meta, package_version=_native.__version__, version=1 if tz is not None else 2
    )


def from_bytes(cls, data, source):
    """The body of :meth:`tetrace.Scene.from_bytes` (which documents it): a ``cls``."""
    arrays, meta, _ = scenefile.unpack(data, source=source)
    # Loaded arrays are views of ``data``: copy them (writable, independent of it) once.
    arrays = {k: np.array(v) for k, v in arrays.items()}
    try:
        return restore(cls, arrays, meta, source)
    except SceneFileError:
        raise
    except (KeyError, TypeError, ValueError, IndexError, AttributeError) as exc:
        # A header whose checksum holds but whose content is not a scene (written by
        # something else), or arrays the core rejects (tetrace.MeshError).
        raise SceneFileError(f"{source}: not a valid scene ({type(exc).__name__}: {exc})") from exc


def restore(cls, arrays, meta, source):
    """The ``cls`` scene :func:`to_bytes` described by ``meta`` over ``arrays``."""
    if not isinstance(meta, dict) or meta.get("kind") != "tetrace.Scene":
        kind = meta.get("kind") if isinstance(meta, dict) else type(meta).__name__
        raise ValueError(f"holds {kind!r}, not a tetrace.Scene")
    dec = lambda key: scenefile.decode(meta[key], arrays)  # noqa: E731
    vertices, faces = dec("vertices"), dec("faces")
    moved = bool(meta["moved"])
    if meta["tetrahedralization"] is None:
        if moved:
            raise ValueError("a moved scene saved without its tetrahedralization")
        # Saved before its tetrahedralization was built: the same lazy scene (the domain
        # box comes from the options it was made with, so every answer is the same).
        scene = cls._without_ct(
            vertices, faces, dec("build_options"), bool(meta["hilbert"]), meta.get("mesh_name")
        )
        return restore_state(scene, meta, dec)
    tz = tz_from_fields(dec("tetrahedralization"))
    rest_tz, rest_vertices = tz, vertices
    if moved:
        rest_tz, rest_vertices = (
            tz_from_fields(dec("rest_tetrahedralization")),
            dec("rest_vertices"),
        )
    scene = cls(rest_tz, rest_vertices, faces, hilbert=bool(meta["hilbert"]))
    if moved:
        tri = np.asarray(vertices)[np.asarray(faces)]
        applied, inverted, outside = scene._native.update_points(
            np.ascontiguousarray(tz.points, dtype=np.float64),
            np.ascontiguousarray(tri, dtype=np.float64),
        )
        if not applied:
            raise SceneFileError(
                f"{source}: the saved positions are not a valid move of the saved "
                f"tetrahedralization ({inverted} tets inverted, {outside} points outside)"
            )
        scene.tetrahedralization, scene._rest = tz, (rest_tz, rest_vertices)
        set_vertices(scene, vertices)
    scene._mesh_name = meta.get("mesh_name")
    return restore_state(scene, meta, dec)


def restore_state(scene, meta, dec):
    """``scene`` given the saved state every scene has (with or without its
    tetrahedralization): geometries, options, timings, deformation record, structures."""
    geometries = dec("geometries")
    if geometries is not None:
        from .meshes import Geometries

        scene.geometries = Geometries(*geometries)
    scene._build_options = dec("build_options")
    scene.build_times = dec("build_times")
    scene._frames = int(meta["frames"])
    last = dec("last_deformation")
    scene.last_deformation = None if last is None else Deformation(**last)
    structures = meta["structures"]
    for name, build in (
        ("bvh", scene.build_bvh),
        ("octree", scene.build_octree),
        ("exact_bvh", scene.build_exact_bvh),
    ):
        if name in structures:
            build(**structures[name])
    return scene


def tz_fields(tz):
    """A tetrahedralization's fields to save (its cached weight is recomputed)."""
    fields = {f.name: getattr(tz, f.name) for f in dataclasses.fields(tz) if f.init}
    fields.pop("_weight", None)
    fields["clean"] = {f.name: getattr(tz.clean, f.name) for f in dataclasses.fields(tz.clean)}
    return fields


def tz_from_fields(fields):
    from .mesh.types import CleanMesh, Tetrahedralization

    fields = dict(fields)
    fields["clean"] = CleanMesh(**fields["clean"])
    return Tetrahedralization(**fields)
