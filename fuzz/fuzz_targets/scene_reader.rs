//! Fuzz target: the scene file reader must never panic on any bytes.
#![no_main]

use gigawalk_scene::SceneReader;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(r) = SceneReader::from_source(data, "fuzz.gwk") {
        for lod in 0..r.skeleton().lods().len() as u32 {
            let _ = r.read_lod(lod);
        }
        let _ = r.verify();
    }
});
