//! Time of the pixel-error bound metric (`bound_violations`) on one frame,
//! best, typical and worst case, at 1920x1080 with pixel error 8 (window
//! 9, the largest the knob sweep uses).
//!
//! Run: `cargo bench -p gigawalk-replay --bench bound -- --noplot`
//! (figures in docs/results.md, "What measuring accuracy costs").

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use gigawalk_gpu::DepthImage;
use gigawalk_replay::bound_violations;
use gigawalk_testkit::XorShift32;

const W: u32 = 1920;
const H: u32 = 1080;

/// A depth image of `boxes` screen rectangles at random depths over
/// background, the nearest winning (reversed-Z: larger is nearer), each
/// rectangle's edges moved by up to `shift` pixels and every
/// `drop_every`-th rectangle left out (0: none). The same seed gives the
/// same rectangles, so two calls differ only by the moves and drops.
fn scene(seed: u32, shift: u32, drop_every: usize, moves: u32) -> DepthImage {
    let (w, h) = (W as i64, H as i64);
    let mut depth = vec![0f32; (W * H) as usize];
    // Deterministic xorshift, so every run times the same images.
    let mut rng = XorShift32::new(seed);
    let mut jitter = XorShift32::new(moves.max(1));
    for b in 0..3000usize {
        let (x, y) = (rng.below(W) as i64, rng.below(H) as i64);
        let (bw, bh) = (4 + rng.below(160) as i64, 4 + rng.below(120) as i64);
        let d = 0.01 + rng.below(1000) as f32 * 1e-3;
        if drop_every > 0 && b % drop_every == 0 {
            continue;
        }
        let mut mv = || {
            if shift == 0 {
                0
            } else {
                jitter.below(2 * shift + 1) as i64 - shift as i64
            }
        };
        // Moved edges can cross on a small rectangle: then it is empty.
        let (x0, x1) = ((x + mv()).clamp(0, w), (x + bw + mv()).clamp(0, w));
        let (y0, y1) = ((y + mv()).clamp(0, h), (y + bh + mv()).clamp(0, h));
        let x1 = x1.max(x0);
        for v in y0..y1 {
            for e in &mut depth[(v * w + x0) as usize..(v * w + x1) as usize] {
                *e = e.max(d);
            }
        }
    }
    DepthImage {
        width: W,
        height: H,
        depth,
    }
}

fn bound(c: &mut Criterion) {
    let reference = scene(7, 0, 0, 0);
    // Typical of a coarse LOD: edges within a few pixels, one object in 50
    // gone.
    let typical = scene(7, 3, 50, 11);
    let everything_gone = DepthImage {
        depth: vec![0.0; (W * H) as usize],
        ..reference.clone()
    };
    let covered = reference.depth.iter().filter(|&&d| d > 0.0).count();
    let differing = reference
        .depth
        .iter()
        .zip(&typical.depth)
        .filter(|(a, b)| a != b)
        .count();
    eprintln!(
        "{W}x{H}: {:.0}% covered; typical case differs at {:.1}% of pixels, {} violate at 8 px",
        100.0 * covered as f64 / (W * H) as f64,
        100.0 * differing as f64 / (W * H) as f64,
        bound_violations(&reference, &typical, 8.0).unwrap()
    );
    let mut g = c.benchmark_group("bound_violations_1920x1080_8px");
    g.sample_size(10);
    g.throughput(Throughput::Elements(W as u64 * H as u64));
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    for (name, result) in [
        ("identical", &reference),
        ("typical", &typical),
        ("everything_gone", &everything_gone),
    ] {
        g.bench_with_input(BenchmarkId::new("pool", name), result, |b, x| {
            b.iter(|| bound_violations(&reference, x, 8.0).unwrap())
        });
        // One thread, as when the other core is busy.
        g.bench_with_input(BenchmarkId::new("1_thread", name), result, |b, x| {
            b.iter(|| one.install(|| bound_violations(&reference, x, 8.0).unwrap()))
        });
    }
    g.finish();
}

criterion_group!(benches, bound);
criterion_main!(benches);
