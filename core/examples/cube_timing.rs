//! Time per step of the 10 368-tet cube (12×12×12 cells of 6 tetrahedra, the
//! grid of `../shared/meshes/cube_13n_t6`), `Qr`, 5 CG iterations, dt 1 ms,
//! clamped at x = 0 under gravity: the scene of the benchmark report's
//! "Instruction sets" section, but built with only the core's default
//! features (`libm`, `qr`), as a scene that uses `Qr` alone would be. The
//! report's binary carries every method and model (`full`), a few percent
//! slower on this scene (the node loops check for the ground, the tool and
//! loads; the step dispatches over four methods).
//!
//! ```sh
//! cargo run --release -p corofem --features std --example cube_timing
//! ```
//!
//! Prints the fastest of 20 rounds of 50 steps (ms per step, wall clock) for
//! the baseline step and, where the CPU has AVX2, for the AVX2 step, and
//! whether both reach the same bits.

use corofem::{
    element_blocks, BoxMesh, BuildOptions, ElementBlock, InstructionSet, Material, Method, Node,
    NodeWork, Scene, SliceStorage, ELEMENTS_PER_BLOCK,
};
use std::time::Instant;

/// Steps per round and rounds; the fastest round filters out other processes
/// (on this shared 2-core machine, runs still differ by about 5 %).
const STEPS: usize = 50;
const ROUNDS: usize = 20;

fn main() {
    let mesh = BoxMesh {
        size: [1.0; 3],
        cells: [12, 12, 12],
        tets_per_cell: 6,
    };
    let mut nodes = vec![[0.0f32; 3]; mesh.node_count()];
    let mut tets = vec![[0u32; 4]; mesh.tet_count()];
    let (n, t) = mesh.generate(&mut nodes, &mut tets).expect("box mesh");
    nodes.truncate(n);
    tets.truncate(t);
    let fixed: Vec<u32> = (0..n as u32)
        .filter(|&i| nodes[i as usize][0] == 0.0)
        .collect();

    let mut ns = vec![Node::EMPTY; n];
    let mut ws = vec![NodeWork::EMPTY; n];
    let mut es = vec![ElementBlock::EMPTY; element_blocks(t)];
    let mut run = |isa: InstructionSet| {
        let mut scene = Scene::with_storage(SliceStorage::new(&mut ns, &mut ws, &mut es));
        let material = Material {
            young: 1.0e6,
            poisson: 0.3,
            density: 1000.0,
        };
        scene
            .build(&nodes, &tets, &material, BuildOptions::default())
            .expect("build");
        scene.fix_nodes(&fixed).expect("fix");
        scene.set_instruction_set(Some(isa)).expect("supported");
        let mut s = *scene.settings();
        s.method = Method::Qr;
        s.dt = 1e-3;
        s.cg_iterations = 5;
        s.cg_tolerance = 0.0;
        s.gravity = [0.0, 0.0, -9.81];
        scene.set_settings(s).expect("settings");
        let mut best = f64::MAX;
        for _ in 0..ROUNDS {
            let start = Instant::now();
            for _ in 0..STEPS {
                scene.step().expect("finite");
            }
            best = best.min(start.elapsed().as_secs_f64() * 1e3 / STEPS as f64);
        }
        (best, scene.state_hash())
    };
    // 72 bytes per element with `qr` alone, 124 with every feature.
    let per_element = std::mem::size_of::<ElementBlock>() / ELEMENTS_PER_BLOCK;
    println!("{t} tets, {n} nodes, Qr, 5 CG iterations, dt 1 ms, {per_element} bytes per element");
    let (base, base_hash) = run(InstructionSet::Baseline);
    println!("baseline step (SSE2): {base:.3} ms/step");
    if InstructionSet::Avx2.is_supported() {
        let (fast, fast_hash) = run(InstructionSet::Avx2);
        println!(
            "AVX2 step:            {fast:.3} ms/step, same bits as the baseline: {}",
            if fast_hash == base_hash { "yes" } else { "NO" }
        );
        if fast_hash != base_hash {
            std::process::exit(1);
        }
    } else {
        println!("AVX2 step: this CPU has no AVX2");
    }
}
