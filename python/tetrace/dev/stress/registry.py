"""Every family by name, and making cases."""

import zlib

import numpy as np

from .certify import certify
from .closed import (
    fam_box_axis,
    fam_box_edges,
    fam_box_grid_axis,
    fam_icosphere,
    fam_parallel,
    fam_parallel_ball,
    fam_scan,
)
from .families import (
    fam_along_edges,
    fam_axis,
    fam_dirscale,
    fam_distance,
    fam_domain,
    fam_edges,
    fam_far,
    fam_flat,
    fam_grazing,
    fam_huge,
    fam_long,
    fam_on_surface,
    fam_on_surface_tmin,
    fam_planes,
    fam_terrain,
    fam_tiny,
    fam_tmin,
    fam_vertices,
)
from .real import SHARED_SCENES, _fam_shared, _shared_path, fam_spot

FAMILIES = {
    "vertices": fam_vertices,
    "edges": fam_edges,
    "along_edges": fam_along_edges,
    "planes": fam_planes,
    "grazing": fam_grazing,
    "on_surface": fam_on_surface,
    "on_surface_tmin": fam_on_surface_tmin,
    "tmin": fam_tmin,
    "domain": fam_domain,
    "axis": fam_axis,
    "tiny": fam_tiny,
    "huge": fam_huge,
    "flat": fam_flat,
    "terrain": fam_terrain,
    "long": fam_long,
    "dirscale": fam_dirscale,
    "far1e3": lambda rng, n: fam_far(rng, n, 1e3, "far1e3"),
    "far1e4": lambda rng, n: fam_far(rng, n, 1e4, "far1e4"),
    "far1e5": lambda rng, n: fam_far(rng, n, 1e5, "far1e5"),
    "far1e7": lambda rng, n: fam_far(rng, n, 1e7, "far1e7"),
    "origin1e2": lambda rng, n: fam_distance(rng, n, 1e2, "origin1e2"),
    "origin1e4": lambda rng, n: fam_distance(rng, n, 1e4, "origin1e4"),
    "origin1e6": lambda rng, n: fam_distance(rng, n, 1e6, "origin1e6"),
    "origin1e8": lambda rng, n: fam_distance(rng, n, 1e8, "origin1e8"),
    "scan": fam_scan,
    "box_axis": fam_box_axis,
    "box_grid_axis": fam_box_grid_axis,
    "box_edges": fam_box_edges,
    "icosphere": fam_icosphere,
    "parallel": fam_parallel,
    "parallel_ball": fam_parallel_ball,
    "spot": fam_spot,
    "fandisk": _fam_shared("fandisk"),
    "bunny": _fam_shared("bunny"),
}

#: Families on real meshes (rays certified and kept; the rest are built exact).
REAL_FAMILIES = ("spot", "fandisk", "bunny")
#: Families whose construction makes every claim true: all candidates certify.
EXACT_FAMILIES = tuple(k for k in FAMILIES if k not in REAL_FAMILIES)


def family_unavailable(name):
    """Why a family cannot be built here (a shared scene not found), or None."""
    if name in SHARED_SCENES:
        return _shared_path(name)[1]
    return None


def _stream(seed, name):
    return np.random.default_rng([seed, zlib.crc32(name.encode())])


def make_case(name, n, seed=0, *, certify_rays=True, **kw):
    """Build family ``name`` with ``n`` candidate rays from its own stream of ``seed`` (the same
    rays whatever other families are built), certified (:func:`certify`) unless asked not to."""
    case = FAMILIES[name](_stream(seed, name), n, **kw)
    case.family = name
    return certify(case) if certify_rays else case


def cases(n_per_family, seed=0, families=None, *, skipped=None):
    """Yield one certified :class:`StressCase` per family (default: every family available).

    Families that cannot be built here (a shared scene not found) are left out; their names
    and the reasons are appended to ``skipped`` when given.
    """
    names = list(FAMILIES) if families is None else list(families)
    for name in names:
        why = family_unavailable(name)
        if why is not None:
            if skipped is not None:
                skipped.append((name, why))
            continue
        yield make_case(name, n_per_family, seed)
