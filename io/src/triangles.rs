//! Triangle surfaces in memory: the boundary of a tetrahedral mesh, and
//! Loop subdivision to smooth one. No dependency beyond `std`: the web
//! demo's module uses them without the surface-file readers.

use std::collections::HashMap;

/// A triangle surface: vertices (in the file's unit) and triangles indexing
/// them, wound as in the file.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Surface {
    /// Vertex positions, in the order of the file (see the module docs).
    pub vertices: Vec<[f32; 3]>,
    /// Triangles as indices into `vertices`.
    pub triangles: Vec<[u32; 3]>,
}

/// The boundary of a tetrahedral mesh: the faces that belong to one
/// tetrahedron only, wound so that `(b − a) × (c − a)` points out of
/// positively oriented tetrahedra, in the order the tetrahedra list them.
/// Its vertices are the mesh's nodes (the indices are node indices).
///
/// For `det[b−a, c−a, d−a] > 0` the outward faces of `(a, b, c, d)` are
/// `(a, c, b)`, `(a, b, d)`, `(a, d, c)` and `(b, c, d)`: each is wound so
/// that its normal points away from the fourth node.
pub fn boundary_triangles(tets: &[[u32; 4]]) -> Vec<[u32; 3]> {
    let faces = |t: &[u32; 4]| {
        let [a, b, c, d] = *t;
        [[a, c, b], [a, b, d], [a, d, c], [b, c, d]]
    };
    let key = |f: [u32; 3]| {
        let mut k = f;
        k.sort_unstable();
        k
    };
    let mut count: HashMap<[u32; 3], u32> = HashMap::with_capacity(4 * tets.len());
    for t in tets {
        for f in faces(t) {
            *count.entry(key(f)).or_insert(0) += 1;
        }
    }
    tets.iter()
        .flat_map(faces)
        .filter(|&f| count.get(&key(f)) == Some(&1))
        .collect()
}

/// The boundary of a tetrahedral mesh as a surface of its own: the
/// [`boundary_triangles`] over the nodes on them only, numbered in the order
/// the triangles first use them. `None` when a tetrahedron refers to a node
/// that does not exist.
pub fn boundary_surface(nodes: &[[f32; 3]], tets: &[[u32; 4]]) -> Option<Surface> {
    let triangles = boundary_triangles(tets);
    let mut index = vec![u32::MAX; nodes.len()];
    let mut vertices = Vec::new();
    for &i in triangles.iter().flatten() {
        let slot = index.get_mut(i as usize)?;
        if *slot == u32::MAX {
            *slot = vertices.len() as u32;
            vertices.push(nodes[i as usize]);
        }
    }
    let triangles = triangles
        .iter()
        .map(|t| t.map(|i| index[i as usize]))
        .collect();
    Some(Surface {
        vertices,
        triangles,
    })
}

/// One step of Loop subdivision (Loop 1987): each triangle becomes four,
/// and the vertices move towards the smooth limit surface, which lies
/// inside the coarse surface where it is convex and outside where it is
/// concave. A smooth surface to show over a coarse mesh (its boundary,
/// say) and a test surface with vertices on both sides of it.
///
/// The vertices of `surface` keep their indices; each edge's new vertex
/// follows them, in the order the triangles first meet the edges. Edges of
/// one triangle only (an open surface's border) use the border rules
/// (midpoints; `¾ v + ⅛ (v₋ + v₊)`). `None` when a triangle refers to a
/// vertex that does not exist.
pub fn loop_subdivide(surface: &Surface) -> Option<Surface> {
    let n = surface.vertices.len();
    if surface.triangles.iter().flatten().any(|&i| i as usize >= n) {
        return None;
    }
    let key = |a: u32, b: u32| (a.min(b), a.max(b));
    // Each edge: its new vertex and the corners opposite it (one or two).
    let mut edges: HashMap<Edge, usize> = HashMap::new();
    let mut list: Vec<(Edge, [Option<u32>; 2])> = Vec::new();
    for t in &surface.triangles {
        for k in 0..3 {
            let (a, b, c) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
            let e = *edges.entry(key(a, b)).or_insert_with(|| {
                list.push((key(a, b), [None, None]));
                list.len() - 1
            });
            let opposite = &mut list[e].1;
            if opposite[0].is_none() {
                opposite[0] = Some(c);
            } else {
                opposite[1] = Some(c);
            }
        }
    }
    let at = |i: u32| surface.vertices[i as usize].map(f64::from);
    let mut vertices: Vec<[f64; 3]> = Vec::with_capacity(n + list.len());
    // Old vertices: the neighbour sum and count, and the border neighbours.
    let mut ring = vec![([0.0f64; 3], 0u32); n];
    let mut border: Vec<Vec<u32>> = vec![Vec::new(); n];
    for &((a, b), opp) in &list {
        for (v, w) in [(a, b), (b, a)] {
            let r = &mut ring[v as usize];
            r.0 = add(r.0, at(w));
            r.1 += 1;
            if opp[1].is_none() {
                border[v as usize].push(w);
            }
        }
    }
    for (i, &(sum, count)) in ring.iter().enumerate() {
        let v = at(i as u32);
        let moved = match (border[i].as_slice(), count) {
            (&[p, q], _) => add(scale(v, 0.75), scale(add(at(p), at(q)), 0.125)),
            ([], k) if k >= 3 => {
                let k = f64::from(k);
                let c = 0.375 + 0.25 * (2.0 * std::f64::consts::PI / k).cos();
                let beta = (0.625 - c * c) / k;
                add(scale(v, 1.0 - k * beta), scale(sum, beta))
            }
            // Corners of the border and vertices of fewer than three
            // neighbours stay.
            _ => v,
        };
        vertices.push(moved);
    }
    for &((a, b), opp) in &list {
        let mid = add(at(a), at(b));
        vertices.push(match opp {
            [Some(c), Some(d)] => add(scale(mid, 0.375), scale(add(at(c), at(d)), 0.125)),
            _ => scale(mid, 0.5),
        });
    }
    let mut triangles = Vec::with_capacity(4 * surface.triangles.len());
    for t in &surface.triangles {
        let m = |k: usize| (n + edges[&key(t[k], t[(k + 1) % 3])]) as u32;
        let (ab, bc, ca) = (m(0), m(1), m(2));
        triangles.push([t[0], ab, ca]);
        triangles.push([ab, t[1], bc]);
        triangles.push([ca, bc, t[2]]);
        triangles.push([ab, bc, ca]);
    }
    Some(Surface {
        vertices: vertices.iter().map(|p| p.map(|c| c as f32)).collect(),
        triangles,
    })
}

/// An edge by its two vertices, the smaller first.
type Edge = (u32, u32);

fn add(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

fn scale(a: [f64; 3], s: f64) -> [f64; 3] {
    a.map(|c| c * s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn subdividing_a_tetrahedron_twice() {
        let tets = [[0u32, 1, 2, 3]];
        let nodes = [
            [0.0f32, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
        ];
        assert_eq!(boundary_triangles(&tets).len(), 4);
        let mut s = boundary_surface(&nodes, &tets).unwrap();
        assert_eq!(s.vertices.len(), 4);
        assert_eq!(boundary_surface(&nodes[..3], &tets), None);
        for level in 1..=2u32 {
            s = loop_subdivide(&s).unwrap();
            // Euler: a closed genus-0 surface keeps V − E + F = 2.
            let f = 4 * 4usize.pow(level);
            assert_eq!(s.triangles.len(), f);
            assert_eq!(s.vertices.len(), 2 + f / 2);
        }
        let bad = Surface {
            vertices: nodes.to_vec(),
            triangles: vec![[0, 1, 4]],
        };
        assert_eq!(loop_subdivide(&bad), None);
        // Convex: every vertex moves inside the tetrahedron, off its faces.
        for p in &s.vertices {
            assert!(
                p.iter().all(|&c| c > 0.0) && p.iter().sum::<f32>() < 1.0,
                "{p:?}"
            );
        }
    }
}
