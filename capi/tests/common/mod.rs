//! What the C API's test files share.

use std::path::PathBuf;

/// The path of a shared mesh (`../shared/meshes/NAME`), or `None` with a
/// `SKIPPED` line on stderr when the folder does not have it; with
/// `COROFEM_REQUIRE_MESHES` set, a missing mesh fails the test instead.
pub fn shared_mesh(name: &str) -> Option<PathBuf> {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/meshes")
        .join(name);
    if p.is_file() {
        Some(p)
    } else if std::env::var_os("COROFEM_REQUIRE_MESHES").is_some() {
        panic!(
            "COROFEM_REQUIRE_MESHES is set but {} is missing",
            p.display()
        );
    } else {
        eprintln!("SKIPPED: ../shared/meshes/{name} not found");
        None
    }
}
