//! The firmware example's scene on the host: the same code
//! (`corofem_test_scenes::firmware`) that runs on the Cortex-M4F in QEMU
//! and in the wasm module. Each size prints one
//! `firmware-scene` line; `.ci/firmware.sh` compares their hashes with the
//! firmware's and the wasm module's, which must be bit-identical.

use corofem::Preconditioner;
use corofem_test_scenes::firmware::{self as scene, ContactSet};

fn run(cells: [u32; 3]) -> scene::Outcome {
    run_with(cells, Preconditioner::Mass)
}

/// The scene with `pre`; prints `firmware-scene` (the mass preconditioner)
/// or `firmware-scene-two-level`, the line `.ci/firmware.sh` reads.
fn run_with(cells: [u32; 3], pre: Preconditioner) -> scene::Outcome {
    let (mut s, start) = set_up(cells, pre);
    let (n, t) = (s.node_count(), s.element_count());
    let out = scene::run(&mut s, start, |s, target| s.step_haptic(target)).expect("steps");
    println!(
        "firmware-scene{} cells={}x{}x{} nodes={n} tets={t} hash={:#018x} peak_push={:.4} N final_force=[{:.4}, {:.4}, {:.4}] N",
        if pre == Preconditioner::Mass { "" } else { "-two-level" },
        cells[0],
        cells[1],
        cells[2],
        out.hash,
        out.peak_push,
        out.final_force[0],
        out.final_force[1],
        out.final_force[2],
    );
    out
}

#[test]
fn firmware_scene_is_plausible_at_every_size() {
    for cells in scene::SIZES {
        let out = run(cells);
        assert_eq!(scene::check(&out), Ok(()), "{cells:?}: {out:?}");
    }
}

#[test]
fn firmware_scene_golden_hash() {
    // Recorded on x86_64 (rustc 1.95); the firmware (thumbv7em-none-eabihf,
    // with and without `fpu-sqrt`) and wasm32 print the same value.
    let out = run(scene::REFERENCE);
    assert_eq!(out.hash, 0x70cc_9f3f_9a04_7405, "{:#018x}", out.hash);
}

#[test]
fn firmware_scene_with_two_level_is_plausible_at_every_size() {
    for cells in scene::SIZES {
        let out = run_with(cells, Preconditioner::TwoLevel);
        assert_eq!(
            scene::check_with(&out, Preconditioner::TwoLevel),
            Ok(()),
            "{cells:?}: {out:?}"
        );
    }
}

#[test]
fn firmware_scene_with_two_level_golden_hash() {
    // Recorded on x86_64 (rustc 1.95); the firmware's two-level build
    // (thumbv7em-none-eabihf) prints the same value.
    let out = run_with(scene::REFERENCE, Preconditioner::TwoLevel);
    assert_eq!(out.hash, 0x9b83_2cbe_988a_e1eb, "{:#018x}", out.hash);
}

/// The reference scene in contact with the obstacles of `set`; prints
/// `firmware-scene-<set>` (`firmware-scene-ground`, ...), the lines
/// `.ci/firmware.sh` compares with the firmware's contact builds.
fn run_contact(set: ContactSet) -> (scene::Outcome, scene::Contacts) {
    let cells = scene::REFERENCE;
    let (mut s, start) = set_up(cells, Preconditioner::Mass);
    let mut contacts = scene::Contacts::setup(&mut s, cells, set).expect("obstacles");
    let (n, t) = (s.node_count(), s.element_count());
    let out = scene::run(&mut s, start, |s, target| contacts.step(s, target)).expect("steps");
    println!(
        "firmware-scene-{} cells={}x{}x{} nodes={n} tets={t} hash={:#018x} peak_push={:.4} N contacts={} contact_steps={} cg_iterations={} probe_contacts={} probe_force={:.4} N",
        set.name(),
        cells[0],
        cells[1],
        cells[2],
        out.hash,
        out.peak_push,
        out.max_contacts,
        out.contact_steps,
        out.cg_iterations,
        contacts.probe_max_contacts,
        contacts.probe_peak_force,
    );
    (out, contacts)
}

#[test]
fn firmware_scene_in_contact_is_plausible_and_touches() {
    for set in ContactSet::ALL {
        let (out, contacts) = run_contact(set);
        assert_eq!(
            scene::check_contacts(&out, &contacts, Preconditioner::Mass),
            Ok(()),
            "{set:?}: {out:?} {contacts:?}"
        );
    }
}

#[test]
fn firmware_scene_in_contact_golden_hashes() {
    // Recorded on x86_64 (rustc 1.95); the firmware's builds with the
    // features ground, probe and probe + friction (thumbv7em-none-eabihf)
    // print the same values.
    let golden = [
        (ContactSet::GROUND, 0x4ad0_b5a8_7475_d643),
        (ContactSet::PROBE, 0xb443_086f_06ed_3f02),
        (ContactSet::PROBE_FRICTION, 0x682d_7c2c_0e88_7516),
    ];
    for (set, want) in golden {
        let (out, _) = run_contact(set);
        assert_eq!(out.hash, want, "{}: {:#018x}", set.name(), out.hash);
    }
}

#[test]
fn firmware_scene_without_obstacles_is_the_plain_scene() {
    // `Contacts` with no obstacle steps exactly as `step_haptic`.
    let cells = scene::REFERENCE;
    let (mut s, start) = set_up(cells, Preconditioner::Mass);
    let mut contacts = scene::Contacts::setup(&mut s, cells, ContactSet::NONE).expect("none");
    let out = scene::run(&mut s, start, |s, target| contacts.step(s, target)).expect("steps");
    assert_eq!(out, run(cells));
    assert_eq!(out.contact_steps, 0);
}

/// The scene of `cells` with `pre`, set up: the scene and the tool's start.
fn set_up(cells: [u32; 3], pre: Preconditioner) -> (corofem::VecScene, [f32; 3]) {
    let mesh = scene::mesh(cells);
    let (n, t) = (mesh.node_count(), mesh.tet_count());
    let mut nodes = vec![[0.0f32; 3]; n];
    let mut tets = vec![[0u32; 4]; t];
    let mut s = corofem::VecScene::with_capacity(n, t);
    let start = scene::setup_with(&mut s, cells, &mut nodes, &mut tets, pre).expect("scene builds");
    (s, start)
}

/// Displacements after every step of the reference scene with `pre` and
/// `iterations` CG iterations (`tolerance` 0: the whole budget).
fn trajectory(pre: Preconditioner, iterations: u32, tolerance: f32) -> Vec<Vec<[f64; 3]>> {
    let (mut s, start) = set_up(scene::REFERENCE, pre);
    let n = s.node_count();
    let mut settings = *s.settings();
    settings.cg_iterations = iterations;
    settings.cg_tolerance = tolerance;
    s.set_settings(settings).expect("settings");
    (1..=scene::STEPS)
        .map(|k| {
            s.step_haptic(scene::tool_target(start, k)).expect("step");
            (0..n as u32)
                .map(|i| s.displacement(i).expect("node").map(f64::from))
                .collect()
        })
        .collect()
}

/// Relative RMS difference of two trajectories, over the RMS of `reference`.
fn relative(a: &[Vec<[f64; 3]>], reference: &[Vec<[f64; 3]>]) -> f64 {
    let (mut num, mut den) = (0.0f64, 0.0f64);
    for (p, q) in a.iter().flatten().zip(reference.iter().flatten()) {
        for k in 0..3 {
            num += (p[k] - q[k]).powi(2);
            den += q[k].powi(2);
        }
    }
    (num / den).sqrt()
}

#[test]
fn firmware_scene_two_level_is_as_close_to_converged_steps_as_mass() {
    // Converged steps: CG to a residual of 1e-7 of its start, which f32
    // reaches on this 297-unknown system, with each preconditioner.
    let exact = trajectory(Preconditioner::TwoLevel, 400, 1.0e-7);
    let exact_mass = trajectory(Preconditioner::Mass, 2000, 1.0e-7);
    let reference = relative(&exact_mass, &exact);
    let settings = |p| scene::settings_with(p).cg_iterations;
    let mass = relative(
        &trajectory(Preconditioner::Mass, settings(Preconditioner::Mass), 0.0),
        &exact,
    );
    let two = relative(
        &trajectory(
            Preconditioner::TwoLevel,
            settings(Preconditioner::TwoLevel),
            0.0,
        ),
        &exact,
    );
    println!(
        "firmware scene, error against converged steps: mass {mass:.2e}, two-level {two:.2e} \
         (the two converged references differ by {reference:.2e})"
    );
    // The reference is independent of the preconditioner that reached it
    // to a tenth of the smaller error compared, so that the comparison
    // below is decided by the truncated solves, not by the reference.
    assert!(
        reference < 0.1 * two.min(mass),
        "references differ by {reference:.3e}"
    );
    // The firmware's two-level run (4 iterations) must be no worse than its
    // mass run (5 iterations): it is the cheaper way to the same accuracy
    // only if it is at least as accurate.
    assert!(two <= mass, "two-level {two:.3e} against mass {mass:.3e}");
}
