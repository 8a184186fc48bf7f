//! How fast a scene's LODs read back: every LOD read (`read_lod`: the
//! blob from the file, its CRC, decoding) on one thread, twice (the first
//! pass warms the page cache; the second is timed). Prints the LODs,
//! triangles, blob bytes, decoded vertex bytes (positions and normals as
//! the runtime takes them, 16 bytes a vertex) and MB/s of each.
//!
//! `cargo run --release -p gigawalk-scene --example read_speed -- SCENE`

use std::time::Instant;

use gigawalk_scene::SceneReader;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let path = std::env::args().nth(1).ok_or("usage: read_speed SCENE")?;
    let r = SceneReader::open(std::path::Path::new(&path))?;
    let n = r.skeleton().lods().len() as u32;
    let mut secs = 0.0;
    for pass in 0..2 {
        let t = Instant::now();
        for l in 0..n {
            std::hint::black_box(r.read_lod(l)?);
        }
        if pass == 1 {
            secs = t.elapsed().as_secs_f64();
        }
    }
    let lods = r.skeleton().lods();
    let blob: u64 = lods.iter().map(|l| l.len).sum();
    let vertices: u64 = lods.iter().map(|l| l.vertices as u64).sum();
    let triangles: u64 = lods.iter().map(|l| l.triangles as u64).sum();
    let encoded = lods.iter().filter(|l| l.encoded).count();
    let mb = |b: u64| b as f64 / 1e6;
    println!(
        "{n} LODs ({encoded} encoded), {triangles} triangles, {vertices} vertices: \
         {:.1} MB of blobs, {:.1} MB decoded vertices, read in {secs:.3} s: \
         {:.0} MB/s of blobs, {:.0} MB/s of decoded vertices, {:.2} bytes a triangle",
        mb(blob),
        mb(16 * vertices),
        mb(blob) / secs,
        mb(16 * vertices) / secs,
        blob as f64 / triangles.max(1) as f64
    );
    Ok(())
}
