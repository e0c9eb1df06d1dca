//! Containment without a tetrahedralization: the parity of the crossings of one ray from the
//! point, counted exactly on the exact BVH.
//!
//! **The rule it computes.** On a closed surface (every edge shared by an even number of
//! triangles: a cycle mod 2) the number of crossings of a path from a point to far away has the
//! same parity for every path that crosses the surface only through triangle interiors, so one
//! ray's count decides it. That is the rule [`crate::query::contains`] computes on the
//! tetrahedralization (the fewest crossings to outside the domain box, odd: inside), so on a
//! closed surface the two give the same answer for every point; points on the surface (on a
//! triangle, its edge or its corner) are inside by both. On an open surface they differ (a
//! ray's count is then a property of the ray), so the scene uses this only on closed ones.
//!
//! **Which triangles count** is the caller's choice (`keep`): the scene passes the triangles its
//! cleaning keeps (exact duplicates and zero-area ones dropped), the triangles the
//! tetrahedralization is built from and whose edges `Scene.is_closed` counts.
//!
//! **Exactness.** A ray whose count could depend on rounding is not counted: one that meets a
//! kept triangle on its edge or corner (a side product exactly zero) or lies in a kept
//! triangle's plane where a leaf offers it (all three zero) is given up, and the next of
//! [`TRIES`] fixed directions is tried. A ray that starts on a kept triangle (the point in its
//! plane, exactly, and the triangle met: at t = 0) answers inside at once. Every other
//! triangle it meets is crossed through its interior at t > 0, decided by exact signs, and
//! counted. A point for which every direction is given up is [`UNDECIDED`]: the caller decides
//! it otherwise (the scene, on the tetrahedralization). With directions of no special relation
//! to the mesh that takes a point on a plane or line through mesh features for every one of
//! them; none of the tests' grids, vertices and edge points needed a second direction more
//! than rarely.

use super::ExactBvh;
use crate::error::Result;
use crate::geom::exact::triangle_sides;
use crate::geom::predicates::orient;
use crate::geom::ray::Ray;
use crate::geom::real::Real;
use crate::query::gather::{Gather, Line, Tri};
use crate::simd::Simd;

/// The point is outside: an even count (or a coordinate that is not finite).
pub const OUTSIDE: u8 = 0;
/// The point is inside: an odd count, or on a kept triangle.
pub const INSIDE: u8 = 1;
/// Every direction met a kept triangle's edge or corner or lay in its plane.
pub const UNDECIDED: u8 = 2;

/// Directions tried per point before it is left [`UNDECIDED`].
pub const TRIES: usize = 16;

/// The k-th direction: a point of the additive recurrence with the plastic-number ratios
/// (Roberts' R3 sequence) in [-1, 1)³, so no two are parallel and none lies on an axis or a
/// coordinate plane; only additions, a product and `floor`, so it is the same everywhere.
pub fn direction(k: usize) -> [f64; 3] {
    // 1/g, 1/g², 1/g³ for g the real root of x⁴ = x + 1.
    const ALPHA: [f64; 3] = [
        0.819_172_513_396_164_4,
        0.671_043_606_703_789_2,
        0.549_700_477_901_970_6,
    ];
    ALPHA.map(|a| {
        let x = 0.5 + a * (k as f64 + 1.0);
        2.0 * (x - x.floor()) - 1.0
    })
}

/// Why a ray stopped before its count was complete.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Stop {
    /// It starts on a kept triangle.
    OnSurface,
    /// It meets a kept triangle on its edge or corner, or lies in its plane.
    Degenerate,
}

/// Counts the kept triangles one ray crosses (in any order: only the parity matters).
struct Crossings<'a> {
    line: Line,
    /// The caller's triangles, by id.
    triangles: &'a [Tri],
    keep: &'a [bool],
    odd: bool,
    stop: Option<Stop>,
}

impl Crossings<'_> {
    fn kept(&self, id: u32) -> bool {
        self.keep.get(id as usize).copied().unwrap_or(false)
    }
}

impl Gather for Crossings<'_> {
    fn reach(&self) -> f64 {
        f64::INFINITY
    }

    fn offer(&mut self, id: u32, tri: &Tri, _: (f64, f64)) -> bool {
        if !self.kept(id) {
            return false;
        }
        let o = self.line.o;
        // Met at one point with t ≥ 0 and not in its plane: the origin in the plane is the
        // point met, so the origin lies on the closed triangle.
        if orient(tri[0], tri[1], tri[2], o) == 0.0 {
            self.stop = Some(Stop::OnSurface);
            return true;
        }
        if triangle_sides(self.line.dir, o, tri).contains(&0) {
            self.stop = Some(Stop::Degenerate);
            return true;
        }
        self.odd = !self.odd;
        false
    }

    fn in_plane(&mut self, id: u32) -> bool {
        // The three side products all zero: the line lies in the plane of this (kept, so not
        // degenerate) triangle. Given up wherever the ray may touch it (its leaf's box).
        if self.kept(id)
            && triangle_sides(self.line.dir, self.line.o, &self.triangles[id as usize]) == [0; 3]
        {
            self.stop = Some(Stop::Degenerate);
            return true;
        }
        false
    }
}

/// One point's answer ([`OUTSIDE`], [`INSIDE`] or [`UNDECIDED`]), and the directions given
/// up before it.
pub fn side_of(
    bvh: &ExactBvh,
    triangles: &[Tri],
    keep: &[bool],
    p: [f64; 3],
    simd: Simd,
    stack: &mut Vec<(u32, f32)>,
) -> (u8, usize) {
    if !p.iter().all(|x| x.is_finite()) {
        return (OUTSIDE, 0);
    }
    for k in 0..TRIES {
        let ray = Ray::new(p, direction(k), 0.0, f64::INFINITY);
        let Ok(line) = Line::new(&ray) else {
            continue;
        };
        let mut count = Crossings {
            line,
            triangles,
            keep,
            odd: false,
            stop: None,
        };
        bvh.walk(&line, &mut count, simd, stack);
        match count.stop {
            Some(Stop::OnSurface) => return (INSIDE, k),
            Some(Stop::Degenerate) => continue,
            None => return (if count.odd { INSIDE } else { OUTSIDE }, k),
        }
    }
    (UNDECIDED, TRIES)
}

/// [`side_of`]'s answer for every point (`points`: x y z of each, 3N values) into `out` (N), in
/// parallel; `triangles`: the caller's, as `bvh` was built from them; `keep[i]`: whether
/// triangle i counts.
pub fn sides<R: Real>(
    bvh: &ExactBvh,
    triangles: &[Tri],
    keep: &[bool],
    points: &[R],
    out: &mut [u8],
    threads: Option<usize>,
) -> Result<()> {
    let simd = Simd::from_env()?;
    crate::query::contains::per_point(
        points,
        out,
        threads,
        |_| Vec::with_capacity(64),
        |p, stack| side_of(bvh, triangles, keep, p, simd, stack).0,
    )
}

#[cfg(test)]
mod tests;
