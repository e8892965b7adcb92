//! The in-memory tetrahedral mesh and operations on its connectivity.

/// A tetrahedral mesh: node coordinates and 4-node tetrahedra.
///
/// Coordinates are in whatever length unit the file uses (the readers do not
/// convert). Tetrahedra hold 0-based indices into `nodes`, in the node order of the
/// file; a tetrahedron `[a, b, c, d]` is positively oriented when
/// `det[b − a, c − a, d − a] > 0` (readers keep the file's order and never reorient;
/// see [`MeshStats::negative_tets`](crate::MeshStats::negative_tets)).
///
/// The readers guarantee that every index is `< nodes.len()` and that there is at
/// least one tetrahedron. Nodes used by no tetrahedron may be present (Gmsh files
/// often carry geometry nodes); remove them with [`drop_unused_nodes`].
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Mesh {
    /// Node positions `[x, y, z]` (file length unit).
    pub nodes: Vec<[f64; 3]>,
    /// Tetrahedra as 0-based node indices.
    pub tets: Vec<[usize; 4]>,
}

/// For each node, whether some tetrahedron uses it. Indices out of range are ignored.
pub(crate) fn used_nodes(mesh: &Mesh) -> Vec<bool> {
    let mut used = vec![false; mesh.nodes.len()];
    for tet in &mesh.tets {
        for &i in tet {
            if let Some(u) = used.get_mut(i) {
                *u = true;
            }
        }
    }
    used
}

/// Removes the nodes that no tetrahedron uses and renumbers the tetrahedra.
///
/// The remaining nodes keep their relative order, so a mesh without unused nodes
/// is left unchanged. Returns the number of nodes removed.
///
/// # Panics
/// If a tetrahedron refers to a node index `>= mesh.nodes.len()` (the readers never
/// produce such a mesh).
pub fn drop_unused_nodes(mesh: &mut Mesh) -> usize {
    let used = used_nodes(mesh);
    let before = mesh.nodes.len();
    if used.iter().all(|&u| u) {
        return 0;
    }
    let mut new_index = vec![usize::MAX; before];
    let mut next = 0;
    for (i, &u) in used.iter().enumerate() {
        if u {
            new_index[i] = next;
            mesh.nodes[next] = mesh.nodes[i];
            next += 1;
        }
    }
    mesh.nodes.truncate(next);
    for tet in &mut mesh.tets {
        for i in tet.iter_mut() {
            // Every in-range index is used, hence renumbered; out of range panics here.
            *i = new_index[*i];
        }
    }
    before - next
}
