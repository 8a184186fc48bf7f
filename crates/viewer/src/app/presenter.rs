//! The runtime's presenter (RVG thread): shows each finished frame in the
//! window with the HUD, the help text, node boxes and the measurement
//! drawn on top, and
//! writes the screenshots asked for.

use std::sync::{Arc, Mutex};

use gigawalk_gpu::{GpuContext, GpuError, OverlayFrame, OverlayText, VisiblePass, WindowSurface};
use gigawalk_runtime::{CullReason, FrameReport, Presenter};
use gigawalk_scene::Skeleton;

use super::{Script, Shared};
use crate::boxes::{overlay_boxes, CullSets};
use crate::controls;
use crate::hud::{hud_lines, FrameClock, FrameNumbers};
use crate::image::write_png;
use crate::objects::hud_text;

/// How many times its 8-pixel glyphs the HUD text is drawn on a window
/// `height` pixels tall: 1x below 600, 2x to 1440 (1080p: 16-pixel
/// text), 3x to 2000 and 4x from there (4K: 32-pixel text), so it reads
/// at about the same size on any screen.
fn hud_scale(height: u32) -> u32 {
    match height {
        0..600 => 1,
        600..1440 => 2,
        1440..2000 => 3,
        _ => 4,
    }
}

/// Shows frames in the window (RVG thread).
pub(super) struct ViewerPresenter<'s> {
    pub(super) surface: WindowSurface,
    pub(super) shared: Arc<Mutex<Shared>>,
    pub(super) skeleton: &'s Skeleton,
    /// The last culled frame's sets, shown while culling is frozen.
    pub(super) culled_sets: CullSets,
    pub(super) script: Option<Script>,
    pub(super) clock: FrameClock,
}

impl Presenter for ViewerPresenter<'_> {
    fn present(
        &mut self,
        ctx: &GpuContext,
        pass: &VisiblePass,
        report: &FrameReport,
    ) -> Result<(), GpuError> {
        let (settings, viewer, size, mut capture) = {
            let mut s = self.shared.lock().expect("viewer state");
            (
                s.settings.clone(),
                s.viewer.clone(),
                s.window_size,
                s.capture.take(),
            )
        };
        // The HUD shows this frame's own numbers (the frame loop only
        // hears of it after it is presented).
        self.clock.tick(report.finished_at);
        let numbers = FrameNumbers {
            frame: report.frame,
            or_ms: report.or_ms,
            hzb_ms: report.hzb_ms,
            stc_ms: report.stc_ms,
            rvg_ms: report.rvg_ms,
            latency_ms: report.latency_ms(),
            occlusion_used: report.occlusion_used,
            occluder_triangles: report.occluder_triangles,
            stats: report.stats,
            streaming: report.streaming,
            tiles: report.tiles.as_ref().map(|t| {
                (
                    t.grid.to_string(),
                    t.max_triangles,
                    t.ms_adaptive,
                    t.ms_naive,
                )
            }),
            pixel_error: report.pixel_error,
            culler_work: report.culler_work,
        };
        let hud = hud_lines(self.clock.fps(), &numbers, &settings, &viewer);
        if let Some(script) = &self.script {
            if report.frame + 1 >= script.frames {
                capture = script.screenshot.clone();
            }
        }
        // A frame that reused an older visible set (frozen, or async RVG
        // ahead of STC) keeps the boxes of the frame that culled it.
        if !report.reused_visible_set || self.culled_sets.drawn.is_empty() {
            self.culled_sets = cull_sets(report);
        }
        let mut overlay = OverlayFrame {
            view_proj: report.camera.view_projection_rel(),
            ..Default::default()
        };
        if settings.boxes || settings.frozen {
            overlay.boxes = overlay_boxes(self.skeleton, &self.culled_sets, report.camera.position);
        }
        let (w, h) = pass.size();
        let scale = hud_scale(h);
        let glyph = (8 * scale) as f32;
        // The measurement, projected with the frame's own camera (the
        // line stays on the points while the camera moves).
        let marks = viewer.measure.on_screen(&report.camera, (w, h));
        let label = viewer.measure.label(&viewer.units).map(|l| hud_text(&l));
        overlay.push_measurement(&marks.markers, marks.segment, label, (w, h), scale);
        if settings.hud && !hud.is_empty() {
            overlay.text.push(OverlayText {
                x: glyph,
                y: glyph,
                scale,
                lines: hud,
                colour: [1.0, 1.0, 0.85, 1.0],
                background: [0.0, 0.0, 0.0, 0.55],
            });
        }
        if let Some(text) = &viewer.prompt {
            // The prompt shows with the HUD off too: it is what you type.
            overlay.text.push(OverlayText {
                x: glyph,
                y: (h as f32 - 3.0 * glyph).max(glyph),
                scale,
                lines: vec![hud_text(&format!(
                    "find: {text}_   (Enter: fly to a match, Esc: cancel)"
                ))],
                colour: [1.0, 0.9, 0.6, 1.0],
                background: [0.0, 0.0, 0.0, 0.75],
            });
        }
        if settings.help {
            let lines: Vec<String> = std::iter::once("gigawalk view: controls".to_string())
                .chain(std::iter::once(String::new()))
                .chain(controls::help_lines())
                .chain(std::iter::once(String::new()))
                .chain(saved_view_lines(&viewer.views))
                .collect();
            // The help is long: the largest scale up to the HUD's at
            // which it fits the window's height.
            let scale = (1..=scale)
                .rev()
                .find(|s| (lines.len() as u32 + 2) * 8 * s <= h)
                .unwrap_or(1);
            let glyph = (8 * scale) as f32;
            let cols = lines.iter().map(|l| l.len()).max().unwrap_or(0) as f32;
            overlay.text.push(OverlayText {
                x: (w as f32 - cols * glyph - glyph).max(glyph),
                y: glyph,
                scale,
                lines,
                colour: [0.85, 0.95, 1.0, 1.0],
                background: [0.0, 0.02, 0.08, 0.75],
            });
        }
        let shown = self
            .surface
            .present(ctx, pass, &overlay, size, capture.is_some())?;
        if let (Some(file), Some((w, h, rgba))) = (capture, shown.capture) {
            let mut s = self.shared.lock().expect("viewer state");
            match write_png(&file, w, h, &rgba) {
                Ok(()) => {
                    eprintln!("screenshot: {}", file.display());
                    s.message = Some(format!("screenshot: {}", file.display()));
                }
                Err(e) if self.script.is_some() => s.error = Some(e.into()),
                Err(e) => s.message = Some(format!("screenshot failed: {e}")),
            }
        }
        Ok(())
    }
}

/// The help's list of saved views: the keys that restore them.
fn saved_view_lines(names: &[String]) -> Vec<String> {
    if names.is_empty() {
        return vec!["saved views: none yet (V saves one)".into()];
    }
    std::iter::once("saved views (1 - 9 restore, N cycles):".to_string())
        .chain(names.iter().enumerate().map(|(i, n)| {
            let key = if i < 9 {
                (i + 1).to_string()
            } else {
                "N".into()
            };
            hud_text(&format!("  {key:>2}  {n}"))
        }))
        .collect()
}

fn cull_sets(report: &FrameReport) -> CullSets {
    let mut sets = CullSets {
        drawn: report.visible.iter().map(|d| d.node).collect(),
        ..Default::default()
    };
    for &(node, why) in report.culled.iter() {
        match why {
            CullReason::Frustum => sets.frustum_culled.push(node),
            CullReason::Occlusion => sets.occlusion_culled.push(node),
        }
    }
    sets
}

#[cfg(test)]
mod tests {
    use super::hud_scale;

    #[test]
    fn hud_text_grows_with_the_window() {
        assert_eq!(hud_scale(360), 1);
        assert_eq!(hud_scale(720), 2);
        assert_eq!(hud_scale(1080), 2);
        assert_eq!(hud_scale(1440), 3);
        assert_eq!(hud_scale(2160), 4);
        assert_eq!(hud_scale(u32::MAX), 4);
    }
}
