//! Judged by geometry the code does not use: boxes known analytically (which points are in
//! them, on their sides), the winding number of a closed surface (solid angles in f64), and
//! a tet-level 0-1 breadth-first search for the fewest crossings (no regions).
use super::*;
use crate::mesh::build::OUTWARD_FACES;
use crate::scene::Scene;
use crate::testing::{grid_scene, kuhn_grid, Rng};

/// Kuhn grid of n³ cubes (6 tets each, cube by cube, x fastest) and the boundary faces of
/// the union of the cubes `keep` selects (by cube index), oriented out of that union.
fn block_surface(
    pts: &[[f64; 3]],
    tets: &[[u32; 4]],
    n: usize,
    keep: impl Fn([usize; 3]) -> bool,
) -> Vec<[u32; 3]> {
    let mut faces: Vec<([u32; 3], [u32; 3])> = Vec::new();
    for (k, t) in tets.iter().enumerate() {
        let c = k / 6;
        if !keep([c % n, (c / n) % n, c / (n * n)]) {
            continue;
        }
        let mut t = *t;
        let [a, b, cc, d] = t.map(|v| pts[v as usize]);
        if orient(a, b, cc, d) < 0.0 {
            t.swap(2, 3);
        }
        for f in OUTWARD_FACES {
            let f = f.map(|i| t[i]);
            let mut key = f;
            key.sort();
            faces.push((key, f));
        }
    }
    faces.sort();
    faces
        .chunk_by(|a, b| a.0 == b.0)
        .filter(|g| g.len() == 1)
        .map(|g| g[0].1)
        .collect()
}

fn scene_of(pts: &[[f64; 3]], tets: &[[u32; 4]], faces: &[[u32; 3]]) -> Scene {
    let tris: Vec<_> = faces.iter().map(|f| f.map(|v| pts[v as usize])).collect();
    let ids: Vec<u32> = (0..faces.len() as u32).collect();
    Scene::build(pts.to_vec(), tets, faces, &ids, tris).unwrap()
}

/// A closed axis-aligned box [lo, hi]³.
#[derive(Clone, Copy)]
struct Cube(f64, f64);
impl Cube {
    fn closed(&self, p: [f64; 3]) -> bool {
        p.iter().all(|&x| self.0 <= x && x <= self.1)
    }
    fn open(&self, p: [f64; 3]) -> bool {
        p.iter().all(|&x| self.0 < x && x < self.1)
    }
    fn on_side(&self, p: [f64; 3]) -> bool {
        self.closed(p) && !self.open(p)
    }
}

/// Test points: uniform ones in and around the unit box, dyadic ones (k/16, exactly on
/// block sides, edges, corners and mesh vertices, or off them), mixes of both, and
/// non-finite ones. More than two chunks, so threads split them.
fn test_points(rng: &mut Rng) -> Vec<[f64; 3]> {
    let mut v = Vec::new();
    let dyadic = |rng: &mut Rng| ((rng.f() * 19.0).floor() - 1.0) / 16.0;
    for k in 0..3 * CHUNK + 123 {
        let p = match k % 3 {
            0 => rng.p3().map(|x| 1.4 * x - 0.2),
            1 => [(); 3].map(|_| dyadic(rng)),
            _ => [(); 3].map(|_| if rng.f() < 0.5 { dyadic(rng) } else { rng.f() }),
        };
        v.push(p);
    }
    v.extend([
        [f64::NAN, 0.5, 0.5],
        [0.5, f64::INFINITY, 0.5],
        [0.5, 0.5, f64::NEG_INFINITY],
        [0.5, 0.5, 0.5],
        [0.0, 0.0, 0.0],
        [1.0, 0.5, 0.5],
        [1.0 + 1e-12, 0.5, 0.5],
    ]);
    v
}

/// Answers with 1, 2 and all threads; asserts they agree and returns them.
fn contains(scene: &Scene, pts: &[[f64; 3]]) -> Vec<bool> {
    let flat: Vec<f64> = pts.iter().flatten().copied().collect();
    let mut outs = Vec::new();
    for threads in [Some(1), Some(2), None] {
        let mut out = vec![false; pts.len()];
        scene.contains(&flat, &mut out, threads).unwrap();
        outs.push(out);
    }
    assert_eq!(outs[0], outs[1], "1 and 2 threads differ");
    assert_eq!(outs[0], outs[2], "1 and all threads differ");
    outs.pop().unwrap()
}

fn check_all(scene: &Scene, pts: &[[f64; 3]], expect: impl Fn([f64; 3]) -> bool) {
    let got = contains(scene, pts);
    let mut bad = 0;
    for (p, &g) in pts.iter().zip(&got) {
        let e = expect(*p) && p.iter().all(|x| x.is_finite());
        if g != e {
            if bad < 10 {
                eprintln!("{p:?}: got {g}, expected {e}");
            }
            bad += 1;
        }
    }
    assert_eq!(bad, 0, "{bad} of {} points answered wrong", pts.len());
}

#[test]
fn closed_block_holds_its_inside_and_its_surface() {
    let (pts, tets) = kuhn_grid(4, 0.0, &mut Rng::xorshift(1));
    let faces = block_surface(&pts, &tets, 4, |c| c.iter().all(|&x| (1..3).contains(&x)));
    assert_eq!(faces.len(), 6 * 4 * 2);
    let scene = scene_of(&pts, &tets, &faces);
    let block = Cube(0.25, 0.75);
    check_all(&scene, &test_points(&mut Rng::xorshift(2)), |p| {
        block.closed(p)
    });
}

#[test]
fn nested_shells_alternate() {
    // Three shells: [1/8, 7/8]³ ⊃ [2/8, 6/8]³ ⊃ [3/8, 5/8]³.
    let (pts, tets) = kuhn_grid(8, 0.0, &mut Rng::xorshift(3));
    let shells = [Cube(0.125, 0.875), Cube(0.25, 0.75), Cube(0.375, 0.625)];
    let mut faces = Vec::new();
    for k in 1..=3 {
        let range = k..8 - k;
        faces.extend(block_surface(&pts, &tets, 8, |c| {
            c.iter().all(|x| range.contains(x))
        }));
    }
    let scene = scene_of(&pts, &tets, &faces);
    check_all(&scene, &test_points(&mut Rng::xorshift(4)), |p| {
        shells.iter().any(|s| s.on_side(p)) || shells.iter().filter(|s| s.open(p)).count() % 2 == 1
    });
}

#[test]
fn open_surface_holds_only_itself() {
    // The block's surface without its side at x = 3/4: its inside is reached from outside
    // with no crossing, so only points on the remaining sides are inside.
    let (pts, tets) = kuhn_grid(4, 0.0, &mut Rng::xorshift(5));
    let faces: Vec<_> = block_surface(&pts, &tets, 4, |c| c.iter().all(|&x| (1..3).contains(&x)))
        .into_iter()
        .filter(|f| !f.iter().all(|&v| pts[v as usize][0] == 0.75))
        .collect();
    assert_eq!(faces.len(), 5 * 4 * 2);
    let scene = scene_of(&pts, &tets, &faces);
    let block = Cube(0.25, 0.75);
    check_all(&scene, &test_points(&mut Rng::xorshift(6)), |p| {
        block.closed(p) && (p[0] == 0.25 || [1, 2].iter().any(|&a| p[a] == 0.25 || p[a] == 0.75))
    });
}

#[test]
fn surface_on_the_domain_box_encloses_the_whole_domain() {
    // Scene triangles on the box itself: one crossing from outside to anywhere inside.
    let (pts, tets) = kuhn_grid(3, 0.0, &mut Rng::xorshift(7));
    let faces = block_surface(&pts, &tets, 3, |_| true);
    let scene = scene_of(&pts, &tets, &faces);
    check_all(&scene, &test_points(&mut Rng::xorshift(8)), |p| {
        Cube(0.0, 1.0).closed(p)
    });
}

/// The generalized winding number of a closed, outward oriented triangle surface at p
/// (Van Oosterom & Strackee's solid angle per triangle): 1 inside, 0 outside.
pub(crate) fn winding(tris: &[[[f64; 3]; 3]], p: [f64; 3]) -> f64 {
    let sub = |a: [f64; 3]| [a[0] - p[0], a[1] - p[1], a[2] - p[2]];
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let norm = |a: [f64; 3]| dot(a, a).sqrt();
    let cross = |a: [f64; 3], b: [f64; 3]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let total: f64 = tris
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(sub);
            let (la, lb, lc) = (norm(a), norm(b), norm(c));
            let num = dot(a, cross(b, c));
            let den = la * lb * lc + dot(a, b) * lc + dot(b, c) * la + dot(c, a) * lb;
            2.0 * num.atan2(den)
        })
        .sum();
    total / (4.0 * std::f64::consts::PI)
}

/// Two nested closed shells (the cubes from 1 to n - 1 and from 2 to n - 2) in a jittered
/// Kuhn grid of n³ cubes, its points rounded to float32 or not (`f32_points`: no tet may flip,
/// which would leave no tetrahedralization to judge), and the shells' triangles.
pub(crate) fn jittered_shells(
    n: usize,
    seed: u64,
    f32_points: bool,
) -> (Scene, Vec<[[f64; 3]; 3]>) {
    let (mut pts, tets) = kuhn_grid(n, 0.3, &mut Rng::xorshift(seed));
    if f32_points {
        let before = pts.clone();
        for p in &mut pts {
            *p = p.map(|x| x as f32 as f64);
        }
        let sign = |p: &[[f64; 3]], t: &[u32; 4]| {
            let [a, b, c, d] = t.map(|v| p[v as usize]);
            orient(a, b, c, d) > 0.0
        };
        let flips = tets.iter().any(|t| sign(&before, t) != sign(&pts, t));
        assert!(!flips, "seed {seed}: rounding flips a tet");
    }
    let mut faces = Vec::new();
    for k in [1, 2] {
        let range = k..n - k;
        faces.extend(block_surface(&pts, &tets, n, |c| {
            c.iter().all(|x| range.contains(x))
        }));
    }
    let tris: Vec<_> = faces.iter().map(|f| f.map(|v| pts[v as usize])).collect();
    (scene_of(&pts, &tets, &faces), tris)
}

#[test]
fn jittered_closed_surfaces_agree_with_the_winding_number() {
    // A jittered grid: the shells' sides are no longer planes. Two shells, so the parity
    // of the winding number is the answer; the surfaces' vertices lie on them (inside).
    let (scene, tris) = jittered_shells(6, 9, false);
    let mut rng = Rng::xorshift(10);
    let sample: Vec<[f64; 3]> = (0..3 * CHUNK)
        .map(|_| rng.p3().map(|x| 1.2 * x - 0.1))
        .collect();
    let mut on: Vec<[f64; 3]> = tris.iter().flatten().copied().collect();
    on.sort_by(|a, b| a.partial_cmp(b).unwrap());
    on.dedup();
    let got = contains(&scene, &sample);
    let mut judged = 0;
    for (p, &g) in sample.iter().zip(&got) {
        let w = winding(&tris, *p);
        if (w - w.round()).abs() > 1e-6 {
            continue; // too near the surface for a float judge
        }
        judged += 1;
        let e = (0.0..=1.0).contains(&p[0])
            && (0.0..=1.0).contains(&p[1])
            && (0.0..=1.0).contains(&p[2])
            && (w.round() as i64) % 2 != 0;
        assert_eq!(g, e, "{p:?}: winding number {w}");
    }
    assert!(judged > sample.len() * 9 / 10);
    assert!(
        contains(&scene, &on).iter().all(|&x| x),
        "surface vertices are inside"
    );
}

/// The fewest crossings from outside to each tet, by a 0-1 breadth-first search over tets
/// (free faces cost 0, scene triangles 1), without regions.
fn fewest_crossings(mesh: &TetMesh) -> Vec<u32> {
    let mut dist = vec![u32::MAX; mesh.len()];
    let mut dq = VecDeque::new();
    for (t, links) in mesh.links.iter().enumerate() {
        for &l in links {
            let d = if l == BOUNDARY {
                0
            } else if l & CONSTRAINED_BIT != 0
                && mesh.constrained[(l & !CONSTRAINED_BIT) as usize].beyond == BOUNDARY
            {
                1
            } else {
                continue;
            };
            if d < dist[t] {
                dist[t] = d;
                dq.push_back((d, t as u32));
            }
        }
    }
    let mut sorted: Vec<_> = dq.drain(..).collect();
    sorted.sort();
    dq.extend(sorted);
    while let Some((d, t)) = dq.pop_front() {
        if d > dist[t as usize] {
            continue;
        }
        for i in 0..4 {
            let u = mesh.neighbor(t, i);
            if u == BOUNDARY {
                continue;
            }
            let w = u32::from(mesh.links[t as usize][i] & CONSTRAINED_BIT != 0);
            if d + w < dist[u as usize] {
                dist[u as usize] = d + w;
                if w == 0 {
                    dq.push_front((d, u));
                } else {
                    dq.push_back((d + 1, u));
                }
            }
        }
    }
    dist
}

#[test]
fn parity_is_that_of_the_fewest_crossings() {
    for (seed, frac) in [(11, 0.1), (12, 0.3), (13, 0.6)] {
        let g = grid_scene(&mut Rng::xorshift(seed), 5, 0.3, frac);
        let mesh = &g.scene.mesh;
        let parity = Parity::build(mesh);
        let dist = fewest_crossings(mesh);
        for (t, &d) in dist.iter().enumerate() {
            assert_eq!(parity.odd(t as u32), d % 2 == 1, "tet {t}: {d} crossings");
            // The GPU's 32-bit words: tet t is bit t % 32 of word t / 32.
            let bit = parity.word32(t / 32) >> (t % 32) & 1;
            assert_eq!(bit, u32::from(d % 2 == 1), "tet {t}: word32");
        }
        // Bits past the last tet are clear, words past the last are 0; one u64 per 64 tets.
        let words = dist.len().div_ceil(32);
        for t in dist.len()..words * 32 + 64 {
            assert_eq!(
                parity.word32(t / 32) >> (t % 32) & 1,
                0,
                "tet {t} past the end"
            );
        }
        assert_eq!(parity.bytes(), dist.len().div_ceil(64) * 8);
    }
}

#[test]
fn settling_corrects_a_wrong_tet() {
    let g = grid_scene(&mut Rng::xorshift(14), 4, 0.3, 0.3);
    let scene = &g.scene;
    let parity = Parity::build(&scene.mesh);
    let c = Containment {
        mesh: &scene.mesh,
        grid: &scene.locator,
        incidence: &scene.incidence,
        parity: &parity,
    };
    let mut rng = Rng::xorshift(15);
    let mut state = 1u32;
    for k in 0..500 {
        let p = rng.p3();
        let start = (k * 37 % scene.mesh.len()) as u32;
        let (t, _) = c.settle(start, p, &mut state).unwrap();
        // Barycentric coordinates in f64: all ≥ 0 up to rounding.
        let v = scene.mesh.tet_points(t);
        let vol = |a: [f64; 3], b: [f64; 3], c: [f64; 3], d: [f64; 3]| {
            let (u, w, x) = (
                [b[0] - a[0], b[1] - a[1], b[2] - a[2]],
                [c[0] - a[0], c[1] - a[1], c[2] - a[2]],
                [d[0] - a[0], d[1] - a[1], d[2] - a[2]],
            );
            u[0] * (w[1] * x[2] - w[2] * x[1]) - u[1] * (w[0] * x[2] - w[2] * x[0])
                + u[2] * (w[0] * x[1] - w[1] * x[0])
        };
        let whole = vol(v[0], v[1], v[2], v[3]);
        for i in 0..4 {
            let mut w = v;
            w[i] = p;
            assert!(
                vol(w[0], w[1], w[2], w[3]) / whole >= -1e-12,
                "{p:?} not in {t}"
            );
        }
    }
}

#[test]
fn float32_points_and_bad_arguments() {
    let (pts, tets) = kuhn_grid(4, 0.0, &mut Rng::xorshift(16));
    let faces = block_surface(&pts, &tets, 4, |c| c.iter().all(|&x| (1..3).contains(&x)));
    let scene = scene_of(&pts, &tets, &faces);
    let p32: [f32; 12] = [0.5, 0.5, 0.5, 0.25, 0.3, 0.6, 0.1, 0.5, 0.5, 2.0, 0.5, 0.5];
    let mut out = [false; 4];
    scene.contains(&p32, &mut out, None).unwrap();
    assert_eq!(out, [true, true, false, false]);
    assert!(matches!(
        scene.contains(&p32[..11], &mut out, None),
        Err(Error::InvalidInput(_))
    ));
    assert!(matches!(
        scene.contains(&p32, &mut out, Some(0)),
        Err(Error::InvalidOption(_))
    ));
    let mut none: [bool; 0] = [];
    scene.contains::<f64>(&[], &mut none, None).unwrap();
}
