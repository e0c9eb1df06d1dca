// Maria, Horna & Aveneau 2017 on their 80-byte tet: the walk of src/traverse/mod.rs for INLINE
// layouts with the exit test of src/traverse/maria2017.rs and the records of
// src/layout/tet80.rs, in float32. Its CPU twin is `walk::<f32, Tet80, Maria2017>`: the same
// operations in the same order (cross and dot written out as the CPU writes them).
//
// Vertices are named by their slot 0..3 in the current tet, as Maria et al. do: a step reads
// one record (four float32 vertices and four faces) and no point array.

// src/layout/tet80.rs, Tet80Face: the constrained side's index (u32::MAX for a free face) and
// neighbour << 2 | the same face's index in the neighbour (u32::MAX on the domain boundary).
struct Face80 {
    constrained: u32,
    neighbor: u32,
}

// src/layout/tet80.rs, Tet80Record: 4 x 3 float32 vertices, then faces[i] opposite vertex i.
struct Tet80 {
    vertices: array<f32, 12>,
    faces: array<Face80, 4>,
}

@group(0) @binding(3) var<storage, read> tets: array<Tet80>;

fn vertex80(t: u32, k: u32) -> vec3<f32> {
    return vec3<f32>(tets[t].vertices[3u * k], tets[t].vertices[3u * k + 1u], tets[t].vertices[3u * k + 2u]);
}

// What lies across face i of tet t (a link), and that face's index in the neighbour.
fn inline_face(t: u32, i: u32) -> vec2<u32> {
    let f = tets[t].faces[i];
    if f.constrained != 0xffffffffu {
        return vec2<u32>(CONSTRAINED_BIT | f.constrained, 0u);
    }
    if f.neighbor == 0xffffffffu {
        return vec2<u32>(BOUNDARY, 0u);
    }
    return vec2<u32>(f.neighbor >> 2u, f.neighbor & 3u);
}

fn cross3(a: vec3<f32>, b: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}

fn dot3(a: vec3<f32>, b: vec3<f32>) -> f32 {
    return a.x * b.x + a.y * b.y + a.z * b.z;
}

fn sub3(a: vec3<f32>, b: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(a.x - b.x, a.y - b.y, a.z - b.z);
}

// Algorithm 1 with d the complement vertex of the (possibly fake) entry face (a, b, c): the
// ray's moment moved to d, then two side products. Leaves 0, 1, 2 = CAD, ABD, BCD.
fn exit_tetra(u: vec3<f32>, v: vec3<f32>, a: vec3<f32>, b: vec3<f32>, c: vec3<f32>, d: vec3<f32>) -> u32 {
    let w = sub3(v, cross3(d, u));
    var id = select(0u, 1u, dot3(w, sub3(c, d)) <= 0.0);
    let k = select(b, a, id == 0u);
    id += select(0u, 1u, dot3(w, sub3(k, d)) > 0.0);
    switch id {
        case 0u: { return EXIT_CAD; }
        case 1u: { return EXIT_ABD; }
        default: { return EXIT_BCD; }
    }
}

// Algorithm 2: one side product with edge V2V3 rules out F0 or F1, then Algorithm 1 with the
// ruled-out face as a fake entry face.
fn start_exit(u: vec3<f32>, v: vec3<f32>, p: ptr<function, array<vec3<f32>, 4>>) -> u32 {
    let w3 = sub3(v, cross3((*p)[3], u));
    let side = dot3(w3, sub3((*p)[2], (*p)[3]));
    let f = select(0u, 1u, side < 0.0);
    let g = outward_face(f);
    let e = exit_tetra(u, v, (*p)[g.x], (*p)[g.z], (*p)[g.y], (*p)[f]);
    if e == EXIT_ABD {
        return g.y;
    }
    if e == EXIT_BCD {
        return g.x;
    }
    return g.z;
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = ray_index(gid, nwg);
    if i >= params.n_rays {
        return;
    }
    let ray = rays[i];
    let u = ray.e0;
    let v = ray.e1;
    // a, b, c: slots of the entry face in the current tet.
    var a: u32;
    var b: u32;
    var c: u32;
    var pa: vec3<f32>;
    var pb: vec3<f32>;
    var pc: vec3<f32>;
    var link: u32;
    var t = ray.tet;
    var steps: u32;
    var entry_face: u32;
    if ray.entry < NO_ENTRY {
        let f = outward_face(ray.entry);
        a = f.x;
        b = f.z;
        c = f.y;
        pa = vertex80(t, a);
        pb = vertex80(t, b);
        pc = vertex80(t, c);
        link = t;
        steps = 0u;
        entry_face = ray.entry;
    } else {
        var p: array<vec3<f32>, 4>;
        for (var k = 0u; k < 4u; k++) {
            p[k] = vertex80(t, k);
        }
        let e = start_exit(u, v, &p);
        let f = outward_face(e);
        a = f.x;
        b = f.y;
        c = f.z;
        pa = p[f.x];
        pb = p[f.y];
        pc = p[f.z];
        let l = inline_face(t, e);
        link = l.x;
        entry_face = l.y;
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
        // Names are local to each tet: rename the entry face in this one and read its
        // vertices from the record.
        let f = outward_face(entry_face);
        a = f.x;
        b = f.z;
        c = f.y;
        pa = vertex80(t, a);
        pb = vertex80(t, b);
        pc = vertex80(t, c);
        let d = entry_face;
        let pd = vertex80(t, d);
        let e = exit_tetra(u, v, pa, pb, pc, pd);
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
        let l = inline_face(t, opposite);
        link = l.x;
        entry_face = l.y;
    }
}
