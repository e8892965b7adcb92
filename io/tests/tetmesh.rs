//! `.tetmesh` reading, writing and error reporting, plus `read_mesh` dispatch errors.

use crate::common;

use std::path::Path;

use common::{message, shared_meshes, shared_tetmesh, two_tets, TempDir};
use corofem_io::{format_tetmesh, parse_tetmesh, read_mesh, write_tetmesh, MeshError, MAX_COUNT};

const SMALL: &str = "tetmesh 1
5 2
0 0 0
1 0 0
0 1 0
0 0 1
1 1 1
0 1 2 3
1 2 3 4
";

#[test]
fn parses_inline_example() {
    let mesh = parse_tetmesh(SMALL, "small.tetmesh").unwrap();
    assert_eq!(mesh, two_tets());
}

#[test]
fn tolerates_crlf_blank_lines_and_spaces() {
    let text = "tetmesh 1\r\n\r\n 5   2 \r\n0 0 0\r\n1 0 0\r\n0 1 0\r\n0\t0 1\r\n1 1 1\r\n0 1 2 3\r\n1 2 3 4\r\n\r\n";
    assert_eq!(parse_tetmesh(text, "crlf.tetmesh").unwrap(), two_tets());
}

#[test]
fn format_then_parse_is_exact() {
    let mut mesh = two_tets();
    mesh.nodes[4] = [0.1 + 0.2, -1e-300, 12345.678901234567];
    let text = format_tetmesh(&mesh);
    assert!(text.starts_with("tetmesh 1\n5 2\n"));
    assert_eq!(parse_tetmesh(&text, "x.tetmesh").unwrap(), mesh);
}

#[test]
fn write_then_read_file() {
    let dir = TempDir::new("tetmesh-roundtrip");
    let path = dir.path().join("two.tetmesh");
    write_tetmesh(&path, &two_tets()).unwrap();
    assert_eq!(read_mesh(&path).unwrap(), two_tets());
}

#[test]
#[cfg_attr(not(shared_meshes), ignore = "needs ../shared/meshes")]
fn reads_shared_liver_and_bunny() {
    let liver = shared_tetmesh("sofa_liver.tetmesh");
    assert_eq!((liver.nodes.len(), liver.tets.len()), (181, 596));
    assert_eq!(liver.nodes[0], [-0.979259, 2.23512, 2.61245]);
    assert_eq!(liver.tets[0], [127, 140, 137, 141]);

    let bunny = shared_tetmesh("bunny_ftw_1k.tetmesh");
    assert_eq!((bunny.nodes.len(), bunny.tets.len()), (397, 1027));

    // Writing and reading back a real mesh gives it back exactly.
    let dir = TempDir::new("tetmesh-shared-roundtrip");
    let path = dir.path().join("liver.tetmesh");
    write_tetmesh(&path, &liver).unwrap();
    assert_eq!(read_mesh(&path).unwrap(), liver);
}

#[test]
#[cfg_attr(not(shared_meshes), ignore = "needs ../shared/meshes")]
fn every_shared_tetmesh_reads() {
    let dir = shared_meshes();
    let mut n = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "tetmesh") {
            let mesh = read_mesh(&path).unwrap_or_else(|e| panic!("{e}"));
            assert!(!mesh.tets.is_empty());
            n += 1;
        }
    }
    assert!(
        n >= 2,
        "expected several .tetmesh files in {}",
        dir.display()
    );
}

// ----- malformed input ------------------------------------------------------

fn err(text: &str) -> MeshError {
    parse_tetmesh(text, "bad.tetmesh").expect_err("should fail")
}

#[test]
fn error_bad_header() {
    let e = err("tetmesh 2\n1 1\n");
    let msg = message(&e, "bad.tetmesh", Some(1));
    assert!(matches!(e, MeshError::Malformed { .. }), "{e:?}");
    assert!(msg.contains("expected header \"tetmesh 1\""), "{msg}");

    let e = err("");
    assert!(matches!(e, MeshError::Truncated { line: 1, .. }), "{e:?}");
    message(&e, "bad.tetmesh", Some(1));
}

#[test]
fn error_wrong_number_of_coordinates() {
    let e = err("tetmesh 1\n4 1\n0 0 0\n1 0 0\n0 1\n0 0 1\n0 1 2 3\n");
    let msg = message(&e, "bad.tetmesh", Some(5));
    assert!(matches!(e, MeshError::Malformed { .. }), "{e:?}");
    assert!(msg.contains("expected 3 coordinates"), "{msg}");
    assert!(msg.ends_with("found 2 values"), "{msg}");
}

#[test]
fn error_wrong_number_of_indices() {
    let e = err("tetmesh 1\n4 1\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n0 1 2\n");
    let msg = message(&e, "bad.tetmesh", Some(7));
    assert!(msg.contains("expected 4 node indices"), "{msg}");
}

#[test]
fn error_bad_numbers() {
    let e = err("tetmesh 1\n4 1\n0 0 0\n1 zero 0\n0 1 0\n0 0 1\n0 1 2 3\n");
    let msg = message(&e, "bad.tetmesh", Some(4));
    assert!(matches!(e, MeshError::BadNumber { .. }), "{e:?}");
    assert!(msg.contains("y coordinate of node 1"), "{msg}");
    assert!(msg.contains("\"zero\""), "{msg}");

    // Non-finite coordinates are refused too.
    let e = err("tetmesh 1\n4 1\n0 0 0\n1 0 nan\n0 1 0\n0 0 1\n0 1 2 3\n");
    message(&e, "bad.tetmesh", Some(4));
    let e = err("tetmesh 1\n4 1\n0 0 0\n1 0 0\n0 1 inf\n0 0 1\n0 1 2 3\n");
    message(&e, "bad.tetmesh", Some(5));

    // Negative or fractional indices, bad counts.
    let e = err("tetmesh 1\n4 1\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n0 1 -2 3\n");
    assert!(matches!(e, MeshError::BadNumber { line: 7, .. }), "{e:?}");
    let e = err("tetmesh 1\n4 1\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n0 1 2.0 3\n");
    assert!(matches!(e, MeshError::BadNumber { line: 7, .. }), "{e:?}");
    let e = err("tetmesh 1\nfour 1\n");
    let msg = message(&e, "bad.tetmesh", Some(2));
    assert!(msg.contains("node count"), "{msg}");
}

#[test]
fn error_index_out_of_range() {
    let e = err("tetmesh 1\n4 2\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n0 1 2 3\n0 1 2 4\n");
    let msg = message(&e, "bad.tetmesh", Some(8));
    assert!(
        matches!(
            e,
            MeshError::IndexOutOfRange {
                index: 4,
                nodes: 4,
                ..
            }
        ),
        "{e:?}"
    );
    assert!(msg.contains("node index 4 out of range"), "{msg}");
}

#[test]
fn error_truncated() {
    // Header promises 2 tets, file has 1.
    let e = err("tetmesh 1\n4 2\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n0 1 2 3\n");
    let msg = message(&e, "bad.tetmesh", Some(8));
    assert!(matches!(e, MeshError::Truncated { .. }), "{e:?}");
    assert!(msg.contains("tetrahedron 2 of 2"), "{msg}");

    // Cut in the middle of the nodes.
    let e = err("tetmesh 1\n4 1\n0 0 0\n1 0 0\n");
    let msg = message(&e, "bad.tetmesh", Some(5));
    assert!(msg.contains("node 3 of 4"), "{msg}");
}

#[test]
fn error_wrong_counts() {
    // Header says 3 nodes but there are 4: the 4th node line is read as a tet line.
    let e = err("tetmesh 1\n3 1\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n0 1 2 3\n");
    let msg = message(&e, "bad.tetmesh", Some(6));
    assert!(
        msg.contains("expected 4 node indices (tetrahedron 1 of 1)"),
        "{msg}"
    );

    // More tet lines than declared.
    let e = err("tetmesh 1\n5 1\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n1 1 1\n0 1 2 3\n1 2 3 4\n");
    let msg = message(&e, "bad.tetmesh", Some(9));
    assert!(
        matches!(
            e,
            MeshError::CountMismatch {
                declared: 6,
                found: 7,
                ..
            }
        ),
        "{e:?}"
    );
    assert!(
        msg.contains("declares 6 node and tetrahedron lines but contains 7"),
        "{msg}"
    );
}

#[test]
fn error_no_tetrahedra() {
    let e = err("tetmesh 1\n1 0\n0 0 0\n");
    assert!(matches!(e, MeshError::NoTetrahedra { .. }), "{e:?}");
    message(&e, "bad.tetmesh", None);
}

#[test]
fn error_huge_count_refused_before_allocating() {
    let e = err("tetmesh 1\n99999999999999 1\n");
    let msg = message(&e, "bad.tetmesh", Some(2));
    assert!(
        matches!(
            e,
            MeshError::TooLarge {
                count: 99999999999999,
                ..
            }
        ),
        "{e:?}"
    );
    assert!(msg.contains(&MAX_COUNT.to_string()), "{msg}");
    let e = err(&format!("tetmesh 1\n4 {}\n", MAX_COUNT + 1));
    assert!(matches!(e, MeshError::TooLarge { .. }), "{e:?}");
}

#[test]
fn error_missing_file_and_unknown_extension() {
    let dir = TempDir::new("tetmesh-missing");
    let missing = dir.path().join("nope.tetmesh");
    let e = read_mesh(&missing).unwrap_err();
    let name = missing.display().to_string();
    let msg = message(&e, &name, None);
    assert!(matches!(e, MeshError::Io { .. }), "{e:?}");
    assert!(msg.contains("cannot read file"), "{msg}");
    assert!(std::error::Error::source(&e).is_some());

    let obj = dir.write("mesh.obj", "v 0 0 0\n");
    let e = read_mesh(&obj).unwrap_err();
    let msg = message(&e, &obj.display().to_string(), None);
    assert!(matches!(e, MeshError::UnknownExtension { .. }), "{e:?}");
    assert!(msg.contains("\".obj\""), "{msg}");

    let e = read_mesh(Path::new("no_extension")).unwrap_err();
    assert!(
        matches!(
            e,
            MeshError::UnknownExtension {
                extension: None,
                ..
            }
        ),
        "{e:?}"
    );
}

#[test]
fn error_file_name_is_the_path_given() {
    let dir = TempDir::new("tetmesh-name");
    let path = dir.write("liver.tetmesh", "tetmesh 1\n4 1\n0 0 0\n1 0 0\n0 1\n");
    let e = read_mesh(&path).unwrap_err();
    assert_eq!(
        e.to_string(),
        format!(
            "{}:5: expected 3 coordinates (node 3 of 4), found 2 values",
            path.display()
        )
    );
}

/// `parse_mesh` chooses the reader by the content, whatever the name says.
#[test]
fn parse_mesh_detects_the_format() {
    use corofem_io::{parse_mesh, MeshFormat};
    let mesh = common::two_tets();
    let tetmesh = corofem_io::format_tetmesh(&mesh);
    assert_eq!(
        MeshFormat::detect(tetmesh.as_bytes()),
        Some(MeshFormat::Tetmesh)
    );
    assert_eq!(parse_mesh(tetmesh.as_bytes(), "upload.bin").unwrap(), mesh);
    let msh = common::msh::to_msh2(&mesh);
    assert_eq!(MeshFormat::detect(msh.as_bytes()), Some(MeshFormat::Gmsh));
    assert_eq!(
        parse_mesh(msh.as_bytes(), "upload").unwrap().tets,
        mesh.tets
    );
    assert_eq!(
        MeshFormat::detect(b"\n# vtk DataFile Version 3.0\n"),
        Some(MeshFormat::VtkLegacy)
    );
    assert_eq!(
        MeshFormat::detect(b"<?xml version=\"1.0\"?>\n<VTKFile"),
        Some(MeshFormat::Vtu)
    );
    assert_eq!(MeshFormat::detect(b"$NOD\n1\n"), Some(MeshFormat::Gmsh));

    let e = parse_mesh(b"\n\nhello\n", "upload").unwrap_err();
    let msg = common::message(&e, "upload", Some(3));
    assert!(msg.contains("a mesh file"), "{msg}");
    assert!(msg.contains("found \"hello\""), "{msg}");
    let e = parse_mesh(b"  \n", "upload").unwrap_err();
    assert!(matches!(e, MeshError::Truncated { .. }), "{e:?}");
}
