//! Surface files and binding on arbitrary bytes. The first byte picks the
//! reader (OBJ, STL), the second scales the reach; the rest is the file.
//! The reader returns a surface whose indices are in range and whose
//! coordinates are finite, or an error naming the file. A surface then binds
//! to a small box mesh, or is refused with a typed error, and a bound one
//! moves with it and gets finite normals: none of which may panic.

#![no_main]

use corofem::{
    surface_scratch_len, vertex_normals, BoxMesh, BuildOptions, Material, SurfaceBinding, VecScene,
};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&[which, reach], bytes)) = data.split_first_chunk::<2>() else {
        return;
    };
    let name = if which % 2 == 0 {
        "fuzz.obj"
    } else {
        "fuzz.stl"
    };
    let surface = match corofem_io::parse_surface(bytes, name) {
        Err(e) => {
            assert_eq!(e.file(), name);
            assert!(e.to_string().starts_with(name), "{e}");
            return;
        }
        Ok(s) => s,
    };
    let n = surface.vertices.len();
    assert!(!surface.triangles.is_empty());
    assert!(surface
        .triangles
        .iter()
        .flatten()
        .all(|&i| (i as usize) < n));
    assert!(surface.vertices.iter().flatten().all(|x| x.is_finite()));
    if n > 100_000 {
        return;
    }
    // A 2 × 1 × 1 box of 2 × 1 × 1 cells.
    let mesh = BoxMesh {
        size: [2.0, 1.0, 1.0],
        cells: [2, 1, 1],
        tets_per_cell: 6,
    };
    let mut nodes = vec![[0.0f32; 3]; mesh.node_count()];
    let mut tets = vec![[0u32; 4]; mesh.tet_count()];
    mesh.generate(&mut nodes, &mut tets).unwrap();
    let mut scene = VecScene::with_capacity(nodes.len(), tets.len());
    scene
        .build(&nodes, &tets, &Material::default(), BuildOptions::default())
        .unwrap();
    let mut scratch = vec![0u32; surface_scratch_len(n)];
    let mut bindings = vec![SurfaceBinding::EMPTY; n];
    let reach = f32::from(reach) * 0.1;
    let Ok(stats) = scene.bind_surface(
        &surface.vertices,
        &surface.triangles,
        reach,
        &mut scratch,
        &mut bindings,
    ) else {
        return;
    };
    assert_eq!((stats.inside + stats.outside) as usize, n);
    // The distance is the f32 square root of an f32-rounded square: a few
    // ulps (1e-7 relative each) over the reach at most.
    assert!(stats.max_distance <= reach * (1.0 + 1e-6));
    let _ = scene.step();
    let mut out = vec![[0.0f32; 3]; n];
    let mut normals = vec![[0.0f32; 3]; n];
    scene.update_surface(&bindings, &mut out).unwrap();
    vertex_normals(&out, &surface.triangles, &mut normals).unwrap();
    assert!(out.iter().chain(&normals).flatten().all(|x| x.is_finite()));
});
