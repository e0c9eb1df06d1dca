//! A pinhole camera's float32 rays, made the same way on the CPU and on the GPU
//! (`shaders/camera.wgsl`, issue 34's item 5).
//!
//! The ray through pixel (i, j) starts at the eye and has the direction
//!
//! ```text
//! d = (forward + xs[j] * right) + ys[i] * up          (each operation rounded to float32)
//! d = d / sqrt((d0 * d0 + d1 * d1) + d2 * d2)         (when the camera normalizes)
//! ```
//!
//! from the camera's numbers rounded once to float32. IEEE arithmetic rounds each of these
//! operations correctly, so the result is one set of bits, whoever computes it: numpy's
//! float32 arithmetic, [`direction`] (Rust never fuses a multiply and an add unasked) and the
//! device's kernel, which undoes its driver's freedoms (fusing, flushing subnormals, a `sqrt`
//! and a `/` a few ulps off) and hands back the rays where it cannot. A cast of a camera's
//! rays then answers the same on every device. `tetrace.Camera.rays(np.float32)` calls
//! [`directions`].

use crate::error::{Error, Result};

/// A camera's numbers in float32: the three axes (the direction `xs` steps along, the one
/// `ys` steps along, the one through the image plane's origin), each column's and each row's
/// image-plane coordinate, and whether directions are scaled to unit length.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraF32 {
    pub right: [f32; 3],
    pub up: [f32; 3],
    pub forward: [f32; 3],
    pub xs: Vec<f32>,
    pub ys: Vec<f32>,
    pub normalize: bool,
}

/// Inputs the device's kernel takes (`CameraF32::fits_device`): zero, or a magnitude within
/// [2^-60, 2^30], so that no product, sum, square or norm leaves float32's normal range.
pub const DEVICE_MIN: f32 = 8.673617e-19; // 2^-60
pub const DEVICE_MAX: f32 = 1_073_741_824.0; // 2^30

impl CameraF32 {
    pub fn width(&self) -> usize {
        self.xs.len()
    }

    pub fn height(&self) -> usize {
        self.ys.len()
    }

    pub fn n_rays(&self) -> usize {
        self.xs.len() * self.ys.len()
    }

    /// Refuses a camera with no pixels or a number that is not finite.
    pub fn check(&self) -> Result<()> {
        if self.xs.is_empty() || self.ys.is_empty() {
            return Err(Error::InvalidInput(format!(
                "a camera needs at least one pixel, got {} x {}",
                self.xs.len(),
                self.ys.len()
            )));
        }
        if !self.numbers().all(f32::is_finite) {
            return Err(Error::InvalidInput(
                "a camera's axes and image-plane coordinates must be finite in float32".into(),
            ));
        }
        Ok(())
    }

    fn numbers(&self) -> impl Iterator<Item = f32> + '_ {
        (self.right.iter().chain(&self.up).chain(&self.forward))
            .chain(&self.xs)
            .chain(&self.ys)
            .copied()
    }

    /// Whether the device's kernel can make this camera's rays: every number zero or of a
    /// magnitude within [[`DEVICE_MIN`], [`DEVICE_MAX`]]. (Any field of view short of 180°
    /// and any pixel grid a real camera has qualify; the others are made on the host.)
    pub fn fits_device(&self) -> bool {
        self.numbers()
            .all(|x| x == 0.0 || (DEVICE_MIN..=DEVICE_MAX).contains(&x.abs()))
    }

    /// The direction of ray `p` (row-major: row p / width, column p % width).
    #[inline]
    pub fn ray(&self, p: usize) -> [f32; 3] {
        let w = self.width();
        direction(self, self.xs[p % w], self.ys[p / w])
    }
}

/// The direction through the pixel at image-plane coordinates (x, y): the module's recipe,
/// operation by operation (the kernel's twin).
#[inline]
pub fn direction(c: &CameraF32, x: f32, y: f32) -> [f32; 3] {
    let d: [f32; 3] = std::array::from_fn(|k| (c.forward[k] + x * c.right[k]) + y * c.up[k]);
    if !c.normalize {
        return d;
    }
    let n = ((d[0] * d[0] + d[1] * d[1]) + d[2] * d[2]).sqrt();
    d.map(|v| v / n)
}

/// Every ray's direction, row-major, three floats a ray, on `threads` threads.
pub fn directions(c: &CameraF32, threads: Option<usize>) -> Result<Vec<f32>> {
    c.check()?;
    let n = c.n_rays();
    let mut out = crate::error::try_vec(3 * n, 0f32, "the camera's directions")?;
    const PIECE: usize = 16_384;
    let pieces: Vec<(usize, &mut [f32])> = out.chunks_mut(3 * PIECE).enumerate().collect();
    crate::threads::run_pieces(pieces, threads, |(k, piece)| {
        for (j, d) in piece.chunks_exact_mut(3).enumerate() {
            d.copy_from_slice(&c.ray(k * PIECE + j));
        }
    })?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn look_at() -> CameraF32 {
        CameraF32 {
            right: [0.8, 0.0, -0.6],
            up: [0.0, 1.0, 0.0],
            forward: [0.6, 0.0, 0.8],
            xs: (0..7).map(|j| (j as f32 - 3.0) * 0.1).collect(),
            ys: (0..5).map(|i| (2.0 - i as f32) * 0.1).collect(),
            normalize: true,
        }
    }

    /// The recipe written out once more in float64 and rounded at every step (a float64
    /// operation on float32 numbers, rounded to float32, is the correctly rounded float32
    /// operation for +, −, ×, / and sqrt: float64 has more than 2·24 + 2 bits), against
    /// [`direction`]: the same bits for every pixel.
    #[test]
    fn directions_are_the_recipe_rounded_at_every_step() {
        let mut c = look_at();
        for normalize in [true, false] {
            c.normalize = normalize;
            let got = directions(&c, Some(2)).unwrap();
            let r = |x: f64| x as f32 as f64;
            for (p, g) in got.chunks(3).enumerate() {
                let (x, y) = (c.xs[p % 7] as f64, c.ys[p / 7] as f64);
                let d: [f64; 3] = std::array::from_fn(|k| {
                    r(r(c.forward[k] as f64 + r(x * c.right[k] as f64)) + r(y * c.up[k] as f64))
                });
                let want = if normalize {
                    let n = r(r(r(r(d[0] * d[0]) + r(d[1] * d[1])) + r(d[2] * d[2])).sqrt());
                    d.map(|v| r(v / n))
                } else {
                    d
                };
                for k in 0..3 {
                    assert_eq!(g[k].to_bits(), (want[k] as f32).to_bits(), "pixel {p}");
                }
            }
        }
    }

    #[test]
    fn bad_cameras_are_refused_and_extreme_ones_stay_on_the_host() {
        let mut c = look_at();
        assert!(c.fits_device());
        c.xs[2] = 1e-30;
        assert!(!c.fits_device());
        c.xs[2] = f32::NAN;
        assert!(matches!(directions(&c, None), Err(Error::InvalidInput(_))));
        c.xs.clear();
        assert!(matches!(directions(&c, None), Err(Error::InvalidInput(_))));
    }
}
