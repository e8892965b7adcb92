//! Criterion benchmarks of embedded surfaces on the 3k-tet bunny
//! (`bunny_ftw_3k.tetmesh`, 0.2 m, held at its base): binding 10 000 and
//! 100 000 vertices, and moving 100 000 (`update_surface`, then
//! `vertex_normals`), beside one step of the same scene with the default
//! solver. The surface is the bunny's boundary Loop-subdivided four times
//! (178 712 vertices); the first 10 000 and 100 000 of them are bound (old
//! vertices first, then edge points: spread over the whole body), and the
//! normals are those of every triangle of the first 100 000.
//!
//! `cargo bench -p corofem-bench --bench surface`.

use corofem::{
    surface_scratch_len, vertex_normals, Method, Preconditioner, SurfaceBinding, VecScene,
};
use corofem_bench::scenes;
use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;
use std::time::Duration;

fn bunny() -> (corofem_bench::SceneDef, corofem_io::Surface) {
    let meshes = scenes::meshes_dir();
    let mut def = scenes::from_file("bunny3k", &meshes.join("bunny_ftw_3k.tetmesh"), 1.0);
    let lo = def.nodes.iter().fold(f32::MAX, |l, p| l.min(p[1]));
    def.fixed = (0..def.nodes.len() as u32)
        .filter(|&i| def.nodes[i as usize][1] <= lo + 0.01)
        .collect();
    let mut s = corofem_io::boundary_surface(&def.nodes, &def.tets).expect("valid mesh");
    for _ in 0..4 {
        s = corofem_io::loop_subdivide(&s).expect("valid surface");
    }
    (def, s)
}

fn bind(scene: &VecScene, vertices: &[[f32; 3]], reach: f32) -> Vec<SurfaceBinding> {
    let mut scratch = vec![0; surface_scratch_len(vertices.len())];
    let mut b = vec![SurfaceBinding::EMPTY; vertices.len()];
    scene
        .bind_surface(vertices, &[], reach, &mut scratch, &mut b)
        .expect("binds");
    b
}

fn surface(c: &mut Criterion) {
    let (def, s) = bunny();
    let mut scene = def.core_with(Method::QrInvertible, 1e-3, 4, Preconditioner::TwoLevel);
    let reach = 0.5 * scene.mean_edge_length();
    let mut group = c.benchmark_group("surface, 3k-tet bunny");
    group.measurement_time(Duration::from_secs(5));
    for n in [10_000, 100_000] {
        let v = &s.vertices[..n];
        let mut scratch = vec![0; surface_scratch_len(n)];
        let mut b = vec![SurfaceBinding::EMPTY; n];
        group.bench_function(format!("bind {n} vertices"), |bench| {
            bench.iter(|| {
                scene
                    .bind_surface(black_box(v), &[], reach, &mut scratch, &mut b)
                    .expect("binds")
            })
        });
    }
    let n = 100_000;
    let b = bind(&scene, &s.vertices[..n], reach);
    let tris: Vec<[u32; 3]> = s
        .triangles
        .iter()
        .copied()
        .filter(|t| t.iter().all(|&i| (i as usize) < n))
        .collect();
    // A deformed state, as in a run.
    for _ in 0..50 {
        scene.step().expect("finite");
    }
    let mut out = vec![[0.0f32; 3]; n];
    let mut normals = vec![[0.0f32; 3]; n];
    group.bench_function(format!("update {n} vertices"), |bench| {
        bench.iter(|| {
            scene
                .update_surface(black_box(&b), &mut out)
                .expect("sizes")
        })
    });
    group.bench_function(
        format!("normals of {n} vertices ({} triangles)", tris.len()),
        |bench| bench.iter(|| vertex_normals(black_box(&out), &tris, &mut normals).expect("sizes")),
    );
    group.bench_function("step (default solver)", |bench| {
        bench.iter(|| black_box(scene.step().expect("finite")))
    });
    group.finish();
}

criterion_group!(benches, surface);
criterion_main!(benches);
