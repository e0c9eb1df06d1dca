//! A cast's inputs and outputs as flat slices (what numpy hands over), and the owned buffers
//! a caller without numpy allocates.

use crate::error::{try_zeroed_vec, Error, Result};
use crate::geom::ray::{Leaving, Ray};
use crate::geom::real::Real;
use crate::query::{RayHit, Sink};
use crate::status::{HIT, INVALID};

/// Rays as flat slices of length 3N (origins, directions) in the walk's precision.
pub struct Rays<'a, R> {
    pub origins: &'a [R],
    pub directions: &'a [R],
    /// One value for all rays, or one per ray.
    pub tmin: &'a [f64],
    pub tmax: &'a [f64],
    /// For rays started from hits (`start=hits`): what each leaves.
    pub leaving: Option<LeavingRays<'a>>,
}

/// Per ray, the caller's triangle a ray started from a hit leaves (−1: none, an ordinary ray)
/// and the tet that hit's walk ended in (−1: none), with the triangles the ids index.
#[derive(Clone, Copy)]
pub struct LeavingRays<'a> {
    pub triangles: &'a [[[f64; 3]; 3]],
    pub triangle: &'a [i32],
    pub tet: &'a [i32],
}

impl LeavingRays<'_> {
    /// Refuses ids out of range and lengths other than `n`; `n_tets`: the scene's tet count.
    pub fn check(&self, n: usize, n_tets: usize) -> Result<()> {
        if self.triangle.len() != n || self.tet.len() != n {
            return Err(Error::InvalidInput(format!(
                "{n} rays started from hits need {n} hit triangles and tets, got {} and {}",
                self.triangle.len(),
                self.tet.len()
            )));
        }
        let bad = |ids: &[i32], limit: usize| {
            ids.iter().position(|&k| k < -1 || k as i64 >= limit as i64)
        };
        if let Some(i) = bad(self.triangle, self.triangles.len()) {
            return Err(Error::InvalidInput(format!(
                "ray {i} starts from triangle {} but the scene has {} triangles (hits of \
                 another scene?)",
                self.triangle[i],
                self.triangles.len()
            )));
        }
        if let Some(i) = bad(self.tet, n_tets) {
            return Err(Error::InvalidInput(format!(
                "ray {i} starts from tet {} but the scene has {n_tets} tets (hits of another \
                 scene?)",
                self.tet[i]
            )));
        }
        Ok(())
    }

    #[inline]
    fn of(&self, i: usize) -> Option<Leaving> {
        let k = self.triangle[i];
        (k >= 0).then(|| Leaving {
            triangle: k as u32,
            corners: self.triangles[k as usize],
            tet: u32::try_from(self.tet[i]).unwrap_or(u32::MAX),
        })
    }
}

impl<R: Real> Rays<'_, R> {
    /// Ray i in float64 (exact from float32).
    #[inline(always)]
    pub fn ray(&self, i: usize) -> Ray {
        let at = |b: &[f64]| b[if b.len() == 1 { 0 } else { i }];
        // Each point sliced once: one bounds check for its three components, not three.
        let three = |b: &[R]| -> [f64; 3] {
            let p: &[R; 3] = b[3 * i..3 * i + 3].try_into().unwrap();
            p.map(|x| x.to_f64())
        };
        Ray {
            o: three(self.origins),
            d: three(self.directions),
            tmin: at(self.tmin),
            tmax: at(self.tmax),
            leaving: self.leaving.as_ref().and_then(|l| l.of(i)),
        }
    }

    pub fn len(&self) -> usize {
        self.origins.len() / 3
    }

    pub fn is_empty(&self) -> bool {
        self.origins.is_empty()
    }
}

/// Output slices, one entry per ray (`point` has 3 per ray).
pub struct HitsOut<'a, R> {
    pub t: &'a mut [R],
    pub u: &'a mut [R],
    pub v: &'a mut [R],
    pub point: &'a mut [R],
    pub triangle: &'a mut [i32],
    pub tet: &'a mut [i32],
    pub steps: &'a mut [u32],
    pub status: &'a mut [u8],
    /// Empty, or two per ray to audit every step (see [`ExactAudit`]): exit faces taken that
    /// the exact predicates reject, and steps where the method found no exit face.
    pub audit: &'a mut [u32],
}

impl<'a, R> HitsOut<'a, R> {
    pub fn len(&self) -> usize {
        self.t.len()
    }

    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// Writes entry j: the hit of `ray` (its values rounded to the rays' precision: from
    /// float64 values within an ulp of the exact ones, still within an ulp).
    #[inline(always)]
    pub fn set(&mut self, j: usize, r: &RayHit)
    where
        R: Real,
    {
        let t = R::from_f64(r.t);
        // A hit whose t is beyond the rays' precision (a direction so short that t
        // overflows): no finite t would be true, so the ray is INVALID, not a HIT at inf.
        let status = if r.status == HIT && !t.to_f64().is_finite() {
            INVALID
        } else {
            r.status
        };
        self.t[j] = t;
        self.u[j] = R::from_f64(r.u);
        self.v[j] = R::from_f64(r.v);
        for a in 0..3 {
            self.point[3 * j + a] = R::from_f64(if status == HIT { r.point[a] } else { f64::NAN });
        }
        self.triangle[j] = if status == r.status { r.triangle } else { -1 };
        self.tet[j] = r.tet;
        self.steps[j] = r.steps;
        self.status[j] = status;
    }

    pub fn split_at(self, n: usize) -> (Self, Self) {
        let (t0, t1) = self.t.split_at_mut(n);
        let (u0, u1) = self.u.split_at_mut(n);
        let (v0, v1) = self.v.split_at_mut(n);
        let (p0, p1) = self.point.split_at_mut(3 * n);
        let (tr0, tr1) = self.triangle.split_at_mut(n);
        let (te0, te1) = self.tet.split_at_mut(n);
        let (s0, s1) = self.steps.split_at_mut(n);
        let (st0, st1) = self.status.split_at_mut(n);
        let (au0, au1) = self
            .audit
            .split_at_mut(if self.audit.is_empty() { 0 } else { 2 * n });
        (
            HitsOut {
                t: t0,
                u: u0,
                v: v0,
                point: p0,
                triangle: tr0,
                tet: te0,
                steps: s0,
                status: st0,
                audit: au0,
            },
            HitsOut {
                t: t1,
                u: u1,
                v: v1,
                point: p1,
                triangle: tr1,
                tet: te1,
                steps: s1,
                status: st1,
                audit: au1,
            },
        )
    }
}

/// Closest-hit answers (and with a non-empty `audit`, the audit's two counts per ray).
impl<R: Real + Send> Sink<RayHit> for HitsOut<'_, R> {
    fn len(&self) -> usize {
        self.t.len()
    }
    fn split_at(self, n: usize) -> (Self, Self) {
        HitsOut::split_at(self, n)
    }
    // Inlined into the accelerators' loops: as a call, each answer (about 100 bytes) went
    // through memory.
    #[inline(always)]
    fn put(&mut self, j: usize, r: RayHit) {
        self.set(j, &r);
        if !self.audit.is_empty() {
            self.audit[2 * j..2 * j + 2].copy_from_slice(&r.audit);
        }
    }
}

/// Owned output buffers for N rays: what tests and Rust callers allocate, and lend as
/// [`HitsOut`] to a cast.
#[derive(Clone, Debug)]
pub struct HitBuffers<R> {
    pub t: Vec<R>,
    pub u: Vec<R>,
    pub v: Vec<R>,
    pub point: Vec<R>,
    pub triangle: Vec<i32>,
    pub tet: Vec<i32>,
    pub steps: Vec<u32>,
    pub status: Vec<u8>,
    pub audit: Vec<u32>,
}

impl<R: Real> HitBuffers<R> {
    /// Buffers for `n` rays; with `audit`, two audit counts per ray.
    pub fn new(n: usize, audit: bool) -> Self {
        HitBuffers {
            t: vec![R::ZERO; n],
            u: vec![R::ZERO; n],
            v: vec![R::ZERO; n],
            point: vec![R::ZERO; 3 * n],
            triangle: vec![0; n],
            tet: vec![0; n],
            steps: vec![0; n],
            status: vec![0; n],
            audit: vec![0; if audit { 2 * n } else { 0 }],
        }
    }

    /// [`HitBuffers::new`], or [`Error::OutOfMemory`] with the bytes all of them need when
    /// they cannot be allocated (the ray count is the caller's).
    pub fn try_new(n: usize, audit: bool) -> Result<Self> {
        let r = std::mem::size_of::<R>();
        let per_ray = 6 * r + 3 * 4 + 1 + if audit { 8 } else { 0 };
        let oom = |_| Error::OutOfMemory {
            bytes: n.saturating_mul(per_ray),
            what: format!("the hits of {n} rays"),
        };
        let what = "hits";
        Ok(HitBuffers {
            t: try_zeroed_vec(n, what).map_err(oom)?,
            u: try_zeroed_vec(n, what).map_err(oom)?,
            v: try_zeroed_vec(n, what).map_err(oom)?,
            point: try_zeroed_vec(n.saturating_mul(3), what).map_err(oom)?,
            triangle: try_zeroed_vec(n, what).map_err(oom)?,
            tet: try_zeroed_vec(n, what).map_err(oom)?,
            steps: try_zeroed_vec(n, what).map_err(oom)?,
            status: try_zeroed_vec(n, what).map_err(oom)?,
            audit: try_zeroed_vec(if audit { n.saturating_mul(2) } else { 0 }, what)
                .map_err(oom)?,
        })
    }

    pub fn out(&mut self) -> HitsOut<'_, R> {
        HitsOut {
            t: &mut self.t,
            u: &mut self.u,
            v: &mut self.v,
            point: &mut self.point,
            triangle: &mut self.triangle,
            tet: &mut self.tet,
            steps: &mut self.steps,
            status: &mut self.status,
            audit: &mut self.audit,
        }
    }
}

/// `rays` holds the origins and directions of `n` rays (3 values each).
pub fn check_ray_count<R>(rays: &Rays<R>, n: usize) -> Result<()> {
    if rays.origins.len() != 3 * n || rays.directions.len() != 3 * n {
        return Err(Error::InvalidInput(format!(
            "{} rays expected 3N origin and direction values, got {} and {}",
            n,
            rays.origins.len(),
            rays.directions.len()
        )));
    }
    Ok(())
}

/// Rays and outputs of one cast have matching lengths (the audit: empty or 2 per ray).
pub fn check_lengths<R>(rays: &Rays<R>, out: &HitsOut<R>) -> Result<()> {
    let n = out.len();
    if rays.origins.len() != 3 * n || rays.directions.len() != 3 * n || out.point.len() != 3 * n {
        return Err(Error::InvalidInput(format!(
            "{} rays expected 3N origin and direction values, got {} and {}",
            n,
            rays.origins.len(),
            rays.directions.len()
        )));
    }
    for (name, b) in [("tmin", rays.tmin), ("tmax", rays.tmax)] {
        if b.len() != 1 && b.len() != n {
            return Err(Error::InvalidInput(format!(
                "{name} needs 1 or {n} values, got {}",
                b.len()
            )));
        }
    }
    if !out.audit.is_empty() && out.audit.len() != 2 * n {
        return Err(Error::InvalidInput(format!(
            "the audit needs 2 values per ray ({}), got {}",
            2 * n,
            out.audit.len()
        )));
    }
    Ok(())
}

/// The unit geometric normal of each triangle, `cross(p1 − p0, p2 − p0)` normalized (NaN for
/// a zero-area triangle), into `out[..faces.len()]`, and a NaN row after them (a miss's, for
/// [`take_rows`]); on the pool's threads. Each row is numpy's `np.cross` and
/// `np.linalg.norm` of the same numbers bit for bit (the same products, differences and sums
/// in the same order), which `Scene.normals` computed before (17 ms on bunny's 69,451
/// triangles, most of a first cast's time after the BVH). A face naming no vertex is
/// [`Error::InvalidInput`].
pub fn triangle_normals(
    vertices: &[[f64; 3]],
    faces: &[[i64; 3]],
    out: &mut [[f64; 3]],
    threads: Option<usize>,
) -> Result<()> {
    const PIECE: usize = 1 << 14;
    if out.len() != faces.len() + 1 {
        return Err(Error::InvalidInput(format!(
            "triangle_normals: {} rows for {} faces and the NaN row",
            out.len(),
            faces.len()
        )));
    }
    let (rows, nan) = out.split_at_mut(faces.len());
    nan[0] = [f64::NAN; 3];
    let n = vertices.len();
    let fill = |(o, f): (&mut [[f64; 3]], &[[i64; 3]])| -> std::result::Result<(), i64> {
        for (o, face) in o.iter_mut().zip(f) {
            let [p0, p1, p2] = face.map(|v| {
                usize::try_from(v)
                    .ok()
                    .filter(|&v| v < n)
                    .map(|v| vertices[v])
                    .ok_or(v)
            });
            let (p0, p1, p2) = (p0?, p1?, p2?);
            let a = [0, 1, 2].map(|k| p1[k] - p0[k]);
            let b = [0, 1, 2].map(|k| p2[k] - p0[k]);
            let c = [
                a[1] * b[2] - a[2] * b[1],
                a[2] * b[0] - a[0] * b[2],
                a[0] * b[1] - a[1] * b[0],
            ];
            let length = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
            *o = if length > 0.0 {
                c.map(|x| x / length)
            } else {
                [f64::NAN; 3]
            };
        }
        Ok(())
    };
    in_pieces(rows, faces, PIECE, threads, fill)?.map_err(|v| {
        Error::InvalidInput(format!(
            "a face names vertex {v}, outside 0..{n} (triangle_normals)"
        ))
    })
}

/// `out[i] = rows[index[i]]`, with index −1 taking the last row (a miss's triangle −1 takes the
/// NaN row that follows the triangles' normals), on the pool's threads: a hit's normal for
/// millions of rays in one parallel pass instead of numpy's `take` on one thread. An index
/// outside [−1, rows − 1) is [`Error::InvalidInput`] naming one (what `out` then holds is
/// unspecified).
pub fn take_rows<T: Copy + Send + Sync>(
    rows: &[[T; 3]],
    index: &[i32],
    out: &mut [[T; 3]],
    threads: Option<usize>,
) -> Result<()> {
    const PIECE: usize = 1 << 15;
    let last = rows.len().checked_sub(1).ok_or_else(|| {
        Error::InvalidInput("take_rows needs at least one row (the miss's)".into())
    })?;
    if index.len() != out.len() {
        return Err(Error::InvalidInput(format!(
            "take_rows: {} indices for {} output rows",
            index.len(),
            out.len()
        )));
    }
    // Checked as it goes: one read of the indices, not two.
    let fill = |(o, ix): (&mut [[T; 3]], &[i32])| {
        for (o, &i) in o.iter_mut().zip(ix) {
            // A miss (-1) takes the last row, chosen without a branch: hits and misses mix
            // (a random ray misses two times in three), and a branch on it mispredicted.
            if !(i == -1 || (i as u32 as usize) < last) {
                return Err(i);
            }
            *o = rows[if i < 0 { last } else { i as usize }];
        }
        Ok(())
    };
    in_pieces(out, index, PIECE, threads, fill)?
        .map_err(|i| Error::InvalidInput(format!("take_rows: index {i} is outside [-1, {last})")))
}

/// `fill` over matching pieces of `out` and `input` (`piece` entries of `out` for `piece` of
/// `input`) on the pool's threads, or at once on this thread when there is one piece; the
/// first piece's error, if any (the pool's own failure is the outer error).
fn in_pieces<O: Send, I: Sync, E: Send>(
    out: &mut [O],
    input: &[I],
    piece: usize,
    threads: Option<usize>,
    fill: impl Fn((&mut [O], &[I])) -> std::result::Result<(), E> + Send + Sync,
) -> Result<std::result::Result<(), E>> {
    use rayon::prelude::*;
    if input.len() <= piece {
        return Ok(fill((out, input)));
    }
    crate::threads::install(threads, || {
        out.par_chunks_mut(piece)
            .zip(input.par_chunks(piece))
            .try_for_each(fill)
    })
}

#[cfg(test)]
mod tests {
    use super::take_rows;
    use crate::error::Error;

    /// Every output row is its index's row (−1: the last), across pieces and thread counts;
    /// an index past the triangles (the miss row's own index too) or below −1 is refused.
    #[test]
    fn take_rows_is_the_indexed_gather() {
        let rows: Vec<[f64; 3]> = (0..7).map(|i| [i as f64, -(i as f64), 0.5]).collect();
        let n = 100_001;
        let index: Vec<i32> = (0..n).map(|i| (i as i32 * 7919 % 7) - 1).collect();
        for threads in [None, Some(1), Some(2)] {
            let mut out = vec![[f64::NAN; 3]; n];
            take_rows(&rows, &index, &mut out, threads).unwrap();
            for (o, &i) in out.iter().zip(&index) {
                let want = if i < 0 { rows[6] } else { rows[i as usize] };
                assert_eq!(*o, want);
            }
        }
        for bad in [6, -2, i32::MAX, i32::MIN] {
            let mut index = index.clone();
            index[n / 2 + 3] = bad;
            let mut out = vec![[0.0; 3]; n];
            let e = take_rows(&rows, &index, &mut out, None).unwrap_err();
            assert!(matches!(e, Error::InvalidInput(m) if m.contains(&bad.to_string())));
        }
        let mut out = vec![[0.0; 3]; 1];
        assert!(take_rows::<f64>(&[], &[-1], &mut out, None).is_err());
        assert!(take_rows(&rows, &[0, 1], &mut out, None).is_err());
    }
}
