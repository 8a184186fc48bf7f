//! Box tests per second (HZB occlusion and frustum, one core) and traversal
//! of a 100k-node hierarchy against a realistic HZB.
//!
//! Run: `cargo bench --bench cull -- --noplot` (figures in docs/results.md, "The HZB: build and box test").

use std::collections::VecDeque;
use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use gigawalk_cull::{
    Camera, CullView, Hzb, HzbOcclusion, NoOcclusion, OcclusionTest, Reduction, RelBox,
    TraversalOptions, Traverser, Viewport, ALL_PLANES,
};
use gigawalk_scene::{Aabb, Node, Provenance, Skeleton, NO_NODE};
use gigawalk_suite::raster::DepthImage;
use gigawalk_suite::scenes::bare_lod as lod;
use glam::DVec3;
use rand::rngs::SmallRng;
use rand::{RngExt, SeedableRng};

/// 224 x 224 = 50176 buildings on a 10-unit grid, 6 x 6 footprints, 5 to 40
/// units tall: a city where a street-level view is mostly occluded.
fn buildings() -> Vec<Aabb> {
    let mut rng = SmallRng::seed_from_u64(7);
    let mut out = Vec::new();
    for i in 0..224 {
        for j in 0..224 {
            let (x, z) = (i as f64 * 10.0, j as f64 * 10.0);
            let h = rng.random_range(5.0..40.0);
            out.push(Aabb::new(
                DVec3::new(x, 0.0, z),
                DVec3::new(x + 6.0, h, z + 6.0),
            ));
        }
    }
    out
}

/// A binary median-split hierarchy over the boxes, nodes in breadth-first
/// order (children contiguous, after their parent): 2n - 1 nodes. Leaves
/// get 3 LODs, inner nodes 2 HLODs, errors growing with the box size as a
/// simplifier's would.
fn hierarchy(mut boxes: Vec<Aabb>) -> Skeleton {
    let mut nodes = Vec::new();
    let mut lods = Vec::new();
    let n = boxes.len();
    let mut queue = VecDeque::from([(0usize, 0..n)]);
    nodes.push(Node {
        bounds: Aabb::EMPTY,
        parent: NO_NODE,
        first_child: 0,
        child_count: 0,
        first_lod: 0,
        lod_count: 0,
    });
    while let Some((idx, range)) = queue.pop_front() {
        let slice = &mut boxes[range.clone()];
        let bounds = slice.iter().fold(Aabb::EMPTY, |a, b| a.union(b));
        let size = bounds.diagonal() as f32;
        nodes[idx].bounds = bounds;
        nodes[idx].first_lod = lods.len() as u32;
        if slice.len() == 1 {
            nodes[idx].lod_count = 3;
            lods.extend([lod(0.0, 2000), lod(0.002 * size, 400), lod(0.02 * size, 40)]);
            continue;
        }
        let tris = 2000 * slice.len().min(64) as u32;
        nodes[idx].lod_count = 2;
        lods.extend([lod(0.01 * size, tris / 8), lod(0.05 * size, tris / 64)]);
        let axis = if bounds.extent().x >= bounds.extent().z {
            0
        } else {
            2
        };
        slice.sort_by(|a, b| a.center()[axis].total_cmp(&b.center()[axis]));
        let mid = range.start + slice.len() / 2;
        let first = nodes.len();
        nodes[idx].first_child = first as u32;
        nodes[idx].child_count = 2;
        for (k, r) in [range.start..mid, mid..range.end].into_iter().enumerate() {
            nodes.push(Node {
                bounds: Aabb::EMPTY,
                parent: idx as u32,
                first_child: 0,
                child_count: 0,
                first_lod: 0,
                lod_count: 0,
            });
            queue.push_back((first + k, r));
        }
    }
    let bounds = nodes[0].bounds;
    Skeleton::new(bounds.center(), bounds, nodes, lods, Provenance::default())
        .expect("a valid skeleton")
}

/// A street-level camera at the city's edge looking diagonally across it.
fn camera(viewport: Viewport) -> Camera {
    Camera::look_at(
        DVec3::new(-20.0, 1.7, -20.0),
        DVec3::new(1000.0, 10.0, 1200.0),
        60f64.to_radians(),
        viewport.aspect(),
        0.1,
    )
}

/// The depth of every leaf in the frustum: the occluder pass at full detail.
fn realistic_hzb(skeleton: &Skeleton, view: &CullView) -> Hzb {
    let (w, h) = (view.viewport.width, view.viewport.height);
    let mut img = DepthImage::new(w, h);
    let vp = view.camera.view_projection_rel_f64();
    for n in skeleton.nodes().iter().filter(|n| n.is_leaf()) {
        let (min, max) = view.rel_f64(&n.bounds);
        if view.frustum.test(min, max, ALL_PLANES).0 != gigawalk_cull::Containment::Outside {
            img.draw_box(&vp, view.camera.position, &n.bounds);
        }
    }
    Hzb::build(w, h, &img.depth, Reduction::Farthest).unwrap()
}

fn cull(c: &mut Criterion) {
    let viewport = Viewport::new(1920, 1080);
    let skeleton = hierarchy(buildings());
    let view = CullView::new(camera(viewport), viewport);
    let hzb = realistic_hzb(&skeleton, &view);
    let test = HzbOcclusion::new(&hzb);

    // Box tests on every node's box: real sizes, from whole-city to one
    // building, so every HZB level is exercised.
    let boxes: Vec<RelBox> = skeleton
        .nodes()
        .iter()
        .map(|n| view.rel_box(&n.bounds))
        .collect();
    let visible = boxes.iter().filter(|b| test.is_visible(&view, b)).count();
    eprintln!(
        "{} nodes; HZB test: {visible} of {} node boxes visible",
        skeleton.nodes().len(),
        boxes.len()
    );
    let mut g = c.benchmark_group("box_test");
    g.throughput(Throughput::Elements(boxes.len() as u64));
    g.bench_function("hzb_occlusion", |b| {
        b.iter(|| {
            boxes
                .iter()
                .filter(|bx| test.is_visible(&view, black_box(bx)))
                .count()
        })
    });
    let rel: Vec<(DVec3, DVec3)> = skeleton
        .nodes()
        .iter()
        .map(|n| view.rel_f64(&n.bounds))
        .collect();
    g.bench_function("frustum", |b| {
        b.iter(|| {
            rel.iter()
                .filter(|(lo, hi)| {
                    view.frustum.test(*lo, *hi, ALL_PLANES).0 != gigawalk_cull::Containment::Outside
                })
                .count()
        })
    });
    // The same boxes against a 64x64 HZB that fits in L1: the test's own
    // cost, without the cache misses of a 1080p pyramid.
    let small = Hzb::build(64, 64, &[0.001; 64 * 64], Reduction::Farthest).unwrap();
    let small_test = HzbOcclusion::new(&small);
    g.bench_function("hzb_occlusion_64x64_in_cache", |b| {
        b.iter(|| {
            boxes
                .iter()
                .filter(|bx| small_test.is_visible(&view, black_box(bx)))
                .count()
        })
    });
    g.finish();

    let mut g = c.benchmark_group("traversal_100k");
    let mut traverser = Traverser::new();
    for (name, options) in [
        ("occlusion_hlod_1px", TraversalOptions::default()),
        (
            "occlusion_full_detail",
            TraversalOptions {
                pixel_error: 0.0,
                ..Default::default()
            },
        ),
        (
            "frustum_only_full_detail",
            TraversalOptions {
                occlusion: false,
                hlod: false,
                pixel_error: 0.0,
            },
        ),
    ] {
        let stats = traverser.traverse(&skeleton, &view, &test, &options, &mut |_| {});
        eprintln!("{name}: {stats:?}");
        g.bench_function(name, |b| {
            b.iter(|| {
                let mut drawn = 0u32;
                if options.occlusion {
                    traverser.traverse(&skeleton, &view, &test, &options, &mut |_| drawn += 1)
                } else {
                    traverser.traverse(&skeleton, &view, &NoOcclusion, &options, &mut |_| {
                        drawn += 1
                    })
                }
            })
        });
    }
    g.finish();
}

criterion_group!(benches, cull);
criterion_main!(benches);
