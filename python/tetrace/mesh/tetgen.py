"""TetGen: options, the sizing field, one run, and the route through repair and snap rounding."""

from __future__ import annotations

import time

import numpy as np

from ..errors import MeshingError
from ..progress import stage
from .clean import _box_mesh, describe_degenerate, needles
from .isolate import ISOLATE_TETGEN, _run_stage, _stage_message, _TetGenCrashed, _TetGenFailed
from .options import (
    _COMMON,
    _LOOSE_RATIO,
    _STEINER_MIN,
    _STEINER_PER_VERTEX,
    DEFAULT_PRESET,
    SNAP_LADDER,
    SPLIT_FALLBACK,
    preset_options,
)
from .repair import _igl_cgal, _repair, _repair_left_message, _snap_cell, count_intersecting_pairs
from .types import CleanMesh

# --------------------------------------------------------------------------- TetGen


def _tetgen_arrays(points_in, faces_in, markers, options, log=False):
    """Run TetGen; return ``(points, tets, scene_faces, scene_markers)``.

    ``log``: stdout is a log file (a forked child): let TetGen print its phase headers
    there (verbose=0: headers only), so that a timeout or crash can name the phase.
    """
    import tetgen

    options = dict(options)
    if log:
        options.update(quiet=False)
    tg = tetgen.TetGen(points_in, faces_in, markers)
    try:
        nodes, elems, _, _ = tg.tetrahedralize(**options)
    except (RuntimeError, ValueError, MemoryError) as exc:
        raise _TetGenFailed(str(exc).strip() or type(exc).__name__) from exc
    if len(elems) == 0:
        raise _TetGenFailed("TetGen produced no tetrahedra")
    # Without facesout TetGen outputs only boundary faces: the box pieces (-1) and the
    # constrained scene pieces (their marker), never the unmarked interior faces.
    marks = np.asarray(tg.triface_markers).reshape(-1)
    keep = marks > 0
    return (
        np.ascontiguousarray(nodes, dtype=np.float64),
        np.ascontiguousarray(elems, dtype=np.uint32),
        np.ascontiguousarray(np.asarray(tg.trifaces).reshape(-1, 3)[keep], dtype=np.uint32),
        marks[keep].astype(np.int64),
    )


#: Most points a sizing field may add (see :func:`_sizing_points`).
SIZING_MAX_POINTS = 2_000_000


def _sizing_points(box, vertices, faces, h0, growth):
    """Points that make TetGen's tets grow away from the surface: ``(N, 3)``.

    An octree over the domain box: a cell of side s is split while the target edge
    length ``h0 + growth * d`` at its centre (d: distance to the surface) is below s;
    each leaf contributes its centre unless the cell may touch the surface (d < s) or
    sticks out of the box. TetGen inserts them as isolated vertices, and its quality
    refinement fills in around them, so tets near a point at distance d have edges of
    about ``h0 + growth * d``. (TetGen's own sizing, ``-m`` with a background mesh,
    crashed on a torus knot, whichever background mesh it was given.)
    """
    import igl

    lo, hi = np.asarray(box[0], np.float64), np.asarray(box[1], np.float64)
    ext = hi - lo
    s = float(ext.min())
    counts = np.maximum(np.ceil(ext / s).astype(int), 1)
    grid = np.stack(np.meshgrid(*(np.arange(n) for n in counts), indexing="ij"), -1).reshape(-1, 3)
    centres = lo + (grid + 0.5) * s
    offsets = np.array([[(i >> 2 & 1), (i >> 1 & 1), i & 1] for i in range(8)], float) - 0.5
    v = np.ascontiguousarray(vertices, np.float64)
    f = np.ascontiguousarray(faces, np.int64)
    out = []
    total = 0
    while len(centres):
        d2, _, _ = igl.point_mesh_squared_distance(centres, v, f)
        d = np.sqrt(d2)
        leaf = h0 + growth * d >= s
        keep = (
            leaf
            & (d >= s)
            & np.all(centres - s / 2 >= lo, axis=1)
            & np.all(centres + s / 2 <= hi, axis=1)
        )
        out.append((centres[keep], s))
        total += int(keep.sum())
        if total > SIZING_MAX_POINTS:
            raise MeshingError(
                f"the sizing field (h0={h0:.3g}, growth={growth:.3g}) asks for "
                f"more than {SIZING_MAX_POINTS:,} points; raise h0 or growth"
            )
        # Split the rest, unless they are already finer than h0 (the surface's layer).
        split = centres[~leaf & (s / 2 >= h0 / 2)]
        centres = (split[:, None, :] + offsets[None] * (s / 2)).reshape(-1, 3)
        s /= 2
    if not total:
        return np.zeros((0, 3))
    # A jitter (seeded: the same scene gives the same mesh) breaks the grid's
    # degeneracies (cospherical and coplanar points), on which TetGen's boundary
    # recovery stalled for a thin plate. Each point stays in the middle half of its cell.
    rng = np.random.default_rng(0)
    return np.concatenate([c + rng.uniform(-size / 4, size / 4, c.shape) for c, size in out])


def _run_tetgen(
    cm: CleanMesh, box: np.ndarray, options: dict, isolate=None, *, extra=None, timeout=None
):
    """Tetrahedralize scene + box (+ ``extra`` isolated points); return
    ``(points, tets, faces, face_triangle)``."""
    import tetgen  # noqa: F401  (imported here so a forked child finds it loaded)

    corners, box_faces = _box_mesh(box)
    nv = len(cm.vertices)
    parts = [cm.vertices, corners] + ([extra] if extra is not None and len(extra) else [])
    points_in = np.vstack(parts)
    faces_in = np.vstack([cm.faces, box_faces + nv])
    if len(points_in) >= 2**31 or len(faces_in) >= 2**31 - 1:
        raise MeshingError(
            f"scene too large for TetGen: {len(points_in)} points, {len(faces_in)} faces"
        )
    # Marker id + 1 for scene face id (0 is TetGen's "no marker"), -1 for the box.
    markers = np.concatenate([np.arange(1, len(cm.faces) + 1), np.full(len(box_faces), -1)])
    isolate = ISOLATE_TETGEN if isolate is None else isolate
    args = (points_in, faces_in.astype(np.int32), markers.astype(np.int32), options, isolate)
    points, tets, faces, marks = _run_stage(_tetgen_arrays, *args, timeout=timeout, isolate=isolate)
    face_triangle = np.ascontiguousarray(cm.triangle_ids[marks - 1], dtype=np.uint32)
    return points, tets, faces, face_triangle


def tetgen_options(preset=DEFAULT_PRESET, *, minratio=None, maxvolume=None, n_vertices=0) -> dict:
    """Return the keyword arguments :func:`tetrahedralize` passes to TetGen.

    Parameters
    ----------
    preset : str
        A key of :data:`PRESETS` or ``"quality<r>"`` (see :func:`preset_options`).
    minratio : float, optional
        Radius-edge bound (TetGen ``-q``), > 1; turns refinement on.
    maxvolume : float, optional
        Maximum tet volume (TetGen ``-a``), > 0; turns refinement on.
    n_vertices : int
        Scene vertices, which size the Steiner-point budget of a refinement.

    Returns
    -------
    dict
        Keyword arguments of ``tetgen.TetGen.tetrahedralize``: the preset's,
        the overrides, and ``steinerleft``, the Steiner-point budget. A
        refinement gets ``max(10000, 2 * n_vertices)`` (radius-edge refinement
        grades down to the smallest feature, so a thin plate would otherwise
        take hundreds of thousands of points; the real scenes measured need
        0.4-1.3 per vertex). Without refinement it is unlimited (``-1``): only
        the points boundary recovery cannot do without are added. A preset's
        sizing field is not a TetGen option (see :func:`tetrahedralize`), but it
        turns refinement on.
    """
    p = preset_options(preset)
    options = dict(_COMMON, **p["tetgen"])
    if p["minratio"] is not None:
        options.update(quality=True, minratio=float(p["minratio"]), mindihedral=0.0)
    else:
        options.update(quality=False)
    if minratio is not None:
        minratio = float(minratio)
        if not (np.isfinite(minratio) and minratio > 1.0):
            raise ValueError(f"minratio (TetGen radius-edge bound) must be > 1.0, got {minratio!r}")
        options.update(quality=True, minratio=minratio, mindihedral=0.0)
    if maxvolume is not None:
        maxvolume = float(maxvolume)
        if not (np.isfinite(maxvolume) and maxvolume > 0):
            raise ValueError(f"maxvolume must be a positive number, got {maxvolume!r}")
        # A volume bound needs Steiner points on the boundary too (TetGen -Y would leave the
        # tets along the box and the scene as large as they are): triangles may be split,
        # and the exact walk is then exact on their faces (docs/exact_walk.md).
        options.update(fixedvolume=True, maxvolume=maxvolume, nobisect=False)
    if (maxvolume is not None or p["sizing"] is not None) and not options.get("quality"):
        # TetGen enforces -a and -m only while refining; a bound this loose splits
        # tets for their volume or size alone.
        options.update(quality=True, minratio=_LOOSE_RATIO, mindihedral=0.0)
    if options.get("quality"):
        options["steinerleft"] = max(_STEINER_MIN, _STEINER_PER_VERTEX * int(n_vertices))
    else:
        # Only the Steiner points boundary recovery cannot do without: no budget.
        options["steinerleft"] = -1
    return options


def _check_sizing(sizing):
    if sizing is None:
        return None
    try:
        h0, growth = (float(x) for x in sizing)
    except (TypeError, ValueError):
        raise ValueError(f"sizing must be (h0, growth), two numbers, got {sizing!r}") from None
    if not (np.isfinite(h0) and h0 > 0 and np.isfinite(growth) and growth >= 0):
        raise ValueError(f"sizing: h0 must be > 0 and growth >= 0, got {sizing!r}")
    return h0, growth


def _tetgen_route(
    name,
    cm,
    box,
    options,
    *,
    repair,
    sizing,
    timeout,
    timings,
    attempts,
    diagonal,
    constrained_last=False,
    isolate=None,
    preset_name=None,
):
    """The exact route: as given (repaired if it self-intersects), then the snap ladder,
    then (``constrained_last``, when the preset refines) the constrained CT of the first
    snap-rounded scene.

    Returns ``(points, tets, faces, face_triangle, cm, repaired, snap, options, preset)``;
    ``preset`` is None, or ``"constrained"`` when the last rung built it.
    """
    have_igl = _igl_cgal() is not None
    # Needles (nearly collinear vertices) are no self-intersection, but TetGen reports them
    # as one: name them, so the message blames the right triangles.
    thin = needles(cm)
    needle_note = ""
    if len(thin):
        named = describe_degenerate(cm.vertices, cm.faces, thin, caller_ids=cm.triangle_ids)
        needle_note = (
            f"{len(thin)} triangle(s) are degenerate needles, which TetGen reports as "
            f"self-intersections: {named}"
        )
    t = time.perf_counter()
    intersects = (
        have_igl
        and repair is not False
        and count_intersecting_pairs(cm.vertices, cm.faces, first_only=True) > 0
    )
    if repair is False and have_igl:
        n = count_intersecting_pairs(cm.vertices, cm.faces)
        if n:
            raise MeshingError(
                f"{name} is not a valid PLC: {n} pairs of triangles intersect "
                f"(cross, overlap or touch away from shared edges), which TetGen "
                f"cannot mesh; pass repair='auto' or repair=True to cut them"
            )
    timings["repair"] += time.perf_counter() - t
    # Rungs: (snap cell, TetGen overrides, preset override).
    ladder = [(0.0, {}, None), (0.0, SPLIT_FALLBACK, None)]
    if repair is not False and have_igl:
        ladder += [(_snap_cell(box, rel), overrides, None) for rel, overrides in SNAP_LADDER]
        if constrained_last and options.get("quality") and SNAP_LADDER:
            rel, overrides = SNAP_LADDER[0]
            ladder.append((_snap_cell(box, rel), overrides, "constrained"))
    sizing_points = None
    if sizing is not None:
        try:
            import igl  # noqa: F401
        except ImportError:
            raise MeshingError(
                "a sizing field (preset 'graded', sizing=) needs libigl (pip install libigl)"
            ) from None
        t = time.perf_counter()
        sizing_points = _sizing_points(box, cm.vertices, cm.faces, sizing[0] * diagonal, sizing[1])
        timings["tetgen"] += time.perf_counter() - t
    repaired_meshes = {}  # snap cell -> (mesh, repaired, label) or an error message
    # Snap rounding starts from the exact repair's result when there is one, even if
    # a few intersections were left: that is most of the cutting done.
    start = cm
    tries = 0
    for snap, overrides, preset in ladder:
        t = time.perf_counter()
        if snap not in repaired_meshes:
            try:
                if snap:
                    with stage(f"repair (snap rounding to {snap:.3g})"):
                        work, n_cut, left = _run_stage(
                            _repair, start, name, 1e-14, snap, timeout=timeout, isolate=isolate
                        )
                    label = (
                        f"TetGen on the scene snap-rounded to {snap:.3g} "
                        f"({snap / diagonal:.1g} of the diagonal) and repaired"
                    )
                elif repair is True or intersects:
                    with stage("repair (cutting self-intersections)"):
                        work, n_cut, left = _run_stage(
                            _repair, cm, name, 1e-14, timeout=timeout, isolate=isolate
                        )
                    start = work
                    label = f"TetGen after exact repair of {n_cut} intersecting triangle pairs"
                else:
                    work, n_cut, left = cm, None, 0
                    label = "TetGen on the scene as given"
                if left:
                    raise MeshingError(_repair_left_message(name, snap, left, n_cut))
                if len(work.faces) == 0:
                    raise MeshingError(
                        f"snap rounding to {snap:.3g} flattens every triangle of {name}"
                    )
                repaired_meshes[snap] = (work, n_cut is not None, label)
            except (_TetGenFailed, _TetGenCrashed) as exc:
                repaired_meshes[snap] = _stage_message(
                    f"repair{' (snap rounding)' if snap else ''}", exc, timeout
                )
                attempts.append(repaired_meshes[snap])
            except MeshingError as exc:
                repaired_meshes[snap] = str(exc)
                attempts.append(str(exc))
            timings["repair"] += time.perf_counter() - t
        if isinstance(repaired_meshes[snap], str):
            continue
        work, repaired, label = repaired_meshes[snap]
        if preset is None:
            opts = dict(options, **overrides)
            points = sizing_points
        else:
            opts = dict(tetgen_options(preset, n_vertices=len(work.vertices)), **overrides)
            label += f", preset {preset!r}"
            points = None
        if overrides.get("opt_iterations") == 0:
            label += ", mesh optimisation off"
        if overrides.get("nobisect") is False:
            label += ", scene triangles split (TetGen could not keep them whole)"
        t = time.perf_counter()
        tries += 1
        shown = preset or preset_name
        what = f"TetGen attempt {tries}" + (f": preset {shown!r}" if shown else "")
        try:
            with stage(f"{what}, {label.removeprefix('TetGen ')}"):
                result = _run_tetgen(work, box, opts, isolate, extra=points, timeout=timeout)
        except (_TetGenFailed, _TetGenCrashed) as exc:
            timings["tetgen"] += time.perf_counter() - t
            message = _stage_message(label, exc, timeout)
            if snap == 0.0 and needle_note and not intersects:
                why = "libigl finds no intersecting pair" if have_igl else "not checked"
                message += f" [self-intersections: {why}; {needle_note}]"
            attempts.append(message)
            continue
        timings["tetgen"] += time.perf_counter() - t
        return (*result, work, repaired, snap, opts, preset)
    if needle_note:
        hint = f"{needle_note}; remove or widen them"
    elif not have_igl:
        hint = (
            "self-intersections were not checked: libigl, the tetrace dependency that "
            "checks and repairs them, is missing (pip install libigl)"
        )
    elif repair is False:
        hint = "repair=False: no snap rounding was tried"
    else:
        hint = "mesher='ftetwild' or 'fallback' meshes it approximately"
        if options.get("quality") and not constrained_last:
            hint = "preset='constrained' may work; " + hint
    raise MeshingError(f"TetGen could not mesh {name}: " + "; ".join(attempts) + f". {hint}")
