//! Textures read back to the host: a copy into a mappable buffer kept from
//! one read-back to the next, and, on adapters that cannot copy a depth
//! texture to a buffer (GL), a pass that draws depth bit for bit into an
//! integer target first. Also the wait for the device that every read-back
//! ends with, and the error a device failure becomes.

use crate::passes::{fullscreen_pipeline, target, DepthImage, DEPTH_COPY_FORMAT, DEPTH_COPY_WGSL};
use crate::{GpuContext, GpuError};

/// Maps `slice` for reading and waits until it is (after the submissions
/// that fill it).
pub(crate) fn map_and_wait(ctx: &GpuContext, slice: wgpu::BufferSlice) -> Result<(), GpuError> {
    let (tx, rx) = std::sync::mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |r| {
        let _ = tx.send(r);
    });
    ctx.device
        .poll(wgpu::PollType::wait_indefinitely())
        .map_err(|e| device_error(ctx, e))?;
    ctx.check()?;
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

/// A mappable buffer that texture read-backs copy into, kept from one
/// read-back to the next: OR reads its depth back every frame, and a new
/// buffer each time would be an allocation (and a driver-side free) per
/// frame. Made on first use, and again if the size changes.
#[derive(Default)]
pub(crate) struct ReadBack {
    buffer: Option<wgpu::Buffer>,
    /// The copy pass for depth, on adapters that need it (made on first use).
    depth_copy: Option<DepthCopy>,
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
    ) -> Result<DepthImage, GpuError> {
        let depth = if ctx.depth_via_pass {
            let copy = self.depth_copy.get_or_insert_with(|| DepthCopy::new(ctx));
            let target = copy.draw(ctx, tex, w, h);
            let bits: Vec<u32> = self.read(ctx, &target, w, h, 4, wgpu::TextureAspect::All)?;
            bits.into_iter().map(f32::from_bits).collect()
        } else {
            self.read(ctx, tex, w, h, 4, wgpu::TextureAspect::DepthOnly)?
        };
        Ok(DepthImage {
            width: w,
            height: h,
            depth,
        })
    }

    /// Copies a texture of `bpp` bytes per texel into the buffer, waits,
    /// and returns its rows tightly packed (the copy pads rows to 256
    /// bytes) as `T`s.
    pub(crate) fn read<T: bytemuck::Pod>(
        &mut self,
        ctx: &GpuContext,
        tex: &wgpu::Texture,
        w: u32,
        h: u32,
        bpp: u32,
        aspect: wgpu::TextureAspect,
    ) -> Result<Vec<T>, GpuError> {
        let row = w * bpp;
        let padded = row.next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
        let size = padded as u64 * h as u64;
        // Taken out while in use: a read-back that fails part-way may leave
        // the buffer mapped, so only a finished one is put back.
        let buf = match self.buffer.take().filter(|b| b.size() == size) {
            Some(b) => b,
            None => ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("readback"),
                size,
                usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
                mapped_at_creation: false,
            }),
        };
        let mut enc = ctx.device.create_command_encoder(&Default::default());
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
                    bytes_per_row: Some(padded),
                    rows_per_image: Some(h),
                },
            },
            wgpu::Extent3d {
                width: w,
                height: h,
                depth_or_array_layers: 1,
            },
        );
        ctx.queue.submit([enc.finish()]);
        map_and_wait(ctx, buf.slice(..))?;
        let data = buf.get_mapped_range(..).map_err(|e| device_error(ctx, e))?;
        let mut out = Vec::with_capacity(row as usize * h as usize / std::mem::size_of::<T>());
        for y in 0..h as usize {
            let bytes = &data[y * padded as usize..][..row as usize];
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
        self.buffer = Some(buf);
        Ok(out)
    }
}

/// The depth copy pass (`shaders/depth_copy.wgsl`), with its target and
/// bind group kept while the depth texture and size stay the same.
struct DepthCopy {
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
    /// The depth texture last copied, its bind group, and the target.
    bound: Option<(wgpu::Texture, wgpu::BindGroup, wgpu::Texture)>,
}

impl DepthCopy {
    fn new(ctx: &GpuContext) -> DepthCopy {
        let d = &ctx.device;
        let layout = d.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("depth copy"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Float { filterable: false },
                    view_dimension: wgpu::TextureViewDimension::D2,
                    multisampled: false,
                },
                count: None,
            }],
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
            bound: None,
        }
    }

    /// Draws `tex`'s depth into the R32Uint target and returns it (the
    /// caller's copy is submitted after this pass, on the same queue).
    fn draw(&mut self, ctx: &GpuContext, tex: &wgpu::Texture, w: u32, h: u32) -> wgpu::Texture {
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
                entries: &[wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::TextureView(&view),
                }],
            });
            let target = target(ctx, "depth copy", w, h, DEPTH_COPY_FORMAT);
            self.bound = Some((tex.clone(), bind_group, target));
        }
        let (_, bind_group, target) = self.bound.as_ref().expect("bound above");
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        {
            let view = target.create_view(&Default::default());
            let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("depth copy"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                ..Default::default()
            });
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, bind_group, &[]);
            pass.draw(0..3, 0..1);
        }
        ctx.queue.submit([enc.finish()]);
        target.clone()
    }
}
