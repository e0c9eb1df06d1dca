//! The device's hit finishing (shaders/methods/exact_hit.wgsl) against its CPU twin
//! (`gpu::finish`), function by function: the same hits run through both, alone, in a small
//! kernel. Their error-free sums and products must come out exact on the device as on the CPU
//! (a driver that rewrites them would show here), and every hit the device finishes must be the
//! twin's, bit for bit (the twin's values are checked against the host and the exact referee
//! in `gpu/finish/tests.rs`).

use super::*;
use crate::gpu::finish::{finish_hit, tri_words, two_prod, two_sum, TRI_WORDS};
use crate::gpu::kernels::Wgsl;

const HIT: Wgsl = Wgsl {
    path: "methods/exact_hit.wgsl",
    source: include_str!("../../../shaders/methods/exact_hit.wgsl"),
};

/// Runs `main` (reading `inp`, writing `outp`, `words` f32 words per case) over `n` cases.
fn run_kernel(main: &str, inp: &[f32], n: usize, words: usize) -> Vec<f32> {
    let source = format!(
        "struct Params {{ n_rays: u32, max_steps: u32, _pad0: u32, _pad1: u32 }}\n\
         @group(0) @binding(0) var<uniform> params: Params;\n\
         @group(0) @binding(1) var<storage, read> inp: array<f32>;\n\
         @group(0) @binding(2) var<storage, read_write> outp: array<f32>;\n{}\n{main}",
        HIT.source
    );
    let params = crate::gpu::structs::Params {
        n_rays: n as u32,
        ..Default::default()
    };
    run_harness(&source, "main", bytemuck::bytes_of(&params), inp, n, words)
}

/// TwoSum is exact and the product within its bound on the device, as on the CPU: the same
/// words, bit for bit (the device rounds `+`, `−` and `×` correctly; a driver rewriting the
/// sums algebraically would make the error words 0).
#[test]
fn device_two_sum_and_two_prod_are_the_twins() {
    if !device_or_skip("device two_sum") {
        return;
    }
    let mut rng = Rng::xorshift(5);
    let mut inp = Vec::new();
    let n = 4096;
    for i in 0..n {
        let a = (rng.f() - 0.5) as f32 * 2f32.powi((i % 40) as i32 - 20);
        let b = (rng.f() - 0.5) as f32 * 2f32.powi((i % 17) as i32 - 8);
        inp.extend([a, b]);
    }
    let main = "@compute @workgroup_size(64) fn main(@builtin(global_invocation_id) g: vec3<u32>) {\n\
        let i = g.x; if i >= params.n_rays { return; }\n\
        zero_bits = bitcast<u32>(inp[arrayLength(&inp) - 1u]);\n\
        let s = two_sum(inp[2u * i], inp[2u * i + 1u]);\n\
        let p = two_prod(inp[2u * i], inp[2u * i + 1u]);\n\
        outp[4u * i] = s.hi; outp[4u * i + 1u] = s.lo; outp[4u * i + 2u] = p.hi; outp[4u * i + 3u] = p.lo;\n}";
    let out = run_kernel(main, &inp, n, 4);
    let mut nonzero = 0;
    for i in 0..n {
        let (a, b) = (inp[2 * i], inp[2 * i + 1]);
        let (s, e) = two_sum(a, b);
        let (p, pe) = two_prod(a, b);
        let got = &out[4 * i..4 * i + 4];
        assert_eq!(
            [s, e, p, pe].map(f32::to_bits),
            [got[0], got[1], got[2], got[3]].map(f32::to_bits),
            "two_sum/two_prod({a:e}, {b:e}) on the device"
        );
        nonzero += (e != 0.0) as usize;
    }
    // Not vacuous: most sums of these operands round, and their error words are not 0.
    assert!(nonzero > n / 2, "{nonzero}");
}

/// Hits finished on the device are the twin's, bit for bit, and finished where the twin
/// finishes them (their quotients may differ in the last bit: WGSL divides within 2.5 ulp,
/// the twin correctly; the remainder absorbs it, so both give the same certified values).
#[test]
fn device_finished_hits_are_the_twins() {
    if !device_or_skip("device finish") {
        return;
    }
    let mut rng = Rng::xorshift(8);
    let (mut inp, mut cases) = (Vec::new(), Vec::new());
    for i in 0..6000 {
        let size = [1e-3, 1.0, 50.0][i % 3];
        // Every other case at float64 corners (not float32 numbers), some far from 0.
        let at = [0.0, 0.0, 1000.0, -70.0][i % 4];
        let c = [0, 1, 2].map(|_| at + (rng.f() - 0.5) * 10.0 * size);
        let tri = [0, 1, 2].map(|_| {
            [0, 1, 2].map(|k| {
                let x = c[k] + size * (rng.f() - 0.5);
                if i % 2 == 0 {
                    (x as f32) as f64
                } else {
                    x
                }
            })
        });
        let o = [0, 1, 2].map(|k| (c[k] + size * 20.0 * (rng.f() - 0.5)) as f32);
        let (s, t) = (rng.f() * 0.5, rng.f() * 0.5);
        let d0 = [0, 1, 2].map(|k| {
            let [a, b, cc] = tri.map(|v| v[k]);
            ((a + s * (b - a) + t * (cc - a)) - o[k] as f64) as f32 * [1e-30, 1.0, 1e30][i % 3]
        });
        let top = d0.iter().map(|x| x.to_bits() & 0x7fff_ffff).max().unwrap();
        let k = 127 - (top >> 23) as i32;
        if top >> 23 < 2 || top >> 23 > 253 {
            continue;
        }
        let Some(words) = tri_words(&tri) else {
            continue;
        };
        let d = d0.map(|x| x * f32::from_bits(((k + 127) as u32) << 23));
        inp.extend(o);
        inp.extend(d);
        inp.push(f32::from_bits(k as u32));
        let mut w = [0.0f32; TRI_WORDS];
        for kk in 0..3 {
            w[3 * kk..3 * kk + 3].copy_from_slice(&words.a[kk]);
            w[9 + 2 * kk] = words.e1[kk].hi;
            w[10 + 2 * kk] = words.e1[kk].lo;
            w[15 + 2 * kk] = words.e2[kk].hi;
            w[16 + 2 * kk] = words.e2[kk].lo;
        }
        inp.extend(w);
        cases.push((o, d, k, tri, words));
    }
    let main = "@compute @workgroup_size(64) fn main(@builtin(global_invocation_id) g: vec3<u32>) {\n\
        let i = g.x; if i >= params.n_rays { return; }\n\
        zero_bits = bitcast<u32>(inp[arrayLength(&inp) - 1u]);\n\
        let b = 28u * i;\n\
        let v = vec3<f32>(inp[b], inp[b + 1u], inp[b + 2u]);\n\
        let d = vec3<f32>(inp[b + 3u], inp[b + 4u], inp[b + 5u]);\n\
        let k = bitcast<i32>(inp[b + 6u]);\n\
        let at = b + 7u;\n\
        var t3: Tri;\n\
        for (var j = 0u; j < 3u; j++) {\n\
            t3.a0[j] = inp[at + 3u * j]; t3.a1[j] = inp[at + 3u * j + 1u]; t3.a2[j] = inp[at + 3u * j + 2u];\n\
            t3.e1.hi[j] = inp[at + 9u + 2u * j]; t3.e1.lo[j] = inp[at + 10u + 2u * j];\n\
            t3.e2.hi[j] = inp[at + 15u + 2u * j]; t3.e2.lo[j] = inp[at + 16u + 2u * j];\n\
        }\n\
        let h = finish_hit(v, d, k, t3);\n\
        let o = 7u * i;\n\
        outp[o] = select(0.0, 1.0, h.ok); outp[o + 1u] = h.t; outp[o + 2u] = h.u; outp[o + 3u] = h.v;\n\
        outp[o + 4u] = h.p.x; outp[o + 5u] = h.p.y; outp[o + 6u] = h.p.z;\n}";
    let out = run_kernel(main, &inp, cases.len(), 7);
    let (mut both, mut only_gpu, mut only_twin) = (0, 0, 0);
    for (i, (o, d, k, tri, words)) in cases.iter().enumerate() {
        let got = &out[7 * i..7 * i + 7];
        let twin = finish_hit(*o, *d, *k, words);
        match (got[0] == 1.0, twin) {
            (true, Some(f)) => {
                both += 1;
                let want = [f.t, f.u, f.v, f.point[0], f.point[1], f.point[2]];
                assert_eq!(
                    want.map(f32::to_bits),
                    [got[1], got[2], got[3], got[4], got[5], got[6]].map(f32::to_bits),
                    "case {i}: o {o:?} d {d:?} k {k} tri {tri:?}"
                );
            }
            (true, None) => {
                // The host's values (geom::rounded, rounded to float32), t in the caller's
                // units: the direction was scaled by 2^k.
                only_gpu += 1;
                let f = |v: [f32; 3]| v.map(f64::from);
                let h = crate::geom::rounded::rounded_hit(f(*o), f(*d), tri).unwrap();
                let t = (h.t * 2f64.powi(*k)) as f32;
                let want = [t, h.u as f32, h.v as f32]
                    .into_iter()
                    .chain(h.point.map(|x| x as f32));
                let want: Vec<u32> = want.map(f32::to_bits).collect();
                let got: Vec<u32> = got[1..].iter().map(|x| x.to_bits()).collect();
                assert_eq!(
                    want, got,
                    "case {i} (device only): o {o:?} d {d:?} tri {tri:?}"
                );
            }
            (false, Some(_)) => only_twin += 1,
            (false, None) => {}
        }
    }
    eprintln!(
        "device finish: both {both}, device only {only_gpu}, twin only {only_twin} of {}",
        cases.len()
    );
    assert!(both * 10 > cases.len() * 9, "{both} of {}", cases.len());
}
