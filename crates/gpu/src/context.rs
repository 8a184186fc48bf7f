//! Opening wgpu devices: two by default (two adapters when the machine has
//! two GPUs, else two devices on one adapter), on adapters that qualify
//! (`capabilities.rs`), and a clear error naming every adapter seen and
//! what it lacks when none does.

use crate::capabilities::Capabilities;
use std::sync::{Arc, Mutex};

/// Why the GPU side failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum GpuError {
    /// No adapter qualifies: `seen` names each adapter found and what it
    /// lacks, or the backends tried when there was none.
    #[error("no GPU adapter gigawalk can use ({seen}); {how}", how = crate::capabilities::HOW_TO_GET_ONE)]
    NoAdapter { seen: String },
    #[error("no usable GPU adapter's name contains {wanted:?} (usable: {usable}); `gigawalk info --adapters` lists them")]
    NoMatchingAdapter { wanted: String, usable: String },
    #[error("cannot open a device on adapter {adapter}: {source}")]
    RequestDevice {
        adapter: String,
        source: wgpu::RequestDeviceError,
    },
    #[error(
        "LOD {lod} has {vertices} vertices, more than device {device} can index ({max} a LOD)"
    )]
    IndexRange {
        lod: u32,
        vertices: u64,
        device: String,
        max: u64,
    },
    #[error("cannot open {count} devices: the pipeline uses 1 or 2")]
    DeviceCount { count: usize },
    #[error("GPU error on device {device}: {message}")]
    Device { device: String, message: String },
    #[error("scene geometry: {0}")]
    Scene(#[from] gigawalk_scene::ReadError),
    #[error("{what} needs {needed} bytes, more than this device's buffer limit of {limit}")]
    TooLarge {
        what: String,
        needed: u64,
        limit: u64,
    },
}

/// One wgpu device with its queue; a pipeline stage owns one.
pub struct GpuContext {
    pub(crate) device: wgpu::Device,
    pub(crate) queue: wgpu::Queue,
    pub(crate) info: wgpu::AdapterInfo,
    /// A name for messages, e.g. "A (llvmpipe, Vulkan)".
    name: String,
    /// The first uncaptured wgpu error, if any: wgpu reports validation
    /// errors through a callback; we turn them into [`GpuError::Device`]
    /// instead of the default panic.
    errors: Arc<Mutex<Option<String>>>,
    /// The optional capabilities it was opened with, and the passes use
    /// (a test may turn one off to compare the two paths on one adapter).
    pub(crate) caps: Capabilities,
}

/// Names of software rasterizers, as adapters report them (lower case).
const CPU_RASTERIZERS: [&str; 5] = [
    "llvmpipe",
    "lavapipe",
    "softpipe",
    "swiftshader",
    "basic render",
];

impl GpuContext {
    /// A name for messages, e.g. "A (llvmpipe, Vulkan)".
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The adapter's own name ("llvmpipe (LLVM 15.0.6, 256 bits)").
    pub fn adapter_name(&self) -> &str {
        &self.info.name
    }

    /// Whether the device is on a GL backend (native GL, or a browser's
    /// WebGL2).
    pub fn is_gl(&self) -> bool {
        self.info.backend == wgpu::Backend::Gl
    }

    /// The largest side of a 2D texture (a viewport or depth image).
    pub fn max_texture_side(&self) -> u32 {
        self.device.limits().max_texture_dimension_2d
    }

    /// The largest buffer the device allocates, in bytes.
    pub fn max_buffer_size(&self) -> u64 {
        self.device.limits().max_buffer_size
    }

    /// Submits the work recorded so far (uploads written to the queue)
    /// without waiting for it.
    pub fn flush(&self) {
        self.queue.submit([]);
    }

    /// Whether this is the null adapter ([`NULL_ADAPTER_NAMES`]): every
    /// GPU operation free, nothing drawn, depth read back as zeros.
    pub fn is_null(&self) -> bool {
        self.info.backend == wgpu::Backend::Noop
    }

    /// Whether the adapter rasterizes on the CPU (lavapipe, llvmpipe,
    /// WARP, SwiftShader). A browser's WebGPU adapter says only whether it
    /// is a fallback, so a known software rasterizer's name counts too.
    pub fn is_cpu(&self) -> bool {
        let name = self.info.name.to_ascii_lowercase();
        self.info.device_type == wgpu::DeviceType::Cpu
            || CPU_RASTERIZERS.iter().any(|r| name.contains(r))
    }

    /// Whether the rasterizer clips by user planes (sections clip there
    /// rather than discarding fragments).
    pub fn supports_clip_distances(&self) -> bool {
        self.caps.clip_distances
    }

    /// Whether RVG can draw [`crate::DrawStyle::Wireframe`] here.
    pub fn supports_wireframe(&self) -> bool {
        self.caps.wireframe
    }

    /// The optional capabilities this device's passes use.
    pub fn capabilities(&self) -> Capabilities {
        self.caps
    }

    /// An absolute bound on how far a depth this device stores may lie from
    /// the surface's exact depth, beyond the f32 rounding the culling's
    /// relative slacks absorb: [`GL_DEPTH_ERROR`] on GL, else 0.
    pub fn depth_error(&self) -> f32 {
        if self.info.backend == wgpu::Backend::Gl {
            GL_DEPTH_ERROR
        } else {
            0.0
        }
    }

    /// The most vertices one LOD may have here: its indices are local to it
    /// and must stay within the adapter's index range (2^32, or 2^24 where
    /// the adapter lacks `FULL_DRAW_INDEX_UINT32`, as some GL drivers do).
    pub fn max_lod_vertices(&self) -> u64 {
        if self.caps.full_index_range {
            1 << 32
        } else {
            1 << 24
        }
    }

    /// Reads depth back through the copy pass even where direct copies
    /// work, so tests compare the two paths on one adapter.
    #[cfg(feature = "testing")]
    pub fn force_depth_copy_pass(&mut self) {
        self.caps.depth_copies = false;
    }

    /// Records every draw as a call of its own even where runs of draws
    /// would be one multi-draw (passes made after this), so tests compare
    /// the two on one adapter.
    #[cfg(feature = "testing")]
    pub fn force_draw_calls(&mut self) {
        self.caps.multi_draw = false;
    }

    /// Takes the paths a browser's WebGL2 needs even where the adapter
    /// has better (no multi-draw, no base vertex, no shared vertex and
    /// index buffer, the fragment pyramid), so tests compare them on one
    /// adapter.
    #[cfg(feature = "testing")]
    pub fn force_webgl2_paths(&mut self) {
        self.caps.multi_draw = false;
        self.caps.base_vertex = false;
        self.caps.shared_buffers = false;
        self.caps.compute_pyramid = false;
    }

    /// Builds OR's HZB pyramid with fragment passes even where compute
    /// passes would be used, so tests compare the two paths on one adapter.
    #[cfg(feature = "testing")]
    pub fn force_fragment_pyramid(&mut self) {
        self.caps.compute_pyramid = false;
    }

    /// Returns the first GPU error seen since the device was opened.
    pub fn check(&self) -> Result<(), GpuError> {
        match self.errors.lock().expect("error slot").clone() {
            None => Ok(()),
            Some(message) => Err(GpuError::Device {
                device: self.name.clone(),
                message,
            }),
        }
    }
}

/// The absolute depth error of wgpu's GL backend: its shaders map clip z
/// from [0, 1] to GL's [-1, 1] (`z * 2 - w`) and GL maps it back, so a
/// depth near 0 (far away, reversed-Z) is rounded near -1, where an f32
/// step is 2^-24 in NDC and 2^-25 in stored depth, absolute, not relative
/// (measured: 1.8e-8 off at depth 1.3e-4 on llvmpipe). 2^-22 is eight
/// stored-depth steps: a bound on the gap between any two depths GL
/// stores for one surface (drawn by different shaders, OR's and RVG's),
/// and between either and the exact depth, so occlusion tests against GL
/// depth (the HZB from OR's, the grid's software depth against RVG's)
/// lower the occluder by it once.
pub const GL_DEPTH_ERROR: f32 = 1.0 / (1 << 22) as f32;

/// The devices' names in messages: OR's device first, RVG's second.
const DEVICE_NAMES: [&str; 2] = ["A", "B"];

/// The name of device `k` of `count`, or [`GpuError::DeviceCount`] when
/// `count` is not 1 or 2 (a caller's option, so an error, not a panic).
pub(crate) fn device_name(k: usize, count: usize) -> Result<&'static str, GpuError> {
    match DEVICE_NAMES.get(k) {
        Some(&name) if (1..=DEVICE_NAMES.len()).contains(&count) => Ok(name),
        _ => Err(GpuError::DeviceCount { count }),
    }
}

pub(crate) fn rank(t: wgpu::DeviceType) -> u8 {
    match t {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Other => 3,
        wgpu::DeviceType::Cpu => 4,
    }
}

pub(crate) fn instance(backends: wgpu::Backends) -> wgpu::Instance {
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
    desc.backends = backends;
    // wgpu lists the noop adapter only when asked for it by name.
    desc.backend_options.noop.enable = backends.contains(wgpu::Backends::NOOP);
    if backends == wgpu::Backends::NOOP {
        // wgpu checks indirect draws with a compute pass whose setup
        // assumes a real device's storage alignment (the noop backend
        // reports 1); the null adapter draws nothing, so there is nothing
        // to check. Its CPU figures leave out that pass's recording.
        desc.flags
            .remove(wgpu::InstanceFlags::VALIDATION_INDIRECT_CALL);
    }
    wgpu::Instance::new(desc)
}

/// The names `--adapter` takes for the null adapter (wgpu's noop backend:
/// every GPU operation is free and does nothing, depth reads back as
/// zeros), which measures what the CPU can feed a GPU. Never chosen
/// unless asked for by one of these names.
pub const NULL_ADAPTER_NAMES: [&str; 2] = ["null", "noop"];

/// Whether `--adapter want` asks for the null adapter.
pub fn is_null_adapter(want: &str) -> bool {
    NULL_ADAPTER_NAMES
        .iter()
        .any(|n| n.eq_ignore_ascii_case(want.trim()))
}

/// The adapters devices may be opened on, best first, from one instance.
pub(crate) struct Candidates {
    pub(crate) instance: wgpu::Instance,
    /// Qualifying adapters, best first (and matching the name asked for).
    pub(crate) usable: Vec<wgpu::Adapter>,
    /// The backends `instance` was made for.
    pub(crate) backends: wgpu::Backends,
}

/// An instance with qualifying adapters: WGPU_BACKEND=vulkan|gl|... picks
/// backends as in wgpu's examples; otherwise the primary backends (Vulkan,
/// Metal, DX12), and GL only when they have no qualifying adapter (probing
/// GL prints noise on headless machines). `adapter`: only adapters whose
/// name contains it (case-insensitive). `instance_for` makes the instance
/// for a set of backends (a window's needs its display handle).
pub(crate) fn candidates(
    adapter: Option<&str>,
    instance_for: &mut dyn FnMut(wgpu::Backends) -> wgpu::Instance,
) -> Result<Candidates, GpuError> {
    // Only backends this build has (no Metal or DX12 on Linux).
    let built = wgpu::Instance::enabled_backend_features();
    let null = adapter.is_some_and(is_null_adapter);
    let tries = match wgpu::Backends::from_env() {
        _ if null => vec![wgpu::Backends::NOOP],
        Some(b) if (b & built).is_empty() => {
            let value = std::env::var("WGPU_BACKEND").unwrap_or_default();
            return Err(GpuError::NoAdapter {
                seen: format!(
                    "WGPU_BACKEND={value:?} names no backend this build has ({})",
                    backend_names(built)
                ),
            });
        }
        Some(b) => vec![b & built],
        None => [wgpu::Backends::PRIMARY, wgpu::Backends::SECONDARY]
            .into_iter()
            .map(|b| b & built)
            .filter(|b| !b.is_empty())
            .collect(),
    };
    let mut seen = Vec::new();
    let mut usable_names = Vec::new();
    let mut unusable_matches = Vec::new();
    let mut tried = Vec::new();
    for backends in tries {
        tried.push(backend_names(backends));
        let instance = instance_for(backends);
        let all = adapters(&instance);
        let mut usable = Vec::new();
        for a in all {
            let report = crate::capabilities::AdapterReport::of(&a);
            if !report.qualifies() {
                if let Some(want) = adapter.filter(|w| name_matches(&report.name(), w)) {
                    unusable_matches.push(format!("{want:?} matches {}", report.line()));
                }
                tracing::warn!("skipping GPU adapter {}", report.line());
                seen.push(report.line());
                continue;
            }
            usable_names.push(report.name());
            if null || adapter.is_none_or(|want| name_matches(&report.name(), want)) {
                usable.push(a);
            }
        }
        if !usable.is_empty() {
            return Ok(Candidates {
                instance,
                usable,
                backends,
            });
        }
    }
    if let (Some(wanted), false) = (adapter, usable_names.is_empty()) {
        let mut usable = usable_names.join(", ");
        for m in unusable_matches {
            usable.push_str("; ");
            usable.push_str(&m);
        }
        return Err(GpuError::NoMatchingAdapter {
            wanted: wanted.to_string(),
            usable,
        });
    }
    if seen.is_empty() {
        seen.push(format!(
            "none found; backends tried: {}",
            tried.join(", then ")
        ));
    }
    Err(GpuError::NoAdapter {
        seen: seen.join("; "),
    })
}

/// The backends gigawalk runs on, in the order they are preferred, with
/// their names for messages.
pub(crate) const BACKENDS: [(wgpu::Backends, &str); 4] = [
    (wgpu::Backends::VULKAN, "Vulkan"),
    (wgpu::Backends::METAL, "Metal"),
    (wgpu::Backends::DX12, "DX12"),
    (wgpu::Backends::GL, "GL"),
];

/// [`BACKENDS`] and the null adapter's, for naming backends in messages.
const NAMED_BACKENDS: [(wgpu::Backends, &str); 5] = [
    BACKENDS[0],
    BACKENDS[1],
    BACKENDS[2],
    BACKENDS[3],
    (wgpu::Backends::NOOP, "noop"),
];

/// "Vulkan, Metal, DX12": the backends of [`BACKENDS`] in `b`, for messages.
fn backend_names(b: wgpu::Backends) -> String {
    let names: Vec<&str> = NAMED_BACKENDS
        .iter()
        .filter(|(flag, _)| b.contains(*flag))
        .map(|(_, name)| *name)
        .collect();
    if names.is_empty() {
        format!("{b:?}")
    } else {
        names.join(", ")
    }
}

/// Whether an adapter called `name` is the one `--adapter want` asks for.
pub(crate) fn name_matches(name: &str, want: &str) -> bool {
    name.to_lowercase().contains(&want.to_lowercase())
}

/// Adapters, best first: hardware before software, then by backend
/// (Vulkan/Metal/DX12 before GL).
pub(crate) fn adapters(instance: &wgpu::Instance) -> Vec<wgpu::Adapter> {
    let mut list = pollster::block_on(instance.enumerate_adapters(wgpu::Backends::all()));
    list.sort_by_key(|a| {
        let i = a.get_info();
        (rank(i.device_type), i.backend == wgpu::Backend::Gl)
    });
    list
}

/// Opens `count` (1 or 2) devices on the best qualifying adapter. With two,
/// each gets its own hardware adapter when the machine has two GPUs, else
/// both share the best adapter. Any other count is
/// [`GpuError::DeviceCount`]; no qualifying adapter is
/// [`GpuError::NoAdapter`], naming each adapter seen and what it lacks.
pub fn open_devices(count: usize) -> Result<Vec<GpuContext>, GpuError> {
    open_devices_on(count, None)
}

/// Like [`open_devices`], only on adapters whose name contains `adapter`
/// (case-insensitive; `--adapter`), else [`GpuError::NoMatchingAdapter`].
pub fn open_devices_on(count: usize, adapter: Option<&str>) -> Result<Vec<GpuContext>, GpuError> {
    device_name(0, count)?;
    let c = candidates(adapter, &mut instance)?;
    let best = &c.usable[0];
    let best_info = best.get_info();
    let hardware: Vec<&wgpu::Adapter> = c
        .usable
        .iter()
        .filter(|a| {
            let i = a.get_info();
            rank(i.device_type) <= 1 && i.backend == best_info.backend
        })
        .collect();
    let mut out = Vec::with_capacity(count);
    for k in 0..count {
        let name = device_name(k, count)?;
        let adapter = if count == 2 && hardware.len() >= 2 {
            hardware[k].clone()
        } else if k == 0 {
            best.clone()
        } else {
            second_adapter(&c, best, &mut instance)
        };
        out.push(open(&adapter, name)?);
    }
    Ok(out)
}

/// The adapter [`open_devices_on`] would open devices on, without opening
/// any (for `gigawalk info --adapters`).
pub fn chosen_adapter(adapter: Option<&str>) -> Result<wgpu::AdapterInfo, GpuError> {
    Ok(candidates(adapter, &mut instance)?.usable[0].get_info())
}

/// A fresh Adapter object for a second device on `best`'s adapter: wgpu
/// allows one device per Adapter object, so enumerate again. On GL, again
/// from a new instance: every enumeration of one instance shares its one
/// EGL context, each adapter behind its own lock, so two devices on two
/// threads make it current at once and EGL fails (BadAccess); a new
/// instance has a context of its own.
pub(crate) fn second_adapter(
    c: &Candidates,
    best: &wgpu::Adapter,
    instance_for: &mut dyn FnMut(wgpu::Backends) -> wgpu::Instance,
) -> wgpu::Adapter {
    let info = best.get_info();
    let fresh;
    let instance = if info.backend == wgpu::Backend::Gl {
        fresh = instance_for(c.backends);
        &fresh
    } else {
        &c.instance
    };
    adapters(instance)
        .into_iter()
        .find(|a| a.get_info() == info)
        .unwrap_or_else(|| {
            if info.backend == wgpu::Backend::Gl {
                tracing::warn!(
                    "a new GL instance does not list {}: both devices share one EGL context",
                    info.name
                );
            }
            best.clone()
        })
}

pub(crate) fn open(adapter: &wgpu::Adapter, name: &str) -> Result<GpuContext, GpuError> {
    pollster::block_on(open_async(adapter, name))
}

/// [`open`] without blocking: what a browser, whose device arrives
/// through the event loop, awaits.
pub(crate) async fn open_async(
    adapter: &wgpu::Adapter,
    name: &str,
) -> Result<GpuContext, GpuError> {
    let info = adapter.get_info();
    let label = format!("{name} ({}, {:?})", info.name, info.backend);
    let caps = Capabilities::of(adapter);
    let limits = wgpu::Limits {
        // Big scenes want big buffers; take what the adapter offers.
        max_buffer_size: adapter.limits().max_buffer_size,
        max_texture_dimension_2d: adapter.limits().max_texture_dimension_2d,
        // OR's HZB pyramid is one storage buffer of a third of its depth.
        max_storage_buffer_binding_size: adapter.limits().max_storage_buffer_binding_size,
        ..crate::capabilities::base_limits(adapter)
    };
    let (device, queue) = adapter
        .request_device(&wgpu::DeviceDescriptor {
            label: Some(&label),
            // Line mode for the viewer's wireframe and clip distances for
            // sections, where the adapter has them.
            required_features: caps.features(),
            required_limits: limits,
            ..Default::default()
        })
        .await
        .map_err(|source| GpuError::RequestDevice {
            adapter: label.clone(),
            source,
        })?;
    let errors = Arc::new(Mutex::new(None));
    let slot = errors.clone();
    device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
        tracing::error!("wgpu: {e}");
        let mut s = slot.lock().expect("error slot");
        if s.is_none() {
            *s = Some(e.to_string());
        }
    }));
    Ok(GpuContext {
        device,
        queue,
        info,
        name: label,
        errors,
        caps,
    })
}

/// For tests that need a GPU (feature `testing`): opens `count` devices,
/// or `None` after [`skip_test`] when no adapter qualifies.
#[cfg(feature = "testing")]
pub fn devices_or_skip(count: usize, test: &str) -> Option<Vec<GpuContext>> {
    quiet_headless_probing();
    match open_devices(count) {
        Ok(d) => Some(d),
        Err(GpuError::NoAdapter { .. }) => {
            skip_test(
                test,
                "no usable GPU adapter (install mesa-vulkan-drivers to run it)",
            );
            None
        }
        Err(e) => panic!("{test}: {e}"),
    }
}

/// Gives a test process without a desktop session a private, empty
/// XDG_RUNTIME_DIR before it first looks for adapters. Enumerating them
/// asks for a Wayland display (Mesa's Vulkan device-selection layer, EGL's
/// platform probe), and without XDG_RUNTIME_DIR libwayland-client prints
/// "error: XDG_RUNTIME_DIR is invalid or not set in the environment." each
/// time, although nothing failed: a few hundred such lines in a test run.
/// With a directory that holds no display the probe fails quietly. The
/// binary quiets the same probe its own way (`NODEVICE_SELECT`, in
/// tools/gigawalk's main.rs), which its tests check, so this stays out of
/// the library's paths. Once per process, and before any adapter is
/// enumerated from this helper, since other threads may read the
/// environment afterwards.
#[cfg(feature = "testing")]
fn quiet_headless_probing() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let set = std::env::var_os("XDG_RUNTIME_DIR")
            .is_some_and(|d| std::path::Path::new(&d).is_absolute());
        if set {
            return;
        }
        let dir = std::env::temp_dir().join("gigawalk-tests-runtime-dir");
        let mut builder = std::fs::DirBuilder::new();
        #[cfg(unix)]
        std::os::unix::fs::DirBuilderExt::mode(&mut builder, 0o700);
        // Already there (an earlier test process) is fine; so is failing to
        // make it: libwayland only needs an absolute path that holds no
        // display.
        let _ = builder.create(&dir);
        std::env::set_var("XDG_RUNTIME_DIR", &dir);
    });
}

/// For tests (feature `testing`): `test` cannot run on this machine
/// because of `why` (no adapter, no X server). Prints one `SKIP` line on
/// stderr, which `cargo test` shows; with the environment variable
/// `GIGAWALK_REQUIRE_ADAPTER` set (CI sets it) it panics instead, so that
/// a machine that should run every test fails rather than passes
/// untested.
#[cfg(feature = "testing")]
pub fn skip_test(test: &str, why: &str) {
    assert!(
        std::env::var_os("GIGAWALK_REQUIRE_ADAPTER").is_none(),
        "{test}: GIGAWALK_REQUIRE_ADAPTER is set but {why}"
    );
    eprintln!("\n!!! SKIP {test}: {why} !!!\n");
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn device_counts_other_than_one_or_two_are_errors() {
        for count in [0, 3, usize::MAX] {
            let e = open_devices(count).err().expect("an error");
            assert!(
                matches!(e, GpuError::DeviceCount { count: c } if c == count),
                "{e}"
            );
            assert!(
                e.to_string()
                    .contains(&format!("cannot open {count} devices")),
                "{e}"
            );
        }
        assert_eq!(device_name(1, 2).unwrap(), "B");
    }
}
