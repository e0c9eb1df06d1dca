// The walk of src/traverse/mod.rs for layouts that store the vertices in the record
// (`Layout::INLINE`: tet80). Vertices are named by their slot 0..3 in the current tet, as Maria
// et al. do: names are local to each tet, so each step renames the entry face in the new tet
// and reads all four vertices from its record (no point array).
//
// The layout provides slot_position(t, k) and across(t, face) (the link and the face's index
// in the neighbour).

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = ray_index(gid, nwg);
    if i >= params.n_rays {
        return;
    }
    let ray = rays[i];
    // a, b, c: slots of the entry face in the current tet.
    var a: u32;
    var b: u32;
    var c: u32;
    var pa: Vert;
    var pb: Vert;
    var pc: Vert;
    var link: u32;
    var t = ray.tet;
    var steps: u32;
    var entry_face: u32;
    if ray.entry < NO_ENTRY {
        let f = outward_face(ray.entry);
        a = f.x;
        b = f.z;
        c = f.y;
        pa = vertex(ray, slot_position(t, a));
        pb = vertex(ray, slot_position(t, b));
        pc = vertex(ray, slot_position(t, c));
        link = t;
        steps = 0u;
        entry_face = ray.entry;
    } else {
        var p: array<Vert, 4>;
        for (var k = 0u; k < 4u; k++) {
            p[k] = vertex(ray, slot_position(t, k));
        }
        let e = start_exit(ray, &p);
        if e == EXIT_UNSURE {
            finish(i, END_DEFERRED, 0u, t, 0u, 0u, 0u, 0u);
            return;
        }
        let f = outward_face(e);
        a = f.x;
        b = f.y;
        c = f.z;
        pa = p[f.x];
        pb = p[f.y];
        pc = p[f.z];
        let l = across(t, e);
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
        let f = outward_face(entry_face);
        a = f.x;
        b = f.z;
        c = f.y;
        pa = vertex(ray, slot_position(t, a));
        pb = vertex(ray, slot_position(t, b));
        pc = vertex(ray, slot_position(t, c));
        let d = entry_face;
        let pd = vertex(ray, slot_position(t, d));
        let e = step_exit(ray, pa, pb, pc, pd);
        if e == EXIT_UNSURE {
            finish(i, END_DEFERRED, 0u, t, steps, a, b, c);
            return;
        }
        let opposite = turn(e, d, pd, &a, &b, &c, &pa, &pb, &pc);
        let l = across(t, opposite);
        link = l.x;
        entry_face = l.y;
    }
}
