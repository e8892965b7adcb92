//! Mesh files a user drops on the page, read by `corofem-io` (built without
//! its default features: `tetmesh 1` and Gmsh `.msh` ASCII 1.0, 2.x and 4.1,
//! with nothing but `std`), the format told by the content. Errors say the
//! line; the page puts the file name in front. Then [`prepare`] makes the
//! mesh ready for the page: unused nodes dropped, sizes checked, scaled when
//! it is far from the page's scale; its [`Placement`] places a surface file
//! given for the same body (`surface_file`) the same way.

use corofem_io::{Mesh as FileMesh, MeshError};

/// Most tetrahedra the page takes: past this a frame takes seconds.
pub const MAX_TETS: usize = 200_000;
/// Most nodes the core addresses (`u16` indices).
pub const MAX_NODES: usize = 65_536;

/// Reads `bytes` as `tetmesh 1` or Gmsh `.msh` (by content, not by name).
/// The error is `line N: what` where the reader knows the line.
pub fn parse(bytes: &[u8]) -> Result<FileMesh, String> {
    corofem_io::parse_mesh(bytes, "").map_err(|e| message(&e))
}

/// The reader's message without the file name, which the page shows itself.
pub(crate) fn message(e: &MeshError) -> String {
    match e.line() {
        Some(line) => format!("line {line}: {}", e.detail()),
        None => e.detail().to_string(),
    }
}

/// Where a file's coordinates go on the page: `(p − centre) · scale`, in
/// f64, rounded to f32 once.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Placement {
    centre: [f64; 3],
    scale: f64,
}

impl Placement {
    /// Coordinates as they are (the built-in bodies).
    pub const IDENTITY: Placement = Placement {
        centre: [0.0; 3],
        scale: 1.0,
    };

    /// The factor the coordinates are multiplied by.
    pub fn scale(&self) -> f64 {
        self.scale
    }

    /// A point of the file, placed.
    pub fn apply(&self, p: [f64; 3]) -> [f32; 3] {
        [
            ((p[0] - self.centre[0]) * self.scale) as f32,
            ((p[1] - self.centre[1]) * self.scale) as f32,
            ((p[2] - self.centre[2]) * self.scale) as f32,
        ]
    }
}

/// A read mesh made ready for the solver: unused nodes dropped (Gmsh files
/// keep geometry points), counts checked, f32 coordinates. A body whose
/// largest extent is not between 5 cm and 2 m (a file in millimetres, say)
/// is scaled to 0.4 m; the returned note says so. The placement is what
/// was done to the coordinates, for a surface file of the same body.
pub fn prepare(m: &FileMesh) -> Result<(super::demo::Mesh, Placement, String), String> {
    if m.tets.is_empty() {
        return Err("the mesh has no tetrahedron".to_owned());
    }
    if m.tets.len() > MAX_TETS {
        return Err(format!(
            "{} tetrahedra: the page takes at most {MAX_TETS} (a frame would take seconds)",
            m.tets.len()
        ));
    }
    let mut new_index = vec![u32::MAX; m.nodes.len()];
    let mut nodes64 = Vec::new();
    for t in &m.tets {
        for &i in t {
            let slot = &mut new_index[i];
            if *slot == u32::MAX {
                *slot = nodes64.len() as u32;
                nodes64.push(m.nodes[i]);
            }
        }
    }
    if nodes64.len() > MAX_NODES {
        return Err(format!(
            "{} nodes: the solver addresses at most {MAX_NODES}",
            nodes64.len()
        ));
    }
    let dropped = m.nodes.len() - nodes64.len();
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in &nodes64 {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let extent = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
    // `!(x > 0)` also rejects NaN, which `x <= 0` would let through.
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    if !(extent > 0.0) {
        return Err("the mesh is flat: all nodes lie at one point".to_owned());
    }
    let scale = if (0.05..=2.0).contains(&extent) {
        1.0
    } else {
        0.4 / extent
    };
    let placement = Placement {
        centre: [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]), lo[2]],
        scale,
    };
    let nodes = nodes64.iter().map(|&p| placement.apply(p)).collect();
    let tets = m.tets.iter().map(|t| t.map(|i| new_index[i])).collect();
    let mut note = String::new();
    if scale != 1.0 {
        note.push_str(&format!("scaled ×{} to 0.4 m. ", sig3(scale)));
    }
    if dropped > 0 {
        note.push_str(&format!("{dropped} nodes in no tetrahedron dropped. "));
    }
    Ok((
        super::demo::Mesh { nodes, tets },
        placement,
        note.trim_end().to_owned(),
    ))
}

/// Positive `x` to 3 significant digits in plain decimal ("0.004", "25.4",
/// "1500"), without the float formatter (20 kB, which only the STL reader
/// brings into the module, for one of its errors).
pub(crate) fn sig3(x: f64) -> String {
    if !(x > 0.0 && x.is_finite()) {
        return "?".to_owned();
    }
    let mut e = x.log10().floor() as i32;
    let mut m = (x / 10f64.powi(e - 2)).round() as u64; // 100..=1000
    if m >= 1000 {
        m /= 10;
        e += 1;
    }
    if e >= 2 {
        return (m * 10u64.pow((e - 2) as u32)).to_string();
    }
    let digits = m.to_string(); // three digits
    let decimals = (2 - e) as usize;
    let s = if decimals >= 3 {
        format!("0.{}{digits}", "0".repeat(decimals - 3))
    } else {
        format!("{}.{}", &digits[..3 - decimals], &digits[3 - decimals..])
    };
    s.trim_end_matches('0').trim_end_matches('.').to_owned()
}

#[cfg(test)]
mod tests {
    use super::*;

    const TET: &str = "tetmesh 1\n4 1\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n0 1 2 3\n";

    #[test]
    fn tetmesh_reads_and_reports_errors_by_line() {
        let m = parse(TET.as_bytes()).unwrap();
        assert_eq!(m.nodes.len(), 4);
        assert_eq!(m.tets, vec![[0, 1, 2, 3]]);
        let bad = TET.replace("0 1 2 3", "0 1 2 4");
        assert_eq!(
            parse(bad.as_bytes()).unwrap_err(),
            "line 7: node index 4 out of range (the mesh has 4 nodes, valid indices are 0..4)"
        );
        let bad = TET.replace("1 0 0", "1 x 0");
        assert!(parse(bad.as_bytes())
            .unwrap_err()
            .starts_with("line 4: expected y coordinate of node 1"));
        let bad = format!("{TET}0 1 2 3\n");
        assert_eq!(
            parse(bad.as_bytes()).unwrap_err(),
            "line 8: file declares 5 node and tetrahedron lines but contains 6"
        );
        assert_eq!(
            parse(b"tetmesh 1\n4 1\n0 0 0\n").unwrap_err(),
            "line 4: unexpected end of file, expected node 2 of 4"
        );
        assert!(parse(b"hello")
            .unwrap_err()
            .starts_with("line 1: expected a mesh file"));
        assert!(parse(b"tetmesh 1\n99999999999 1\n")
            .unwrap_err()
            .contains("node count 99999999999 exceeds the limit"));
    }

    /// Two tetrahedra sharing a face, with a line, a triangle, an unused node
    /// and tags out of order.
    const V2: &str = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$PhysicalNames\n1\n3 1 \"body\"\n$EndPhysicalNames\n\
$Nodes\n6\n10 0 0 0\n20 1 0 0\n30 0 1 0\n40 0 0 1\n50 1 1 1\n99 5 5 5\n$EndNodes\n\
$Elements\n4\n1 1 2 0 1 10 20\n2 2 2 0 1 10 20 30\n3 4 2 1 1 10 20 30 40\n4 4 2 1 1 20 30 40 50\n$EndElements\n";

    #[test]
    fn msh2_reads_tets_only_and_maps_tags() {
        let m = parse(V2.as_bytes()).unwrap();
        assert_eq!(m.nodes.len(), 6);
        assert_eq!(m.tets, vec![[0, 1, 2, 3], [1, 2, 3, 4]]);
        let (mesh, _, note) = prepare(&m).unwrap();
        assert_eq!(mesh.nodes.len(), 5);
        assert_eq!(note, "1 nodes in no tetrahedron dropped.");
        let bad = V2.replace("20 30 40 50", "20 30 40 77");
        assert_eq!(
            parse(bad.as_bytes()).unwrap_err(),
            "line 22: element refers to node tag 77, which no $Nodes entry defines"
        );
        let bad = V2.replace("$EndNodes", "$EndNode");
        assert_eq!(
            parse(bad.as_bytes()).unwrap_err(),
            "line 16: expected \"$EndNodes\", found \"$EndNode\""
        );
        let bin = V2.replace("2.2 0 8", "2.2 1 8");
        assert!(parse(bin.as_bytes())
            .unwrap_err()
            .starts_with("line 2: unsupported: binary MSH 2.2"));
    }

    const V41: &str = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Entities\n0 0 0 1\n1 0 0 0 1 1 1 0 0\n$EndEntities\n\
$Nodes\n2 5 1 5\n0 1 0 1\n1\n0 0 0\n3 1 0 4\n2\n3\n4\n5\n1 0 0\n0 1 0\n0 0 1\n1 1 1\n$EndNodes\n\
$Elements\n2 3 1 3\n2 1 2 1\n1 1 2 3\n3 1 4 2\n2 1 2 3 4\n3 2 3 4 5\n$EndElements\n";

    #[test]
    fn msh41_reads_blocks() {
        let m = parse(V41.as_bytes()).unwrap();
        assert_eq!(m.nodes.len(), 5);
        assert_eq!(m.nodes[4], [1.0, 1.0, 1.0]);
        assert_eq!(m.tets, vec![[0, 1, 2, 3], [1, 2, 3, 4]]);
        let bad = V41.replace("3 1 4 2", "3 1 4 3");
        assert!(parse(bad.as_bytes())
            .unwrap_err()
            .contains("file declares 3 elements but contains 4"));
        let v40 = V41.replace("4.1 0 8", "4 0 8");
        assert!(parse(v40.as_bytes())
            .unwrap_err()
            .starts_with("line 2: unsupported: MSH version 4;"));
        // Binary MSH 4.1 needs corofem-io's `gmsh-binary` feature, which the
        // page leaves out.
        let bin = V41.replace("4.1 0 8", "4.1 1 8");
        assert!(parse(bin.as_bytes())
            .unwrap_err()
            .starts_with("line 2: unsupported: binary MSH 4.1; readable are MSH 4.1 ASCII"));
        // MSH 1.0, and VTK (not in this build).
        let v1 = "$NOD\n4\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n$ENDNOD\n\
                  $ELM\n1\n1 4 1 1 4 1 2 3 4\n$ENDELM\n";
        assert_eq!(parse(v1.as_bytes()).unwrap().tets, vec![[0, 1, 2, 3]]);
        assert!(parse(b"# vtk DataFile Version 3.0\n")
            .unwrap_err()
            .contains("VTK files (.vtk, .vtu) are not read by this build"));
    }

    #[test]
    fn three_significant_digits() {
        for (x, s) in [
            (0.004, "0.004"),
            (0.00123456, "0.00123"),
            (25.44, "25.4"),
            (1500.2, "1500"),
            (9.996, "10"),
            (0.5, "0.5"),
            (123.0, "123"),
        ] {
            assert_eq!(sig3(x), s, "{x}");
        }
    }

    #[test]
    fn prepare_scales_millimetres_and_rejects_flat() {
        let mut m = parse(TET.as_bytes()).unwrap();
        for p in &mut m.nodes {
            *p = p.map(|c| 100.0 * c);
        }
        let (mesh, placement, note) = prepare(&m).unwrap();
        assert!(note.starts_with("scaled ×0.004"), "{note}");
        assert!((mesh.nodes[1][0] - 0.2).abs() < 1e-6 && (mesh.nodes[1][1] + 0.2).abs() < 1e-6);
        assert_eq!(placement.scale(), 0.004);
        assert_eq!(placement.apply(m.nodes[1]), mesh.nodes[1]);
        for p in &mut m.nodes {
            *p = [1.0; 3];
        }
        assert!(prepare(&m).unwrap_err().contains("flat"));
    }
}
