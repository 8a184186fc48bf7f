//! Fuzz target: arbitrary text as OBJ must give a model or an ImportError,
//! never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let _ = gigawalk_import::import_obj_str(&text, "fuzz.obj");
});
