//! The queries as an accelerator that tests the caller's triangles answers them (a BVH,
//! `accel::reshetov_bvh`), rather than one that walks: it offers every triangle the ray meets
//! at one point within [tmin, tmax], in no particular order, and the query keeps what it asks
//! for ([`Gather`]). Every decision is exact (`geom::exact`): which triangles the ray meets,
//! which of two crossings comes first, which are one point. So the answers are the ones the
//! exact walk gives, whatever order the triangles come in.

use super::contact::{meet_at, Meet};
use crate::geom::exact::{
    beyond, cmp_plane_t, cmp_plane_t_at, cmp_t_at, plane_t_unit, triangle_sides, unit_direction,
};
use crate::geom::ray::{checked_range, Ray};
use std::cmp::Ordering;

/// A triangle's three corners.
pub type Tri = [[f64; 3]; 3];

/// A ray checked for tracing ([`checked_range`]): its numbers and its range, tmin ≥ 0.
///
/// Its [`Span`] (what every query's gatherer keeps of it) and, for a ray started from a hit,
/// the triangle it leaves (what only the triangle tests read). Apart, a gatherer copies 96
/// bytes in a few moves where the whole was a 176-byte library call for every ray.
#[derive(Clone, Copy, Debug)]
pub struct Line {
    pub span: Span,
    /// A ray started from a hit: the corners of the caller's triangle it leaves; it meets
    /// only what lies beyond that triangle's plane ([`beyond`]).
    pub leaving: Option<Tri>,
}

/// A ray's numbers and its range: what ordering and evaluating its meets needs.
#[derive(Clone, Copy, Debug)]
pub struct Span {
    pub o: [f64; 3],
    pub d: [f64; 3],
    /// d scaled by a power of two, 2^-scale (for signs: the filters' operands stay in range;
    /// `plane_t` scales d so too).
    pub dir: [f64; 3],
    pub scale: i32,
    pub tmin: f64,
    pub tmax: f64,
}

impl std::ops::Deref for Line {
    type Target = Span;
    #[inline(always)]
    fn deref(&self) -> &Span {
        &self.span
    }
}

impl Line {
    /// Err: the status of a ray no query traces.
    #[inline(always)]
    pub fn new(ray: &Ray) -> Result<Line, u8> {
        let (tmin, tmax) = checked_range(ray)?;
        Ok(Line::within(ray, tmin, tmax))
    }

    /// The line of `ray` over the range [`checked_range`] gave it.
    #[inline(always)]
    pub fn within(ray: &Ray, tmin: f64, tmax: f64) -> Line {
        let mut line = std::mem::MaybeUninit::uninit();
        Line::write_within(&mut line, ray, tmin, tmax);
        // SAFETY: `write_within` wrote every field.
        unsafe { line.assume_init() }
    }

    /// [`Line::within`] written into `out` field by field, each from the ray's own numbers:
    /// built whole and then moved, the line was assembled on the stack in pieces and moved
    /// with wide reads of them, which waited for those narrow stores to retire (a fifth of
    /// the fan's time on bunny's camera, `perf annotate`).
    #[inline(always)]
    pub fn write_within(out: &mut std::mem::MaybeUninit<Line>, ray: &Ray, tmin: f64, tmax: f64) {
        use std::ptr::addr_of_mut;
        let (dir, scale) = unit_direction(ray.d);
        let p = out.as_mut_ptr();
        // SAFETY: `p` points to `out`'s storage, valid for writes; every field is written
        // once, through a raw pointer (no reference to the uninitialized whole).
        unsafe {
            addr_of_mut!((*p).span.o).write(ray.o);
            addr_of_mut!((*p).span.d).write(ray.d);
            addr_of_mut!((*p).span.dir).write(dir);
            addr_of_mut!((*p).span.scale).write(scale);
            addr_of_mut!((*p).span.tmin).write(tmin);
            addr_of_mut!((*p).span.tmax).write(tmax);
            addr_of_mut!((*p).leaving).write(ray.leaving.map(|l| l.corners));
        }
    }

    /// Whether the ray meets the closed triangle `tri` at one point with t in [tmin, tmax]:
    /// its three side products are all ≥ 0 or all ≤ 0 and not all zero (all zero: the line
    /// lies in the triangle's plane, or the triangle has no area), each sign exact.
    #[inline]
    pub fn meets(&self, tri: &Tri) -> bool {
        self.meets_at(tri).is_some()
    }

    /// [`Line::meets`], with the float64 crossing `plane_t` gave on the way (t and its
    /// certified error bound: what [`Gather::offer`] orders by before anything exact).
    #[inline]
    pub fn meets_at(&self, tri: &Tri) -> Option<(f64, f64)> {
        let s = triangle_sides(self.dir, self.o, tri);
        let (pos, neg) = (s.iter().any(|&x| x > 0), s.iter().any(|&x| x < 0));
        if pos == neg {
            return None;
        }
        self.crosses_at(tri)
    }

    /// [`Line::meets_at`] for a triangle whose side products are known to have one sign (all
    /// ≥ 0 or all ≤ 0, not all zero: the line meets its plane at one point of the closed
    /// triangle), as a leaf filter that certified all three found: whether that point's t
    /// lies in [tmin, tmax] (and beyond the triangle a ray leaves), with `plane_t`'s crossing.
    #[inline(always)]
    pub fn crosses_at(&self, tri: &Tri) -> Option<(f64, f64)> {
        let o = self.o;
        // Exact t against [tmin, tmax] (tmin ≥ 0 also rules out crossings behind the origin),
        // the float crossing deciding where it is farther from the bound than its error.
        let at = plane_t_unit(o, self.dir, self.scale, tri);
        let inside = cmp_t_at(o, self.d, tri, self.tmin, at) != Ordering::Less
            && !(self.tmax.is_finite()
                && cmp_t_at(o, self.d, tri, self.tmax, at) == Ordering::Greater)
            && self
                .leaving
                .is_none_or(|from| beyond(o, self.d, self.dir, &from, tri));
        inside.then_some(at)
    }
}

impl Span {
    /// Which of two triangles the ray meets first: the sign of t1 − t2, exactly.
    #[inline]
    pub fn cmp(&self, tri1: &Tri, tri2: &Tri) -> Ordering {
        cmp_plane_t(self.o, self.d, tri1, tri2)
    }

    /// The point where the ray meets triangle `id` (corners `tri`): t, (u, v), the triangle.
    pub fn meet(&self, tri: &Tri, id: u32) -> Meet {
        meet_at(
            self.o,
            self.d,
            self.tmin,
            self.tmax,
            tri,
            id,
            [id, u32::MAX, u32::MAX],
        )
    }

    /// An upper bound on the exact t of a crossing [`plane_t_unit`] gave (`at`: its float64 t
    /// and certified error), at most tmax (tmax where the bound is not finite).
    #[inline]
    pub fn above(&self, (t, err): (f64, f64)) -> f64 {
        // Twice the certified error: the sum's own rounding is within the bound's slack.
        let above = t + 2.0 * err;
        if above.is_finite() {
            above.min(self.tmax)
        } else {
            self.tmax
        }
    }
}

/// What a query keeps of the triangles an accelerator offers.
pub trait Gather {
    /// An upper bound on the t still wanted: the accelerator may skip whatever lies beyond.
    fn reach(&self) -> f64;
    /// Takes triangle `id` (the caller's numbering), which the ray meets at one point within
    /// [tmin, tmax] ([`Line::meets`]), with its corners (`tri`, the same numbers as the
    /// caller's triangle `id`: an accelerator's copy, just read, so a gatherer that keeps or
    /// compares them reads them from the cache rather than from the caller's array) and the
    /// float crossing [`Line::meets_at`] gave (a gatherer that orders may decide by it where it
    /// is certain); true: the answer is settled, offer no more. Every accelerator offers
    /// through this one method (an `offer(id)` beside it was left with no caller).
    fn offer(&mut self, id: u32, tri: &Tri, at: (f64, f64)) -> bool;
    /// Triangle `id`, tested and not met at one point (its plane may hold the line: the
    /// query decides); true: the answer is settled, offer no more. Only the exact BVH tells
    /// (its leaves and the fan), and only the ray-parity gatherer asks; for the others this
    /// default is inlined to `false` and costs nothing.
    #[inline(always)]
    fn in_plane(&mut self, _id: u32) -> bool {
        false
    }
}

/// Closest hit: the triangle with the smallest exact t (ties: the smallest id, as the walk).
pub struct Nearest {
    pub line: Span,
    pub best: Option<u32>,
    /// The best's corners (meaningful when `best` is set): kept as offered, so that the
    /// comparisons with later offers and the hit's evaluation do not fetch them again from
    /// the caller's array, where incoherent rays find them out of the cache.
    pub best_tri: Tri,
    /// The best's float crossing (t, error bound).
    best_at: (f64, f64),
    reach: f64,
}

impl Nearest {
    #[inline(always)]
    pub fn new(line: &Line) -> Self {
        Nearest {
            line: line.span,
            best: None,
            best_tri: [[f64::NAN; 3]; 3],
            best_at: (f64::NAN, f64::INFINITY),
            reach: line.tmax,
        }
    }

    /// The point kept, if any.
    pub fn meet(&self) -> Option<Meet> {
        self.best.map(|id| self.line.meet(&self.best_tri, id))
    }
}

impl Gather for Nearest {
    #[inline]
    fn reach(&self) -> f64 {
        self.reach
    }

    #[inline]
    fn offer(&mut self, id: u32, tri: &Tri, at: (f64, f64)) -> bool {
        // Surely beyond the best's exact t (reach bounds it from above): not better. Where
        // err is not finite, t − err is −∞ or NaN and the exact comparison decides (a finite
        // err bounds 4ε|t|, so t is finite wherever err is).
        let (t, err) = at;
        if self.best.is_some() && t - err > self.reach {
            return false;
        }
        let better = match self.best {
            None => true,
            Some(b) => {
                match cmp_plane_t_at(
                    self.line.o,
                    self.line.d,
                    tri,
                    &self.best_tri,
                    at,
                    self.best_at,
                ) {
                    Ordering::Less => true,
                    Ordering::Equal => id < b,
                    Ordering::Greater => false,
                }
            }
        };
        if better {
            self.best = Some(id);
            self.best_tri = *tri;
            self.best_at = at;
            self.reach = self.line.above(at);
        }
        false
    }
}

/// Any hit: the first triangle offered settles it.
#[derive(Default)]
pub struct Found {
    pub found: bool,
    pub tmax: f64,
}

impl Gather for Found {
    #[inline]
    fn reach(&self) -> f64 {
        self.tmax
    }

    #[inline]
    fn offer(&mut self, _: u32, _: &Tri, _: (f64, f64)) -> bool {
        self.found = true;
        true
    }
}

/// All hits: each distinct point once (triangles met at the same exact t meet the ray at the
/// same point), named by the smallest id met there.
pub struct Every<'a> {
    pub line: Span,
    pub triangles: &'a [Tri],
    pub ids: Vec<u32>,
}

impl<'a> Every<'a> {
    pub fn new(line: &Line, triangles: &'a [Tri]) -> Self {
        Every {
            line: line.span,
            triangles,
            ids: Vec::new(),
        }
    }

    /// The points in order of t.
    pub fn meets(&mut self) -> Vec<Meet> {
        let (line, tris) = (self.line, self.triangles);
        self.ids
            .sort_by(|&a, &b| line.cmp(&tris[a as usize], &tris[b as usize]));
        self.ids
            .iter()
            .map(|&id| line.meet(&tris[id as usize], id))
            .collect()
    }
}

impl Gather for Every<'_> {
    #[inline]
    fn reach(&self) -> f64 {
        self.line.tmax
    }

    fn offer(&mut self, id: u32, tri: &Tri, _: (f64, f64)) -> bool {
        let (line, tris) = (self.line, self.triangles);
        match self
            .ids
            .iter_mut()
            .find(|k| line.cmp(tri, &tris[**k as usize]) == Ordering::Equal)
        {
            Some(k) => *k = (*k).min(id),
            None => self.ids.push(id),
        }
        false
    }
}
