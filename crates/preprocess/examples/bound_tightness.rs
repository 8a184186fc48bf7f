//! How tight a scene's stored LOD errors are: for every `stride`-th node,
//! per LOD, the largest distance brute-force sampling finds
//! ([`verify::check_error_bounds`]: random points both ways plus every
//! vertex) over the stored error. At most about 1 / (1 + spacing) when
//! the error is a measurement at `--bound-spacing`; lower is looser.
//! Prints n / p10 / median / p90 by level, leaves and inner nodes apart.
//!
//! `cargo run --release -p gigawalk-preprocess --example bound_tightness -- SCENE [STRIDE] [SAMPLES]`

use gigawalk_preprocess::verify::check_error_bounds;
use gigawalk_scene::SceneReader;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let path = args
        .next()
        .ok_or("usage: bound_tightness SCENE [STRIDE] [SAMPLES]")?;
    let stride: usize = args.next().map(|s| s.parse()).transpose()?.unwrap_or(15);
    let samples: usize = args.next().map(|s| s.parse()).transpose()?.unwrap_or(400);
    let reader = SceneReader::open(std::path::Path::new(&path))?;
    let sk = reader.skeleton();
    let errors: Vec<f32> = sk.lods().iter().map(|l| l.error).collect();
    // (inner?, level) -> ratios.
    let mut ratios: std::collections::BTreeMap<(bool, usize), Vec<f64>> = Default::default();
    for ni in (0..sk.nodes().len()).step_by(stride.max(1)) {
        let node = &sk.nodes()[ni];
        for (k, l) in node.lods().enumerate() {
            let (inner, level) = (!node.is_leaf(), k);
            if !inner && level == 0 {
                continue; // a leaf's own mesh: error 0
            }
            if errors[l] <= 0.0 {
                continue;
            }
            // Only this level's error counts; the others are unbounded.
            let mut only = vec![f32::INFINITY; errors.len()];
            only[l] = errors[l];
            let b = check_error_bounds(
                sk.nodes(),
                &only,
                &mut |i| reader.read_lod(i).expect("a stored LOD"),
                Some(&[ni as u32]),
                samples,
                ni as u64,
            )?;
            ratios
                .entry((inner, level.min(3)))
                .or_default()
                .push(b.worst_ratio);
        }
    }
    for v in ratios.values_mut() {
        v.sort_by(f64::total_cmp);
    }
    println!("level | leaves: n / p10 / median / p90 | inner: n / p10 / median / p90");
    for level in 0..=3 {
        let row = |inner: bool| match ratios.get(&(inner, level)) {
            Some(v) if !v.is_empty() => {
                let q = |f: f64| v[((v.len() - 1) as f64 * f).round() as usize];
                format!(
                    "{} / {:.2} / {:.3} / {:.2}",
                    v.len(),
                    q(0.1),
                    q(0.5),
                    q(0.9)
                )
            }
            _ => "-".into(),
        };
        let name = if level == 3 {
            "3+".to_string()
        } else {
            level.to_string()
        };
        println!("{name} | {} | {}", row(false), row(true));
    }
    let all: Vec<f64> = ratios.values().flatten().copied().collect();
    let mut all = all;
    all.sort_by(f64::total_cmp);
    if !all.is_empty() {
        println!("all: n {} median {:.3}", all.len(), all[all.len() / 2]);
    }
    Ok(())
}
