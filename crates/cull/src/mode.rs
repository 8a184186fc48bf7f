//! The rendering modes: the paper's Table 2 rows, what replay compares
//! and what the viewer's and the page's O and L keys toggle between.

use crate::TraversalOptions;

/// One row of the paper's Table 2 (Section 6.3.3).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Mode {
    /// View-frustum culling only, every leaf at full detail: the baseline
    /// every speed-up is measured against, and the accuracy reference.
    Vfc,
    /// HLODs selected by pixel error, plus frustum culling.
    Hlod,
    /// HZB occlusion culling plus frustum culling, full detail.
    Occ,
    /// Occlusion culling plus HLODs: GigaWalk.
    Och,
}

impl Mode {
    /// The mode with occlusion culling `occlusion` and HLODs `hlod`.
    pub fn of(occlusion: bool, hlod: bool) -> Mode {
        match (occlusion, hlod) {
            (false, false) => Mode::Vfc,
            (false, true) => Mode::Hlod,
            (true, false) => Mode::Occ,
            (true, true) => Mode::Och,
        }
    }

    pub fn occlusion(self) -> bool {
        matches!(self, Mode::Occ | Mode::Och)
    }

    pub fn hlod(self) -> bool {
        self.uses_pixel_error()
    }

    pub const ALL: [Mode; 4] = [Mode::Vfc, Mode::Hlod, Mode::Occ, Mode::Och];

    pub fn name(self) -> &'static str {
        match self {
            Mode::Vfc => "vfc",
            Mode::Hlod => "hlod",
            Mode::Occ => "occ",
            Mode::Och => "och",
        }
    }

    /// Whether the mode's output depends on the pixel-error tolerance.
    /// `vfc` and `occ` draw every leaf at full detail, so a pixel-error
    /// sweep runs them once, at 0.
    pub fn uses_pixel_error(self) -> bool {
        matches!(self, Mode::Hlod | Mode::Och)
    }

    /// The traversal this mode runs with at `pixel_error`.
    pub fn traversal(self, pixel_error: f64) -> TraversalOptions {
        TraversalOptions::mode(self.occlusion(), self.hlod(), pixel_error)
    }
}

impl std::fmt::Display for Mode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Mode {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.trim() {
            "vfc" => Ok(Mode::Vfc),
            "hlod" => Ok(Mode::Hlod),
            "occ" => Ok(Mode::Occ),
            "och" => Ok(Mode::Och),
            other => Err(format!(
                "unknown mode {other:?} (expected vfc, hlod, occ or och)"
            )),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn modes_are_their_toggles_and_names() {
        for m in Mode::ALL {
            assert_eq!(Mode::of(m.occlusion(), m.hlod()), m);
            assert_eq!(m.name().parse::<Mode>(), Ok(m));
        }
        assert!("nope".parse::<Mode>().is_err());
        assert_eq!(Mode::Occ.traversal(3.0).pixel_error, 0.0);
        assert_eq!(Mode::Och.traversal(3.0).pixel_error, 3.0);
    }
}
