// A pinhole camera's float32 ray directions, generated on the device (issue 34, item 5): the
// direction through pixel (i, j) is
//
//     d = (forward + xs[j] * right) + ys[i] * up,           each operation rounded once,
//     d = d / sqrt((d.x * d.x + d.y * d.y) + d.z * d.z)     when the camera normalizes,
//
// in float32, the recipe of `tetrace.Camera.rays(np.float32)` and of this kernel's CPU twin
// (`gpu::camera::direction`), so that a cast of a camera's rays answers the same on the CPU
// and on the GPU, bit for bit. WGSL rounds `+`, `-` and `*` correctly but lets a driver fuse
// and reassociate them (each result goes through `opaque`), flush subnormals (the host keeps
// every input at 0 or within [2^-60, 2^30], and a ray whose sums could leave the normal range
// is handed back), and compute `sqrt` and `/` a few ulps off (both are corrected here to the
// correctly rounded result, by exact comparisons in 64-bit integer arithmetic). A ray this
// kernel cannot make exactly gets NaN directions: the walk's kernel hands a non-finite
// direction back unbegun, and the host makes that ray with the twin.

struct CamParams {
    forward: vec3<f32>,
    n_rays: u32,
    right: vec3<f32>,
    width: u32,
    up: vec3<f32>,
    first: u32,
    normalize: u32,
    height: u32,
    _pad0: u32,
    _pad1: u32,
}

@group(0) @binding(0) var<uniform> cam: CamParams;
// xs (width values), then ys (height values), then one 0.0 (read as `zero_bits`).
@group(0) @binding(1) var<storage, read> coords: array<f32>;
// Three floats a ray, for rays first .. first + n_rays of the image in row-major order.
@group(0) @binding(2) var<storage, read_write> dirs: array<f32>;

const WORKGROUP: u32 = 64u;
// A nonzero component of d below this is handed back: its square (2^-120 at least) and its
// quotient by the norm (2^-123 at least, the norm being below 2^63) stay normal.
const MIN_COMPONENT: f32 = 8.673617e-19; // 2^-60
const MIN_NORMAL: f32 = 1.1754944e-38; // 2^-126
const MAX_FINITE: f32 = 3.4028235e38;

// 0, read from storage so that no compiler can know it (as in methods/exact_hit.wgsl): `opaque`
// xors a value's bits with it, a wall no float rewrite (fusing, reassociation) crosses.
var<private> zero_bits: u32;

fn opaque(x: f32) -> f32 {
    return bitcast<f32>(bitcast<u32>(x) ^ zero_bits);
}

fn opaque3(x: vec3<f32>) -> vec3<f32> {
    return bitcast<vec3<f32>>(bitcast<vec3<u32>>(x) ^ vec3<u32>(zero_bits));
}

fn nan() -> f32 {
    return bitcast<f32>(0x7fc00000u);
}

// a · b as (high, low) 32-bit words, exact (16-bit limbs: no product overflows).
fn mul64(a: u32, b: u32) -> vec2<u32> {
    let a0 = a & 0xffffu;
    let a1 = a >> 16u;
    let b0 = b & 0xffffu;
    let b1 = b >> 16u;
    let p00 = a0 * b0;
    let p01 = a0 * b1;
    let p10 = a1 * b0;
    let p11 = a1 * b1;
    let mid = (p00 >> 16u) + (p01 & 0xffffu) + (p10 & 0xffffu);
    return vec2<u32>(p11 + (p01 >> 16u) + (p10 >> 16u) + (mid >> 16u), (p00 & 0xffffu) | (mid << 16u));
}

// x · 2^sh as (high, low), for sh < 64 (a WGSL shift takes its amount modulo 32).
fn shl64(x: u32, sh: u32) -> vec2<u32> {
    if sh == 0u {
        return vec2<u32>(0u, x);
    }
    if sh < 32u {
        return vec2<u32>(x >> (32u - sh), x << sh);
    }
    return vec2<u32>(x << (sh - 32u), 0u);
}

fn lt64(a: vec2<u32>, b: vec2<u32>) -> bool {
    return a.x < b.x || (a.x == b.x && a.y < b.y);
}

// The significand (24 bits, the implicit one set) and unbiased exponent of a positive normal.
fn significand(x: f32) -> u32 {
    return (bitcast<u32>(x) & 0x7fffffu) | 0x800000u;
}

fn exponent(x: f32) -> i32 {
    return i32(bitcast<u32>(x) >> 23u) - 127;
}

// The correctly rounded square root of a positive normal x, from a guess s0 (within a few
// ulps; one out of the normal range starts at its edge): s moves an ulp at a time until sqrt(x) lies strictly between the midpoints around it
// (no square root of a float is a midpoint, so there are no ties). With x = X 2^(ex-23) and
// s = S 2^(es-23), sh = ex - 2 es + 25:
//   x < (upper midpoint)^2 = (2S + 1)^2 2^(2es-48)  <=>  X 2^sh < (2S + 1)^2,
//   x > (lower midpoint)^2 = (2S - 1)^2 2^(2es-48)  <=>  X 2^sh > (2S - 1)^2,
// and where s is a power of two (S = 2^23) the lower neighbour is half an ulp closer:
//   x > (4S - 1)^2 2^(2es-50)  <=>  X 2^(sh+2) > (4S - 1)^2.
// Every side is below 2^63 for sh <= 36. NaN: no settled result (the ray is handed back).
fn sqrt_rn_from(x: f32, s0: f32) -> f32 {
    let xx = significand(x);
    let ex = exponent(x);
    // A guess flushed or rounded out of the normal range starts at its edge.
    var s = clamp(s0, MIN_NORMAL, MAX_FINITE);
    for (var it = 0; it < 8; it++) {
        if !(s >= MIN_NORMAL && s <= MAX_FINITE) {
            return nan();
        }
        let ss = significand(s);
        let sh = ex - 2 * exponent(s) + 25;
        if sh < 0 || sh > 36 {
            return nan();
        }
        let lhs = shl64(xx, u32(sh));
        if !lt64(lhs, mul64(2u * ss + 1u, 2u * ss + 1u)) {
            s = bitcast<f32>(bitcast<u32>(s) + 1u);
            continue;
        }
        var below: bool;
        if ss > 0x800000u {
            below = lt64(mul64(2u * ss - 1u, 2u * ss - 1u), lhs);
        } else {
            below = lt64(mul64(4u * ss - 1u, 4u * ss - 1u), shl64(xx, u32(sh) + 2u));
        }
        if !below {
            s = bitcast<f32>(bitcast<u32>(s) - 1u);
            continue;
        }
        return s;
    }
    return nan();
}

// The correctly rounded quotient a / n of a (0, or normal) by a positive normal n whose exact
// value is normal, from a guess q0 of |a| / n (within a few ulps); the same walk as
// `sqrt_rn_from`. With |a| = A 2^(ea-23), n = N 2^(en-23), q = Q 2^(eq-23) and
// sh = ea - eq - en + 24:
//   |a| < (upper midpoint) n  <=>  A 2^sh < (2Q + 1) N,
//   |a| > (lower midpoint) n  <=>  A 2^sh > (2Q - 1) N   (A 2^(sh+1) > (4Q - 1) N at Q = 2^23).
// An exact quotient of a float by a float is never a midpoint, so there are no ties.
fn div_rn_from(a: f32, n: f32, q0: f32) -> f32 {
    if a == 0.0 {
        return a;
    }
    let aa = significand(abs(a));
    let nn = significand(n);
    let e = exponent(abs(a)) - exponent(n) + 24;
    var q = clamp(q0, MIN_NORMAL, MAX_FINITE);
    for (var it = 0; it < 8; it++) {
        if !(q >= MIN_NORMAL && q <= MAX_FINITE) {
            return nan();
        }
        let qq = significand(q);
        let sh = e - exponent(q);
        if sh < 0 || sh > 36 {
            return nan();
        }
        let lhs = shl64(aa, u32(sh));
        if !lt64(lhs, mul64(2u * qq + 1u, nn)) {
            q = bitcast<f32>(bitcast<u32>(q) + 1u);
            continue;
        }
        var below: bool;
        if qq > 0x800000u {
            below = lt64(mul64(2u * qq - 1u, nn), lhs);
        } else {
            below = lt64(mul64(4u * qq - 1u, nn), shl64(aa, u32(sh) + 1u));
        }
        if !below {
            q = bitcast<f32>(bitcast<u32>(q) - 1u);
            continue;
        }
        return bitcast<f32>(bitcast<u32>(q) | (bitcast<u32>(a) & 0x80000000u));
    }
    return nan();
}

fn sqrt_rn(x: f32) -> f32 {
    return sqrt_rn_from(x, sqrt(x));
}

fn div_rn(a: f32, n: f32) -> f32 {
    return div_rn_from(a, n, abs(a) / n);
}

// Any component nonzero below the normal range (a driver may flush it, or flush it on input
// to the next operation), or zero where the exact sum was not: a flushed sum.
fn unsafe_sum(s: vec3<f32>, a: vec3<f32>, b: vec3<f32>) -> bool {
    let tiny = (s != vec3<f32>(0.0)) & (abs(s) < vec3<f32>(MIN_NORMAL));
    let flushed = (s == vec3<f32>(0.0)) & (a != -b);
    return any(tiny | flushed);
}

// The ray through the pixel at image-plane coordinates (x, y); NaN where it cannot be made
// exactly here (the host makes it).
fn camera_direction(x: f32, y: f32) -> vec3<f32> {
    let a = opaque3(x * cam.right);
    let b = opaque3(cam.forward + a);
    let c = opaque3(y * cam.up);
    let d = opaque3(b + c);
    let small = (d != vec3<f32>(0.0)) & (abs(d) < vec3<f32>(MIN_COMPONENT));
    if unsafe_sum(b, cam.forward, a) || unsafe_sum(d, b, c) || any(small) {
        return vec3<f32>(nan());
    }
    if cam.normalize == 0u {
        return d;
    }
    let sq = opaque3(d * d);
    let n2 = opaque(opaque(sq.x + sq.y) + sq.z);
    if n2 == 0.0 {
        return vec3<f32>(nan());
    }
    let n = sqrt_rn(n2);
    return vec3<f32>(div_rn(d.x, n), div_rn(d.y, n), div_rn(d.z, n));
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let k = gid.y * nwg.x * WORKGROUP + gid.x;
    if k >= cam.n_rays {
        return;
    }
    zero_bits = bitcast<u32>(coords[arrayLength(&coords) - 1u]);
    let p = cam.first + k;
    let d = camera_direction(coords[p % cam.width], coords[cam.width + p / cam.width]);
    dirs[3u * k] = d.x;
    dirs[3u * k + 1u] = d.y;
    dirs[3u * k + 2u] = d.z;
}
