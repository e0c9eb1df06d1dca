//! Closest hit: stop at the first constrained face and evaluate the hit in float64 on the
//! caller's triangle it lies on.

use super::{QueryKind, StopAtFirst};
use crate::geom::triangle::{intersect_triangle, on_triangle};
use crate::locate::WalkStart;
use crate::mesh::{Surface, TetMesh};
use crate::status::{FAILED, HIT, MISS};
use crate::traverse::{Walk, WalkEnd};

/// One ray's closest hit before it is written out.
#[derive(Clone, Copy, Debug)]
pub struct RayHit {
    pub status: u8,
    pub t: f64,
    pub u: f64,
    pub v: f64,
    pub triangle: i32,
    pub tet: i32,
    pub steps: u32,
    pub audit: [u32; 2],
}

impl RayHit {
    pub fn nothing(status: u8) -> RayHit {
        RayHit {
            status,
            t: f64::INFINITY,
            u: f64::NAN,
            v: f64::NAN,
            triangle: -1,
            tet: -1,
            steps: 0,
            audit: [0, 0],
        }
    }
}

/// The closest-hit query over a mesh and the caller's triangles.
#[derive(Clone, Copy)]
pub struct ClosestHit<'a> {
    pub mesh: &'a TetMesh,
    pub surface: &'a Surface,
}

impl QueryKind for ClosestHit<'_> {
    type Policy = StopAtFirst;
    type Answer = RayHit;

    #[inline(always)]
    fn policy(&self, _: &WalkStart) -> StopAtFirst {
        StopAtFirst
    }

    #[inline]
    fn skipped(&self, status: u8) -> RayHit {
        RayHit::nothing(status)
    }

    #[inline]
    fn answer(&self, s: &WalkStart, w: &Walk, _: StopAtFirst, audit: [u32; 2]) -> RayHit {
        RayHit {
            audit,
            ..self.finish(s, w)
        }
    }
}

impl ClosestHit<'_> {
    /// The hit of a finished walk, evaluated in f64 on the caller's triangle (the CPU cast's
    /// and the GPU's second half).
    #[inline]
    pub fn finish(&self, s: &WalkStart, w: &Walk) -> RayHit {
        let mesh = self.mesh;
        let mut r = RayHit {
            tet: w.tet as i32,
            steps: w.steps,
            ..RayHit::nothing(MISS)
        };
        match w.end {
            WalkEnd::Boundary => {}
            WalkEnd::StepLimit => r.status = FAILED,
            WalkEnd::Hit { constrained } => {
                let named = mesh.constrained[constrained as usize].triangle;
                let ids = if w.slots {
                    w.face.map(|k| mesh.tets[w.tet as usize][k as usize])
                } else {
                    w.face
                };
                let face = || ids.map(|v| mesh.points[v as usize]);
                let (tri, (t, u, v)) = self.hit_triangle(s, named, face);
                if t <= s.tmax {
                    r = RayHit {
                        status: HIT,
                        t: t.max(s.tmin),
                        u,
                        v,
                        triangle: tri as i32,
                        ..r
                    };
                }
            }
        }
        r
    }

    /// The caller's triangle a hit on a constrained face lies on, and (t, u, v) on it: of the
    /// named one and its alternatives, the one the ray crosses nearest the face (the named
    /// one when the ray crosses none of them).
    fn hit_triangle(
        &self,
        s: &WalkStart,
        named: u32,
        face: impl Fn() -> [[f64; 3]; 3],
    ) -> (u32, (f64, f64, f64)) {
        let triangles = &self.surface.triangles;
        let on_named = intersect_triangle(s.o, s.d, &triangles[named as usize], &face);
        let alternatives = self.surface.alternatives.of(named);
        if alternatives.is_empty() {
            return (named, on_named);
        }
        // Of the named triangle and its alternatives, the one the ray crosses nearest to
        // where it crosses the face (the named one may be crossed too, farther away).
        use glam::DVec3;
        let [a, b, c] = face().map(DVec3::from);
        let (o, d) = (DVec3::from(s.o), DVec3::from(s.d));
        let n = (b - a).cross(c - a);
        let t_face = n.dot(a - o) / n.dot(d);
        let mut best = (named, on_named);
        let mut best_gap = if on_triangle(on_named) {
            (on_named.0 - t_face).abs()
        } else {
            f64::INFINITY
        };
        // Crossed within a face's size of the face: the named triangle is the one (most
        // hits; the alternatives are then not tried).
        let size = (b - a).length().max((c - b).length()).max((a - c).length());
        if best_gap * d.length() <= size {
            return best;
        }
        for &alt in alternatives {
            let hit = intersect_triangle(s.o, s.d, &triangles[alt as usize], &face);
            let gap = (hit.0 - t_face).abs();
            if on_triangle(hit) && gap < best_gap {
                (best, best_gap) = ((alt, hit), gap);
            }
        }
        best
    }
}
