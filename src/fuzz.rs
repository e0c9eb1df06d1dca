//! Fuzzing on stable Rust (issue 18.5): two targets driven by a seed, each case reproducible
//! from its own seed alone, panics caught per case so a failure names the seed.
//!
//! * [`construct_case`](crate::fuzz::construct_case): `Scene::build` / `Scene::build_with` on random point clouds with
//!   random tets, and on valid Kuhn-grid meshes then mutated (indices out of range or
//!   repeated, flipped, flat and duplicate tets, NaN/inf/huge/denormal coordinates, faces that
//!   are no tet face, triangle ids out of range, empty inputs, non-box domains). Every case
//!   must give `Ok` or an [`Error`]; a scene that builds then casts a few rays.
//! * [`walk_case`](crate::fuzz::walk_case): valid generated scenes, rays with random, NaN, inf, zero, denormal and huge
//!   origins and directions, tmin/tmax scalar or per ray (NaN, negative, inverted), every query
//!   kind (closest, any, all hits), rays started from hits (`leaving`, ids valid and not),
//!   every accelerator, both precisions. Invariants: every status is MISS/HIT/FAILED/INVALID;
//!   a HIT has a finite t in [tmin, tmax] and a triangle in range; any hit agrees with the
//!   closest hit; the all-hits list is sorted, inside [tmin, tmax], and its first t is the
//!   closest hit's; the exact accelerators agree on hit or miss; answers do not depend on the
//!   thread count.
//!
//! `cargo test` runs a bounded number of cases of each (`tests` below); `examples/fuzz.rs`
//! runs long ones (docs/fuzzing.md).

mod construction;
mod scenes;
mod walk;

pub use crate::mesh::kuhn::{kuhn_grid, tet_faces};
pub use crate::rng::{mix, Rng};
pub use construction::construct_case;
pub use scenes::{grid_input, BuildInput};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::time::Instant;
// The query tests replay fuzz cases on the walk's scenes.
#[cfg(test)]
pub(crate) use scenes::walk_scene;
pub use walk::walk_case;

/// The seed of case `i` of a run seeded `seed`.
pub fn case_seed(seed: u64, i: u64) -> u64 {
    mix(seed ^ mix(i))
}

/// Odd values a coordinate, direction component or bound may take.
const ODD: [f64; 16] = [
    f64::NAN,
    f64::INFINITY,
    f64::NEG_INFINITY,
    0.0,
    -0.0,
    5e-324,
    -1e-310,
    f64::MIN_POSITIVE,
    1e-300,
    1e300,
    -1e300,
    f64::MAX,
    f64::MIN,
    1e-30,
    1e30,
    3.4e38,
];

/// A coordinate: mostly around the unit box (grid-aligned at times, to meet vertices, edges and
/// faces exactly), sometimes odd.
fn coord(rng: &mut Rng, odd: f64) -> f64 {
    if rng.chance(odd) {
        return rng.pick(&ODD);
    }
    match rng.below(3) {
        0 => -0.5 + 2.0 * rng.f(),
        1 => (rng.below(13) as f64 - 2.0) / 8.0,
        _ => rng.f(),
    }
}

/// Which target a run drives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Target {
    Construct,
    Walk,
}

impl Target {
    pub fn name(self) -> &'static str {
        match self {
            Target::Construct => "construct",
            Target::Walk => "walk",
        }
    }
    pub fn case(self, seed: u64) -> Result<(), String> {
        match self {
            Target::Construct => construct_case(seed),
            Target::Walk => walk_case(seed),
        }
    }
}

/// A failed case: its seed (rerun with [`Target::case`]) and what happened.
#[derive(Clone, Debug)]
pub struct Failure {
    pub seed: u64,
    pub panicked: bool,
    pub message: String,
}

/// What a run did.
#[derive(Clone, Debug, Default)]
pub struct Report {
    pub cases: u64,
    pub panics: u64,
    pub violations: u64,
    pub failures: Vec<Failure>,
    pub seconds: f64,
    /// The slowest case: (seconds, seed).
    pub slowest: (f64, u64),
}

/// Runs cases `first..first + cases` of `target` seeded `seed`, catching panics; keeps the first
/// 20 failures. `progress` is called after each case with the case index and its seed (the
/// example's watchdog reads it).
pub fn run(
    target: Target,
    seed: u64,
    first: u64,
    cases: u64,
    mut progress: impl FnMut(u64, u64),
) -> Report {
    let mut r = Report::default();
    let start = Instant::now();
    for i in first..first + cases {
        let s = case_seed(seed, i);
        let t0 = Instant::now();
        let out = catch_unwind(AssertUnwindSafe(|| target.case(s)));
        let dt = t0.elapsed().as_secs_f64();
        if dt > r.slowest.0 {
            r.slowest = (dt, s);
        }
        r.cases += 1;
        let failure = match out {
            Ok(Ok(())) => None,
            Ok(Err(m)) => {
                r.violations += 1;
                Some((false, m))
            }
            Err(p) => {
                r.panics += 1;
                let m = p
                    .downcast_ref::<String>()
                    .cloned()
                    .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                    .unwrap_or_else(|| "a panic".into());
                Some((true, m))
            }
        };
        if let Some((panicked, message)) = failure {
            if r.failures.len() < 20 {
                r.failures.push(Failure {
                    seed: s,
                    panicked,
                    message,
                });
            }
        }
        progress(i, s);
    }
    r.seconds = start.elapsed().as_secs_f64();
    r
}

#[cfg(test)]
mod tests;
