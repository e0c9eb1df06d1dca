//! The octree kernel (`shaders/octree/portalez.wgsl`): naga validation and its structs' layout
//! (no GPU), its CPU twin judged by the exact referee and the exact CPU walk (no GPU), and the
//! kernel against its twin bit for bit (lavapipe or any adapter).
//!
//! Mutation tried: the twin reading the sign of Π_u at the exit face's centre the other way
//! (the 4-neighbour choice): the twin test fails (8 of 3000 random rays wrong, 277 with other
//! leaves than the exact walk's) and so does parity (15,413 of 56,384 rays differ).

use super::device_or_skip;
use crate::accel::portalez_octree::{OctreeParams, OctreeState, PortalezOctree, Walked};
use crate::geom::ray::Ray;
use crate::gpu::octree::*;
use crate::query::gather::{Line, Nearest, Tri};
use crate::referee;
use crate::rng::Rng;
use crate::status::{FAILED, HIT, MISS};
use std::mem::{offset_of, size_of};

/// `n` random triangles in [0, 1]³ (sides up to ~0.1), corners rounded to float32 so the
/// float32 kernel reads the very scene the referee judges.
fn random_tris(n: usize, seed: u64) -> Vec<Tri> {
    let mut rng = Rng::xorshift(seed);
    (0..n)
        .map(|_| {
            let c = rng.p3();
            [0, 1, 2].map(|_| [0, 1, 2].map(|k| ((c[k] + (rng.f() - 0.5) * 0.1) as f32) as f64))
        })
        .collect()
}

fn build(tris: &[Tri], max_depth: u32, leaf_size: u32) -> PortalezOctree {
    PortalezOctree::build(
        tris,
        OctreeParams {
            max_depth,
            leaf_size,
            balance: true,
        },
    )
    .unwrap()
}

/// Tiny triangles packed against the root box's z = lo face (and one large triangle that
/// makes the box): with leaf size 1 and depth 11 the leaves along that face are finer than
/// the cube map's 2^10 texels, so rays entering there need the steps within the face.
fn boundary_tris(n: usize, seed: u64) -> Vec<Tri> {
    let mut rng = Rng::xorshift(seed);
    let mut tris = vec![[[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, 1.0, 1.0]]];
    for _ in 0..n {
        let c = [rng.f() * 0.01, rng.f() * 0.01, rng.f() * 0.002];
        tris.push(
            [0, 1, 2].map(|_| [0, 1, 2].map(|k| ((c[k] + (rng.f() - 0.5) * 6e-4) as f32) as f64)),
        );
    }
    tris
}

/// A scene to walk: its triangles, the octree, and rays as [`rays`] gives them.
struct Case {
    name: String,
    tris: Vec<Tri>,
    oct: PortalezOctree,
    rays: (Vec<f32>, Vec<f32>, Vec<u8>),
}

/// Random triangles at depths 6 and 11 (few leaves that deep: leaf size 8), and the boundary
/// cluster at depth 11; `n` random and centroid rays each, a `res`² camera.
fn cases(n: usize, res: usize) -> Vec<Case> {
    let mut out = Vec::new();
    for (n_tris, depth, seed) in [(3000, 6, 7u64), (400, 11, 8)] {
        let tris = random_tris(n_tris, seed);
        out.push(Case {
            name: format!("{n_tris} random triangles, depth {depth}"),
            oct: build(&tris, depth, 8),
            rays: rays(&tris, n, res, seed + 100, [0.0; 3], 1.0, None),
            tris,
        });
    }
    let tris = boundary_tris(300, 9);
    // Rays from below the cluster, into the z = lo face where the leaves are finest.
    let r = rays(
        &tris[1..],
        n,
        res,
        110,
        [0.0, 0.0, -0.02],
        0.012,
        Some(-0.05),
    );
    out.push(Case {
        name: "300 tiny triangles on the root's z = lo face, depth 11".into(),
        oct: build(&tris, 11, 1),
        rays: r,
        tris,
    });
    out
}

/// Rays of three kinds, as (origins, directions, kind): 0 random (from in and around the
/// box), 1 a pinhole camera from outside, 2 aimed at triangle centroids (from in and around).
/// The rays start in the box `at + sc [0, 1]³` widened by half a side each way, or (camera)
/// before it; `z`: every random and centroid ray starts at that height instead.
fn rays(
    tris: &[Tri],
    n: usize,
    res: usize,
    seed: u64,
    at: [f64; 3],
    sc: f64,
    z: Option<f64>,
) -> (Vec<f32>, Vec<f32>, Vec<u8>) {
    let mut rng = Rng::xorshift(seed);
    let (mut o, mut d, mut kind) = (Vec::new(), Vec::new(), Vec::new());
    let around = |rng: &mut Rng| {
        let p = [0, 1, 2].map(|k| at[k] + sc * (rng.f() * 2.0 - 0.5));
        [p[0], p[1], z.unwrap_or(p[2])]
    };
    for _ in 0..n {
        o.extend(around(&mut rng).map(|x| x as f32));
        d.extend([0, 1, 2].map(|_| (rng.f() - 0.5) as f32));
    }
    kind.resize(n, 0);
    let eye = [0.5, 0.45, -1.2];
    let eye = [0, 1, 2].map(|k| (at[k] + eye[k] * sc) as f32);
    for y in 0..res {
        for x in 0..res {
            o.extend(eye);
            let px = (x as f64 + 0.5) / res as f64 - 0.5;
            let py = (y as f64 + 0.5) / res as f64 - 0.5;
            d.extend([px * 0.9, py * 0.9, 1.0].map(|v| v as f32));
            kind.push(1);
        }
    }
    for _ in 0..n {
        let t = &tris[(rng.f() * tris.len() as f64) as usize % tris.len()];
        let c = [0, 1, 2].map(|k| (t[0][k] + t[1][k] + t[2][k]) / 3.0);
        let p = around(&mut rng);
        o.extend(p.map(|x| x as f32));
        d.extend([0, 1, 2].map(|k| (c[k] - p[k]) as f32));
    }
    kind.resize(o.len() / 3, 2);
    (o, d, kind)
}

/// The shader parses and validates (with the generated tables); its structs have the Rust
/// mirrors' sizes and offsets as naga lays them out; the tables it gets are the exact walk's.
#[test]
fn octree_shader_validates_with_naga() {
    let src = source();
    let module = naga::front::wgsl::parse_str(&src)
        .unwrap_or_else(|e| panic!("{PATH}: WGSL parse error:\n{}", e.emit_to_string(&src)));
    naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::empty(),
    )
    .validate(&module)
    .unwrap_or_else(|e| panic!("{PATH}: invalid WGSL:\n{}", e.emit_to_string(&src)));
    let entries: Vec<_> = module
        .entry_points
        .iter()
        .map(|e| (e.name.as_str(), e.stage, e.workgroup_size))
        .collect();
    assert_eq!(entries, [("main", naga::ShaderStage::Compute, [64, 1, 1])]);
    type Layout<'a> = (&'a str, usize, Vec<(&'a str, usize)>);
    let expect: Vec<Layout> = vec![
        (
            "OctParams",
            size_of::<OctParams>(),
            vec![
                ("lo", offset_of!(OctParams, lo)),
                ("n_rays", offset_of!(OctParams, n_rays)),
                ("hi", offset_of!(OctParams, hi)),
                ("max_steps", offset_of!(OctParams, max_steps)),
                ("scale", offset_of!(OctParams, scale)),
                ("cube_res", offset_of!(OctParams, cube_res)),
                ("depth", offset_of!(OctParams, depth)),
                ("grid_stride", offset_of!(OctParams, grid_stride)),
            ],
        ),
        (
            "OctRayIn",
            size_of::<OctRayIn>(),
            vec![
                ("o", offset_of!(OctRayIn, o)),
                ("start", offset_of!(OctRayIn, start)),
                ("d", offset_of!(OctRayIn, d)),
            ],
        ),
        (
            "OctRayOut",
            size_of::<OctRayOut>(),
            vec![
                ("status", offset_of!(OctRayOut, status)),
                ("tri", offset_of!(OctRayOut, tri)),
                ("t", offset_of!(OctRayOut, t)),
                ("leaves", offset_of!(OctRayOut, leaves)),
            ],
        ),
    ];
    let mut layouter = naga::proc::Layouter::default();
    layouter.update(module.to_ctx()).unwrap();
    let mut seen = 0;
    for (h, ty) in module.types.iter() {
        let (Some(name), naga::TypeInner::Struct { members, span }) = (&ty.name, &ty.inner) else {
            continue;
        };
        let (_, size, fields) = expect
            .iter()
            .find(|e| e.0 == name)
            .unwrap_or_else(|| panic!("{PATH}: struct {name} has no Rust mirror"));
        assert_eq!(*span as usize, *size, "size of {name}");
        assert_eq!(layouter[h].size as usize, *size, "size of {name}");
        for (f, off) in fields {
            let m = members
                .iter()
                .find(|m| m.name.as_deref() == Some(f))
                .unwrap_or_else(|| panic!("{name}.{f} missing in WGSL"));
            assert_eq!(m.offset as usize, *off, "offset of {name}.{f}");
        }
        seen += 1;
    }
    assert_eq!(seen, expect.len());
    // The kernel's face constants are the exact walk's.
    use crate::accel::portalez_octree::face_of;
    let of: Vec<String> = (0..3)
        .flat_map(|a| [false, true].map(|p| format!("{}u", face_of(a, p))))
        .collect();
    assert!(src.contains(&format!(
        "const FACE_OF = array<u32, 6>({});",
        of.join(", ")
    )));
    let mut axis = [0usize; 6];
    for a in 0..3 {
        axis[face_of(a, false)] = a;
        axis[face_of(a, true)] = a;
    }
    let ax: Vec<String> = axis.iter().map(|a| format!("{a}u")).collect();
    assert!(src.contains(&format!(
        "const FACE_AXIS = array<u32, 6>({});",
        ax.join(", ")
    )));
}

/// Unbalanced trees link faces to hierarchy nodes: refused with a clear error.
#[test]
fn octree_gpu_refuses_unbalanced_trees() {
    let tris = random_tris(300, 1);
    let oct = PortalezOctree::build(
        &tris,
        OctreeParams {
            max_depth: 6,
            leaf_size: 2,
            balance: false,
        },
    )
    .unwrap();
    let e = OctreeHost::new(&oct).err().expect("refused");
    assert!(
        matches!(e, crate::Error::InvalidOption(_)) && e.to_string().contains("balanced"),
        "{e}"
    );
}

/// How the twin's answers compare with the exact referee, per kind of ray.
#[derive(Debug, Default, Clone, Copy)]
struct Judged {
    rays: usize,
    hits: usize,
    /// Status or triangle not the referee's (a miss for a hit, a hit for a miss, or a
    /// triangle not tied at the first hit).
    wrong: usize,
    failed: usize,
    /// Worst relative t error on right hits.
    worst_t: f64,
    /// Rays whose leaves visited differ from the exact CPU walk's.
    leaves_differ: usize,
}

/// The twin against the referee (and the exact walk's leaves visited), by kind of ray.
fn judge_twin(
    oct: &PortalezOctree,
    tris: &[Tri],
    o: &[f32],
    d: &[f32],
    kind: &[u8],
    out: &[OctRayOut],
) -> [Judged; 3] {
    use rayon::prelude::*;
    let per: Vec<(u8, Judged)> = (0..out.len())
        .into_par_iter()
        .map(|i| {
            let v = |x: &[f32]| [0, 1, 2].map(|k| x[3 * i + k] as f64);
            let (oi, di) = (v(o), v(d));
            let want = referee::first_hit(oi, di, 0.0, f64::INFINITY, tris);
            let r = out[i];
            let mut j = Judged {
                rays: 1,
                hits: (r.status == HIT as u32) as usize,
                failed: (r.status == FAILED as u32) as usize,
                ..Default::default()
            };
            match (&want, r.status as u8) {
                (None, MISS) => {}
                (Some(w), HIT) if w.ties_with(r.tri as usize) => {
                    j.worst_t = (r.t as f64 - w.t).abs() / w.t.abs().max(f64::MIN_POSITIVE);
                }
                _ => j.wrong = 1,
            }
            // The exact walk with the nearest-hit gatherer: the leaves it visits.
            let line = Line::new(&Ray {
                o: oi,
                d: di,
                tmin: 0.0,
                tmax: f64::INFINITY,
                leaving: None,
            })
            .unwrap();
            let mut gather = Nearest::new(&line);
            let exact = match oct.walk(&line, &mut gather, &mut OctreeState::default()) {
                Walked::Done(n) | Walked::Guard(n) => n,
            };
            j.leaves_differ = (exact != r.leaves) as usize;
            (kind[i], j)
        })
        .collect();
    let mut by = [Judged::default(); 3];
    for (k, j) in per {
        let b = &mut by[k as usize];
        b.rays += j.rays;
        b.hits += j.hits;
        b.wrong += j.wrong;
        b.failed += j.failed;
        b.worst_t = b.worst_t.max(j.worst_t);
        b.leaves_differ += j.leaves_differ;
    }
    by
}

/// The float32 walk (the twin) against the exact referee, no GPU needed: how many rays it gets
/// wrong is printed, and bounded loosely (at most 0.1% of random and camera rays: float32 can
/// fail at edges and corners); rays aimed at triangle centroids must all be right, every ray
/// must finish, and nearly every ray must see exactly the leaves the exact walk sees. In the
/// boundary scene most entries need steps within the root face after the cube map.
#[test]
fn octree_twin_against_the_referee() {
    for case in cases(3000, 64) {
        let Case {
            name,
            tris,
            oct,
            rays: (o, d, kind),
        } = &case;
        let host = OctreeHost::new(oct).unwrap();
        let out = host.cast_twin(o, d, None);
        let by = judge_twin(oct, tris, o, d, kind, &out);
        // Entries from outside, and those the cube map alone did not place.
        let (mut entered, mut fixed) = (0, 0);
        for i in 0..out.len() {
            let v = |x: &[f32]| [x[3 * i], x[3 * i + 1], x[3 * i + 2]];
            let r = host.prepare(v(o), v(d)).unwrap();
            if r.start == NO_START {
                if let Ok((_, fixes)) = host.entry(&r, 1 << 20) {
                    entered += 1;
                    fixed += (fixes > 0) as usize;
                }
            }
        }
        eprintln!(
            "octree twin, {name} ({} leaves, cube map {}²): {entered} rays entered, {fixed} \
             needed steps after the cube map",
            oct.leaves(),
            oct.cube_res
        );
        for (k, j) in by.iter().enumerate() {
            let kind = ["random", "camera", "centroid"][k];
            eprintln!("octree twin, {name}, {kind} rays: {j:?}");
            assert_eq!(j.failed, 0, "{name} {kind}");
            assert!(j.wrong * 1000 <= j.rays, "{name} {kind}: {j:?}");
            assert!(j.leaves_differ * 100 <= j.rays, "{name} {kind}: {j:?}");
        }
        assert_eq!(by[2].wrong, 0, "{name}, centroid rays: {:?}", by[2]);
        assert!(by[2].hits == by[2].rays && by[1].hits > by[1].rays / 10);
        assert!(by[2].worst_t < 1e-3, "{name}: {:?}", by[2]);
        if oct.cube_res < 1 << oct.params.max_depth && name.contains("tiny") {
            assert!(fixed * 4 > entered, "{name}: {fixed} of {entered}");
        }
    }
}

/// The kernel against its twin, every field bit for bit on a driver that neither fuses nor
/// flushes (lavapipe); batching changes nothing; the throughput is printed (lavapipe emulates
/// a GPU on the CPU: the number says little about a GPU).
#[test]
fn gpu_octree_matches_its_twin() {
    if !device_or_skip("gpu octree parity") {
        return;
    }
    let g = crate::gpu::gpu().unwrap();
    for case in cases(20_000, 128) {
        let Case {
            name,
            oct,
            rays: (o, d, _),
            ..
        } = &case;
        let host = OctreeHost::new(oct).unwrap();
        let dev = DeviceOctree::new(&g, &host).unwrap();
        let twin = host.cast_twin(o, d, None);
        // A first run compiles the pipeline on lavapipe; the second is timed.
        dev.cast(&g, &host, &o[..3], &d[..3], None).unwrap();
        let t0 = std::time::Instant::now();
        let gpu = dev.cast(&g, &host, o, d, None).unwrap();
        let secs = t0.elapsed().as_secs_f64();
        let n = twin.len();
        let same = |a: &OctRayOut, b: &OctRayOut| {
            a.status == b.status
                && a.tri == b.tri
                && a.t.to_bits() == b.t.to_bits()
                && a.leaves == b.leaves
        };
        let differ = (0..n).filter(|&i| !same(&twin[i], &gpu[i])).count();
        let hits = gpu.iter().filter(|r| r.status == HIT as u32).count();
        let leaves: u64 = gpu.iter().map(|r| r.leaves as u64).sum();
        eprintln!(
            "gpu octree, {name}, on {}: {n} rays, {hits} hits, {differ} differ from the twin, \
             {:.2} leaves a ray, {:.3} s ({:.2} Mrays/s, with host preparation, upload and \
             readback)",
            g.adapter.name,
            leaves as f64 / n as f64,
            secs,
            n as f64 / secs / 1e6
        );
        if let Some(i) = (0..n).find(|&i| !same(&twin[i], &gpu[i])) {
            eprintln!(
                "first differing ray {i}: twin {:?} gpu {:?}",
                twin[i], gpu[i]
            );
        }
        assert!(hits > n / 10, "{name}");
        super::parity::float_kernel_parity(&format!("gpu octree, {name}"), differ, n);
        // Batches of 1000 rays: the same answers.
        let v = |x: &[f32], i: usize| [x[3 * i], x[3 * i + 1], x[3 * i + 2]];
        let prepared: Vec<OctRayIn> = (0..n)
            .map(|i| host.prepare(v(o, i), v(d, i)).unwrap())
            .collect();
        let batched = dev.run(&g, &prepared, None, 1000).unwrap();
        assert_eq!(batched, gpu, "{name}");
    }
}
