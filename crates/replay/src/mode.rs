//! The rendering modes a replay compares: the paper's Table 2 rows.

pub use gigawalk_cull::Mode;
use gigawalk_runtime::CullMethod;

/// One run of a replay: a mode, its pixel error, and the occlusion
/// culler (`None` for the modes without occlusion).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Run {
    pub mode: Mode,
    pub pixel_error: f64,
    pub culler: Option<CullMethod>,
    /// Held to a target frame rate (the pixel error is where it starts).
    pub target: bool,
}

/// The runs of a replay: every requested mode, the pixel-error modes once
/// per pixel error, the full-detail modes once at 0, the occlusion modes
/// once per culler. In the order given, duplicates removed. With a
/// `target` frame rate, each pixel-error mode also runs once held to it,
/// starting from the first pixel error.
pub fn runs(
    modes: &[Mode],
    pixel_errors: &[f64],
    cullers: &[CullMethod],
    target: bool,
) -> Vec<Run> {
    let mut out: Vec<Run> = Vec::new();
    for &mode in modes {
        let errs: Vec<f64> = if mode.uses_pixel_error() {
            pixel_errors.to_vec()
        } else {
            vec![0.0]
        };
        let cs: Vec<Option<CullMethod>> = if mode.traversal(0.0).occlusion {
            cullers.iter().copied().map(Some).collect()
        } else {
            vec![None]
        };
        let held = (target && mode.uses_pixel_error())
            .then(|| (pixel_errors.first().copied().unwrap_or(1.0), true));
        let variants = errs.into_iter().map(|e| (e, false)).chain(held);
        for (pixel_error, target) in variants {
            for &culler in &cs {
                let r = Run {
                    mode,
                    pixel_error,
                    culler,
                    target,
                };
                if !out.contains(&r) {
                    out.push(r);
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn full_detail_modes_run_once_in_a_sweep() {
        let r: Vec<(Mode, f64)> = runs(&Mode::ALL, &[0.0, 1.0, 4.0], &[CullMethod::Hzb], false)
            .into_iter()
            .map(|r| (r.mode, r.pixel_error))
            .collect();
        assert_eq!(
            r,
            vec![
                (Mode::Vfc, 0.0),
                (Mode::Hlod, 0.0),
                (Mode::Hlod, 1.0),
                (Mode::Hlod, 4.0),
                (Mode::Occ, 0.0),
                (Mode::Och, 0.0),
                (Mode::Och, 1.0),
                (Mode::Och, 4.0),
            ]
        );
    }

    #[test]
    fn occlusion_modes_run_once_per_culler() {
        let (h, g) = (Some(CullMethod::Hzb), Some(CullMethod::Grid));
        let r: Vec<(Mode, Option<CullMethod>)> = runs(
            &Mode::ALL,
            &[1.0],
            &[CullMethod::Hzb, CullMethod::Grid, CullMethod::Hzb],
            false,
        )
        .into_iter()
        .map(|r| (r.mode, r.culler))
        .collect();
        assert_eq!(
            r,
            vec![
                (Mode::Vfc, None),
                (Mode::Hlod, None),
                (Mode::Occ, h),
                (Mode::Occ, g),
                (Mode::Och, h),
                (Mode::Och, g),
            ]
        );
    }

    #[test]
    fn mode_traversals() {
        let v = Mode::Vfc.traversal(2.0);
        assert!(!v.occlusion && !v.hlod && v.pixel_error == 0.0);
        let o = Mode::Occ.traversal(2.0);
        assert!(o.occlusion && !o.hlod && o.pixel_error == 0.0);
        let h = Mode::Och.traversal(2.0);
        assert!(h.occlusion && h.hlod && h.pixel_error == 2.0);
        assert_eq!("och".parse::<Mode>(), Ok(Mode::Och));
        assert!("fast".parse::<Mode>().is_err());
    }

    #[test]
    fn a_target_adds_one_held_run_per_pixel_error_mode() {
        let r = runs(&Mode::ALL, &[2.0, 4.0], &[CullMethod::Hzb], true);
        let held: Vec<(Mode, f64)> = r
            .iter()
            .filter(|r| r.target)
            .map(|r| (r.mode, r.pixel_error))
            .collect();
        assert_eq!(held, vec![(Mode::Hlod, 2.0), (Mode::Och, 2.0)]);
        assert_eq!(r.len(), 1 + 3 + 1 + 3);
    }
}
