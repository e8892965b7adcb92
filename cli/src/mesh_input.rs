//! The scene's mesh: read from a file or generated, scaled, in the core's
//! `f32` / `u32` form.

use corofem::BoxMesh;

use crate::error::{CliError, CliResult};
use crate::scene_file::{MeshSource, MeshSpec};

/// A mesh ready for `Scene::build`.
#[derive(Debug, Clone, PartialEq)]
pub struct CoreMesh {
    /// Node positions, scaled (m).
    pub nodes: Vec<[f32; 3]>,
    /// Tetrahedra (node indices).
    pub tets: Vec<[u32; 4]>,
    /// Where it came from, for messages: the file as written in the scene or
    /// `box 10x2x2 cells`.
    pub name: String,
}

/// Reads or generates the mesh of `spec`. Nodes that no tetrahedron uses are
/// dropped from a file mesh (the tetrahedra are renumbered), with a note in
/// `notes`. `file` is the scene file, for messages.
pub fn load(spec: &MeshSpec, file: &str, notes: &mut Vec<String>) -> CliResult<CoreMesh> {
    let mesh = match &spec.source {
        MeshSource::File { path, given } => {
            let mut mesh = corofem_io::read_mesh(path)
                .map_err(|e| CliError(format!("{file}: [mesh] file = {given:?}: {e}")))?;
            // The test `corofem info` reports, in the file's numbering.
            if let Some(why) = corofem_io::unusable(&mesh, spec.scale) {
                return Err(CliError(format!(
                    "{file}: [mesh] file = {given:?}: {why} (corofem info {given} shows the mesh's figures)"
                )));
            }
            let dropped = corofem_io::drop_unused_nodes(&mut mesh);
            if dropped > 0 {
                notes.push(format!(
                    "{}: dropped {} that no tetrahedron uses; node indices in the scene refer to the {} remaining, renumbered in order",
                    path.display(),
                    plural(dropped, "node"),
                    plural(mesh.nodes.len(), "node")
                ));
            }
            (mesh, given.clone())
        }
        MeshSource::Box(b) => (generate_box(b), box_name(b)),
    };
    let (nodes, tets) = corofem_io::to_core(&mesh.0, spec.scale);
    Ok(CoreMesh {
        nodes,
        tets,
        name: mesh.1,
    })
}

/// `1 node`, `2 nodes`.
pub fn plural(n: usize, noun: &str) -> String {
    if n == 1 {
        format!("1 {noun}")
    } else {
        format!("{n} {noun}s")
    }
}

/// `box 10x2x2 cells, 6 tets per cell`.
fn box_name(b: &BoxMesh) -> String {
    let [x, y, z] = b.cells;
    format!("box {x}x{y}x{z} cells, {} tets per cell", b.tets_per_cell)
}

/// The generated box as an io mesh (counts validated by the scene file).
fn generate_box(b: &BoxMesh) -> corofem_io::Mesh {
    let mut nodes = vec![[0.0f32; 3]; b.node_count()];
    let mut tets = vec![[0u32; 4]; b.tet_count()];
    // The sizes were checked when the scene was read, and the buffers have
    // exactly the generator's counts, so this cannot fail.
    let (n, t) = b
        .generate(&mut nodes, &mut tets)
        .expect("box parameters validated with the scene file");
    corofem_io::Mesh {
        nodes: nodes[..n].iter().map(|p| p.map(f64::from)).collect(),
        tets: tets[..t].iter().map(|t| t.map(|i| i as usize)).collect(),
    }
}
