// The walk of src/traverse/mod.rs for layouts that name vertices by id (`Layout::INLINE` is
// false: tet20): the entry face's vertex ids and their method vertices are kept from step to
// step; each step reads the fourth vertex's id from the record and its position from `points`.
//
// The layout provides position(id), fourth_vertex(t, a, b, c) and link_opposite(t, x, a, b, c).

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = ray_index(gid, nwg);
    if i >= params.n_rays {
        return;
    }
    let ray = rays[i];
    let names = ray.verts;
    var a: u32;
    var b: u32;
    var c: u32;
    var pa: Vert;
    var pb: Vert;
    var pc: Vert;
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
        pa = vertex(ray, position(a));
        pb = vertex(ray, position(b));
        pc = vertex(ray, position(c));
        link = t;
        steps = 0u;
    } else {
        var vs: array<Vert, 4>;
        for (var k = 0u; k < 4u; k++) {
            vs[k] = vertex(ray, position(names[k]));
        }
        let e = start_exit(ray, &vs);
        if e == EXIT_UNSURE {
            finish(i, END_DEFERRED, 0u, t, 0u, 0u, 0u, 0u);
            return;
        }
        let f = outward_face(e);
        a = names[f.x];
        b = names[f.y];
        c = names[f.z];
        pa = vs[f.x];
        pb = vs[f.y];
        pc = vs[f.z];
        link = link_opposite(t, names[e], a, b, c);
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
        let d = fourth_vertex(t, a, b, c);
        let pd = vertex(ray, position(d));
        let e = step_exit(ray, pa, pb, pc, pd);
        if e == EXIT_UNSURE {
            finish(i, END_DEFERRED, 0u, t, steps, a, b, c);
            return;
        }
        let opposite = turn(e, d, pd, &a, &b, &c, &pa, &pb, &pc);
        link = link_opposite(t, opposite, a, b, c);
    }
}
