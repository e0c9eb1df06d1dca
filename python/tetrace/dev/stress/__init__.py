"""Adversarial rays and scenes that are what they say, judged by the exact referee.

Each family is reproducible from a seed and yields a :class:`StressCase`: a scene, rays (with
per-ray ``tmin`` and ``tmax``) and **claims** about each ray: that its first hit is exactly at
a mesh vertex (``zero_signs == 2``), on an edge (1) or inside a face (0), at an exact ``t``;
that it hits or misses; that a named triangle is, or is not, in its tie set; that its line
passes exactly through a given point, lies exactly in a triangle's plane, or runs exactly
parallel to it off the plane.

Exactness is built in. Every synthetic scene lies on a grid of small integers scaled by a
power of two (a sphere's vertices rounded to the grid and checked convex in integers, a box
of 12 triangles or of grids of squares, a box rotated onto integer orthogonal edges, a
scan-like bumpy noisy closed surface whose kernel is checked in integers, a height field),
placed with an exact offset or power-of-two scaling; rays are built from grid
points by differences and dyadic combinations whose every bit fits float32's 24: the float32
rays are the same numbers as the float64 ones. Real meshes (Spot; fandisk and the bunny from
``$TETRACE_SCENES``) have their vertices rounded to a dyadic grid of 2^-19 of their largest
coordinate for the same reason (rays built from them that still miss a float32 bit do not
certify). The one family whose rays cannot be float32 numbers (``long``: an origin 10^4 sizes
away and a target on the surface) claims only what survives rounding (a hit, on the aimed-at
triangle) and is judged on the float32 rays as passed.

The verdicts are computed once per family and precision when the rays are certified, before
any cast (the referee's hint only speeds its search up; the verdict does not depend on it):
every method, layout and precision is judged against the same verdict. :func:`cast_case`
computes one with the cast's triangles as the hint for a case that has none.

Then every ray is **certified**: the exact referee (:mod:`tetrace.referee`) computes its verdict
in each precision, exact integer arithmetic checks the geometric claims, and only rays whose
claims all hold are kept (:func:`cases`); each case records how many candidates it had and the
certified fraction per precision. Families built exact certify 100% of their candidates
(``tests/test_stability.py`` asserts it); the real meshes keep the rays whose aimed-at point is
the first thing they meet (others are occluded) and report the fraction.

Each ray is judged twice. Per ray, against the referee's verdict (:func:`judge_cast`, after
``docs/referee.md``): ``failed`` (the walk gave up, e.g. its step guard fired on a cycle),
``leaked`` (a miss where the referee hits), ``late`` (a triangle past the first hit), ``wrong``
(anything else: a phantom or early hit, a triangle not in the tie set, ``t`` off its bound),
of which ``fabricated`` counts the phantoms (a hit where the referee has none). Per
step, by the walk's exact audit (:func:`audited_cast`): every exit face the method took is
checked with exact orientation predicates against the line the robust walk in the same precision
follows (``wrong_exit``), and methods with a fallback report the steps where their own tests
found no exit face (``no_exit``).
"""

from __future__ import annotations

from .case import CLAIMS, StressCase
from .certify import (
    certify,
    check_claims,
    exact_in_plane,
    exact_parallel,
    exact_through,
    subset,
)
from .judge import OUTCOMES, audited_cast, build_scene, cast_case, count, examples, judge_cast
from .real import SHARED_SCENES
from .registry import EXACT_FAMILIES, FAMILIES, REAL_FAMILIES, cases, family_unavailable, make_case

__all__ = [
    "StressCase",
    "FAMILIES",
    "EXACT_FAMILIES",
    "REAL_FAMILIES",
    "SHARED_SCENES",
    "CLAIMS",
    "cases",
    "make_case",
    "certify",
    "check_claims",
    "exact_through",
    "exact_in_plane",
    "exact_parallel",
    "subset",
    "family_unavailable",
    "OUTCOMES",
    "audited_cast",
    "build_scene",
    "cast_case",
    "judge_cast",
    "count",
    "examples",
]
