//! What gigawalk needs of an adapter, stated once, and every adapter checked
//! against it before a device is opened: an adapter that cannot run the
//! passes is skipped with the reason, instead of failing with a validation
//! error minutes into a run.
//!
//! Required (every pass): the downlevel flags in [`REQUIRED_DOWNLEVEL`]
//! (none now), the limits of [`base_limits`] (what [`crate::open_devices`]
//! requests), and the texture formats in [`REQUIRED_FORMATS`].
//! Optional, each with what happens without it ([`Optional`]): depth
//! texture copies (without them depth is read back through a small pass
//! that draws it into a colour target, `DepthCopy` in passes/readback.rs), line
//! polygon mode (wireframe), index values beyond 2^24 (larger LODs), clip
//! distances (sections clip in the rasterizer rather than discarding
//! fragments), compute shaders (OR's HZB pyramid), indirect draws with
//! a first instance (a run of draws recorded as one multi-draw), draws
//! with a base vertex and one buffer bound as both vertex and index
//! buffer (a browser's WebGL2 has neither). [`Capabilities::of`]
//! decides them all once per adapter; a device is opened with what it
//! decided, and the passes ask the device's [`Capabilities`], nothing else.
//! Whether occlusion queries count samples (only `oq`'s adaptive culling
//! needs it) takes a device to find out: [`crate::query_counts`].

use wgpu::{DownlevelFlags, Features, TextureFormat, TextureUsages};

/// Downlevel flags every pass needs, each with why: none (base vertex
/// and shared buffers are [`Optional`]).
pub const REQUIRED_DOWNLEVEL: [(DownlevelFlags, &str); 0] = [];

/// Texture formats every pass needs, with the usages and why.
pub const REQUIRED_FORMATS: [(TextureFormat, TextureUsages, &str); 3] = [
    (
        crate::DEPTH_FORMAT,
        TextureUsages::RENDER_ATTACHMENT.union(TextureUsages::TEXTURE_BINDING),
        "OR's and RVG's depth, sampled when read back",
    ),
    (
        crate::COLOUR_FORMAT,
        TextureUsages::RENDER_ATTACHMENT.union(TextureUsages::COPY_SRC),
        "RVG's colour, read back for references and screenshots",
    ),
    (
        crate::passes::DEPTH_COPY_FORMAT,
        TextureUsages::RENDER_ATTACHMENT.union(TextureUsages::COPY_SRC),
        "depth copied to a colour target for read-back",
    ),
];

/// What an adapter may lack and still run gigawalk, and what changes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Optional {
    /// Copying a depth texture to a buffer (`DEPTH_TEXTURE_AND_BUFFER_COPIES`;
    /// GL lacks it): depth is read back through a copy pass instead.
    DepthCopies,
    /// Line polygon mode (`POLYGON_MODE_LINE`; GLES lacks it): no wireframe.
    Wireframe,
    /// Index values up to 2^32 - 1 (`FULL_DRAW_INDEX_UINT32`; some GL
    /// drivers, llvmpipe among them, promise only 2^24 - 1): a LOD may have
    /// at most 2^24 vertices (indices are local to a LOD), checked when a
    /// scene is loaded ([`crate::GpuContext::max_lod_vertices`]).
    IndexRange,
    /// User clip planes (`CLIP_DISTANCES`; GL and many mobile drivers lack
    /// it): section planes are applied by discarding fragments instead.
    ClipDistances,
    /// Compute passes for OR's HZB pyramid (`COMPUTE_SHADERS` and a backend
    /// other than GL, whose compute path is not used): the pyramid is built
    /// with fragment passes into a texture instead.
    ComputePyramid,
    /// Indirect draws with a first instance (`INDIRECT_EXECUTION` and
    /// `INDIRECT_FIRST_INSTANCE`; GL lacks the second): each draw is
    /// recorded as a call of its own instead of runs of draws as one
    /// multi-draw. The image is the same.
    MultiDraw,
    /// Draws with a base vertex (`BASE_VERTEX`; WebGL2 lacks it): each
    /// draw binds the vertex buffer at its LOD's first vertex. The image
    /// is the same.
    BaseVertex,
    /// One buffer bound as both vertex and index buffer
    /// (`UNRESTRICTED_INDEX_BUFFER`; WebGL2 forbids it): the streaming
    /// pool keeps vertices and indices in buffers of their own, half the
    /// pool each.
    SharedBuffers,
}

impl Optional {
    /// What the adapter lacks, and what that changes.
    pub fn describe(self) -> &'static str {
        match self {
            Optional::DepthCopies => {
                "no depth-texture copies: depth is read back through a copy pass"
            }
            Optional::Wireframe => "no line polygon mode: no wireframe",
            Optional::IndexRange => {
                "index values only up to 2^24 - 1: a LOD may have at most 16,777,216 vertices"
            }
            Optional::ClipDistances => {
                "no clip distances: section planes discard fragments instead"
            }
            Optional::ComputePyramid => {
                "no compute pyramid: OR's HZB pyramid is built with fragment passes"
            }
            Optional::MultiDraw => {
                "no indirect first instance: each LOD is a draw call of its own, not one multi-draw a run"
            }
            Optional::BaseVertex => {
                "no base vertex: each draw binds its LOD's vertices at their offset"
            }
            Optional::SharedBuffers => {
                "no buffer both vertex and index buffer: the streaming pool splits vertices and indices"
            }
        }
    }
}

/// The optional capabilities of an adapter, decided once: the device is
/// opened with the features they need, and every pass asks this instead
/// of the adapter.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Capabilities {
    /// Depth textures copy straight to a buffer (else the copy pass).
    pub depth_copies: bool,
    /// Line polygon mode, for the viewer's wireframe.
    pub wireframe: bool,
    /// Index values may use all 32 bits.
    pub full_index_range: bool,
    /// Section planes clip in the rasterizer.
    pub clip_distances: bool,
    /// OR's HZB pyramid may be built by compute passes.
    pub compute_pyramid: bool,
    /// Runs of draws go as one `multi_draw_indexed_indirect`, each draw's
    /// instance data found by its first instance.
    pub multi_draw: bool,
    /// Draws take a base vertex (else the vertex buffer is bound at the
    /// LOD's first vertex for each draw).
    pub base_vertex: bool,
    /// One buffer may be bound as vertex and index buffer at once.
    pub shared_buffers: bool,
}

impl Capabilities {
    pub fn of(adapter: &wgpu::Adapter) -> Capabilities {
        let flags = adapter.get_downlevel_capabilities().flags;
        let features = adapter.features();
        Capabilities {
            depth_copies: flags.contains(DownlevelFlags::DEPTH_TEXTURE_AND_BUFFER_COPIES),
            wireframe: features.contains(Features::POLYGON_MODE_LINE),
            full_index_range: flags.contains(DownlevelFlags::FULL_DRAW_INDEX_UINT32),
            clip_distances: features.contains(Features::CLIP_DISTANCES),
            compute_pyramid: flags.contains(DownlevelFlags::COMPUTE_SHADERS)
                && adapter.get_info().backend != wgpu::Backend::Gl,
            multi_draw: flags.contains(DownlevelFlags::INDIRECT_EXECUTION)
                && features.contains(Features::INDIRECT_FIRST_INSTANCE),
            base_vertex: flags.contains(DownlevelFlags::BASE_VERTEX),
            shared_buffers: flags.contains(DownlevelFlags::UNRESTRICTED_INDEX_BUFFER),
        }
    }

    /// The device features these need (requested when it is opened).
    pub fn features(self) -> Features {
        let mut f = Features::empty();
        if self.wireframe {
            f |= Features::POLYGON_MODE_LINE;
        }
        if self.clip_distances {
            f |= Features::CLIP_DISTANCES;
        }
        if self.multi_draw {
            f |= Features::INDIRECT_FIRST_INSTANCE;
        }
        f
    }

    /// What is missing, in [`Optional`]'s order.
    pub fn missing(self) -> Vec<Optional> {
        [
            (self.depth_copies, Optional::DepthCopies),
            (self.wireframe, Optional::Wireframe),
            (self.full_index_range, Optional::IndexRange),
            (self.clip_distances, Optional::ClipDistances),
            (self.compute_pyramid, Optional::ComputePyramid),
            (self.multi_draw, Optional::MultiDraw),
            (self.base_vertex, Optional::BaseVertex),
            (self.shared_buffers, Optional::SharedBuffers),
        ]
        .into_iter()
        .filter(|(has, _)| !has)
        .map(|(_, o)| o)
        .collect()
    }
}

/// One adapter as seen, and whether it can run gigawalk.
#[derive(Clone, Debug)]
pub struct AdapterReport {
    pub info: wgpu::AdapterInfo,
    /// What it lacks that gigawalk needs; empty when it qualifies.
    pub missing: Vec<String>,
    /// Optional capabilities it lacks (it may still qualify).
    pub optional_missing: Vec<Optional>,
    /// What its occlusion queries return, where a device was opened to
    /// find out ([`list_adapters`]; qualifying adapters only).
    pub query_counts: Option<crate::QueryCounts>,
}

impl AdapterReport {
    /// Checks `adapter` against what gigawalk needs.
    pub fn of(adapter: &wgpu::Adapter) -> AdapterReport {
        let info = adapter.get_info();
        let downlevel = adapter.get_downlevel_capabilities();
        let mut missing: Vec<String> = REQUIRED_DOWNLEVEL
            .iter()
            .filter(|(flag, _)| !downlevel.flags.contains(*flag))
            .map(|(_, why)| (*why).to_string())
            .collect();
        let mut limits = Vec::new();
        base_limits(adapter).check_limits_with_fail_fn(
            &adapter.limits(),
            false,
            |name, needed, has| limits.push(format!("{name} {has} (needs {needed})")),
        );
        if !limits.is_empty() {
            missing.push(format!("limits: {}", limits.join(", ")));
        }
        // The null adapter states no format capabilities of its own; a
        // device that does not ask for adapter-specific format features
        // (ours never does) gets WebGPU's guaranteed ones, so those are
        // what it has.
        let null = info.backend == wgpu::Backend::Noop;
        for (format, usages, why) in REQUIRED_FORMATS {
            let has = if null {
                format
                    .guaranteed_format_features(adapter.features())
                    .allowed_usages
            } else {
                adapter.get_texture_format_features(format).allowed_usages
            };
            if !has.contains(usages) {
                missing.push(format!("{format:?} as {:?} ({why})", usages - has));
            }
        }
        AdapterReport {
            info,
            missing,
            optional_missing: Capabilities::of(adapter).missing(),
            query_counts: None,
        }
    }

    pub fn qualifies(&self) -> bool {
        self.missing.is_empty()
    }

    /// "llvmpipe (LLVM 15.0.6, 256 bits) (Gl, Cpu)".
    pub fn name(&self) -> String {
        format!(
            "{} ({:?}, {:?})",
            self.info.name, self.info.backend, self.info.device_type
        )
    }

    /// One line: the adapter, and what it lacks or that it qualifies.
    pub fn line(&self) -> String {
        if self.qualifies() {
            format!("{}: usable", self.name())
        } else {
            format!("{} lacks {}", self.name(), self.missing.join("; "))
        }
    }
}

/// The limits gigawalk asks a device for: [`wgpu::Limits::downlevel_defaults`],
/// or on a browser's WebGL2, which has no storage buffers and no compute,
/// WebGL2's own (OR's pyramid then takes its fragment path, as on GL).
pub fn base_limits(adapter: &wgpu::Adapter) -> wgpu::Limits {
    if cfg!(target_arch = "wasm32") && adapter.get_info().backend == wgpu::Backend::Gl {
        wgpu::Limits::downlevel_webgl2_defaults()
    } else {
        wgpu::Limits::downlevel_defaults()
    }
}

/// How to get an adapter gigawalk can use, for the "none" error.
pub const HOW_TO_GET_ONE: &str = "on Linux without a GPU install Mesa's software Vulkan driver (apt-get install mesa-vulkan-drivers); otherwise install a GPU driver with Vulkan, Metal, DX12 or OpenGL 3.3+ / GLES 3.2";

/// Every adapter on every backend (Vulkan, Metal, DX12, GL) that wgpu finds
/// here, each checked, and on each that qualifies a device opened to see
/// whether its occlusion queries count samples; `WGPU_BACKEND` narrows the
/// backends as everywhere. For `gigawalk info --adapters`: it probes GL
/// even when another backend has adapters, which opening devices does not.
pub fn list_adapters() -> Vec<AdapterReport> {
    let backends = wgpu::Backends::from_env().unwrap_or(wgpu::Backends::all())
        & wgpu::Instance::enabled_backend_features();
    let mut out = Vec::new();
    for (backend, _) in crate::context::BACKENDS {
        if !backends.contains(backend) {
            continue;
        }
        let instance = crate::context::instance(backend);
        for adapter in crate::context::adapters(&instance) {
            let mut report = AdapterReport::of(&adapter);
            if report.qualifies() {
                report.query_counts = crate::context::open(&adapter, "probe")
                    .and_then(|ctx| crate::query_counts(&ctx))
                    .ok();
            }
            out.push(report);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_missing_capability_is_named_once_and_features_follow_the_choice() {
        let all = Capabilities {
            depth_copies: true,
            wireframe: true,
            full_index_range: true,
            clip_distances: true,
            compute_pyramid: true,
            multi_draw: true,
            base_vertex: true,
            shared_buffers: true,
        };
        assert!(all.missing().is_empty());
        assert_eq!(
            all.features(),
            Features::POLYGON_MODE_LINE
                | Features::CLIP_DISTANCES
                | Features::INDIRECT_FIRST_INSTANCE
        );
        let gl_like = Capabilities {
            depth_copies: false,
            wireframe: true,
            full_index_range: false,
            clip_distances: false,
            compute_pyramid: false,
            multi_draw: false,
            base_vertex: false,
            shared_buffers: false,
        };
        assert_eq!(
            gl_like.missing(),
            [
                Optional::DepthCopies,
                Optional::IndexRange,
                Optional::ClipDistances,
                Optional::ComputePyramid,
                Optional::MultiDraw,
                Optional::BaseVertex,
                Optional::SharedBuffers,
            ]
        );
        assert_eq!(gl_like.features(), Features::POLYGON_MODE_LINE);
        // Every description is distinct, so a report names each once.
        let mut texts: Vec<_> = gl_like.missing().iter().map(|o| o.describe()).collect();
        texts.push(Optional::Wireframe.describe());
        texts.sort_unstable();
        texts.dedup();
        assert_eq!(texts.len(), 8);
    }
}
