//! The conversion of a read mesh to the core's input types, for host
//! programs and tests whose meshes are only known at run time (their scenes
//! go in the core's `VecScene`, feature `alloc`).

use crate::Mesh;

/// The mesh as the core takes it: f32 coordinates (m, after multiplying by
/// `scale`) and u32 indices. Indices that do not fit in u32 become
/// `u32::MAX`, which the core rejects as out of range.
pub fn to_core(mesh: &Mesh, scale: f64) -> (Vec<[f32; 3]>, Vec<[u32; 4]>) {
    let nodes = mesh
        .nodes
        .iter()
        .map(|p| {
            [
                (p[0] * scale) as f32,
                (p[1] * scale) as f32,
                (p[2] * scale) as f32,
            ]
        })
        .collect();
    let tets = mesh
        .tets
        .iter()
        .map(|t| t.map(|i| u32::try_from(i).unwrap_or(u32::MAX)))
        .collect();
    (nodes, tets)
}
