//! Containment of points on the device (`Scene::contains`'s parity rule): the contains kernel
//! (`shaders/walks/contains.wgsl`) locates each float32 point on certified orientations and
//! answers from its tet's region parity, or outside the box; a point it cannot certify (on or
//! near a face, where it may lie on the surface) is answered by the host's
//! `Containment::point`. Every answer is the CPU's.

use super::cast::OnDevice;
use super::device_scene::DeviceScene;
use super::kernels::CONTAINS;
use super::launch::{Batching, Launch};
use super::origin::locate_uniform;
use super::structs::{RayOut, END_UNBEGUN};
use super::timings::GpuTimings;
use super::upload::upload_records;
use crate::error::Result;
use crate::query::contains::check;
use crate::scene::{CastOptions, Scene, CHUNK};
use crate::threads::run_pieces;
use std::time::Instant;

/// `RayOut::end` of the contains kernel: the point is outside, inside.
pub const CONTAINS_OUT: u32 = 8;
pub const CONTAINS_IN: u32 = 9;

impl DeviceScene {
    /// Containment of float32 points (`points`: x y z of each, 3N values) on the GPU:
    /// `out[i]` as [`Scene::contains`] answers for point i. Returns the phases' seconds
    /// (`walked`: points the kernel ran on; `deferred`: those the host answered).
    pub fn contains(
        &self,
        scene: &Scene,
        points: &[f32],
        out: &mut [bool],
        threads: Option<usize>,
    ) -> Result<GpuTimings> {
        self.contains_with(scene, points, out, threads, Batching::default())
    }

    /// [`DeviceScene::contains`] with a given batching.
    pub(crate) fn contains_with(
        &self,
        scene: &Scene,
        points: &[f32],
        out: &mut [bool],
        threads: Option<usize>,
        batching: Batching,
    ) -> Result<GpuTimings> {
        check(points.len(), out.len(), threads)?;
        let t0 = Instant::now();
        let containment = scene.containment();
        let opts = CastOptions {
            threads,
            ..Default::default()
        };
        self.on_device(scene, &CONTAINS, &opts, batching, |device, timings| {
            let Some(uniform) = locate_uniform(scene, device.scene.points_slack) else {
                // Coordinates beyond the filter's range: every point is the host's.
                return containment.points(points, out, threads);
            };
            let g = device.g;
            let (locate, locate_upload) = self.locate_table(g, scene)?;
            let parity = containment.parity;
            let (bits, bits_upload) = self.parity_bits(g, || {
                let words = scene.mesh.len().div_ceil(32);
                upload_records(g, "region parity", words, |k| parity.word32(k))
            })?;
            timings.scene_upload += locate_upload + bits_upload;
            timings.locate = t0.elapsed().as_secs_f64() - locate_upload - bits_upload;
            let uniform = super::structs::Shared {
                beyond_at: locate.beyond_at,
                ..uniform
            };
            let extra = [(10, &locate.buffer), (11, &*bits)];
            let host = |p: [f64; 3], rng: &mut u32| containment.point(p, rng);
            run(
                device,
                (uniform, &extra),
                (points, out),
                threads,
                timings,
                host,
            )
        })
    }
}

/// The contains kernel over every point, batch by batch; each batch's answers written where
/// they lie (in pieces of [`CHUNK`] points on the pool's threads), the points the kernel
/// handed back answered by `host`.
fn run(
    device: &OnDevice,
    (uniform, extra): (super::structs::Shared, &[(u32, &wgpu::Buffer)]),
    (points, out): (&[f32], &mut [bool]),
    threads: Option<usize>,
    timings: &mut GpuTimings,
    host: impl Fn([f64; 3], &mut u32) -> bool + Sync,
) -> Result<()> {
    let launch = Launch {
        g: device.g,
        pipeline: device.pipeline,
        scene: device.scene,
        max_steps: device.max_steps,
        batching: device.batching,
        cache: device.cache,
        input_binding: 6,
        shared: Some(uniform),
        extra,
        camera: None,
        origins: None,
    };
    let n = out.len();
    timings.walked = n;
    let pts: &[[f32; 3]] = bytemuck::cast_slice(points);
    let mut handed = 0;
    launch.run(&[pts], n, timings, |before, results: &[RayOut]| {
        let count = results.iter().filter(|r| r.end == END_UNBEGUN).count();
        handed += count;
        let pieces: Vec<_> = out[before..before + results.len()]
            .chunks_mut(CHUNK)
            .zip(results.chunks(CHUNK))
            .zip(pts[before..].chunks(CHUNK))
            .enumerate()
            .collect();
        run_pieces(pieces, threads, |(k, ((o, r), p))| {
            // A nonzero xorshift seed per piece (the host walk's random face order).
            let mut rng = 0x9E37_79B9u32 ^ (k as u32).wrapping_mul(0x85EB_CA6B) | 1;
            for ((slot, r), p) in o.iter_mut().zip(r).zip(p) {
                *slot = match r.end {
                    CONTAINS_IN => true,
                    CONTAINS_OUT => false,
                    _ => host(p.map(f64::from), &mut rng),
                };
            }
        })
    })?;
    timings.deferred = handed;
    Ok(())
}
