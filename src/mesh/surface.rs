//! The caller's triangles, which hits are evaluated on, and for meshers whose faces only lie
//! near them (fTetWild) the neighbours a hit may name instead.

use crate::error::{Error, Result};

/// Refuses triangles with a NaN or infinite corner, naming the first.
pub fn check_finite(triangles: &[[[f64; 3]; 3]]) -> Result<()> {
    match triangles
        .iter()
        .position(|t| !t.iter().flatten().all(|x| x.is_finite()))
    {
        Some(k) => Err(Error::InvalidInput(format!(
            "triangle {k} has a non-finite corner"
        ))),
        None => Ok(()),
    }
}

/// The caller's triangles (three corners each), indexed by the ids constrained faces carry.
#[derive(Clone, Debug, Default)]
pub struct Surface {
    pub triangles: Vec<[[f64; 3]; 3]>,
    /// Per caller triangle, the triangles a hit on a face naming it may lie on instead (empty
    /// for exact meshers; see [`Surface::set_alternatives`]).
    pub alternatives: Alternatives,
}

/// Triangles that may hold a hit instead of the one a constrained face names, in CSR form:
/// those of triangle `k` are `ids[offsets[k]..offsets[k + 1]]`.
#[derive(Clone, Debug, Default)]
pub struct Alternatives {
    pub offsets: Vec<u32>,
    pub ids: Vec<u32>,
}

impl Alternatives {
    #[inline]
    pub fn of(&self, triangle: u32) -> &[u32] {
        match self.offsets.get(triangle as usize..triangle as usize + 2) {
            Some(&[a, b]) => &self.ids[a as usize..b as usize],
            _ => &[],
        }
    }
}

impl Surface {
    /// Lets hits name another triangle than the constrained face's own: of `offsets` (one
    /// per caller triangle, plus one) and `ids` (CSR, see [`Alternatives`]). For meshers whose
    /// faces lie near the input rather than on it (fTetWild): a face names the triangle
    /// nearest its centre, but a ray through it may cross a neighbour of that triangle; the
    /// hit then names the alternative the ray crosses nearest the face.
    pub fn set_alternatives(&mut self, offsets: Vec<u32>, ids: Vec<u32>) -> Result<()> {
        let n = self.triangles.len();
        if offsets.len() != n + 1 {
            return Err(Error::InvalidInput(format!(
                "alternatives: {} offsets for {n} triangles (expected {})",
                offsets.len(),
                n + 1
            )));
        }
        if offsets[0] != 0
            || offsets.windows(2).any(|w| w[0] > w[1])
            || offsets[n] as usize != ids.len()
        {
            return Err(Error::InvalidInput(
                "alternatives: offsets must rise from 0 to the number of ids".into(),
            ));
        }
        if let Some(k) = ids.iter().position(|&t| t as usize >= n) {
            return Err(Error::InvalidInput(format!(
                "alternatives: id {k} names triangle {} but only {n} triangles were given",
                ids[k]
            )));
        }
        self.alternatives = Alternatives { offsets, ids };
        Ok(())
    }

    /// Bytes of the alternatives table.
    pub fn alternatives_bytes(&self) -> usize {
        (self.alternatives.offsets.len() + self.alternatives.ids.len()) * 4
    }
}
