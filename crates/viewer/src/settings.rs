//! The viewer's toggles (occlusion, HLOD, pixel error, async rendering,
//! wireframe, the look, x-ray, boxes, freeze, HUD, help), and which of them need the
//! pipeline restarted: the runtime fixes its options per run.

pub use gigawalk_cull::PIXEL_ERROR_STEPS;
use gigawalk_cull::{step_pixel_error, TraversalOptions};
use gigawalk_gpu::{Antialias, Look};
use gigawalk_runtime::CullMethod;

#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    pub occlusion: bool,
    /// Which occlusion culler (C cycles them).
    pub culler: CullMethod,
    pub hlod: bool,
    pub pixel_error: f64,
    /// RVG draws the newest culled set without waiting for the camera's own
    /// (the runtime's `async_rvg`).
    pub async_rvg: bool,
    pub wireframe: bool,
    /// What the shown image adds: edges (E), ambient occlusion (F2),
    /// anti-aliasing (F3), the sky.
    pub look: Look,
    /// Hidden objects, and those an isolation leaves out, drawn as faint
    /// ghosts for context (F4).
    pub xray: bool,
    pub boxes: bool,
    /// Freeze culling: RVG keeps drawing the frozen view's visible set.
    pub frozen: bool,
    pub hud: bool,
    pub help: bool,
    /// Hold a frame rate (K toggles): the pixel error is chosen each frame
    /// (from `pixel_error` up to 16 px) to hold `target_fps`.
    pub target: bool,
    pub target_fps: f64,
}

impl Default for Settings {
    fn default() -> Self {
        let t = TraversalOptions::default();
        Settings {
            occlusion: t.occlusion,
            culler: CullMethod::default(),
            hlod: t.hlod,
            pixel_error: t.pixel_error,
            async_rvg: false,
            wireframe: false,
            look: Look::PLAIN,
            xray: false,
            boxes: false,
            frozen: false,
            hud: true,
            help: false,
            target: false,
            target_fps: 30.0,
        }
    }
}

impl Settings {
    /// The traversal of the toggles: HLOD off is full detail
    /// (`TraversalOptions::mode`), whatever the pixel error.
    pub fn traversal(&self) -> TraversalOptions {
        TraversalOptions::mode(self.occlusion, self.hlod, self.pixel_error)
    }

    /// The next pixel-error step up (`up`) or down from the current value.
    pub fn step_pixel_error(&mut self, up: bool) {
        self.pixel_error = step_pixel_error(self.pixel_error, up);
    }

    /// Anti-aliasing on (FXAA) or off.
    pub fn toggle_aa(&mut self) {
        self.look.aa = match self.look.aa {
            Antialias::Off => Antialias::Fxaa,
            Antialias::Fxaa => Antialias::Off,
        };
    }

    /// Whether going from `self` to `next` needs a new pipeline run.
    pub fn needs_restart(&self, next: &Settings) -> bool {
        self.traversal() != next.traversal()
            || self.async_rvg != next.async_rvg
            || self.culler != next.culler
    }

    /// The next culler of [`CullMethod::ALL`], wrapping around.
    pub fn cycle_culler(&mut self) {
        let all = CullMethod::ALL;
        let i = all.iter().position(|&c| c == self.culler).unwrap_or(0);
        self.culler = all[(i + 1) % all.len()];
    }

    /// The mode as the HUD names it (Table 2's modes).
    pub fn mode(&self) -> String {
        let detail = if self.traversal().pixel_error == 0.0 {
            "full detail".to_string()
        } else {
            format!("{} px", self.pixel_error)
        };
        format!(
            "{}{}, {}",
            if self.occlusion {
                format!("occlusion ({})", self.culler)
            } else {
                "frustum only".to_string()
            },
            if self.hlod { " + HLOD" } else { "" },
            detail
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pixel_error_steps_clamp_at_both_ends() {
        let mut s = Settings {
            pixel_error: 0.0,
            ..Default::default()
        };
        s.step_pixel_error(false);
        assert_eq!(s.pixel_error, 0.0);
        s.step_pixel_error(true);
        assert_eq!(s.pixel_error, 0.5);
        s.pixel_error = 64.0;
        s.step_pixel_error(true);
        assert_eq!(s.pixel_error, 64.0);
    }

    #[test]
    fn off_step_values_go_to_the_neighbouring_step() {
        let mut s = Settings {
            pixel_error: 3.0,
            ..Default::default()
        };
        s.step_pixel_error(true);
        assert_eq!(s.pixel_error, 4.0);
        s.pixel_error = 3.0;
        s.step_pixel_error(false);
        assert_eq!(s.pixel_error, 2.0);
    }

    #[test]
    fn only_pipeline_options_restart() {
        let a = Settings::default();
        let hud = Settings {
            hud: false,
            help: true,
            ..a.clone()
        };
        assert!(!a.needs_restart(&hud));
        let occ = Settings {
            occlusion: false,
            ..a.clone()
        };
        assert!(a.needs_restart(&occ));
        // Boxes and freezing work on every frame's culled set: no restart.
        let frozen = Settings {
            frozen: true,
            boxes: true,
            ..a.clone()
        };
        assert!(!a.needs_restart(&frozen));
        let asynchronous = Settings {
            async_rvg: true,
            ..a.clone()
        };
        assert!(a.needs_restart(&asynchronous));
    }

    #[test]
    fn c_cycles_every_culler_and_restarts_the_pipeline() {
        let mut s = Settings::default();
        let first = s.clone();
        let mut seen = vec![s.culler];
        for _ in 1..CullMethod::ALL.len() {
            s.cycle_culler();
            assert!(first.needs_restart(&s));
            seen.push(s.culler);
        }
        assert_eq!(seen, CullMethod::ALL.to_vec());
        s.cycle_culler();
        assert_eq!(s, first);
        s.culler = CullMethod::Grid;
        assert_eq!(s.mode(), "occlusion (grid) + HLOD, 1 px");
    }

    #[test]
    fn mode_names_the_table_2_mode() {
        let s = Settings::default();
        assert_eq!(s.mode(), "occlusion (hzb) + HLOD, 1 px");
        let s = Settings {
            occlusion: false,
            hlod: false,
            pixel_error: 0.0,
            ..s
        };
        assert_eq!(s.mode(), "frustum only, full detail");
    }
}
