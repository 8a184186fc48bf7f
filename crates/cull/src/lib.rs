//! gigawalk's culling core: everything the scene-traversal-and-culling stage
//! (STC, GigaWalk Section 5.1.2) computes, on the CPU.
//!
//! Main types: [`Camera`] (f64 pose, reversed-Z infinite-far projection,
//! camera-relative f32 matrices), [`CullView`] (one frame's camera and
//! viewport prepared for culling), [`Frustum`], [`Hzb`] (the hierarchical
//! Z-buffer), [`OcclusionTest`] with [`HzbOcclusion`] (the conservative
//! box-vs-HZB test), [`select_lod`] (LOD by pixel error) and
//! [`Traverser`] (Algorithm 5.2, emitting [`DrawItem`]s to a [`DrawSink`]).
//!
//! # Depth convention
//!
//! Reversed Z with an infinite far plane: NDC depth = near / view distance,
//! 1 at the near plane, tending to 0 at infinity; depth buffers clear to 0.
//! **The farthest value is the minimum**, so the HZB stores minima and a box
//! is occluded when its nearest (largest) depth is below the farthest
//! (smallest) stored depth over its footprint; ties are visible. The depth
//! image is the GPU readback as is: row-major f32, row 0 = top, pixel
//! `(x, y)` centred at NDC `((x + 0.5) / w * 2 - 1, 1 - (y + 0.5) / h * 2)`.
//! docs/culling.md has the details.
//!
//! # Precision
//!
//! Positions are f64. Every box is made camera-relative in f64 before any
//! f32 math, and rounded outward when it becomes f32; the box tests add
//! slack for their own rounding, so a box is culled only when the math is
//! sure. A scene 10^7 units from the origin culls like the same scene at
//! the origin.
//!
//! This crate knows nothing about GPUs and starts no threads of its own
//! (HZB building uses rayon's pool inside the call).

#![forbid(unsafe_code)]

mod camera;
mod ct;
mod culler;
mod frustum;
mod grid;
mod hzb;
pub mod lod;
mod mode;
mod nearest;
mod object_space;
mod occlusion;
pub mod pick;
mod raster;
#[cfg(test)]
mod test_rng;
pub mod tiles;
mod traverse;
mod view;
pub mod visibility;

pub use camera::{default_near, Camera, Viewport, NEAR_FRACTION_OF_SCENE};
pub use ct::{CtCuller, CtStats, PlaneCache, MAX_FRAME_OCCLUDERS};
pub use culler::{BoxTest, Culler, Verdict};
pub use frustum::{Containment, Frustum, PlaneMask, ALL_PLANES};
pub use gigawalk_scene::section::{
    classify as section_classify, BoxSide, HalfSpace, Section, SectionError, SectionSpec,
};
pub use grid::{
    GridCuller, GridStats, LodTriangles, OcclusionGrid, TriangleSource, DEFAULT_GRID_CELL,
};
pub use hzb::{auto_hzb_level, level_sizes, Hzb, HzbError, HzbLevel, Reduction, HZB_READ_TEXELS};
pub use lod::select_lod;
pub use mode::Mode;
pub use object_space::{occlusion, pair_fully_occludes, ConvexOccluder, Occlusion, TangentPlanes};
pub use occlusion::{HzbOcclusion, NoOcclusion, OcclusionTest, DEPTH_SLACK, MAX_SPLITS, SPLITS};
pub use pick::{pick, PickHit, PickStats, Ray};
pub use raster::{PixelRect, SoftDepth, DEPTH_REL_SLACK, DEPTH_SLOPE_PX, INNER_MARGIN_PX};
pub use traverse::{
    reselect_lods, select_occluders, step_pixel_error, traverse, CullReason, DrawItem, DrawSink,
    TraversalOptions, TraversalStats, Traverser, PIXEL_ERROR_STEPS,
};
pub use view::{BoxProjection, CullView, RelBox};
pub use visibility::{NodeShow, Piece, Visibility};
