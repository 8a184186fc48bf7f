//! The window's side of the event loop: winit's callbacks turned into
//! input (keys held, actions, clicks, mouse look, scroll, the search
//! prompt's text) that the frame loop applies once per frame, and the
//! window created on the first pump.

use std::collections::HashSet;
use std::sync::Arc;
use std::time::{Duration, Instant};

use winit::application::ApplicationHandler;
use winit::dpi::PhysicalSize;
use winit::error::OsError;
use winit::event::{ElementState, KeyEvent, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::ActiveEventLoop;
use winit::keyboard::{KeyCode, PhysicalKey};
use winit::window::{Window, WindowId};

use crate::controls::{self, Action, Does, Movement};

/// A left press and release within this many pixels of travel is a click
/// (select), more is a drag (look).
const CLICK_SLOP_PX: f64 = 4.0;
/// A second click this soon and this close to the first is a double click.
const DOUBLE_CLICK: Duration = Duration::from_millis(400);
const DOUBLE_CLICK_PX: f64 = 6.0;
/// The search prompt takes at most this many characters.
const PROMPT_CHARS: usize = 200;

/// Input for the frame loop to apply, in the order it came.
#[derive(Clone, Debug, PartialEq)]
pub(super) enum Input {
    Act(Action),
    /// Restore saved view N (1-based).
    RestoreView(usize),
    /// Enter in the search prompt, with its text.
    Find(String),
    /// A left click at window pixel (x, y), from the top-left.
    Click {
        x: f64,
        y: f64,
        double: bool,
    },
    /// `X` with the cursor at this window pixel (`None`: outside the
    /// window, so the window's centre).
    SectionPlane {
        at: Option<(f64, f64)>,
    },
    /// Shift+wheel: move the active section plane this many notches
    /// along its normal.
    MoveSection(f64),
}

/// The left button held: how far the cursor moved since it went down.
#[derive(Clone, Copy, Debug)]
pub(super) struct Press {
    pub(super) travel: f64,
}

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
    /// The left button, while held.
    pub(super) press: Option<Press>,
    /// The last click, for double clicks.
    pub(super) last_click: Option<(Instant, (f64, f64))>,
    /// The search prompt's text while it is open (`/`).
    pub(super) prompt: Option<String>,
    pub(super) inputs: Vec<Input>,
    pub(super) scroll: f64,
    /// Shift is held (Shift+wheel moves a section plane).
    pub(super) shift: bool,
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
                self.shift = false;
                self.drag = None;
                self.press = None;
            }
            WindowEvent::KeyboardInput { event, .. } => {
                let PhysicalKey::Code(code) = event.physical_key else {
                    return;
                };
                if self.prompt.is_some() {
                    self.prompt_key(code, &event);
                    return;
                }
                let pressed = event.state == ElementState::Pressed && !event.repeat;
                match controls::lookup(code) {
                    Some(Does::Move(m)) => {
                        if event.state == ElementState::Pressed {
                            self.held.insert(*m);
                        } else {
                            self.held.remove(m);
                        }
                    }
                    Some(Does::Act(Action::SectionPlane)) if pressed => {
                        self.inputs.push(Input::SectionPlane { at: self.cursor })
                    }
                    Some(Does::Act(Action::Search)) if pressed => {
                        // Typing must not fly: keys held now are let go.
                        self.held.clear();
                        self.prompt = Some(String::new());
                    }
                    Some(Does::Act(a)) if pressed => self.inputs.push(Input::Act(*a)),
                    Some(Does::RestoreView) if pressed => {
                        if let Some(n) = controls::view_number(code) {
                            self.inputs.push(Input::RestoreView(n));
                        }
                    }
                    _ => {}
                }
            }
            WindowEvent::MouseInput { state, button, .. } => {
                let held = self.drag.unwrap_or(0);
                self.drag = match state {
                    ElementState::Pressed => Some(held + 1),
                    ElementState::Released => held.checked_sub(1).filter(|&n| n > 0),
                };
                if button == MouseButton::Left {
                    match state {
                        ElementState::Pressed => self.press = Some(Press { travel: 0.0 }),
                        ElementState::Released => {
                            let press = self.press.take();
                            if let (Some(p), Some(at)) = (press, self.cursor) {
                                if p.travel <= CLICK_SLOP_PX {
                                    self.click(at);
                                }
                            }
                        }
                    }
                }
            }
            WindowEvent::CursorMoved { position, .. } => {
                let p = (position.x, position.y);
                if let Some(c) = self.cursor {
                    if self.drag.is_some() {
                        self.look.0 += p.0 - c.0;
                        self.look.1 += p.1 - c.1;
                    }
                    if let Some(press) = &mut self.press {
                        press.travel += (p.0 - c.0).hypot(p.1 - c.1);
                    }
                }
                self.cursor = Some(p);
            }
            WindowEvent::CursorLeft { .. } => self.cursor = None,
            WindowEvent::ModifiersChanged(m) => self.shift = m.state().shift_key(),
            WindowEvent::MouseWheel { delta, .. } => {
                let notches = match delta {
                    MouseScrollDelta::LineDelta(_, y) => y as f64,
                    // Touchpads: ~50 pixels a notch, as browsers count.
                    MouseScrollDelta::PixelDelta(p) => p.y / 50.0,
                };
                if self.shift {
                    self.inputs.push(Input::MoveSection(notches));
                } else {
                    self.scroll += notches;
                }
            }
            _ => {}
        }
    }
}

impl App {
    /// A key while the search prompt is open: Enter searches, Esc
    /// cancels, Backspace deletes, F1 and F12 (help, screenshot) work as
    /// ever, anything else types its text.
    fn prompt_key(&mut self, code: KeyCode, event: &KeyEvent) {
        if event.state != ElementState::Pressed {
            // A movement key let go while typing stays let go.
            if let Some(Does::Move(m)) = controls::lookup(code) {
                self.held.remove(m);
            }
            return;
        }
        let Some(text) = &mut self.prompt else {
            return;
        };
        match code {
            KeyCode::Escape => self.prompt = None,
            KeyCode::Enter | KeyCode::NumpadEnter => {
                let text = std::mem::take(text);
                self.prompt = None;
                self.inputs.push(Input::Find(text));
            }
            KeyCode::Backspace => {
                text.pop();
            }
            // Keys that type nothing and do not move still work: help
            // and a screenshot of the prompt.
            _ if matches!(
                controls::lookup(code),
                Some(Does::Act(Action::ToggleHelp | Action::Screenshot))
            ) && event
                .text
                .as_ref()
                .is_none_or(|t| t.chars().all(char::is_control)) =>
            {
                if let Some(Does::Act(a)) = controls::lookup(code) {
                    if !event.repeat {
                        self.inputs.push(Input::Act(*a));
                    }
                }
            }
            _ => {
                if let Some(typed) = &event.text {
                    for c in typed.chars().filter(|c| !c.is_control()) {
                        if text.chars().count() < PROMPT_CHARS {
                            text.push(c);
                        }
                    }
                }
            }
        }
    }

    /// A left click at `at`: a double click when it follows the last one
    /// closely in time and place.
    fn click(&mut self, at: (f64, f64)) {
        let now = Instant::now();
        let double = self.last_click.is_some_and(|(t, p)| {
            now.duration_since(t) <= DOUBLE_CLICK
                && (at.0 - p.0).hypot(at.1 - p.1) <= DOUBLE_CLICK_PX
        });
        // A third click starts a new pair rather than framing again.
        self.last_click = (!double).then_some((now, at));
        self.inputs.push(Input::Click {
            x: at.0,
            y: at.1,
            double,
        });
    }
}
