// Aman, Demirci & Güdükbay 2022: the exit test of src/traverse/aman2022.rs in float32. Its CPU
// twin is `walk::<f32, L, Aman2022>`: the same operations in the same order (written out, no
// dot()/cross() builtins), so the two differ only where the GPU's compiler fuses a
// multiply-add or flushes a subnormal.
//
// RayIn: `origin` is the start point and (e0, e1) the 2D basis (u, w) perpendicular to the ray.

// A vertex projected on the basis (u, w).
alias Vert = vec2<f32>;

// Position p projected on the basis (u, w) perpendicular to the ray, translated first.
fn vertex(ray: RayIn, p: vec3<f32>) -> Vert {
    let o = ray.origin;
    let u = ray.e0;
    let w = ray.e1;
    let q = vec3<f32>(p.x - o.x, p.y - o.y, p.z - o.z);
    return vec2<f32>(q.x * u.x + q.y * u.y + q.z * u.z, q.x * w.x + q.y * w.y + q.z * w.z);
}

fn cross2(p: vec2<f32>, q: vec2<f32>) -> f32 {
    return p.x * q.y - p.y * q.x;
}

// Algorithm 1: two determinants per tet.
fn step_exit(ray: RayIn, a: Vert, b: Vert, c: Vert, d: Vert) -> u32 {
    if cross2(d, a) >= 0.0 {
        if cross2(d, b) <= 0.0 {
            return EXIT_ABD;
        }
        return EXIT_BCD;
    }
    if cross2(d, c) >= 0.0 {
        return EXIT_CAD;
    }
    return EXIT_BCD;
}

// The start tet: the face the ray leaves by turns counter-clockwise around it; if rounding
// makes every face miss, the one missed by the least.
fn start_exit(ray: RayIn, v: ptr<function, array<Vert, 4>>) -> u32 {
    var best = 0u;
    var best_m = 0.0;
    for (var i = 0u; i < 4u; i++) {
        let f = outward_face(i);
        let p = (*v)[f.x];
        let q = (*v)[f.y];
        let r = (*v)[f.z];
        let x = cross2(p, q);
        let y = cross2(q, r);
        let z = cross2(r, p);
        var m = select(y, x, x < y);
        m = select(z, m, m < z);
        if m >= 0.0 {
            return i;
        }
        if i == 0u || m > best_m {
            best = i;
            best_m = m;
        }
    }
    return best;
}
