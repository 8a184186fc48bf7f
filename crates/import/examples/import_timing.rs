//! Import throughput for docs/results.md: imports a model several times
//! and prints the median time and triangles per second.
//!
//! `cargo run --release -p gigawalk-import --example import_timing -- model.glb [runs]`

use std::time::Instant;

fn main() {
    let mut args = std::env::args().skip(1);
    let Some(path) = args.next() else {
        eprintln!("usage: import_timing <model.glb|.gltf|.obj> [runs]");
        std::process::exit(2);
    };
    let runs: usize = args.next().and_then(|r| r.parse().ok()).unwrap_or(5);
    let mut times = Vec::new();
    let mut summary = String::new();
    let mut triangles = 0;
    for _ in 0..runs.max(1) {
        let t = Instant::now();
        match gigawalk_import::import(std::path::Path::new(&path)) {
            Ok(model) => {
                times.push(t.elapsed().as_secs_f64());
                triangles = model.stats.triangles;
                summary = model.stats.summary(model.objects.len());
            }
            Err(e) => {
                eprintln!("error: {e}");
                std::process::exit(1);
            }
        }
    }
    times.sort_by(f64::total_cmp);
    let median = times[times.len() / 2];
    println!(
        "{path}: {summary}; median {median:.3} s over {} runs (min {:.3} s): {:.1} M triangles/s",
        times.len(),
        times[0],
        triangles as f64 / median / 1e6
    );
}
