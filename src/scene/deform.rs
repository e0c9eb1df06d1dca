//! Moving a scene's points without rebuilding its topology (Lagae & Dutré 2008: keep the
//! constrained tetrahedralization, move all its vertices, Steiner points included; it stays a
//! valid one while no tet inverts).
//!
//! Where each point goes is the caller's rule (tetrace's, in Python: `docs/deformation.md`).
//! The scene checks that the new points leave the structure valid before it takes them: every
//! tet positively oriented (exact, as construction checks it), the points on the domain box's
//! sides where they were, every other point strictly inside the box. With the box's boundary
//! fixed and every tet positive, the tets cover the box once (a piecewise linear map of
//! degree one), so the topology, the constrained faces and the region parity all stay right.
//! Only then are the points swapped in, with what depends on coordinates: both precisions of
//! the points, the caller's triangles, `Incidence::split`, the seed grid, the layouts whose
//! records hold positions, the BVH and the octree. The boundary locator reads the box's points
//! only (they do not move); the parity and the topological layouts stay as they are.

use super::{split, Scene};
use crate::error::{Error, Result};
use crate::geom::predicates::orient;
use crate::layout::LayoutKind;
use crate::locate::GridLocator;
use crate::mesh::build::{on_box, snap_to_box};
use crate::mesh::surface::check_finite;
use rayon::prelude::*;
use std::sync::OnceLock;

/// What [`Scene::update_points`] found, and whether it moved the scene.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Moved {
    /// Tets whose orientation with the new points is not positive (exact): inverted or flat.
    pub inverted: usize,
    /// Points on the domain box's sides that would move, and other points that would not lie
    /// strictly inside the box.
    pub outside: usize,
    /// Whether the new points were taken (both counts 0); otherwise the scene is unchanged.
    pub applied: bool,
}

impl Scene {
    /// Checks new positions of the points, given in the order the scene was built with (see
    /// [`Scene::input_index`]); returns them in the scene's order, snapped onto the box's
    /// sides as construction snaps them, and what the check found. Nothing changes.
    pub fn check_points(&self, points: &[[f64; 3]]) -> Result<(Vec<[f64; 3]>, Moved)> {
        let n = self.mesh.points.len();
        if points.len() != n {
            return Err(Error::InvalidInput(format!(
                "{} points given for a scene of {n} points",
                points.len()
            )));
        }
        if let Some(i) = points.iter().position(|p| !p.iter().all(|x| x.is_finite())) {
            return Err(Error::InvalidInput(format!(
                "point {i} is not finite: {:?}",
                points[i]
            )));
        }
        let mut new: Vec<[f64; 3]> = self
            .input_index
            .par_iter()
            .map(|&i| points[i as usize])
            .collect();
        let [lo, hi] = self.mesh.bounds;
        snap_to_box(&mut new, lo, hi);
        let bounds = &self.mesh.bounds;
        let outside = new
            .par_iter()
            .zip(&self.mesh.points)
            .filter(|(p, old)| {
                if on_box(old, bounds) {
                    p != old
                } else {
                    !(0..3).all(|a| lo[a] < p[a] && p[a] < hi[a])
                }
            })
            .count();
        let inverted = self
            .mesh
            .tets
            .par_iter()
            .filter(|t| {
                let [a, b, c, d] = t.map(|v| new[v as usize]);
                orient(a, b, c, d) <= 0.0
            })
            .count();
        let applied = inverted == 0 && outside == 0;
        Ok((
            new,
            Moved {
                inverted,
                outside,
                applied,
            },
        ))
    }

    /// Moves the scene's points to `points` (in the order the scene was built with) and the
    /// caller's triangles to `triangles` (as many as before), keeping the topology, if
    /// [`Scene::check_points`] finds the structure still valid; otherwise changes nothing
    /// (`applied` false: the caller re-meshes). A BVH or octree built with other than the
    /// default parameters is built again now with the same ones; the default ones are built
    /// again on first use.
    pub fn update_points(
        &mut self,
        points: &[[f64; 3]],
        triangles: Vec<[[f64; 3]; 3]>,
    ) -> Result<Moved> {
        self.check_triangles(&triangles)?;
        let (new, moved) = self.check_points(points)?;
        if moved.applied {
            self.take_points(new, triangles)?;
        }
        Ok(moved)
    }

    /// [`Scene::update_points`] on a copy, leaving this scene as it is (for a scene that casts
    /// under way still read): the moved copy, or None when the check fails.
    pub fn moved_copy(
        &self,
        points: &[[f64; 3]],
        triangles: Vec<[[f64; 3]; 3]>,
    ) -> Result<(Option<Scene>, Moved)> {
        self.check_triangles(&triangles)?;
        let (new, moved) = self.check_points(points)?;
        if !moved.applied {
            return Ok((None, moved));
        }
        let mut copy = Scene {
            mesh: self.mesh.clone(),
            locator: self.locator.clone(),
            entry: self.entry.clone(),
            layouts: Default::default(),
            points_f32: Vec::new(),
            surface: self.surface.clone(),
            incidence: self.incidence.clone(),
            parity: self.parity.get().cloned().map_or_else(OnceLock::new, |p| {
                let cell = OnceLock::new();
                let _ = cell.set(p);
                cell
            }),
            structures: self.structures.share(),
            input_index: self.input_index.clone(),
        };
        copy.take_points(new, triangles)?;
        Ok((Some(copy), moved))
    }

    fn check_triangles(&self, triangles: &[[[f64; 3]; 3]]) -> Result<()> {
        let n = self.surface.triangles.len();
        if triangles.len() != n {
            return Err(Error::InvalidInput(format!(
                "{} triangles given for a scene of {n} triangles",
                triangles.len()
            )));
        }
        check_finite(triangles)
    }

    /// Swaps in checked points (in the scene's order) and triangles, and refreshes what reads
    /// coordinates.
    fn take_points(&mut self, new: Vec<[f64; 3]>, triangles: Vec<[[f64; 3]; 3]>) -> Result<()> {
        self.points_f32 = new.iter().map(|p| p.map(|x| x as f32)).collect();
        self.mesh.points = new;
        self.surface.triangles = triangles;
        self.incidence.split = split(&self.mesh, &self.incidence, &self.surface.triangles);
        self.locator = GridLocator::build(&self.mesh);
        self.layouts.forget_points();
        self.layouts.prepare(LayoutKind::DEFAULT, &self.mesh)?;
        self.structures = self.structures.moved(&self.surface.triangles)?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::BvhParams;
    use crate::scene::{CastOptions, HitBuffers, Rays};
    use crate::testing::{grid_scene_inside, Rng};

    /// Closest hits of `n` random rays from inside the box (status, triangle, t).
    fn cast(scene: &Scene, n: usize, seed: u64) -> Vec<(u8, i32, f64)> {
        let mut rng = Rng::xorshift(seed);
        let o: Vec<f64> = (0..3 * n).map(|_| 0.05 + 0.9 * rng.f()).collect();
        let d: Vec<f64> = (0..3 * n).map(|_| rng.f() - 0.5).collect();
        let rays = Rays {
            origins: &o[..],
            directions: &d[..],
            tmin: &[0.0],
            tmax: &[f64::INFINITY],
            leaving: None,
        };
        let mut b = HitBuffers::<f64>::new(n, false);
        scene.cast(&rays, b.out(), &CastOptions::default()).unwrap();
        (0..n)
            .map(|i| (b.status[i], b.triangle[i], b.t[i]))
            .collect()
    }

    /// A smooth displacement that vanishes on the box's sides: small enough to invert nothing
    /// in the jittered grid.
    fn bend(p: [f64; 3], amplitude: f64) -> [f64; 3] {
        let bump = |x: f64| (std::f64::consts::PI * x).sin();
        let s = amplitude * bump(p[0]) * bump(p[1]) * bump(p[2]);
        [p[0] + s, p[1] + 0.5 * s, p[2] - s]
    }

    /// Points in the order the scene was built with, moved by `f`.
    fn moved(pts: &[[f64; 3]], f: impl Fn([f64; 3]) -> [f64; 3]) -> Vec<[f64; 3]> {
        pts.iter().map(|&p| f(p)).collect()
    }

    fn triangles(points: &[[f64; 3]], faces: &[[u32; 3]]) -> Vec<[[f64; 3]; 3]> {
        faces
            .iter()
            .map(|f| f.map(|v| points[v as usize]))
            .collect()
    }

    /// A moved scene answers as a scene built from scratch on the moved points: the same
    /// hits, bit for bit (the walk is exact; only the tet order differs).
    #[test]
    fn moved_scene_answers_as_a_rebuilt_one() {
        let g = grid_scene_inside(&mut Rng::xorshift(3), 4, 0.3, 0.3);
        let mut scene = g.scene;
        let before = cast(&scene, 2000, 11);
        let pts = moved(&g.pts, |p| bend(p, 0.02));
        let tris = triangles(&pts, &g.faces);
        let m = scene.update_points(&pts, tris.clone()).unwrap();
        assert_eq!(
            m,
            Moved {
                inverted: 0,
                outside: 0,
                applied: true
            }
        );
        let ids: Vec<u32> = (0..g.faces.len() as u32).collect();
        let tets: Vec<[u32; 4]> = {
            // The scene's tets, renumbered back to the input's point ids.
            scene
                .mesh
                .tets
                .iter()
                .map(|t| t.map(|v| scene.input_index[v as usize]))
                .collect()
        };
        let fresh = Scene::build(pts.clone(), &tets, &g.faces, &ids, tris).unwrap();
        let after = cast(&scene, 2000, 11);
        assert_eq!(after, cast(&fresh, 2000, 11));
        assert_ne!(after, before, "the displacement moved some hit");
        for (k, &i) in scene.input_index.iter().enumerate() {
            assert_eq!(scene.mesh.points[k], pts[i as usize]);
            assert_eq!(scene.points_f32[k], pts[i as usize].map(|x| x as f32));
        }
    }

    /// A point pushed through its neighbourhood inverts tets: nothing changes.
    #[test]
    fn an_inverting_move_is_refused() {
        let g = grid_scene_inside(&mut Rng::xorshift(5), 3, 0.3, 0.3);
        let mut scene = g.scene;
        let before = cast(&scene, 500, 2);
        let points_before = scene.mesh.points.clone();
        // The grid's interior point nearest the centre (at about 1/3 or 2/3 in x) jumps past
        // the layer of points at the other third, out of the union of its tets.
        let k = (0..g.pts.len())
            .min_by(|&a, &b| {
                let d = |p: [f64; 3]| p.iter().map(|x| (x - 0.5) * (x - 0.5)).sum::<f64>();
                d(g.pts[a]).total_cmp(&d(g.pts[b]))
            })
            .unwrap();
        let mut pts = g.pts.clone();
        pts[k][0] = if pts[k][0] > 0.5 { 0.1 } else { 0.9 };
        let m = scene
            .update_points(&pts, triangles(&pts, &g.faces))
            .unwrap();
        assert!(!m.applied && m.inverted > 0 && m.outside == 0, "{m:?}");
        assert_eq!(scene.mesh.points, points_before);
        assert_eq!(cast(&scene, 500, 2), before);
        let (copy, m2) = scene.moved_copy(&pts, triangles(&pts, &g.faces)).unwrap();
        assert!(copy.is_none() && m2 == m);
    }

    /// A box point that moves, or an inner point on or past the box, is refused.
    #[test]
    fn the_box_stays() {
        let g = grid_scene_inside(&mut Rng::xorshift(8), 3, 0.3, 0.3);
        let mut scene = g.scene;
        let corner = g.pts.iter().position(|p| *p == [1.0, 1.0, 1.0]).unwrap();
        let mut pts = g.pts.clone();
        pts[corner] = [1.0, 1.0, 0.999];
        let m = scene
            .update_points(&pts, triangles(&pts, &g.faces))
            .unwrap();
        assert!(!m.applied && m.outside == 1, "{m:?}");
        let inner = g
            .pts
            .iter()
            .position(|p| p.iter().all(|&x| x > 0.0 && x < 1.0))
            .unwrap();
        let mut pts = g.pts.clone();
        pts[inner][2] = 1.5;
        let m = scene
            .update_points(&pts, triangles(&pts, &g.faces))
            .unwrap();
        assert!(!m.applied && m.outside == 1 && m.inverted > 0, "{m:?}");
    }

    /// Bad input is an error, not a panic, and changes nothing.
    #[test]
    fn bad_input_is_an_error() {
        let g = grid_scene_inside(&mut Rng::xorshift(9), 3, 0.3, 0.5);
        assert!(!g.faces.is_empty());
        let mut scene = g.scene;
        let tris = triangles(&g.pts, &g.faces);
        let short = &g.pts[1..];
        assert!(matches!(
            scene.update_points(short, tris.clone()),
            Err(Error::InvalidInput(_))
        ));
        let mut nan = g.pts.clone();
        nan[0][1] = f64::NAN;
        assert!(matches!(
            scene.update_points(&nan, tris.clone()),
            Err(Error::InvalidInput(_))
        ));
        assert!(matches!(
            scene.update_points(&g.pts, tris[1..].to_vec()),
            Err(Error::InvalidInput(_))
        ));
        let mut bad = tris.clone();
        bad[0][2][0] = f64::INFINITY;
        assert!(matches!(
            scene.update_points(&g.pts, bad),
            Err(Error::InvalidInput(_))
        ));
        let m = scene.update_points(&g.pts, tris).unwrap();
        assert!(m.applied, "the points as they are: {m:?}");
    }

    /// The moved copy equals the scene moved in place, and the original keeps its points.
    #[test]
    fn a_moved_copy_leaves_the_original() {
        let g = grid_scene_inside(&mut Rng::xorshift(4), 3, 0.3, 0.4);
        let mut scene = g.scene;
        scene
            .build_bvh(BvhParams {
                max_leaf: 2,
                ..Default::default()
            })
            .unwrap();
        scene.octree().unwrap();
        let before = cast(&scene, 800, 5);
        let pts = moved(&g.pts, |p| bend(p, 0.03));
        let tris = triangles(&pts, &g.faces);
        let (copy, m) = scene.moved_copy(&pts, tris.clone()).unwrap();
        let copy = copy.unwrap();
        assert!(m.applied);
        assert_eq!(cast(&scene, 800, 5), before);
        scene.update_points(&pts, tris).unwrap();
        assert_eq!(cast(&copy, 800, 5), cast(&scene, 800, 5));
        assert_eq!(copy.mesh.points, scene.mesh.points);
        // The BVH was built again, with the caller's parameters, on the moved triangles; the
        // octree (default parameters) waits for its next use.
        for s in [&scene, &copy] {
            let bvh = s.built_bvh().unwrap();
            assert_eq!(bvh.params.max_leaf, 2);
            for (k, &i) in bvh.order.iter().enumerate() {
                assert_eq!(bvh.triangles[k], s.surface.triangles[i as usize]);
            }
            assert_eq!(s.surface.triangles, triangles(&pts, &g.faces));
            assert!(s.structures.octree.get().is_none());
        }
    }
}
