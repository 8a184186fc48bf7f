//! The runtime's camera source (OR thread): each frame's camera request,
//! from the live controller's camera the frame loop published, or from the
//! script's path.

use std::sync::{Arc, Mutex};
use std::time::Duration;

use gigawalk_cull::Camera;
use gigawalk_runtime::{CameraError, CameraRequest, CameraSource, DrawStyle};

use super::{Script, Shared};

/// While minimised, the camera source waits this long per frame so a
/// hidden window does not spin the pipeline at full speed.
const MINIMISED_WAIT: Duration = Duration::from_millis(50);

/// Cameras for the runtime (OR thread): the live controller's, or the
/// script's.
pub(super) struct LiveSource {
    pub(super) shared: Arc<Mutex<Shared>>,
    pub(super) script: Option<Script>,
    pub(super) sent: u64,
    pub(super) near: f64,
}

impl CameraSource for LiveSource {
    fn next_camera(&mut self, frame: u64) -> Result<Option<CameraRequest>, CameraError> {
        let (
            camera,
            frozen,
            style,
            look,
            quit,
            minimised,
            pixel_error,
            visibility,
            ghosts,
            section,
        ) = {
            let s = self.shared.lock().map_err(|_| CameraError::Source {
                frame,
                source: "the window's state is poisoned: its thread panicked".into(),
            })?;
            (
                s.camera,
                s.frozen,
                if s.settings.wireframe {
                    DrawStyle::Wireframe
                } else {
                    DrawStyle::Shaded
                },
                s.settings.look,
                s.quit,
                s.window_size.0 == 0 || s.window_size.1 == 0,
                s.target_pixel_error.filter(|_| s.settings.target),
                s.visibility.clone(),
                s.ghosts.clone(),
                s.section.clone(),
            )
        };
        if quit {
            return Ok(None);
        }
        if let Some(script) = &self.script {
            if self.sent >= script.frames {
                return Ok(None);
            }
            let i = self.sent as usize;
            self.sent += 1;
            let camera = match script.poses.get(i).or(script.poses.last()) {
                Some(p) => Camera {
                    position: p.position,
                    orientation: p.orientation,
                    fovy: p.fovy,
                    near: self.near,
                    ..camera
                },
                None => camera,
            };
            return Ok(Some(CameraRequest {
                camera,
                read_back: false,
                hold_culling: false,
                style,
                look,
                pixel_error,
                visibility,
                ghosts,
                section,
            }));
        }
        if minimised {
            std::thread::sleep(MINIMISED_WAIT);
        }
        Ok(Some(CameraRequest {
            camera,
            read_back: false,
            hold_culling: frozen,
            style,
            look,
            pixel_error,
            visibility,
            ghosts,
            section,
        }))
    }
}
