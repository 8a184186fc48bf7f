//! Opening wgpu devices: two by default (two adapters when the machine has
//! two GPUs, else two devices on one adapter), and a clear error when no
//! adapter exists.

use std::sync::{Arc, Mutex};

/// Why the GPU side failed.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    #[error("no GPU adapter found (backends tried: {backends}); on a machine without a GPU install Mesa's software Vulkan driver: apt-get install mesa-vulkan-drivers")]
    NoAdapter { backends: String },
    #[error("cannot open a device on adapter {adapter}: {source}")]
    RequestDevice {
        adapter: String,
        source: wgpu::RequestDeviceError,
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
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub info: wgpu::AdapterInfo,
    /// A name for messages, e.g. "A (llvmpipe, Vulkan)".
    pub name: String,
    /// The first uncaptured wgpu error, if any: wgpu reports validation
    /// errors through a callback; we turn them into [`GpuError::Device`]
    /// instead of the default panic.
    errors: Arc<Mutex<Option<String>>>,
}

impl GpuContext {
    /// Whether the adapter rasterizes on the CPU (lavapipe, llvmpipe, WARP).
    pub fn is_cpu(&self) -> bool {
        self.info.device_type == wgpu::DeviceType::Cpu
    }

    /// Whether RVG can draw [`crate::DrawStyle::Wireframe`] here.
    pub fn supports_wireframe(&self) -> bool {
        self.device
            .features()
            .contains(wgpu::Features::POLYGON_MODE_LINE)
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

fn instance(backends: wgpu::Backends) -> wgpu::Instance {
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
    desc.backends = backends;
    wgpu::Instance::new(desc)
}

/// An instance with adapters: WGPU_BACKEND=vulkan|gl|... picks backends as
/// in wgpu's examples; otherwise the primary backends (Vulkan, Metal, DX12),
/// and GL only when they have no adapter (probing GL prints noise on
/// headless machines).
pub(crate) fn instance_with_adapters() -> (wgpu::Instance, Vec<wgpu::Adapter>, wgpu::Backends) {
    let tries = match wgpu::Backends::from_env() {
        Some(b) => vec![b],
        None => vec![wgpu::Backends::PRIMARY, wgpu::Backends::SECONDARY],
    };
    let mut last = None;
    for backends in tries {
        let instance = instance(backends);
        let list = adapters(&instance);
        if !list.is_empty() {
            return (instance, list, backends);
        }
        last = Some((instance, backends));
    }
    let (instance, backends) = last.expect("at least one try");
    (instance, Vec::new(), backends)
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

/// Opens `count` (1 or 2) devices. With two, each gets its own hardware
/// adapter when the machine has two GPUs, else both share the best adapter.
/// Any other count is [`GpuError::DeviceCount`].
pub fn open_devices(count: usize) -> Result<Vec<GpuContext>, GpuError> {
    device_name(0, count)?;
    let (instance, list, backends) = instance_with_adapters();
    let best = list.first().ok_or_else(|| GpuError::NoAdapter {
        backends: format!("{backends:?}"),
    })?;
    let best_info = best.get_info();
    let hardware: Vec<&wgpu::Adapter> = list
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
            // A second device on the same adapter: wgpu allows one device
            // per Adapter object, so enumerate again for a fresh one.
            adapters(&instance)
                .into_iter()
                .find(|a| a.get_info() == best_info)
                .unwrap_or_else(|| best.clone())
        };
        out.push(open(&adapter, name)?);
    }
    Ok(out)
}

pub(crate) fn open(adapter: &wgpu::Adapter, name: &str) -> Result<GpuContext, GpuError> {
    let info = adapter.get_info();
    let label = format!("{name} ({}, {:?})", info.name, info.backend);
    let limits = wgpu::Limits {
        // Big scenes want big buffers; take what the adapter offers.
        max_buffer_size: adapter.limits().max_buffer_size,
        max_texture_dimension_2d: adapter.limits().max_texture_dimension_2d,
        ..wgpu::Limits::downlevel_defaults()
    };
    let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        label: Some(&label),
        // Line mode for the viewer's wireframe, where the adapter has it.
        required_features: adapter.features() & wgpu::Features::POLYGON_MODE_LINE,
        required_limits: limits,
        ..Default::default()
    }))
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
    })
}

/// For tests that need a GPU (feature `testing`): opens `count` devices, or
/// returns `None` after a loud message when no adapter exists, unless the
/// environment variable `GIGAWALK_REQUIRE_ADAPTER` is set (CI sets it), in
/// which case a missing adapter panics so the test fails.
#[cfg(feature = "testing")]
pub fn devices_or_skip(count: usize, test: &str) -> Option<Vec<GpuContext>> {
    match open_devices(count) {
        Ok(d) => Some(d),
        Err(GpuError::NoAdapter { .. })
            if std::env::var_os("GIGAWALK_REQUIRE_ADAPTER").is_none() =>
        {
            eprintln!("\n!!! SKIPPING {test}: no GPU adapter (install mesa-vulkan-drivers to run it) !!!\n");
            None
        }
        Err(e) => panic!("{test}: {e}"),
    }
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
