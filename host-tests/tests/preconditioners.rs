//! The preconditioners solve the same system: converged, every one gives the
//! same step; truncated, the two-level one stays close to the converged
//! steps where the lumped mass does not. Measured on the liver (a soft body
//! hanging from its top, gravity), against converged steps of this code
//! (the converged steps themselves match an independent f64 implicit Euler,
//! `cg_direct.rs`).

use corofem::{Material, Method, Preconditioner, Settings, VecScene};
use corofem_host_tests::{shared_mesh, CoreMesh};

/// The report's liver: SOFA's liver scaled to ~0.2 m (× 0.03), soft
/// (E = 30 kPa, ν = 0.45), hanging from its three pins under gravity.
fn hanging(mesh: &CoreMesh, pre: Preconditioner, cg_iterations: u32, warm: bool) -> VecScene {
    let small = CoreMesh {
        nodes: mesh.nodes.iter().map(|p| p.map(|x| x * 0.03)).collect(),
        tets: mesh.tets.clone(),
    };
    let mut s = small.scene(&Material {
        young: 3.0e4,
        poisson: 0.45,
        density: 1000.0,
    });
    s.fix_nodes(&[3, 39, 64]).unwrap();
    s.set_settings(Settings {
        method: Method::Qr,
        dt: 1.0e-3,
        cg_iterations,
        // Tolerance 0: the budget alone stops a truncated solve; a
        // converged one stops at CG's round-off floor.
        cg_tolerance: 0.0,
        rayleigh_mass: 1.0,
        rayleigh_stiffness: 0.01,
        warm_start: warm,
        preconditioner: pre,
        gravity: [0.0, -9.81, 0.0],
        energy_guard: true,
        free_rotation: true,
        friction_damping: Settings::new().friction_damping,
        contact_rounds: Settings::new().contact_rounds,
    })
    .unwrap();
    s
}

fn displacements(s: &VecScene) -> Vec<[f64; 3]> {
    (0..s.node_count() as u32)
        .map(|i| s.displacement(i).unwrap().map(f64::from))
        .collect()
}

/// Relative RMS difference of two trajectories (lists of displacements).
fn relative(a: &[Vec<[f64; 3]>], b: &[Vec<[f64; 3]>]) -> f64 {
    let (mut num, mut den) = (0.0f64, 0.0f64);
    for (fa, fb) in a.iter().zip(b) {
        for (x, y) in fa.iter().zip(fb) {
            for k in 0..3 {
                num += (x[k] - y[k]).powi(2);
                den += y[k].powi(2);
            }
        }
    }
    (num / den).sqrt()
}

fn trajectory(mut s: VecScene, steps: usize) -> Vec<Vec<[f64; 3]>> {
    (0..steps)
        .map(|_| {
            s.step().expect("the hanging liver steps");
            displacements(&s)
        })
        .collect()
}

#[test]
#[cfg_attr(not(shared_meshes), ignore = "needs ../shared/meshes")]
fn converged_solves_agree_whatever_the_preconditioner() {
    let mesh = shared_mesh("sofa_liver.tetmesh");
    let steps = 20;
    let reference = trajectory(hanging(&mesh, Preconditioner::Mass, 500, false), steps);
    for pre in [Preconditioner::BlockJacobi, Preconditioner::TwoLevel] {
        let t = trajectory(hanging(&mesh, pre, 500, false), steps);
        let d = relative(&t, &reference);
        eprintln!("{pre:?}: {d:.2e} from the mass-preconditioned converged steps");
        // Both stop at CG's f32 round-off floor (rᵀz below ε² of its
        // start): what remains is round-off of the f32 products, a few ε
        // relative (2e-7 measured); 1e-5 leaves room for its growth over
        // the steps and still catches a preconditioner that changes the
        // system (a lost filter or a wrong block moves the answer by far
        // more).
        assert!(d < 1.0e-5, "{pre:?} converges elsewhere: {d:.2e}");
    }
}

#[test]
#[cfg_attr(not(shared_meshes), ignore = "needs ../shared/meshes")]
fn three_two_level_iterations_stay_within_a_percent_of_converged_steps() {
    let mesh = shared_mesh("sofa_liver.tetmesh");
    let steps = 100;
    let reference = trajectory(hanging(&mesh, Preconditioner::Mass, 500, false), steps);
    let two_level = relative(
        &trajectory(hanging(&mesh, Preconditioner::TwoLevel, 3, true), steps),
        &reference,
    );
    let mass = relative(
        &trajectory(hanging(&mesh, Preconditioner::Mass, 5, false), steps),
        &reference,
    );
    eprintln!("relative RMS error over {steps} steps: two-level, 3 warm {two_level:.2e}; mass, 5 {mass:.2e}");
    // The accuracy goal of the step: 1 % of the converged implicit steps.
    assert!(
        two_level < 1.0e-2,
        "two-level, 3 iterations: {two_level:.2e}"
    );
    // And the reason for the preconditioner: the paper's CG at five
    // iterations misses the sag of this soft body by far more.
    assert!(mass > 1.0e-1, "mass, 5 iterations: {mass:.2e}");
}

/// `steps` steps of `s`, then the bits of its displacements.
fn bits_after_steps(mut s: VecScene, steps: usize) -> Vec<[u32; 3]> {
    for _ in 0..steps {
        s.step().expect("the hanging liver steps");
    }
    (0..s.node_count() as u32)
        .map(|i| s.displacement(i).unwrap().map(f32::to_bits))
        .collect()
}

#[test]
#[cfg_attr(not(shared_meshes), ignore = "needs ../shared/meshes")]
fn settings_that_leave_the_system_matrix_keep_the_coarse_factor() {
    let mesh = shared_mesh("sofa_liver.tetmesh");
    // The factor is prepared on the first step, at rest. Prepared again at
    // the sagged state of step 5, it would differ, and so would the bits of
    // the steps after it.
    let mut plain = hanging(&mesh, Preconditioner::TwoLevel, 3, true);
    let mut touched = hanging(&mesh, Preconditioner::TwoLevel, 3, true);
    for _ in 0..5 {
        plain.step().unwrap();
        touched.step().unwrap();
    }
    let same = *touched.settings();
    // Gravity, the budget and the warm start changed and changed back.
    touched
        .set_settings(Settings {
            gravity: [1.0, 2.0, 3.0],
            cg_iterations: 7,
            warm_start: false,
            ..same
        })
        .unwrap();
    touched.set_settings(same).unwrap();
    assert_eq!(
        bits_after_steps(plain.clone(), 10),
        bits_after_steps(touched, 10),
        "the factor was prepared again"
    );
    // A time step changed and changed back does prepare it again (at the
    // sagged state): the test above can see a rebuild.
    let mut rebuilt = plain.clone();
    rebuilt
        .set_settings(Settings { dt: 2.0e-3, ..same })
        .unwrap();
    rebuilt.set_settings(same).unwrap();
    assert_ne!(
        bits_after_steps(plain, 10),
        bits_after_steps(rebuilt, 10),
        "a changed time step left the factor as it was"
    );
}
