//! Textures and buffers read back to the host: a copy into a mappable
//! buffer kept from one read-back to the next, and, on adapters that cannot
//! copy a depth texture to a buffer (GL), a pass that draws depth bit for
//! bit into an integer target first. Also the wait for the submission that
//! fills it (never for the whole device), what each step cost the CPU
//! ([`PassFigures`]), and the error a device failure becomes.

use web_time::Instant;

use crate::passes::{
    draw_fullscreen, fullscreen_pipeline, sampled_texture_layout, target, DepthImage,
    DEPTH_COPY_FORMAT, DEPTH_COPY_WGSL,
};
use crate::{GpuContext, GpuError};

/// What a pass cost the CPU in one frame, step by step (milliseconds),
/// and what it read back. The null adapter (every GPU operation free)
/// makes these the whole cost of a frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PassFigures {
    /// Recording commands: draw lists prepared, passes and copies encoded.
    pub encode_ms: f64,
    /// Handing them to the queue.
    pub submit_ms: f64,
    /// Waiting for the device: for a read-back's data, or for an older
    /// frame to leave the device.
    pub wait_ms: f64,
    /// How many times it waited.
    pub waits: u32,
    /// Copying read-back data out of mapped memory.
    pub copy_ms: f64,
    /// Bytes read back from the device.
    pub read_bytes: u64,
}

impl PassFigures {
    /// Adds `other`'s figures to these.
    pub fn add(&mut self, other: &PassFigures) {
        self.encode_ms += other.encode_ms;
        self.submit_ms += other.submit_ms;
        self.wait_ms += other.wait_ms;
        self.waits += other.waits;
        self.copy_ms += other.copy_ms;
        self.read_bytes += other.read_bytes;
    }

    /// Submits `enc` (its time is `submit_ms`), returning the submission.
    pub(crate) fn submit(
        &mut self,
        ctx: &GpuContext,
        enc: wgpu::CommandEncoder,
    ) -> wgpu::SubmissionIndex {
        let t = Instant::now();
        let cmd = enc.finish();
        self.encode_ms += ms_since(t);
        let t = Instant::now();
        let index = ctx.queue.submit([cmd]);
        self.submit_ms += ms_since(t);
        index
    }

    /// Waits until `index` has finished on the device (its time is
    /// `wait_ms`). Not in a browser: a page's thread may not block, and
    /// the browser orders its submissions itself (WebGPU's poll does
    /// nothing; WebGL2's can only time out).
    pub(crate) fn wait(
        &mut self,
        ctx: &GpuContext,
        index: wgpu::SubmissionIndex,
    ) -> Result<(), GpuError> {
        if cfg!(target_arch = "wasm32") {
            return ctx.check();
        }
        let t = Instant::now();
        ctx.device
            .poll(wgpu::PollType::Wait {
                submission_index: Some(index),
                timeout: None,
            })
            .map_err(|e| device_error(ctx, e))?;
        self.wait_ms += ms_since(t);
        self.waits += 1;
        ctx.check()
    }
}

pub(crate) fn ms_since(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

/// Maps `slice` for reading and waits until it is, after submission
/// `index` (which fills it) has finished.
pub(crate) fn map_and_wait(
    ctx: &GpuContext,
    slice: wgpu::BufferSlice,
    index: wgpu::SubmissionIndex,
    figures: &mut PassFigures,
) -> Result<(), GpuError> {
    let (tx, rx) = std::sync::mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |r| {
        let _ = tx.send(r);
    });
    figures.wait(ctx, index)?;
    rx.recv()
        .map_err(|e| device_error(ctx, e))?
        .map_err(|e| device_error(ctx, e))
}

pub(crate) fn device_error(ctx: &GpuContext, e: impl std::fmt::Display) -> GpuError {
    GpuError::Device {
        device: ctx.name().to_string(),
        message: e.to_string(),
    }
}

/// A mappable buffer that read-backs copy into, kept from one read-back
/// to the next: OR reads depth back every frame, and a new buffer each
/// time would be an allocation (and a driver-side free) per frame. Made on
/// first use, and again if the size changes.
#[derive(Default)]
pub(crate) struct ReadBack {
    buffer: Option<wgpu::Buffer>,
    /// The copy pass for depth, on adapters that need it (made on first use).
    depth_copy: Option<DepthCopy>,
}

/// Where a recorded copy put its rows in the read-back buffer.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Rows {
    /// Bytes of one row as wanted, and as laid out (padded).
    row: u32,
    padded: u32,
    rows: u32,
}

impl Rows {
    /// `rows` rows of `row` bytes, packed.
    pub(crate) fn packed(row: u32, rows: u32) -> Rows {
        Rows {
            row,
            padded: row,
            rows,
        }
    }

    fn bytes(&self) -> u64 {
        self.padded as u64 * self.rows as u64
    }
}

impl ReadBack {
    /// Reads a `Depth32Float` texture back as a [`DepthImage`]: copied
    /// directly, or, where the adapter cannot copy depth (GL), drawn bit
    /// for bit into an R32Uint target that is copied.
    pub(crate) fn depth(
        &mut self,
        ctx: &GpuContext,
        tex: &wgpu::Texture,
        w: u32,
        h: u32,
        figures: &mut PassFigures,
    ) -> Result<DepthImage, GpuError> {
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        let rows = self.record_depth(ctx, &mut enc, tex, w, h);
        let bits = self.submit_and_read(ctx, enc, rows, figures)?;
        Ok(DepthImage::from_bits(w, h, bits))
    }

    /// Records on `enc` the copy of a `Depth32Float` texture's depth (bit
    /// for bit, as u32) into the buffer.
    pub(crate) fn record_depth(
        &mut self,
        ctx: &GpuContext,
        enc: &mut wgpu::CommandEncoder,
        tex: &wgpu::Texture,
        w: u32,
        h: u32,
    ) -> Rows {
        if !ctx.caps.depth_copies {
            let copy = self.depth_copy.get_or_insert_with(|| DepthCopy::new(ctx));
            let target = copy.draw(ctx, enc, tex, w, h);
            self.record_texture(ctx, enc, &target, w, h, 4, wgpu::TextureAspect::All)
        } else {
            self.record_texture(ctx, enc, tex, w, h, 4, wgpu::TextureAspect::DepthOnly)
        }
    }

    /// Copies a texture of `bpp` bytes per texel into the buffer, waits,
    /// and returns its rows tightly packed as `T`s.
    pub(crate) fn read<T: bytemuck::Pod>(
        &mut self,
        ctx: &GpuContext,
        tex: &wgpu::Texture,
        w: u32,
        h: u32,
        bpp: u32,
        aspect: wgpu::TextureAspect,
    ) -> Result<Vec<T>, GpuError> {
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        let rows = self.record_texture(ctx, &mut enc, tex, w, h, bpp, aspect);
        self.submit_and_read(ctx, enc, rows, &mut PassFigures::default())
    }

    /// The buffer, sized to hold `size` bytes (taken out while in use: a
    /// read-back that fails part-way may leave it mapped, so only a
    /// finished one is put back).
    fn buffer(&mut self, ctx: &GpuContext, size: u64) -> wgpu::Buffer {
        match self.buffer.take().filter(|b| b.size() == size) {
            Some(b) => b,
            None => ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("readback"),
                size,
                usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
                mapped_at_creation: false,
            }),
        }
    }

    /// Records on `enc` the copy of a texture of `bpp` bytes per texel
    /// into the buffer (rows padded to 256 bytes, as copies need).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn record_texture(
        &mut self,
        ctx: &GpuContext,
        enc: &mut wgpu::CommandEncoder,
        tex: &wgpu::Texture,
        w: u32,
        h: u32,
        bpp: u32,
        aspect: wgpu::TextureAspect,
    ) -> Rows {
        let row = w * bpp;
        let rows = Rows {
            row,
            padded: row.next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT),
            rows: h,
        };
        let buf = self.buffer(ctx, rows.bytes());
        enc.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture: tex,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: &buf,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(rows.padded),
                    rows_per_image: Some(h),
                },
            },
            wgpu::Extent3d {
                width: w,
                height: h,
                depth_or_array_layers: 1,
            },
        );
        self.buffer = Some(buf);
        rows
    }

    /// Records on `enc` the copy of `rows` (packed) from `src` at
    /// `offset` into the buffer.
    pub(crate) fn record_buffer(
        &mut self,
        ctx: &GpuContext,
        enc: &mut wgpu::CommandEncoder,
        src: &wgpu::Buffer,
        offset: u64,
        rows: Rows,
    ) -> Rows {
        let buf = self.buffer(ctx, rows.bytes());
        enc.copy_buffer_to_buffer(src, offset, &buf, 0, rows.bytes());
        self.buffer = Some(buf);
        rows
    }

    /// Submits `enc` (which ends with a copy recorded here), waits for
    /// that submission, and returns the copied rows, unpadded, as `T`s;
    /// every step's cost goes to `figures`.
    pub(crate) fn submit_and_read<T: bytemuck::Pod>(
        &mut self,
        ctx: &GpuContext,
        enc: wgpu::CommandEncoder,
        rows: Rows,
        figures: &mut PassFigures,
    ) -> Result<Vec<T>, GpuError> {
        let index = figures.submit(ctx, enc);
        let buf = self.buffer.take().expect("a copy was recorded");
        map_and_wait(ctx, buf.slice(..), index, figures)?;
        self.unpack(ctx, buf, rows, figures)
    }

    /// Submits `enc` (which ends with a copy recorded here) and asks for
    /// the buffer's mapping without waiting: [`ReadBack::try_finish`]
    /// takes the rows once the device has filled it. The buffer is the
    /// pending read-back's until then, so no other copy may be recorded
    /// here meanwhile (a new buffer would be made).
    pub(crate) fn submit_async(
        &mut self,
        ctx: &GpuContext,
        enc: wgpu::CommandEncoder,
        rows: Rows,
        figures: &mut PassFigures,
    ) -> Pending {
        figures.submit(ctx, enc);
        let buffer = self.buffer.take().expect("a copy was recorded");
        let mapped: MapResult = Default::default();
        let slot = mapped.clone();
        buffer.slice(..).map_async(wgpu::MapMode::Read, move |r| {
            *slot.lock().unwrap_or_else(|p| p.into_inner()) = Some(r);
        });
        Pending {
            buffer,
            rows,
            mapped,
        }
    }

    /// The rows of `pending` as `T`s once its buffer is mapped (`Err`
    /// gives `pending` back while it is not). Never blocks: on native
    /// backends it polls the device once; in a browser the mapping
    /// arrives between the page's tasks.
    pub(crate) fn try_finish<T: bytemuck::Pod>(
        &mut self,
        ctx: &GpuContext,
        pending: Pending,
        figures: &mut PassFigures,
    ) -> Result<Result<Vec<T>, GpuError>, Pending> {
        let _ = ctx.device.poll(wgpu::PollType::Poll);
        let state = pending
            .mapped
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .take();
        match state {
            None => Err(pending),
            Some(Err(e)) => Ok(Err(device_error(ctx, e))),
            Some(Ok(())) => Ok(self.unpack(ctx, pending.buffer, pending.rows, figures)),
        }
    }

    /// The mapped `buf`'s `rows`, unpadded, as `T`s; unmaps it and keeps
    /// it for the next read-back.
    fn unpack<T: bytemuck::Pod>(
        &mut self,
        ctx: &GpuContext,
        buf: wgpu::Buffer,
        rows: Rows,
        figures: &mut PassFigures,
    ) -> Result<Vec<T>, GpuError> {
        let t = Instant::now();
        let data = buf.get_mapped_range(..).map_err(|e| device_error(ctx, e))?;
        let (row, padded) = (rows.row as usize, rows.padded as usize);
        let mut out = Vec::with_capacity(row * rows.rows as usize / std::mem::size_of::<T>());
        for y in 0..rows.rows as usize {
            let bytes = &data[y * padded..][..row];
            match bytemuck::try_cast_slice(bytes) {
                Ok(texels) => out.extend_from_slice(texels),
                // Mapped memory is aligned in practice; copy if it is not.
                Err(_) => out.extend(
                    bytes
                        .chunks_exact(std::mem::size_of::<T>())
                        .map(bytemuck::pod_read_unaligned::<T>),
                ),
            }
        }
        drop(data);
        buf.unmap();
        figures.copy_ms += ms_since(t);
        figures.read_bytes += rows.bytes();
        self.buffer = Some(buf);
        Ok(out)
    }
}

/// What the mapping callback of a pending read-back reports.
type MapResult = std::sync::Arc<std::sync::Mutex<Option<Result<(), wgpu::BufferAsyncError>>>>;

/// A read-back submitted and not yet taken ([`ReadBack::submit_async`]).
pub(crate) struct Pending {
    buffer: wgpu::Buffer,
    rows: Rows,
    mapped: MapResult,
}

/// The depth copy pass (`shaders/depth_copy.wgsl`), with its target and
/// bind group kept while the depth texture and size stay the same.
struct DepthCopy {
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
    sampler: wgpu::Sampler,
    /// The depth texture last copied, its bind group, and the target.
    bound: Option<(wgpu::Texture, wgpu::BindGroup, wgpu::Texture)>,
}

impl DepthCopy {
    fn new(ctx: &GpuContext) -> DepthCopy {
        let d = &ctx.device;
        let layout = sampled_texture_layout(ctx, "depth copy", false);
        // Nearest, clamped: what the shader reads at texel centres.
        let sampler = d.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("depth copy"),
            ..Default::default()
        });
        let pipeline = fullscreen_pipeline(
            ctx,
            "depth copy",
            DEPTH_COPY_WGSL,
            &layout,
            DEPTH_COPY_FORMAT,
        );
        DepthCopy {
            pipeline,
            layout,
            sampler,
            bound: None,
        }
    }

    /// Records on `enc` the drawing of `tex`'s depth into the R32Uint
    /// target and returns the target (the caller records its copy next).
    fn draw(
        &mut self,
        ctx: &GpuContext,
        enc: &mut wgpu::CommandEncoder,
        tex: &wgpu::Texture,
        w: u32,
        h: u32,
    ) -> wgpu::Texture {
        let fresh = match &self.bound {
            Some((t, _, target)) => t != tex || target.width() != w || target.height() != h,
            None => true,
        };
        if fresh {
            let view = tex.create_view(&wgpu::TextureViewDescriptor {
                aspect: wgpu::TextureAspect::DepthOnly,
                ..Default::default()
            });
            let bind_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("depth copy"),
                layout: &self.layout,
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
            let target = target(ctx, "depth copy", w, h, DEPTH_COPY_FORMAT);
            self.bound = Some((tex.clone(), bind_group, target));
        }
        let (_, bind_group, target) = self.bound.as_ref().expect("bound above");
        draw_fullscreen(enc, "depth copy", target, &self.pipeline, bind_group);
        target.clone()
    }
}
