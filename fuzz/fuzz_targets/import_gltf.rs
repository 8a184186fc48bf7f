//! Fuzz target: arbitrary bytes as .glb or .gltf JSON must give a model or
//! an ImportError, never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = gigawalk_import::import_glb_bytes(data, "fuzz.glb");
});
