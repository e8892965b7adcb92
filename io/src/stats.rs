//! Size and quality figures of a tetrahedral mesh.

use crate::mesh::{used_nodes, Mesh};

/// A tetrahedron counts as zero-volume when `|V| <= ZERO_VOLUME_RTOL * L³`, with `L`
/// its longest edge (a regular tetrahedron has `V ≈ 0.118 L³`).
pub const ZERO_VOLUME_RTOL: f64 = 1e-12;

/// Size and quality figures of a mesh, from [`mesh_stats`].
///
/// Lengths and volumes are in the mesh's own length unit (and its cube); angles are
/// in degrees. Volumes are signed: `V = det[b − a, c − a, d − a] / 6` for a
/// tetrahedron `[a, b, c, d]`, positive when it is positively oriented.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeshStats {
    /// Number of nodes.
    pub nodes: usize,
    /// Number of tetrahedra.
    pub tets: usize,
    /// Smallest `[x, y, z]` over all nodes (`+∞` for a mesh without nodes).
    pub bbox_min: [f64; 3],
    /// Largest `[x, y, z]` over all nodes (`−∞` for a mesh without nodes).
    pub bbox_max: [f64; 3],
    /// Sum of the signed tetrahedron volumes (length unit³).
    pub total_volume: f64,
    /// Smallest signed tetrahedron volume (length unit³; NaN without tetrahedra).
    pub min_tet_volume: f64,
    /// Largest signed tetrahedron volume (length unit³; NaN without tetrahedra).
    pub max_tet_volume: f64,
    /// Tetrahedra with negative volume (inverted), not counting zero-volume ones.
    pub negative_tets: usize,
    /// Tetrahedra whose volume is zero up to [`ZERO_VOLUME_RTOL`] (flat or with
    /// repeated nodes).
    pub zero_volume_tets: usize,
    /// Smallest interior dihedral angle over all tetrahedra, degrees (NaN without
    /// tetrahedra). Angles at faces of zero area are left out.
    pub min_dihedral_deg: f64,
    /// Largest interior dihedral angle over all tetrahedra, degrees (NaN without
    /// tetrahedra).
    pub max_dihedral_deg: f64,
    /// Nodes used by no tetrahedron (see [`drop_unused_nodes`](crate::drop_unused_nodes)).
    pub unused_nodes: usize,
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Signed volume of the tetrahedron `p` (positive if positively oriented).
pub fn tet_volume(p: &[[f64; 3]; 4]) -> f64 {
    dot(sub(p[1], p[0]), cross(sub(p[2], p[0]), sub(p[3], p[0]))) / 6.0
}

/// The six interior dihedral angles of the tetrahedron `p`, in degrees, at the
/// edges 01, 02, 03, 12, 13, 23. An angle next to a face of zero area is NaN.
pub fn dihedral_angles_deg(p: &[[f64; 3]; 4]) -> [f64; 6] {
    // Face k is the face opposite vertex k, with vertices ordered so that its
    // normal points outwards for a positively oriented tetrahedron (inwards for a
    // negative one: the formula below is the same either way).
    let faces = [(1, 2, 3), (0, 3, 2), (0, 1, 3), (0, 2, 1)];
    let normals = faces.map(|(a, b, c)| {
        let n = cross(sub(p[b], p[a]), sub(p[c], p[a]));
        let len = dot(n, n).sqrt();
        if len > 0.0 {
            [n[0] / len, n[1] / len, n[2] / len]
        } else {
            [f64::NAN; 3]
        }
    });
    // The edge ij is shared by the faces opposite the two other vertices k, l.
    let edges = [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)];
    edges.map(|(i, j)| {
        let mut others = (0..4).filter(|&v| v != i && v != j);
        let (k, l) = (others.next().unwrap_or(0), others.next().unwrap_or(0));
        (-dot(normals[k], normals[l]))
            .clamp(-1.0, 1.0)
            .acos()
            .to_degrees()
    })
}

/// Computes counts, bounding box, volumes, orientation and dihedral-angle range of
/// a mesh. Runs in `O(nodes + tets)`.
///
/// # Panics
/// If a tetrahedron refers to a node index `>= mesh.nodes.len()` (the readers never
/// produce such a mesh).
pub fn mesh_stats(mesh: &Mesh) -> MeshStats {
    let mut bbox_min = [f64::INFINITY; 3];
    let mut bbox_max = [f64::NEG_INFINITY; 3];
    for p in &mesh.nodes {
        for c in 0..3 {
            bbox_min[c] = bbox_min[c].min(p[c]);
            bbox_max[c] = bbox_max[c].max(p[c]);
        }
    }

    let mut s = MeshStats {
        nodes: mesh.nodes.len(),
        tets: mesh.tets.len(),
        bbox_min,
        bbox_max,
        total_volume: 0.0,
        min_tet_volume: f64::NAN,
        max_tet_volume: f64::NAN,
        negative_tets: 0,
        zero_volume_tets: 0,
        min_dihedral_deg: f64::NAN,
        max_dihedral_deg: f64::NAN,
        unused_nodes: used_nodes(mesh).iter().filter(|&&u| !u).count(),
    };
    for tet in &mesh.tets {
        let p = tet.map(|i| mesh.nodes[i]);
        let v = tet_volume(&p);
        s.total_volume += v;
        // f64::min/max ignore the NaN start value.
        s.min_tet_volume = s.min_tet_volume.min(v);
        s.max_tet_volume = s.max_tet_volume.max(v);

        let longest = longest_edge(&p);
        if v.abs() <= ZERO_VOLUME_RTOL * longest.powi(3) {
            s.zero_volume_tets += 1;
        } else if v < 0.0 {
            s.negative_tets += 1;
        }

        for a in dihedral_angles_deg(&p) {
            s.min_dihedral_deg = s.min_dihedral_deg.min(a);
            s.max_dihedral_deg = s.max_dihedral_deg.max(a);
        }
    }
    s
}

/// Why the solver, which computes in f32, cannot use a mesh, from
/// [`unusable`]. `corofem info` and `corofem run` apply the same test.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Unusable {
    /// A node's coordinate, multiplied by the scale, is beyond f32's range
    /// (its magnitude exceeds `f32::MAX`, about 3.4e38) or not finite.
    Coordinate {
        /// The node, 0-based in the file's order.
        node: usize,
        /// 0, 1, 2 for x, y, z.
        axis: usize,
        /// The coordinate as read (before scaling).
        value: f64,
    },
    /// A tetrahedron is flat: `|V| <= ZERO_VOLUME_RTOL * L³` (with `L` its
    /// longest edge), which f32 cannot solve with.
    Flat {
        /// The tetrahedron, 0-based in the file's order.
        tet: usize,
        /// Its signed volume (file units cubed).
        volume: f64,
        /// Its longest edge (file units).
        longest_edge: f64,
    },
}

impl core::fmt::Display for Unusable {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match *self {
            Unusable::Coordinate { node, axis, value } => write!(
                f,
                "node {node} has {} = {value:e}, beyond f32's range (at most 3.4e38 in \
                 magnitude after [mesh] scale; the solver computes in f32)",
                ["x", "y", "z"][axis]
            ),
            Unusable::Flat {
                tet,
                volume,
                longest_edge,
            } => write!(
                f,
                "tetrahedron {tet} is flat: its volume {volume:.3e} is {:.1e} of its longest \
                 edge ({longest_edge:.3e}) cubed, and the solver needs more than \
                 {ZERO_VOLUME_RTOL:e} (a regular tetrahedron has 0.118)",
                volume.abs() / longest_edge.powi(3)
            ),
        }
    }
}

/// The first reason the solver cannot use `mesh` with its coordinates
/// multiplied by `scale`: a coordinate beyond f32's range, then a flat
/// tetrahedron (the same test as [`MeshStats::zero_volume_tets`]). `None`
/// when neither applies.
pub fn unusable(mesh: &Mesh, scale: f64) -> Option<Unusable> {
    for (node, p) in mesh.nodes.iter().enumerate() {
        for (axis, &value) in p.iter().enumerate() {
            if !((value * scale) as f32).is_finite() {
                return Some(Unusable::Coordinate { node, axis, value });
            }
        }
    }
    for (tet, t) in mesh.tets.iter().enumerate() {
        let p = t.map(|i| mesh.nodes.get(i).copied().unwrap_or([0.0; 3]));
        let volume = tet_volume(&p);
        let longest_edge = longest_edge(&p);
        if volume.abs() <= ZERO_VOLUME_RTOL * longest_edge.powi(3) {
            return Some(Unusable::Flat {
                tet,
                volume,
                longest_edge,
            });
        }
    }
    None
}

/// The longest of the six edges of `p`.
fn longest_edge(p: &[[f64; 3]; 4]) -> f64 {
    [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)]
        .iter()
        .map(|&(i, j)| {
            let e = sub(p[i], p[j]);
            dot(e, e)
        })
        .fold(0.0, f64::max)
        .sqrt()
}
