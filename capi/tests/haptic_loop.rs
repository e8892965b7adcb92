//! The scenes of `examples/haptic_loop.c`, run three ways: through the Rust
//! API, through the C functions called from Rust, and (when
//! `COROFEM_C_EXAMPLE` names the compiled C program, as `.ci/capi.sh` does)
//! by the C program itself. All three must give the same state hash.

use std::path::PathBuf;
use std::process::Command;

use corofem_capi::{Material, Settings, Stats, Status};
use corofem_core::{BoxMesh, BuildOptions};

mod common;

/// One scene of the C example, exactly as it builds it.
struct Def {
    nodes: Vec<[f32; 3]>,
    tets: Vec<[u32; 4]>,
    material: corofem_core::Material,
    settings: corofem_core::Settings,
    fixed: Vec<u32>,
    tip: Vec<u32>,
    stiffness: f32,
    pull: [f32; 3],
}

fn base_settings() -> corofem_core::Settings {
    // As the C example: QR and the paper's CG, 10 iterations, cold.
    corofem_core::Settings {
        method: corofem_core::Method::Qr,
        dt: 0.001,
        cg_iterations: 10,
        warm_start: false,
        preconditioner: corofem_core::Preconditioner::Mass,
        ..corofem_core::Settings::default()
    }
}

fn box_def() -> Def {
    let mesh = BoxMesh {
        size: [0.1, 0.02, 0.02],
        cells: [10, 2, 2],
        tets_per_cell: 6,
    };
    let mut nodes = vec![[0.0; 3]; mesh.node_count()];
    let mut tets = vec![[0; 4]; mesh.tet_count()];
    mesh.generate(&mut nodes, &mut tets).unwrap();
    Def {
        nodes,
        tets,
        material: corofem_core::Material {
            young: 1.0e5,
            poisson: 0.4,
            density: 1000.0,
        },
        settings: corofem_core::Settings {
            rayleigh_mass: 5.0,
            ..base_settings()
        },
        fixed: (0..9).map(|jk| 11 * jk).collect(),
        tip: (0..9).map(|jk| 11 * jk + 10).collect(),
        stiffness: 500.0,
        pull: [0.0, 0.0, -0.02],
    }
}

fn liver_path() -> Option<PathBuf> {
    common::shared_mesh("sofa_liver.tetmesh")
}

fn liver_def(path: &std::path::Path) -> Def {
    let mesh = corofem_io::read_mesh(path).unwrap();
    let (nodes, tets) = corofem_io::to_core(&mesh, 0.03);
    Def {
        nodes,
        tets,
        material: corofem_core::Material {
            young: 5.0e3,
            poisson: 0.45,
            density: 1000.0,
        },
        settings: corofem_core::Settings {
            rayleigh_mass: 1.0,
            rayleigh_stiffness: 0.01,
            gravity: [0.0, -9.81, 0.0],
            ..base_settings()
        },
        fixed: vec![3, 39, 64],
        tip: vec![80, 81, 78, 83, 82],
        stiffness: 2000.0,
        pull: [0.03, 0.02, 0.0],
    }
}

/// The tool path of the C example: a triangle wave 0 → 1 → 0 each second.
fn triangle(step: u32) -> f32 {
    let a = (step % 1000) as f32 / 1000.0;
    if a < 0.5 {
        2.0 * a
    } else {
        2.0 - 2.0 * a
    }
}

fn target(start: [f32; 3], pull: [f32; 3], step: u32) -> [f32; 3] {
    let a = triangle(step + 1);
    [
        start[0] + a * pull[0],
        start[1] + a * pull[1],
        start[2] + a * pull[2],
    ]
}

/// Through the Rust API: (hash, tool force).
fn run_rust(d: &Def, steps: u32) -> (u64, [f32; 3]) {
    let mut s = corofem_core::VecScene::with_capacity(d.nodes.len(), d.tets.len());
    s.build(&d.nodes, &d.tets, &d.material, BuildOptions::default())
        .unwrap();
    s.set_settings(d.settings).unwrap();
    s.fix_nodes(&d.fixed).unwrap();
    s.grab(&d.tip, d.stiffness).unwrap();
    let start = s.tool_target();
    let mut force = [0.0; 3];
    for i in 0..steps {
        // The liver's thinnest elements may invert under the pull; the QR
        // method pushes them back, so inversions are not an error here.
        let st = s.step_haptic(target(start, d.pull, i)).unwrap();
        force = st.tool_force;
    }
    (s.state_hash(), force)
}

/// Through the C functions, in a heap buffer at an odd address: (hash, tool force).
fn run_capi(d: &Def, steps: u32) -> (u64, [f32; 3]) {
    let (n, t) = (d.nodes.len(), d.tets.len());
    let mut bytes = 0usize;
    // SAFETY (whole function): every pointer is a live local or a slice of
    // the stated length; the buffer outlives the handle.
    unsafe {
        assert_eq!(
            corofem_capi::corofem_scene_bytes(n, t, &mut bytes),
            Status::Ok
        );
        let mut buf = vec![0u8; bytes + 1];
        let mut h = std::ptr::null_mut();
        let ok =
            corofem_capi::corofem_scene_init(buf.as_mut_ptr().add(1).cast(), bytes, n, t, &mut h);
        assert_eq!(ok, Status::Ok);
        let mat = Material {
            young: d.material.young,
            poisson: d.material.poisson,
            density: d.material.density,
        };
        let st = corofem_capi::corofem_build(
            h,
            d.nodes.as_ptr().cast(),
            n,
            d.tets.as_ptr().cast(),
            t,
            &mat,
            0,
            std::ptr::null_mut(),
        );
        assert_eq!(st, Status::Ok);
        let mut set = std::mem::zeroed::<Settings>();
        assert_eq!(corofem_capi::corofem_settings_default(&mut set), Status::Ok);
        set.dt = d.settings.dt;
        set.cg_iterations = d.settings.cg_iterations;
        set.rayleigh_mass = d.settings.rayleigh_mass;
        set.rayleigh_stiffness = d.settings.rayleigh_stiffness;
        set.gravity = d.settings.gravity;
        set.warm_start = u32::from(d.settings.warm_start);
        // The C codes are the core's discriminants.
        set.method = d.settings.method as u32;
        set.preconditioner = d.settings.preconditioner as u32;
        assert_eq!(corofem_capi::corofem_set_settings(h, &set), Status::Ok);
        let mut back = std::mem::zeroed::<Settings>();
        assert_eq!(corofem_capi::corofem_get_settings(h, &mut back), Status::Ok);
        assert_eq!(back, set);
        let f = &d.fixed;
        assert_eq!(
            corofem_capi::corofem_fix_nodes(h, f.as_ptr(), f.len()),
            Status::Ok
        );
        let g = &d.tip;
        assert_eq!(
            corofem_capi::corofem_grab(h, g.as_ptr(), g.len(), d.stiffness),
            Status::Ok
        );
        let mut start = [0.0f32; 3];
        assert_eq!(
            corofem_capi::corofem_tool_target(h, start.as_mut_ptr()),
            Status::Ok
        );
        let mut force = [0.0f32; 3];
        let mut stats = Stats::default();
        for i in 0..steps {
            let tg = target(start, d.pull, i);
            let st =
                corofem_capi::corofem_step_haptic(h, tg.as_ptr(), force.as_mut_ptr(), &mut stats);
            assert_eq!(st, Status::Ok);
        }
        assert_eq!(stats.steps, u64::from(steps));
        assert_eq!(stats.tool_force, force);
        let mut hash = 0u64;
        assert_eq!(corofem_capi::corofem_state_hash(h, &mut hash), Status::Ok);
        assert_eq!(corofem_capi::corofem_scene_deinit(h), Status::Ok);
        (hash, force)
    }
}

/// Runs the compiled C example, if `COROFEM_C_EXAMPLE` names it: its hash.
fn run_c(args: &[&str]) -> Option<u64> {
    let exe = std::env::var_os("COROFEM_C_EXAMPLE")?;
    let out = Command::new(&exe)
        .args(args)
        .output()
        .expect("C example runs");
    let text = String::from_utf8_lossy(&out.stdout);
    eprintln!("{text}");
    assert!(out.status.success(), "C example failed: {text}");
    let line = text.lines().find_map(|l| l.strip_prefix("hash "))?;
    Some(u64::from_str_radix(line.trim(), 16).expect("hex hash"))
}

const STEPS: u32 = 2000;

/// `--help` and `-h` print the usage (they used to be read as a mesh file
/// named `--help`); an unknown option is a usage error.
#[test]
fn c_example_help_prints_usage() {
    let Some(exe) = std::env::var_os("COROFEM_C_EXAMPLE") else {
        return;
    };
    for flag in ["--help", "-h"] {
        let out = Command::new(&exe)
            .arg(flag)
            .output()
            .expect("C example runs");
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(out.status.success(), "{flag}: {text}");
        assert!(text.starts_with("usage: haptic_loop "), "{flag}: {text}");
    }
    let out = Command::new(&exe)
        .arg("--bogus")
        .output()
        .expect("C example runs");
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stdout).contains("unknown option --bogus"));
}

#[test]
fn box_scene_same_hash_from_rust_and_c() {
    let d = box_def();
    let (rust, force) = run_rust(&d, STEPS);
    let (capi, cforce) = run_capi(&d, STEPS);
    println!("box: rust hash {rust:016x}, tool force {force:?} N");
    assert_eq!(rust, capi);
    assert_eq!(force, cforce);
    // The beam pulls the tool back up (towards +z) and the force is finite.
    assert!(force.iter().all(|f| f.is_finite()));
    if let Some(c) = run_c(&["box", &STEPS.to_string()]) {
        assert_eq!(c, rust, "C program hash {c:016x} vs Rust {rust:016x}");
    }
}

#[test]
fn liver_scene_same_hash_from_rust_and_c() {
    let Some(path) = liver_path() else { return };
    let d = liver_def(&path);
    let (rust, force) = run_rust(&d, STEPS);
    let (capi, cforce) = run_capi(&d, STEPS);
    println!("liver: rust hash {rust:016x}, tool force {force:?} N");
    assert_eq!(rust, capi);
    assert_eq!(force, cforce);
    assert!(force.iter().all(|f| f.is_finite()));
    let p = path.to_string_lossy().into_owned();
    if let Some(c) = run_c(&[&p, &STEPS.to_string()]) {
        assert_eq!(c, rust, "C program hash {c:016x} vs Rust {rust:016x}");
    }
}

/// The two-level preconditioner (3 iterations, warm start) through the C
/// API: the scene buffer holds its slots, and the bits are the Rust API's.
#[test]
fn liver_with_two_level_same_hash_from_rust_and_c() {
    let Some(path) = liver_path() else { return };
    let mut d = liver_def(&path);
    d.settings.preconditioner = corofem_core::Preconditioner::TwoLevel;
    d.settings.cg_iterations = 3;
    d.settings.warm_start = true;
    let (rust, force) = run_rust(&d, STEPS);
    let (capi, cforce) = run_capi(&d, STEPS);
    println!("liver, two-level: rust hash {rust:016x}, tool force {force:?} N");
    assert_eq!(rust, capi);
    assert_eq!(force, cforce);
    // Not the mass preconditioner's run: the setting reached the solver.
    let mass = run_rust(&liver_def(&path), STEPS).0;
    assert_ne!(rust, mass);
}
