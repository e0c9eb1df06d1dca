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
    let v = ray.verts;
    let p = array<Vert, 3>(
        vertex(ray, position(v.x)),
        vertex(ray, position(v.y)),
        vertex(ray, position(v.z)),
    );
    plain_steps(i, ray, vec4<u32>(ray.tet, v.w, ray.entry, 0u), v.xyz, p);
}

// At a constrained face or the boundary: handed back as it stands (the host decides the face).
fn at_constrained(i: u32, link: u32, t: u32, steps: u32, a: u32, b: u32, c: u32) {
    resumed(i, link_end(link), link, t, steps, a, b, c);
}
