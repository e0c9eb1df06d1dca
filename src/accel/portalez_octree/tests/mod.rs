//! The octree against the exact referee, the exact walk and the BVH (the same gatherer: the
//! same answers bit for bit) on the stress rays, with and without 2:1 balance; its tables
//! against the published arrays; its build against brute force (every triangle that meets a
//! leaf listed, by exact rational clipping; every face-adjacent pair linked both ways).
//!
//! Mutations tried, each caught: reading the sign bit the other way (b = 1 ⇔ Π > 0) in
//! `exit_face` fails the answers, every-scale and along-planes tests on their first rays
//! (hits leaked); trusting the cube map's guess without the exact check (`start`) fails the
//! answers test on the depth-12 tree (another triangle than the BVH's).

use super::tables::{FACE_AXIS, FACE_POSITIVE};
use super::*;
use crate::geom::exact::sign2;
use crate::query::gather::Nearest;
use crate::query::{AllHits, AnyHit};
use crate::referee;
use crate::scene::{CastOptions, HitBuffers};
use crate::status::{HIT, MISS};
use crate::testing::{assert_same_points, Agreement, Rng};
use num_rational::BigRational;
use num_traits::{Signed, Zero};

mod answers;
mod build;
mod lookup;

/// Small scenes in [0, 1]³ whose corners lie on split planes (multiples of 1/16 and 1/64),
/// with edge-on, face-on and corner-on contacts with leaf boxes, and slivers.
fn dyadic_scene(rng: &mut Rng, n: usize) -> Vec<Tri> {
    let mut tris: Vec<Tri> = vec![
        [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        [[1.0, 1.0, 1.0], [0.0, 1.0, 1.0], [1.0, 0.0, 1.0]],
    ];
    let at = |rng: &mut Rng, q: f64| [0, 1, 2].map(|_| (rng.f() * q).round() / q);
    while tris.len() < n {
        let c = at(rng, 16.0);
        let s = [1.0 / 16.0, 1.0 / 64.0, 1.0 / 4.0][tris.len() % 3];
        let p = |rng: &mut Rng| {
            [0, 1, 2].map(|k| (c[k] + ((rng.f() * 4.0).round() - 2.0) * s).clamp(0.0, 1.0))
        };
        let (a, b) = (p(rng), p(rng));
        let c3 = if tris.len().is_multiple_of(7) {
            [0, 1, 2].map(|k| 0.5 * a[k] + 0.5 * b[k]) // zero area
        } else {
            p(rng)
        };
        tris.push([a, b, c3]);
    }
    tris
}
