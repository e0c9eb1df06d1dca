//! The query policies on synthetic scenes, judged by the exact referee (`crate::referee`) and
//! by counting exact crossings: closest hit and any hit agree with it, and a policy that walks
//! on through every constrained face meets each triangle the ray crosses once.

use super::*;
use crate::layout::{LayoutKind, Tet32};
use crate::referee;
use crate::scene::{CastOptions, HitBuffers, Rays, Scene};
use crate::status::{HIT, INVALID, MISS};
use crate::testing::{exact_case_rays, random_scene, Rng};
use crate::traverse::{
    walk_with, Aman2022, ExitMethod, Method, NoObserver, Robust, WalkEnd, WalkSetup,
};
use std::cmp::Ordering;

mod closest_order;
mod fields;
#[cfg(feature = "fuzz")]
mod fuzz_cases;
mod grazing;
mod lanes;
mod policies;
mod reach;
mod surface_only;

/// A sink says it is empty exactly when it holds no entry (`Sink::is_empty`, the trait's
/// default, which no cast asks: the trait keeps it beside `len`, as clippy asks of a `len`).
#[test]
fn a_sink_is_empty_exactly_when_it_holds_no_entry() {
    let mut status = [0u8; 3];
    let all: &mut [u8] = &mut status;
    assert!(!Sink::<u8>::is_empty(&all));
    let (none, rest) = Sink::<u8>::split_at(all, 0);
    assert!(Sink::<u8>::is_empty(&none));
    let (one, none) = Sink::<u8>::split_at(rest, 3);
    assert!(!Sink::<u8>::is_empty(&one) && Sink::<u8>::is_empty(&none));
}

/// A jittered Kuhn grid with a random third of its interior faces constrained.
fn grid_scene(seed: u64) -> (Scene, Vec<[[f64; 3]; 3]>) {
    random_scene(&mut Rng::xorshift(seed), 4, 0.3)
}

/// Random rays: origins in and around the unit box, directions uniform-ish, all float32-exact.
fn random_rays(rng: &mut Rng, n: usize) -> (Vec<f64>, Vec<f64>) {
    let q = |x: f64| (x * 1024.0).round() / 1024.0;
    let o = (0..3 * n).map(|_| q(rng.f() * 1.6 - 0.3)).collect();
    let d = (0..3 * n).map(|_| q(rng.f() - 0.5)).collect();
    (o, d)
}
