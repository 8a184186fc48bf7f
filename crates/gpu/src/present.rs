//! Showing RVG's frames in a window: devices whose adapter can present to
//! it, the surface's configuration (resized with the window; a minimised,
//! 0x0 window skips presenting instead of erroring), and per frame a copy of
//! the offscreen colour into a composite target, the overlays on top, an
//! optional read-back (screenshots) and a blit to the surface.

use crate::context::{candidates, device_name, open, rank, second_adapter};
use crate::overlay::{OverlayFrame, OverlayRenderer};
use crate::passes::{fullscreen_pipeline, sampled_texture_layout, ReadBack};
use crate::{GpuContext, GpuError, VisiblePass, COLOUR_FORMAT};

pub const BLIT_WGSL: &str = include_str!("../../../shaders/blit.wgsl");

/// Why a window could not get a GPU surface.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum WindowError {
    #[error("cannot create a GPU surface for the window: {0}")]
    Surface(#[source] wgpu::CreateSurfaceError),
    #[error("no GPU adapter can present to the window (adapters: {adapters})")]
    NoPresentableAdapter { adapters: String },
    #[error(transparent)]
    Gpu(#[from] GpuError),
}

/// Opens `count` (1 or 2) devices, all on a qualifying adapter that can
/// present to `window` (the surface and the adapters come from one wgpu
/// instance, as wgpu requires; the instance knows the window's display,
/// which GL needs), and the window's surface. `adapter`: only adapters
/// whose name contains it. Any other count is [`GpuError::DeviceCount`].
pub fn open_devices_for_window<W>(
    count: usize,
    adapter: Option<&str>,
    window: W,
) -> Result<(Vec<GpuContext>, WindowSurface), WindowError>
where
    W: wgpu::wgt::WgpuHasDisplayHandle + Clone + Into<wgpu::SurfaceTarget<'static>>,
{
    device_name(0, count)?;
    let display = window.clone();
    let mut instance_for = |backends| {
        let mut desc = wgpu::InstanceDescriptor::new_with_display_handle(Box::new(display.clone()));
        desc.backends = backends;
        wgpu::Instance::new(desc)
    };
    let c = candidates(adapter, &mut instance_for)?;
    let surface = c
        .instance
        .create_surface(window)
        .map_err(WindowError::Surface)?;
    let Some(best) = c.usable.iter().find(|a| a.is_surface_supported(&surface)) else {
        let names: Vec<String> = c
            .usable
            .iter()
            .map(|a| format!("{} ({:?})", a.get_info().name, a.get_info().backend))
            .collect();
        return Err(WindowError::NoPresentableAdapter {
            adapters: names.join(", "),
        });
    };
    let info = best.get_info();
    tracing::info!(
        "presenting on {} ({:?}, rank {})",
        info.name,
        info.backend,
        rank(info.device_type)
    );
    // The last device (RVG's) presents, so it is the one on the surface's
    // instance; on GL a second device comes from an instance of its own.
    let mut devices = Vec::with_capacity(count);
    for k in 0..count {
        let name = device_name(k, count)?;
        let adapter = if k + 1 == count {
            best.clone()
        } else {
            second_adapter(&c, best, &mut instance_for)
        };
        devices.push(open(&adapter, name)?);
    }
    let caps = surface.get_capabilities(best);
    Ok((
        devices,
        WindowSurface {
            surface,
            caps,
            config: None,
            gpu: None,
        },
    ))
}

/// Opens one device that presents to a browser page's `canvas` (wasm32
/// only): on WebGPU where the browser has it (`webgpu`: whether to try),
/// else on WebGL2. A page has one thread and one device: OR and RVG
/// share it, and the device arrives through the event loop, so this is
/// awaited rather than blocked on. A canvas takes one kind of context
/// for good, so WebGPU is tried before the canvas is touched.
#[cfg(target_arch = "wasm32")]
pub async fn open_device_for_canvas(
    canvas: web_sys::HtmlCanvasElement,
    webgpu: bool,
) -> Result<(GpuContext, WindowSurface), WindowError> {
    let instance = |backends| {
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
        desc.backends = backends;
        wgpu::Instance::new(desc)
    };
    // What was tried, for the error when nothing works.
    let none = |tried: &[String]| WindowError::NoPresentableAdapter {
        adapters: tried.join("; "),
    };
    let mut tried = Vec::new();
    if webgpu {
        let instance = instance(wgpu::Backends::BROWSER_WEBGPU);
        match instance
            .request_adapter(&wgpu::RequestAdapterOptions {
                power_preference: wgpu::PowerPreference::HighPerformance,
                ..Default::default()
            })
            .await
        {
            // The WebGPU adapter must pass what every device's adapter
            // passes (capabilities.rs); else WebGL2 is tried.
            Ok(adapter) => {
                let report = crate::AdapterReport::of(&adapter);
                if report.qualifies() {
                    let surface = instance
                        .create_surface(wgpu::SurfaceTarget::Canvas(canvas))
                        .map_err(WindowError::Surface)?;
                    return canvas_device(adapter, surface).await;
                }
                tried.push(format!("WebGPU's {}", report.line()));
            }
            Err(e) => tried.push(format!("the browser offers no WebGPU adapter ({e})")),
        }
    } else {
        tried.push("the browser has no WebGPU".to_string());
    }
    let instance = instance(wgpu::Backends::GL);
    let surface = match instance.create_surface(wgpu::SurfaceTarget::Canvas(canvas)) {
        Ok(s) => s,
        Err(e) => {
            tried.push(format!("nor WebGL2 ({e})"));
            return Err(none(&tried));
        }
    };
    let adapter = instance
        .request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            compatible_surface: Some(&surface),
            force_fallback_adapter: false,
            ..Default::default()
        })
        .await
        .map_err(|e| {
            tried.push(format!("nor a WebGL2 adapter ({e})"));
            none(&tried)
        })?;
    let report = crate::AdapterReport::of(&adapter);
    if !report.qualifies() {
        tried.push(format!("WebGL2's {}", report.line()));
        return Err(none(&tried));
    }
    canvas_device(adapter, surface).await
}

/// The page's device on `adapter`, presenting to `surface`.
#[cfg(target_arch = "wasm32")]
async fn canvas_device(
    adapter: wgpu::Adapter,
    surface: wgpu::Surface<'static>,
) -> Result<(GpuContext, WindowSurface), WindowError> {
    let ctx = crate::context::open_async(&adapter, "page").await?;
    let caps = surface.get_capabilities(&adapter);
    Ok((
        ctx,
        WindowSurface {
            surface,
            caps,
            config: None,
            gpu: None,
        },
    ))
}

/// A window's surface and what presenting to it needs on the presenting
/// device (created on the first [`WindowSurface::present`]).
pub struct WindowSurface {
    surface: wgpu::Surface<'static>,
    caps: wgpu::SurfaceCapabilities,
    config: Option<wgpu::SurfaceConfiguration>,
    gpu: Option<PresentGpu>,
}

struct PresentGpu {
    overlay: OverlayRenderer,
    blit: wgpu::RenderPipeline,
    blit_format: wgpu::TextureFormat,
    blit_layout: wgpu::BindGroupLayout,
    sampler: wgpu::Sampler,
    /// The frame with overlays, at the render size.
    composite: Option<(wgpu::Texture, wgpu::BindGroup)>,
}

/// What [`WindowSurface::present`] did.
#[derive(Debug, Default, PartialEq)]
pub struct Presented {
    /// False when the window is minimised, occluded or its surface timed out.
    pub shown: bool,
    /// The composited frame (sRGB RGBA8, row 0 at the top) when asked for.
    pub capture: Option<(u32, u32, Vec<u8>)>,
}

impl WindowSurface {
    /// Shows RVG's current frame with `overlay` on top in a window of
    /// `window_size` pixels, after the pass's `finish`. With `capture`, also
    /// reads the composited frame back (even when the window is minimised).
    pub fn present(
        &mut self,
        ctx: &GpuContext,
        pass: &VisiblePass,
        overlay: &OverlayFrame,
        window_size: (u32, u32),
        capture: bool,
    ) -> Result<Presented, GpuError> {
        self.present_texture(ctx, pass.shown_texture(), overlay, window_size, capture)
    }

    /// [`WindowSurface::present`] for any `COLOUR_FORMAT` texture with
    /// `COPY_SRC` usage.
    pub fn present_texture(
        &mut self,
        ctx: &GpuContext,
        colour: &wgpu::Texture,
        overlay: &OverlayFrame,
        window_size: (u32, u32),
        capture: bool,
    ) -> Result<Presented, GpuError> {
        let size = (colour.width(), colour.height());
        let gpu = self.gpu.get_or_insert_with(|| PresentGpu::new(ctx));
        gpu.ensure_composite(ctx, size);
        let composite = &gpu.composite.as_ref().expect("just made").0;
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        let extent = wgpu::Extent3d {
            width: size.0,
            height: size.1,
            depth_or_array_layers: 1,
        };
        enc.copy_texture_to_texture(colour.as_image_copy(), composite.as_image_copy(), extent);
        let composite_view = composite.create_view(&Default::default());
        gpu.overlay
            .draw(ctx, &mut enc, &composite_view, size, overlay);
        ctx.queue.submit([enc.finish()]);
        let capture = if capture {
            Some((size.0, size.1, read_rgba(ctx, composite, size)?))
        } else {
            None
        };
        let shown = self.blit_to_surface(ctx, window_size)?;
        ctx.check()?;
        Ok(Presented { shown, capture })
    }

    /// Configures the surface for `size` if it changed; false for a 0x0
    /// (minimised) window.
    fn configure(&mut self, ctx: &GpuContext, size: (u32, u32)) -> bool {
        if size.0 == 0 || size.1 == 0 {
            return false;
        }
        let max = ctx.device.limits().max_texture_dimension_2d;
        let (w, h) = (size.0.min(max), size.1.min(max));
        if let Some(c) = &self.config {
            if c.width == w && c.height == h {
                return true;
            }
        }
        let format = self
            .caps
            .formats
            .iter()
            .copied()
            .find(|f| f.is_srgb())
            .or_else(|| self.caps.formats.first().copied())
            .unwrap_or(wgpu::TextureFormat::Bgra8UnormSrgb);
        // A surface with no sRGB format (a browser's WebGPU canvas offers
        // only bgra8unorm and rgba8unorm) is drawn through an sRGB view of
        // its texture, so the blit encodes the linear image as the
        // display expects, as on an sRGB surface.
        let view_formats = match format.add_srgb_suffix() {
            f if f != format => vec![f],
            _ => vec![],
        };
        let config = wgpu::SurfaceConfiguration {
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
            format,
            color_space: wgpu::SurfaceColorSpace::Auto,
            width: w,
            height: h,
            // Unthrottled where the platform allows, so the HUD's fps is
            // the pipeline's, not the monitor's; falls back to Fifo.
            present_mode: wgpu::PresentMode::AutoNoVsync,
            desired_maximum_frame_latency: 2,
            alpha_mode: self
                .caps
                .alpha_modes
                .first()
                .copied()
                .unwrap_or(wgpu::CompositeAlphaMode::Auto),
            view_formats,
        };
        self.surface.configure(&ctx.device, &config);
        self.config = Some(config);
        true
    }

    fn blit_to_surface(&mut self, ctx: &GpuContext, size: (u32, u32)) -> Result<bool, GpuError> {
        if !self.configure(ctx, size) {
            return Ok(false);
        }
        let mut texture = None;
        // One retry after reconfiguring an outdated surface (the window
        // changed between our configure and the acquire).
        for _ in 0..2 {
            match self.surface.get_current_texture() {
                wgpu::CurrentSurfaceTexture::Success(t) => {
                    texture = Some((t, false));
                    break;
                }
                wgpu::CurrentSurfaceTexture::Suboptimal(t) => {
                    texture = Some((t, true));
                    break;
                }
                wgpu::CurrentSurfaceTexture::Timeout | wgpu::CurrentSurfaceTexture::Occluded => {
                    return Ok(false)
                }
                wgpu::CurrentSurfaceTexture::Outdated => {
                    self.config = None;
                    if !self.configure(ctx, size) {
                        return Ok(false);
                    }
                }
                wgpu::CurrentSurfaceTexture::Lost => {
                    return Err(GpuError::Device {
                        device: ctx.name().to_string(),
                        message: "the window's surface was lost".into(),
                    })
                }
                wgpu::CurrentSurfaceTexture::Validation => {
                    ctx.check()?;
                    return Err(GpuError::Device {
                        device: ctx.name().to_string(),
                        message: "validation error acquiring the window's surface texture".into(),
                    });
                }
            }
        }
        let Some((frame, suboptimal)) = texture else {
            return Ok(false);
        };
        let format = self
            .config
            .as_ref()
            .map(|c| c.view_formats.first().copied().unwrap_or(c.format))
            .unwrap_or(frame.texture.format());
        let gpu = self.gpu.as_mut().expect("present_texture created it");
        gpu.blit_pipeline(ctx, format);
        let blit = &gpu.blit;
        let (_, bind_group) = gpu.composite.as_ref().expect("composite made this frame");
        let view = frame.texture.create_view(&wgpu::TextureViewDescriptor {
            format: Some(format),
            ..Default::default()
        });
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        {
            let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("blit to window"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                ..Default::default()
            });
            pass.set_pipeline(blit);
            pass.set_bind_group(0, bind_group, &[]);
            pass.draw(0..3, 0..1);
        }
        ctx.queue.submit([enc.finish()]);
        ctx.queue.present(frame);
        if suboptimal {
            self.config = None;
        }
        Ok(true)
    }
}

impl PresentGpu {
    fn new(ctx: &GpuContext) -> PresentGpu {
        let d = &ctx.device;
        let blit_layout = sampled_texture_layout(ctx, "blit", true);
        let sampler = d.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("blit"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        PresentGpu {
            overlay: OverlayRenderer::new(ctx, COLOUR_FORMAT),
            blit: blit_pipeline(ctx, &blit_layout, wgpu::TextureFormat::Bgra8UnormSrgb),
            blit_format: wgpu::TextureFormat::Bgra8UnormSrgb,
            blit_layout,
            sampler,
            composite: None,
        }
    }

    /// The blit pipeline for the surface's format (rebuilt if it differs).
    fn blit_pipeline(&mut self, ctx: &GpuContext, format: wgpu::TextureFormat) {
        if self.blit_format != format {
            self.blit = blit_pipeline(ctx, &self.blit_layout, format);
            self.blit_format = format;
        }
    }

    fn ensure_composite(&mut self, ctx: &GpuContext, size: (u32, u32)) {
        let stale = match &self.composite {
            Some((t, _)) => (t.width(), t.height()) != size,
            None => true,
        };
        if stale {
            let tex = ctx.device.create_texture(&wgpu::TextureDescriptor {
                label: Some("viewer composite"),
                size: wgpu::Extent3d {
                    width: size.0,
                    height: size.1,
                    depth_or_array_layers: 1,
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: COLOUR_FORMAT,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT
                    | wgpu::TextureUsages::TEXTURE_BINDING
                    | wgpu::TextureUsages::COPY_DST
                    | wgpu::TextureUsages::COPY_SRC,
                view_formats: &[],
            });
            let view = tex.create_view(&Default::default());
            let bind_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("blit"),
                layout: &self.blit_layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: wgpu::BindingResource::TextureView(&view),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: wgpu::BindingResource::Sampler(&self.sampler),
                    },
                ],
            });
            self.composite = Some((tex, bind_group));
        }
    }
}

fn blit_pipeline(
    ctx: &GpuContext,
    layout: &wgpu::BindGroupLayout,
    format: wgpu::TextureFormat,
) -> wgpu::RenderPipeline {
    fullscreen_pipeline(ctx, "blit", BLIT_WGSL, layout, format)
}

/// Reads an RGBA8 texture back, rows tightly packed, row 0 at the top.
fn read_rgba(ctx: &GpuContext, tex: &wgpu::Texture, size: (u32, u32)) -> Result<Vec<u8>, GpuError> {
    ReadBack::default()
        .read(ctx, tex, size.0, size.1, 4, wgpu::TextureAspect::All)
        .map_err(|e| match e {
            GpuError::Device { device, message } => GpuError::Device {
                device,
                message: format!("screenshot readback: {message}"),
            },
            other => other,
        })
}
