//! Surface files (Wavefront OBJ, STL) a user loads next to the body, to draw
//! in place of the tetrahedra's boundary: read by `corofem-io` (the format
//! told by the name's extension), checked against the page's caps, placed
//! as the body's mesh was ([`Placement`]), and the binding's errors put in
//! the user's terms.

use corofem::Error;

use crate::demo::TriangleSurface;
use crate::mesh_file::{message, sig3, Placement};

/// Most vertices a surface file may have: the page moves and re-shades every
/// vertex each frame (about 0.025 µs each in the browser, see docs/web.md),
/// and keeps 100 bytes per vertex.
pub const MAX_VERTICES: usize = 200_000;
/// Most triangles (a closed surface has about twice as many as vertices).
pub const MAX_TRIANGLES: usize = 2 * MAX_VERTICES;

/// Reads the OBJ or STL file `bytes` called `name` (its extension tells the
/// format) and places its vertices as the body's mesh was placed. The
/// error is the reader's (`line N: what` where it knows the line) or names
/// the cap exceeded; the page puts the file name in front.
pub fn parse(bytes: &[u8], name: &str, placement: &Placement) -> Result<TriangleSurface, String> {
    let s = corofem_io::parse_surface(bytes, name).map_err(|e| message(&e))?;
    if s.vertices.len() > MAX_VERTICES {
        return Err(format!(
            "{} vertices: the page takes at most {MAX_VERTICES}",
            s.vertices.len()
        ));
    }
    if s.triangles.len() > MAX_TRIANGLES {
        return Err(format!(
            "{} triangles: the page takes at most {MAX_TRIANGLES}",
            s.triangles.len()
        ));
    }
    Ok(TriangleSurface {
        vertices: s
            .vertices
            .iter()
            .map(|p| placement.apply(p.map(f64::from)))
            .collect(),
        triangles: s.triangles,
    })
}

/// What went wrong binding a surface to the body, with vertices and
/// triangles counted from 1 in the file's order (for OBJ, vertices are the
/// `v` lines and polygons count as the triangles they are split into; for
/// STL, triangles are the facets and vertices the distinct corners).
/// `reach` (m, after any scaling) and `scale` (the body's scaling) give the
/// distance in the file's unit.
pub fn bind_error(e: &Error, reach: f32, scale: f64) -> String {
    match *e {
        Error::VertexTooFar { vertex } => {
            let reach_file = f64::from(reach) / scale;
            format!(
                "vertex {} lies farther than {} from every tetrahedron (the reach: half their mean \
                 edge length, in the file's unit): is the surface in the mesh's units and place?",
                u64::from(vertex) + 1,
                sig3(reach_file),
            )
        }
        Error::DegenerateTriangle { triangle } => format!(
            "triangle {} is degenerate: a repeated vertex or collinear corners",
            triangle + 1
        ),
        Error::NonFiniteVertex { vertex } => format!(
            "vertex {} has a NaN or infinite coordinate",
            u64::from(vertex) + 1
        ),
        Error::TriangleIndexOutOfRange { triangle, vertex } => format!(
            "triangle {} refers to vertex {}, which does not exist",
            triangle + 1,
            u64::from(vertex) + 1
        ),
        ref other => other.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::demo::{App, Body, Params};
    use crate::mesh_file;

    /// An octahedron of "radius" `r` around `c`, subdivided `levels` times
    /// and pushed onto the sphere, as OBJ text.
    fn sphere_obj(c: [f64; 3], r: f64, levels: u32) -> String {
        let mut v: Vec<[f64; 3]> = vec![
            [1.0, 0.0, 0.0],
            [-1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, -1.0, 0.0],
            [0.0, 0.0, 1.0],
            [0.0, 0.0, -1.0],
        ];
        let mut f: Vec<[usize; 3]> = vec![
            [0, 2, 4],
            [2, 1, 4],
            [1, 3, 4],
            [3, 0, 4],
            [2, 0, 5],
            [1, 2, 5],
            [3, 1, 5],
            [0, 3, 5],
        ];
        for _ in 0..levels {
            let mut mid = std::collections::HashMap::new();
            let mut half = |a: usize, b: usize, v: &mut Vec<[f64; 3]>| {
                *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                    let m: [f64; 3] = std::array::from_fn(|k| v[a][k] + v[b][k]);
                    let l = (m[0] * m[0] + m[1] * m[1] + m[2] * m[2]).sqrt();
                    v.push(m.map(|x| x / l));
                    v.len() - 1
                })
            };
            f = f
                .iter()
                .flat_map(|&[a, b, c]| {
                    let (ab, bc, ca) = (half(a, b, &mut v), half(b, c, &mut v), half(c, a, &mut v));
                    [[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]
                })
                .collect();
        }
        let mut s = String::from("# a sphere\no sphere\n");
        for p in &v {
            let q: [f64; 3] = std::array::from_fn(|k| c[k] + r * p[k]);
            s.push_str(&format!("v {} {} {}\n", q[0], q[1], q[2]));
        }
        for t in &f {
            s.push_str(&format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1));
        }
        s
    }

    #[test]
    fn an_obj_sphere_loads_and_binds_inside_the_blob() {
        let obj = sphere_obj([0.0; 3], 0.12, 3);
        let s = parse(obj.as_bytes(), "ball.obj", &Placement::IDENTITY).unwrap();
        assert_eq!((s.vertices.len(), s.triangles.len()), (258, 512));
        let mut app = App::body(Body::Blob, Params::DEFAULT).unwrap();
        let st = app.embed(&s).unwrap().stats();
        assert_eq!((st.inside, st.outside), (258, 0));
    }

    #[test]
    fn a_surface_follows_the_scaling_of_its_mesh() {
        // A box mesh in millimetres and a sphere in the same millimetres.
        let mut text = String::from("tetmesh 1\n8 6\n");
        for k in 0..8 {
            let p = [k & 1, (k >> 1) & 1, (k >> 2) & 1].map(|b| 300 * b);
            text.push_str(&format!("{} {} {}\n", p[0], p[1], p[2]));
        }
        for t in [
            [0, 1, 3, 7],
            [0, 1, 7, 5],
            [0, 2, 7, 3],
            [0, 2, 6, 7],
            [0, 4, 5, 7],
            [0, 4, 7, 6],
        ] {
            text.push_str(&format!("{} {} {} {}\n", t[0], t[1], t[2], t[3]));
        }
        let (mesh, placement, note) =
            mesh_file::prepare(&mesh_file::parse(text.as_bytes()).unwrap()).unwrap();
        assert!(note.starts_with("scaled ×0.00133"), "{note}");
        let mut app = App::new(&mesh, demo_support(), Params::DEFAULT, true).unwrap();
        let obj = sphere_obj([150.0; 3], 140.0, 2);
        let s = parse(obj.as_bytes(), "ball.obj", &placement).unwrap();
        let st = app.embed(&s).unwrap().stats();
        assert_eq!(st.outside, 0, "{st:?}");
        // The sphere sits in the middle of the placed box, 0.4 m across.
        let (lo, hi) = app.rest_bounds();
        let (slo, shi) = crate::demo::bounds(app.embedded().unwrap().positions());
        for k in 0..3 {
            assert!(((slo[k] + shi[k]) - (lo[k] + hi[k])).abs() < 1e-5);
            assert!(((shi[k] - slo[k]) - 0.4 * 140.0 / 150.0).abs() < 1e-3);
        }
        // Unscaled, it is far outside: refused, named in the file's unit.
        let s = parse(obj.as_bytes(), "ball.obj", &Placement::IDENTITY).unwrap();
        let e = app.embed(&s).unwrap_err();
        let m = bind_error(&e, app.embed_reach(), placement.scale());
        assert!(
            m.starts_with("vertex 1 lies farther than 189 from every tetrahedron (the reach"),
            "{m}"
        );
        assert_eq!(
            app.embedded().unwrap().positions().len(),
            66,
            "the old one stays"
        );
    }

    fn demo_support() -> crate::demo::Support {
        crate::demo::Support::Ground
    }

    #[test]
    fn bad_surface_files_are_named_errors() {
        let p = Placement::IDENTITY;
        let e = parse(b"v 0 0 0\nv 1 0 0\n", "a.obj", &p).unwrap_err();
        assert_eq!(e, "expected at least one triangle, found none");
        let e = parse(b"solid x\n", "a.ply", &p).unwrap_err();
        assert!(e.contains("(expected .obj or .stl)"), "{e}");
        let e = parse(b"v 0 0 0\nv 1 0 q\nv 0 1 0\nf 1 2 3\n", "a.obj", &p).unwrap_err();
        assert!(e.starts_with("OBJ: "), "{e}");
        let e = parse(b"solid x\nfacet normal 0 0 1\n", "a.stl", &p).unwrap_err();
        assert!(e.starts_with("STL: "), "{e}");

        let mut big = String::new();
        for i in 0..=MAX_VERTICES {
            big.push_str(&format!("v {i} 0 0\n"));
        }
        big.push_str("f 1 2 3\n");
        let e = parse(big.as_bytes(), "big.obj", &p).unwrap_err();
        assert_eq!(e, "200001 vertices: the page takes at most 200000");

        let mut app = App::body(Body::Cube, Params::DEFAULT).unwrap();
        let flat = parse(
            b"v 0.1 0.1 0.1\nv 0.2 0.1 0.1\nv 0.15 0.1 0.1\nv 0.1 0.2 0.1\nf 1 2 4\nf 1 2 3\n",
            "flat.obj",
            &p,
        )
        .unwrap();
        let e = app.embed(&flat).unwrap_err();
        assert_eq!(
            bind_error(&e, app.embed_reach(), 1.0),
            "triangle 2 is degenerate: a repeated vertex or collinear corners"
        );
        assert!(app.embedded().is_none());
    }
}
