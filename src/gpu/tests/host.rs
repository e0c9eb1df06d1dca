//! The host's side of a GPU cast, no GPU needed: where rays start and how they are prepared,
//! the kernel table's names, refusals and limits.

use super::*;
use crate::gpu::kernels::{KernelSpec, KERNELS};
use crate::gpu::structs::NO_ENTRY;

/// Rays entering the box from outside: the aman/maria kernels start them from the entry face,
/// the robust kernel from the settled tet with no entry face (its start-tet search decides the
/// first exit), as the CPU casts do. No GPU needed: this is the host's preparation.
#[test]
fn robust_entries_are_settled_without_an_entry_face() {
    let (scene, _) = grid_scene(6, 0.05, 0.0, 51);
    let (o, d) = rays(2_000, 0.0, 52);
    let n = o.len() / 3;
    let rays = Rays {
        origins: &o,
        directions: &d,
        tmin: &[0.0],
        tmax: &[f64::INFINITY],
        leaving: None,
    };
    let [lo, hi] = scene.mesh.bounds;
    let outside = |i: usize| (0..3).any(|a| !(lo[a]..=hi[a]).contains(&(o[3 * i + a] as f64)));
    for kernel in &KERNELS {
        let settle = kernel.perturbed_start.then_some(&scene.points_f32[..]);
        let mut st = crate::locate::LocateState::seeded(1);
        let (mut entering, mut with_face) = (0, 0);
        for i in 0..n {
            let start = scene.locate_one(&rays, i, settle, &mut st);
            if let (crate::locate::Start::Walk(s), true) = (start, outside(i)) {
                entering += 1;
                let r = (kernel.prepare)(&s, &scene.mesh);
                assert_eq!(r.entry, s.entry.map_or(NO_ENTRY, |f| f as u32));
                assert_eq!(r.tet, s.tet);
                with_face += usize::from(r.entry != NO_ENTRY);
            }
        }
        let name = kernel.name();
        assert!(entering > n / 10, "{name}: {entering} entering rays");
        if kernel.method == "robust" {
            assert_eq!(
                with_face, 0,
                "{name}: {with_face} of {entering} with an entry face"
            );
        } else {
            assert!(
                with_face * 2 > entering,
                "{name}: {with_face} of {entering}"
            );
        }
    }
}

/// The exact audit watches the CPU walk: a GPU cast asked for it is refused, not left empty.
#[test]
fn gpu_cast_refuses_the_audit() {
    let (scene, _) = grid_scene(2, 0.0, 0.0, 41);
    let (o, d) = ([0.5f32; 3], [0.0f32, 0.0, 1.0]);
    let (mut t, mut u, mut v, mut p) = ([0f32; 1], [0f32; 1], [0f32; 1], [0f32; 3]);
    let (mut tri, mut tet, mut steps, mut status, mut audit) = ([0], [0], [0], [0], [0; 2]);
    let rays = Rays {
        origins: &o,
        directions: &d,
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
        audit: &mut audit,
    };
    let opts = CastOptions {
        threads: Some(1),
        max_steps: Some(100),
        ..Default::default()
    };
    let e = cast_gpu(&scene, None, None, &rays, out, &opts).unwrap_err();
    assert!(matches!(e, crate::Error::InvalidOption(_)), "{e}");
}

#[test]
fn unknown_kernel_is_a_clear_error() {
    let e = KernelSpec::find(Some("ms06"), Some("tet32")).unwrap_err();
    assert!(e.to_string().contains("exact/tet20, aman2022/tet20"), "{e}");
    let e = KernelSpec::find(Some("ms06"), None).unwrap_err();
    assert!(
        e.to_string().contains(r#"method "ms06" on layout "tet20""#),
        "{e}"
    );
    let found = |m, l| KernelSpec::find(m, l).unwrap().name();
    assert_eq!(found(None, None), "exact/tet20");
    assert_eq!(found(Some("aman2022"), None), "aman2022/tet20");
    assert_eq!(found(Some("maria2017"), None), "maria2017/tet80");
    assert_eq!(found(Some("robust"), None), "robust/tet20");
    assert_eq!(found(None, Some("tet20")), "exact/tet20");
}

/// The robust kernel's slack: an upper bound on |s − s̃|₁.
#[test]
fn slack_bounds_the_start_point_rounding() {
    let mut rng = Rng::xorshift(1);
    for _ in 0..10_000 {
        let s = [0, 1, 2].map(|_| (rng.f() - 0.5) * 10f64.powi((rng.f() * 12.0) as i32 - 6));
        let sr = s.map(|x| x as f32);
        let e: f64 = (0..3).map(|k| (s[k] - sr[k] as f64).abs()).sum();
        assert!(crate::gpu::upload::slack(s, sr) as f64 >= e);
    }
}

/// A scene buffer beyond the device's limits is refused with TooLarge naming both numbers.
#[test]
fn oversized_scene_is_too_large() {
    let limits = wgpu::Limits::default();
    let ok = crate::gpu::upload::check_fits("tet20 records", 1 << 20, &limits, "test device");
    assert!(ok.is_ok());
    let big = limits.max_storage_buffer_binding_size + 20;
    let e =
        crate::gpu::upload::check_fits("tet20 records", big, &limits, "test device").unwrap_err();
    assert!(matches!(e, crate::Error::TooLarge(_)), "{e}");
    let m = e.to_string();
    assert!(
        m.contains(&big.to_string()) && m.contains("max_storage_buffer_binding_size"),
        "{m}"
    );
}
