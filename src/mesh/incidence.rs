//! Which constrained faces meet at a vertex or an edge of the mesh: what the exact walk reads
//! when a ray touches a vertex or an edge (a touch there meets every scene triangle around it,
//! whichever tets the walk passes through), and what containment reads for a point on one.

use super::build::{CONSTRAINED_BIT, OUTWARD_FACES};
use super::{TetMesh, BOUNDARY};

/// A constrained face: its three point ids (as the first tet listing it orders them) and the
/// index of one of its sides in [`TetMesh::constrained`] (which names the caller's triangle).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SurfaceFace {
    pub points: [u32; 3],
    pub side: u32,
}

/// Constrained faces by vertex (compressed rows): the faces around each point id.
#[derive(Clone, Debug, Default)]
pub struct Incidence {
    pub faces: Vec<SurfaceFace>,
    /// Some constrained face has a corner that is not a corner of its caller's triangle (the
    /// mesher split triangles with Steiner points, which sit an ulp off them): the exact
    /// queries then also check the caller's triangles around in-plane faces and touches
    /// (`query::contact`). Set by the scene, which knows the caller's triangles.
    pub split: bool,
    offsets: Vec<u32>,
    around: Vec<u32>,
}

impl Incidence {
    pub fn build(mesh: &TetMesh) -> Incidence {
        // Each constrained face appears once per tet side: keep the first by its sorted ids.
        let mut keyed: Vec<([u32; 3], SurfaceFace)> = Vec::new();
        for (t, links) in mesh.links.iter().enumerate() {
            for (i, &l) in links.iter().enumerate() {
                if l == BOUNDARY || l & CONSTRAINED_BIT == 0 {
                    continue;
                }
                let points = OUTWARD_FACES[i].map(|k| mesh.tets[t][k]);
                let mut key = points;
                key.sort_unstable();
                let side = l & !CONSTRAINED_BIT;
                keyed.push((key, SurfaceFace { points, side }));
            }
        }
        keyed.sort_unstable_by_key(|(k, f)| (*k, f.side));
        keyed.dedup_by_key(|(k, _)| *k);
        let faces: Vec<SurfaceFace> = keyed.into_iter().map(|(_, f)| f).collect();
        let mut offsets = vec![0u32; mesh.points.len() + 1];
        for f in &faces {
            for &v in &f.points {
                offsets[v as usize + 1] += 1;
            }
        }
        for k in 0..mesh.points.len() {
            offsets[k + 1] += offsets[k];
        }
        let mut fill = offsets.clone();
        let mut around = vec![0u32; offsets[mesh.points.len()] as usize];
        for (j, f) in faces.iter().enumerate() {
            for &v in &f.points {
                around[fill[v as usize] as usize] = j as u32;
                fill[v as usize] += 1;
            }
        }
        Incidence {
            faces,
            offsets,
            around,
            split: false,
        }
    }

    /// Indices (into `faces`) of the constrained faces having point `v` as a corner.
    #[inline]
    pub fn at_vertex(&self, v: u32) -> &[u32] {
        match (
            self.offsets.get(v as usize),
            self.offsets.get(v as usize + 1),
        ) {
            (Some(&a), Some(&b)) => &self.around[a as usize..b as usize],
            _ => &[],
        }
    }

    /// Indices of the constrained faces having edge (p, q) as a side.
    #[inline]
    pub fn at_edge(&self, p: u32, q: u32) -> impl Iterator<Item = u32> + '_ {
        self.at_vertex(p)
            .iter()
            .copied()
            .filter(move |&f| self.faces[f as usize].points.contains(&q))
    }

    pub fn bytes(&self) -> usize {
        self.faces.len() * 16 + self.offsets.len() * 4 + self.around.len() * 4
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{grid_scene, Rng};

    /// Every constrained face is listed once, at each of its corners and each of its edges,
    /// and nowhere else.
    #[test]
    fn faces_are_found_at_their_corners_and_edges() {
        let g = grid_scene(&mut Rng::xorshift(7), 3, 0.3, 0.5);
        let mesh = &g.scene.mesh;
        let inc = Incidence::build(mesh);
        let n_sides = mesh.constrained.len();
        // Interior constrained faces have two sides, those on the box one.
        assert!(inc.faces.len() * 2 >= n_sides && inc.faces.len() <= n_sides);
        for (j, f) in inc.faces.iter().enumerate() {
            for k in 0..3 {
                let (p, q) = (f.points[k], f.points[(k + 1) % 3]);
                assert!(inc.at_vertex(p).contains(&(j as u32)));
                assert!(inc.at_edge(p, q).any(|x| x == j as u32));
                assert!(inc.at_edge(q, p).any(|x| x == j as u32));
            }
        }
        let listed: usize = (0..mesh.points.len() as u32)
            .map(|v| inc.at_vertex(v).len())
            .sum();
        assert_eq!(listed, 3 * inc.faces.len());
        assert!(inc.at_vertex(u32::MAX).is_empty());
    }
}
