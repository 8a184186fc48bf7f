//! STC: the culler's frame, then traversal (GigaWalk Algorithm 5.2),
//! each drawn item sent to RVG as it is found; when streaming, the
//! loader's prefetch requests (`streaming::Prefetch`).

use std::sync::Arc;
use web_time::Instant;

use gigawalk_cull::{
    BoxTest, CullReason, CullView, DrawItem, NoOcclusion, TraversalOptions, TraversalStats,
    Traverser,
};
use gigawalk_gpu::DepthLevel;
use gigawalk_scene::Skeleton;

use super::*;
use crate::cullers::CullerWork;
use crate::streaming::Prefetch;
use crate::ResolvedOptions;
use crate::{ms_since, RuntimeError, Stage};

/// STC: HZB from OR's depth, then traversal (Algorithm 5.2); or the lazy
/// occlusion grid over what it draws itself.
pub(crate) struct StcStage<'a> {
    pub skeleton: &'a Skeleton,
    pub opts: &'a ResolvedOptions,
    pub(super) traverser: Traverser,
    /// The occlusion culler's state (with occlusion on).
    pub(super) culler: Option<crate::cullers::State<'a>>,
    pub(super) prefetch: Option<Prefetch<'a>>,
}

/// One frame's culling result. Cheap to clone: the visible set is shared
/// by RVG, OR's occluders of a later frame, a held frame and the report.
#[derive(Clone)]
pub(crate) struct StcOutput {
    pub stats: TraversalStats,
    pub visible: Arc<[DrawItem]>,
    /// X-ray's ghosts (the view's hidden objects) as LOD indices,
    /// frustum-culled only: RVG draws them faint after the visible set,
    /// tested against its depth; never occluders.
    pub ghosts: Arc<[u32]>,
    pub culled: Arc<[(u32, CullReason)]>,
    pub occlusion_used: bool,
    pub hzb_ms: f64,
    /// Traversal (LOD selection and the culler's tests), and the tests
    /// alone (estimated from one test in sixteen).
    pub traversal_ms: f64,
    pub test_ms: f64,
    /// What the culler did beyond traversal (none for the HZB).
    pub culler_work: Option<CullerWork>,
    /// The tiles' draw lists (a tiled display only).
    pub tiles: Option<Arc<TileFrame>>,
    /// The pixel-error tolerance traversal used.
    pub pixel_error: f64,
    pub ms: f64,
}

impl<'a> StcStage<'a> {
    /// Without a culler; [`Target::stc_stage`] sets it up.
    pub(super) fn new(
        skeleton: &'a Skeleton,
        opts: &'a ResolvedOptions,
        prefetch: Option<Prefetch<'a>>,
    ) -> Self {
        StcStage {
            skeleton,
            opts,
            traverser: Traverser::new(),
            culler: None,
            prefetch,
        }
    }

    /// Traverses, handing every item to `emit` as it is found; `pixel_error`
    /// overrides the options' pixel error for this frame.
    pub fn run(
        &mut self,
        frame: u64,
        view: &CullView,
        pixel_error: Option<f64>,
        depth: Option<&DepthLevel>,
        emit: &mut dyn FnMut(DrawItem),
    ) -> Result<StcOutput, RuntimeError> {
        let _span = tracing::info_span!("STC", frame).entered();
        let t = Instant::now();
        if self.opts.stc_delay_ms > 0.0 {
            std::thread::sleep(std::time::Duration::from_secs_f64(
                self.opts.stc_delay_ms / 1e3,
            ));
        }
        self.opts.inject_failure.check(Stage::Stc, frame)?;
        // The culler, when occlusion is on, and whether it culls this
        // frame (the HZB needs OR's depth: none in the startup bypass).
        let (occlusion, hzb_ms) = match self.culler.as_mut() {
            Some(c) => c.prepare(frame, depth, self.opts)?,
            None => (false, 0.0),
        };
        let options = TraversalOptions {
            occlusion,
            ..self.opts.traversal_at(pixel_error)
        };
        let mut visible = Vec::new();
        let pixel_error = options.pixel_error;
        let band = self
            .prefetch
            .as_ref()
            .filter(|_| self.opts.prefetch.band() && options.hlod && pixel_error > 0.0);
        let skeleton = self.skeleton;
        let mut sink = |item: DrawItem| {
            visible.push(item);
            emit(item);
            if let Some(p) = band {
                p.item(skeleton, view, pixel_error, frame, item);
            }
        };
        let mut culled = Vec::new();
        let record = self.opts.record_culled;
        let mut on_cull = |node, why| {
            if record {
                culled.push((node, why));
            }
        };
        let mut traversal = crate::cullers::Traversal {
            traverser: &mut self.traverser,
            skeleton,
            view,
            options: &options,
            sink: &mut sink,
            on_cull: &mut on_cull,
            test_time: std::time::Duration::ZERO,
        };
        let traversed = Instant::now();
        let (stats, work) = match self.culler.as_mut().filter(|_| occlusion) {
            Some(c) => c.cull(&mut traversal, self.opts)?,
            None => (traversal.run(&mut BoxTest(&NoOcclusion)), None),
        };
        let test_ms = traversal.test_time.as_secs_f64() * 1e3;
        let traversal_ms = ms_since(traversed);
        if let Some(p) = self.prefetch.as_ref().filter(|_| self.opts.prefetch.ring()) {
            p.margin(&mut self.traverser, skeleton, view, &options, frame);
        }
        // Ghosts: what the view hides, by frustum and LOD alone (RVG's
        // depth test against the visible set hides what lies behind it).
        let mut ghosts = Vec::new();
        if let Some(ghost_view) = view.ghost_view() {
            let _s = tracing::info_span!("ghosts", frame).entered();
            let ghost_options = TraversalOptions {
                occlusion: false,
                ..options
            };
            self.traverser.traverse(
                skeleton,
                &ghost_view,
                &NoOcclusion,
                &ghost_options,
                &mut |item: DrawItem| ghosts.push(item),
            );
        }
        let ghosts = super::lod_ids(skeleton, &ghosts);
        let tiles = self.opts.tiles.map(|grid| {
            let _s = tracing::info_span!("tiles", frame).entered();
            Arc::new(TileFrame::new(
                skeleton,
                view,
                grid,
                self.opts.tile_culling,
                &visible,
            ))
        });
        Ok(StcOutput {
            tiles,
            pixel_error: options.pixel_error,
            stats,
            culled: culled.into(),
            visible: visible.into(),
            ghosts: ghosts.into(),
            occlusion_used: occlusion,
            hzb_ms,
            traversal_ms,
            test_ms,
            culler_work: work,
            ms: ms_since(t),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::RuntimeOptions;
    use gigawalk_cull::{Camera, Viewport};
    use gigawalk_scene::{Aabb, IndexFormat, LodInfo, Node, Skeleton, NO_NODE};
    use glam::DVec3;

    /// A root (no LODs) over one-LOD unit boxes every 2 degrees on a
    /// horizontal circle of radius 40 around the origin.
    fn ring() -> (Skeleton, Vec<f64>) {
        let angles: Vec<f64> = (0..180).map(|i| (i * 2) as f64).collect();
        let leaf = |a: f64| {
            let c = DVec3::new(a.to_radians().cos(), 0.0, a.to_radians().sin()) * 40.0;
            Aabb {
                min: c - 0.5,
                max: c + 0.5,
            }
        };
        let mut nodes = vec![Node {
            bounds: Aabb {
                min: DVec3::splat(-41.0),
                max: DVec3::splat(41.0),
            },
            parent: NO_NODE,
            first_child: 1,
            child_count: angles.len() as u32,
            first_lod: 0,
            lod_count: 0,
        }];
        let mut lods = Vec::new();
        for (i, &a) in angles.iter().enumerate() {
            nodes.push(Node {
                bounds: leaf(a),
                parent: 0,
                first_child: 0,
                child_count: 0,
                first_lod: i as u32,
                lod_count: 1,
            });
            lods.push(LodInfo {
                error: 0.0,
                triangles: 12,
                vertices: 8,
                origin: leaf(a).center(),
                index_format: IndexFormat::U16,
                uniform_colour: None,
                encoded: false,
                grid: None,
                compressed: false,
                offset: 0,
                len: 0,
                checksum: 0,
            });
        }
        let skeleton = Skeleton::new(
            DVec3::ZERO,
            nodes[0].bounds,
            nodes,
            lods,
            Default::default(),
        )
        .expect("a valid skeleton");
        (skeleton, angles)
    }

    #[test]
    fn prefetch_asks_for_the_ring_just_outside_the_frustum_and_nothing_else() {
        let (skeleton, angles) = ring();
        let plan = Plan::new(&skeleton, 1 << 30, crate::PINNED_MAX);
        let opts = RuntimeOptions {
            prefetch: crate::Prefetching::Ring,
            ..Default::default()
        }
        .resolve(false)
        .unwrap();
        let (tx, rx) = crossbeam_channel::unbounded();
        let prefetch = Prefetch {
            requests: tx,
            plan: &plan,
            mask: 1,
        };
        let mut stc = StcStage::new(&skeleton, &opts, Some(prefetch));
        // Looking along +x, 60 degrees both ways (aspect 1): the wide
        // frustum reaches atan(1.25 tan 30) = 35.8 degrees.
        let camera = Camera::look_at(DVec3::ZERO, DVec3::X, 60f64.to_radians(), 1.0, 0.1);
        let view = CullView::new(camera, Viewport::new(64, 64));
        let mut drawn = Vec::new();
        stc.run(0, &view, None, None, &mut |i| drawn.push(i.node))
            .unwrap();
        let asked: std::collections::BTreeSet<u32> = rx.try_iter().map(|r| r.lod).collect();
        // A unit box at radius 40 spans +-0.72 degrees around its angle.
        let off = |a: f64| a.min(360.0 - a);
        for (lod, &a) in angles.iter().enumerate() {
            let a = off(a);
            let lod = lod as u32;
            if (31.0..=35.0).contains(&a) {
                assert!(asked.contains(&lod), "leaf at {a} degrees not prefetched");
            }
            if !(29.0..=37.0).contains(&a) {
                assert!(!asked.contains(&lod), "leaf at {a} degrees prefetched");
            }
        }
        assert!(!asked.is_empty());
        // The frame itself drew what is inside, and nothing of the ring
        // outside the frustum.
        assert!(drawn.iter().all(|&n| off(angles[n as usize - 1]) < 31.0));
        // The prefetch traversal does not disturb the frame's own result.
        let mut again = Vec::new();
        let mut plain = StcStage::new(&skeleton, &opts, None);
        plain
            .run(0, &view, None, None, &mut |i| again.push(i.node))
            .unwrap();
        assert_eq!(drawn, again);
    }
}
