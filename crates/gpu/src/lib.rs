//! gigawalk's GPU side, the only crate that names wgpu.
//!
//! Main types: [`GpuContext`] (one device; [`open_devices`] opens the two
//! the pipeline uses, on adapters that have what [`AdapterReport`] checks), [`HostGeometry`] / [`ResidentGeometry`] (the scene's
//! geometry in a few large buffers per device, behind the [`Residency`]
//! trait), [`DepthPass`] (OR: occluder depth, reduced to the HZB's
//! pyramid on the device and a level of it read back) and
//! [`VisiblePass`] (RVG: colour + depth of the visible set, drawn in
//! chunks). Every draw is camera-relative: a pass gets the camera position
//! in f64 and each LOD's origin minus it, rounded once to f32.
//!
//! Conventions: reversed-Z with an infinite far plane (depth 1 at the near
//! plane, 0 at infinity; clear to 0, keep the greater); images read back
//! row-major with row 0 at the top.

#![forbid(unsafe_code)]

mod capabilities;
mod context;
mod overlay;
mod passes;
mod present;
mod queries;
mod residency;
pub mod shader_types;

pub use capabilities::{
    list_adapters, AdapterReport, Capabilities, Optional, HOW_TO_GET_ONE, REQUIRED_DOWNLEVEL,
    REQUIRED_FORMATS,
};
pub use context::{
    chosen_adapter, is_null_adapter, open_devices, open_devices_on, GpuContext, GpuError,
    GL_DEPTH_ERROR, NULL_ADAPTER_NAMES,
};
#[cfg(feature = "testing")]
pub use context::{devices_or_skip, skip_test};
pub use overlay::{
    OverlayBox, OverlayFrame, OverlayLine, OverlayText, OverlayUniforms, OVERLAY_WGSL,
};
pub use passes::{
    Antialias, ClipPlanes, DepthImage, DepthLevel, DepthPass, DrawStyle, FrameImage, Look,
    LookChoice, PassFigures, PendingFrame, PendingLevel, PyramidPath, View, VisiblePass,
    COLOUR_FORMAT, DEPTH_COPY_WGSL, DEPTH_FORMAT, HZB_DOWNSAMPLE_WGSL, LOOK_WGSL,
};
#[cfg(target_arch = "wasm32")]
pub use present::open_device_for_canvas;
pub use present::{open_devices_for_window, Presented, WindowError, WindowSurface, BLIT_WGSL};
pub use queries::{query_counts, QueryBox, QueryCounts, QueryPass, QUERY_BOX_WGSL};
pub use residency::{
    device_bytes, DecodedLod, GeometryPool, HostGeometry, LodRange, Residency, ResidentGeometry,
    INDEX_BYTES, VERTEX_BYTES,
};
pub use shader_types::VertexLayout;
