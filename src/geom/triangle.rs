//! Where a ray crosses one of the caller's triangles, in float64.

/// Whether barycentric (u, v) at a finite t lie on the triangle, with a little slack for the
/// rounding of a hit on a shared edge.
#[inline]
pub fn on_triangle((t, u, v): (f64, f64, f64)) -> bool {
    const SLACK: f64 = 1e-9;
    t.is_finite() && u >= -SLACK && v >= -SLACK && u + v <= 1.0 + SLACK
}

/// t and barycentrics (u, v) of the ray on the caller's triangle (Möller–Trumbore in f64, no
/// culling). The walk already decided that the ray crosses `face`, a piece of that triangle; if
/// the ray lies in the triangle's plane, the face's centroid gives t instead (fetched only
/// then: three point loads per hit are not free).
pub fn intersect_triangle(
    o: [f64; 3],
    d: [f64; 3],
    tri: &[[f64; 3]; 3],
    face: impl FnOnce() -> [[f64; 3]; 3],
) -> (f64, f64, f64) {
    use glam::DVec3;
    let (o, d) = (DVec3::from(o), DVec3::from(d));
    let [p0, p1, p2] = tri.map(DVec3::from);
    let (e1, e2) = (p1 - p0, p2 - p0);
    let pv = d.cross(e2);
    let det = e1.dot(pv);
    // |det| > 1e-14 |e1| |e2| |d|, squared to avoid three square roots per hit.
    let scale2 = e1.length_squared() * e2.length_squared() * d.length_squared();
    if det * det > 1e-28 * scale2 {
        let inv = 1.0 / det;
        let tv = o - p0;
        let u = tv.dot(pv) * inv;
        let qv = tv.cross(e1);
        let v = d.dot(qv) * inv;
        let t = e2.dot(qv) * inv;
        (t, u, v)
    } else {
        let face = face();
        let c = (DVec3::from(face[0]) + DVec3::from(face[1]) + DVec3::from(face[2])) / 3.0;
        let t = (c - o).dot(d) / d.length_squared();
        (t, 1.0 / 3.0, 1.0 / 3.0)
    }
}
