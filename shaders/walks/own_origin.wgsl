// The exact kernel for rays with their own origins (random rays, rays from many points): the
// kernel reads each ray's origin and direction, locates the origin (locate.wgsl) and begins
// its walk as begin.wgsl says (both joined before this file). Where the origin lies against
// the box is decided per ray, exactly:
// - outside: the box's entry, as for a shared origin outside it (with a finite tmax the host
//   skips a ray that ends before the box, as the CPU does);
// - inside: the origin is located (the host takes only scenes whose faces are whole caller's
//   triangles, so an origin strictly inside a tet lies in no triangle's plane). Anything
//   uncertain (an origin on or near a face, a walk past the guard, out of the domain) ends
//   END_UNBEGUN: the host walks that ray from its start.
//
// Each decision is a certified sign, so every ray begins where the CPU exact walk begins it.

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = ray_index(gid, nwg);
    if i >= params.n_rays {
        return;
    }
    let at = params.origins_at + 3u * i;
    let o = vec3<f32>(dirs[at], dirs[at + 1u], dirs[at + 2u]);
    origin = o;
    // From the bits: comparisons may flush subnormals to zero.
    let bits = bitcast<vec3<u32>>(o);
    let mag = bits & vec3<u32>(0x7fffffffu);
    if max(mag.x, max(mag.y, mag.z)) >= 0x7f800000u {
        // Not finite: the host says INVALID.
        unbegun(i);
        return;
    }
    let beyond = box_side(bits);
    if any(beyond != vec3<i32>(0)) {
        begin(i, beyond, false, 0u, vec4<u32>(0u));
        return;
    }
    let names = locate_origin(i, o);
    if located == BOUNDARY {
        unbegun(i);
        return;
    }
    begin(i, beyond, true, located, names);
}
