"""Families on real meshes (spot, fandisk, bunny), quantized so that the claims stay exact."""

import os
from pathlib import Path

import numpy as np

from .case import _Rays, _split
from .families import _in_plane
from .scenes import _vertex_face

# --------------------------------------------------------------------------- real meshes

#: Shared scenes (``$TETRACE_SCENES``) with a family each: fandisk (a CAD part: flat regions
#: of coplanar triangles) and the Stanford bunny.
SHARED_SCENES = {"fandisk": "fandisk.obj", "bunny": "bunny.obj"}

#: Bits kept of a real mesh's coordinates (relative to the largest), so that every ray built
#: from it below is a float32 number: points on edges and faces add 2-3 bits, origins up to
#: twice the mesh's size one more, which leaves a bit of float32's 24 to spare.
REAL_BITS = 19


def _real_mesh(path):
    from ...io import load_triangles

    v, f = load_triangles(str(path))
    v = np.asarray(v, np.float64)
    e = int(np.ceil(np.log2(np.abs(v).max()))) - REAL_BITS
    return np.round(v / 2.0**e) * 2.0**e, np.asarray(f, np.int64), e


def _quantized_normals(n):
    q = np.round(8 * n / np.maximum(np.abs(n).max(axis=1, keepdims=True), 1e-300))
    zero = ~q.any(axis=1)
    q[zero, 2] = 1
    return q


def fam_real(rng, n, path, name):
    """A real mesh, its vertices rounded to a dyadic grid (2^-19 of its largest coordinate):
    rays exactly through vertices, edge points and face points from just outside along the
    normal (first hit there at t = 1, where nothing hides it), origins exactly on vertices,
    edges and faces with tmin = 0 (first hit at t = 0) and tmin > 0 going inwards (a hit past
    the start's triangles), and rays in faces' planes (never a hit on that face). Every ray is
    certified by the referee; the kept fraction is reported."""
    import trimesh

    v, f, e = _real_mesh(path)
    mesh = trimesh.Trimesh(v, f, process=False)
    fn = np.nan_to_num(np.asarray(mesh.face_normals))
    area = np.asarray(mesh.area_faces)
    good = np.flatnonzero(area > 0)
    vn = np.zeros_like(v)
    np.add.at(vn, f.ravel(), np.repeat(fn * area[:, None], 3, axis=0))
    used = np.unique(f[good])
    vf = _vertex_face(f[good], len(v))
    diag = float(np.linalg.norm(np.ptp(v, axis=0)))
    h = 2.0 ** np.round(np.log2(diag / 256))  # |offset| = h |n| <= 8 sqrt(3) h ~ diag / 18
    r = _Rays()
    m = _split(rng, n, 7)
    # through a vertex, from outside along its normal
    vi = used[rng.integers(0, len(used), m[0])]
    nv = _quantized_normals(vn[vi]) * h
    r.add(
        "vertex",
        v[vi] + nv,
        -nv,
        hit=1,
        t=1.0,
        zs=2,
        in_tie=good[vf[vi]],
        through=v[vi],
        through_t=1.0,
    )
    # through an edge point (lambda 1/4, 1/2, 3/4), from outside along the face normal
    fi = good[rng.integers(0, len(good), m[1])]
    k = rng.integers(0, 3, m[1])
    a, b = v[f[fi, k]], v[f[fi, (k + 1) % 3]]
    lam = rng.integers(1, 4, m[1]) / 4.0
    p = a + lam[:, None] * (b - a)
    nf = _quantized_normals(fn[fi]) * h
    r.add("edge", p + nf, -nf, hit=1, t=1.0, zs=1, in_tie=fi, through=p, through_t=1.0)
    # through a face point (weights / 8, each >= 1/8)
    fi = good[rng.integers(0, len(good), m[2])]
    w = np.array([(i, j, 8 - i - j) for i in range(1, 7) for j in range(1, 8 - i)], float) / 8
    w = w[rng.integers(0, len(w), m[2])]
    p = np.einsum("ij,ijk->ik", w, v[f[fi]])
    nf = _quantized_normals(fn[fi]) * h
    r.add("face", p + nf, -nf, hit=1, t=1.0, zs=0, in_tie=fi, through=p, through_t=1.0)
    # origins on the surface, tmin = 0 and tmin > 0, inwards
    for kind, mm, tmin in (("on_surface", m[3], 0.0), ("on_surface_tmin", m[4], 2.0**-8)):
        sizes = _split(rng, mm, 3)
        vi = used[rng.integers(0, len(used), sizes[0])]
        fe = good[rng.integers(0, len(good), sizes[1])]
        ke = rng.integers(0, 3, sizes[1])
        ae, be = v[f[fe, ke]], v[f[fe, (ke + 1) % 3]]
        pe = ae + rng.integers(1, 4, sizes[1])[:, None] / 4.0 * (be - ae)
        ff = good[rng.integers(0, len(good), sizes[2])]
        pf = np.einsum("ij,ijk->ik", w[rng.integers(0, len(w), sizes[2])], v[f[ff]])
        for sub, p, nrm, fid, zs in (
            ("vertex", v[vi], vn[vi], good[vf[vi]], 2),
            ("edge", pe, fn[fe], fe, 1),
            ("face", pf, fn[ff], ff, 0),
        ):
            d = -_quantized_normals(nrm) * h
            if tmin == 0:
                r.add(
                    f"{kind}_{sub}", p, d, hit=1, t=0.0, zs=zs, in_tie=fid, through=p, through_t=0.0
                )
            else:
                r.add(
                    f"{kind}_{sub}",
                    p,
                    d,
                    tmin=tmin,
                    hit=1,
                    not_tie=np.column_stack([fid, fid]),
                    through=p,
                    through_t=0.0,
                )
    # in a face's plane, from outside it across it
    fi = good[rng.integers(0, len(good), m[5] + m[6])]
    o, d, p = _in_plane(rng, v, f, fi)
    r.add("in_plane", o, d, not_tie=np.column_stack([fi, fi]), through=p, through_t=4.0, plane=fi)
    return r.case(
        name,
        v,
        f,
        f"{Path(path).name} on a 2^{e} grid: through vertices/edges/"
        "faces at t=1, origins on them (tmin 0 and >0), in face planes; certified",
        built_exact=False,
    )


def fam_spot(rng, n):
    """The bundled scene (Spot): see :func:`fam_real`."""
    from ...scene import default_scene_path

    return fam_real(rng, n, default_scene_path(), "spot")


def _shared_path(name):
    env = os.environ.get("TETRACE_SCENES")
    if not env:
        return None, "TETRACE_SCENES is not set"
    path = Path(env).expanduser() / SHARED_SCENES[name]
    if not path.is_file():
        return None, f"{path} not found"
    return path, None


def _fam_shared(name):
    def fam(rng, n, path=None):
        if path is None:
            path, why = _shared_path(name)
            if path is None:
                raise FileNotFoundError(why)
        return fam_real(rng, n, path, name)

    fam.__doc__ = f"The shared scene {SHARED_SCENES[name]} (``$TETRACE_SCENES``): see fam_real."
    return fam


#: Family name -> generator ``(rng, n) -> StressCase`` (uncertified candidates).
