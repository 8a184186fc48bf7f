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

/// `model` preprocessed with `params` into `dir/NAME.gwk`, opened.
pub fn preprocess(
    dir: &std::path::Path,
    name: &str,
    model: &gigawalk_import::Model,
    params: gigawalk_preprocess::Params,
) -> gigawalk_scene::SceneReader {
    let file = dir.join(format!("{name}.gwk"));
    gigawalk_preprocess::preprocess(
        model,
        &params,
        &file,
        "test",
        &gigawalk_preprocess::NoProgress,
    )
    .unwrap();
    gigawalk_scene::SceneReader::open(&file).unwrap()
}
