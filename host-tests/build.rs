// Sets the cfg `shared_meshes` when the third-party meshes are in
// `../shared/meshes` beside the repository: the tests that need them are
// `#[cfg_attr(not(shared_meshes), ignore = "needs ../shared/meshes")]`, so
// without the folder `cargo test` reports them as ignored rather than
// passing them unrun. With `COROFEM_REQUIRE_MESHES` set (as CI does), a
// missing folder fails the build instead.

use std::path::Path;

fn main() {
    println!("cargo::rustc-check-cfg=cfg(shared_meshes)");
    println!("cargo::rerun-if-env-changed=COROFEM_REQUIRE_MESHES");
    let manifest = std::env::var("CARGO_MANIFEST_DIR").unwrap_or_default();
    let dir = Path::new(&manifest).join("../../shared/meshes");
    // Watched so that the folder appearing or going rebuilds the tests.
    println!("cargo::rerun-if-changed={}", dir.display());
    if dir.is_dir() {
        println!("cargo::rustc-cfg=shared_meshes");
    } else if std::env::var_os("COROFEM_REQUIRE_MESHES").is_some() {
        panic!(
            "COROFEM_REQUIRE_MESHES is set but {} is missing",
            dir.display()
        );
    }
}
