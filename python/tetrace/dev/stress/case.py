"""A stress case (rays, the scene, what each ray is claimed to do) and the ray builder."""

import dataclasses

import numpy as np

#: The claims a case can make about each ray (arrays of length N; the "unclaimed" value in
#: brackets): ``hit`` int8 (1 hits, 0 misses; [-1]); ``t`` float64 (the exact first-hit
#: parameter; [nan]); ``zs_lo``, ``zs_hi`` int8 (range of the first tie's exact zero side
#: products: 2 at a vertex, 1 on an edge, 0 inside a face; [-1]); ``in_tie`` int64 (a triangle
#: in the tie set; [-1]); ``not_tie`` (N, 2) int64 (triangles not in the tie set, e.g. those
#: whose plane holds the line; [-1]); ``through`` (N, 3) float64 and ``through_t`` float64 (the
#: line passes exactly through this point at this parameter; [nan]); ``plane`` int64 (a
#: triangle whose plane holds the line exactly; [-1]); ``parallel`` int64 (a triangle whose
#: plane is parallel to the line and does not hold it: the line never meets it; [-1]).
CLAIMS = (
    "hit",
    "t",
    "zs_lo",
    "zs_hi",
    "in_tie",
    "not_tie",
    "through",
    "through_t",
    "plane",
    "parallel",
)


@dataclasses.dataclass
class StressCase:
    """A scene, rays to cast into it, and what is claimed of each ray.

    Attributes
    ----------
    family : str
        Family name (see :data:`FAMILIES`).
    vertices, faces : numpy.ndarray
        The scene (float64 vertices; every family's are float32 numbers too).
    origins, directions : numpy.ndarray
        ``(N, 3)`` float64 rays.
    tmin, tmax : numpy.ndarray
        ``(N,)`` float64 bounds of the hit parameter.
    claims : dict
        Per-ray claims (:data:`CLAIMS`).
    kind : numpy.ndarray
        ``(N,)`` str: what each ray is (``vertex``, ``edge``, ``face``, ``random``, ...).
    what : str
        What is exact about the family, in words.
    exact32 : bool
        The rays are float32 numbers: the float32 rays are the same numbers.
    built_exact : bool
        The construction makes every claim true (so 100% of the candidates certify); False
        for real meshes, whose aimed-at points may be hidden.
    contain : bool
        Grow the domain to hold the origins (False: rays enter through the domain box).
    margin : float
        Domain box margin (``Scene.from_mesh``'s, a fraction of the diagonal).
    domain : numpy.ndarray or None
        ``(2, 3)`` the domain box the rays were aimed at (families that aim at it).
    candidates : int
        Rays generated before certification.
    certified : dict
        ``{"f64": fraction, "f32": fraction}`` of the candidates whose claims all hold in each
        precision (set by :func:`certify`).
    verdicts : dict
        ``{"f64": Verdict, "f32": Verdict}`` of the kept rays (set by :func:`certify`).
    """

    family: str
    vertices: np.ndarray
    faces: np.ndarray
    origins: np.ndarray
    directions: np.ndarray
    tmin: np.ndarray
    tmax: np.ndarray
    claims: dict
    kind: np.ndarray
    what: str = ""
    exact32: bool = True
    built_exact: bool = True
    contain: bool = True
    margin: float = 0.02
    domain: np.ndarray | None = None
    candidates: int = 0
    certified: dict = dataclasses.field(default_factory=dict)
    verdicts: dict = dataclasses.field(default_factory=dict)

    def __len__(self):
        return len(self.origins)

    def rays(self, precision):
        """``(origins, directions)`` in ``precision`` (``"f32"``: the float64 rays rounded)."""
        dt = np.float32 if precision == "f32" else np.float64
        return self.origins.astype(dt), self.directions.astype(dt)


# --------------------------------------------------------------------------- ray builder


class _Rays:
    """Accumulates rays and their claims, kind by kind."""

    def __init__(self):
        self.parts = []

    def add(self, kind, o, d, *, tmin=0.0, tmax=np.inf, **claims):
        n = len(o)
        c = dict(
            hit=np.full(n, -1, np.int8),
            t=np.full(n, np.nan),
            zs_lo=np.full(n, -1, np.int8),
            zs_hi=np.full(n, -1, np.int8),
            in_tie=np.full(n, -1, np.int64),
            not_tie=np.full((n, 2), -1, np.int64),
            through=np.full((n, 3), np.nan),
            through_t=np.full(n, np.nan),
            plane=np.full(n, -1, np.int64),
            parallel=np.full(n, -1, np.int64),
        )
        for k, v in claims.items():
            if k == "zs":
                c["zs_lo"][:] = v
                c["zs_hi"][:] = v
                continue
            if k not in c:
                raise KeyError(k)
            v = np.asarray(v)
            if k == "not_tie" and v.ndim == 1:
                v = np.column_stack([v, np.full(n, -1)])
            c[k][:] = v
        self.parts.append(
            dict(
                kind=np.full(n, kind),
                o=np.asarray(o, np.float64),
                d=np.asarray(d, np.float64),
                tmin=np.broadcast_to(np.asarray(tmin, np.float64), (n,)),
                tmax=np.broadcast_to(np.asarray(tmax, np.float64), (n,)),
                c=c,
            )
        )

    def case(self, family, v, f, what, **kw):
        p = self.parts
        claims = {k: np.concatenate([x["c"][k] for x in p]) for k in CLAIMS}
        o = np.concatenate([x["o"] for x in p])
        return StressCase(
            family,
            np.asarray(v, np.float64),
            np.asarray(f, np.int64),
            o,
            np.concatenate([x["d"] for x in p]),
            np.concatenate([x["tmin"] for x in p]).copy(),
            np.concatenate([x["tmax"] for x in p]).copy(),
            claims,
            np.concatenate([x["kind"] for x in p]),
            what=what,
            candidates=len(o),
            **kw,
        )


def _split(rng, n, k):
    """``n`` split into ``k`` nearly equal random-order parts."""
    sizes = np.full(k, n // k)
    sizes[rng.permutation(k)[: n % k]] += 1
    return sizes
