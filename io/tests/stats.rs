//! `mesh_stats`, the geometric helpers and `drop_unused_nodes`.

use crate::common;

use common::{shared_tetmesh, two_tets};
use corofem_io::{dihedral_angles_deg, drop_unused_nodes, mesh_stats, tet_volume, Mesh};

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol
}

#[test]
fn corner_and_regular_tet_angles() {
    let corner = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
    ];
    assert!(close(tet_volume(&corner), 1.0 / 6.0, 1e-15));
    let a = dihedral_angles_deg(&corner);
    // Edges 01, 02, 03 (at the right-angle corner) are 90°; 12, 13, 23 are
    // acos(1/√3) = 54.7356°.
    for (k, expected) in [
        90.0,
        90.0,
        90.0,
        54.735_610_317,
        54.735_610_317,
        54.735_610_317,
    ]
    .iter()
    .enumerate()
    {
        assert!(close(a[k], *expected, 1e-8), "edge {k}: {}", a[k]);
    }

    let s = 1.0 / 2f64.sqrt();
    let regular = [
        [1.0, 0.0, -s],
        [-1.0, 0.0, -s],
        [0.0, 1.0, s],
        [0.0, -1.0, s],
    ];
    let sign = tet_volume(&regular).signum();
    for a in dihedral_angles_deg(&regular) {
        assert!(close(a, 70.528_779_366, 1e-8), "{a}");
    }
    // Swapping two vertices flips the orientation but not the angles.
    let flipped = [regular[1], regular[0], regular[2], regular[3]];
    assert_eq!(tet_volume(&flipped).signum(), -sign);
    for a in dihedral_angles_deg(&flipped) {
        assert!(close(a, 70.528_779_366, 1e-8), "{a}");
    }
}

#[test]
fn stats_of_small_mesh() {
    let s = mesh_stats(&two_tets());
    assert_eq!((s.nodes, s.tets), (5, 2));
    assert_eq!(s.bbox_min, [0.0; 3]);
    assert_eq!(s.bbox_max, [1.0; 3]);
    assert!(close(s.total_volume, 0.5, 1e-15));
    assert!(close(s.min_tet_volume, 1.0 / 6.0, 1e-15));
    assert!(close(s.max_tet_volume, 1.0 / 3.0, 1e-15));
    assert_eq!(
        (s.negative_tets, s.zero_volume_tets, s.unused_nodes),
        (0, 0, 0)
    );
    assert!(s.min_dihedral_deg > 0.0 && s.max_dihedral_deg < 180.0);
}

#[test]
fn stats_count_inverted_flat_and_unused() {
    let mut mesh = two_tets();
    mesh.tets[1] = [2, 1, 3, 4]; // inverted
    mesh.nodes.push([5.0, 5.0, 5.0]); // unused
    mesh.nodes.push([0.25, 0.25, 0.0]); // in the plane z = 0
    mesh.tets.push([0, 1, 2, 6]); // flat
    mesh.tets.push([0, 0, 1, 2]); // repeated node
    let s = mesh_stats(&mesh);
    assert_eq!(s.negative_tets, 1);
    assert_eq!(s.zero_volume_tets, 2);
    assert_eq!(s.unused_nodes, 1);
    assert_eq!(s.bbox_max, [5.0; 3]);
    assert!(close(s.min_tet_volume, -1.0 / 3.0, 1e-15));
    assert!(close(s.total_volume, 1.0 / 6.0 - 1.0 / 3.0, 1e-15));
    // The flat tet has angles of 0° and 180°.
    assert!(
        close(s.min_dihedral_deg, 0.0, 1e-6),
        "{}",
        s.min_dihedral_deg
    );
    assert!(
        close(s.max_dihedral_deg, 180.0, 1e-6),
        "{}",
        s.max_dihedral_deg
    );
}

#[test]
fn stats_of_empty_mesh() {
    let s = mesh_stats(&Mesh::default());
    assert_eq!((s.nodes, s.tets, s.unused_nodes), (0, 0, 0));
    assert_eq!(s.total_volume, 0.0);
    assert!(s.min_dihedral_deg.is_nan() && s.min_tet_volume.is_nan());
}

#[test]
fn drop_unused_nodes_renumbers() {
    let mut mesh = Mesh {
        nodes: vec![
            [9.0, 9.0, 9.0], // unused
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [8.0, 8.0, 8.0], // unused
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
            [7.0, 7.0, 7.0], // unused
        ],
        tets: vec![[1, 2, 4, 5]],
    };
    assert_eq!(drop_unused_nodes(&mut mesh), 3);
    assert_eq!(
        mesh.nodes,
        vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0]
        ]
    );
    assert_eq!(mesh.tets, vec![[0, 1, 2, 3]]);
    // Idempotent.
    let before = mesh.clone();
    assert_eq!(drop_unused_nodes(&mut mesh), 0);
    assert_eq!(mesh, before);
}

/// The shared README says: liver min dihedral angle 6.2° (rounded to 0.1°), no
/// inverted or zero-volume tetrahedra, every node used.
#[test]
#[cfg_attr(not(shared_meshes), ignore = "needs ../shared/meshes")]
fn liver_quality_matches_readme() {
    let liver = shared_tetmesh("sofa_liver.tetmesh");
    let s = mesh_stats(&liver);
    println!("sofa_liver: {s:?}");
    assert_eq!((s.nodes, s.tets), (181, 596));
    assert_eq!(s.negative_tets, 0);
    assert_eq!(s.zero_volume_tets, 0);
    assert_eq!(s.unused_nodes, 0);
    assert!(s.min_tet_volume > 0.0);
    // "6.2°" is rounded to one decimal: accept [6.15, 6.25].
    assert!(
        (6.15..=6.25).contains(&s.min_dihedral_deg),
        "min dihedral {}",
        s.min_dihedral_deg
    );
    assert!(s.max_dihedral_deg < 180.0);
    // README: "arbitrary (~6.5 long)".
    let longest = (0..3)
        .map(|c| s.bbox_max[c] - s.bbox_min[c])
        .fold(0.0, f64::max);
    assert!((5.0..8.0).contains(&longest), "{longest}");
    assert!(close(
        s.total_volume,
        liver
            .tets
            .iter()
            .map(|t| tet_volume(&t.map(|i| liver.nodes[i])))
            .sum(),
        1e-12
    ));
}

/// The README's other figures: fTetWild bunny ≥ 8°, bunny ≈ 0.155 m across.
#[test]
#[cfg_attr(not(shared_meshes), ignore = "needs ../shared/meshes")]
fn bunny_quality_matches_readme() {
    let bunny = shared_tetmesh("bunny_ftw_1k.tetmesh");
    let s = mesh_stats(&bunny);
    println!("bunny_ftw_1k: {s:?}");
    assert_eq!((s.nodes, s.tets), (397, 1027));
    assert_eq!(
        (s.negative_tets, s.zero_volume_tets, s.unused_nodes),
        (0, 0, 0)
    );
    assert!(s.min_dihedral_deg >= 8.0 - 0.05, "{}", s.min_dihedral_deg);
    let longest = (0..3)
        .map(|c| s.bbox_max[c] - s.bbox_min[c])
        .fold(0.0, f64::max);
    assert!((0.14..0.17).contains(&longest), "{longest}");
}
