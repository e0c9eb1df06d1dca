//! Exact orientation: the one predicate construction, location and the exact referee of the
//! walk's steps share.

/// Exact orientation with the sign convention used everywhere in tetrace:
/// positive when d lies on the side of plane (a,b,c) that det(b-a, c-a, d-a) > 0 points to.
#[inline]
pub fn orient(a: [f64; 3], b: [f64; 3], c: [f64; 3], d: [f64; 3]) -> f64 {
    let p = |v: [f64; 3]| robust::Coord3D {
        x: v[0],
        y: v[1],
        z: v[2],
    };
    // robust::orient3d is positive when d is *below* (a,b,c); ours is the opposite sign.
    -robust::orient3d(p(a), p(b), p(c), p(d))
}
