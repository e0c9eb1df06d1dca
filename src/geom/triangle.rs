//! Where a ray crosses one of the caller's triangles (the float walks' hit finishing: the CPU
//! cast's and the GPU's second half).

use super::rounded::{rounded_hit, RoundedHit};

/// Whether barycentric (u, v) at a finite t lie on the triangle, with a little slack for the
/// rounding of a hit on a shared edge.
#[inline]
pub fn on_triangle(h: &RoundedHit) -> bool {
    const SLACK: f64 = 1e-9;
    h.t.is_finite() && h.u >= -SLACK && h.v >= -SLACK && h.u + h.v <= 1.0 + SLACK
}

/// t, barycentrics (u, v) and the point of the ray on the caller's triangle, each within one
/// ulp of its exact value ([`rounded_hit`]). The walk already decided that the ray crosses
/// `face`, a piece of that triangle; if the ray is parallel to the triangle's plane (exactly:
/// a float walk may cross a face its line lies in), the face's centroid gives t instead
/// (fetched only then: three point loads per hit are not free).
pub fn intersect_triangle(
    o: [f64; 3],
    d: [f64; 3],
    tri: &[[f64; 3]; 3],
    face: impl FnOnce() -> [[f64; 3]; 3],
) -> RoundedHit {
    if let Some(h) = rounded_hit(o, d, tri) {
        return h;
    }
    use glam::DVec3;
    let (o, d) = (DVec3::from(o), DVec3::from(d));
    let face = face();
    let c = (DVec3::from(face[0]) + DVec3::from(face[1]) + DVec3::from(face[2])) / 3.0;
    let t = (c - o).dot(d) / d.length_squared();
    RoundedHit {
        t,
        t_err: f64::INFINITY,
        u: 1.0 / 3.0,
        v: 1.0 / 3.0,
        point: (o + t * d).to_array(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A hit on the closed triangle's edges and vertices (u = 0, v = 0 or u + v = 1 exactly)
    /// is on it, and so is one a rounding's width outside an edge (1e-12); one well outside
    /// (1e-6), or at a t that is not finite, is not.
    #[test]
    fn hits_on_edges_and_vertices_are_on_the_triangle() {
        let hit = |t: f64, u: f64, v: f64| RoundedHit {
            t,
            t_err: 0.0,
            u,
            v,
            point: [0.0; 3],
        };
        let (e, far) = (1e-12, 1e-6);
        let on = [
            (0.0, 0.5),
            (0.5, 0.0),
            (0.0, 0.0),
            (1.0, 0.0),
            (0.0, 1.0),
            (0.5, 0.5),
            (0.25, 0.25),
            (-e, 0.3),
            (0.3, -e),
            (0.6, 0.4 + e),
        ];
        for (u, v) in on {
            assert!(
                on_triangle(&hit(2.0, u, v)),
                "({u}, {v}) is on the triangle"
            );
            for t in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
                assert!(!on_triangle(&hit(t, u, v)), "({u}, {v}) at t = {t}");
            }
        }
        for (u, v) in [(-far, 0.3), (0.3, -far), (0.6, 0.4 + far), (-far, -far)] {
            assert!(
                !on_triangle(&hit(2.0, u, v)),
                "({u}, {v}) is off the triangle"
            );
        }
    }

    /// A line in the triangle's plane has no crossing: a float walk that crossed a face there
    /// gets the point of the line nearest the face's centroid (t = (c − o)·d / |d|², exact on
    /// these numbers; the origin lies off the centroid along d, so that c − o and c + o
    /// differ there), weights 1/3 and an unbounded error.
    #[test]
    fn a_line_in_the_plane_takes_the_face_centroid() {
        let tri = [[0.0, 0.0, 0.0], [8.0, 0.0, 0.0], [0.0, 8.0, 0.0]];
        let face = [[3.0, 1.0, 0.0], [6.0, 4.0, 0.0], [6.0, -2.0, 0.0]];
        for (d, t) in [
            ([1.0, 0.0, 0.0], 4.0),
            ([2.0, 0.0, 0.0], 2.0),
            ([0.5, 0.0, 0.0], 8.0),
        ] {
            let h = intersect_triangle([1.0, 1.0, 0.0], d, &tri, || face);
            assert_eq!((h.t, h.u, h.v), (t, 1.0 / 3.0, 1.0 / 3.0), "d = {d:?}");
            assert_eq!(h.point, [5.0, 1.0, 0.0], "d = {d:?}");
            assert_eq!(h.t_err, f64::INFINITY);
        }
    }
}
