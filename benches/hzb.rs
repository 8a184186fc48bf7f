//! HZB build time from a GPU-style depth readback, per variant and size.
//!
//! Run: `cargo bench --bench hzb -- --noplot` (figures in docs/results.md, "The HZB: build and box test").

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use gigawalk_cull::{Hzb, Reduction};
use gigawalk_testkit::XorShift32;

/// A depth image with structure (near/far bands and noise) so no branch or
/// min is trivially predictable; the build cost does not depend on content.
fn depth_image(w: u32, h: u32) -> Vec<f32> {
    let mut rng = XorShift32::new(0x9E37_79B9);
    (0..w * h)
        .map(|i| {
            let noise = rng.next_u32();
            let (x, y) = (i % w, i / w);
            let band = if (x / 97 + y / 61) % 3 == 0 {
                0.0
            } else {
                0.05
            };
            band + (noise >> 8) as f32 / (1u32 << 24) as f32 * 0.01
        })
        .collect()
}

fn build(c: &mut Criterion) {
    let mut g = c.benchmark_group("hzb_build");
    for (w, h) in [(1920u32, 1080u32), (3840, 2160)] {
        let full = depth_image(w, h);
        let half = depth_image(w / 2, h / 2);
        g.throughput(Throughput::Elements(w as u64 * h as u64));
        let mut hzb = Hzb::new();
        let size = format!("{w}x{h}");
        g.bench_with_input(BenchmarkId::new("farthest", &size), &full, |b, d| {
            b.iter(|| hzb.rebuild(w, h, d, Reduction::Farthest).unwrap())
        });
        g.bench_with_input(BenchmarkId::new("nth_farthest_2", &size), &full, |b, d| {
            b.iter(|| hzb.rebuild(w, h, d, Reduction::NthFarthest(2)).unwrap())
        });
        // Section 5.3: occluders rendered at half the resolution.
        g.bench_with_input(
            BenchmarkId::new("farthest_from_half_res", &size),
            &half,
            |b, d| b.iter(|| hzb.rebuild(w / 2, h / 2, d, Reduction::Farthest).unwrap()),
        );
        // The same build on one thread, to show what rayon buys.
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        g.bench_with_input(
            BenchmarkId::new("farthest_1_thread", &size),
            &full,
            |b, d| b.iter(|| one.install(|| hzb.rebuild(w, h, d, Reduction::Farthest).unwrap())),
        );
    }
    g.finish();
}

criterion_group!(benches, build);
criterion_main!(benches);
