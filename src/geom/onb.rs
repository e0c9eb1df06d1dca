//! An orthonormal basis around a direction (Aman et al. 2022 project vertices onto it).

use crate::geom::real::V3;

/// Duff et al. 2017, "Building an Orthonormal Basis, Revisited": branchless, and
/// (u, w, n) is right-handed, so counter-clockwise in (u, w) means "normal along n".
pub fn onb(n: V3<f64>) -> (V3<f64>, V3<f64>) {
    let sign = 1f64.copysign(n[2]);
    let a = -1.0 / (sign + n[2]);
    let b = n[0] * n[1] * a;
    let u = [1.0 + sign * n[0] * n[0] * a, sign * b, -sign * n[0]];
    let w = [b, sign + n[1] * n[1] * a, -n[1]];
    (u, w)
}
