//! LOD selection by screen-space pixel error (GigaWalk Sections 4.3 and
//! 5.1.2, as in Erikson et al. 2001).

use gigawalk_scene::LodInfo;
use glam::DVec3;

/// Distance from the eye to the nearest point of a camera-relative box
/// (`min`, `max` already have the eye subtracted): 0 when the eye is inside.
pub fn distance_to_rel_box(min: DVec3, max: DVec3) -> f64 {
    min.max(-max).max(DVec3::ZERO).length()
}

/// Screen-space error in pixels of an LOD with object-space `error` seen at
/// `distance`: error x (viewport height / (2 tan(fovy / 2))) / distance.
/// Traversal passes [`crate::CullView::lod_distance`], which makes this a
/// bound off the view axis too.
/// Infinite when the eye touches the box (distance 0) and the error is not 0.
pub fn pixel_error(error: f32, distance: f64, pixels_per_radian: f64) -> f64 {
    let e = error as f64 * pixels_per_radian;
    if e == 0.0 {
        0.0
    } else {
        e / distance
    }
}

/// The coarsest of `lods` (finest first) whose pixel error at `distance` is
/// at most `pixel_error` pixels; `None` when none is, or when the eye touches
/// the box (distance 0: always refine), or when `lods` is empty.
pub fn select_lod(
    lods: &[LodInfo],
    distance: f64,
    pixels_per_radian: f64,
    pixel_error: f64,
) -> Option<usize> {
    if distance.is_nan() || distance <= 0.0 {
        return None;
    }
    // error x ppr <= tolerance x distance, written without a division so an
    // infinite distance (or error) cannot make NaN.
    lods.iter()
        .rposition(|l| l.error as f64 * pixels_per_radian <= pixel_error * distance)
}

#[cfg(test)]
mod tests {

    use super::*;

    fn lods(errors: &[f32]) -> Vec<LodInfo> {
        errors
            .iter()
            .map(|&error| crate::test_rng::lod(error, 1))
            .collect()
    }

    #[test]
    fn distance_to_box() {
        let d = distance_to_rel_box(DVec3::new(3.0, -1.0, -1.0), DVec3::new(4.0, 1.0, 1.0));
        assert_eq!(d, 3.0);
        assert_eq!(
            distance_to_rel_box(DVec3::splat(-1.0), DVec3::splat(1.0)),
            0.0
        );
        let d = distance_to_rel_box(DVec3::new(-4.0, -5.0, 1.0), DVec3::new(-3.0, -4.0, 2.0));
        assert!((d - (9.0f64 + 16.0 + 1.0).sqrt()).abs() < 1e-12);
    }

    #[test]
    fn coarsest_acceptable_is_chosen() {
        // Binary fractions, so the boundary cases are exact.
        let l = lods(&[0.0, 0.0625, 0.125, 1.0]);
        // ppr 800, distance 100: pixel errors 0, 0.5, 1, 8.
        assert_eq!(select_lod(&l, 100.0, 800.0, 1.0), Some(2));
        assert_eq!(select_lod(&l, 100.0, 800.0, 0.5), Some(1));
        assert_eq!(select_lod(&l, 100.0, 800.0, 0.0), Some(0));
        assert_eq!(select_lod(&l, 100.0, 800.0, 100.0), Some(3));
    }

    #[test]
    fn eye_inside_refines() {
        let l = lods(&[0.0, 1.0]);
        assert_eq!(select_lod(&l, 0.0, 1000.0, 1.0), None);
        assert_eq!(pixel_error(1.0, 0.0, 1000.0), f64::INFINITY);
        assert_eq!(pixel_error(0.0, 0.0, 1000.0), 0.0);
    }

    #[test]
    fn nothing_acceptable_or_empty_is_none() {
        assert_eq!(select_lod(&lods(&[0.5, 1.0]), 1.0, 1000.0, 1.0), None);
        assert_eq!(select_lod(&[], 1.0, 1000.0, 1.0), None);
    }

    #[test]
    fn infinitely_far_takes_coarsest() {
        assert_eq!(
            select_lod(&lods(&[0.0, 1.0]), f64::INFINITY, 1000.0, 1.0),
            Some(1)
        );
    }
}
