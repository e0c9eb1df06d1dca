// Maria, Horna & Aveneau 2017: the exit test of src/traverse/maria2017.rs in float32 (Plücker
// side products). Its CPU twin is `walk::<f32, L, Maria2017>`: the same operations in the
// same order (cross and dot written out as the CPU writes them).
//
// RayIn: e0 is the direction u and e1 the moment v = o x u; `origin` is unused.

// A vertex: its world position.
alias Vert = vec3<f32>;

fn vertex(ray: RayIn, p: vec3<f32>) -> Vert {
    return p;
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
fn exit_tetra(u: vec3<f32>, v: vec3<f32>, a: Vert, b: Vert, c: Vert, d: Vert) -> u32 {
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

fn step_exit(ray: RayIn, a: Vert, b: Vert, c: Vert, d: Vert) -> u32 {
    return exit_tetra(ray.e0, ray.e1, a, b, c, d);
}

// Algorithm 2: one side product with edge V2V3 rules out F0 or F1, then Algorithm 1 with the
// ruled-out face as a fake entry face.
fn start_exit(ray: RayIn, p: ptr<function, array<Vert, 4>>) -> u32 {
    let u = ray.e0;
    let v = ray.e1;
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
