//! Time to static equilibrium against mesh size, for both preconditioners of
//! the static solve.
//!
//! A beam 1 m × 0.2 m × 0.2 m of boxes of 5 tets (as
//! `examples/scenes/beam_static.toml`), E = 1e7 Pa, ν = 0.3, ρ = 1000 kg/m³,
//! clamped at x = 0, sagging under gravity, solved with the default
//! [`StaticSettings`]: once with the two-level preconditioner of `K`, once
//! with the stiffness diagonal. Each line gives the wall time of
//! `solve_static` (the fastest of three), the Newton iterations, the CG
//! iterations of each, and which stopping rule was met.
//!
//! `cargo run --release -p corofem-bench --example static_beams [-- CELLS…]`,
//! each `CELLS` as `nx,ny,nz` (default: 240 to 57,600 tets).

use std::time::Instant;

use corofem::{BoxMesh, BuildOptions, Material, Settings, StaticSettings, VecScene};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let sizes: Vec<[u32; 3]> = if args.is_empty() {
        vec![
            [12, 2, 2],
            [24, 4, 4],
            [40, 6, 6],
            [64, 8, 8],
            [96, 8, 8],
            [80, 12, 12],
        ]
    } else {
        args.iter()
            .map(|a| {
                let v: Vec<u32> = a
                    .split(',')
                    .map(|x| x.parse().expect("CELLS as nx,ny,nz"))
                    .collect();
                [v[0], v[1], v[2]]
            })
            .collect()
    };
    println!("tets    preconditioner  wall s   Newton  CG per Newton iteration        rule met");
    for cells in sizes {
        for two_level in [true, false] {
            let (tets, best, newton, cg, met) = solve(cells, two_level);
            println!(
                "{tets:6}  {:14}  {best:7.3}  {newton:6}  {:30} {met}",
                if two_level { "two-level" } else { "diagonal" },
                format!("{cg:?}"),
            );
        }
    }
}

/// Builds the beam and solves it three times from rest; returns the tets,
/// the fastest wall time (s), and the last run's Newton iterations, CG
/// iterations and rule.
fn solve(cells: [u32; 3], two_level: bool) -> (usize, f64, u32, Vec<u32>, &'static str) {
    let mesh = BoxMesh {
        size: [1.0, 0.2, 0.2],
        cells,
        tets_per_cell: 5,
    };
    let mut nodes = vec![[0.0f32; 3]; mesh.node_count()];
    let mut tets = vec![[0u32; 4]; mesh.tet_count()];
    let (n, t) = mesh.generate(&mut nodes, &mut tets).expect("box mesh");
    let fixed: Vec<u32> = (0..n as u32)
        .filter(|&i| nodes[i as usize][0] <= 1e-6)
        .collect();
    let cfg = StaticSettings {
        two_level,
        ..StaticSettings::default()
    };
    let mut best = f64::INFINITY;
    let mut last = (0, Vec::new(), "none");
    for _ in 0..3 {
        let mut scene = VecScene::with_capacity(n, t);
        scene
            .build(
                &nodes[..n],
                &tets[..t],
                &Material {
                    young: 1.0e7,
                    poisson: 0.3,
                    density: 1000.0,
                },
                BuildOptions::default(),
            )
            .expect("build");
        scene.fix_nodes(&fixed).expect("fix");
        scene
            .set_settings(Settings {
                gravity: [0.0, 0.0, -9.81],
                ..Settings::default()
            })
            .expect("settings");
        let mut cg = Vec::new();
        let start = Instant::now();
        let out = scene
            .solve_static(&cfg, |s| cg.push(s.cg_iterations))
            .expect("static solve");
        best = best.min(start.elapsed().as_secs_f64());
        let met = if !out.converged {
            "none"
        } else if out.residual <= cfg.tolerance {
            "force"
        } else {
            "update"
        };
        last = (cg.len() as u32, cg, met);
    }
    (t, best, last.0, last.1, last.2)
}
