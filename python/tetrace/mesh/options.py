"""Meshing options: TetGen presets, budgets, timeouts and the fTetWild defaults."""

from __future__ import annotations

import os
import re

# Options every TetGen run shares. brio_hilbert: TetGen inserts points in a BRIO/Hilbert
# order, which is what keeps its Delaunay phase fast; quiet/nowarning: TetGen prints
# to the C stdout, which Python cannot capture (in a forked child it prints its phases
# to a log file instead, see _tetgen_arrays).
# nobisect (TetGen -Y): no Steiner point on the scene's triangles, so every constrained face
# is exactly one of them (or a piece the repair cut) and the exact walk's touches at their
# vertices and edges are the caller's (a split triangle's faces sit an ulp off it, where a
# ray in its plane can leave it unseen). Where TetGen cannot recover the surface so, the
# ladder tries again with splitting allowed (``SPLIT_FALLBACK``).
_COMMON = dict(plc=True, brio_hilbert=True, quiet=True, nowarning=True, verbose=0, nobisect=True)

#: TetGen overrides of the rung that lets TetGen split the scene's triangles after the
#: unsplit attempt failed (the exact walk is then exact on the faces, which the caller's
#: triangles contain up to the Steiner points' rounding).
SPLIT_FALLBACK = dict(nobisect=False)

#: The named TetGen presets: ``minratio`` is the radius-edge bound (TetGen ``-q``;
#: None: no refinement), ``sizing`` a target edge length that grows away from the
#: surface (see ``sizing`` in :func:`tetrahedralize`; None: none), ``tetgen`` (optional)
#: TetGen keyword arguments that override the defaults.
#:
#: ``"constrained"``
#:     Constrained Delaunay tetrahedralization of the PLC (TetGen ``-p``), no
#:     refinement: the fewest points (the scene's vertices, the box's corners and
#:     the Steiner points boundary recovery needs) and the fastest build, but not
#:     the fewest tets: long slivers fan out from the scene's vertices, so it can
#:     have more tets than ``"quality"`` (bunny: 228,894 tets on 34,842 points
#:     against 215,821 on 38,776; Spot: 18,684 against 18,251), twice its weight,
#:     and rays cross 1.7-3.8x more tets.
#: ``"quality"`` (the default)
#:     Delaunay refinement to radius-edge ratio 5 (TetGen ``-pq5``). Measured on
#:     spot, bunny, armadillo and torus_knots_27, bounds from 1.5 to 10 all cut
#:     the tets a ray visits to a half to a third of ``"constrained"``; 3-5 visit
#:     the fewest, and 5 builds the fewest tets the fastest of those (bunny:
#:     261k tets in 3.5 s, against 613k in 9.7 s at 1.5).
#: ``"quality3"``, ``"quality2"``, ``"quality1.5"``
#:     Tighter radius-edge bounds (more, better-shaped tets). Any ``"quality<r>"``
#:     with r > 1 is accepted, e.g. ``"quality1.2"``.
#: ``"graded"``
#:     ``"quality"`` plus a sizing field: target edge length 2% of the scene
#:     diagonal on the surface, growing by 0.5 per unit of distance from it, so
#:     tet volume grows away from the surface instead of a few huge tets and
#:     long slivers filling the space between objects (see ``sizing`` in
#:     :func:`tetrahedralize`; needs libigl).
#:
#: :func:`tetrahedralize` adds a Steiner-point budget (``steinerleft``, see
#: :func:`tetgen_options`).
PRESETS: dict[str, dict] = {
    "constrained": dict(minratio=None, sizing=None),
    "quality": dict(minratio=5.0, sizing=None),
    "quality3": dict(minratio=3.0, sizing=None),
    "quality2": dict(minratio=2.0, sizing=None),
    "quality1.5": dict(minratio=1.5, sizing=None),
    "graded": dict(minratio=5.0, sizing=(0.02, 0.5)),
}

#: The preset :func:`tetrahedralize` uses when none is given.
DEFAULT_PRESET = "quality"

#: Values of ``mesher``: ``"tetgen"`` (exact, the default), ``"ftetwild"``
#: (approximate, within ``epsilon``), ``"fallback"`` (TetGen, then fTetWild if it fails),
#: ``"auto"`` (the lowest-weight setting that meets ``accuracy``; :mod:`tetrace.mesh.auto`).
MESHERS = ("tetgen", "ftetwild", "fallback", "auto")

#: fTetWild defaults, relative to the scene's bounding-box diagonal: the envelope
#: (how far the remeshed surface may lie from the input) and the target edge length.
FTETWILD_EPSILON = 1e-3
FTETWILD_EDGE_LENGTH = 0.05

#: Attempts of the TetGen route after the scene as given (or exactly repaired) fails:
#: ``(snap, overrides)``, the snap-rounding cell relative to the domain diagonal
#: (rounded to a power of two) and TetGen options that change. ``opt_iterations=0``
#: turns off TetGen's final mesh optimisation (``-O``), which is what raises
#: "Internal error in repair_tet" on repaired scenes; the CT is valid without it.
SNAP_LADDER = ((1e-7, dict(opt_iterations=0)), (1e-6, dict(opt_iterations=0)))

# Steiner-point budget of a refinement (TetGen -S): max(MIN, PER_VERTEX * scene
# vertices). Radius-edge refinement grades the mesh down to the smallest feature,
# so a thin plate or a light 0.1 under a 550-unit ceiling would otherwise take
# hundreds of thousands of points; the real scenes measured need 0.4-1.3 per vertex.
_STEINER_MIN = 10_000
_STEINER_PER_VERTEX = 2
# Radius-edge bound used when only maxvolume or a sizing field asks for refinement:
# loose enough that no tet is split for its shape.
_LOOSE_RATIO = 1e6


def preset_options(preset) -> dict:
    """Return the options of a preset name: ``minratio`` (float or None), ``sizing``
    (tuple or None) and ``tetgen`` (dict of TetGen overrides).

    Parameters
    ----------
    preset : str
        A key of :data:`PRESETS`, or ``"quality<r>"`` for any radius-edge bound r > 1.

    Raises
    ------
    ValueError
        Unknown name, or a bound not above 1.
    """
    if not isinstance(preset, str):
        raise TypeError(f"preset must be a name (str), got {type(preset).__name__}")
    if preset in PRESETS:
        return dict(dict(tetgen={}), **PRESETS[preset])
    m = re.fullmatch(r"quality(\d+(?:\.\d*)?|\.\d+)", preset)
    if m:
        ratio = float(m.group(1))
        if not ratio > 1.0:
            raise ValueError(f"preset {preset!r}: the radius-edge bound must be > 1")
        return dict(minratio=ratio, sizing=None, tetgen={})
    raise ValueError(
        f"unknown preset {preset!r}; choose one of {sorted(PRESETS)} or 'quality<r>' with r > 1"
    )


def default_timeout(n_faces, stage="tetgen") -> float:
    """Seconds one stage may run on a scene of ``n_faces`` triangles before it is stopped.

    ``"tetgen"`` and ``"repair"``: 180 s + 1 ms per triangle (bunny, 69k triangles:
    249 s, against 3.5 s for the default preset and 10 s for ``"quality1.5"``; but
    featuretype's 3.5k triangles, with their sharp angles, took 50 s to refine);
    ``"ftetwild"``: 300 s + 10 ms per triangle (fTetWild is far slower: spot's 5.8k
    triangles take 13 s on one core). ``TETRACE_TETGEN_TIMEOUT`` (seconds; 0 or
    "none": no limit) overrides every stage.
    """
    env = os.environ.get("TETRACE_TETGEN_TIMEOUT", "").strip().lower()
    if env:
        if env in ("0", "none", "inf"):
            return None
        return float(env)
    n = max(int(n_faces), 0)
    if stage == "ftetwild":
        return 300.0 + 10e-3 * n
    return 180.0 + 1e-3 * n
