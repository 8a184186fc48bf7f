//! The window's side of the event loop: winit's callbacks turned into
//! input (keys held, actions, mouse look, scroll) that the frame loop
//! applies once per frame, and the window created on the first pump.

use std::collections::HashSet;
use std::sync::Arc;
use std::time::Instant;

use winit::application::ApplicationHandler;
use winit::dpi::PhysicalSize;
use winit::error::OsError;
use winit::event::{ElementState, MouseScrollDelta, WindowEvent};
use winit::event_loop::ActiveEventLoop;
use winit::keyboard::PhysicalKey;
use winit::window::{Window, WindowId};

use crate::controls::{self, Action, Does, Movement};

/// The window's side of the event loop: collects input for the frame loop.
pub(super) struct App {
    pub(super) title: String,
    pub(super) size: PhysicalSize<u32>,
    pub(super) window: Option<Arc<Window>>,
    /// Why the window could not be created.
    pub(super) error: Option<OsError>,
    pub(super) held: HashSet<Movement>,
    /// Drag-to-look is on while any mouse button is held.
    pub(super) drag: Option<u32>,
    pub(super) cursor: Option<(f64, f64)>,
    pub(super) actions: Vec<Action>,
    pub(super) scroll: f64,
    pub(super) look: (f64, f64),
    /// When the window last changed size.
    pub(super) resized: Option<Instant>,
    pub(super) close: bool,
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.window.is_some() {
            return;
        }
        let attrs = Window::default_attributes()
            .with_title(self.title.clone())
            .with_inner_size(self.size);
        match event_loop.create_window(attrs) {
            Ok(w) => {
                let s = w.inner_size();
                if s.width > 0 && s.height > 0 {
                    self.size = s;
                }
                self.window = Some(Arc::new(w));
            }
            Err(e) => self.error = Some(e),
        }
    }

    fn window_event(&mut self, _: &ActiveEventLoop, _: WindowId, event: WindowEvent) {
        match event {
            WindowEvent::CloseRequested | WindowEvent::Destroyed => self.close = true,
            WindowEvent::Resized(s) if s != self.size => {
                self.size = s;
                self.resized = Some(Instant::now());
            }
            WindowEvent::Focused(false) => {
                self.held.clear();
                self.drag = None;
            }
            WindowEvent::KeyboardInput { event, .. } => {
                let PhysicalKey::Code(code) = event.physical_key else {
                    return;
                };
                match controls::lookup(code) {
                    Some(Does::Move(m)) => {
                        if event.state == ElementState::Pressed {
                            self.held.insert(*m);
                        } else {
                            self.held.remove(m);
                        }
                    }
                    Some(Does::Act(a)) if event.state == ElementState::Pressed && !event.repeat => {
                        self.actions.push(*a)
                    }
                    _ => {}
                }
            }
            WindowEvent::MouseInput { state, .. } => {
                let held = self.drag.unwrap_or(0);
                self.drag = match state {
                    ElementState::Pressed => Some(held + 1),
                    ElementState::Released => held.checked_sub(1).filter(|&n| n > 0),
                };
            }
            WindowEvent::CursorMoved { position, .. } => {
                let p = (position.x, position.y);
                if let (Some(_), Some(c)) = (self.drag, self.cursor) {
                    self.look.0 += p.0 - c.0;
                    self.look.1 += p.1 - c.1;
                }
                self.cursor = Some(p);
            }
            WindowEvent::CursorLeft { .. } => self.cursor = None,
            WindowEvent::MouseWheel { delta, .. } => {
                self.scroll += match delta {
                    MouseScrollDelta::LineDelta(_, y) => y as f64,
                    // Touchpads: ~50 pixels a notch, as browsers count.
                    MouseScrollDelta::PixelDelta(p) => p.y / 50.0,
                };
            }
            _ => {}
        }
    }
}
