//! Puts `memory.x` where the linker finds it, passes the linker scripts, and
//! turns `COROFEM_FW_CELLS=cx,cy,cz` (default `10,2,2`) into the scene size.

use std::{env, fs, path::PathBuf};

fn main() {
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    fs::copy("memory.x", out.join("memory.x")).expect("memory.x is readable");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed=memory.x");
    // cortex-m-rt's and defmt's linker scripts; --nmagic keeps sections
    // unaligned to pages (flash is small).
    println!("cargo:rustc-link-arg-bins=--nmagic");
    println!("cargo:rustc-link-arg-bins=-Tlink.x");
    println!("cargo:rustc-link-arg-bins=-Tdefmt.x");

    println!("cargo:rerun-if-env-changed=COROFEM_FW_CELLS");
    let spec = env::var("COROFEM_FW_CELLS").unwrap_or_else(|_| "10,2,2".to_string());
    let cells: Vec<u32> = spec
        .split([',', 'x'])
        .map(|s| {
            s.trim()
                .parse()
                .expect("COROFEM_FW_CELLS: three positive integers, like 10,2,2")
        })
        .collect();
    assert!(
        cells.len() == 3 && cells.iter().all(|&c| c > 0),
        "COROFEM_FW_CELLS: three positive integers, like 10,2,2 (got {spec:?})"
    );
    fs::write(
        out.join("cells.rs"),
        format!(
            "/// Cells of the beam along x, y, z (`COROFEM_FW_CELLS` at build time).\n\
             pub const CELLS: [u32; 3] = [{}, {}, {}];\n",
            cells[0], cells[1], cells[2]
        ),
    )
    .expect("OUT_DIR is writable");
}
