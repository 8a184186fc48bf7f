//! Reads IFC files and prints, per file, the parse speed, the read time
//! and what was read (products, triangles, unsupported kinds): the
//! figures in docs/ifc.md.
//!
//! `cargo run --release -p gigawalk-ifc --example ifc_read -- FILE.ifc...`

use std::time::Instant;

fn main() {
    let mut failed = false;
    for path in std::env::args().skip(1) {
        let bytes = match std::fs::read(&path) {
            Ok(b) => b,
            Err(e) => {
                eprintln!("{path}: {e}");
                failed = true;
                continue;
            }
        };
        let size = bytes.len() as f64;
        let t0 = Instant::now();
        let file = match gigawalk_ifc::IfcFile::parse(bytes, &path) {
            Ok(f) => f,
            Err(e) => {
                eprintln!("{e}");
                failed = true;
                continue;
            }
        };
        let parse = t0.elapsed().as_secs_f64();
        // Decoding every entity's arguments: the cost a reader pays when it
        // touches the whole file.
        let t1 = Instant::now();
        let mut ids: Vec<u32> = Vec::new();
        for (ty, _) in file.step().types() {
            ids.extend(file.step().ids_of_type(ty));
        }
        let decoded = ids
            .iter()
            .filter(|&&id| file.step().get(id).is_ok())
            .count();
        let decode = t1.elapsed().as_secs_f64();
        let t2 = Instant::now();
        let mut objects = 0usize;
        let stats = file.read(&mut |_| {
            objects += 1;
            true
        });
        let read = t2.elapsed().as_secs_f64();
        println!(
            "{path}: {:.1} MB, {} entities; index {:.1} ms ({:.0} MB/s), decode all {:.1} ms ({:.0} MB/s), geometry {:.1} ms",
            size / 1e6,
            decoded,
            parse * 1e3,
            size / 1e6 / parse,
            decode * 1e3,
            size / 1e6 / decode,
            read * 1e3,
        );
        match stats {
            Ok(s) => {
                println!(
                    "  {} products, {} objects, {} triangles, {} openings subtracted, {} degenerate dropped, {} warnings",
                    s.products, s.objects, s.triangles, s.openings_subtracted, s.degenerate_triangles_dropped, s.warnings.len()
                );
                if !s.unsupported.is_empty() {
                    println!("  unsupported: {}", s.unsupported_summary());
                }
                for w in s.warnings.iter().take(5) {
                    println!("  warning: {w}");
                }
            }
            Err(e) => {
                println!("  {e}");
                failed = true;
            }
        }
    }
    if failed {
        std::process::exit(1);
    }
}
