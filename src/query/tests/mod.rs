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
