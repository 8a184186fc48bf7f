//! The real models beside the checkout (`../shared/models`), which tests
//! read in place and never copy into the repository.

use std::path::PathBuf;

/// The real IFC files (`../shared/models/ifc` beside the workspace), or
/// `None` after a `SKIP` line when they are missing; with
/// `GIGAWALK_REQUIRE_MODELS` set (as CI sets it) a missing folder fails
/// the test instead.
pub fn shared_ifc_models() -> Option<PathBuf> {
    let dir = PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../../shared/models/ifc"
    ));
    if dir.is_dir() {
        return Some(dir);
    }
    assert!(
        std::env::var_os("GIGAWALK_REQUIRE_MODELS").is_none(),
        "GIGAWALK_REQUIRE_MODELS is set but {} is missing",
        dir.display()
    );
    println!("SKIP: no models at {}", dir.display());
    None
}
