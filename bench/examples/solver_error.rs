//! Error against the converged implicit step, and time per step, of chosen
//! solver settings on the report's scenes (dt 1 ms, 200 steps from rest):
//!
//! ```text
//! cargo run --release -p corofem-bench --example solver_error -- [scene …]
//! ```
//!
//! Scenes: `beam`, `liver`, `bunny` (the report's), `liver3k`, `bunny3k`.
//! `RUNS="mass:5 two-level:3"` chooses the preconditioners and CG
//! iterations to measure; an entry `two-level:4:0.2` also sets the CG
//! tolerance, and `mass:5:0:qr` the method (the paper's CG as the
//! defaults were before `two-level` and `qr-invertible`). The warm start is
//! on for every preconditioner but `mass`; `WARM=0` (or `1`) sets it for
//! every run; `GUARD=0` turns the energy guard off; `METHOD=qr` (any
//! method's name) replaces the default method, `qr-invertible`.
//! Each line gives the preconditioner, CG iterations, mean ms per step (the
//! first step, which prepares the preconditioner, apart), the CG iterations
//! that ran per step (the energy certificate may add some), the steps that
//! ended with a Galerkin step, and
//! the relative RMS position error against the f64 reference with linear
//! systems solved to 1e-12 (the "solve error" of the report).

use corofem::{Method, Preconditioner};
use corofem_bench::reference::{RefMethod, Trajectory};
use corofem_bench::scenes::{self, SceneDef};
use std::time::Instant;

/// A mesh of `../shared/meshes` scaled by `scale`, hanging from its nodes
/// within `band` (m) of its top (largest y), with α_M 0.5, α_K 0.002.
fn hanging(name: &str, file: &str, scale: f64, band: f32) -> SceneDef {
    let mut s = scenes::from_file(name, &scenes::meshes_dir().join(file), scale);
    let top = s.nodes.iter().map(|p| p[1]).fold(f32::MIN, f32::max);
    s.fixed = (0..s.nodes.len() as u32)
        .filter(|&i| s.nodes[i as usize][1] >= top - band)
        .collect();
    s.rayleigh_mass = 0.5;
    s.rayleigh_stiffness = 0.002;
    s
}

fn scene(name: &str) -> SceneDef {
    let m = scenes::meshes_dir();
    match name {
        "beam" => scenes::beam(),
        "liver" => scenes::liver(&m),
        "bunny" => scenes::bunny(&m),
        "liver3k" => hanging("liver3k", "liver_ftw_3k.tetmesh", 0.03, 0.005),
        "bunny3k" => hanging("bunny3k", "bunny_ftw_3k.tetmesh", 1.0, 0.008),
        _ => panic!("unknown scene {name}"),
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let names = if args.is_empty() {
        vec!["beam".to_owned(), "liver".to_owned(), "bunny".to_owned()]
    } else {
        args
    };
    let method = std::env::var("METHOD").map_or(Method::DEFAULT, |m| {
        Method::from_name(&m).expect("METHOD is a method's name")
    });
    let steps = 200;
    let dt = 1.0e-3;
    for name in &names {
        let d = scene(name);
        let mut r = d.reference().with_method(RefMethod::Qr);
        let rs = d.ref_settings(dt);
        let mut traj = Trajectory::default();
        for _ in 0..steps {
            r.step(&rs);
            traj.push(&r.u);
        }
        let runs: Vec<(Preconditioner, u32, f32, Method)> = match std::env::var("RUNS") {
            // `RUNS="mass:5 two-level:3"` chooses the runs.
            Ok(list) => list
                .split_whitespace()
                .map(|r| {
                    let mut parts = r.split(':');
                    let (p, c, t, m) = (parts.next(), parts.next(), parts.next(), parts.next());
                    (
                        Preconditioner::from_name(p.unwrap_or_default())
                            .expect("a preconditioner name"),
                        c.and_then(|c| c.parse().ok())
                            .expect("RUNS entries are name:iterations[:tolerance[:method]]"),
                        t.map_or(0.0, |t| t.parse().expect("a tolerance")),
                        m.map_or(method, |m| Method::from_name(m).expect("a method name")),
                    )
                })
                .collect(),
            Err(_) => vec![
                (Preconditioner::Mass, 5, 0.0, method),
                (Preconditioner::BlockJacobi, 5, 0.0, method),
                (Preconditioner::TwoLevel, 3, 0.0, method),
                (Preconditioner::TwoLevel, 4, 0.0, method),
                (Preconditioner::TwoLevel, 5, 0.0, method),
            ],
        };
        for (pre, cg, tol, method) in runs {
            let mut sc = d.core_with(method, dt as f32, cg, pre);
            let mut settings = *sc.settings();
            settings.cg_tolerance = tol;
            // `WARM=0` (or `1`) overrides the warm start, which is on for
            // every preconditioner but the mass.
            if let Ok(w) = std::env::var("WARM") {
                settings.warm_start = w != "0";
            }
            // `GUARD=0` turns the energy guard off.
            if let Ok(g) = std::env::var("GUARD") {
                settings.energy_guard = g != "0";
            }
            sc.set_settings(settings).expect("a valid tolerance");
            let (mut e, mut secs) = (0.0f64, 0.0f64);
            let mut diverged = false;
            // The first step prepares the preconditioner: timed apart.
            let mut first = 0.0f64;
            let (mut iterations, mut galerkin) = (0u64, 0u32);
            for s in 0..steps {
                let t = Instant::now();
                let st = sc.step();
                let dt = t.elapsed().as_secs_f64();
                if s == 0 {
                    first = dt;
                } else {
                    secs += dt;
                }
                match st {
                    Ok(st) => {
                        iterations += u64::from(st.cg_iterations);
                        galerkin += u32::from(st.galerkin);
                    }
                    Err(_) => {
                        diverged = true;
                        break;
                    }
                }
                e += traj.sq_err(
                    s,
                    (0..sc.node_count() as u32)
                        .map(|i| sc.displacement(i).unwrap_or([f32::NAN; 3]).map(f64::from)),
                );
            }
            println!(
                "{name:8} {:5} nodes {:6} tets  {:13} {:13} cg {cg:2} tol {tol:4}  {:.4} ms/step (first {:.3} ms)  {:.2} it/step  {galerkin:3} galerkin  error {}{}",
                d.nodes.len(),
                d.tets.len(),
                method.name(),
                pre.name(),
                secs * 1e3 / (steps - 1) as f64,
                first * 1e3,
                iterations as f64 / steps as f64,
                if diverged {
                    "diverged".to_owned()
                } else {
                    format!("{:.2e}", traj.relative(e))
                },
                if pre == Preconditioner::TwoLevel {
                    // What `VecStorage` makes room for and the scene uses.
                    let free = d.nodes.len() - d.fixed.len();
                    format!(
                        "  ({} aggregates)",
                        corofem::aggregates_for(free, corofem::MAX_AGGREGATES)
                    )
                } else {
                    String::new()
                }
            );
        }
    }
}
