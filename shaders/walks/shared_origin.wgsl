// The exact kernel for rays that share one origin (a camera): the kernel reads only each
// ray's direction. The host located the origin once (`gpu::origin`): strictly inside one tet
// (`batch.inside`), or outside the domain box, with the box's entry grid on the device. Each
// ray begins and walks as begin.wgsl says (joined before this file).

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = ray_index(gid, nwg);
    if i >= params.n_rays {
        return;
    }
    origin = batch.origin;
    begin(i, batch.beyond, batch.inside != 0u, batch.start_tet, batch.verts);
}
