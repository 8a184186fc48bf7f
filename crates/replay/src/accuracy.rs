//! Image accuracy of a mode's frame against the reference frame (full
//! detail, frustum culling only, same camera): differing pixels, wrongly
//! culled pixels, PSNR.

use gigawalk_gpu::FrameImage;
use serde::Serialize;

/// How much nearer (relatively) the reference surface must be than the
/// result's before a pixel counts as wrongly culled. Reversed-Z depth is
/// near / distance, so a relative difference in depth is the same relative
/// difference in distance. Both images come from the same rasterizer, so
/// with the same triangles they are bit-identical; 1e-5 is ~80 f32 ulps,
/// far above rounding noise, and 10 um at 1 m. A coarser LOD whose surface
/// lies behind the original by more than this also counts: its pixels
/// show something that is not there in the reference.
pub const WRONGLY_CULLED_RELATIVE_DEPTH: f32 = 1e-5;

/// One frame's comparison.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Accuracy {
    pub pixels: u64,
    /// Pixels whose RGB differs at all (8-bit sRGB; alpha ignored).
    pub differing_pixels: u64,
    /// Pixels where the reference depth is nearer than the result's beyond
    /// [`WRONGLY_CULLED_RELATIVE_DEPTH`]: something that should show is
    /// missing.
    pub wrongly_culled_pixels: u64,
    /// Sum of squared 8-bit RGB differences, for pooling PSNR over frames.
    pub squared_error: f64,
}

impl Accuracy {
    /// Compares `result` with `reference`; `None` when their sizes differ.
    pub fn compare(reference: &FrameImage, result: &FrameImage) -> Option<Accuracy> {
        let (r, x) = (&reference.depth, &result.depth);
        let n = (r.width as usize) * (r.height as usize);
        if r.width != x.width
            || r.height != x.height
            || r.depth.len() != n
            || x.depth.len() != n
            || reference.colour.len() != 4 * n
            || result.colour.len() != 4 * n
        {
            return None;
        }
        let mut acc = Accuracy {
            pixels: n as u64,
            ..Default::default()
        };
        for (a, b) in reference
            .colour
            .chunks_exact(4)
            .zip(result.colour.chunks_exact(4))
        {
            let mut diff = false;
            for c in 0..3 {
                let d = a[c] as f64 - b[c] as f64;
                acc.squared_error += d * d;
                diff |= a[c] != b[c];
            }
            acc.differing_pixels += diff as u64;
        }
        acc.wrongly_culled_pixels = r
            .depth
            .iter()
            .zip(&x.depth)
            .filter(|(r, x)| **r > **x * (1.0 + WRONGLY_CULLED_RELATIVE_DEPTH))
            .count() as u64;
        Some(acc)
    }

    /// Pools two comparisons.
    pub fn add(&mut self, o: &Accuracy) {
        self.pixels += o.pixels;
        self.differing_pixels += o.differing_pixels;
        self.wrongly_culled_pixels += o.wrongly_culled_pixels;
        self.squared_error += o.squared_error;
    }

    pub fn differing_fraction(&self) -> f64 {
        self.differing_pixels as f64 / self.pixels.max(1) as f64
    }

    pub fn wrongly_culled_fraction(&self) -> f64 {
        self.wrongly_culled_pixels as f64 / self.pixels.max(1) as f64
    }

    /// PSNR of the RGB channels in dB, from the pooled mean squared error;
    /// `None` for identical images (infinite PSNR).
    pub fn psnr_db(&self) -> Option<f64> {
        if self.squared_error == 0.0 || self.pixels == 0 {
            return None;
        }
        let mse = self.squared_error / (3.0 * self.pixels as f64);
        Some(10.0 * (255.0 * 255.0 / mse).log10())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use gigawalk_gpu::DepthImage;

    fn image(colour: &[[u8; 4]], depth: &[f32]) -> FrameImage {
        FrameImage {
            colour: colour.iter().flatten().copied().collect(),
            depth: DepthImage {
                width: depth.len() as u32,
                height: 1,
                depth: depth.to_vec(),
            },
        }
    }

    #[test]
    fn identical_images() {
        let a = image(&[[1, 2, 3, 255], [0, 0, 0, 0]], &[0.5, 0.0]);
        let acc = Accuracy::compare(&a, &a).unwrap();
        assert_eq!(
            (acc.pixels, acc.differing_pixels, acc.wrongly_culled_pixels),
            (2, 0, 0)
        );
        assert_eq!(acc.psnr_db(), None);
    }

    #[test]
    fn missing_object_is_wrongly_culled() {
        // Reference: an object at depth 0.5 in pixel 0; result: empty there.
        let r = image(&[[200, 0, 0, 255], [0, 0, 0, 255]], &[0.5, 0.0]);
        let x = image(&[[0, 0, 0, 255], [0, 0, 0, 255]], &[0.0, 0.0]);
        let acc = Accuracy::compare(&r, &x).unwrap();
        assert_eq!((acc.differing_pixels, acc.wrongly_culled_pixels), (1, 1));
        // MSE = 200^2 / 6 -> PSNR = 10 log10(255^2 * 6 / 200^2).
        let want = 10.0 * (255.0f64 * 255.0 * 6.0 / 40000.0).log10();
        assert!((acc.psnr_db().unwrap() - want).abs() < 1e-9);
    }

    #[test]
    fn nearer_result_is_not_wrongly_culled() {
        // The result shows something in front of the reference surface
        // (a coarse LOD bulging out): a difference, not a missing object.
        let r = image(&[[9, 9, 9, 255]], &[0.25]);
        let x = image(&[[7, 9, 9, 255]], &[0.5]);
        let acc = Accuracy::compare(&r, &x).unwrap();
        assert_eq!((acc.differing_pixels, acc.wrongly_culled_pixels), (1, 0));
    }

    #[test]
    fn depth_rounding_is_tolerated() {
        let d = 0.3f32;
        let r = image(&[[9, 9, 9, 255]], &[f32::from_bits(d.to_bits() + 4)]);
        let x = image(&[[9, 9, 9, 255]], &[d]);
        assert_eq!(Accuracy::compare(&r, &x).unwrap().wrongly_culled_pixels, 0);
    }

    #[test]
    fn size_mismatch() {
        let r = image(&[[9, 9, 9, 255]], &[0.25]);
        let x = image(&[[9, 9, 9, 255], [9, 9, 9, 255]], &[0.25, 0.25]);
        assert_eq!(Accuracy::compare(&r, &x), None);
    }
}
