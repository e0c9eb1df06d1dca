//! Fixtures shared by the tests of several modules (compiled only for `cargo test`).

use crate::accel::AccelKind;
use crate::geom::ray::Ray;
use crate::layout::LayoutKind;
use crate::query::contact::Meet;
use crate::query::Listed;
use crate::referee;
pub(crate) use crate::rng::Rng;
use crate::scene::{CastOptions, Rays, Scene};
use crate::traverse::Method;
use std::cmp::Ordering;

/// An n³ grid of cubes over [0,1]³, each cut into 6 Kuhn tets (conforming across cubes),
/// interior points jittered so no two faces are coplanar by accident. Every coordinate is a
/// multiple of 2^-24 (moved by at most 2^-25, far below the jitter): the points are exact in
/// float32, so the float32 walk reads the very mesh whose triangles the referee judges, and
/// sums like `p − 3 v` of a test's rays stay exact.
pub(crate) fn kuhn_grid(n: usize, jitter: f64, rng: &mut Rng) -> (Vec<[f64; 3]>, Vec<[u32; 4]>) {
    crate::mesh::kuhn::kuhn_grid(n, jitter, || rng.f())
}

/// The interior faces of the tets (sorted triples).
pub(crate) fn all_faces(tets: &[[u32; 4]]) -> Vec<[u32; 3]> {
    let f = crate::mesh::kuhn::tet_faces(tets);
    // Interior faces only (listed twice): scene triangles never lie on the domain boundary.
    f.chunk_by(|a, b| a == b)
        .filter(|g| g.len() == 2)
        .map(|g| g[0])
        .collect()
}

pub(crate) fn random_scene(rng: &mut Rng, n: usize, frac: f64) -> (Scene, Vec<[[f64; 3]; 3]>) {
    let g = grid_scene(rng, n, 0.3, frac);
    (g.scene, g.tris)
}

pub(crate) struct GridScene {
    pub scene: Scene,
    pub tris: Vec<[[f64; 3]; 3]>,
    pub pts: Vec<[f64; 3]>,
    pub faces: Vec<[u32; 3]>,
}

/// A Kuhn grid (see [`kuhn_grid`]) with a random fraction `frac` of its faces as the scene's
/// triangles.
pub(crate) fn grid_scene(rng: &mut Rng, n: usize, jitter: f64, frac: f64) -> GridScene {
    let (pts, tets) = kuhn_grid(n, jitter, rng);
    let faces: Vec<[u32; 3]> = all_faces(&tets)
        .into_iter()
        .filter(|_| rng.f() < frac)
        .collect();
    let tris: Vec<[[f64; 3]; 3]> = faces.iter().map(|f| f.map(|v| pts[v as usize])).collect();
    let ids: Vec<u32> = (0..faces.len() as u32).collect();
    let scene = Scene::build(pts.clone(), &tets, &faces, &ids, tris.clone()).unwrap();
    GridScene {
        scene,
        tris,
        pts,
        faces,
    }
}

/// [`grid_scene`] with no scene triangle touching the box's sides (as meshing builds scenes:
/// the domain box has a margin).
pub(crate) fn grid_scene_inside(rng: &mut Rng, n: usize, jitter: f64, frac: f64) -> GridScene {
    let (pts, tets) = kuhn_grid(n, jitter, rng);
    let on_side = |v: u32| pts[v as usize].iter().any(|&x| x == 0.0 || x == 1.0);
    let faces: Vec<[u32; 3]> = all_faces(&tets)
        .into_iter()
        .filter(|f| !f.iter().any(|&v| on_side(v)))
        .filter(|_| rng.f() < frac)
        .collect();
    let tris: Vec<[[f64; 3]; 3]> = faces.iter().map(|f| f.map(|v| pts[v as usize])).collect();
    let ids: Vec<u32> = (0..faces.len() as u32).collect();
    let scene = Scene::build(pts.clone(), &tets, &faces, &ids, tris.clone()).unwrap();
    GridScene {
        scene,
        tris,
        pts,
        faces,
    }
}

/// Rays built to hit the cases a perturbed or float walk gets wrong, on an unjittered Kuhn grid
/// (every face plane is an axis plane or a diagonal one, shared by many faces): aimed exactly
/// at vertices, edge midpoints and face points, running along edges and in face planes,
/// starting on vertices, edges and faces, from inside and outside the box, with directions
/// scaled from 1e-30 to 1e30. Dyadic coordinates keep every claim exact.
pub(crate) fn exact_case_rays(
    rng: &mut Rng,
    pts: &[[f64; 3]],
    faces: &[[u32; 3]],
    n: usize,
) -> Vec<Ray6> {
    let mut rays = Vec::new();
    let grid = |rng: &mut Rng, lo: f64, hi: f64| {
        [0, 1, 2].map(|_| ((lo + rng.f() * (hi - lo)) * 16.0).round() / 16.0)
    };
    let feature = |rng: &mut Rng| -> [f64; 3] {
        let f = faces[(rng.f() * faces.len() as f64) as usize].map(|v| pts[v as usize]);
        match (rng.f() * 3.0) as usize {
            0 => f[0],
            1 => [0, 1, 2].map(|k| (f[0][k] + f[1][k]) * 0.5),
            _ => [0, 1, 2].map(|k| (f[0][k] + f[1][k] + 2.0 * f[2][k]) * 0.25),
        }
    };
    while rays.len() < n {
        let kind = rays.len() % 5;
        let (o, d) = match kind {
            // Aimed at a feature from a grid point inside or outside the box.
            0 | 1 => {
                let o = if kind == 0 {
                    grid(rng, 0.0, 1.0)
                } else {
                    grid(rng, -0.5, 1.5)
                };
                let t = feature(rng);
                (o, [0, 1, 2].map(|k| t[k] - o[k]))
            }
            // From a feature (origin on the surface or a vertex) towards a grid point.
            2 => {
                let o = feature(rng);
                let t = grid(rng, -0.25, 1.25);
                (o, [0, 1, 2].map(|k| t[k] - o[k]))
            }
            // Along an axis or a face diagonal through a feature (along edges, in planes).
            3 => {
                let o = feature(rng);
                let axes = [
                    [1., 0., 0.],
                    [0., 1., 0.],
                    [0., 0., 1.],
                    [1., 1., 0.],
                    [0., 1., 1.],
                    [1., 0., 1.],
                    [1., 1., 1.],
                ];
                let a = axes[(rng.f() * 7.0) as usize];
                let s = if rng.f() < 0.5 { -1.0 } else { 1.0 };
                let back = (rng.f() * 4.0).floor() / 4.0;
                ([0, 1, 2].map(|k| o[k] - back * s * a[k]), a.map(|x| s * x))
            }
            // Between two features.
            _ => {
                let (a, b) = (feature(rng), feature(rng));
                (a, [0, 1, 2].map(|k| b[k] - a[k]))
            }
        };
        if d == [0.0; 3] {
            continue;
        }
        let scale = [1.0, 1e-30, 1e30, 3.0][rays.len() / 5 % 4];
        rays.push((o, d.map(|x| x * scale)));
    }
    rays
}

pub(crate) type Ray6 = ([f64; 3], [f64; 3]);

/// Per ray, the window [lo, 1] / ‖d‖∞ (a tmin/tmax pair that cuts the stress rays' crossings
/// on both sides, whatever their direction's scale).
pub(crate) fn windows(rays: &[Ray6], lo: f64) -> (Vec<f64>, Vec<f64>) {
    rays.iter()
        .map(|r| {
            let l = r.1.iter().fold(0f64, |m, x| m.max(x.abs()));
            (lo / l, 1.0 / l)
        })
        .unzip()
}

// The accelerator-agreement harness: every accelerator run over the same rays, each answer
// judged by the exact referee and compared with the exact walk's.

/// Every accelerator a cast can run: the accelerator table's rows, so a new accelerator joins
/// every agreement test.
pub(crate) const ACCEL_KINDS: &[AccelKind] = AccelKind::ALL;

/// The default cast options on `accel`.
/// What the BVHs' tree tests build over: 1,500 small random triangles, two zero-area ones (a
/// point, a segment) and 40 copies of one triangle (centres all equal).
pub(crate) fn triangle_soup(rng: &mut Rng) -> Vec<[[f64; 3]; 3]> {
    let mut tris: Vec<[[f64; 3]; 3]> = (0..1500)
        .map(|_| {
            let c = [0, 1, 2].map(|_| rng.f() * 10.0);
            [0, 1, 2].map(|_| [0, 1, 2].map(|k| c[k] + rng.f() * 0.3))
        })
        .collect();
    tris.push([[1.0, 1.0, 1.0]; 3]);
    tris.push([[0.0; 3], [1.0, 1.0, 1.0], [2.0, 2.0, 2.0]]);
    tris.extend(std::iter::repeat_n(
        [[5.0, 5.0, 5.0], [6.0, 5.0, 5.0], [5.0, 6.0, 5.0]],
        40,
    ));
    tris
}

pub(crate) fn on(accel: AccelKind) -> CastOptions {
    CastOptions {
        accel,
        ..Default::default()
    }
}

/// The scene and rays the accelerators are compared on: an unjittered 4³ Kuhn grid (planes
/// shared by many faces) with about a third of its inner faces as triangles, the stress rays of
/// [`exact_case_rays`] and a 32×32 fan from one eye outside the box (the packets' case), in
/// float64 and float32.
pub(crate) struct Agreement {
    pub g: GridScene,
    pub rays: Vec<Ray6>,
    pub o: Vec<f64>,
    pub d: Vec<f64>,
    pub o32: Vec<f32>,
    pub d32: Vec<f32>,
}

impl Agreement {
    pub fn new(seed: u64) -> Agreement {
        let mut rng = Rng::xorshift(seed);
        let g = grid_scene_inside(&mut rng, 4, 0.0, 0.35);
        let mut rays = exact_case_rays(&mut rng, &g.pts, &g.faces, 2500);
        let eye = [-0.75, 0.3125, 0.4375];
        rays.extend((0..1024).map(|k| {
            let (x, y) = ((k % 32) as f64 / 32.0, (k / 32) as f64 / 32.0);
            (eye, [1.0, x - 0.5, y - 0.5])
        }));
        let o: Vec<f64> = rays.iter().flat_map(|r| r.0).collect();
        let d: Vec<f64> = rays.iter().flat_map(|r| r.1).collect();
        let o32 = o.iter().map(|&x| x as f32).collect();
        let d32 = d.iter().map(|&x| x as f32).collect();
        Agreement {
            g,
            rays,
            o,
            d,
            o32,
            d32,
        }
    }

    pub fn len(&self) -> usize {
        self.rays.len()
    }

    /// Every ray's [tmin, tmax]: [0, ∞), or with `window` one that cuts crossings on both
    /// sides ([`windows`]).
    pub fn bounds(&self, window: bool) -> (Vec<f64>, Vec<f64>) {
        if window {
            windows(&self.rays, 0.25)
        } else {
            (vec![0.0; self.len()], vec![f64::INFINITY; self.len()])
        }
    }

    pub fn r64<'a>(&'a self, tmin: &'a [f64], tmax: &'a [f64]) -> Rays<'a, f64> {
        Rays {
            origins: &self.o,
            directions: &self.d,
            tmin,
            tmax,
            leaving: None,
        }
    }

    pub fn r32<'a>(&'a self, tmin: &'a [f64], tmax: &'a [f64]) -> Rays<'a, f32> {
        Rays {
            origins: &self.o32,
            directions: &self.d32,
            tmin,
            tmax,
            leaving: None,
        }
    }

    /// The exact walk's (the default cast's) any hits and all hits of `rays`.
    pub fn walk_any_all(&self, rays: &Rays<f64>) -> (Vec<u8>, Vec<Listed>) {
        let n = rays.len();
        let (mut any, mut all) = (vec![0u8; n], vec![Listed::default(); n]);
        let opts = CastOptions::default();
        let scene = &self.g.scene;
        scene
            .occluded(Method::DEFAULT, LayoutKind::DEFAULT, rays, &mut any, &opts)
            .unwrap();
        scene.intersections(rays, &mut all, &opts).unwrap();
        (any, all)
    }
}

/// `got` lists the points the exact walk lists (`walk`) for `ray` over `tris`: as many, each
/// one of the walk's at the same exact t (bit for bit where both name the same triangle), in
/// order of exact t. `what` names the case in messages.
pub(crate) fn assert_same_points(
    what: &str,
    ray: &Ray,
    tris: &[[[f64; 3]; 3]],
    got: &[Meet],
    walk: &[Meet],
) {
    let shown = |m: &[Meet]| m.iter().map(|m| (m.t, m.triangle)).collect::<Vec<_>>();
    assert_eq!(
        got.len(),
        walk.len(),
        "{what}: o {:?} d {:?} points {:?} walk {:?}",
        ray.o,
        ray.d,
        shown(got),
        shown(walk)
    );
    let crossing =
        |tri: u32| referee::crossing(ray.o, ray.d, &tris[tri as usize]).expect("a met triangle");
    let mut used = vec![false; walk.len()];
    for m in got {
        let cm = crossing(m.triangle);
        let k = (0..walk.len())
            .find(|&k| !used[k] && crossing(walk[k].triangle).cmp_t_of(&cm) == Ordering::Equal);
        let k = k.unwrap_or_else(|| panic!("{what}: point {m:?} not the walk's"));
        used[k] = true;
        if walk[k].triangle == m.triangle {
            assert_eq!(walk[k].t.to_bits(), m.t.to_bits(), "{what}: t of {m:?}");
        }
    }
    assert!(
        got.windows(2)
            .all(|p| crossing(p[0].triangle).cmp_t_of(&crossing(p[1].triangle)) == Ordering::Less),
        "{what}: the points in order of exact t"
    );
}
