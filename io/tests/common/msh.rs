//! Hand-written Gmsh writers for the tests (the crate has no Gmsh writer).

use std::fmt::Write as _;

use corofem_io::Mesh;

/// Node tag of node `i` in the written files: sparse and not starting at 1.
pub fn tag(i: usize) -> usize {
    100 + 7 * i
}

/// MSH 2.2 ASCII with a `$PhysicalNames` section, one extra (unused) node, a
/// point, a line and a triangle element before the tetrahedra.
pub fn to_msh2(mesh: &Mesh) -> String {
    let n = mesh.nodes.len();
    let mut s = String::from(
        "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$PhysicalNames\n1\n3 1 \"body\"\n$EndPhysicalNames\n",
    );
    writeln!(s, "$Nodes\n{}", n + 1).unwrap();
    for (i, p) in mesh.nodes.iter().enumerate() {
        writeln!(s, "{} {:?} {:?} {:?}", tag(i), p[0], p[1], p[2]).unwrap();
    }
    writeln!(s, "{} 9 9 9\n$EndNodes", tag(n)).unwrap();
    writeln!(s, "$Elements\n{}", mesh.tets.len() + 3).unwrap();
    writeln!(s, "1 15 2 0 1 {}", tag(n)).unwrap();
    writeln!(s, "2 1 2 0 1 {} {}", tag(0), tag(1)).unwrap();
    writeln!(s, "3 2 2 0 1 {} {} {}", tag(0), tag(1), tag(2)).unwrap();
    for (k, t) in mesh.tets.iter().enumerate() {
        // 2 tags (physical, elementary) as Gmsh writes them.
        writeln!(
            s,
            "{} 4 2 1 1 {} {} {} {}",
            k + 4,
            tag(t[0]),
            tag(t[1]),
            tag(t[2]),
            tag(t[3])
        )
        .unwrap();
    }
    s.push_str("$EndElements\n");
    s
}

/// MSH 4.1 ASCII: a point entity block holding one extra node, then a volume block
/// with the mesh nodes (sparse tags); element blocks of points, triangles and
/// tetrahedra.
pub fn to_msh41_ascii(mesh: &Mesh) -> String {
    let n = mesh.nodes.len();
    let m = mesh.tets.len();
    let mut s = String::from("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n");
    s.push_str("$Entities\n1 0 0 1\n1 9 9 9 0\n1 -10 -10 -10 10 10 10 0 0\n$EndEntities\n");
    writeln!(s, "$Nodes\n2 {} {} {}", n + 1, tag(0), tag(n)).unwrap();
    writeln!(s, "0 1 0 1\n{}\n9 9 9", tag(n)).unwrap();
    writeln!(s, "3 1 0 {n}").unwrap();
    for i in 0..n {
        writeln!(s, "{}", tag(i)).unwrap();
    }
    for p in &mesh.nodes {
        writeln!(s, "{:?} {:?} {:?}", p[0], p[1], p[2]).unwrap();
    }
    s.push_str("$EndNodes\n");
    writeln!(s, "$Elements\n3 {} 1 {}", m + 2, m + 2).unwrap();
    writeln!(s, "0 1 15 1\n1 {}", tag(n)).unwrap();
    writeln!(s, "2 1 2 1\n2 {} {} {}", tag(0), tag(1), tag(2)).unwrap();
    writeln!(s, "3 1 4 {m}").unwrap();
    for (k, t) in mesh.tets.iter().enumerate() {
        writeln!(
            s,
            "{} {} {} {} {}",
            k + 3,
            tag(t[0]),
            tag(t[1]),
            tag(t[2]),
            tag(t[3])
        )
        .unwrap();
    }
    s.push_str("$EndElements\n");
    s
}

/// MSH 4.1 binary (little-endian, 8-byte size_t), dense tags 1..=n as Gmsh
/// writes by default, plus a triangle block.
pub fn to_msh41_binary(mesh: &Mesh) -> Vec<u8> {
    let n = mesh.nodes.len() as u64;
    let m = mesh.tets.len() as u64;
    let mut b = Vec::new();
    let size = |b: &mut Vec<u8>, v: u64| b.extend_from_slice(&v.to_le_bytes());
    let int = |b: &mut Vec<u8>, v: i32| b.extend_from_slice(&v.to_le_bytes());
    b.extend_from_slice(b"$MeshFormat\n4.1 1 8\n");
    int(&mut b, 1);
    b.extend_from_slice(b"\n$EndMeshFormat\n$Nodes\n");
    for v in [1, n, 1, n] {
        size(&mut b, v);
    }
    int(&mut b, 3);
    int(&mut b, 1);
    int(&mut b, 0);
    size(&mut b, n);
    for t in 1..=n {
        size(&mut b, t);
    }
    for p in &mesh.nodes {
        for c in p {
            b.extend_from_slice(&c.to_le_bytes());
        }
    }
    b.extend_from_slice(b"\n$EndNodes\n$Elements\n");
    for v in [2, m + 1, 1, m + 1] {
        size(&mut b, v);
    }
    for (ty, count) in [(2, 1u64), (4, m)] {
        int(&mut b, if ty == 2 { 2 } else { 3 });
        int(&mut b, 1);
        int(&mut b, ty);
        size(&mut b, count);
        if ty == 2 {
            for v in [1, 1, 2, 3] {
                size(&mut b, v);
            }
        } else {
            for (k, t) in mesh.tets.iter().enumerate() {
                size(&mut b, k as u64 + 2);
                for &i in t {
                    size(&mut b, i as u64 + 1);
                }
            }
        }
    }
    b.extend_from_slice(b"\n$EndElements\n");
    b
}
