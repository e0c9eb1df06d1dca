//! Walk tests on synthetic tetrahedralizations, judged by the exact referee
//! (`crate::referee`, docs/referee.md), which shares no code with the walk.
//!
//! By subject: `exits.rs` (every method's exit faces and agreement with brute force),
//! `robust.rs` (the robust and exact walks on degenerate rays); the referee-judged casts both
//! use (the GPU tests too) are here.

use super::*;
use crate::geom::predicates::orient;
use crate::mesh::build::OUTWARD_FACES;
use crate::referee::{self, Outcome, Verdict};
use crate::scene::{CastOptions, HitsOut, Rays, Scene};
use crate::status::{FAILED, HIT, MISS};

mod exits;
mod robust;

// The GPU tests judge their kernels with it too.
#[cfg(feature = "gpu")]
pub(crate) use robust::assert_between_touch_and_inside;

pub(crate) use crate::testing::{all_faces, grid_scene, kuhn_grid, random_scene, GridScene, Rng};

/// The referee's verdicts for rays given flat (`3 k ..`), over `[0, ∞)` as [`cast`] casts them.
pub(crate) fn verdicts(o: &[f64], d: &[f64], tris: &[[[f64; 3]; 3]]) -> Vec<Option<Verdict>> {
    use rayon::prelude::*;
    (0..o.len() / 3)
        .into_par_iter()
        .map(|k| {
            let p = |v: &[f64]| [v[3 * k], v[3 * k + 1], v[3 * k + 2]];
            referee::first_hit(p(o), p(d), 0.0, f64::INFINITY, tris)
        })
        .collect()
}

/// How many rays of a cast the referee finds right, and how each other one went
/// (docs/referee.md's outcomes).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Tally {
    pub right: usize,
    pub failed: usize,
    pub leaked: usize,
    pub late: usize,
    pub wrong: usize,
    /// Of `wrong`: a tied triangle, with `t` outside `ulp(t*) + B`.
    pub t_off: usize,
}

impl Tally {
    pub fn bad(&self) -> usize {
        self.failed + self.leaked + self.late + self.wrong
    }
}

/// Judges a cast (status, triangle and `t` per ray; `t` of the output type `R`) against the
/// verdicts, printing the first few rays that are not right under `name`.
pub(crate) fn tally<R: Real>(
    name: &str,
    verdicts: &[Option<Verdict>],
    status: &[u8],
    tri: &[i32],
    t: &[R],
) -> Tally {
    let precision = if R::NAME == "f32" {
        referee::Precision::F32
    } else {
        referee::Precision::F64
    };
    let mut c = Tally::default();
    for (k, v) in verdicts.iter().enumerate() {
        let hit = (status[k] == HIT).then(|| (tri[k] as usize, t[k].to_f64()));
        let out = referee::judge(v.as_ref(), status[k] == FAILED, hit, precision);
        match out {
            Outcome::Right => c.right += 1,
            Outcome::Failed => c.failed += 1,
            Outcome::Leaked => c.leaked += 1,
            Outcome::Late => c.late += 1,
            Outcome::Wrong => {
                c.wrong += 1;
                let tied = v.as_ref().zip(hit).is_some_and(|(v, h)| v.ties_with(h.0));
                c.t_off += tied as usize;
            }
        }
        if out != Outcome::Right && c.bad() <= 5 {
            eprintln!(
                "{name}: ray {k} {out:?}: referee {v:?}, cast status {} triangle {} t {:?}",
                status[k], tri[k], t[k]
            );
        }
    }
    c
}

struct Cast<R> {
    t: Vec<R>,
    u: Vec<R>,
    v: Vec<R>,
    /// Three per ray.
    point: Vec<R>,
    tri: Vec<i32>,
    tet: Vec<i32>,
    status: Vec<u8>,
    steps: Vec<u32>,
    /// Two per ray when the cast was audited ([`cast_audited`]), else empty.
    audit: Vec<u32>,
}

fn cast<R: Real>(
    scene: &Scene,
    o: &[R],
    d: &[R],
    f: impl Fn(&Scene, &Rays<R>, HitsOut<R>) -> crate::Result<()>,
) -> Cast<R> {
    cast_audited(scene, o, d, false, f)
}

/// [`cast`], with the exact audit's column (two counts a ray) when `audit` is set.
fn cast_audited<R: Real>(
    scene: &Scene,
    o: &[R],
    d: &[R],
    audit: bool,
    f: impl Fn(&Scene, &Rays<R>, HitsOut<R>) -> crate::Result<()>,
) -> Cast<R> {
    let n = o.len() / 3;
    let (mut t, mut u, mut v, mut p) = (
        vec![R::ZERO; n],
        vec![R::ZERO; n],
        vec![R::ZERO; n],
        vec![R::ZERO; 3 * n],
    );
    let (mut tri, mut tet, mut steps, mut status) =
        (vec![0; n], vec![0; n], vec![0; n], vec![0; n]);
    let mut counts = vec![0; if audit { 2 * n } else { 0 }];
    let rays = Rays {
        origins: o,
        directions: d,
        tmin: &[0.0],
        tmax: &[f64::INFINITY],
        leaving: None,
    };
    let out = HitsOut {
        t: &mut t,
        u: &mut u,
        v: &mut v,
        point: &mut p,
        triangle: &mut tri,
        tet: &mut tet,
        steps: &mut steps,
        status: &mut status,
        audit: &mut counts,
    };
    f(scene, &rays, out).unwrap();
    Cast {
        t,
        u,
        v,
        point: p,
        tri,
        tet,
        status,
        steps,
        audit: counts,
    }
}
