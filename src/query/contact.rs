//! What the exact walk's queries share: where the ray meets the surface at a constrained face
//! it crosses or at a vertex or edge it touches, with t, the caller's triangle and its range
//! against [tmin, tmax], each decided exactly (`geom::exact`).

use crate::geom::exact::{
    beyond, cmp_plane_t, cmp_t, in_plane, orient_sign, plane_t, side, triangle_hit,
};
use crate::locate::WalkStart;
use crate::mesh::{Incidence, Surface, TetMesh};
use crate::traverse::{Contact, Touch};
use std::cmp::Ordering;

/// One point where a ray meets the surface.
#[derive(Clone, Copy, Debug)]
pub struct Meet {
    /// t on `triangle` ([`meet_at`]), within one ulp of the exact t.
    pub t: f64,
    /// A bound on |t − the exact t| (at most an ulp of t): meets farther apart than their
    /// bounds are ordered by t, nearer ones exactly ([`cmp_meets`]).
    pub err: f64,
    pub u: f64,
    pub v: f64,
    /// The point, each coordinate within one ulp of the exact point's.
    pub point: [f64; 3],
    /// The caller's triangle (of those met at this point, the smallest id).
    pub triangle: u32,
    /// The mesh feature the point lies in: sorted point ids of a vertex, edge or face, padded
    /// with u32::MAX. The same point is the same feature, however many tets report it.
    pub key: [u32; 3],
}

/// Where a point lies against [tmin, tmax].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Range {
    Before,
    In,
    After,
}

/// The scene's parts the exact queries read, and the ray.
#[derive(Clone, Copy)]
pub struct ExactRay<'a> {
    pub mesh: &'a TetMesh,
    pub incidence: &'a Incidence,
    pub surface: &'a Surface,
    pub o: [f64; 3],
    pub d: [f64; 3],
    /// d scaled by a power of two (signs only).
    pub dir: [f64; 3],
    pub tmin: f64,
    pub tmax: f64,
    /// A ray started from a hit: the corners of the caller's triangle it leaves (its points
    /// lie beyond that triangle's plane, [`beyond`]).
    pub leaving: Option<[[f64; 3]; 3]>,
}

/// The key of the ray's origin (t = 0): the same point however it is reported.
pub const ORIGIN_KEY: [u32; 3] = [u32::MAX - 1; 3];

fn sorted_key(mut k: [u32; 3]) -> [u32; 3] {
    k.sort_unstable();
    k
}

impl<'a> ExactRay<'a> {
    pub fn new(
        mesh: &'a TetMesh,
        incidence: &'a Incidence,
        surface: &'a Surface,
        s: &WalkStart,
    ) -> Self {
        ExactRay {
            mesh,
            incidence,
            surface,
            o: s.o,
            d: s.d,
            dir: s.dir,
            tmin: s.tmin,
            tmax: s.tmax,
            leaving: s.leaving.map(|k| surface.triangles[k as usize]),
        }
    }

    /// Point ids of a face the walk names (ids, or slots of tet `tet`).
    #[inline]
    pub fn ids(&self, tet: u32, names: [u32; 3], slots: bool) -> [u32; 3] {
        if slots {
            names.map(|k| self.mesh.tets[tet as usize][k as usize])
        } else {
            names
        }
    }

    /// Where the crossing of triangle `tri`'s plane lies against [tmin, tmax], exactly; for a
    /// ray started from a hit, a crossing not beyond the plane of the triangle it leaves is
    /// `Before` (the walk meets those first, in order).
    pub fn range(&self, tri: &[[f64; 3]; 3]) -> Range {
        match &self.leaving {
            Some(from) if !beyond(self.o, self.d, self.dir, from, tri) => Range::Before,
            _ => range_of(self.o, self.d, self.tmin, self.tmax, tri),
        }
    }

    fn meet_on(&self, triangle: u32, key: [u32; 3]) -> (Meet, Range) {
        let tri = &self.surface.triangles[triangle as usize];
        let meet = meet_at(self.o, self.d, self.tmin, self.tmax, tri, triangle, key);
        (meet, self.range(tri))
    }

    /// The crossing of constrained face `constrained` (a side index) whose points are `ids`,
    /// through its interior.
    /// None when the line lies in the plane of the caller's triangle the face lies on (a
    /// mesher's Steiner points can tilt a face off that plane by an ulp).
    pub fn crossing(&self, constrained: u32, ids: [u32; 3]) -> Option<(Meet, Range)> {
        let named = self.mesh.constrained[constrained as usize].triangle;
        let triangle = self.on_face(named, ids);
        let tri = &self.surface.triangles[triangle as usize];
        if in_plane(self.dir, tri[0], tri[1], tri[2]) {
            return None;
        }
        Some(self.meet_on(triangle, sorted_key(ids)))
    }

    /// Where the line lies in the plane of the caller's triangle of a face it crosses (see
    /// `crossing`): the caller's triangles around that face's vertices that it meets at one
    /// point, each decided exactly on the triangle. Where a mesher split a triangle, the line
    /// leaves it at an edge point the tilted faces do not mark as a touch; its neighbours there
    /// are among these. Not in walk order.
    pub fn around(&self, ids: [u32; 3], mut each: impl FnMut(Meet, Range)) {
        if !self.incidence.split {
            return;
        }
        let mut seen: Vec<u32> = Vec::new();
        for v in ids {
            for &f in self.incidence.at_vertex(v) {
                let triangle =
                    self.mesh.constrained[self.incidence.faces[f as usize].side as usize].triangle;
                if seen.contains(&triangle) {
                    continue;
                }
                seen.push(triangle);
                let tri = self.surface.triangles[triangle as usize];
                // The line, not the ray: behind the origin (or before tmin) is no meet.
                if self.line_meets(&tri) && cmp_t(self.o, self.d, &tri, self.tmin) != Ordering::Less
                {
                    let (meet, range) = self.meet_on(triangle, [u32::MAX - 2, triangle, 0]);
                    each(meet, range);
                }
            }
        }
    }

    /// Whether the line meets the closed triangle at one point (the referee's test: the
    /// three side products agree in sign and are not all zero), exactly.
    fn line_meets(&self, &[a, b, c]: &[[f64; 3]; 3]) -> bool {
        let s = [
            side(self.dir, self.o, a, b),
            side(self.dir, self.o, b, c),
            side(self.dir, self.o, c, a),
        ];
        (s.iter().all(|&x| x >= 0) || s.iter().all(|&x| x <= 0)) && s.iter().any(|&x| x != 0)
    }

    /// The caller's triangle a crossed face lies on: the one it names, unless the scene lists
    /// alternatives for it (overlapping input the cleaning merged): then, of those the line
    /// meets at one point (exact), the one it meets nearest to the face's plane.
    fn on_face(&self, named: u32, ids: [u32; 3]) -> u32 {
        let alternatives = self.surface.alternatives.of(named);
        if alternatives.is_empty() {
            return named;
        }
        let face = ids.map(|v| self.mesh.points[v as usize]);
        let (t_face, _) = plane_t(self.o, self.d, &face);
        let mut best = (f64::INFINITY, named);
        for &k in std::iter::once(&named).chain(alternatives) {
            let tri = self.surface.triangles[k as usize];
            if self.line_meets(&tri) {
                let gap = (plane_t(self.o, self.d, &tri).0 - t_face).abs();
                if gap < best.0 {
                    best = (gap, k);
                }
            }
        }
        best.1
    }

    /// The ray's origin on one of the caller's triangles (t = 0): of the triangles of the
    /// constrained faces around the start tet's vertices, the smallest id that holds o (closed)
    /// and whose plane does not hold the line. Decided on the caller's triangles, not on the
    /// faces: where a mesher split a triangle, its faces may be an ulp off it.
    fn at_origin(&self, tet: u32) -> Option<(Meet, Range)> {
        let mut best: Option<u32> = None;
        self.planes_at_origin(tet, |triangle, [a, b, c]| {
            if best.is_some_and(|b| b <= triangle) || in_plane(self.dir, a, b, c) {
                return;
            }
            // o in the triangle's plane: in the closed triangle when the line meets it.
            if self.line_meets(&[a, b, c]) {
                best = Some(triangle);
            }
        });
        best.map(|triangle| self.meet_on(triangle, ORIGIN_KEY))
    }

    /// Whether the origin lies in the plane of a caller's triangle around start tet `tet`:
    /// if not, the origin touches nothing, whatever the direction (`Contact::Origin` finds no
    /// point). Depends on the origin and the tet only, so a cast asks it once per origin.
    pub fn origin_on_a_plane(&self, tet: u32) -> bool {
        let mut found = false;
        self.planes_at_origin(tet, |_, _| found = true);
        found
    }

    /// Calls `each` with the caller's triangles, around the start tet's vertices, whose plane
    /// holds the origin (some twice).
    fn planes_at_origin(&self, tet: u32, mut each: impl FnMut(u32, [[f64; 3]; 3])) {
        if !self.incidence.split {
            // Faces are whole caller's triangles: an origin strictly inside the tet lies on none
            // (four orientations instead of one per face around the tet's vertices).
            let v = self.mesh.tet_points(tet);
            let strictly_inside = crate::mesh::build::OUTWARD_FACES
                .iter()
                .all(|f| orient_sign(v[f[0]], v[f[1]], v[f[2]], self.o) < 0);
            if strictly_inside {
                return;
            }
        }
        for v in self.mesh.tets[tet as usize] {
            for &f in self.incidence.at_vertex(v) {
                let triangle =
                    self.mesh.constrained[self.incidence.faces[f as usize].side as usize].triangle;
                let [a, b, c] = self.surface.triangles[triangle as usize];
                if orient_sign(a, b, c, self.o) == 0 {
                    each(triangle, [a, b, c]);
                }
            }
        }
    }

    /// The point where the line meets the surface at feature `points` (1, 2 or 3 ids, padded
    /// with u32::MAX), if a caller's triangle around it is met there at one point: of the
    /// constrained faces having the feature, those whose plane does not hold the line.
    fn at_feature(&self, key: [u32; 3]) -> Option<(Meet, Range)> {
        let faces = self.incidence.at_vertex(key[0]);
        let mut best: Option<u32> = None;
        for &f in faces {
            let face = &self.incidence.faces[f as usize];
            if !key[1..]
                .iter()
                .all(|&k| k == u32::MAX || face.points.contains(&k))
            {
                continue;
            }
            let triangle = self.mesh.constrained[face.side as usize].triangle;
            if best.is_some_and(|b| b <= triangle) {
                continue;
            }
            let tri = &self.surface.triangles[triangle as usize];
            if !in_plane(self.dir, tri[0], tri[1], tri[2]) {
                best = Some(triangle);
            }
        }
        best.map(|triangle| self.meet_on(triangle, key))
    }

    /// The points a touch reports (one, or up to three for a line in a face's plane), each
    /// with its range; `ordered` is false for the in-plane case, whose points are not at the
    /// walk's current position.
    pub fn touch(&self, at: &Touch, mut each: impl FnMut(Meet, Range)) -> bool {
        let ids = self.ids(at.tet, at.face, at.slots);
        let m = u32::MAX;
        let vertex = |k: u8| [ids[k as usize], m, m];
        let edge = |k: u8| {
            let (p, q) = (ids[k as usize], ids[(k as usize + 1) % 3]);
            [p.min(q), p.max(q), m]
        };
        let mut report = |key: [u32; 3]| {
            if let Some((meet, range)) = self.at_feature(key) {
                each(meet, range);
            }
        };
        match at.contact {
            Contact::Interior => true,
            Contact::Vertex(k) => {
                report(vertex(k));
                true
            }
            Contact::Edge(k) => {
                report(edge(k));
                true
            }
            Contact::Origin => {
                if let Some((meet, range)) = self.at_origin(at.tet) {
                    each(meet, range);
                }
                true
            }
            Contact::Coplanar { vertices, edges } => {
                for k in 0..3u8 {
                    if vertices & (1 << k) != 0 {
                        report(vertex(k));
                    }
                    if edges & (1 << k) != 0 {
                        report(edge(k));
                    }
                }
                false
            }
        }
    }
}

/// Where the line o + t d crosses the plane of `tri` against [tmin, tmax], exactly, for a
/// crossing the walk reached (so not behind the origin when tmin is 0).
pub fn range_of(o: [f64; 3], d: [f64; 3], tmin: f64, tmax: f64, tri: &[[f64; 3]; 3]) -> Range {
    if tmin > 0.0 && cmp_t(o, d, tri, tmin) == Ordering::Less {
        Range::Before
    } else if tmax.is_finite() && cmp_t(o, d, tri, tmax) == Ordering::Greater {
        Range::After
    } else {
        Range::In
    }
}

/// The point where the ray meets the caller's triangle `triangle` (corners `tri`), t clamped
/// into [tmin, tmax] (the exact t is in it; the rounded one may be an ulp out).
pub fn meet_at(
    o: [f64; 3],
    d: [f64; 3],
    tmin: f64,
    tmax: f64,
    tri: &[[f64; 3]; 3],
    triangle: u32,
    key: [u32; 3],
) -> Meet {
    let hit = triangle_hit(o, d, tri);
    let (mut t, t_err) = (hit.t, hit.t_err);
    // A touch at the origin (a ray starting on the surface) is at t = 0 exactly, which the
    // quotient may miss by an ulp of nothing: decide it exactly when t is that close.
    if t.abs() <= t_err && cmp_t(o, d, tri, 0.0).is_eq() {
        t = 0.0;
    }
    let t = t.max(tmin).min(tmax);
    // Clamping moves t towards the exact t (which is in [tmin, tmax]): t_err still bounds it.
    Meet {
        t: if t == 0.0 { 0.0 } else { t },
        err: t_err,
        u: hit.u,
        v: hit.v,
        point: hit.point,
        triangle,
        key,
    }
}

/// The order of two meets of the ray (o, d) by their exact t, `triangles` the caller's
/// triangles they name: Equal when they are the same point of the ray. Decided by the floats
/// where they are farther apart than their error bounds, else exactly ([`cmp_plane_t`]): the
/// answer is what exact arithmetic gives, whatever the rounding of t.
pub fn cmp_meets(
    o: [f64; 3],
    d: [f64; 3],
    triangles: &[[[f64; 3]; 3]],
    a: &Meet,
    b: &Meet,
) -> Ordering {
    if a.triangle == b.triangle {
        // One plane, one crossing.
        return Ordering::Equal;
    }
    if [a.t, a.err, b.t, b.err].iter().all(|x| x.is_finite()) {
        if a.t + a.err < b.t - b.err {
            return Ordering::Less;
        }
        if a.t - a.err > b.t + b.err {
            return Ordering::Greater;
        }
    }
    let tri = |m: &Meet| &triangles[m.triangle as usize];
    cmp_plane_t(o, d, tri(a), tri(b))
}

impl ExactRay<'_> {
    /// [`cmp_meets`] for this ray.
    #[inline]
    pub fn cmp_meets(&self, a: &Meet, b: &Meet) -> Ordering {
        cmp_meets(self.o, self.d, &self.surface.triangles, a, b)
    }

    /// The earlier of two meets by exact t (the same point: the smaller triangle id).
    #[inline]
    pub fn earlier(&self, a: Option<Meet>, b: Meet) -> Meet {
        match a {
            Some(a)
                if self
                    .cmp_meets(&a, &b)
                    .then(a.triangle.cmp(&b.triangle))
                    .is_le() =>
            {
                a
            }
            _ => b,
        }
    }
}
