//! The slope sweep (docs/contact.md): blocks on the ground under gravity
//! tilted by θ, with Coulomb friction μ, across μ, θ around the friction
//! angle, block shapes, tetrahedra per cell, dt and stiffness, with the
//! default settings. Prints one row per case: the distance slid in the
//! run against Coulomb's `½ g (sin θ − μ cos θ) t²` (0 below the angle),
//! the centre's acceleration after break-away, and the worst cone ratio
//! `|s_t| / (μ s_n)` of the support a step reports.
//!
//! `cargo run --release -p corofem-host-tests --bin slopes [-- --quick]`
//! (`--quick`: the 4 × 4 × 2 cm block at dt 1 ms only; `--one MU THETA
//! TETS YOUNG DT`: one case of that block, or with `SLOPES_BIG=1` of the
//! 10 × 10 × 5 cm one, with `SLOPES_TALL=1` of the 2 × 2 × 4 cm one, for
//! `SLOPES_SECONDS`, default 0.5). Exits non-zero if a case
//! misses Coulomb's law by more than the bounds of docs/contact.md: below
//! the angle, the centre moves by more than 10 µm over the run's second
//! half; above, its acceleration there is off by more than 2 %, or a
//! step's support leaves the cone by more than 1 %, or has a tangential
//! part without a normal one.
//!
//! Settings other than the defaults, for comparisons: `SLOPES_ROUNDS`
//! (`contact_rounds`), `SLOPES_CG` (`cg_iterations`, with `cg_tolerance`
//! 1e-6), `SLOPES_KINETIC` (a kinetic coefficient below μ), `SLOPES_DAMP`
//! (`rayleigh_stiffness`, s), `SLOPES_FRICTION_DAMPING` (`friction_damping`,
//! s), `SLOPES_POISSON` (ν, default 0.3);
//! `SLOPES_TRACE=1` prints the steps of `--one` (`SLOPES_TRACE=all`: every
//! step); `SLOPES_AUDIT=1` prints the energy budget (kinetic, elastic,
//! gravity's potential) of every step that gains energy (every step with
//! `SLOPES_TRACE=all`), and the centre's normal and tangential velocity at
//! the run's half and end; `SLOPES_CELLS=NX,NY,NZ` meshes `--one`'s block
//! with other cells.

use corofem::{Friction, Material, Plane, Settings};
use corofem_host_tests::{box_mesh, centre};

const G: f64 = 9.81;

struct Case {
    size: [f32; 3],
    cells: [u32; 3],
    tets: u8,
    young: f32,
    dt: f32,
    mu: f32,
    theta_deg: f32,
    seconds: f32,
}

struct Row {
    slid: f64,
    /// The centre's motion along the slope over the run's second half.
    late: f64,
    expect: f64,
    accel: f64,
    expect_accel: f64,
    cone: f64,
    tangent_alone: u32,
    inverted: u32,
    cg: f64,
    /// The step whose solve diverged (refused, the run stopped there).
    diverged: Option<u32>,
}

fn run(c: &Case) -> Row {
    let mesh = box_mesh(c.size, c.cells, c.tets);
    let mut scene = mesh.scene(&Material {
        young: c.young,
        poisson: std::env::var("SLOPES_POISSON")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(0.3),
        density: 1000.0,
    });
    scene.set_ground(Some(Plane::Z_UP)).unwrap();
    let kinetic = std::env::var("SLOPES_KINETIC")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(c.mu);
    scene.set_ground_friction(Friction::new(c.mu, kinetic).unwrap());
    let theta = f64::from(c.theta_deg).to_radians();
    let defaults = scene.default_settings();
    scene
        .set_settings(Settings {
            dt: c.dt,
            gravity: [(G * theta.sin()) as f32, 0.0, (-G * theta.cos()) as f32],
            cg_iterations: std::env::var("SLOPES_CG")
                .ok()
                .and_then(|v| v.parse().ok())
                .unwrap_or(defaults.cg_iterations),
            cg_tolerance: if std::env::var_os("SLOPES_CG").is_some() {
                1e-6
            } else {
                defaults.cg_tolerance
            },
            rayleigh_stiffness: std::env::var("SLOPES_DAMP")
                .ok()
                .and_then(|v| v.parse().ok())
                .unwrap_or(defaults.rayleigh_stiffness),
            friction_damping: std::env::var("SLOPES_FRICTION_DAMPING")
                .ok()
                .and_then(|v| v.parse().ok())
                .unwrap_or(defaults.friction_damping),
            contact_rounds: std::env::var("SLOPES_ROUNDS")
                .ok()
                .and_then(|v| v.parse().ok())
                .unwrap_or(defaults.contact_rounds),
            ..defaults
        })
        .unwrap();
    let steps = (c.seconds / c.dt).round() as u32;
    let (_, x0, _) = centre(&scene);
    let mu = f64::from(c.mu);
    let expect_accel = (G * (theta.sin() - mu * theta.cos())).max(0.0);
    let t = f64::from(steps) * f64::from(c.dt);
    let (mut cone, mut alone, mut inverted) = (0.0f64, 0u32, 0u32);
    let mut v_half = 0.0;
    let mut x_half = 0.0;
    let mut cg = 0u64;
    let trace = std::env::var_os("SLOPES_TRACE").is_some();
    let every = std::env::var_os("SLOPES_TRACE").is_some_and(|v| v == "all");
    let mut diverged = None;
    let gvec = [G * theta.sin(), 0.0, -G * theta.cos()];
    let energy = |scene: &mut corofem::VecScene| {
        let (m, x, _) = centre(scene);
        let pot = -m * (gvec[0] * x[0] + gvec[2] * x[2]);
        (
            f64::from(scene.kinetic_energy()),
            f64::from(scene.elastic_energy()),
            pot,
        )
    };
    let audit = std::env::var_os("SLOPES_AUDIT").is_some();
    let mut e_prev = energy(&mut scene);
    let (mut gained, mut gain_steps) = (0.0f64, 0u32);
    for k in 1..=steps {
        let v_before = centre(&scene).2;
        let s = match scene.step() {
            Ok(s) => s,
            Err(_) => {
                diverged = Some(k);
                break;
            }
        };
        let weight = centre(&scene).0 * G;
        if trace && (every || k < 40 || k % 50 == 0) {
            let f = s.support_force.map(f64::from);
            let (_, _, v) = centre(&scene);
            eprintln!(
                "step {k:4} contacts {:3} cg {:3} support n {:.5} t {:.5} ratio {:.3} vx {:.5} miss {:.2e}",
                s.contacts,
                s.cg_iterations,
                f[2],
                (f[0] * f[0] + f[1] * f[1]).sqrt(),
                (f[0] * f[0] + f[1] * f[1]).sqrt() / (mu * f[2]),
                v[0],
                (weight / G) * (v[0] - v_before[0]) / f64::from(c.dt) - (weight * theta.sin() + f[0])
            );
        }
        if audit {
            let e = energy(&mut scene);
            let d = (e.0 + e.1 + e.2) - (e_prev.0 + e_prev.1 + e_prev.2);
            if d > 0.0 {
                gained += d;
                gain_steps += 1;
            }
            if every || d > 1e-7 {
                eprintln!(
                    "audit {k:4} contacts {:3} kin {:.3e} ela {:.3e} pot {:.4e} dE {:+.3e} sn {:.4}",
                    s.contacts, e.0, e.1, e.2, d, s.support_force[2]
                );
            }
            e_prev = e;
        }
        inverted = inverted.max(s.inverted);
        cg += u64::from(s.cg_iterations);
        let f = s.support_force.map(f64::from);
        // The support in the slope's frame: normal along z, tangent x, y.
        let normal = f[2];
        let tangent = (f[0] * f[0] + f[1] * f[1]).sqrt();
        if normal > 1e-6 * weight {
            cone = cone.max(tangent / (mu * normal));
        } else if tangent > 1e-6 * weight {
            alone += 1;
            if trace {
                eprintln!("alone at step {k}: contacts {} n {normal:.3e} t {tangent:.3e} weight {weight:.3}", s.contacts);
            }
        }
        if k == steps / 2 {
            let (_, x, v) = centre(&scene);
            v_half = v[0];
            if audit {
                eprintln!("half vn {:.5} vx {:.5}", v[2], v[0]);
            }
            x_half = x[0];
        }
    }
    if audit {
        eprintln!(
            "end vn {:.5} vx {:.5}",
            centre(&scene).2[2],
            centre(&scene).2[0]
        );
        eprintln!("audit: energy gained {gained:.3e} J in {gain_steps} steps");
    }
    let (_, x1, v1) = centre(&scene);
    Row {
        slid: x1[0] - x0[0],
        late: x1[0] - x_half,
        expect: 0.5 * expect_accel * t * t,
        accel: (v1[0] - v_half) / (t - f64::from(steps / 2) * f64::from(c.dt)),
        expect_accel,
        cone,
        tangent_alone: alone,
        inverted,
        cg: cg as f64 / f64::from(steps),
        diverged,
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if let Some(i) = args.iter().position(|a| a == "--one") {
        // --one MU THETA TETS YOUNG DT: one case, traced with SLOPES_TRACE.
        let num = |k: usize| args[i + k].parse::<f32>().expect("a number");
        let big = std::env::var_os("SLOPES_BIG").is_some();
        let tall = std::env::var_os("SLOPES_TALL").is_some();
        let (size, cells) = match (big, tall) {
            (true, _) => ([0.1, 0.1, 0.05], [5, 5, 3]),
            (_, true) => ([0.02, 0.02, 0.04], [2, 2, 4]),
            _ => ([0.04, 0.04, 0.02], [4, 4, 2]),
        };
        let cells = std::env::var("SLOPES_CELLS").ok().map_or(cells, |v| {
            let n: Vec<u32> = v
                .split(',')
                .map(|x| x.parse().expect("SLOPES_CELLS=NX,NY,NZ"))
                .collect();
            n.try_into().expect("SLOPES_CELLS=NX,NY,NZ: three counts")
        });
        let c = Case {
            size,
            cells,
            tets: num(3) as u8,
            young: num(4),
            dt: num(5),
            mu: num(1),
            theta_deg: num(2),
            seconds: std::env::var("SLOPES_SECONDS")
                .ok()
                .and_then(|v| v.parse().ok())
                .unwrap_or(0.5),
        };
        let r = run(&c);
        println!(
            "slid {:.4} late {:.2e} coulomb {:.4} accel {:.4} expect {:.4} cone {:.3} alone {} inverted {} cg {:.1}{}",
            r.slid,
            r.late,
            r.expect,
            r.accel,
            r.expect_accel,
            r.cone,
            r.tangent_alone,
            r.inverted,
            r.cg,
            r.diverged
                .map_or(String::new(), |k| format!(" diverged at step {k}"))
        );
        return;
    }
    let quick = args.iter().any(|a| a == "--quick");
    let blocks: &[([f32; 3], [u32; 3])] = if quick {
        &[([0.04, 0.04, 0.02], [4, 4, 2])]
    } else {
        &[
            ([0.04, 0.04, 0.02], [4, 4, 2]),
            ([0.1, 0.1, 0.05], [5, 5, 3]),
            ([0.02, 0.02, 0.04], [2, 2, 4]),
        ]
    };
    let dts: &[f32] = if quick { &[1e-3] } else { &[5e-4, 1e-3, 5e-3] };
    let (mut failed, mut cases, mut tipping) = (0u32, 0u32, 0u32);
    println!(
        "{:>16} {:>3} {:>6} {:>7} {:>4} {:>5} {:>6} {:>9} {:>9} {:>9} {:>9} {:>6} {:>5} {:>3} {:>5}",
        "block",
        "tet",
        "E",
        "dt",
        "mu",
        "theta",
        "angle",
        "slid",
        "coulomb",
        "accel",
        "expect",
        "cone",
        "alone",
        "inv",
        "cg"
    );
    for &(size, cells) in blocks {
        for tets in [5u8, 6] {
            for young in [1e5f32, 1e7] {
                for &dt in dts {
                    for mu in [0.1f32, 0.3, 0.5, 0.8, 1.0] {
                        let angle = mu.atan().to_degrees();
                        for off in [-5.0f32, 5.0, 15.0, 25.0] {
                            let theta = angle + off;
                            if !(1.0..89.0).contains(&theta) {
                                continue;
                            }
                            let c = Case {
                                size,
                                cells,
                                tets,
                                young,
                                dt,
                                mu,
                                theta_deg: theta,
                                seconds: 0.5,
                            };
                            // A rigid block tips over once tan θ exceeds its
                            // width over its height along the slope: then no
                            // slide is Coulomb's to check.
                            let tips = theta.to_radians().tan() > size[0] / size[2];
                            let r = run(&c);
                            let missed = if r.expect_accel == 0.0 {
                                r.late.abs() > 1e-5
                            } else {
                                (r.accel - r.expect_accel).abs() > 0.02 * r.expect_accel
                            };
                            let bad = r.diverged.is_some()
                                || !tips && (missed || r.cone > 1.01 || r.tangent_alone > 0);
                            failed += u32::from(bad);
                            cases += 1;
                            tipping += u32::from(tips);
                            println!(
                                "{:>16} {:>3} {:>6.0e} {:>7.1e} {:>4.1} {:>5.1} {:>6.1} {:>9.4} {:>9.4} {:>9.4} {:>9.4} {:>6.3} {:>5} {:>3} {:>5.1}{}",
                                format!("{:?}", size.map(|s| s * 100.0)),
                                tets,
                                young,
                                dt,
                                mu,
                                theta,
                                angle,
                                r.slid,
                                r.expect,
                                r.accel,
                                r.expect_accel,
                                r.cone,
                                r.tangent_alone,
                                r.inverted,
                                r.cg,
                                if r.diverged.is_some() {
                                    "  DIVERGED"
                                } else if tips {
                                    "  tips"
                                } else if bad {
                                    "  FAIL"
                                } else {
                                    ""
                                }
                            );
                        }
                    }
                }
            }
        }
    }
    println!("slopes: {failed} of {cases} failed ({tipping} tip over, not judged)");
    std::process::exit(i32::from(failed > 0));
}
