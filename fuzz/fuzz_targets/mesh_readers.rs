//! The host program's mesh readers on arbitrary bytes. The first byte picks
//! the reader (tetmesh, Gmsh MSH, legacy VTK, VTU); the rest is the file.
//! Every reader returns a valid mesh or an error naming the file; a valid
//! mesh then goes the CLI's way (unused nodes dropped, statistics, f32
//! conversion, scene build), none of which may panic.

#![no_main]

use corofem::BuildOptions;
use corofem_io::{parse_msh, parse_tetmesh, parse_vtk_legacy, parse_vtu};
use libfuzzer_sys::fuzz_target;

const NAME: &str = "fuzz-input";

fuzz_target!(|data: &[u8]| {
    let Some((&which, bytes)) = data.split_first() else {
        return;
    };
    let parsed = match which % 4 {
        0 => match std::str::from_utf8(bytes) {
            Ok(text) => parse_tetmesh(text, NAME),
            Err(_) => return,
        },
        1 => parse_msh(bytes, NAME),
        2 => parse_vtk_legacy(bytes, NAME),
        _ => parse_vtu(bytes, NAME),
    };
    let mut mesh = match parsed {
        Err(e) => {
            let msg = e.to_string();
            assert!(msg.starts_with(NAME), "error without the file name: {msg}");
            assert_eq!(e.file(), NAME);
            return;
        }
        Ok(mesh) => mesh,
    };
    let n = mesh.nodes.len();
    assert!(!mesh.tets.is_empty(), "a mesh without tetrahedra");
    assert!(
        mesh.tets.iter().flatten().all(|&i| i < n),
        "index out of range"
    );
    assert!(
        mesh.nodes.iter().flatten().all(|x| x.is_finite()),
        "non-finite coordinate"
    );
    corofem_io::drop_unused_nodes(&mut mesh);
    let stats = corofem_io::mesh_stats(&mesh);
    assert_eq!(stats.nodes, mesh.nodes.len());
    if mesh.nodes.len() <= 1 << 16 && mesh.tets.len() <= 100_000 {
        let (nodes, tets) = corofem_io::to_core(&mesh, 1.0);
        let mut scene = corofem::VecScene::with_capacity(nodes.len(), tets.len());
        if scene
            .build(
                &nodes,
                &tets,
                &corofem::Material::default(),
                BuildOptions { reorient: true },
            )
            .is_ok()
        {
            let _ = scene.step();
            assert!(scene.positions().all(|p| p.iter().all(|x| x.is_finite())));
        }
    }
});
