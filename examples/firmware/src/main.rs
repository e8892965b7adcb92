//! corofem on a Cortex-M4F: the scene of `corofem_test_scenes::firmware` in statics (fixed
//! capacity, no heap, no allocator), poked by a haptic tool for
//! `scene::STEPS` steps of 1 ms: target position in, reaction force out.
//!
//! Runs in QEMU (`cargo run --release`, see `.cargo/config.toml`) and
//! reports through semihosting: one `corofem-firmware ...` text line on
//! stdout with the state hash and the measured costs, a defmt log in
//! `defmt.bin`, and the exit code (0 when the results are plausible).
//!
//! The release build is the panic-freedom proof: its panic handler calls a
//! function that does not exist, so the image links only if the optimiser
//! removed every panicking branch of everything it calls — the scene build,
//! the step and the hash included (see docs/firmware.md).
#![no_std]
#![no_main]

mod host;
mod logger;
mod measure;

use corofem::{BoxMesh, Preconditioner, StaticScene, Vec3};
use corofem_test_scenes::firmware as scene;
use cortex_m_rt::entry;
use cortex_m_semihosting::debug::{self, EXIT_FAILURE, EXIT_SUCCESS};

use crate::host::Line;
use crate::measure::Counter;

// `pub const CELLS: [u32; 3]` from `COROFEM_FW_CELLS` (default 10,2,2).
include!(concat!(env!("OUT_DIR"), "/cells.rs"));

const MESH: BoxMesh = scene::mesh(CELLS);
/// Node capacity: exactly the mesh.
const N: usize = MESH.node_count();
/// Element capacity: exactly the mesh.
const T: usize = MESH.tet_count();

/// Steps timed with 1 CG iteration after the run, to split the cost of a
/// step into its element/node passes and its CG iterations.
const SPLIT_STEPS: u32 = 20;

/// The preconditioner the haptic loop runs with: the lumped mass, or with
/// the feature `two-level` the two-level preconditioner, whose node-block
/// and aggregate slots the storage then holds.
#[cfg(not(feature = "two-level"))]
const PRECONDITIONER: Preconditioner = Preconditioner::Mass;
#[cfg(feature = "two-level")]
const PRECONDITIONER: Preconditioner = Preconditioner::TwoLevel;
/// Aggregate slots: what the two-level preconditioner uses for this beam.
#[cfg(not(feature = "two-level"))]
const AGGREGATES: usize = 0;
#[cfg(feature = "two-level")]
const AGGREGATES: usize = scene::aggregates(CELLS);

corofem::capacity! {
    /// The scene's capacity: exactly the mesh, the face the tool holds, and
    /// the slots of the preconditioner the haptic loop runs with.
    struct Fw {
        nodes: N,
        elements: T,
        grabs: scene::grabbed_nodes(CELLS),
        preconditioner: PRECONDITIONER,
        aggregates: AGGREGATES,
    }
}

/// The scene, with exactly the mesh's capacity.
type FwScene = StaticScene<Fw>;

#[entry]
fn main() -> ! {
    // The scene in a static, which cortex-m-rt hands over as `&'static mut`.
    // An empty scene is all zero bits, so it goes to .bss and costs no
    // flash (.ci/firmware.sh checks that .data stays small).
    static mut SCENE: FwScene = FwScene::new();
    let ok = run(SCENE);
    debug::exit(if ok { EXIT_SUCCESS } else { EXIT_FAILURE });
    #[allow(clippy::empty_loop)]
    loop {}
}

/// What the firmware measured.
#[derive(Default)]
struct Costs {
    /// SysTick ticks of all the haptic steps.
    step_ticks: u64,
    /// Ticks of the build (mesh generation, scene build, constraints).
    setup_ticks: u64,
    /// Ticks of `SPLIT_STEPS` steps with 1 CG iteration.
    split_ticks: u64,
    /// Stack bytes of one `step_haptic` call.
    step_stack: usize,
    /// Most stack bytes used at any time.
    peak_stack: usize,
}

fn run(scene: &mut FwScene) -> bool {
    measure::paint();
    #[cfg(feature = "panic-negative-control")]
    defmt::info!("negative control: {=u32}", negative_control());
    let Some(cp) = cortex_m::Peripherals::take() else {
        return false;
    };
    let counter = Counter::new(cp.SYST);
    let cal = counter.calibrate();
    let mut costs = Costs::default();

    let t = counter.now();
    let start = match setup(scene) {
        Ok(start) => start,
        Err(e) => {
            defmt::error!("scene build failed: {}", e);
            Line::new().str("corofem-firmware error=build").print();
            return false;
        }
    };
    // The obstacles of the scene in contact (features ground, probe,
    // friction): the ground, its friction, the probe.
    #[cfg(feature = "ground")]
    let mut contacts = match scene::Contacts::setup(scene, CELLS, scene::ContactSet::COMPILED) {
        Ok(c) => c,
        Err(e) => {
            defmt::error!("obstacles failed: {}", e);
            Line::new().str("corofem-firmware error=contacts").print();
            return false;
        }
    };
    costs.setup_ticks = u64::from(counter.since(t));
    defmt::info!(
        "corofem: {=u32}x{=u32}x{=u32} cells, {=usize} nodes, {=usize} tetrahedra, {} ",
        CELLS[0],
        CELLS[1],
        CELLS[2],
        scene.node_count(),
        scene.element_count(),
        scene.settings()
    );

    // The haptic loop, each step timed. The first step also measures its
    // stack: everything below this frame is painted just before it.
    let mut k = 0u32;
    let outcome = scene::run(scene, start, |scene, target| {
        k += 1;
        if k == 1 {
            costs.peak_stack = measure::stack_top() - measure::lowest_touched();
            measure::paint();
        }
        let sp = measure::sp();
        let t = counter.now();
        #[cfg(feature = "ground")]
        let stats = contacts.step(scene, target);
        #[cfg(not(feature = "ground"))]
        let stats = scene.step_haptic(target);
        costs.step_ticks += u64::from(counter.since(t));
        if k == 1 {
            costs.step_stack = sp - measure::lowest_touched();
        }
        if k % 100 == 0 {
            if let Ok(s) = &stats {
                defmt::info!("step {=u32}: {}", k, s);
            }
        }
        stats
    });
    let outcome = match outcome {
        Ok(o) => o,
        Err(e) => {
            defmt::error!("step {=u32} failed: {}", k, e);
            Line::new().str("corofem-firmware error=step").print();
            return false;
        }
    };
    #[cfg(feature = "ground")]
    let verdict = scene::check_contacts(&outcome, &contacts, PRECONDITIONER);
    #[cfg(not(feature = "ground"))]
    let verdict = scene::check_with(&outcome, PRECONDITIONER);
    // What the obstacles did: their set, the probe's most contacts and
    // largest force (N).
    #[cfg(feature = "ground")]
    let touch = Touch {
        set: contacts.set().name(),
        probe_contacts: contacts.probe_max_contacts,
        probe_force: contacts.probe_peak_force,
    };
    #[cfg(not(feature = "ground"))]
    let touch = Touch;

    // The split: the same scene, a few more steps with 1 CG iteration.
    let mut settings = *scene.settings();
    settings.cg_iterations = 1;
    let split_ok = scene.set_settings(settings).is_ok();
    for _ in 0..SPLIT_STEPS {
        let t = counter.now();
        // With a probe: held where the run left it (clear of the body).
        #[cfg(feature = "ground")]
        let r = contacts.step_at(scene, scene::STEPS, start);
        #[cfg(not(feature = "ground"))]
        let r = scene.step_haptic(start);
        costs.split_ticks += u64::from(counter.since(t));
        if r.is_err() {
            costs.split_ticks = 0;
        }
    }
    costs.peak_stack = costs
        .peak_stack
        .max(measure::stack_top() - measure::lowest_touched());

    #[cfg(feature = "nalgebra")]
    let twins_ok = nalgebra_twins();
    #[cfg(not(feature = "nalgebra"))]
    let twins_ok = true;

    report(&outcome, &costs, &cal, &touch, verdict, split_ok);
    verdict.is_ok() && split_ok && twins_ok
}

/// The core's nalgebra twins of the probe and the coupling (feature
/// `nalgebra`), on inputs the optimiser cannot see, so that the proof
/// covers them: a capsule placed and moved by a pose turned 90° about x,
/// the pose read back, one step of a coupling driving it. True when the
/// axis is −y and the pose reads back as that turn, to 1e-6 (a few ulps of
/// 1), and the force is finite.
#[cfg(feature = "nalgebra")]
#[inline(never)]
fn nalgebra_twins() -> bool {
    use core::hint::black_box;
    use nalgebra::{Isometry3, Point3, Quaternion, Translation3, UnitQuaternion, Vector3};
    let half = black_box(core::f32::consts::FRAC_1_SQRT_2);
    let pose = Isometry3 {
        rotation: UnitQuaternion::new_unchecked(Quaternion::new(half, half, 0.0, 0.0)),
        translation: Translation3::new(0.0, 0.0, black_box(0.08)),
    };
    let Ok(mut probe) = corofem::Probe::capsule(0.005, 0.02, [0.0; 3], [0.0, 0.0, 1.0]) else {
        return false;
    };
    let Ok(mut coupling) = corofem::Coupling::new(1000.0, 2.0, 0.01) else {
        return false;
    };
    if probe.place_isometry(&pose).is_err() || probe.move_to_isometry(&pose).is_err() {
        return false;
    }
    let back = probe.pose_isometry();
    let device = Point3::new(0.0, 0.0, black_box(0.079));
    let Ok(force) = coupling.drive_point(&mut probe, device, Vector3::zeros(), 1e-3) else {
        return false;
    };
    let axis = probe.axis_vector();
    defmt::info!(
        "nalgebra twins: axis {=f32} {=f32} {=f32}, force {=f32} N",
        axis.x,
        axis.y,
        axis.z,
        coupling.device_force_vector().z
    );
    (axis.y + 1.0).abs() < 1e-6
        && (back.rotation.coords - pose.rotation.coords).amax() < 1e-6
        && force.z.is_finite()
        && probe.force_vector().z.is_finite()
}

/// Generates the mesh into scratch on the stack (freed on return) and builds
/// the scene.
#[inline(never)]
fn setup(scene: &mut FwScene) -> Result<Vec3, corofem::Error> {
    let mut nodes = [[0.0f32; 3]; N];
    let mut tets = [[0u32; 4]; T];
    // `black_box`: the optimiser may not specialise the build (and so the
    // proof) on this particular size.
    scene::setup_with(
        scene,
        core::hint::black_box(CELLS),
        &mut nodes,
        &mut tets,
        PRECONDITIONER,
    )
}

/// What the obstacles of the scene in contact did (nothing without them).
#[cfg(not(feature = "ground"))]
struct Touch;
/// What the obstacles of the scene in contact did.
#[cfg(feature = "ground")]
struct Touch {
    /// `ContactSet::name`: `none` without the feature `ground`.
    set: &'static str,
    /// Most nodes the probe held in one step.
    probe_contacts: u32,
    /// Largest upward force of the body on the probe (N).
    probe_force: f32,
}

fn report(
    o: &scene::Outcome,
    c: &Costs,
    cal: &measure::Calibration,
    #[cfg_attr(not(feature = "ground"), allow(unused_variables))] touch: &Touch,
    verdict: Result<(), &'static str>,
    split_ok: bool,
) {
    let tets = T as u64;
    let steps = u64::from(o.steps.max(1));
    let step = cal.instructions(c.step_ticks);
    let split = cal.instructions(c.split_ticks);
    // Per step with k CG iterations (ck, the run's budget) and with 1 (c1):
    // one CG iteration costs (ck − c1) / (k − 1), the rest of the step c1 −
    // that.
    let k = u64::from(scene::settings_with(PRECONDITIONER).cg_iterations);
    let ck = step.checked_div(steps).unwrap_or(0);
    let c1 = split.checked_div(u64::from(SPLIT_STEPS)).unwrap_or(0);
    let cg_iter = ck
        .saturating_sub(c1)
        .checked_div(k.saturating_sub(1))
        .unwrap_or(0);
    let rest = c1.saturating_sub(cg_iter);
    let per_tet = |v: u64| (v * 10).checked_div(tets).unwrap_or(0);

    defmt::info!(
        "hash {=u64:#018x}, peak push {=f32} N, final force {} N",
        o.hash,
        o.peak_push,
        o.final_force
    );
    defmt::info!(
        "{=u64} instructions per step, {=u64} per tetrahedron-step (x10); one CG iteration {=u64}, the rest {=u64}",
        ck,
        per_tet(ck),
        cg_iter,
        rest
    );
    defmt::info!(
        "stack: {=usize} bytes per step, {=usize} peak; {=usize} bytes of statics",
        c.step_stack,
        c.peak_stack,
        measure::static_ram()
    );
    match verdict {
        Ok(()) => defmt::info!("results plausible"),
        Err(why) => defmt::error!("results wrong: {=str}", why),
    }

    let mut l = Line::new();
    l.str("corofem-firmware cells=")
        .u64(CELLS[0].into())
        .str("x")
        .u64(CELLS[1].into())
        .str("x")
        .u64(CELLS[2].into())
        .str(" nodes=")
        .u64(N as u64)
        .str(" tets=")
        .u64(tets)
        .str(" steps=")
        .u64(o.steps.into())
        .str(" hash=")
        .hex64(o.hash);
    // The scene in contact: its obstacles and what they touched.
    #[cfg(feature = "ground")]
    l.str(" contact=")
        .str(touch.set)
        .str(" contacts=")
        .u64(o.max_contacts.into())
        .str(" contact_steps=")
        .u64(o.contact_steps.into())
        .str(" probe_contacts=")
        .u64(touch.probe_contacts.into())
        .str(" probe_force=")
        .newtons(touch.probe_force);
    l.str(" cg_iterations=")
        .u64(o.cg_iterations.into())
        .str(" sqrt=")
        .str(if cfg!(feature = "fpu-sqrt") {
            "vsqrt"
        } else {
            "libm"
        })
        .str(" product=")
        .str(if cfg!(feature = "_fpu-product-vmul") {
            "asm-vmul"
        } else if cfg!(feature = "fpu-product") {
            "asm-vmla"
        } else {
            "rust"
        })
        .str(" instr_per_tick=")
        .fixed(cal.instructions(1000), 3)
        .str(" instr_per_step=")
        .u64(ck)
        .str(" instr_per_tet_step=")
        .fixed(per_tet(ck), 1)
        .str(" cg_iter_per_tet=")
        .fixed(per_tet(cg_iter), 1)
        .str(" rest_per_tet=")
        .fixed(per_tet(rest), 1)
        .str(" setup_instr=")
        .u64(cal.instructions(c.setup_ticks))
        .str(" stack_step=")
        .u64(c.step_stack as u64)
        .str(" stack_peak=")
        .u64(c.peak_stack as u64)
        .str(" static_ram=")
        .u64(measure::static_ram() as u64)
        .str(" node_bytes=")
        .u64((size_of::<corofem::Node>() + size_of::<corofem::NodeWork>()) as u64)
        .str(" peak_push=")
        .newtons(o.peak_push)
        .str(" result=")
        .str(match (verdict, split_ok) {
            (Ok(()), true) => "ok",
            (Ok(()), false) => "split-failed",
            (Err(why), _) => why,
        });
    l.print();
}

/// The proof's negative control (feature `panic-negative-control`): one
/// bounds check on an index the optimiser cannot see through. With it the
/// release build must fail to link.
#[cfg(feature = "panic-negative-control")]
#[inline(never)]
fn negative_control() -> u32 {
    let table = [1u32, 2, 3, 4];
    table[core::hint::black_box(4usize)]
}

/// Debug builds (and `find-panics`): a panic ends the QEMU run with a
/// failure.
#[cfg(any(debug_assertions, feature = "find-panics"))]
#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    debug::exit(EXIT_FAILURE);
    #[allow(clippy::empty_loop)]
    loop {}
}

/// Release builds: the proof. `corofem_firmware_panic_is_reachable` is
/// defined nowhere, so if any panicking branch survives optimisation, the
/// link fails with "undefined symbol: corofem_firmware_panic_is_reachable".
#[cfg(not(any(debug_assertions, feature = "find-panics")))]
#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    extern "Rust" {
        fn corofem_firmware_panic_is_reachable() -> !;
    }
    // SAFETY: never runs: the image only links if this call is unreachable.
    unsafe { corofem_firmware_panic_is_reachable() }
}
