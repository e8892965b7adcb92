//! Helpers shared by the integration tests.
#![allow(dead_code)]

pub mod msh;

use std::path::{Path, PathBuf};

use corofem_io::{Mesh, MeshError};

/// A fresh, empty scratch directory under the system temp dir, unique per test
/// and process. Removed when dropped (best effort).
pub struct TempDir(PathBuf);

impl TempDir {
    pub fn new(test: &str) -> TempDir {
        let dir = std::env::temp_dir().join(format!("corofem-io-{}-{test}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("create temp dir");
        TempDir(dir)
    }

    pub fn path(&self) -> &Path {
        &self.0
    }

    /// Writes `contents` to `name` inside the directory and returns the path.
    pub fn write(&self, name: &str, contents: impl AsRef<[u8]>) -> PathBuf {
        let p = self.0.join(name);
        std::fs::write(&p, contents).expect("write test file");
        p
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// The shared test meshes (`../shared/meshes` beside the repository).
///
/// A test that needs them is marked
/// `#[cfg_attr(not(shared_meshes), ignore = "needs ../shared/meshes")]`: the
/// build script sets `shared_meshes` when the folder exists, so without it
/// `cargo test` lists those tests as ignored. Run anyway (`--ignored`), this
/// panics naming the folder.
pub fn shared_meshes() -> PathBuf {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/meshes");
    assert!(dir.is_dir(), "this test needs {}", dir.display());
    dir
}

/// Reads a shared mesh file ([`shared_meshes`]).
pub fn shared_tetmesh(name: &str) -> Mesh {
    corofem_io::read_mesh(&shared_meshes().join(name)).expect("shared mesh must read")
}

/// Asserts that two meshes have the same connectivity and coordinates equal
/// within `tol` (absolute).
pub fn assert_same_mesh(a: &Mesh, b: &Mesh, tol: f64) {
    assert_eq!(a.nodes.len(), b.nodes.len(), "node count");
    assert_eq!(a.tets, b.tets, "tetrahedra");
    for (i, (p, q)) in a.nodes.iter().zip(&b.nodes).enumerate() {
        for c in 0..3 {
            assert!(
                (p[c] - q[c]).abs() <= tol,
                "node {i} coordinate {c}: {} vs {}",
                p[c],
                q[c]
            );
        }
    }
}

/// The error's message, after checking it names `file` (and `line`, if given).
pub fn message(err: &MeshError, file: &str, line: Option<usize>) -> String {
    let msg = err.to_string();
    match line {
        Some(l) => assert!(
            msg.starts_with(&format!("{file}:{l}: ")),
            "message should start with \"{file}:{l}: \": {msg}"
        ),
        None => assert!(
            msg.starts_with(&format!("{file}: ")),
            "message should start with \"{file}\": {msg}"
        ),
    }
    assert_eq!(err.file(), file);
    if line.is_some() {
        assert_eq!(err.line(), line, "line of: {msg}");
    }
    msg
}

/// A unit tetrahedron plus one more, sharing a face: 5 nodes, 2 tets, positively
/// oriented.
pub fn two_tets() -> Mesh {
    Mesh {
        nodes: vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
            [1.0, 1.0, 1.0],
        ],
        tets: vec![[0, 1, 2, 3], [1, 2, 3, 4]],
    }
}
