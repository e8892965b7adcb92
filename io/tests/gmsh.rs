//! Gmsh `.msh` reading: MSH 1.0, 2.2 ASCII, 4.1 ASCII and binary.
//!
//! The shared `.tetmesh` files are converted to each version here, by hand-written
//! writers (a Gmsh writer is not part of the crate), and read back. The written
//! files carry what real Gmsh output has: sparse node tags, extra geometry nodes,
//! and point/line/triangle elements that must be skipped.

// Reads binary MSH 4.1 among them: needs the feature that reads them.
#![cfg(feature = "gmsh-binary")]

use crate::common;

use common::msh::{to_msh2, to_msh41_ascii, to_msh41_binary};
use common::{assert_same_mesh, message, shared_meshes, shared_tetmesh, two_tets, TempDir};
use corofem_io::{drop_unused_nodes, parse_msh, read_mesh, Mesh, MeshError};

/// Reads back a converted mesh: same tets, the extra node unused, coordinates
/// exact; after dropping unused nodes, identical to the original.
fn check_with_extra_node(read: Mesh, original: &Mesh) {
    let mut read = read;
    assert_eq!(read.nodes.len(), original.nodes.len() + 1);
    assert_eq!(read.tets.len(), original.tets.len());
    assert_eq!(drop_unused_nodes(&mut read), 1);
    assert_same_mesh(&read, original, 0.0);
}

// ----- inline examples ------------------------------------------------------

const MSH2_SMALL: &str = "$MeshFormat
2.2 0 8
$EndMeshFormat
$Nodes
5
10 0 0 0
20 1 0 0
30 0 1 0
40 0 0 1
50 1 1 1
$EndNodes
$Elements
3
1 2 2 0 1 10 20 30
2 4 2 0 1 10 20 30 40
3 4 2 0 1 20 30 40 50
$EndElements
";

#[test]
fn msh2_inline_example() {
    let mesh = parse_msh(MSH2_SMALL.as_bytes(), "small.msh").unwrap();
    assert_eq!(mesh, two_tets());
}

#[test]
fn msh41_inline_example() {
    let text = "$MeshFormat
4.1 0 8
$EndMeshFormat
$Nodes
1 5 1 5
3 1 0 5
1
2
3
4
5
0 0 0
1 0 0
0 1 0
0 0 1
1 1 1
$EndNodes
$Elements
1 2 1 2
3 1 4 2
1 1 2 3 4
2 2 3 4 5
$EndElements
";
    assert_eq!(parse_msh(text.as_bytes(), "small.msh").unwrap(), two_tets());
}

/// Dense tags (1..=5) that are not in increasing order, split over two blocks:
/// mshio alone would number them by position; the reader must use the tags.
#[test]
fn msh41_dense_tags_out_of_order() {
    let text = "$MeshFormat
4.1 0 8
$EndMeshFormat
$Nodes
2 5 1 5
3 1 0 2
5
3
1 1 1
0 1 0
3 1 0 3
4
1
2
0 0 1
0 0 0
1 0 0
$EndNodes
$Elements
1 2 1 2
3 1 4 2
1 1 2 3 4
2 2 3 4 5
$EndElements
";
    let mesh = parse_msh(text.as_bytes(), "dense.msh").unwrap();
    // Nodes in file order: tags 5, 3, 4, 1, 2.
    assert_eq!(
        mesh.nodes,
        vec![
            [1.0, 1.0, 1.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0]
        ]
    );
    assert_eq!(mesh.tets, vec![[3, 4, 1, 2], [4, 1, 2, 0]]);

    // The same in binary.
    let mut b = Vec::new();
    let size = |b: &mut Vec<u8>, v: u64| b.extend_from_slice(&v.to_le_bytes());
    let int = |b: &mut Vec<u8>, v: i32| b.extend_from_slice(&v.to_le_bytes());
    b.extend_from_slice(b"$MeshFormat\n4.1 1 8\n");
    int(&mut b, 1);
    b.extend_from_slice(b"\n$EndMeshFormat\n$Nodes\n");
    for v in [2, 5, 1, 5] {
        size(&mut b, v);
    }
    for (tags, coords) in [
        (vec![5, 3], vec![[1.0, 1.0, 1.0], [0.0, 1.0, 0.0]]),
        (
            vec![4, 1, 2],
            vec![[0.0, 0.0, 1.0], [0.0, 0.0, 0.0], [1.0, 0.0, 0.0]],
        ),
    ] {
        for v in [3, 1, 0] {
            int(&mut b, v);
        }
        size(&mut b, tags.len() as u64);
        for t in tags {
            size(&mut b, t);
        }
        for c in coords.iter().flatten() {
            b.extend_from_slice(&f64::to_le_bytes(*c));
        }
    }
    b.extend_from_slice(b"\n$EndNodes\n$Elements\n");
    for v in [1, 2, 1, 2] {
        size(&mut b, v);
    }
    for v in [3, 1, 4] {
        int(&mut b, v);
    }
    size(&mut b, 2);
    for v in [1, 1, 2, 3, 4, 2, 2, 3, 4, 5] {
        size(&mut b, v);
    }
    b.extend_from_slice(b"\n$EndElements\n");
    assert_eq!(parse_msh(&b, "dense.msh").unwrap(), mesh);
}

#[test]
fn msh1_inline_example() {
    let text = "$NOD
5
1 0 0 0
2 1 0 0
3 0 1 0
4 0 0 1
5 1 1 1
$ENDNOD
$ELM
3
1 2 1 1 3 1 2 3
2 4 1 1 4 1 2 3 4
3 4 1 1 4 2 3 4 5
$ENDELM
";
    assert_eq!(parse_msh(text.as_bytes(), "small.msh").unwrap(), two_tets());
}

#[test]
fn small_mesh_in_every_version_via_files() {
    let dir = TempDir::new("gmsh-small");
    let mesh = two_tets();
    for (name, bytes) in [
        ("v2.msh", to_msh2(&mesh).into_bytes()),
        ("v41.msh", to_msh41_ascii(&mesh).into_bytes()),
        ("v41b.msh", to_msh41_binary(&mesh)),
    ] {
        let path = dir.write(name, bytes);
        let read = read_mesh(&path).unwrap_or_else(|e| panic!("{e}"));
        if name == "v41b.msh" {
            assert_same_mesh(&read, &mesh, 0.0);
        } else {
            check_with_extra_node(read, &mesh);
        }
    }
}

// ----- shared meshes --------------------------------------------------------

#[test]
#[cfg_attr(not(shared_meshes), ignore = "needs ../shared/meshes")]
fn sofa_liver_msh1_matches_tetmesh() {
    let dir = shared_meshes();
    let msh = read_mesh(&dir.join("sofa_liver.msh")).unwrap();
    let tetmesh = read_mesh(&dir.join("sofa_liver.tetmesh")).unwrap();
    assert_same_mesh(&msh, &tetmesh, 0.0);
}

#[test]
#[cfg_attr(not(shared_meshes), ignore = "needs ../shared/meshes")]
fn shared_meshes_through_msh2_and_msh41() {
    for name in ["sofa_liver.tetmesh", "bunny_ftw_1k.tetmesh"] {
        let mesh = shared_tetmesh(name);
        let dir = TempDir::new(&format!("gmsh-shared-{name}"));
        let v2 = dir.write("m2.msh", to_msh2(&mesh));
        check_with_extra_node(read_mesh(&v2).unwrap(), &mesh);
        let v41 = dir.write("m41.msh", to_msh41_ascii(&mesh));
        check_with_extra_node(read_mesh(&v41).unwrap(), &mesh);
        let v41b = dir.write("m41b.msh", to_msh41_binary(&mesh));
        assert_same_mesh(&read_mesh(&v41b).unwrap(), &mesh, 0.0);
    }
}

#[test]
fn unsupported_data_size_is_refused_without_panic() {
    // A header mshio cannot handle must not panic: data size 16 is refused up front.
    let text = "$MeshFormat\n4.1 1 16\n\x01\x00\x00\x00\n$EndMeshFormat\n";
    let e = parse_msh(text.as_bytes(), "odd.msh").unwrap_err();
    assert!(
        matches!(e, MeshError::Unsupported { line: Some(2), .. }),
        "{e:?}"
    );
}

// ----- malformed input ------------------------------------------------------

fn err(text: &str) -> MeshError {
    parse_msh(text.as_bytes(), "bad.msh").expect_err("should fail")
}

#[test]
fn error_unknown_or_unsupported_header() {
    let e = err("hello\n");
    let msg = message(&e, "bad.msh", Some(1));
    assert!(msg.contains("$MeshFormat"), "{msg}");

    let e = err("$MeshFormat\n2.2 1 8\n");
    let msg = message(&e, "bad.msh", Some(2));
    assert!(matches!(e, MeshError::Unsupported { .. }), "{e:?}");
    assert!(msg.contains("binary MSH 2.2"), "{msg}");

    let e = err("$MeshFormat\n4 0 8\n$EndMeshFormat\n");
    let msg = message(&e, "bad.msh", Some(2));
    assert!(msg.contains("MSH version 4"), "{msg}");

    let e = err("$MeshFormat\n");
    assert!(matches!(e, MeshError::Truncated { .. }), "{e:?}");
}

#[test]
fn error_msh2_truncated() {
    let cut = &MSH2_SMALL[..MSH2_SMALL.find("40 0 0 1").unwrap()];
    let e = err(cut);
    let msg = message(&e, "bad.msh", Some(9));
    assert!(matches!(e, MeshError::Truncated { .. }), "{e:?}");
    assert!(msg.contains("node 4 of 5"), "{msg}");

    let cut = MSH2_SMALL.replace("$EndElements\n", "");
    let e = err(&cut);
    assert!(matches!(e, MeshError::Truncated { line: 17, .. }), "{e:?}");
}

#[test]
fn error_msh2_wrong_counts() {
    let e = err(&MSH2_SMALL.replace("$Nodes\n5\n", "$Nodes\n6\n"));
    let msg = message(&e, "bad.msh", Some(11));
    assert!(
        matches!(
            e,
            MeshError::CountMismatch {
                declared: 6,
                found: 5,
                ..
            }
        ),
        "{e:?}"
    );
    assert!(msg.contains("declares 6 nodes but contains 5"), "{msg}");

    let e = err(&MSH2_SMALL.replace("$Elements\n3\n", "$Elements\n2\n"));
    let msg = message(&e, "bad.msh", Some(16));
    assert!(msg.contains("declares 2 elements but contains 3"), "{msg}");
}

#[test]
fn error_msh2_bad_numbers_and_tags() {
    let e = err(&MSH2_SMALL.replace("30 0 1 0", "30 0 1.2.3 0"));
    let msg = message(&e, "bad.msh", Some(8));
    assert!(matches!(e, MeshError::BadNumber { .. }), "{e:?}");
    assert!(msg.contains("y coordinate of node tag 30"), "{msg}");

    let e = err(&MSH2_SMALL.replace("2 4 2 0 1 10 20 30 40", "2 4 2 0 1 10 20 30 41"));
    let msg = message(&e, "bad.msh", Some(15));
    assert!(
        matches!(e, MeshError::UnknownNodeTag { tag: 41, .. }),
        "{e:?}"
    );
    assert!(msg.contains("node tag 41"), "{msg}");

    let e = err(&MSH2_SMALL.replace("2 4 2 0 1 10 20 30 40", "2 4 2 0 1 10 20 30"));
    message(&e, "bad.msh", Some(15));

    let e = err(&MSH2_SMALL.replace("50 1 1 1", "40 1 1 1"));
    let msg = message(&e, "bad.msh", Some(10));
    assert!(msg.contains("tag 40 again"), "{msg}");
}

#[test]
fn error_msh2_huge_count() {
    let e = err("$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n123456789012\n");
    let msg = message(&e, "bad.msh", Some(5));
    assert!(matches!(e, MeshError::TooLarge { .. }), "{e:?}");
    assert!(msg.contains("node count 123456789012 exceeds"), "{msg}");
}

#[test]
fn error_msh_without_tets() {
    let text = MSH2_SMALL
        .replace("2 4 2 0 1 10 20 30 40\n", "")
        .replace("3 4 2 0 1 20 30 40 50\n", "")
        .replace("$Elements\n3\n", "$Elements\n1\n");
    let e = err(&text);
    assert!(
        matches!(e, MeshError::NoTetrahedra { skipped: 1, .. }),
        "{e:?}"
    );
    let msg = message(&e, "bad.msh", None);
    assert!(msg.contains("(1 element of other types skipped)"), "{msg}");
    assert!(!msg.contains("first-order"), "{msg}");
}

/// The advice for second-order meshes, as every reader gives it.
const FIRST_ORDER: &str = "second- or higher-order tetrahedra: corofem uses 4-node \
    tetrahedra; mesh with first-order elements (Gmsh: `-order 1` or `Mesh.ElementOrder = 1`)";

#[test]
fn error_second_order_msh_says_to_mesh_first_order() {
    // Two 10-node tetrahedra (type 11) and a triangle, in MSH 2 ...
    let nodes: String = (1..=10).map(|i| format!("{i} {i} 0 {}\n", i % 3)).collect();
    let msh2 = format!(
        "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n10\n{nodes}$EndNodes\n$Elements\n3\n\
         1 2 2 0 1 1 2 3\n\
         2 11 2 0 1 1 2 3 4 5 6 7 8 9 10\n\
         3 11 2 0 1 1 2 3 4 5 6 7 8 9 10\n$EndElements\n"
    );
    let e = err(&msh2);
    assert!(
        matches!(
            e,
            MeshError::NoTetrahedra {
                skipped: 3,
                higher_order: 2,
                ..
            }
        ),
        "{e:?}"
    );
    let msg = message(&e, "bad.msh", None);
    assert!(
        msg.ends_with(&format!(
            "(3 elements of other types skipped). 2 of them are {FIRST_ORDER}"
        )),
        "{msg}"
    );
    // ... in MSH 4.1 ASCII ...
    let msh41 = format!(
        "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 10 1 10\n3 1 0 10\n{}{}$EndNodes\n\
         $Elements\n1 1 1 1\n3 1 11 1\n1 1 2 3 4 5 6 7 8 9 10\n$EndElements\n",
        (1..=10).map(|i| format!("{i}\n")).collect::<String>(),
        (1..=10)
            .map(|i| format!("{i} 0 {}\n", i % 3))
            .collect::<String>(),
    );
    let e = err(&msh41);
    let msg = message(&e, "bad.msh", None);
    assert!(
        msg.ends_with(&format!(
            "(1 element of other types skipped). It is a {}",
            FIRST_ORDER.replacen("tetrahedra", "tetrahedron", 1)
        )),
        "{msg}"
    );
    // ... and in binary MSH 4.1.
    let size = |b: &mut Vec<u8>, v: u64| b.extend(v.to_le_bytes());
    let int = |b: &mut Vec<u8>, v: i32| b.extend(v.to_le_bytes());
    let mut b = b"$MeshFormat\n4.1 1 8\n".to_vec();
    int(&mut b, 1);
    b.extend(b"\n$EndMeshFormat\n$Nodes\n");
    for v in [1, 10, 1, 10] {
        size(&mut b, v);
    }
    for v in [3, 1, 0] {
        int(&mut b, v);
    }
    size(&mut b, 10);
    for t in 1..=10 {
        size(&mut b, t);
    }
    for i in 1..=10 {
        for x in [f64::from(i), 0.0, f64::from(i % 3)] {
            b.extend(x.to_le_bytes());
        }
    }
    b.extend(b"\n$EndNodes\n$Elements\n");
    for v in [1, 1, 1, 1] {
        size(&mut b, v);
    }
    for v in [3, 1, 11] {
        int(&mut b, v);
    }
    size(&mut b, 1);
    // Element tag 1, then its ten node tags.
    size(&mut b, 1);
    for n in 1..=10 {
        size(&mut b, n);
    }
    b.extend(b"\n$EndElements\n");
    let e = parse_msh(&b, "bad.msh").unwrap_err();
    assert!(
        matches!(
            e,
            MeshError::NoTetrahedra {
                skipped: 1,
                higher_order: 1,
                ..
            }
        ),
        "{e:?}"
    );
}

#[test]
fn error_corrupt_binary_msh_names_each_context_once() {
    let size = |v: u64| v.to_le_bytes().to_vec();
    let mut b = b"$MeshFormat\n4.1 1 8\n".to_vec();
    b.extend(1i32.to_le_bytes());
    b.extend(b"\n$EndMeshFormat\n$Entities\n");
    for v in [3, 0, 0, 0] {
        b.extend(size(v));
    }
    // One point entity of three, then garbage.
    b.extend(1i32.to_le_bytes());
    for x in [0.0f64; 3] {
        b.extend(x.to_le_bytes());
    }
    b.extend(size(0));
    b.extend(b"garbage\n$EndEntities\n");
    let e = parse_msh(&b, "bad.msh").unwrap_err();
    let msg = e.to_string();
    assert!(
        msg.starts_with("bad.msh: Gmsh MSH 4.1: entity section: points: point entity (2 of 3)"),
        "{msg}"
    );
    assert_eq!(msg.matches("entity section").count(), 1, "{msg}");
}

#[test]
fn error_msh41_huge_count_and_garbage() {
    let mesh = two_tets();
    let text = to_msh41_ascii(&mesh).replace("$Nodes\n2 6 ", "$Nodes\n2 99999999999 ");
    let e = err(&text);
    let msg = message(&e, "bad.msh", Some(10));
    assert!(matches!(e, MeshError::TooLarge { .. }), "{e:?}");
    assert!(msg.contains("node count 99999999999"), "{msg}");

    // Binary: huge node count in the section header.
    let mut bin = to_msh41_binary(&mesh);
    let at = bin.windows(7).position(|w| w == b"$Nodes\n").unwrap() + 7 + 8;
    bin[at..at + 8].copy_from_slice(&(1u64 << 40).to_le_bytes());
    let e = parse_msh(&bin, "bad.msh").unwrap_err();
    assert!(matches!(e, MeshError::TooLarge { line: None, .. }), "{e:?}");

    // Garbage in a node coordinate: the token, what it should be, the line.
    let text = to_msh41_ascii(&mesh).replace("\n1.0 1.0 1.0\n", "\n1.0 x 1.0\n");
    let line = 1 + text[..text.find("1.0 x 1.0").unwrap()]
        .matches('\n')
        .count();
    let e = err(&text);
    assert!(matches!(e, MeshError::BadNumber { .. }), "{e:?}");
    let msg = message(&e, "bad.msh", Some(line));
    assert!(msg.contains("y coordinate of node tag"), "{msg}");

    // Truncated binary file.
    let bin = to_msh41_binary(&mesh);
    let e = parse_msh(&bin[..bin.len() - 40], "bad.msh").unwrap_err();
    assert!(matches!(e, MeshError::Parse { .. }), "{e:?}");
    assert!(e.to_string().contains("byte offset"), "{e}");

    // Unknown node tag.
    let text = to_msh41_ascii(&mesh).replace("\n4 107 114 121 128\n", "\n4 107 114 121 999\n");
    let e = err(&text);
    assert!(
        matches!(e, MeshError::UnknownNodeTag { tag: 999, .. }),
        "{e:?}"
    );
}

#[test]
fn msh41_parametric_nodes_and_skipped_sections() {
    // Gmsh's "SaveParametric" output: a curve node with u, volume nodes with
    // u v w; $PhysicalNames and $Entities are skipped.
    let text = "$MeshFormat
4.1 0 8
$EndMeshFormat
$PhysicalNames
1
3 1 \"body\"
$EndPhysicalNames
$Nodes
2 6 1 6
1 1 1 1
6
9 9 9 0.5
3 1 1 5
1
2
3
4
5
0 0 0 0 0 0
1 0 0 1 0 0
0 1 0 0 1 0
0 0 1 0 0 1
1 1 1 1 1 1
$EndNodes
$Elements
1 2 1 2
3 1 4 2
1 1 2 3 4
2 2 3 4 5
$EndElements
";
    let mut mesh = parse_msh(text.as_bytes(), "param.msh").unwrap();
    assert_eq!(mesh.nodes[0], [9.0, 9.0, 9.0]);
    assert_eq!(drop_unused_nodes(&mut mesh), 1);
    assert_eq!(mesh, two_tets());

    // A parametric volume node without its three parametric coordinates.
    let e = err(&text.replace("0 1 0 0 1 0\n", "0 1 0\n"));
    let msg = message(&e, "bad.msh", Some(21));
    assert!(msg.contains("6 coordinates of node tag 3"), "{msg}");
}

#[test]
fn msh_elements_before_nodes() {
    let text = MSH2_SMALL.replace(
        "$Nodes\n5\n10 0 0 0\n20 1 0 0\n30 0 1 0\n40 0 0 1\n50 1 1 1\n$EndNodes\n",
        "",
    ) + "$Nodes\n5\n10 0 0 0\n20 1 0 0\n30 0 1 0\n40 0 0 1\n50 1 1 1\n$EndNodes\n";
    assert_eq!(parse_msh(text.as_bytes(), "late.msh").unwrap(), two_tets());
}

#[test]
fn error_wrong_end_marker_is_named() {
    let e = err(&MSH2_SMALL.replace("$EndNodes", "$EndNode"));
    let msg = message(&e, "bad.msh", Some(11));
    assert!(matches!(e, MeshError::Malformed { .. }), "{e:?}");
    assert!(
        msg.contains("expected \"$EndNodes\", found \"$EndNode\""),
        "{msg}"
    );
}

#[test]
fn error_msh41_block_counts() {
    let mesh = two_tets();
    let text = to_msh41_ascii(&mesh);
    // A block holds more elements than the section declares.
    let e = err(&text.replace("\n3 1 4 2\n", "\n3 1 4 3\n"));
    assert!(
        matches!(
            e,
            MeshError::CountMismatch {
                declared: 4,
                found: 5,
                ..
            }
        ),
        "{e:?}"
    );
    // The section ends inside a block.
    let cut = text.replace("\n3 1 4 2\n", "\n3 1 4 2\n$EndElements\n");
    let e = err(&cut);
    assert!(matches!(e, MeshError::CountMismatch { .. }), "{e:?}");
    // A node tag line with a coordinate on it.
    let e = err(&text.replace(&format!("\n{}\n", common::msh::tag(1)), "\n107 1\n"));
    assert!(matches!(e, MeshError::Malformed { .. }), "{e:?}");
    assert!(
        e.to_string().contains("a node tag alone on its line"),
        "{e}"
    );
}
