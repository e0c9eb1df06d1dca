//! The valid scenes both targets start from: Kuhn grids with a fraction of their faces as
//! triangles, and the walk's 48 scenes, each a function of its id.

use super::Rng;
use crate::mesh::kuhn::{kuhn_grid, tet_faces};
use crate::scene::Scene;
use std::cell::RefCell;
use std::collections::HashMap;
use std::sync::Arc;

/// Every face of the tets once (sorted triples).
fn faces_of(tets: &[[u32; 4]]) -> Vec<[u32; 3]> {
    let mut f = tet_faces(tets);
    f.dedup();
    f
}

/// The inputs of one `Scene::build_with`.
#[derive(Clone, Debug)]
pub struct BuildInput {
    pub points: Vec<[f64; 3]>,
    pub tets: Vec<[u32; 4]>,
    pub faces: Vec<[u32; 3]>,
    pub face_triangle: Vec<u32>,
    pub triangles: Vec<[[f64; 3]; 3]>,
    pub hilbert: bool,
}

impl BuildInput {
    pub fn build(&self) -> crate::Result<Scene> {
        Scene::build_with(
            self.points.clone(),
            &self.tets,
            &self.faces,
            &self.face_triangle,
            self.triangles.clone(),
            self.hilbert,
        )
    }
}

/// A valid scene's inputs: a Kuhn grid of side `n`, a fraction `frac` of its faces as
/// triangles; with `inside`, none on the box's sides (as meshing builds scenes: the domain box
/// has a margin).
pub fn grid_input(rng: &mut Rng, n: usize, jitter: f64, frac: f64, inside: bool) -> BuildInput {
    let (points, tets) = kuhn_grid(n, jitter, || rng.f());
    let on_side = |v: u32| points[v as usize].iter().any(|&x| x == 0.0 || x == 1.0);
    let faces: Vec<[u32; 3]> = faces_of(&tets)
        .into_iter()
        .filter(|f| !(inside && f.iter().any(|&v| on_side(v))))
        .filter(|_| rng.chance(frac))
        .collect();
    let triangles = faces
        .iter()
        .map(|f| f.map(|v| points[v as usize]))
        .collect();
    let face_triangle = (0..faces.len() as u32).collect();
    BuildInput {
        points,
        tets,
        faces,
        face_triangle,
        triangles,
        hilbert: rng.chance(0.7),
    }
}

thread_local! {
    static SCENES: RefCell<HashMap<u64, (Arc<Scene>, usize)>> = RefCell::new(HashMap::new());
}

/// The walk's scenes: 48 valid ones, a function of `id` alone (cached per thread).
pub fn walk_scene(id: u64) -> (Arc<Scene>, usize) {
    SCENES.with(|s| {
        s.borrow_mut()
            .entry(id)
            .or_insert_with(|| {
                let mut rng = Rng::new(id ^ 0x5ce4e);
                let n = 1 + rng.below(3);
                let jitter = rng.pick(&[0.0, 0.3]);
                let frac = rng.pick(&[0.05, 0.3, 1.0]);
                let input = grid_input(&mut rng, n, jitter, frac, true);
                let ntri = input.triangles.len();
                let scene = input
                    .build()
                    .unwrap_or_else(|e| panic!("walk scene {id} does not build: {e}"));
                (Arc::new(scene), ntri)
            })
            .clone()
    })
}
