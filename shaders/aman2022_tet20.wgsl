// Aman, Demirci & Güdükbay 2022 on their Tet20 layout: the walk of src/traverse/mod.rs with
// the exit test of src/traverse/aman2022.rs and the records of src/layout/tet20.rs, in float32.
// Its CPU twin is `walk::<f32, Tet20, Aman2022>`: the same operations in the same order
// (written out, no dot()/cross() builtins), so the two differ only where the GPU's compiler
// fuses a multiply-add or flushes a subnormal.

// src/layout/tet20.rs, Tet20Record: the xor of the four vertex ids, and the four links ordered
// by the rank of the opposite vertex's id.
struct Tet20 {
    vertex_xor: u32,
    links: array<u32, 4>,
}

@group(0) @binding(3) var<storage, read> tets: array<Tet20>;
// Scene points in float32, padded to 16 bytes (w = 0).
@group(0) @binding(4) var<storage, read> points: array<vec4<f32>>;

// Vertex id p projected on the basis (u, w) perpendicular to the ray, translated first.
fn project(o: vec3<f32>, u: vec3<f32>, w: vec3<f32>, id: u32) -> vec2<f32> {
    let p = points[id];
    let q = vec3<f32>(p.x - o.x, p.y - o.y, p.z - o.z);
    return vec2<f32>(q.x * u.x + q.y * u.y + q.z * u.z, q.x * w.x + q.y * w.y + q.z * w.z);
}

fn cross2(p: vec2<f32>, q: vec2<f32>) -> f32 {
    return p.x * q.y - p.y * q.x;
}

// Algorithm 1: two determinants per tet.
fn step_exit(a: vec2<f32>, b: vec2<f32>, c: vec2<f32>, d: vec2<f32>) -> u32 {
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
fn start_exit(v: ptr<function, array<vec2<f32>, 4>>) -> u32 {
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

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = ray_index(gid, nwg);
    if i >= params.n_rays {
        return;
    }
    let ray = rays[i];
    let o = ray.origin;
    let u = ray.e0;
    let w = ray.e1;
    let names = ray.verts;
    var a: u32;
    var b: u32;
    var c: u32;
    var pa: vec2<f32>;
    var pb: vec2<f32>;
    var pc: vec2<f32>;
    var link: u32;
    var t = ray.tet;
    var steps: u32;
    if ray.entry < NO_ENTRY {
        // Entering through face `entry`: reversed from its outward order it turns
        // counter-clockwise around the ray, as the loop expects of an entry face.
        let f = outward_face(ray.entry);
        a = names[f.x];
        b = names[f.z];
        c = names[f.y];
        pa = project(o, u, w, a);
        pb = project(o, u, w, b);
        pc = project(o, u, w, c);
        link = t;
        steps = 0u;
    } else {
        var vs: array<vec2<f32>, 4>;
        for (var k = 0u; k < 4u; k++) {
            vs[k] = project(o, u, w, names[k]);
        }
        let e = start_exit(&vs);
        let f = outward_face(e);
        a = names[f.x];
        b = names[f.y];
        c = names[f.z];
        pa = vs[f.x];
        pb = vs[f.y];
        pc = vs[f.z];
        link = tets[t].links[rank(names[e], a, b, c)];
        steps = 1u;
    }
    loop {
        if (link & CONSTRAINED_BIT) != 0u {
            finish(i, link_end(link), link, t, steps, a, b, c);
            return;
        }
        if steps >= params.max_steps {
            finish(i, END_STEP_LIMIT, 0u, t, steps, a, b, c);
            return;
        }
        t = link;
        steps += 1u;
        let d = tets[t].vertex_xor ^ a ^ b ^ c;
        let pd = project(o, u, w, d);
        let e = step_exit(pa, pb, pc, pd);
        var opposite: u32;
        if e == EXIT_ABD {
            opposite = c;
            c = d;
            pc = pd;
        } else if e == EXIT_BCD {
            opposite = a;
            a = b;
            pa = pb;
            b = c;
            pb = pc;
            c = d;
            pc = pd;
        } else {
            opposite = b;
            let a0 = a;
            let pa0 = pa;
            a = c;
            pa = pc;
            b = a0;
            pb = pa0;
            c = d;
            pc = pd;
        }
        link = tets[t].links[rank(opposite, a, b, c)];
    }
}
