//! What a scene's LODs take on a device, and how fast the loader turns
//! them into that: every LOD read and decoded into its device layout
//! (`DecodedLod::read`, as the streaming loader and the resident load do:
//! an encoded LOD of a 16-bit grid and 8-bit normals stays on its grid),
//! and again into the wide layout (`read_lod`, dequantized, 20-byte
//! vertices: the layout before the compact one), each on one thread, the
//! second of two passes timed. Prints device bytes per triangle, LODs in
//! each layout, and decode MB/s of device bytes.
//!
//! `cargo run --release -p gigawalk-gpu --example device_bytes -- SCENE`

use std::time::Instant;

use gigawalk_gpu::{DecodedLod, VertexLayout};
use gigawalk_scene::SceneReader;

/// One way of reading a LOD into a device layout.
type Read<'a> = dyn Fn(u32) -> Result<DecodedLod, gigawalk_scene::ReadError> + 'a;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let path = std::env::args().nth(1).ok_or("usage: device_bytes SCENE")?;
    let r = SceneReader::open(std::path::Path::new(&path))?;
    let n = r.skeleton().lods().len() as u32;
    let triangles: u64 = r.skeleton().lods().iter().map(|l| l.triangles as u64).sum();
    let blobs: u64 = r.skeleton().lods().iter().map(|l| l.len).sum();
    let wide_lod = |l: u32| r.read_lod(l).map(|m| DecodedLod::new(&m));
    let own_lod = |l: u32| DecodedLod::read(&r, l);
    let runs: [(&str, &Read); 2] = [("device layout", &own_lod), ("wide layout", &wide_lod)];
    println!(
        "{path}: {n} LODs, {triangles} triangles, {:.1} MB of blobs ({:.2} bytes a triangle)",
        blobs as f64 / 1e6,
        blobs as f64 / triangles.max(1) as f64
    );
    for (what, read) in runs {
        let mut secs = 0.0;
        let (mut bytes, mut vertex_bytes, mut counts) = (0u64, 0u64, [0usize; 2]);
        for pass in 0..2 {
            let t = Instant::now();
            let (mut b, mut v, mut c) = (0u64, 0u64, [0usize; 2]);
            for l in 0..n {
                let d = read(l)?;
                b += d.bytes();
                v += d.vertices.len() as u64;
                c[d.layout as usize] += 1;
                std::hint::black_box(&d);
            }
            if pass == 1 {
                secs = t.elapsed().as_secs_f64();
                (bytes, vertex_bytes, counts) = (b, v, c);
            }
        }
        println!(
            "{what}: {:.2} device bytes a triangle ({:.1} MB, vertices {:.1} MB), \
             LODs wide {} / compact {}, decoded in {secs:.3} s: {:.0} MB/s of device bytes, \
             {:.0} MB/s of blobs",
            bytes as f64 / triangles.max(1) as f64,
            bytes as f64 / 1e6,
            vertex_bytes as f64 / 1e6,
            counts[VertexLayout::Wide as usize],
            counts[VertexLayout::Compact as usize],
            bytes as f64 / 1e6 / secs,
            blobs as f64 / 1e6 / secs,
        );
    }
    Ok(())
}
