//! Deterministic mutation test: corrupted files of every format must give either
//! a valid mesh or a `MeshError` naming the file, never a panic.
//!
//! The inputs are small meshes written in-test in each format (plus the shared
//! liver, when `../shared/meshes` is present), then truncated, with bytes replaced
//! by random or by "dangerous" characters (digits, `-`, `.`, `$`, newlines), or
//! with a stretch cut out.

// Reads VTK and binary MSH among them: needs the feature that reads them.
#![cfg(all(feature = "vtk", feature = "gmsh-binary"))]

use crate::common;

use std::panic::{catch_unwind, AssertUnwindSafe};

use common::msh::{to_msh2, to_msh41_ascii, to_msh41_binary};
use common::{shared_meshes, two_tets, TempDir};
use corofem_io::{
    format_tetmesh, parse_msh, parse_tetmesh, parse_vtk_legacy, parse_vtu, write_vtk_mesh, Mesh,
    MeshError,
};

/// xorshift64: a fixed, dependency-free pseudo-random sequence.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

fn mutate(rng: &mut Rng, data: &[u8]) -> Vec<u8> {
    let mut d = data.to_vec();
    match rng.below(4) {
        0 => d.truncate(rng.below(d.len())),
        1 => {
            for _ in 0..1 + rng.below(4) {
                let i = rng.below(d.len());
                d[i] = rng.next() as u8;
            }
        }
        2 => {
            for _ in 0..1 + rng.below(3) {
                let i = rng.below(d.len());
                d[i] = b"0123456789 \n-.e$"[rng.below(16)];
            }
        }
        _ => {
            let i = rng.below(d.len());
            let j = (i + rng.below(50)).min(d.len());
            d.drain(i..j);
        }
    }
    d
}

fn parse(format: &str, bytes: &[u8]) -> Result<Mesh, MeshError> {
    match format {
        "tetmesh" => match std::str::from_utf8(bytes) {
            Ok(text) => parse_tetmesh(text, "f"),
            Err(_) => Err(MeshError::Parse {
                file: "f".to_owned(),
                line: None,
                message: "not UTF-8".to_owned(),
            }),
        },
        "msh" => parse_msh(bytes, "f"),
        "vtk" => parse_vtk_legacy(bytes, "f"),
        "vtu" => parse_vtu(bytes, "f"),
        _ => unreachable!(),
    }
}

fn inputs(mesh: &Mesh) -> Vec<(&'static str, Vec<u8>)> {
    let dir = TempDir::new(&format!("robustness-{}", mesh.nodes.len()));
    let vtk = dir.path().join("m.vtk");
    let vtu = dir.path().join("m.vtu");
    write_vtk_mesh(&vtk, mesh).unwrap();
    write_vtk_mesh(&vtu, mesh).unwrap();
    vec![
        ("tetmesh", format_tetmesh(mesh).into_bytes()),
        ("msh", to_msh2(mesh).into_bytes()),
        ("msh", to_msh41_ascii(mesh).into_bytes()),
        ("msh", to_msh41_binary(mesh)),
        ("vtk", std::fs::read(vtk).unwrap()),
        ("vtu", std::fs::read(vtu).unwrap()),
    ]
}

fn run(mesh: &Mesh, rounds: usize, seed: u64) {
    let mut rng = Rng(seed);
    for (format, data) in inputs(mesh) {
        // The unmodified input reads.
        parse(format, &data).unwrap_or_else(|e| panic!("{format}: {e}"));
        for round in 0..rounds {
            let bytes = mutate(&mut rng, &data);
            let result = catch_unwind(AssertUnwindSafe(|| parse(format, &bytes)));
            let result = result.unwrap_or_else(|_| {
                panic!(
                    "{format} round {round}: reader panicked on {:?}",
                    String::from_utf8_lossy(&bytes)
                )
            });
            match result {
                Ok(m) => {
                    assert!(!m.tets.is_empty(), "{format}: mesh without tets");
                    let n = m.nodes.len();
                    assert!(
                        m.tets.iter().flatten().all(|&i| i < n),
                        "{format}: bad index"
                    );
                    assert!(
                        m.nodes.iter().flatten().all(|c| c.is_finite()),
                        "{format}: non-finite"
                    );
                }
                Err(e) => {
                    let msg = e.to_string();
                    assert!(
                        msg.starts_with("f:"),
                        "{format}: message without file: {msg}"
                    );
                    assert_eq!(e.file(), "f");
                }
            }
        }
    }
}

#[test]
fn corrupted_small_files_never_panic() {
    run(&two_tets(), 400, 0x9E37_79B9_7F4A_7C15);
}

#[test]
#[cfg_attr(not(shared_meshes), ignore = "needs ../shared/meshes")]
fn corrupted_liver_files_never_panic() {
    let dir = shared_meshes();
    let liver = corofem_io::read_mesh(&dir.join("sofa_liver.tetmesh")).unwrap();
    run(&liver, 150, 0x2545_F491_4F6C_DD1D);
}
