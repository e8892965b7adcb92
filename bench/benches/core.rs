//! Criterion micro-benchmarks of the core on the 10 368-tet cube of
//! `examples/scenes/timing_cube10k.toml`: the diagnostics' force pass
//! (`Scene::elastic_forces`: the QR kernel over every element, baseline
//! build, each node's share handed to a `dyn` callback; not the step's own
//! force pass, which only the step benchmarks time), the
//! stiffness product of one CG iteration (`stiffness_product`) and whole
//! steps, `Qr` with 1, 5 and 10 CG iterations and every method with 5.
//! CG stops early at the f32 residual floor, so step differences bound the
//! cost of one iteration from above only.
//!
//! `cargo bench -p corofem-bench --bench core`. The report of docs/bench.md
//! (`cargo run --release -p corofem-bench -- bench`) is the larger study; these
//! are the quick, statistically summarised numbers to check a change against.

use corofem::Method;
use corofem_bench::scenes;
use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;
use std::time::Duration;

fn cube() -> corofem_bench::SceneDef {
    scenes::boxed("cube10k", [1.0, 1.0, 1.0], [12, 12, 12], 1.0e6)
}

fn element_pass(c: &mut Criterion) {
    let def = cube();
    let mut scene = def.core(Method::Qr, 1e-3, 5);
    for _ in 0..20 {
        scene.step().expect("finite");
    }
    let mut forces = vec![[0.0f32; 3]; def.nodes.len()];
    c.bench_function(
        "elastic_forces (diagnostics, dyn callback), Qr, 10k tets",
        |b| b.iter(|| black_box(scene.elastic_forces(&mut forces).expect("built"))),
    );
}

fn stiffness_product(c: &mut Criterion) {
    let def = cube();
    let mut scene = def.core(Method::Qr, 1e-3, 5);
    for _ in 0..20 {
        scene.step().expect("finite");
    }
    // Any direction: the product's cost does not depend on the values.
    let d: Vec<[f32; 3]> = (0..def.nodes.len())
        .map(|i| {
            let t = i as f32;
            [t.sin(), (0.7 * t).cos(), 0.1]
        })
        .collect();
    let mut out = vec![[0.0f32; 3]; def.nodes.len()];
    c.bench_function(
        "stiffness product -K d (one CG iteration's element pass), 10k tets",
        |b| {
            b.iter(|| {
                scene
                    .stiffness_product(black_box(&d), &mut out)
                    .expect("sizes")
            })
        },
    );
}

fn steps(c: &mut Criterion) {
    let def = cube();
    let mut group = c.benchmark_group("step, 10k tets");
    for (method, cg) in [
        (Method::Qr, 1),
        (Method::Qr, 5),
        (Method::Qr, 10),
        (Method::Polar, 5),
        (Method::Linear, 5),
        (Method::QrRestB, 5),
    ] {
        // The cube is clamped at x = 0 and swings under gravity: the cost of
        // a step does not depend on where it is in that swing.
        let mut s = def.core(method, 1e-3, cg);
        group.bench_function(format!("{method:?}, {cg} CG"), |b| {
            b.iter(|| black_box(s.step().expect("finite")))
        });
    }
    group.finish();
}

criterion_group! {
    name = benches;
    // Short runs: a step is ~1–2.5 ms, so 3 s of measurement still time
    // over a thousand steps per benchmark, in 30 samples.
    config = Criterion::default().sample_size(30).measurement_time(Duration::from_secs(3));
    targets = element_pass, stiffness_product, steps
}
criterion_main!(benches);
