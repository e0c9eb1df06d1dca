// A walk resumed from where the host left it (the exact kernel): the host located the ray and
// took its first exit with the CPU exact walk (`TetWalk::begin_elsewhere`); this kernel takes
// plain steps (`plain_exit`) while it can, and hands the walk back as it stands: at a
// constrained face or the boundary (the host's query decides what the face means), at the
// step guard, or at a step it cannot certify (END_DEFERRED). The host walks on from there
// (`TetWalk::walk_on_from`), so every answer is the CPU exact walk's. Layouts naming vertices
// by id (tet20).
//
// RayIn for a resumed walk: `tet` is the tet the walk stands in, `entry` the tets visited so
// far, `verts` the exit face (a, b, c) (counter-clockwise around the ray) and, in w, the link
// across it. RayOut: the same state after the kernel's steps, the link in `constrained`.

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = ray_index(gid, nwg);
    if i >= params.n_rays {
        return;
    }
    let ray = rays[i];
    var a = ray.verts.x;
    var b = ray.verts.y;
    var c = ray.verts.z;
    var link = ray.verts.w;
    var t = ray.tet;
    var steps = ray.entry;
    var pa = vertex(ray, position(a));
    var pb = vertex(ray, position(b));
    var pc = vertex(ray, position(c));
    loop {
        if (link & CONSTRAINED_BIT) != 0u {
            resumed(i, link_end(link), link, t, steps, a, b, c);
            return;
        }
        if steps >= params.max_steps {
            resumed(i, END_STEP_LIMIT, link, t, steps, a, b, c);
            return;
        }
        let next = link;
        let d = fourth_vertex(next, a, b, c);
        let pd = vertex(ray, position(d));
        let e = plain_exit(ray, pa, pb, pc, pd);
        if e == EXIT_UNSURE {
            resumed(i, END_DEFERRED, link, t, steps, a, b, c);
            return;
        }
        t = next;
        steps += 1u;
        let opposite = turn(e, d, pd, &a, &b, &c, &pa, &pb, &pc);
        link = link_opposite(t, opposite, a, b, c);
    }
}

// The state the walk stands in, for the host to walk on from.
fn resumed(i: u32, end: u32, link: u32, tet: u32, steps: u32, a: u32, b: u32, c: u32) {
    var out: RayOut;
    out.end = end;
    out.constrained = link;
    out.tet = tet;
    out.steps = steps;
    out.face = vec4<u32>(a, b, c, 0u);
    hits[i] = out;
}
