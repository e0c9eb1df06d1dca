"""Triangle scene -> constrained tetrahedralization (CT), the input of the ray caster.

Two meshers, pure Python around their wrappers:

* **TetGen** (the ``tetgen`` wrapper), the exact route: every scene triangle is a
  union of tet faces, bit for bit. Presets name its settings (:data:`PRESETS`).
* **fTetWild** (the ``pytetwild`` wrapper), the approximate route for scenes
  TetGen cannot take: it remeshes the scene surface within an envelope of
  ``epsilon`` (relative to the scene's diagonal) and tetrahedralizes the box
  around it. The constrained faces are the tet faces lying on the remeshed
  surface, each mapped to the nearest caller triangle; how far that surface is
  from the input is measured and reported (:attr:`Tetrahedralization.surface_distance`).

``mesher="fallback"`` tries TetGen and uses fTetWild when it fails, recording why.

The TetGen route:

1. :func:`load_triangles` takes the caller's triangles as given (their face
   indices are the triangle ids that hits report).
2. :func:`clean` merges coincident vertices and drops zero-area and duplicate
   triangles, which TetGen rejects or mishandles, keeping a map back to the
   caller's ids.
3. The scene plus a box around it (:func:`domain_box`) form a piecewise linear
   complex (PLC); TetGen builds a CT of the box in which every scene triangle
   is a union of tet faces. Scene triangles carry marker ``id + 1`` and box
   faces ``-1``, so the constrained faces TetGen outputs (pieces of input
   triangles, split wherever it inserted Steiner points) name their triangle.
4. Before TetGen runs, the cleaned scene is checked for self-intersections
   (triangles crossing, touching or overlapping other triangles' interiors:
   not a PLC). With ``repair="auto"`` they are cut with
   ``igl.copyleft.cgal.remesh_self_intersections`` in exact arithmetic; each
   piece keeps its original triangle id, and the result is cleaned again.
   The check comes first because TetGen's own failure on such input can
   corrupt the heap of the process it runs in.
5. If TetGen fails on that, the scene is *snap-rounded*: vertices are rounded
   to a grid of cell 2^k close to 1e-7 (then 1e-6) of the diagonal, which
   merges the nearly coincident points that exact cutting leaves behind, the
   intersections this creates are cut again, and so on until none is left;
   TetGen then runs without its final mesh optimisation (the step that fails
   on such scenes). See :data:`SNAP_LADDER`.
6. TetGen, the repair and fTetWild run in forked child processes on Linux
   (:data:`ISOLATE_TETGEN`), so that a crash becomes a :class:`MeshingError`,
   under a time limit that grows with the scene (:func:`default_timeout`); a
   timeout or crash names the stage and, for TetGen, the phase it was in.

Only numpy is imported at module level; trimesh, tetgen, igl and pytetwild are
imported when needed, so this module loads without the compiled extension.
"""

from __future__ import annotations

import time

import numpy as np

from ..errors import MeshFileNotFoundError, MeshingError
from ..io import _mesh_name, load_triangles
from ..progress import stage, with_progress
from .auto import DEFAULT_ACCURACY, auto_tetrahedralize
from .clean import clean, describe_degenerate, domain_box
from .ftetwild import _ftetwild_route, ftetwild_available, neighbour_triangles
from .options import (
    DEFAULT_PRESET,
    FTETWILD_EDGE_LENGTH,
    FTETWILD_EPSILON,
    MESHERS,
    PRESETS,
    SNAP_LADDER,
    default_timeout,
    preset_options,
)
from .repair import count_intersecting_pairs
from .tetgen import _check_sizing, _tetgen_route, tetgen_options
from .types import CleanMesh, Tetrahedralization

__all__ = [
    "MeshingError",
    "MeshFileNotFoundError",
    "CleanMesh",
    "Tetrahedralization",
    "PRESETS",
    "DEFAULT_PRESET",
    "MESHERS",
    "SNAP_LADDER",
    "load_triangles",
    "clean",
    "domain_box",
    "tetrahedralize",
    "tetgen_options",
    "preset_options",
    "default_timeout",
    "count_intersecting_pairs",
    "ftetwild_available",
    "neighbour_triangles",
]


# --------------------------------------------------------------------------- entry point


@with_progress
def tetrahedralize(
    mesh,
    preset=DEFAULT_PRESET,
    *,
    mesher="tetgen",
    margin=0.02,
    contain=None,
    minratio=None,
    maxvolume=None,
    sizing=None,
    repair="auto",
    epsilon=FTETWILD_EPSILON,
    edge_length=FTETWILD_EDGE_LENGTH,
    ftetwild_optimize=False,
    timeout=None,
    threads=0,
    stop_energy=10.0,
    accuracy=None,
    measure=None,
    name=None,
    progress=None,
) -> Tetrahedralization:
    """Build a constrained tetrahedralization of a triangle scene inside a box.

    Parameters
    ----------
    mesh : trimesh.Trimesh or str or os.PathLike or tuple
        Anything :func:`load_triangles` takes. Open, non-manifold and
        multi-component scenes are fine; self-intersecting ones are repaired
        (see ``repair``).
    preset : str
        TetGen settings: a key of :data:`PRESETS` (``"constrained"``,
        ``"quality"``, ``"quality3"``, ``"quality2"``, ``"quality1.5"``,
        ``"graded"``) or ``"quality<r>"`` for a radius-edge bound r > 1.
    mesher : {"tetgen", "ftetwild", "fallback", "auto"}
        ``"tetgen"``: exact; the constrained faces are pieces of the caller's
        triangles. ``"ftetwild"``: fTetWild remeshes the surface within
        ``epsilon`` and keeps the whole box around it; the constrained faces
        lie within ``epsilon`` of the input and name the nearest triangle.
        ``"fallback"``: TetGen, then, if every rung of the snap ladder fails,
        TetGen's ``"constrained"`` preset on the first snap-rounded scene (when
        the preset refines), then fTetWild; the reasons go to ``attempts`` and
        ``preset`` says which preset built it. ``"auto"``: build candidate settings
        and keep the one with the fewest tets among those that meet ``accuracy``
        with a weight (:meth:`Tetrahedralization.weight`) near the lowest; ``preset``
        and the TetGen/fTetWild settings are then chosen, not given
        (:func:`tetrace.mesh.auto.auto_tetrahedralize`).
    margin : float
        Domain box margin, a fraction of the scene's bounding-box diagonal
        (TetGen; fTetWild's box is the scene's grown by about one edge length).
    contain : array_like, optional
        ``(N, 3)`` points the domain box must contain.
    minratio : float, optional
        TetGen radius-edge bound (``-q``), overriding the preset's; it turns on
        refinement for ``"constrained"`` too.
    maxvolume : float, optional
        Maximum tet volume (TetGen ``-a``), in scene units cubed; TetGen's mesh
        optimisation after refinement can exceed it slightly.
    sizing : (float, float), optional
        ``(h0, growth)``: TetGen refines until edges near a point at distance d
        from the surface are no longer than about ``h0 * diagonal + growth * d``
        (the preset's, e.g. ``"graded"``, when None). Needs libigl.
    repair : {"auto", True, False}
        ``"auto"``: check the cleaned scene for self-intersections (exactly,
        with libigl/CGAL) and cut them if there are any; if TetGen still fails,
        snap-round and repair again (:data:`SNAP_LADDER`). ``True``: always run
        the cutting step. ``False``: never; a self-intersecting scene raises.
        The check runs before TetGen because TetGen's failure on such input
        can corrupt the process heap. Without libigl nothing is checked and a
        scene TetGen rejects raises.
    epsilon, edge_length : float
        fTetWild's envelope and target edge length, fractions of the scene's
        diagonal.
    timeout : float, optional
        Seconds each stage (a repair, a TetGen attempt, fTetWild) may run; by
        default :func:`default_timeout` of the scene's size. A stage that runs
        longer is stopped and counts as failed.
    ftetwild_optimize : bool
        Run fTetWild's mesh optimisation (edge collapses, swaps, smoothing towards
        better-shaped tets). Off by default: on spot it took 11 s instead of 0.3 s
        and merged surface pieces of different triangles, so that 78% of camera
        rays named Embree's triangle instead of 98%.
    threads : int
        fTetWild threads (0: all cores).
    stop_energy : float
        fTetWild stops optimising when the worst tet's AMIPS energy is below this.
    accuracy : float, optional
        ``mesher="auto"`` only: the fraction of random rays that must agree with
        Embree on the caller's mesh (default 0.999).
    measure : callable, optional
        ``mesher="auto"`` only: how an inexact candidate's accuracy is measured
        (:meth:`tetrace.Scene.from_mesh` passes
        :func:`tetrace.accuracy.measure_accuracy` with the ``Scene`` class);
        see :func:`tetrace.mesh.auto.auto_tetrahedralize`.
    name : str, optional
        What error messages call the mesh (default: a path's file name, else "the mesh").
    progress : bool, optional
        Show a status line per stage (cleaning, each repair and TetGen attempt, fTetWild)
        with its running time: None (default) when stderr is a terminal or in a Jupyter
        kernel and ``CI`` is not set, or True/False (:mod:`tetrace.progress`).

    Returns
    -------
    Tetrahedralization

    Raises
    ------
    MeshingError
        The mesh is invalid or empty after cleaning, it self-intersects and
        ``repair`` is False, intersections remain after repair, or the mesher
        fails, crashes or times out; the message names the stage and the cause.

    Notes
    -----
    Refinement stops after a budget of Steiner points (see
    :func:`tetgen_options`), so thin or tiny features cannot blow the mesh up;
    the result is then a valid CT, refined only in part. ``timings["repair"]``
    includes the self-intersection check, which runs even when nothing is cut.
    """
    t_start = time.perf_counter()
    if isinstance(repair, (bool, np.bool_)):
        repair = bool(repair)
    elif repair != "auto":
        raise ValueError(f"repair must be 'auto', True or False, got {repair!r}")
    if mesher not in MESHERS:
        raise ValueError(f"mesher must be one of {MESHERS}, got {mesher!r}")
    if mesher == "auto":
        return auto_tetrahedralize(
            mesh,
            build=tetrahedralize,
            measure=measure,
            accuracy=DEFAULT_ACCURACY if accuracy is None else accuracy,
            margin=margin,
            contain=contain,
            timeout=timeout,
        )
    if accuracy is not None:
        raise ValueError("accuracy is a target for mesher='auto'; the other meshers take settings")
    p = preset_options(preset)
    sizing = _check_sizing(sizing if sizing is not None else p["sizing"])
    for what, value in (
        ("epsilon", epsilon),
        ("edge_length", edge_length),
        ("stop_energy", stop_energy),
    ):
        if not (np.isfinite(float(value)) and float(value) > 0):
            raise ValueError(f"{what} must be a positive number, got {value!r}")
    if timeout is not None and not (float(timeout) > 0):
        raise ValueError(f"timeout must be a positive number of seconds, got {timeout!r}")
    name = name or _mesh_name(mesh)
    vertices, faces = load_triangles(mesh)
    timings = dict(
        clean=0.0, repair=0.0, tetgen=0.0, ftetwild=0.0, recover=0.0, mesher=0.0, total=0.0
    )

    t = time.perf_counter()
    with stage(f"clean {name} ({len(faces)} triangles)"):
        cm = clean(vertices, faces)
    timings["clean"] = time.perf_counter() - t
    if len(cm.faces) == 0:
        raise MeshingError(
            f"{name}: all {len(faces)} triangles are degenerate (zero area); nothing to "
            f"mesh: {describe_degenerate(vertices, faces)}"
        )
    # Bounds of every vertex a caller triangle uses, degenerate ones included.
    used = vertices[np.unique(faces)]
    box = domain_box(used, margin=margin, contain=contain)
    diagonal = float(np.linalg.norm(used.max(axis=0) - used.min(axis=0))) or 1.0
    options = tetgen_options(
        preset, minratio=minratio, maxvolume=maxvolume, n_vertices=len(cm.vertices)
    )
    attempts: list[str] = []

    def done(**kw):
        timings["mesher"] = timings["tetgen"] + timings["ftetwild"] + timings["recover"]
        timings["total"] = time.perf_counter() - t_start
        return Tetrahedralization(
            n_input_triangles=len(faces), timings=timings, attempts=attempts, **kw
        )

    if mesher in ("tetgen", "fallback"):
        stage_timeout = timeout if timeout is not None else default_timeout(len(cm.faces), "tetgen")
        try:
            points, tets, cfaces, face_triangle, work, repaired, snap, opts, used = _tetgen_route(
                name,
                cm,
                box,
                options,
                repair=repair,
                sizing=sizing,
                timeout=stage_timeout,
                timings=timings,
                attempts=attempts,
                diagonal=diagonal,
                constrained_last=mesher == "fallback",
                preset_name=preset,
            )
        except MeshingError as exc:
            if mesher == "tetgen":
                raise
            if str(exc) not in attempts:
                attempts.append(str(exc))
        else:
            return done(
                points=points,
                tets=tets,
                faces=cfaces,
                face_triangle=face_triangle,
                domain=box,
                preset=used or preset,
                clean=work,
                repaired=repaired,
                mesher="tetgen",
                snap=snap,
                options=opts,
            )

    stage_timeout = timeout if timeout is not None else default_timeout(len(cm.faces), "ftetwild")
    try:
        points, tets, cfaces, face_triangle, distance, opts = _ftetwild_route(
            name,
            cm,
            box,
            contain=contain,
            epsilon=float(epsilon),
            edge_length=float(edge_length),
            threads=int(threads),
            stop_energy=float(stop_energy),
            optimize=ftetwild_optimize,
            timeout=stage_timeout,
            timings=timings,
        )
    except MeshingError as exc:
        if mesher == "fallback":
            raise MeshingError(
                f"no mesher could mesh {name}: TetGen: {'; '.join(attempts)}; then {exc}"
            ) from None
        raise
    domain = np.array([points.min(axis=0), points.max(axis=0)])
    return done(
        points=points,
        tets=tets,
        faces=cfaces,
        face_triangle=face_triangle,
        domain=domain,
        preset="ftetwild",
        clean=cm,
        repaired=False,
        mesher="ftetwild",
        options=opts,
        surface_distance=distance,
    )
