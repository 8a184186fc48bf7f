//! What the replay crate's GPU tests share.

// Each test file uses what it needs of these.
#![allow(dead_code)]

use gigawalk_runtime::{CameraList, CameraRequest, Runtime, RuntimeOptions};

/// Renders `cameras` (read back) with `opts`; the depth bits and colour
/// of each frame.
pub fn render(
    rt: &Runtime,
    opts: &RuntimeOptions,
    cameras: Vec<CameraRequest>,
) -> Vec<(Vec<u32>, Vec<u8>)> {
    let mut out = Vec::new();
    let mut source = CameraList { cameras };
    rt.run(opts, &mut source, &mut |r| {
        if let Some(img) = r.image {
            out.push((
                img.depth.depth.iter().map(|d| d.to_bits()).collect(),
                img.colour,
            ));
        }
        true
    })
    .unwrap();
    out
}
