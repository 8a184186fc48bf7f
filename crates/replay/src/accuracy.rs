//! Image accuracy of a mode's frame against the reference frame (full
//! detail, frustum culling only, same camera): differing pixels, wrongly
//! culled pixels, PSNR, and the pixels that break the pixel-error bound.

use gigawalk_gpu::{DepthImage, FrameImage};
use rayon::prelude::*;
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

/// How far apart (relatively, in view distance) two depth samples may be
/// and still show the same surface, for the pixel-error bound
/// ([`bound_violations`]). Depth is tested at all so that a surface does
/// not "match" a different one that happens to cover the same pixels:
/// distinct surfaces in these models (a pipe and the wall behind it, two
/// floors) are usually centimetres to metres apart at metres of distance,
/// 1e-2 and more, while the same surface drawn twice with the same
/// triangles is bit-identical and a simplified planar region keeps its
/// plane (differences near f32 rounding, 1e-7). 1e-3 sits between: 1 mm
/// at 1 m. It is a fixed relative depth, not scaled with the tolerance: a
/// coarse LOD that moves a surface along the view ray by more than 0.1%
/// counts even where it stays within p pixels on screen (at 640x360 and a
/// 60 degree field of view, 1e-3 of the distance is about a third of a
/// pixel's footprint; at 1920x1080 about one).
pub const BOUND_RELATIVE_DEPTH: f32 = 1e-3;

/// The relative depth match of [`bound_exceedances`] at pixel-error
/// tolerance `p` and `ppr` pixels per radian (viewport height / (2
/// tan(fovy / 2))): [`BOUND_RELATIVE_DEPTH`] plus p / ppr. A surface moved
/// by the object-space error a tolerance of p pixels allows at view
/// distance z, p z / ppr, moves along the view ray by at most that too: a
/// relative depth of p / ppr. [`BOUND_RELATIVE_DEPTH`] stays as the
/// allowance for rasterising the same surface with different triangles.
/// A NaN, negative or infinite ratio adds nothing.
pub fn scaled_relative_depth(p: f64, ppr: f64) -> f32 {
    let extra = p / ppr;
    let extra = if extra.is_finite() && extra > 0.0 {
        extra as f32
    } else {
        0.0
    };
    BOUND_RELATIVE_DEPTH + extra
}

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
    /// Pixels that break the pixel-error bound ([`bound_violations`]):
    /// the result's surface has no match in the reference within the
    /// window, or the reference's none in the result.
    pub bound_violating_pixels: u64,
    /// Pixels that break the bound with the depth match scaled to the
    /// tolerance ([`bound_exceedances`]): what the bound itself promises,
    /// on screen and in depth. At most `bound_violating_pixels`.
    pub bound_exceeding_pixels: u64,
    /// Sum of squared 8-bit RGB differences, for pooling PSNR over frames.
    pub squared_error: f64,
}

impl Accuracy {
    /// Compares `result`, rendered at pixel-error tolerance
    /// `pixel_error` (0 for full detail) by a camera with
    /// `pixels_per_radian`, with `reference`; `None` when their sizes
    /// differ.
    pub fn compare(
        reference: &FrameImage,
        result: &FrameImage,
        pixel_error: f64,
        pixels_per_radian: f64,
    ) -> Option<Accuracy> {
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
        acc.bound_violating_pixels = bound_violations(r, x, pixel_error)?;
        acc.bound_exceeding_pixels = if acc.bound_violating_pixels == 0 {
            0
        } else {
            bound_exceedances(r, x, pixel_error, pixels_per_radian)?
        };
        Some(acc)
    }

    /// Pools two comparisons.
    pub fn add(&mut self, o: &Accuracy) {
        self.pixels += o.pixels;
        self.differing_pixels += o.differing_pixels;
        self.wrongly_culled_pixels += o.wrongly_culled_pixels;
        self.bound_violating_pixels += o.bound_violating_pixels;
        self.bound_exceeding_pixels += o.bound_exceeding_pixels;
        self.squared_error += o.squared_error;
    }

    pub fn differing_fraction(&self) -> f64 {
        self.differing_pixels as f64 / self.pixels.max(1) as f64
    }

    pub fn wrongly_culled_fraction(&self) -> f64 {
        self.wrongly_culled_pixels as f64 / self.pixels.max(1) as f64
    }

    pub fn bound_violating_fraction(&self) -> f64 {
        self.bound_violating_pixels as f64 / self.pixels.max(1) as f64
    }

    pub fn bound_exceeding_fraction(&self) -> f64 {
        self.bound_exceeding_pixels as f64 / self.pixels.max(1) as f64
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

/// Half-width in pixels of the square window [`bound_violations`] searches
/// at pixel-error tolerance `p`: ceil(p) + 1. The ceiling because a
/// surface `p` pixels off lands in the pixel ceil(p) away; the extra pixel
/// because rasterisation decides coverage at pixel centres, so an edge
/// moved by less than a pixel can still change the covered pixel by one.
/// A NaN or negative `p` is 0.
pub fn bound_window(p: f64) -> usize {
    // `as` saturates: NaN and negatives become 0, huge values usize::MAX.
    (p.ceil() as usize).saturating_add(1)
}

/// Whether depth samples match one reference depth `d`: the surface in
/// both is the same within [`BOUND_RELATIVE_DEPTH`] of view distance.
/// Reversed-Z depth is near / distance, so the farther distance over the
/// nearer is max(a, b) / min(a, b); checking `e` against the range
/// [d / (1 + t), d * (1 + t)] is that test without a division per sample.
/// Background (depth 0) matches only background. A NaN or negative `d`
/// gives an empty range and a NaN `e` fails both comparisons, so NaN never
/// matches.
#[derive(Clone, Copy)]
struct SameSurface {
    lo: f32,
    hi: f32,
}

impl SameSurface {
    /// The match of [`BOUND_RELATIVE_DEPTH`].
    fn of(d: f32) -> SameSurface {
        SameSurface::within(d, BOUND_RELATIVE_DEPTH)
    }

    /// The match of relative depth `relative`.
    fn within(d: f32, relative: f32) -> SameSurface {
        let t = 1.0 + relative;
        if d.is_finite() && d > 0.0 {
            SameSurface {
                lo: d / t,
                hi: d * t,
            }
        } else if d == 0.0 {
            SameSurface { lo: 0.0, hi: 0.0 }
        } else {
            // Empty: nothing matches a NaN, infinite or negative depth.
            SameSurface {
                lo: f32::INFINITY,
                hi: f32::NEG_INFINITY,
            }
        }
    }

    fn matches(self, e: f32) -> bool {
        // `&`, not `&&`: no branch, so a row of the window vectorises.
        (self.lo <= e) & (e <= self.hi)
    }
}

/// Whether reference depth `a` and result depth `b` at one pixel show the
/// same surface. Almost every pixel does, most often bit-identically: this
/// one test settles both directions of the bound there, and equality
/// (which [`SameSurface`] would also accept) saves its division.
fn same_at_centre(a: f32, b: f32) -> bool {
    (a == b && (0.0..f32::INFINITY).contains(&a)) || SameSurface::of(a).matches(b)
}

/// Whether pixel (x, y), whose two depths differ (not
/// [`same_at_centre`]), breaks the bound: the result's depth there has no
/// match in `reference` within `r` pixels (square window, clipped at the
/// border), or the reference's depth there none in `result`. `w` and `h`
/// are the images' size; both slices hold w * h samples.
fn violates_in_window(
    reference: &[f32],
    result: &[f32],
    (w, h): (usize, usize),
    (r, relative): (usize, f32),
    (x, y): (usize, usize),
) -> bool {
    let i = y * w + x;
    let (x0, x1) = (x.saturating_sub(r), x.saturating_add(r).min(w - 1));
    let (y0, y1) = (y.saturating_sub(r), y.saturating_add(r).min(h - 1));
    let near = |image: &[f32], d: f32| {
        let m = SameSurface::within(d, relative);
        // Whole rows without an early exit inside: a window row is at most
        // 2r + 1 samples, which a vectorised fold checks faster than a
        // branch per sample.
        (y0..=y1).any(|v| {
            image[v * w + x0..=v * w + x1]
                .iter()
                .fold(false, |found, &e| found | m.matches(e))
        })
    };
    !near(reference, result[i]) || !near(result, reference[i])
}

/// Pixels of `result` (rendered at pixel-error tolerance `p`) that break
/// the bound against `reference`: where the result shows a surface (or
/// background) that no reference pixel within [`bound_window`]`(p)` pixels
/// shows, or the reference shows one that no result pixel within the
/// window shows (geometry that appeared or vanished). Each pixel counts
/// once, whichever way it fails. `None` when the sizes differ.
///
/// Parallel over rows on rayon's pool; most pixels match at the centre, so
/// the window is searched only around differences.
pub fn bound_violations(reference: &DepthImage, result: &DepthImage, p: f64) -> Option<u64> {
    window_mismatches(reference, result, p, BOUND_RELATIVE_DEPTH)
}

/// [`bound_violations`] with the depth match scaled to the tolerance
/// ([`scaled_relative_depth`]`(p, ppr)`): pixels where the image departs
/// from the reference by more than the bound promises, p pixels on screen
/// and p pixels' worth of object-space error along the view ray. Where
/// [`bound_violations`] counts and this does not, a surface moved in
/// depth by more than [`BOUND_RELATIVE_DEPTH`] but within the bound.
pub fn bound_exceedances(
    reference: &DepthImage,
    result: &DepthImage,
    p: f64,
    ppr: f64,
) -> Option<u64> {
    window_mismatches(reference, result, p, scaled_relative_depth(p, ppr))
}

/// Pixels whose depths differ beyond `relative` at the centre and have no
/// match within [`bound_window`]`(p)` one way or the other.
fn window_mismatches(
    reference: &DepthImage,
    result: &DepthImage,
    p: f64,
    relative: f32,
) -> Option<u64> {
    let (w, h) = (reference.width as usize, reference.height as usize);
    let n = w * h;
    if result.width != reference.width
        || result.height != reference.height
        || reference.depth.len() != n
        || result.depth.len() != n
    {
        return None;
    }
    if n == 0 {
        return Some(0);
    }
    // A window wider than the image is the whole image.
    let r = bound_window(p).min(w.max(h));
    let (a, b) = (reference.depth.as_slice(), result.depth.as_slice());
    Some(
        (0..h)
            .into_par_iter()
            .map(|y| {
                let row = y * w..(y + 1) * w;
                a[row.clone()]
                    .iter()
                    .zip(&b[row])
                    .enumerate()
                    .filter(|&(x, (&ra, &rb))| {
                        !same_at_centre(ra, rb)
                            && violates_in_window(a, b, (w, h), (r, relative), (x, y))
                    })
                    .count() as u64
            })
            .sum(),
    )
}

/// Whether pixel `p` differs between two images: any colour channel by
/// more than 2 of 255, or depth not the same surface
/// ([`BOUND_RELATIVE_DEPTH`], as the bound's test).
fn changed(a: &FrameImage, b: &FrameImage, p: usize) -> bool {
    let (ca, cb) = (&a.colour[4 * p..4 * p + 3], &b.colour[4 * p..4 * p + 3]);
    let colour = ca.iter().zip(cb).any(|(x, y)| x.abs_diff(*y) > 2);
    colour || !same_at_centre(a.depth.depth[p], b.depth.depth[p])
}

/// Popping between two consecutive frames: the share of pixels that change
/// from the run's frame `a` to its next frame `b` while the full-detail
/// reference's same two frames (`ref_a`, `ref_b`) do not change there. A
/// pixel the camera's motion changes changes in both and does not count; a
/// LOD switch or a culling change between the two frames does. 0 for a run
/// drawing what the reference draws. `None` when the sizes differ.
pub fn popping(
    ref_a: &FrameImage,
    ref_b: &FrameImage,
    a: &FrameImage,
    b: &FrameImage,
) -> Option<f64> {
    let n = a.depth.depth.len();
    let ok = |x: &FrameImage| x.depth.depth.len() == n && x.colour.len() == 4 * n;
    if n == 0 || ![ref_a, ref_b, a, b].into_iter().all(ok) {
        return None;
    }
    let popped = (0..n)
        .filter(|&p| changed(a, b, p) && !changed(ref_a, ref_b, p))
        .count();
    Some(popped as f64 / n as f64)
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
        let acc = Accuracy::compare(&a, &a, 0.0, 300.0).unwrap();
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
        let acc = Accuracy::compare(&r, &x, 0.0, 300.0).unwrap();
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
        let acc = Accuracy::compare(&r, &x, 0.0, 300.0).unwrap();
        assert_eq!((acc.differing_pixels, acc.wrongly_culled_pixels), (1, 0));
    }

    #[test]
    fn depth_rounding_is_tolerated() {
        let d = 0.3f32;
        let r = image(&[[9, 9, 9, 255]], &[f32::from_bits(d.to_bits() + 4)]);
        let x = image(&[[9, 9, 9, 255]], &[d]);
        assert_eq!(
            Accuracy::compare(&r, &x, 0.0, 300.0)
                .unwrap()
                .wrongly_culled_pixels,
            0
        );
    }

    #[test]
    fn size_mismatch() {
        let r = image(&[[9, 9, 9, 255]], &[0.25]);
        let x = image(&[[9, 9, 9, 255], [9, 9, 9, 255]], &[0.25, 0.25]);
        assert_eq!(Accuracy::compare(&r, &x, 0.0, 300.0), None);
    }

    /// A depth image from rows of characters: '.' background (0), 'a'
    /// depth 0.5, 'b' depth 0.25, 'n' NaN.
    fn depth(rows: &[&str]) -> DepthImage {
        let width = rows.first().map_or(0, |r| r.len()) as u32;
        let depth = rows
            .iter()
            .flat_map(|r| r.chars())
            .map(|c| match c {
                '.' => 0.0,
                'a' => 0.5,
                'b' => 0.25,
                'n' => f32::NAN,
                _ => panic!("unknown depth character {c:?}"),
            })
            .collect();
        DepthImage {
            width,
            height: rows.len() as u32,
            depth,
        }
    }

    /// The violating pixels of `result` against `reference` at tolerance
    /// `p`, as rows of '.' (fine) and 'X' (violates); checks that
    /// [`bound_violations`] counts the same.
    fn violation_map(reference: &[&str], result: &[&str], p: f64) -> Vec<String> {
        let (a, b) = (depth(reference), depth(result));
        let (w, h) = (a.width as usize, a.height as usize);
        let r = bound_window(p).min(w.max(h));
        let map: Vec<String> = (0..h)
            .map(|y| {
                (0..w)
                    .map(|x| {
                        let i = y * w + x;
                        !same_at_centre(a.depth[i], b.depth[i])
                            && violates_in_window(
                                &a.depth,
                                &b.depth,
                                (w, h),
                                (r, BOUND_RELATIVE_DEPTH),
                                (x, y),
                            )
                    })
                    .map(|v| match v {
                        true => 'X',
                        false => '.',
                    })
                    .collect()
            })
            .collect();
        let marked = map
            .iter()
            .flat_map(|r| r.chars())
            .filter(|&c| c == 'X')
            .count();
        assert_eq!(bound_violations(&a, &b, p), Some(marked as u64));
        map
    }

    #[test]
    fn window_is_ceil_p_plus_one() {
        assert_eq!(bound_window(0.0), 1);
        assert_eq!(bound_window(0.5), 2);
        assert_eq!(bound_window(1.0), 2);
        assert_eq!(bound_window(8.0), 9);
        assert_eq!(bound_window(f64::NAN), 1);
        assert_eq!(bound_window(-3.0), 1);
        assert_eq!(bound_window(f64::INFINITY), usize::MAX);
    }

    #[test]
    fn bound_identical_images() {
        let img = ["..aa..", ".abba.", "..aa.."];
        assert_eq!(violation_map(&img, &img, 0.0), ["......"; 3]);
    }

    #[test]
    fn bound_background_matches_background() {
        let img = ["....", "...."];
        assert_eq!(violation_map(&img, &img, 0.0), ["...."; 2]);
    }

    #[test]
    fn bound_shift_by_one_pixel_within_window() {
        // p = 1: window 2; a surface one pixel to the right is fine.
        let r = ["..aaaa....", "..aaaa...."];
        let x = ["...aaaa...", "...aaaa..."];
        assert_eq!(violation_map(&r, &x, 1.0), [".........."; 2]);
    }

    #[test]
    fn bound_shift_by_three_pixels_violates_at_edges() {
        // p = 1: window 2; the surface moved 3 pixels right. Pixel 2: the
        // reference surface has no result surface within 2 (nearest at 5).
        // Pixel 4: result background, reference background nearest at 1.
        // Pixel 8: reference background, result background nearest at 11.
        // Pixel 10: result surface, reference surface nearest at 7.
        let r = ["..aaaaaa......"];
        let x = [".....aaaaaa..."];
        assert_eq!(violation_map(&r, &x, 1.0), ["..X.X...X.X..."]);
    }

    #[test]
    fn bound_vertical_shift_uses_the_square_window() {
        // Moved 2 pixels down and 2 right: within a window of 2 (p = 1) in
        // Chebyshev distance, though 2.8 pixels away in Euclidean.
        let r = ["aa....", "aa....", "......", "......"];
        let x = ["......", "......", "..aa..", "..aa.."];
        assert_eq!(violation_map(&r, &x, 1.0), ["......"; 4]);
        // p = 0: window 1; only the corners facing each other are
        // within one pixel (diagonally) of the other image's surface.
        assert_eq!(
            violation_map(&r, &x, 0.0),
            ["XX....", "X.....", "...X..", "..XX.."]
        );
    }

    #[test]
    fn bound_vanished_surface_counts_every_pixel() {
        let r = ["........", "..aaaa..", "..aaaa..", "........"];
        let x = ["........"; 4];
        // Window 2 reaches the background beside the surface from every one
        // of its pixels, so only the reference direction fails.
        assert_eq!(
            violation_map(&r, &x, 1.0),
            ["........", "..XXXX..", "..XXXX..", "........"]
        );
    }

    #[test]
    fn bound_appeared_surface_counts_every_pixel() {
        let r = ["......"; 3];
        let x = ["......", ".bbbb.", "......"];
        assert_eq!(violation_map(&r, &x, 8.0), ["......", ".XXXX.", "......"]);
    }

    #[test]
    fn bound_surface_in_front_is_not_a_match() {
        // The same pixels, a different surface (0.25 vs 0.5): nothing
        // within the window has the result's depth.
        let r = ["aaa", "aaa", "aaa"];
        let x = ["aaa", "aba", "aaa"];
        assert_eq!(violation_map(&r, &x, 1.0), ["...", ".X.", "..."]);
    }

    #[test]
    fn bound_depth_tolerance_is_relative() {
        let check = |relative: f32| {
            let r = DepthImage {
                width: 1,
                height: 1,
                depth: vec![0.4],
            };
            // Distance differs by `relative`: depth = near / distance.
            let x = DepthImage {
                depth: vec![0.4 / (1.0 + relative)],
                ..r.clone()
            };
            (
                bound_violations(&r, &x, 0.0).unwrap(),
                bound_violations(&x, &r, 0.0).unwrap(),
            )
        };
        assert_eq!(check(2e-3), (1, 1));
        assert_eq!(check(5e-4), (0, 0));
        assert_eq!(check(-2e-3), (1, 1));
        assert_eq!(check(-5e-4), (0, 0));
    }

    #[test]
    fn bound_border_pixels_clip_the_window() {
        // Corners and edges with a window larger than the image.
        let r = ["a.", ".b"];
        let x = [".a", "b."];
        assert_eq!(violation_map(&r, &x, 0.0), ["..", ".."]);
        assert_eq!(violation_map(&r, &x, 100.0), ["..", ".."]);
        let x = ["..", ".."];
        assert_eq!(violation_map(&r, &x, f64::INFINITY), ["X.", ".X"]);
        assert_eq!(violation_map(&["a"], &["."], 3.0), ["X"]);
    }

    #[test]
    fn bound_nan_depth_never_matches() {
        let r = ["aaa", "ana", "aaa"];
        // NaN in the reference: no result pixel matches it.
        assert_eq!(violation_map(&r, &["aaa"; 3], 1.0), ["...", ".X.", "..."]);
        // NaN in both at the same pixel: still no match, even with itself.
        assert_eq!(violation_map(&r, &r, 1.0), ["...", ".X.", "..."]);
        // NaN in the result.
        assert_eq!(violation_map(&["aaa"; 3], &r, 1.0), ["...", ".X.", "..."]);
    }

    #[test]
    fn bound_empty_and_mismatched_images() {
        let empty = depth(&[]);
        assert_eq!(bound_violations(&empty, &empty, 1.0), Some(0));
        let (a, b) = (depth(&["aa"]), depth(&["a", "a"]));
        assert_eq!(bound_violations(&a, &b, 1.0), None);
        let short = DepthImage {
            depth: vec![0.5],
            ..a.clone()
        };
        assert_eq!(bound_violations(&a, &short, 1.0), None);
    }

    #[test]
    fn compare_counts_bound_violations_at_the_run_tolerance() {
        // A 1x4 frame whose surface moved 2 pixels: beyond window 1 (p = 0),
        // within window 2 (p = 1).
        let c = [[9, 9, 9, 255]; 4];
        let r = FrameImage {
            colour: c.iter().flatten().copied().collect(),
            depth: depth(&["a..."]),
        };
        let x = FrameImage {
            depth: depth(&["..a."]),
            ..r.clone()
        };
        let strict = Accuracy::compare(&r, &x, 0.0, 300.0).unwrap();
        assert_eq!(strict.bound_violating_pixels, 2);
        assert_eq!(strict.bound_violating_fraction(), 0.5);
        assert_eq!(
            Accuracy::compare(&r, &x, 1.0, 300.0)
                .unwrap()
                .bound_violating_pixels,
            0
        );
        let mut pooled = strict;
        pooled.add(&strict);
        assert_eq!((pooled.pixels, pooled.bound_violating_pixels), (8, 4));
    }

    #[test]
    fn scaled_depth_match_counts_only_moves_beyond_the_bound() {
        // A 3x3 wall at depth 0.5 (reversed-Z: distance near / 0.5), and the
        // same wall moved back along the view ray by a relative `m`.
        let wall = depth(&["aaa"; 3]);
        let moved = |m: f32| DepthImage {
            depth: vec![0.5 / (1.0 + m); 9],
            ..wall.clone()
        };
        // 1 px at 300 pixels per radian allows 1/300 = 0.33% in depth.
        let (p, ppr) = (1.0, 300.0);
        assert!((scaled_relative_depth(p, ppr) - (1e-3 + 1.0 / 300.0)).abs() < 1e-7);
        // 0.2%: beyond the fixed 0.1% match, within the bound.
        let within = moved(2e-3);
        assert_eq!(bound_violations(&wall, &within, p), Some(9));
        assert_eq!(bound_exceedances(&wall, &within, p, ppr), Some(0));
        // 1%: beyond both.
        let beyond = moved(1e-2);
        assert_eq!(bound_exceedances(&wall, &beyond, p, ppr), Some(9));
        // A bigger tolerance or a coarser screen allows more.
        assert_eq!(bound_exceedances(&wall, &beyond, 4.0, ppr), Some(0));
        assert_eq!(bound_exceedances(&wall, &beyond, p, 60.0), Some(0));
        // Degenerate ratios fall back to the fixed match.
        for ppr in [0.0, -1.0, f64::NAN] {
            assert_eq!(scaled_relative_depth(p, ppr), BOUND_RELATIVE_DEPTH);
        }
        // Background still matches only background; vanished geometry
        // counts whatever the scale.
        assert_eq!(
            bound_exceedances(&wall, &depth(&["..."; 3]), p, 1.0),
            Some(9)
        );
        // compare() fills both and exceedances never exceed violations.
        let c = vec![9u8; 36];
        let frame = |d: DepthImage| FrameImage {
            colour: c.clone(),
            depth: d,
        };
        let acc = Accuracy::compare(&frame(wall.clone()), &frame(within), p, ppr).unwrap();
        assert_eq!(
            (acc.bound_violating_pixels, acc.bound_exceeding_pixels),
            (9, 0)
        );
        let acc = Accuracy::compare(&frame(wall), &frame(beyond), p, ppr).unwrap();
        assert_eq!(
            (acc.bound_violating_pixels, acc.bound_exceeding_pixels),
            (9, 9)
        );
        assert_eq!(acc.bound_exceeding_fraction(), 1.0);
    }
}
