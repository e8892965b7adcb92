//! Rigid probes in contact with the body: the boundary they touch, no
//! penetration, the balance of forces at rest, momentum against the probe's
//! impulse, the sweep of a fast probe, bad input.

use corofem::{Error, Material, Parameter, Plane, Probe, Settings, StepError, VecScene};
use corofem_host_tests::{box_mesh, penetration, CoreMesh};

/// A soft block, 4 × 4 × 2 cm, 6 tetrahedra per cell, its bottom at z = 0.
fn block(cells: [u32; 3]) -> (CoreMesh, VecScene) {
    let mesh = box_mesh([0.04, 0.04, 0.02], cells, 6);
    let scene = mesh.scene(&Material {
        young: 2.0e4,
        poisson: 0.3,
        density: 1000.0,
    });
    (mesh, scene)
}

/// The block's total mass (kg).
fn total_mass(scene: &VecScene) -> f64 {
    (0..scene.node_count() as u32)
        .map(|i| f64::from(scene.mass(i).unwrap()))
        .sum()
}

#[test]
fn boundary_nodes_are_those_on_the_box_faces() {
    let (mesh, scene) = block([4, 4, 3]);
    let on_face = |p: [f32; 3]| {
        let edge = |x: f32, size: f32| x.abs() < 1e-7 || (x - size).abs() < 1e-7;
        edge(p[0], 0.04) || edge(p[1], 0.04) || edge(p[2], 0.02)
    };
    let mut interior = 0;
    for (i, p) in mesh.nodes.iter().enumerate() {
        assert_eq!(
            scene.on_boundary(i as u32),
            on_face(*p),
            "node {i} at {p:?}"
        );
        interior += usize::from(!on_face(*p));
    }
    // 3 × 3 × 2 interior grid points.
    assert_eq!(interior, 18);
}

/// A block on the ground, a sphere pressed 4 mm into its top and held:
/// no boundary node ends inside the probe, and at rest the ground carries
/// the weight plus the probe's push.
#[test]
fn a_sphere_pressed_into_a_block_on_the_ground() {
    let (_, mut scene) = block([6, 6, 3]);
    scene.set_ground(Some(Plane::Z_UP)).unwrap();
    let h = 1e-3;
    scene
        .set_settings(Settings {
            dt: h,
            // Damping brings the block to rest in the run's 1.5 s.
            rayleigh_mass: 20.0,
            ..scene.default_settings()
        })
        .unwrap();
    let radius = 0.01;
    let top = [0.02, 0.02, 0.02 + radius];
    let mut probes = [Probe::sphere(radius, top).unwrap()];
    let depth = 0.004;
    let steps = 1500;
    let press = 500;
    let speed = depth / (press as f32 * h);
    let (mut worst, mut fastest) = (0.0f32, 0.0f32);
    let mut last = None;
    for k in 1..=steps {
        let z = top[2] - depth * (k.min(press) as f32 / press as f32);
        probes[0].move_to([0.02, 0.02, z], [0.0, 0.0, 1.0]).unwrap();
        last = Some(scene.step_with_probes(&mut probes).unwrap());
        worst = worst.max(penetration(&scene, &probes[0]));
        for v in scene.velocities() {
            fastest = fastest.max((v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt());
        }
    }
    let stats = last.unwrap();
    // A node the probe holds ends on its surface (to the rounding of its
    // distance); one that comes into contact during a step is stopped and pushed out
    // by the next, so it is inside by at most the distance it and the
    // probe approach in a step (plus the rounding of positions of 0.03 m,
    // ~4e-9 m).
    let bound = (speed + fastest) * h + 1e-8;
    println!("penetration {worst:e} m, bound {bound:e} m");
    assert!(
        worst <= bound,
        "penetration {worst:e} m against {bound:e} m"
    );
    assert!(stats.contacts > 0 && probes[0].contacts() > 0);
    // At rest: support = −(weight + the probe's force on the body), the
    // probe's force on the body being −probe.force().
    let weight = 9.81 * total_mass(&scene);
    let push = f64::from(probes[0].force()[2]);
    let support = stats.support_force;
    println!(
        "weight {weight:.5} N, probe push {push:.5} N, support {:?} N, contacts {} (probe {})",
        support,
        stats.contacts,
        probes[0].contacts()
    );
    assert!(push > 0.0, "the body pushes the probe up");
    let balance = f64::from(support[2]) - (weight + push);
    // The block is at rest to ~1e-7 m/s after 1 s of damping at 20/s, and
    // its solve is truncated: the balance holds to the solve's residual,
    // a fraction of a percent of the forces.
    assert!(
        balance.abs() <= 5e-3 * (weight + push),
        "balance {balance:e} N of {:e}",
        weight + push
    );
    assert!(f64::from(support[0]).abs() <= 1e-3 * (weight + push));
    assert!(f64::from(support[1]).abs() <= 1e-3 * (weight + push));
}

/// With a frictionless probe and nothing else acting (no gravity, no
/// ground, no fixed node), the body's momentum changes by exactly the
/// impulse of the probe's force: what the probe takes, the body gets.
#[test]
fn momentum_changes_by_the_probe_impulse() {
    let (_, mut scene) = block([4, 4, 2]);
    let h = 1e-3;
    scene
        .set_settings(Settings {
            dt: h,
            gravity: [0.0; 3],
            // A converged solve: the balance is exact up to its residual.
            cg_iterations: 400,
            cg_tolerance: 1e-6,
            ..scene.default_settings()
        })
        .unwrap();
    let momentum = |s: &VecScene| {
        let mut p = [0.0f64; 3];
        for i in 0..s.node_count() as u32 {
            let (m, v) = (s.mass(i).unwrap() as f64, s.velocity(i).unwrap());
            for k in 0..3 {
                p[k] += m * v[k] as f64;
            }
        }
        p
    };
    // A capsule hits the block's side, moving in x and turning.
    let radius = 0.006;
    let mut probes =
        [Probe::capsule(radius, 0.01, [-radius, 0.02, 0.01], [0.0, 1.0, 0.0]).unwrap()];
    let mut impulse = [0.0f64; 3];
    for k in 1..=200 {
        let t = k as f32 * h;
        let axis = [0.3 * t, 1.0, 0.0];
        probes[0]
            .move_to([-radius + 0.05 * t, 0.02, 0.01], axis)
            .unwrap();
        scene.step_with_probes(&mut probes).unwrap();
        for (j, f) in impulse.iter_mut().zip(probes[0].force()) {
            *j -= f64::from(f) * f64::from(h);
        }
    }
    let p = momentum(&scene);
    println!("momentum {p:?}, probe impulse on the body {impulse:?}");
    assert!(impulse[0] > 0.0, "the probe pushed the block along x");
    let size = f64v_norm(impulse);
    for i in 0..3 {
        // The solve's residual (1e-6 of its start in the mass norm) is the
        // only impulse not counted; 1e-4 of the impulse leaves room for the
        // f32 sums over 200 steps.
        assert!(
            (p[i] - impulse[i]).abs() <= 1e-4 * size,
            "component {i}: momentum {} against impulse {}",
            p[i],
            impulse[i]
        );
    }
}

fn f64v_norm(a: [f64; 3]) -> f64 {
    (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
}

/// A probe that moves through a thin plate in one step pushes its nodes
/// ahead of it instead of leaving them behind (the sweep).
#[test]
fn a_fast_probe_does_not_tunnel_through_a_thin_plate() {
    let mesh = box_mesh([0.04, 0.04, 0.002], [8, 8, 1], 6);
    let mut scene = mesh.scene(&Material::default());
    let corners =
        mesh.select(|p| (p[0] < 1e-6 || p[0] > 0.04 - 1e-6) && (p[1] < 1e-6 || p[1] > 0.04 - 1e-6));
    scene.fix_nodes(&corners).unwrap();
    let h = 1e-3;
    scene
        .set_settings(Settings {
            dt: h,
            gravity: [0.0; 3],
            ..scene.default_settings()
        })
        .unwrap();
    let radius = 0.005;
    let mut probes = [Probe::sphere(radius, [0.02, 0.02, 0.002 + 2.0 * radius]).unwrap()];
    // 25 mm in one step: from 1 cm above the plate to 1.5 cm below it.
    let end = [0.02, 0.02, 0.002 - 0.015];
    probes[0].move_to(end, [0.0, 0.0, 1.0]).unwrap();
    let stats = scene.step_with_probes(&mut probes).unwrap();
    assert!(stats.contacts > 0);
    // The nodes the probe passed over (within its radius of its path) are
    // below its centre's end, on its front side.
    let mut passed = 0;
    for i in 0..mesh.nodes.len() as u32 {
        let p0 = mesh.nodes[i as usize];
        let r = ((p0[0] - 0.02).powi(2) + (p0[1] - 0.02).powi(2)).sqrt();
        if r < 0.5 * radius {
            passed += 1;
            let p = scene.position(i).unwrap();
            assert!(p[2] < end[2], "node {i} left behind at {p:?}");
            assert!(probes[0].distance(p) >= -1e-6, "node {i} inside at {p:?}");
        }
    }
    assert!(passed > 0);
}

/// A probe whose first step would start inside the body is refused, with
/// the scene and the probe unchanged; placed outside, it steps.
#[test]
fn a_probe_may_not_start_inside_the_body() {
    let (_, mut scene) = block([6, 6, 3]);
    // A sphere whose centre is 2 mm below the top face: 8 mm of it is in.
    let mut probes = [Probe::sphere(0.01, [0.02, 0.02, 0.018]).unwrap()];
    let (hash, kept) = (scene.state_hash(), probes);
    match scene.step_with_probes(&mut probes) {
        Err(StepError::ProbeInsideBody {
            probe: 0,
            node: Some(node),
        }) => {
            assert!(probes[0].distance(scene.position(node).unwrap()) < 0.0)
        }
        other => panic!("{other:?}"),
    }
    assert_eq!((scene.state_hash(), probes), (hash, kept));
    // Moving it out in its first step does not help: the step starts
    // where it was made.
    probes[0]
        .move_to([0.02, 0.02, 0.05], [0.0, 0.0, 1.0])
        .unwrap();
    assert!(scene.step_with_probes(&mut probes).is_err());
    // Placed touching the top face, it steps.
    probes[0]
        .place([0.02, 0.02, 0.03], [0.0, 0.0, 1.0])
        .unwrap();
    scene.step_with_probes(&mut probes).unwrap();
}

/// A probe inside the body that reaches no boundary node is refused too,
/// and so is a thin capsule run through it between the surface's nodes:
/// their axes meet elements. Placed outside, each steps.
#[test]
fn a_probe_wholly_inside_or_through_the_body_is_refused() {
    let (_, mut scene) = block([6, 6, 3]);
    // Cells of 6.7 mm: the nearest boundary node is 10 mm from the centre,
    // and 3.3 mm from the thin capsule's axis.
    let centre = [0.02, 0.02, 0.01];
    let inside = [
        Probe::sphere(0.003, centre).unwrap(),
        Probe::capsule(0.003, 0.005, centre, [1.0, 0.0, 0.0]).unwrap(),
        Probe::capsule(0.001, 0.03, centre, [1.0, 0.0, 0.0]).unwrap(),
    ];
    for (k, p) in inside.into_iter().enumerate() {
        // Second in the slice, behind a probe well outside.
        let mut probes = [Probe::sphere(0.005, [0.02, 0.02, 0.1]).unwrap(), p];
        let (hash, kept) = (scene.state_hash(), probes);
        assert_eq!(
            scene.step_with_probes(&mut probes),
            Err(StepError::ProbeInsideBody {
                probe: 1,
                node: None
            }),
            "probe {k}"
        );
        assert_eq!((scene.state_hash(), probes), (hash, kept), "probe {k}");
        // Above the block, clear of it.
        probes[1]
            .place([0.02, 0.02, 0.05], [1.0, 0.0, 0.0])
            .unwrap();
        scene.step_with_probes(&mut probes).unwrap();
        scene.reset_state();
    }
}

#[test]
fn bad_probes_are_refused_and_leave_the_probe_unchanged() {
    let bad_radius = Error::InvalidParameter {
        parameter: Parameter::ProbeRadius,
    };
    for r in [0.0, -1.0, f32::NAN, f32::INFINITY] {
        assert_eq!(Probe::sphere(r, [0.0; 3]), Err(bad_radius));
    }
    assert_eq!(
        Probe::capsule(0.01, -1.0, [0.0; 3], [1.0, 0.0, 0.0]),
        Err(Error::InvalidParameter {
            parameter: Parameter::ProbeHalfLength
        })
    );
    let bad_pose = Err(Error::InvalidParameter {
        parameter: Parameter::ProbePose,
    });
    assert_eq!(Probe::sphere(0.01, [f32::NAN, 0.0, 0.0]), bad_pose);
    assert_eq!(Probe::capsule(0.01, 0.1, [0.0; 3], [0.0; 3]), bad_pose);
    let mut p = Probe::capsule(0.01, 0.1, [1.0, 2.0, 3.0], [0.0, 0.0, 2.0]).unwrap();
    assert_eq!(p.axis(), [0.0, 0.0, 1.0]);
    let kept = p;
    assert_eq!(
        p.move_to([0.0, f32::INFINITY, 0.0], [0.0, 0.0, 1.0]),
        bad_pose.map(|_: Probe| ())
    );
    assert_eq!(
        p.move_to([0.0; 3], [f32::NAN, 0.0, 1.0]),
        bad_pose.map(|_: Probe| ())
    );
    assert_eq!(p, kept);

    // More probes than a step takes: refused, nothing changes.
    let (_, mut scene) = block([2, 2, 1]);
    let hash = scene.state_hash();
    let mut many = vec![Probe::sphere(0.01, [1.0, 1.0, 1.0]).unwrap(); corofem::MAX_PROBES + 1];
    assert_eq!(
        scene.step_with_probes(&mut many),
        Err(StepError::TooManyProbes)
    );
    assert_eq!(scene.state_hash(), hash);
}

/// A block hanging from fixed nodes, at rest: the fixed nodes carry its
/// weight, and no probe or ground is needed for the support force.
#[test]
fn fixed_nodes_carry_the_weight_of_a_hanging_block() {
    let (mesh, mut scene) = block([4, 4, 2]);
    let top = mesh.select(|p| p[2] > 0.02 - 1e-6);
    scene.fix_nodes(&top).unwrap();
    scene
        .set_settings(Settings {
            dt: 1e-3,
            rayleigh_mass: 50.0,
            ..scene.default_settings()
        })
        .unwrap();
    let mut stats = scene.step().unwrap();
    for _ in 0..1000 {
        stats = scene.step().unwrap();
    }
    let weight = 9.81 * total_mass(&scene);
    let support = stats.support_force;
    println!("weight {weight:.6} N, support {support:?} N");
    // At rest (1 s of damping at 50/s) the fixed nodes' forces balance the
    // weight to the truncated solve's residual, a fraction of a percent.
    assert!((f64::from(support[2]) - weight).abs() <= 5e-3 * weight);
    assert!(f64::from(support[0]).abs() <= 1e-3 * weight);
    assert!(f64::from(support[1]).abs() <= 1e-3 * weight);
}

/// A sphere pressed aslant onto the edge of a stiff clamped beam and held
/// there keeps its contact at every step. The beam's push at the touching
/// node is hundreds of newtons, so a node let go for a single step would
/// be driven millimetres into the sphere, and the force a device renders
/// would flicker between the push and almost nothing.
#[test]
fn a_probe_held_on_a_stiff_beam_keeps_its_contact() {
    // The web demo's beam: 1 × 0.2 × 0.2 m, E = 2 MPa, clamped at x = 0,
    // with its stiffness damping; no gravity, the default solver at 2 ms.
    let mesh = box_mesh([1.0, 0.2, 0.2], [20, 4, 4], 6);
    let mut scene = mesh.scene(&Material {
        young: 2.0e6,
        poisson: 0.3,
        density: 1000.0,
    });
    scene.fix_nodes(&mesh.select(|p| p[0] < 1e-6)).unwrap();
    let h = 2e-3;
    scene
        .set_settings(Settings {
            dt: h,
            rayleigh_stiffness: 0.01,
            gravity: [0.0; 3],
            ..scene.default_settings()
        })
        .unwrap();
    // Along a view from above and to the side, towards the top edge at
    // y = 0, 1 cm beside the node at x = 0.25; 3 cm deep at 0.5 m/s.
    let dir = [-0.434_696_8, 0.814_245_3, -0.384_763_8];
    let radius = 0.06;
    let end = [0.26, 0.001, 0.239];
    let (depth, speed) = (0.03, 0.5);
    let at = |d: f32| [0, 1, 2].map(|k| end[k] - (depth - d) * dir[k]);
    let mut probes = [Probe::sphere(radius, at(0.0)).unwrap()];
    let press = (depth / (speed * h)).ceil() as u32;
    let (mut worst, mut fastest) = (0.0f32, 0.0f32);
    let (mut least, mut most) = (f32::INFINITY, 0.0f32);
    for k in 1..=press + 250 {
        let d = (k as f32 * speed * h).min(depth);
        probes[0].move_to(at(d), [0.0, 0.0, 1.0]).unwrap();
        scene.step_with_probes(&mut probes).unwrap();
        for v in scene.velocities() {
            fastest = fastest.max((v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt());
        }
        if k > press {
            assert!(
                probes[0].contacts() > 0,
                "step {k}: no node touches the held probe"
            );
            let f = probes[0].force();
            let f = (f[0] * f[0] + f[1] * f[1] + f[2] * f[2]).sqrt();
            (least, most) = (least.min(f), most.max(f));
            worst = worst.max(penetration(&scene, &probes[0]));
        }
    }
    // A node that comes into contact in a step is inside by at most the
    // distance it approaches the still probe in that step (plus the
    // rounding of positions of 1 m, ~5e-7 m).
    let bound = fastest * h + 1e-6;
    println!("held: force {least:.1}..{most:.1} N, penetration {worst:e} m (bound {bound:e} m)");
    assert!(
        worst <= bound,
        "penetration {worst:e} m against {bound:e} m"
    );
    // The beam vibrates under the held sphere (its damping is light), so
    // the force varies; it never drops to a fraction of itself.
    assert!(least > 0.5 * most, "force between {least} and {most} N");
}
