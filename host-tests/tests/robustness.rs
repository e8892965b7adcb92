//! The paper's hard cases: a liver held at SOFA's three nodes and violently
//! pulled until elements invert, then released; a bunny with zero stiffness
//! crushed flat on the ground, then stiffened; a single tetrahedron pushed flat
//! and through itself.

use corofem::{Material, Method, Plane, Settings};
use corofem_host_tests::{f64v, shared_mesh, CoreMesh};

/// Largest distance of any node from its rest position, relative to the
/// diagonal of the rest bounding box.
fn shape_error<S: corofem::Storage>(scene: &corofem::Scene<S>, mesh: &CoreMesh) -> f64 {
    let (mut lo, mut hi) = ([f64::MAX; 3], [f64::MIN; 3]);
    for p in &mesh.nodes {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k] as f64);
            hi[k] = hi[k].max(p[k] as f64);
        }
    }
    let diag = f64v::norm([hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]]);
    (0..mesh.nodes.len() as u32)
        .map(|i| f64v::norm(f64v::up(scene.displacement(i).unwrap())))
        .fold(0.0, f64::max)
        / diag
}

/// Largest relative change of an edge length from rest: zero for any rigid
/// motion, so it measures the shape wherever the body went.
fn edge_error<S: corofem::Storage>(scene: &corofem::Scene<S>, mesh: &CoreMesh) -> f64 {
    let mut worst = 0.0f64;
    for t in &mesh.tets {
        for (a, b) in [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)] {
            let (i, j) = (t[a], t[b]);
            let d = |p: [f32; 3], q: [f32; 3]| {
                f64v::norm([
                    p[0] as f64 - q[0] as f64,
                    p[1] as f64 - q[1] as f64,
                    p[2] as f64 - q[2] as f64,
                ])
            };
            let rest = d(mesh.nodes[i as usize], mesh.nodes[j as usize]);
            let now = d(scene.position(i).unwrap(), scene.position(j).unwrap());
            worst = worst.max((now - rest).abs() / rest);
        }
    }
    worst
}

fn assert_finite<S: corofem::Storage>(scene: &corofem::Scene<S>) {
    for p in scene.positions().chain(scene.velocities()) {
        assert!(p.iter().all(|v| v.is_finite()));
    }
}

#[test]
#[cfg_attr(not(shared_meshes), ignore = "needs ../shared/meshes")]
fn liver_pulled_until_elements_invert_recovers_after_release() {
    let mesh = shared_mesh("sofa_liver.tetmesh");
    for method in [Method::Qr, Method::Polar] {
        let mut scene = mesh.scene(&Material {
            young: 3.0e4,
            poisson: 0.45,
            density: 1000.0,
        });
        let settings = Settings {
            method,
            dt: 0.005,
            cg_iterations: 5,
            rayleigh_mass: 1.0,
            rayleigh_stiffness: 0.02,
            gravity: [0.0; 3],
            ..Settings::default()
        };
        scene.set_settings(settings).unwrap();
        scene.fix_nodes(&[3, 39, 64]).unwrap();
        // Grab the ten nodes farthest from the fixed ones (the liver is ~6.5
        // long) and pull them ~7 units away in 0.5 s with a stiff spring.
        let fixed_c = [3usize, 39, 64].iter().fold([0.0f64; 3], |c, &i| {
            let p = f64v::up(mesh.nodes[i]);
            [c[0] + p[0] / 3.0, c[1] + p[1] / 3.0, c[2] + p[2] / 3.0]
        });
        let mut by_distance: Vec<u32> = (0..mesh.nodes.len() as u32).collect();
        let dist = |i: u32| {
            let p = f64v::up(mesh.nodes[i as usize]);
            f64v::norm([p[0] - fixed_c[0], p[1] - fixed_c[1], p[2] - fixed_c[2]])
        };
        by_distance.sort_by(|&a, &b| dist(b).total_cmp(&dist(a)));
        let grabbed = &by_distance[..10];
        scene.grab(grabbed, 1.0e6).unwrap();
        let start = scene.tool_target();
        let (mut max_inverted, mut max_force) = (0u32, 0.0f64);
        for step in 0..400 {
            let t = (step + 1) as f32 * settings.dt;
            let pull = 12.0 * t.min(0.5);
            // The step reports the energy its force pass summed: the same
            // bits as the diagnostics' separate pass over the same state.
            let energy = scene.elastic_energy();
            let stats = scene
                .step_haptic([
                    start[0] + pull,
                    start[1] - 0.5 * pull,
                    start[2] + 0.5 * pull,
                ])
                .unwrap();
            assert_eq!(
                stats.elastic_energy.to_bits(),
                energy.to_bits(),
                "step {step}"
            );
            max_inverted = max_inverted.max(stats.inverted);
            max_force = max_force.max(f64v::norm(f64v::up(stats.tool_force)));
        }
        assert_finite(&scene);
        let stretched = shape_error(&scene, &mesh);
        scene.release();
        let mut steps = 0;
        // With 5 CG iterations the stiff modes are heavily damped and the
        // return is slow: measured 3e-2 after 3000 steps, 7e-4 after 6000.
        while steps < 6000 {
            let stats = scene.step().unwrap();
            max_inverted = max_inverted.max(stats.inverted);
            steps += 1;
        }
        assert_finite(&scene);
        let err = shape_error(&scene, &mesh);
        eprintln!("{method:?}: {} grabbed nodes, up to {max_inverted} inverted elements, tool force up to {max_force:.3e} N, displacement {stretched:.2} of the size when pulled, {err:.2e} after {steps} steps released", grabbed.len());
        assert!(max_inverted > 0, "the pull must invert elements");
        assert!(stretched > 0.3, "the pull must be violent: {stretched}");
        // The criterion: back within 1% of the rest shape.
        assert!(err < 0.01, "{method:?}: {err}");
        assert_eq!(scene.inverted_count(), 0);
    }
}

/// What [`crush_and_stiffen`] measures.
struct Crushed {
    /// Height after the crush (m) and the worst edge strain then.
    height: f32,
    crushed: f64,
    /// Most elements inverted at once.
    max_inverted: u32,
    /// Worst edge strain, inverted elements, lowest node above the ground
    /// (m) and kinetic energy (J) at the end.
    err: f64,
    inverted: u32,
    below: f32,
    ke: f32,
}

/// The paper's rabbit with `method`: a bunny without stiffness crushed flat
/// on the ground by gravity, then stiffened to 1 MPa over 0.5 s and left to
/// settle for 3 s.
fn crush_and_stiffen(method: Method) -> Crushed {
    corofem_host_tests::progress(
        "robustness",
        format_args!("{method:?}: crushing the bunny, then 3,500 steps of stiffening"),
    );
    let mesh = shared_mesh("bunny_ftw_1k.tetmesh");
    let zmin = mesh.nodes.iter().map(|p| p[2]).fold(f32::MAX, f32::min);
    let mut scene = mesh.scene(&Material {
        young: 0.0,
        poisson: 0.3,
        density: 1000.0,
    });
    // 50 CG iterations: with 10 the under-converged solve is so sluggish that
    // an ear folded flat by the crush stays folded (measured edge error 0.66).
    scene
        .set_settings(Settings {
            method,
            dt: 1e-3,
            cg_iterations: 50,
            rayleigh_mass: 2.0,
            rayleigh_stiffness: 0.01,
            ..Settings::default()
        })
        .unwrap();
    // Ground 5 cm below the bunny.
    scene
        .set_ground(Some(Plane {
            normal: [0.0, 0.0, 1.0],
            offset: zmin - 0.05,
        }))
        .unwrap();
    let mut max_inverted = 0;
    for _ in 0..600 {
        max_inverted = max_inverted.max(scene.step().unwrap().inverted);
    }
    let height = scene.positions().map(|p| p[2]).fold(f32::MIN, f32::max) - (zmin - 0.05);
    let crushed = edge_error(&scene, &mesh);
    assert_finite(&scene);
    // Raise the stiffness to 1 MPa over 0.5 s, as an operator turning a knob,
    // then let it settle for 3 s.
    for step in 0..3500 {
        if step <= 500 {
            scene.set_young_all(1.0e6 * step as f32 / 500.0).unwrap();
        }
        max_inverted = max_inverted.max(scene.step().unwrap().inverted);
    }
    assert_finite(&scene);
    let below = scene.positions().map(|p| p[2]).fold(f32::MAX, f32::min) - (zmin - 0.05);
    let out = Crushed {
        height,
        crushed,
        max_inverted,
        err: edge_error(&scene, &mesh),
        inverted: scene.inverted_count(),
        below,
        ke: scene.kinetic_energy(),
    };
    eprintln!(
        "bunny, {method:?}: crushed to {:.4} m high (edge error {:.2}), up to {} inverted; stiffened: edge error {:.2e}, {} inverted, lowest node {:.2e} m above ground, kinetic energy {:.2e} J",
        out.height, out.crushed, out.max_inverted, out.err, out.inverted, out.below, out.ke
    );
    // Zero stiffness must crush it flat.
    assert!(out.height < 0.01, "{method:?}: {}", out.height);
    // Resting on the ground, not sunk into it (f32 round-off of the plane test),
    // and at rest: the kinetic energy left is tiny next to the
    // potential energy (~1 J) a 1 kg bunny gains by standing up 0.1 m.
    assert!(out.below > -1e-5, "{method:?}: {}", out.below);
    assert!(out.ke < 1e-3, "{method:?}: {}", out.ke);
    assert_eq!(out.inverted, 0, "{method:?}");
    out
}

#[test]
#[cfg_attr(not(shared_meshes), ignore = "needs ../shared/meshes")]
fn zero_stiffness_bunny_crushed_on_the_ground_recovers_when_stiffened() {
    let out = crush_and_stiffen(Method::Qr);
    // Raised to E = 1 MPa under gravity the bunny sags by ρ g H / E ≈ 1e-3
    // on average, more where it rests on the few nodes touching the ground
    // (measured worst edge 2.1%). Bound: 5% on the worst edge of 6000.
    assert!(out.err < 0.05, "{}", out.err);
}

/// The same with the methods that turn inverted elements by the closest
/// rotation. They stand up too, but settle with more residual strain near
/// the ground (measured: worst edge 5.35% with `QrInvertible`, 5.75% with
/// `Polar`, against 2.06% with `Qr`; 30-odd elements above 2% against 3).
/// The bound: recovered from the crush (worst edge 0.99) to within 10%.
#[test]
#[cfg_attr(not(shared_meshes), ignore = "needs ../shared/meshes")]
fn zero_stiffness_bunny_recovers_with_the_closest_rotation_methods() {
    for method in [Method::QrInvertible, Method::Polar] {
        let out = crush_and_stiffen(method);
        assert!(out.err < 0.10, "{method:?}: {}", out.err);
    }
}

#[test]
fn single_tetrahedron_pushed_flat_and_through_itself_recovers() {
    let mesh = CoreMesh {
        nodes: vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.2, 0.3, 1.0],
        ],
        tets: vec![[0, 1, 2, 3]],
    };
    for method in [Method::Qr, Method::Polar] {
        for (case, z) in [("flat", 0.0f32), ("through itself", -0.8)] {
            let mut scene = mesh.scene(&Material {
                young: 1.0e5,
                poisson: 0.3,
                density: 1000.0,
            });
            scene
                .set_settings(Settings {
                    method,
                    dt: 1e-3,
                    cg_iterations: 10,
                    rayleigh_mass: 50.0,
                    gravity: [0.0; 3],
                    ..Settings::default()
                })
                .unwrap();
            scene.fix_nodes(&[0, 1, 2]).unwrap();
            let mut x = mesh.nodes.clone();
            x[3] = [0.5, 0.1, z];
            scene.set_positions(&x).unwrap();
            for _ in 0..3000 {
                scene.step().unwrap();
            }
            let d = scene.position(3).unwrap();
            let err = f64v::norm([d[0] as f64 - 0.2, d[1] as f64 - 0.3, d[2] as f64 - 1.0]);
            eprintln!("{method:?}, {case}: node d ends {err:.2e} m from rest");
            // k ≈ E·L = 1e5 N/m on m = ρV/4 ≈ 42 kg: ω ≈ 50 rad/s; α_M = 50 damps
            // at ζ ≈ 0.5, so after 3 s the error is far below 1e-3.
            assert!(err < 1e-3, "{method:?} {case}: {err}");
        }
    }
}

/// Bodies dropped on the ground, or set down on it, with the default
/// method and solver (5 CG iterations, on its side the default 4, no
/// damping): the stiff, nearly incompressible drop with a long step, on
/// its feet and on its side (where it lands on one point and turns), the
/// soft one, the
/// 50 ms step and the spinning drop land whole and end with no inverted
/// element; the elastic energy never exceeds the energy the body started
/// with (kinetic, plus potential above the ground); the one set down at
/// rest sags as the 200-iteration solve does.
#[test]
#[cfg_attr(not(shared_meshes), ignore = "needs ../shared/meshes")]
fn bodies_dropped_on_the_ground_land_whole_with_the_default_settings() {
    // The bunny stands on its feet with y up (its mesh's up), and lies on
    // its side with z up.
    let mesh = shared_mesh("bunny_ftw_3k.tetmesh");
    // (case, E, ν, dt, seconds, drop height, velocity, spin, CG iterations, up)
    type Case = (&'static str, f32, f32, f32, f32, f32, f32, f32, u32, usize);
    let run = |&(name, young, poisson, dt, seconds, height, speed, spin, cg, up): &Case| {
        let lowest = mesh.nodes.iter().map(|p| p[up]).fold(f32::MAX, f32::min);
        let mut normal = [0.0f32; 3];
        normal[up] = 1.0;
        let mut scene = mesh.scene(&Material {
            young,
            poisson,
            density: 1000.0,
        });
        scene
            .set_settings(Settings {
                dt,
                cg_iterations: cg,
                gravity: [-9.81 * normal[0], -9.81 * normal[1], -9.81 * normal[2]],
                ..Settings::default()
            })
            .unwrap();
        scene
            .set_ground(Some(Plane {
                normal,
                offset: lowest - height,
            }))
            .unwrap();
        let nodes: Vec<[f32; 3]> = scene.positions().collect();
        let masses: Vec<f32> = (0..nodes.len() as u32)
            .map(|i| scene.mass(i).unwrap())
            .collect();
        let mass: f64 = masses.iter().map(|&m| m as f64).sum();
        let c: Vec<f64> = (0..3)
            .map(|k| {
                nodes
                    .iter()
                    .zip(&masses)
                    .map(|(p, &m)| p[k] as f64 * m as f64)
                    .sum::<f64>()
                    / mass
            })
            .collect();
        let v: Vec<[f32; 3]> = nodes
            .iter()
            .map(|p| {
                // Spin about the horizontal z axis: it tumbles as it falls
                // (the cases with spin stand y up).
                let r = [p[0] - c[0] as f32, p[1] - c[1] as f32];
                let mut v = [-spin * r[1], spin * r[0], 0.0];
                v[up] -= speed;
                v
            })
            .collect();
        scene.set_velocities(&v).unwrap();
        let start =
            scene.kinetic_energy() as f64 + mass * 9.81 * (c[up] - (lowest - height) as f64);
        let (mut max_elastic, mut late_elastic) = (0.0f64, 0.0f64);
        let steps = (seconds / dt).round() as usize;
        for k in 0..steps {
            let stats = scene.step().unwrap();
            max_elastic = max_elastic.max(stats.elastic_energy as f64);
            if 3 * k >= steps {
                late_elastic = late_elastic.max(stats.elastic_energy as f64);
            }
        }
        assert_finite(&scene);
        let (ke, inverted, elastic) = (
            scene.kinetic_energy() as f64,
            scene.inverted_count(),
            scene.elastic_energy() as f64,
        );
        eprintln!(
            "{name}: energy at the start {start:.3e} J, largest elastic {max_elastic:.3e} J, over the last two thirds {late_elastic:.3e} J; at the end: {inverted} inverted, elastic {elastic:.3e} J, kinetic {ke:.3e} J"
        );
        (start, max_elastic, inverted, elastic, ke, late_elastic)
    };
    let drops: [Case; 5] = [
        ("stiff, dt 10 ms", 1e8, 0.49, 1e-2, 1.0, 0.3, 0.0, 0.0, 5, 1),
        (
            "stiff, on its side, dt 10 ms",
            1e8,
            0.49,
            1e-2,
            2.0,
            0.3,
            0.0,
            0.0,
            4,
            2,
        ),
        ("soft, dt 5 ms", 5e3, 0.49, 5e-3, 2.0, 0.3, 0.0, 0.0, 5, 1),
        ("dt 50 ms", 1e5, 0.3, 5e-2, 3.0, 0.3, 0.0, 0.0, 5, 1),
        (
            "spinning, dt 2 ms",
            2e4,
            0.45,
            2e-3,
            1.5,
            0.1,
            2.0,
            20.0,
            5,
            1,
        ),
    ];
    for case in &drops {
        let (start, max_elastic, inverted, _, ke, late) = run(case);
        assert_eq!(inverted, 0, "{}", case.0);
        // The ground does no work on the body and gravity's is in `start`:
        // the body can hold no more than it started with (measured: at most
        // 7 % of it, the stiff bunny on its side; landed node by node, the
        // stiff bunny held 1.6e7 times it, and on its side, moved along its
        // tangents while it turned, 4.8 times with 4 CG iterations).
        assert!(max_elastic < start, "{}: {max_elastic} J", case.0);
        // At rest: under 1e-3 of the start energy still moving (measured:
        // at most 3.3e-5 of it; 1.3e-2 for the stiff bunny landed node by
        // node, still shaking). The spinning bunny may still rock or slide:
        // the ground is frictionless.
        if case.7 == 0.0 {
            assert!(ke < 1e-3 * start, "{}: {ke} J", case.0);
            // Down and resting (the last two thirds of the run), a body
            // holds its sag and whatever its contacts' coming and going
            // leaves: at most a tenth of the fall's energy (measured: at
            // most 1.8 %, the soft bunny's sag; the stiff bunny on its
            // side, pushed out of the ground node by node, held 53 %).
            assert!(late < 0.1 * start, "{}: {late} J once down", case.0);
        }
    }
    // Set down on the ground: the sag's elastic energy after 2 s against
    // the same run with 200 CG iterations.
    let rest = ("resting", 5e4, 0.3, 5e-3, 2.0, 0.0, 0.0, 0.0, 5, 1);
    let (_, _, inverted, elastic, _, _) = run(&rest);
    let (_, _, _, reference, _, _) = run(&(
        "resting, 200 CG",
        5e4,
        0.3,
        5e-3,
        2.0,
        0.0,
        0.0,
        0.0,
        200,
        1,
    ));
    assert_eq!(inverted, 0);
    // Over the last 0.5 s the 5-iteration run still swings by ±1.6 % about
    // its sag and the 200-iteration run by 0.4 % (measured on the same
    // scene with host-tests/ground/run.py, a record every 50 ms); 5 % is
    // three times that swing. Started from the free fall, the 5-iteration
    // run ended at twice the reference.
    assert!(
        (elastic / reference - 1.0).abs() < 0.05,
        "{elastic} J against {reference} J"
    );
}
